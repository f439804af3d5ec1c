//! Coarse patch values → fine vertex values, within one surface only (docs/METHOD.md §5 "Two
//! resolutions"): indirect light is solved on coarse patches and shown on fine vertices.
//!
//! Two linear stages, both precomputed once as weights:
//! 1. **Coarse vertex values** from the coarse patches of the same surface around it: a
//!    weighted least-squares plane (weights = patch areas) through the patch centroids, in the
//!    vertex's tangent plane, evaluated at the vertex. Uses the patches sharing the vertex, or
//!    their neighbours too when those centroids are collinear (surface edges and corners);
//!    falls back to the area-weighted average when even that is degenerate. It reproduces any
//!    field that is linear in position on a planar surface exactly, also at surface edges.
//! 2. **Fine vertex values**: bilinear (quad) or barycentric (triangle) interpolation of the
//!    coarse vertex values inside the coarse patch of the same surface that contains the fine
//!    vertex (the nearest coarse patch of that surface when none contains it).
//!
//! Coarse vertices are never shared across surfaces (see [`crate::scene::Surface`]) and every
//! step stays within the fine vertex's surface, so values never leak across a wall/floor edge.

use std::collections::HashMap;

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use crate::scene::{Patch, PatchMesh};

/// Tolerance on local patch coordinates for "the patch contains the point".
const INSIDE_TOLERANCE: f64 = 1e-9;

/// Smallest `det(M)/(Σ A)³` of the least-squares normal matrix (in patch-size units) accepted as
/// a well-posed plane fit.
const MIN_FIT_DETERMINANT: f64 = 1e-8;

/// Precomputed interpolation from coarse patch values to fine vertex values: per coarse vertex a
/// short list of (coarse patch, weight), per fine vertex at most 4 (coarse vertex, weight).
/// Applying it costs O(coarse vertices + fine vertices) per column.
#[derive(Debug, Clone, PartialEq)]
pub struct InterpolationWeights {
    n_coarse_patches: usize,
    /// Coarse vertex `v` uses `nodal_terms[nodal_offsets[v]..nodal_offsets[v + 1]]`.
    nodal_offsets: Vec<usize>,
    nodal_terms: Vec<(u32, f64)>,
    /// Per fine vertex: up to 4 (coarse vertex, weight); `fine_len[v]` of them are used.
    fine_terms: Vec<[(u32, f64); 4]>,
    fine_len: Vec<u8>,
}

impl InterpolationWeights {
    /// Precomputes the weights. Fine vertices on a surface without coarse patches get no terms
    /// (value 0).
    pub fn new(coarse: &PatchMesh, fine: &PatchMesh) -> Self {
        let (nodal_offsets, nodal_terms) = nodal_weights(coarse);
        let locator = PatchLocator::new(coarse);
        let mut fine_terms = Vec::with_capacity(fine.n_vertices());
        let mut fine_len = Vec::with_capacity(fine.n_vertices());
        for (v, &position) in fine.positions.iter().enumerate() {
            let surface = fine.vertex_surface.get(v).copied().unwrap_or(u32::MAX);
            let mut terms = [(0u32, 0.0); 4];
            let mut len = 0u8;
            if let Some((patch, weights)) = locator.locate(coarse, surface, position) {
                for (&vertex, &w) in coarse.patches[patch].vertex_ids().iter().zip(&weights) {
                    terms[usize::from(len)] = (vertex, w);
                    len += 1;
                }
            }
            fine_terms.push(terms);
            fine_len.push(len);
        }
        InterpolationWeights {
            n_coarse_patches: coarse.patches.len(),
            nodal_offsets,
            nodal_terms,
            fine_terms,
            fine_len,
        }
    }

    /// Bytes held by the weights.
    pub fn bytes(&self) -> usize {
        self.nodal_offsets.len() * std::mem::size_of::<usize>()
            + self.nodal_terms.len() * std::mem::size_of::<(u32, f64)>()
            + self.fine_terms.len() * std::mem::size_of::<[(u32, f64); 4]>()
            + self.fine_len.len()
    }

    /// Number of fine vertices.
    pub fn n_fine_vertices(&self) -> usize {
        self.fine_terms.len()
    }

    /// The (coarse vertex, weight) terms of fine vertex `v` (at most 4, weights sum to 1).
    pub fn fine_vertex_terms(&self, v: usize) -> &[(u32, f64)] {
        &self.fine_terms[v][..usize::from(self.fine_len[v])]
    }

