//! Form factors: from a differential area (a point with a unit normal) to a planar polygon, and
//! the dense coarse-patch matrix `F` the interreflection solve iterates with (docs/METHOD.md §5).
//!
//! `F_ij` is the fraction of the light leaving patch `j` (Lambertian, uniform exitance) that
//! arrives at the centroid of patch `i`, per unit exitance: irradiance at `i` is `Σ_j F_ij B_j`.
//! It is evaluated from `i`'s centroid (collocation), so in a closed convex room every row sums to
//! 1 when the exact contour formula is used everywhere. All positions are world metres, z up.

use std::any::TypeId;
use std::f64::consts::PI;
use std::sync::atomic::{AtomicU64, Ordering};

use glam::{DMat3, DVec3};
use rayon::prelude::*;

use crate::scene::{Patch, PatchMesh};
use crate::transport::visibility::{Unoccluded, Visibility};

/// How far (m) a receiving point is lifted off its patch along the normal, and a ray end point
/// off its target patch, so that coplanar geometry is unambiguously behind or in front.
const SURFACE_OFFSET_M: f64 = 1e-6;

/// `|R_i × R_{i+1}|` (unit vectors) below which an edge is degenerate and contributes 0.
const DEGENERATE_EDGE: f64 = 1e-12;

/// Differential area at `p` (unit normal `n`, world frame) to a planar polygon (world metres,
/// any winding): the exact Lambert/Nusselt contour formula
/// `F = (1/2π) Σ β_i n·(R_i×R_{i+1})/|R_i×R_{i+1}|`, `β_i = atan2(|R_i×R_{i+1}|, R_i·R_{i+1})`,
/// `R_i` the unit vectors from `p` to the vertices (docs/METHOD.md §5).
///
/// The polygon is first clipped to the half-space in front of `p` (`n·(x − p) ≥ 0`); degenerate
/// edges (coincident or collinear with `p`) contribute 0. Dimensionless, in `[0, 1]`.
pub fn point_to_polygon(p: DVec3, n: DVec3, polygon: &[DVec3]) -> f64 {
    let mut clipped = Vec::with_capacity(polygon.len() + 1);
    contour_form_factor(p, n, polygon, &mut clipped)
}

/// Far-field (differential-to-differential) form factor `cosθ_p cosθ_j A_j / (π r²)` from a point
/// `p` with unit normal `n` to a small patch with centroid `centroid`, unit normal `normal` and
/// area `area` (m²). Zero when either side faces away. Its relative error against the exact
/// contour formula is O((size/r)²).
pub fn differential(p: DVec3, n: DVec3, centroid: DVec3, normal: DVec3, area: f64) -> f64 {
    let d = centroid - p;
    let r2 = d.length_squared();
    if r2 == 0.0 {
        return 0.0;
    }
    let r = r2.sqrt();
    let cos_p = n.dot(d) / r;
    let cos_j = -normal.dot(d) / r;
    if cos_p <= 0.0 || cos_j <= 0.0 {
        return 0.0;
    }
    cos_p * cos_j * area / (PI * r2)
}

/// The point-to-point kernel `cosθ_p cosθ_q / r²` (1/m², without the `1/π`) between a point `p`
/// of unit normal `n` and a point `q = p + d` of unit normal `normal`; zero when either side faces
/// away. It weighs shadow rays so that a partly visible patch counts the parts that matter most
/// ([`crate::transport::visibility::weighted_fraction`]).
pub fn kernel(n: DVec3, normal: DVec3, d: DVec3) -> f64 {
    let (u, v) = (n.dot(d), -normal.dot(d));
    if u <= 0.0 || v <= 0.0 {
        return 0.0;
    }
    let r2 = d.length_squared();
    u * v / (r2 * r2)
}

/// The gradient (1/m³, world frame) over a surface point `x` with unit normal `normal` of the
/// point-to-point kernel `K(x) = cosθ_p cosθ_x / (π r²)` from a point `p` with unit normal `n`:
/// the first-order change of [`differential`] per unit area as `x` moves. Zero when either
/// side faces away (where `K` is clipped to zero).
pub fn kernel_gradient(p: DVec3, n: DVec3, x: DVec3, normal: DVec3) -> DVec3 {
    let d = x - p;
    let r2 = d.length_squared();
    let (u, v) = (n.dot(d), -normal.dot(d));
    if r2 == 0.0 || u <= 0.0 || v <= 0.0 {
        return DVec3::ZERO;
    }
    let r4 = r2 * r2;
    (n * v - normal * u) / (PI * r4) - d * (4.0 * u * v / (PI * r4 * r2))
}

/// [`point_to_polygon`] with a caller-owned scratch buffer for the clipped polygon.
pub fn point_to_polygon_with(p: DVec3, n: DVec3, polygon: &[DVec3], scratch: &mut Vec<DVec3>) -> f64 {
    contour_form_factor(p, n, polygon, scratch)
}

/// [`point_to_polygon`] with a caller-owned scratch buffer for the clipped polygon (used only
/// when a corner lies behind `p`).
///
/// The angle `β` and the direction of `R_i × R_{i+1}` do not depend on the lengths of the two
/// vectors, so the vectors from `p` to the corners are used as they are, unnormalised: one
/// square root and one `atan2` per edge.
fn contour_form_factor(p: DVec3, n: DVec3, polygon: &[DVec3], clipped: &mut Vec<DVec3>) -> f64 {
    let polygon = front_part(p, n, polygon, clipped);
    if polygon.len() < 3 {
        return 0.0;
    }
    let degenerate2 = DEGENERATE_EDGE * DEGENERATE_EDGE;
    let mut sum = 0.0;
    for (i, &a) in polygon.iter().enumerate() {
        let (ra, rb) = (a - p, polygon[(i + 1) % polygon.len()] - p);
        let cross = ra.cross(rb);
        let sin2 = cross.length_squared();
        // |R̂_a × R̂_b| at most DEGENERATE_EDGE (or a corner at p): no contribution.
        if sin2 <= degenerate2 * ra.length_squared() * rb.length_squared() {
            continue;
        }
        let sin = sin2.sqrt();
        sum += sin.atan2(ra.dot(rb)) * n.dot(cross) / sin;
    }
    // The sign only reflects the winding as seen from p.
    (sum / (2.0 * PI)).abs()
}

/// The part of `polygon` in front of the plane `n·(x − p) = 0`: the polygon itself when no
/// corner is behind it, else its Sutherland–Hodgman clip written into `clipped`.
fn front_part<'a>(p: DVec3, n: DVec3, polygon: &'a [DVec3], clipped: &'a mut Vec<DVec3>) -> &'a [DVec3] {
    let height = |q: DVec3| n.dot(q - p);
    if polygon.iter().all(|&q| height(q) >= 0.0) {
        return polygon;
    }
    clipped.clear();
    for (i, &a) in polygon.iter().enumerate() {
        let b = polygon[(i + 1) % polygon.len()];
        let (ha, hb) = (height(a), height(b));
        if ha >= 0.0 {
            clipped.push(a);
        }
        if (ha >= 0.0) != (hb >= 0.0) {
            let t = ha / (ha - hb);
            clipped.push(a + (b - a) * t);
        }
    }
    clipped
}

/// A patch as the target of form factors: its polygon and what the far-field rule needs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TargetPatch {
    corners: [DVec3; 4],
    n_corners: usize,
    /// Centroid (world, m).
    pub centroid: DVec3,
    /// Unit normal (world), towards the side light leaves from.
    pub normal: DVec3,
    /// Area, m².
    pub area: f64,
    /// Size: the largest distance between two corners (m).
    pub size: f64,
}

impl TargetPatch {
    /// The target geometry of `patch` in `mesh`.
    pub fn new(mesh: &PatchMesh, patch: &Patch) -> Self {
        let mut corners = [DVec3::ZERO; 4];
        let ids = patch.vertex_ids();
        for (corner, &v) in corners.iter_mut().zip(ids) {
            *corner = mesh.positions[v as usize];
        }
        let used = &corners[..ids.len()];
        let size = used
            .iter()
            .flat_map(|a| used.iter().map(move |b| a.distance(*b)))
            .fold(0.0, f64::max);
        TargetPatch {
            corners,
            n_corners: ids.len(),
            centroid: patch.centroid,
            normal: patch.normal,
            area: patch.area,
            size,
        }
    }