    /// One value per coarse patch → one value per fine vertex.
    ///
    /// Panics when `patch_values.len()` is not the coarse patch count (a caller bug).
    pub fn apply(&self, patch_values: &[f64]) -> Vec<f64> {
        self.apply_columns(patch_values, 1)
    }

    /// `K` columns at once: `patch_values` patch-major (`K` values per coarse patch), result
    /// vertex-major (`K` values per fine vertex).
    ///
    /// Panics when `patch_values.len()` is not `coarse patches × n_columns` (a caller bug).
    pub fn apply_columns(&self, patch_values: &[f64], n_columns: usize) -> Vec<f64> {
        assert_eq!(
            patch_values.len(),
            self.n_coarse_patches * n_columns,
            "one value per coarse patch and column"
        );
        let k = n_columns;
        let n_nodes = self.nodal_offsets.len().saturating_sub(1);
        let mut nodal = vec![0.0; n_nodes * k];
        // Each vertex is independent: parallel in chunks large enough that a 10k-vertex room
        // stays on the calling thread (no pool wake-up on every edit).
        nodal
            .par_chunks_mut(k.max(1))
            .with_min_len(VERTICES_PER_TASK)
            .enumerate()
            .for_each(|(v, out)| {
                for &(patch, w) in &self.nodal_terms[self.nodal_offsets[v]..self.nodal_offsets[v + 1]] {
                    let values = &patch_values[patch as usize * k..(patch as usize + 1) * k];
                    for (o, &x) in out.iter_mut().zip(values) {
                        *o += w * x;
                    }
                }
            });
        let mut fine = vec![0.0; self.fine_terms.len() * k];
        fine.par_chunks_mut(k.max(1))
            .with_min_len(VERTICES_PER_TASK)
            .enumerate()
            .for_each(|(v, out)| {
                for &(node, w) in self.fine_vertex_terms(v) {
                    for (o, &x) in out
                        .iter_mut()
                        .zip(&nodal[node as usize * k..(node as usize + 1) * k])
                    {
                        *o += w * x;
                    }
                }
            });
        fine
    }
}

/// Vertices per rayon task when interpolating.
const VERTICES_PER_TASK: usize = 16_384;

/// Coarse patch values → fine vertex values (one column); see the module docs.
pub fn interpolate(coarse: &PatchMesh, fine: &PatchMesh, values: &[f64]) -> Vec<f64> {
    InterpolationWeights::new(coarse, fine).apply(values)
}

/// Per coarse vertex, the least-squares weights of the surrounding patch values (CSR layout).
fn nodal_weights(mesh: &PatchMesh) -> (Vec<usize>, Vec<(u32, f64)>) {
    let mut vertex_patches: Vec<Vec<u32>> = vec![Vec::new(); mesh.n_vertices()];
    for (p, patch) in mesh.patches.iter().enumerate() {
        for &v in patch.vertex_ids() {
            vertex_patches[v as usize].push(p as u32);
        }
    }
    let mut offsets = Vec::with_capacity(mesh.n_vertices() + 1);
    let mut terms = Vec::new();
    offsets.push(0);
    for v in 0..mesh.n_vertices() {
        let surface = mesh.vertex_surface.get(v).copied().unwrap_or(u32::MAX);
        let same_surface = |p: &u32| mesh.patches[*p as usize].surface == surface;
        let ring: Vec<u32> = vertex_patches[v].iter().copied().filter(same_surface).collect();
        let fitted = plane_fit_weights(mesh, v, &ring).or_else(|| {
            let mut wider: Vec<u32> = ring
                .iter()
                .flat_map(|&p| mesh.patches[p as usize].vertex_ids())
                .flat_map(|&u| vertex_patches[u as usize].iter().copied())
                .filter(same_surface)
                .collect();
            wider.sort_unstable();
            wider.dedup();
            plane_fit_weights(mesh, v, &wider)
        });
        terms.extend(fitted.unwrap_or_else(|| area_average_weights(mesh, &ring)));
        offsets.push(terms.len());
    }
    (offsets, terms)
}