    /// The polygon's corners (world, m).
    pub fn corners(&self) -> &[DVec3] {
        &self.corners[..self.n_corners]
    }

    /// Form factor from a point `p` with unit normal `n` to this patch with the near/far rule:
    /// the exact contour formula when the distance to the centroid is below
    /// `near_field_ratio × size`, the differential formula beyond (pass `f64::INFINITY` for exact
    /// everywhere). Zero when `p` is behind the patch (it only emits towards its normal).
    pub fn form_factor_from(&self, p: DVec3, n: DVec3, near_field_ratio: f64) -> f64 {
        let mut scratch = Vec::with_capacity(self.n_corners + 1);
        self.form_factor_with(p, n, near_field_ratio, &mut scratch)
    }

    pub(crate) fn form_factor_with(
        &self,
        p: DVec3,
        n: DVec3,
        near_field_ratio: f64,
        scratch: &mut Vec<DVec3>,
    ) -> f64 {
        if self.normal.dot(p - self.centroid) <= 0.0 {
            return 0.0;
        }
        let r = p.distance(self.centroid);
        if r < near_field_ratio * self.size {
            contour_form_factor(p, n, self.corners(), scratch)
        } else {
            differential(p, n, self.centroid, self.normal, self.area)
        }
    }

    /// The form-factor-weighted offset `∫ (x − c) dF(p → x)` over the patch (m; world frame), `c`
    /// its centroid, from a point `p` with unit normal `n`, when the patch is large for its
    /// distance to `p`: with a linear radiosity `B(x) = B_c + g · (x − c)` on the patch, the
    /// irradiance at `p` is `B_c F + g · moment`. The midpoint rule on pieces of the polygon,
    /// each split in four until it is at most [`MOMENT_ACCEPT`] times its distance to `p` (at
    /// most [`MOMENT_DEPTH`] times), with each piece's factor exact. `None` when the whole patch
    /// is already that small for its distance (the kernel's first-order change over it,
    /// [`kernel_gradient`], then gives the moment).
    pub fn near_moment(&self, p: DVec3, n: DVec3, scratch: &mut Vec<DVec3>) -> Option<DVec3> {
        if self.accepted_from(p, MOMENT_ACCEPT) {
            return None;
        }
        if self.normal.dot(p - self.centroid) <= 0.0 {
            return Some(DVec3::ZERO);
        }
        let mut moment = DVec3::ZERO;
        self.pieces_toward(p, MOMENT_ACCEPT, MOMENT_DEPTH, |piece| {
            let f = contour_form_factor(p, n, piece.corners(), scratch);
            moment += f * (piece.centroid() - self.centroid);
        });
        Some(moment)
    }

    /// True when the whole patch is at most `accept` times its distance to `p` in size.
    pub fn accepted_from(&self, p: DVec3, accept: f64) -> bool {
        self.whole().accepted(p, accept)
    }

    /// Cuts the patch into pieces, each split in four at its edge midpoints until its size is
    /// at most `accept` times the distance from `p` to its centroid (at most `depth` times),
    /// and calls `each` with every piece: fine where `p` is close, coarse where it is far.
    pub fn pieces_toward(&self, p: DVec3, accept: f64, depth: u32, mut each: impl FnMut(&PatchPiece)) {
        let mut stack = vec![(self.whole(), 0u32)];
        while let Some((piece, level)) = stack.pop() {
            if level < depth && !piece.accepted(p, accept) {
                stack.extend(piece.quarters().map(|q| (q, level + 1)));
                continue;
            }
            each(&piece);
        }
    }

    fn whole(&self) -> PatchPiece {
        PatchPiece {
            corners: self.corners,
            n: self.n_corners,
        }
    }