/// Weights `w_p` with `Σ w_p f_p` = the area-weighted least-squares plane through the centroid
/// values, evaluated at vertex `v`; `None` when the centroids do not determine a plane.
fn plane_fit_weights(mesh: &PatchMesh, v: usize, patches: &[u32]) -> Option<Vec<(u32, f64)>> {
    if patches.len() < 3 {
        return None;
    }
    let origin = mesh.positions[v];
    let normal = mesh.normals.get(v).copied().unwrap_or(DVec3::Z).try_normalize()?;
    let (t1, t2) = normal.any_orthonormal_pair();
    let total_area: f64 = patches.iter().map(|&p| mesh.patches[p as usize].area).sum();
    let scale = (total_area / patches.len() as f64).sqrt();
    if scale.is_nan() || scale <= 0.0 {
        return None;
    }
    let rows: Vec<(f64, [f64; 3])> = patches
        .iter()
        .map(|&p| {
            let patch = &mesh.patches[p as usize];
            let d = (patch.centroid - origin) / scale;
            (patch.area, [1.0, d.dot(t1), d.dot(t2)])
        })
        .collect();
    let mut m = [[0.0; 3]; 3];
    for (a, row) in &rows {
        for r in 0..3 {
            for c in 0..3 {
                m[r][c] += a * row[r] * row[c];
            }
        }
    }
    let z = solve3_first_column(m, total_area)?;
    Some(
        patches
            .iter()
            .zip(&rows)
            .map(|(&p, (a, row))| (p, a * (row[0] * z[0] + row[1] * z[1] + row[2] * z[2])))
            .collect(),
    )
}

/// `M⁻¹ e₁` for a symmetric 3×3 `M` (Cramer's rule); `None` when `det M / scale³` is tiny.
fn solve3_first_column(m: [[f64; 3]; 3], scale: f64) -> Option<[f64; 3]> {
    let cof = |r0: usize, r1: usize, c0: usize, c1: usize| m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0];
    let c00 = cof(1, 2, 1, 2);
    let c01 = -cof(1, 2, 0, 2);
    let c02 = cof(1, 2, 0, 1);
    let det = m[0][0] * c00 + m[0][1] * c01 + m[0][2] * c02;
    if det.is_nan() || det.abs() <= MIN_FIT_DETERMINANT * scale.powi(3) {
        return None;
    }
    // First column of the inverse = first row of the cofactors / det (M symmetric).
    Some([c00 / det, c01 / det, c02 / det])
}

fn area_average_weights(mesh: &PatchMesh, patches: &[u32]) -> Vec<(u32, f64)> {
    let total: f64 = patches.iter().map(|&p| mesh.patches[p as usize].area).sum();
    if total.is_nan() || total <= 0.0 {
        return Vec::new();
    }
    patches
        .iter()
        .map(|&p| (p, mesh.patches[p as usize].area / total))
        .collect()
}

/// Finds, for a point on a surface, the coarse patch of that surface containing it and the
/// point's interpolation weights on that patch's vertices.
struct PatchLocator {
    cell_m: f64,
    /// (surface, cell) → coarse patches whose bounding box touches the cell.
    grid: HashMap<(u32, [i64; 3]), Vec<u32>>,
    /// surface → all its coarse patches (for the nearest-patch fallback).
    by_surface: HashMap<u32, Vec<u32>>,
}

impl PatchLocator {
    fn new(mesh: &PatchMesh) -> Self {
        let corners = |p: &Patch| {
            p.vertex_ids()
                .iter()
                .map(|&v| mesh.positions[v as usize])
                .collect::<Vec<_>>()
        };
        let cell_m = mesh
            .patches
            .iter()
            .map(|p| {
                let c = corners(p);
                let (lo, hi) = bounds(&c);
                (hi - lo).max_element()
            })
            .fold(0.0, f64::max)
            .max(1e-6);
        let mut grid: HashMap<(u32, [i64; 3]), Vec<u32>> = HashMap::new();
        let mut by_surface: HashMap<u32, Vec<u32>> = HashMap::new();
        for (p, patch) in mesh.patches.iter().enumerate() {
            by_surface.entry(patch.surface).or_default().push(p as u32);
            let (lo, hi) = bounds(&corners(patch));
            let margin = DVec3::splat(cell_m * 1e-6);
            let (a, b) = (cell_of(lo - margin, cell_m), cell_of(hi + margin, cell_m));
            for x in a[0]..=b[0] {
                for y in a[1]..=b[1] {
                    for z in a[2]..=b[2] {
                        grid.entry((patch.surface, [x, y, z])).or_default().push(p as u32);
                    }
                }
            }
        }
        PatchLocator {
            cell_m,
            grid,
            by_surface,
        }
    }