    /// The second moment of area `∫ (x − c)(x − c)ᵀ dA` about the centroid `c` (m⁴, world
    /// frame): of each triangle of the fan from the first corner, `A/12 Σ vᵢvᵢᵀ` over its
    /// corners `vᵢ` relative to its centroid, moved to `c` by the parallel-axis term.
    pub fn second_moment(&self) -> DMat3 {
        let c = self.corners();
        let outer = |v: DVec3| DMat3::from_cols(v * v.x, v * v.y, v * v.z);
        let mut sum = DMat3::ZERO;
        for k in 1..c.len() - 1 {
            let t = [c[0], c[k], c[k + 1]];
            let area = 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length();
            let centre = (t[0] + t[1] + t[2]) / 3.0;
            let own = t.iter().fold(DMat3::ZERO, |m, &v| m + outer(v - centre));
            sum += own * (area / 12.0) + outer(centre - self.centroid) * area;
        }
        sum
    }

    /// `samples_per_edge²` points spread evenly over the patch (cell centres of a bilinear grid
    /// on a quad, centroids of the `samples_per_edge²` similar sub-triangles of a triangle),
    /// lifted a hair along the normal; targets of visibility rays.
    pub fn sample_points(&self, samples_per_edge: usize) -> Vec<DVec3> {
        let mut points = Vec::with_capacity(samples_per_edge.max(1).pow(2));
        self.sample_points_into(samples_per_edge, &mut points);
        points
    }

    /// [`Self::sample_points`] appended to `points` (no allocation when it has room).
    pub fn sample_points_into(&self, samples_per_edge: usize, points: &mut Vec<DVec3>) {
        let s = samples_per_edge.max(1);
        let c = &self.corners;
        let lift = self.normal * SURFACE_OFFSET_M;
        if self.n_corners == 4 {
            let step = 1.0 / s as f64;
            for a in 0..s {
                let u = (a as f64 + 0.5) * step;
                for b in 0..s {
                    let v = (b as f64 + 0.5) * step;
                    let q = c[0] * ((1.0 - u) * (1.0 - v))
                        + c[1] * (u * (1.0 - v))
                        + c[2] * (u * v)
                        + c[3] * ((1.0 - u) * v);
                    points.push(q + lift);
                }
            }
        } else {
            // Sub-triangle centroids in barycentric steps of 1/s: upright (i, j) and inverted ones.
            let e1 = (c[1] - c[0]) / s as f64;
            let e2 = (c[2] - c[0]) / s as f64;
            for i in 0..s {
                for j in 0..s - i {
                    let (fi, fj) = (i as f64, j as f64);
                    points.push(c[0] + e1 * (fi + 1.0 / 3.0) + e2 * (fj + 1.0 / 3.0) + lift);
                    if i + j + 1 < s {
                        points.push(c[0] + e1 * (fi + 2.0 / 3.0) + e2 * (fj + 2.0 / 3.0) + lift);
                    }
                }
            }
        }
    }
}