    /// `(patch, weights on its vertices)`; `None` when the surface has no coarse patch.
    fn locate(&self, mesh: &PatchMesh, surface: u32, point: DVec3) -> Option<(usize, [f64; 4])> {
        let nearby = self.grid.get(&(surface, cell_of(point, self.cell_m)));
        let containing = nearby.into_iter().flatten().find_map(|&p| {
            let coords = local_coordinates(mesh, &mesh.patches[p as usize], point);
            coords.inside.then_some((p as usize, coords.weights))
        });
        containing.or_else(|| {
            self.by_surface
                .get(&surface)?
                .iter()
                .map(|&p| {
                    let coords = local_coordinates(mesh, &mesh.patches[p as usize], point);
                    (coords.distance, p as usize, coords.weights)
                })
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .map(|(_, p, w)| (p, w))
        })
    }
}

fn bounds(points: &[DVec3]) -> (DVec3, DVec3) {
    points
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &q| {
            (lo.min(q), hi.max(q))
        })
}

fn cell_of(point: DVec3, cell_m: f64) -> [i64; 3] {
    let c = (point / cell_m).floor();
    [c.x as i64, c.y as i64, c.z as i64]
}

/// Where a point falls on a patch.
struct LocalCoordinates {
    /// Interpolation weights on the patch's vertices (clamped to the patch), summing to 1.
    weights: [f64; 4],
    /// True when the point's projection lies inside the patch.
    inside: bool,
    /// Distance (m) from the point to the clamped position on the patch.
    distance: f64,
}

fn local_coordinates(mesh: &PatchMesh, patch: &Patch, point: DVec3) -> LocalCoordinates {
    let c: Vec<DVec3> = patch
        .vertex_ids()
        .iter()
        .map(|&v| mesh.positions[v as usize])
        .collect();
    let (weights, inside) = if c.len() == 4 {
        let uv = inverse_bilinear(&c, point);
        let inside = uv.cmpge(DVec2::splat(-INSIDE_TOLERANCE)).all()
            && uv.cmple(DVec2::splat(1.0 + INSIDE_TOLERANCE)).all();
        let uv = uv.clamp(DVec2::ZERO, DVec2::ONE);
        let (u, v) = (uv.x, uv.y);
        (
            [(1.0 - u) * (1.0 - v), u * (1.0 - v), u * v, (1.0 - u) * v],
            inside,
        )
    } else {
        let bary = barycentric(&c, point);
        let inside = bary.iter().all(|&b| b >= -INSIDE_TOLERANCE);
        let clamped = bary.map(|b| b.max(0.0));
        let sum: f64 = clamped.iter().sum();
        let w = if sum > 0.0 {
            clamped.map(|b| b / sum)
        } else {
            [1.0 / 3.0; 3]
        };
        ([w[0], w[1], w[2], 0.0], inside)
    };
    let position: DVec3 = c.iter().zip(&weights).map(|(&q, &w)| q * w).sum();
    LocalCoordinates {
        weights,
        inside,
        distance: point.distance(position),
    }
}

/// Barycentric coordinates of the projection of `point` onto triangle `c`'s plane.
fn barycentric(c: &[DVec3], point: DVec3) -> [f64; 3] {
    let (e1, e2, d) = (c[1] - c[0], c[2] - c[0], point - c[0]);
    let (a, b, cc) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (p, q) = (d.dot(e1), d.dot(e2));
    let det = a * cc - b * b;
    if det == 0.0 {
        return [1.0 / 3.0; 3];
    }
    let s = (cc * p - b * q) / det;
    let t = (a * q - b * p) / det;
    [1.0 - s - t, s, t]
}

/// `(u, v)` with `point ≈ (1−u)(1−v)c₀ + u(1−v)c₁ + uv c₂ + (1−u)v c₃` (Gauss–Newton in the least
/// squares sense, so points slightly off the plane project onto it). Exact in one step for
/// parallelograms.
fn inverse_bilinear(c: &[DVec3], point: DVec3) -> DVec2 {
    let mut uv = DVec2::splat(0.5);
    for _ in 0..32 {
        let (u, v) = (uv.x, uv.y);
        let at =
            c[0] * ((1.0 - u) * (1.0 - v)) + c[1] * (u * (1.0 - v)) + c[2] * (u * v) + c[3] * ((1.0 - u) * v);
        let du = (c[1] - c[0]) * (1.0 - v) + (c[2] - c[3]) * v;
        let dv = (c[3] - c[0]) * (1.0 - u) + (c[2] - c[1]) * u;
        let r = point - at;
        let (a, b, cc) = (du.dot(du), du.dot(dv), dv.dot(dv));
        let det = a * cc - b * b;
        if det == 0.0 {
            break;
        }
        let (p, q) = (du.dot(r), dv.dot(r));
        let step = DVec2::new(cc * p - b * q, a * q - b * p) / det;
        uv += step;
        if step.length() < 1e-15 {
            break;
        }
    }
    uv
}