/// The four triangles of `[a, b, c]` split at its edge midpoints: the three at its corners,
/// then the middle one (`[ab, bc, ca]`).
pub fn triangle_quarters([a, b, c]: [DVec3; 3]) -> [[DVec3; 3]; 4] {
    let (ab, bc, ca) = ((a + b) / 2.0, (b + c) / 2.0, (c + a) / 2.0);
    [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
}

/// Pieces of a patch in [`TargetPatch::near_moment`] are split until their size is at most
/// this fraction of their distance to the receiver, at most [`MOMENT_DEPTH`] times.
const MOMENT_ACCEPT: f64 = 0.25;
const MOMENT_DEPTH: u32 = 6;

/// A piece of a patch (world, m): the patch itself or a quarter of a piece, so a rectangle
/// (the mesher's cells) or a triangle (an OBJ face).
#[derive(Debug, Clone, Copy)]
pub struct PatchPiece {
    corners: [DVec3; 4],
    n: usize,
}

impl PatchPiece {
    /// Its three or four corners.
    pub fn corners(&self) -> &[DVec3] {
        &self.corners[..self.n]
    }

    /// Its centroid: the mean of its corners (exact on a parallelogram and a triangle).
    pub fn centroid(&self) -> DVec3 {
        self.corners().iter().sum::<DVec3>() / self.n as f64
    }

    /// The centroids of its four quarters ([`Self::quarters`]), which have equal areas.
    pub fn quarter_centres(&self) -> [DVec3; 4] {
        self.quarters().map(|q| q.centroid())
    }

    /// At most `accept` times its distance to `p` in size.
    fn accepted(&self, p: DVec3, accept: f64) -> bool {
        let c = self.corners();
        let size = c
            .iter()
            .flat_map(|a| c.iter().map(move |b| a.distance_squared(*b)))
            .fold(0.0, f64::max)
            .sqrt();
        size <= accept * p.distance(self.centroid())
    }

    /// The four pieces of a split at the edge midpoints (and the centre of a quad).
    fn quarters(&self) -> [PatchPiece; 4] {
        let c = &self.corners;
        if self.n == 4 {
            let m = [
                (c[0] + c[1]) / 2.0,
                (c[1] + c[2]) / 2.0,
                (c[2] + c[3]) / 2.0,
                (c[3] + c[0]) / 2.0,
            ];
            let o = self.centroid();
            [
                [c[0], m[0], o, m[3]],
                [m[0], c[1], m[1], o],
                [o, m[1], c[2], m[2]],
                [m[3], o, m[2], c[3]],
            ]
            .map(|corners| PatchPiece { corners, n: 4 })
        } else {
            triangle_quarters([c[0], c[1], c[2]]).map(|t| PatchPiece {
                corners: [t[0], t[1], t[2], DVec3::ZERO],
                n: 3,
            })
        }
    }
}

/// Knobs of the form-factor build.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FormFactorOptions {
    /// Exact contour formula when the centroid distance is below this many patch sizes, the
    /// differential formula beyond. Default 3 (docs/METHOD.md §5); `f64::INFINITY` = exact everywhere.
    pub near_field_ratio: f64,
    /// Visibility rays per patch pair are `visibility_samples_per_edge²` (to sample points spread
    /// over the target patch). Default 3. Ignored (no rays) when the visibility is [`Unoccluded`].
    pub visibility_samples_per_edge: usize,
}

impl Default for FormFactorOptions {
    fn default() -> Self {
        FormFactorOptions {
            near_field_ratio: 3.0,
            visibility_samples_per_edge: 3,
        }
    }
}

/// Builds form-factor rows of a patch mesh: geometry from the contour/differential rule, times
/// the visible fraction of rays from the receiving centroid to sample points on the target.
pub struct FormFactorBuilder<'a, V: ?Sized> {
    mesh: &'a PatchMesh,
    targets: Vec<TargetPatch>,
    /// `samples_per_pair` points per target patch, patch-major; empty when no rays are cast.
    samples: Vec<DVec3>,
    samples_per_pair: usize,
    visibility: &'a V,
    options: FormFactorOptions,
    rays: AtomicU64,
}

impl<'a, V: Visibility + ?Sized + 'static> FormFactorBuilder<'a, V> {
    /// Prepares the targets (and, unless `V` is [`Unoccluded`], the visibility sample points).
    /// Pass `Unoccluded` by type (not boxed as `dyn Visibility`) to skip every ray.
    pub fn new(mesh: &'a PatchMesh, visibility: &'a V, options: FormFactorOptions) -> Self {
        let targets: Vec<TargetPatch> = mesh.patches.iter().map(|p| TargetPatch::new(mesh, p)).collect();
        let casts_rays = TypeId::of::<V>() != TypeId::of::<Unoccluded>();
        let (samples, samples_per_pair) = if casts_rays {
            let per_edge = options.visibility_samples_per_edge.max(1);
            let samples: Vec<DVec3> = targets.iter().flat_map(|t| t.sample_points(per_edge)).collect();
            (samples, per_edge * per_edge)
        } else {
            (Vec::new(), 0)
        };
        FormFactorBuilder {
            mesh,
            targets,
            samples,
            samples_per_pair,
            visibility,
            options,
            rays: AtomicU64::new(0),
        }
    }

    /// Row `i` in f64: `F_ij` for every target `j` (0 for `j = i` and for patches in `i`'s plane
    /// facing the same way).
    pub fn row(&self, i: usize) -> Vec<f64> {
        let receiver = &self.mesh.patches[i];
        let p = receiver.centroid + receiver.normal * SURFACE_OFFSET_M;
        let n = receiver.normal;
        let mut scratch = Vec::with_capacity(5);
        let mut rays = 0u64;
        let row = self
            .targets
            .iter()
            .enumerate()
            .map(|(j, target)| {
                if j == i || coplanar_same_facing(receiver, target) {
                    return 0.0;
                }
                let geometric = target.form_factor_with(p, n, self.options.near_field_ratio, &mut scratch);
                if geometric == 0.0 || self.samples_per_pair == 0 {
                    return geometric;
                }
                let points = &self.samples[j * self.samples_per_pair..(j + 1) * self.samples_per_pair];
                rays += points.len() as u64;
                let visible = points.iter().filter(|&&q| self.visibility.visible(p, q)).count();
                geometric * visible as f64 / points.len() as f64
            })
            .collect();
        self.rays.fetch_add(rays, Ordering::Relaxed);
        row
    }

    /// Number of visibility rays cast so far by this builder.
    pub fn rays_cast(&self) -> u64 {
        self.rays.load(Ordering::Relaxed)
    }

    /// The dense matrix, rows built in parallel (rayon), stored as f32.
    pub fn build(&self) -> FormFactors {
        let n = self.targets.len();
        let mut values = vec![0f32; n * n];
        if n > 0 {
            values.par_chunks_mut(n).enumerate().for_each(|(i, out)| {
                for (o, f) in out.iter_mut().zip(self.row(i)) {
                    *o = f as f32;
                }
            });
        }
        FormFactors {
            n,
            values,
            rays_cast: self.rays_cast(),
        }
    }
}

/// True when `target` lies in the receiver's plane and faces the same way (it cannot be seen).
fn coplanar_same_facing(receiver: &Patch, target: &TargetPatch) -> bool {
    const PLANE_TOLERANCE_M: f64 = 1e-9;
    receiver.normal.dot(target.normal) > 1.0 - 1e-12
        && receiver.normal.dot(target.centroid - receiver.centroid).abs() < PLANE_TOLERANCE_M
}

/// Dense form factors between the `n` patches of a (coarse) mesh: f32, row-major, `F_ij` at
/// `i·n + j` (receiver `i`, source `j`). Memory `4n²` bytes.
#[derive(Debug, Clone, PartialEq)]
pub struct FormFactors {
    n: usize,
    values: Vec<f32>,
    rays_cast: u64,
}

impl FormFactors {
    /// Builds all rows of `mesh` (see [`FormFactorBuilder`]).
    pub fn build<V: Visibility + ?Sized + 'static>(
        mesh: &PatchMesh,
        visibility: &V,
        options: FormFactorOptions,
    ) -> Self {
        FormFactorBuilder::new(mesh, visibility, options).build()
    }

    /// Number of patches `n`.
    pub fn n_patches(&self) -> usize {
        self.n
    }

    /// `F_ij`.
    pub fn get(&self, i: usize, j: usize) -> f64 {
        f64::from(self.values[i * self.n + j])
    }

    /// Row `i` (the receiver), length `n`.
    pub fn row(&self, i: usize) -> &[f32] {
        &self.values[i * self.n..(i + 1) * self.n]
    }

    /// `Σ_j F_ij` per row, accumulated in f64 (1 for every row of a closed convex room).
    pub fn row_sums(&self) -> Vec<f64> {
        (0..self.n)
            .map(|i| self.row(i).iter().map(|&f| f64::from(f)).sum())
            .collect()
    }

    /// Bytes held by the matrix.
    pub fn bytes(&self) -> usize {
        self.values.len() * std::mem::size_of::<f32>()
    }

    /// Visibility rays cast while building (0 when built with [`Unoccluded`]).
    pub fn rays_cast(&self) -> u64 {
        self.rays_cast
    }

    /// Makes the collocation matrix conserve energy both ways (docs/METHOD.md §5.6: centre-to-polygon
    /// factors are not reciprocal, which shows as an energy surplus of a few % at high ρ).
    /// Alternating scalings (Sinkhorn) restore, to `1e-9`, each row's original sum (what a point
    /// receives: 1 in a closed room, which the furnace test needs) and each column's reciprocity
    /// sum `Σ_i A_i F_ij = A_j` (all power leaving patch j lands on some patch, which Sumpner's
    /// principle `Σ A H = Φ/(1−ρ)` needs). Only valid when the patches close the scene; the
    /// caller decides. Returns the largest relative column defect before balancing.
    pub fn balance(&mut self, areas: &[f64]) -> f64 {
        let n = self.n;
        let target_rows = self.row_sums();
        let column_defect = |values: &[f32]| -> Vec<f64> {
            let mut sums = vec![0.0; n];
            for i in 0..n {
                for (s, &f) in sums.iter_mut().zip(&values[i * n..(i + 1) * n]) {
                    *s += areas[i] * f64::from(f);
                }
            }
            sums.iter().zip(areas).map(|(s, a)| s / a).collect()
        };
        let initial = column_defect(&self.values)
            .iter()
            .map(|c| (c - 1.0).abs())
            .fold(0.0, f64::max);
        for _ in 0..50 {
            let cols = column_defect(&self.values);
            self.values.par_chunks_mut(n).for_each(|row| {
                for (f, c) in row.iter_mut().zip(&cols) {
                    if *c > 0.0 {
                        *f = (f64::from(*f) / c) as f32;
                    }
                }
            });
            let rows = self.row_sums();
            self.values
                .par_chunks_mut(n)
                .zip(rows.par_iter().zip(&target_rows))
                .for_each(|(row, (r, t))| {
                    if *r > 0.0 {
                        let scale = t / r;
                        row.iter_mut().for_each(|f| *f = (f64::from(*f) * scale) as f32);
                    }
                });
            let worst = column_defect(&self.values)
                .iter()
                .map(|c| (c - 1.0).abs())
                .fold(0.0, f64::max);
            if worst < 1e-10 {
                break;
            }
        }
        initial
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A one-patch mesh with `corners` (counter-clockwise seen from +z) facing +z.
    fn target(corners: &[DVec3]) -> TargetPatch {
        let n = corners.len();
        let area = (1..n - 1)
            .map(|k| {
                0.5 * (corners[k] - corners[0])
                    .cross(corners[k + 1] - corners[0])
                    .length()
            })
            .sum();
        let centroid = if n == 3 {
            corners.iter().sum::<DVec3>() / 3.0
        } else {
            corners.iter().sum::<DVec3>() / 4.0
        };
        let mut vertices = [0; 4];
        (0..n).for_each(|k| vertices[k] = k as u32);
        let mesh = PatchMesh {
            positions: corners.to_vec(),
            normals: vec![DVec3::Z; n],
            vertex_surface: vec![0; n],
            patches: vec![Patch {
                vertices,
                n_vertices: n as u8,
                surface: 0,
                normal: DVec3::Z,
                area,
                centroid,
            }],
        };
        TargetPatch::new(&mesh, &mesh.patches[0])
    }

    /// A piece's quarter centres are the centroids of its four equal quarters: of a
    /// parallelogram its 2 × 2 sub-parallelograms, of a triangle its three corner triangles and
    /// the middle one (centred on the triangle's centroid).
    #[test]
    fn quarter_centres_of_a_parallelogram_and_a_triangle() {
        let a = DVec3::new(0.0, 0.0, 1.0);
        let (u, v) = (DVec3::new(0.4, 0.0, 0.0), DVec3::new(0.1, 0.2, 0.0));
        let quad = PatchPiece {
            corners: [a, a + u, a + u + v, a + v],
            n: 4,
        };
        let want = [(0.25, 0.25), (0.75, 0.25), (0.75, 0.75), (0.25, 0.75)].map(|(s, t)| a + s * u + t * v);
        for (g, w) in quad.quarter_centres().iter().zip(&want) {
            assert!(g.distance(*w) < 1e-15, "{g} vs {w}");
        }
        let (b, c) = (a + u, a + v);
        let triangle = PatchPiece {
            corners: [a, b, c, DVec3::ZERO],
            n: 3,
        };
        let corner_quarter = |p: DVec3, q: DVec3, r: DVec3| (p + 0.5 * (p + q) + 0.5 * (p + r)) / 3.0;
        let want = [
            corner_quarter(a, b, c),
            corner_quarter(b, c, a),
            corner_quarter(c, a, b),
            (a + b + c) / 3.0,
        ];
        for (g, w) in triangle.quarter_centres().iter().zip(&want) {
            assert!(g.distance(*w) < 1e-15, "{g} vs {w}");
        }
    }

    /// The sample points of a quad are the centres of the cells of its bilinear grid, lifted
    /// along the normal: on a trapezoid (not a parallelogram, so the map is not affine) with
    /// 3 × 3 samples, `c0 (1−u)(1−v) + c1 u(1−v) + c2 uv + c3 (1−u)v` at u, v ∈ {1/6, 1/2, 5/6}.
    #[test]
    fn sample_points_of_a_quad_are_its_bilinear_cell_centres() {
        let c = [
            DVec3::new(0.0, 0.0, 2.0),
            DVec3::new(0.6, 0.0, 2.0),
            DVec3::new(0.5, 0.3, 2.0),
            DVec3::new(0.2, 0.3, 2.0),
        ];
        let points = target(&c).sample_points(3);
        let mut want = Vec::new();
        for u in [1.0 / 6.0, 0.5, 5.0 / 6.0] {
            for v in [1.0 / 6.0, 0.5, 5.0 / 6.0] {
                let q = c[0] * ((1.0 - u) * (1.0 - v))
                    + c[1] * (u * (1.0 - v))
                    + c[2] * (u * v)
                    + c[3] * ((1.0 - u) * v);
                want.push(q + DVec3::Z * SURFACE_OFFSET_M);
            }
        }
        assert_eq!(points.len(), want.len());
        for (g, w) in points.iter().zip(&want) {
            assert!(g.distance(*w) < 1e-12, "{g} vs {w}");
        }
    }

    /// A 2 × 1 m rectangle: `A a²/12`, `A b²/12`; the right triangle with legs 1: variance 1/18
    /// and covariance −1/36 of a uniform point, times its area ½.
    #[test]
    fn second_moments_of_a_rectangle_and_a_triangle() {
        let rect = target(&[
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(2.0, 1.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
        ]);
        let j = rect.second_moment();
        let want = DMat3::from_diagonal(DVec3::new(2.0 * 4.0 / 12.0, 2.0 / 12.0, 0.0));
        assert!(j.abs_diff_eq(want, 1e-12), "{j}");
        let tri = target(&[DVec3::ZERO, DVec3::X, DVec3::Y]);
        let j = tri.second_moment();
        assert!((j.x_axis.x - 0.5 / 18.0).abs() < 1e-12, "{j}");
        assert!((j.y_axis.y - 0.5 / 18.0).abs() < 1e-12, "{j}");
        assert!((j.x_axis.y + 0.5 / 36.0).abs() < 1e-12, "{j}");
    }

    /// The kernel's gradient is the derivative of the differential factor per unit area (central
    /// differences along the surface), and zero where the surface point is behind the receiver.
    #[test]
    fn kernel_gradient_is_the_derivative_of_the_kernel() {
        let p = DVec3::new(0.2, -0.3, 0.4);
        let n = DVec3::new(0.3, 0.2, -1.0).normalize();
        let x = DVec3::new(0.5, 0.1, 0.0);
        let kernel = |x: DVec3| differential(p, n, x, DVec3::Z, 1.0);
        let g = kernel_gradient(p, n, x, DVec3::Z);
        let h = 1e-6;
        for axis in [DVec3::X, DVec3::Y] {
            let numeric = (kernel(x + axis * h) - kernel(x - axis * h)) / (2.0 * h);
            assert!(
                (g.dot(axis) - numeric).abs() < 1e-6 * numeric.abs().max(1e-3),
                "{g} {numeric}"
            );
        }
        assert_eq!(kernel_gradient(p, -n, x, DVec3::Z), DVec3::ZERO);
    }
}
