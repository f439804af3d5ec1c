//! Exact-in-the-curve direct irradiance of one light on the solver patches, per edit
//! (docs/DECISIONS.md "Interreflection").
//!
//! Per (light, patch) the cache holds the solid-angle quadrature of the patch seen from the light
//! ([`polygon_quadrature_visible`]): per sample the unit direction from the light and its weight
//! (exact solid angle of its piece × near-field softening `r²/(r² + a²)`, divided by the patch
//! area), visible samples only. An edit or a re-aim then costs one curve evaluation per sample:
//! `E_patch = Σ w · I(γ(dir))` (lx), the patch average of the exact direct light, with no SH
//! truncation and no rays. The flux onto a patch is exact for any curve that is constant over each
//! piece; pieces are split until they are below `split ×` their distance to the light.

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use crate::photometry::lookup::CurveLookup;
use crate::photometry::sh::{ShBasis, sh_count};
use crate::photometry::{Curve, LightState};
use crate::scene::PatchMesh;
use crate::transport::direct::polygon_quadrature_visible;
use crate::transport::radiosity::PatchColumns;
use crate::transport::visibility::Visibility;

/// Default piece size relative to the distance to the light.
pub const DEFAULT_SPLIT: f64 = 1.0 / 32.0;

/// How finely a patch is sampled: pieces below `piece ×` their distance to the light, a piece
/// that a shadow line crosses split up to `shadow_splits` more times
/// ([`crate::transport::direct::polygon_quadrature_visible`]); patch `p` with `beam_edge[p]`
/// (when given) in pieces no longer than [`BEAM_EDGE_PIECE`] of its shortest edge.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Split<'a> {
    pub piece: f64,
    pub shadow_splits: u32,
    pub beam_edge: &'a [bool],
}

/// The longest piece of a patch that a light's beam edge crosses, as a fraction of its
/// shortest edge: the samples' directions are fixed, so a curve's hard cut-off through a piece
/// counts the piece wholly lit or wholly dark, and on a patch smaller than a piece that is the
/// whole patch (docs/DECISIONS.md "Light edges beside contacts").
pub const BEAM_EDGE_PIECE: f64 = 0.25;

/// Patches per rayon task when evaluating a cache.
const MIN_PATCHES_PER_TASK: usize = 256;

/// The quadrature samples of one light on every patch of a mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct PatchDirectCache {
    /// Samples of patch `p` are `offsets[p]..offsets[p + 1]`.
    offsets: Vec<u32>,
    /// Unit direction light → sample (world).
    dirs: Vec<Vec3>,
    /// Solid angle × softening / patch area (sr/m²).
    weights: Vec<f32>,
}

impl PatchDirectCache {
    /// Samples every patch of `mesh` seen from a light at `position` (world, m) with luminous
    /// radius `radius_m`; pieces below `split ×` their distance, a piece that a shadow line
    /// crosses split up to `shadow_splits` more times; samples blocked by `occluders` are dropped.
    pub fn build(
        mesh: &PatchMesh,
        position: DVec3,
        radius_m: f64,
        split: Split,
        occluders: Option<&dyn Visibility>,
    ) -> Self {
        let per_patch: Vec<(Vec<Vec3>, Vec<f32>)> = (0..mesh.patches.len())
            .into_par_iter()
            .map(|index| {
                let (mut dirs, mut weights) = (Vec::new(), Vec::new());
                patch_samples(mesh, index, position, radius_m, split, occluders, |dir, w| {
                    dirs.push(dir);
                    weights.push(w);
                });
                (dirs, weights)
            })
            .collect();
        let mut offsets = Vec::with_capacity(per_patch.len() + 1);
        offsets.push(0u32);
        let total: usize = per_patch.iter().map(|p| p.0.len()).sum();
        let (mut dirs, mut weights) = (Vec::with_capacity(total), Vec::with_capacity(total));
        for (d, w) in per_patch {
            dirs.extend(d);
            weights.extend(w);
            offsets.push(dirs.len() as u32);
        }
        PatchDirectCache {
            offsets,
            dirs,
            weights,
        }
    }

    /// The patch-averaged direct irradiance (lx) of every patch of `mesh` for `curve` (cd)
    /// aimed along the unit vector `aim`, times `scale`, from the samples a cache built with the
    /// same arguments would hold, without holding them: the same values as [`Self::build`] then
    /// [`Self::irradiance_into`] (the same f32 samples summed in the same order), in constant
    /// memory.
    #[allow(clippy::too_many_arguments)]
    pub fn stream_irradiance(
        mesh: &PatchMesh,
        position: DVec3,
        radius_m: f64,
        split: Split,
        occluders: Option<&dyn Visibility>,
        curve: &Curve,
        aim: DVec3,
        scale: f64,
    ) -> Vec<f64> {
        let (aim, lookup) = (aim.as_vec3(), CurveLookup::new(curve));
        (0..mesh.patches.len())
            .into_par_iter()
            .with_min_len(MIN_PATCHES_PER_TASK)
            .map(|index| {
                let mut sum = 0.0;
                patch_samples(mesh, index, position, radius_m, split, occluders, |dir, w| {
                    sum += f64::from(w) * curve_intensity(&lookup, aim, dir);
                });
                scale * sum
            })
            .collect()
    }

    /// The light's leaf direct light (lx) in `state` (its curve, aim and dimmer), as the one
    /// column of emission a solve takes.
    pub fn emission(&self, state: &LightState) -> PatchColumns {
        let mut values = vec![0.0; self.n_patches()];
        self.irradiance_into(&state.curve, state.aim.normalize(), state.dimmer, &mut values);
        PatchColumns {
            n_patches: values.len(),
            n_columns: 1,
            values,
        }
    }

    /// Per patch and each control point `points[j]` of `curve` (aimed along the unit vector
    /// `aim`), the patch-averaged direct irradiance (lx) of the curve with 1 cd at that point and
    /// 0 at the others, into `out` (patch-major, `points.len()` per patch): the hat functions'
    /// weights of every sample, in one pass (the same values as [`Self::irradiance_into`] of each
    /// unit curve). Points outside the curve are left 0.
    pub fn control_point_irradiance_into(
        &self,
        curve: &Curve,
        aim: DVec3,
        points: &[usize],
        out: &mut [f64],
    ) {
        let m = points.len();
        assert_eq!(out.len(), self.n_patches() * m, "a column per point");
        if m == 0 {
            return;
        }
        let mut column_of = vec![None; curve.len()];
        for (j, &k) in points.iter().enumerate() {
            if let Some(c) = column_of.get_mut(k) {
                *c = Some(j);
            }
        }
        let (aim, lookup) = (aim.as_vec3(), CurveLookup::new(curve));
        out.par_chunks_mut(m)
            .enumerate()
            .with_min_len(MIN_PATCHES_PER_TASK)
            .for_each(|(p, row)| {
                row.iter_mut().for_each(|v| *v = 0.0);
                let range = self.offsets[p] as usize..self.offsets[p + 1] as usize;
                let mut add = |k: usize, w: f64| {
                    if let Some(j) = column_of[k] {
                        row[j] += w;
                    }
                };
                for (&dir, &w) in self.dirs[range.clone()].iter().zip(&self.weights[range]) {
                    let w = f64::from(w);
                    match lookup.segment_cos(f64::from(aim.dot(dir))) {
                        None => {}
                        Some((i, None)) => add(i, w),
                        Some((i, Some(t))) => {
                            add(i - 1, w * (1.0 - t));
                            add(i, w * t);
                        }
                    }
                }
            });
    }

    /// Per patch, the patch-averaged direct irradiance (lx) of each real SH basis emitter
    /// `I(dir) = Y_k(dir)` (cd, world frame, k < `sh_count(basis.order())`) into `out`
    /// (patch-major, that many per patch): the emission columns of the light's
    /// [`crate::transport::sh_response::ShResponse`], in one pass over the samples.
    pub fn sh_irradiance_into(&self, basis: &ShBasis, out: &mut [f64]) {
        let m = sh_count(basis.order());
        assert_eq!(out.len(), self.n_patches() * m, "a column per SH function");
        out.par_chunks_mut(m)
            .enumerate()
            .with_min_len(MIN_PATCHES_PER_TASK)
            .for_each(|(p, row)| {
                row.iter_mut().for_each(|v| *v = 0.0);
                let mut y = vec![0.0; m];
                let range = self.offsets[p] as usize..self.offsets[p + 1] as usize;
                for (&dir, &w) in self.dirs[range.clone()].iter().zip(&self.weights[range]) {
                    basis.eval(dir.as_dvec3().normalize(), &mut y);
                    let w = f64::from(w);
                    row.iter_mut().zip(&y).for_each(|(r, y)| *r += w * y);
                }
            });
    }

    /// Number of patches.
    pub fn n_patches(&self) -> usize {
        self.offsets.len() - 1
    }

    /// Number of (visible) samples.
    pub fn n_samples(&self) -> usize {
        self.weights.len()
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.offsets.len() * 4 + self.dirs.len() * 12 + self.weights.len() * 4
    }

    /// Patch-averaged direct irradiance (lx) into `out` (one per patch) for `curve` (cd) aimed
    /// along the unit vector `aim`, times `scale`.
    pub fn irradiance_into(&self, curve: &Curve, aim: DVec3, scale: f64, out: &mut [f64]) {
        let (aim, lookup) = (aim.as_vec3(), CurveLookup::new(curve));
        self.irradiance_with(|dir| curve_intensity(&lookup, aim, dir), scale, out);
    }

    /// Like [`Self::irradiance_into`] for any intensity `I(dir)` (cd) of the unit direction from
    /// the light (e.g. an SH basis emitter).
    pub fn irradiance_with(&self, intensity: impl Fn(Vec3) -> f64 + Sync, scale: f64, out: &mut [f64]) {
        assert_eq!(out.len(), self.n_patches(), "one output per patch");
        out.par_iter_mut()
            .enumerate()
            .with_min_len(MIN_PATCHES_PER_TASK)
            .for_each(|(p, o)| {
                let range = self.offsets[p] as usize..self.offsets[p + 1] as usize;
                let sum: f64 = self.dirs[range.clone()]
                    .iter()
                    .zip(&self.weights[range])
                    .map(|(&d, &w)| f64::from(w) * intensity(d))
                    .sum();
                *o = scale * sum;
            });
    }
}

/// The intensity (cd) of the curve behind `lookup` along the unit direction `dir` for the unit
/// `aim`: [`CurveLookup::eval_cos`], the curve's value at the angle to within 2.5·10⁻⁸ rad, its
/// segment found through the lookup's table (an evaluation per cached sample is most of an
/// edit's patch direct light: docs/DECISIONS.md "Patch direct light through the curve's lookup").
#[inline]
fn curve_intensity(lookup: &CurveLookup, aim: Vec3, dir: Vec3) -> f64 {
    lookup.eval_cos(f64::from(aim.dot(dir)))
}

/// Visits the visible quadrature samples of patch `index` of `mesh` seen from a light at
/// `position` with luminous radius `radius_m`, pieces below `split ×` their distance: the unit
/// direction light → sample and the weight (solid angle × softening / patch area, sr/m²), as
/// the cache stores them.
fn patch_samples(
    mesh: &PatchMesh,
    index: usize,
    position: DVec3,
    radius_m: f64,
    split: Split,
    occluders: Option<&dyn Visibility>,
    mut sample: impl FnMut(Vec3, f32),
) {
    let patch = &mesh.patches[index];
    let polygon: Vec<DVec3> = patch
        .vertex_ids()
        .iter()
        .map(|&v| mesh.positions[v as usize])
        .collect();
    let max_piece_m = if split.beam_edge.get(index) == Some(&true) {
        let shortest = (0..polygon.len())
            .map(|k| polygon[k].distance(polygon[(k + 1) % polygon.len()]))
            .fold(f64::INFINITY, f64::min);
        BEAM_EDGE_PIECE * shortest
    } else {
        f64::INFINITY
    };
    let inv_area = 1.0 / patch.area;
    let visible = |point: DVec3| occluders.is_none_or(|v| v.visible(position, point));
    polygon_quadrature_visible(
        position,
        radius_m,
        &polygon,
        patch.normal,
        split.piece,
        max_piece_m,
        split.shadow_splits,
        &visible,
        |dir, w, _| sample(dir.as_vec3(), (w * inv_area) as f32),
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Patch;

    /// Pieces below `piece ×` their distance (no occluders here, so no shadow lines to split at).
    fn pieces(piece: f64) -> Split<'static> {
        Split {
            piece,
            shadow_splits: 0,
            beam_edge: &[],
        }
    }

    /// One square patch `[-a/2, a/2]²` at z = 0 facing up.
    fn square(a: f64) -> PatchMesh {
        let h = a / 2.0;
        rectangle(-h, h, -h, h)
    }

    /// One patch `[x0, x1] × [y0, y1]` at z = 0 facing up.
    fn rectangle(x0: f64, x1: f64, y0: f64, y1: f64) -> PatchMesh {
        PatchMesh {
            positions: vec![
                DVec3::new(x0, y0, 0.0),
                DVec3::new(x1, y0, 0.0),
                DVec3::new(x1, y1, 0.0),
                DVec3::new(x0, y1, 0.0),
            ],
            normals: vec![DVec3::Z; 4],
            vertex_surface: vec![0; 4],
            patches: vec![Patch {
                vertices: [0, 1, 2, 3],
                n_vertices: 4,
                surface: 0,
                normal: DVec3::Z,
                area: (x1 - x0) * (y1 - y0),
                centroid: DVec3::new(0.5 * (x0 + x1), 0.5 * (y0 + y1), 0.0),
            }],
        }
    }

    /// Isotropic flux onto a centred square (docs/METHOD.md §8): a = 6, h = 2 gives 3.05872871 sr;
    /// the patch average is `I · Ω / A`, for any split (the solid angle of each piece is exact).
    #[test]
    fn isotropic_patch_average_is_the_exact_flux_over_the_area() {
        let mesh = square(6.0);
        for split in [1.0 / 16.0, 1.0 / 8.0, 1.0 / 2.0] {
            let cache = PatchDirectCache::build(&mesh, DVec3::new(0.0, 0.0, 2.0), 0.0, pieces(split), None);
            let mut e = [0.0];
            cache.irradiance_into(&Curve::isotropic(1000.0), DVec3::NEG_Z, 1.0, &mut e);
            let want = 1000.0 * 3.05872871 / 36.0;
            assert!(
                (e[0] - want).abs() < 1e-5 * want,
                "split {split}: {} vs {want}",
                e[0]
            );
        }
    }

    /// A hard 30° spot 2 m above the square: the flux through the disc of radius 2 tan 30° is
    /// `2π I (1 − cos 30°)`; the patch average converges to it over the area as pieces shrink,
    /// and the edit (a new curve, a new aim) needs no rebuild.
    #[test]
    fn a_hard_spot_converges_and_edits_without_rebuild() {
        let mesh = square(6.0);
        let spot = Curve::new(&[(0.0, 1000.0), (30.0, 1000.0), (30.0, 0.0), (180.0, 0.0)]).unwrap();
        let want = 2.0 * std::f64::consts::PI * 1000.0 * (1.0 - 30f64.to_radians().cos()) / 36.0;
        let mut errors = Vec::new();
        for split in [1.0 / 4.0, 1.0 / 16.0, 1.0 / 64.0] {
            let cache = PatchDirectCache::build(&mesh, DVec3::new(0.0, 0.0, 2.0), 0.0, pieces(split), None);
            let mut e = [0.0];
            cache.irradiance_into(&spot, DVec3::NEG_Z, 1.0, &mut e);
            errors.push((e[0] - want).abs() / want);
            // Re-aimed straight up: nothing reaches the floor.
            cache.irradiance_into(&spot, DVec3::Z, 1.0, &mut e);
            assert_eq!(e[0], 0.0);
        }
        assert!(errors[2] < errors[0] && errors[2] < 2e-3, "{errors:?}");
    }

    /// A hard spot's edge through a patch smaller than one piece (3 × 2 cm, 1.4 m under the
    /// light, the 15° cut-off a third of the way across it): the fixed samples count the
    /// patch lit or dark by where they fall, half its exact light here (693 against 1 394 lx,
    /// the direct light averaged over 200 × 200 points of the patch); sampled as a leaf crossed
    /// by a beam edge (`beam_edge`, pieces a quarter of its shorter side) it is within 6 %
    /// (1 469 lx: a column of 5 mm pieces still counts whole).
    #[test]
    fn a_beam_edge_through_a_small_patch_is_sampled_finely() {
        let (x0, x1, y0, y1) = (0.365, 0.395, -0.01, 0.01);
        let mesh = rectangle(x0, x1, y0, y1);
        let light = DVec3::new(0.0, 0.0, 1.4);
        let spot = Curve::new(&[(0.0, 9000.0), (15.0, 9000.0), (15.0, 0.0), (180.0, 0.0)]).unwrap();
        let n = 200;
        let mut exact = 0.0;
        for i in 0..n {
            for j in 0..n {
                let p = DVec3::new(
                    x0 + (i as f64 + 0.5) / n as f64 * (x1 - x0),
                    y0 + (j as f64 + 0.5) / n as f64 * (y1 - y0),
                    0.0,
                );
                let d = p - light;
                let r = d.length();
                exact += spot.eval_rad((-d.z / r).acos()) * (-d.z / r) / (r * r);
            }
        }
        exact /= (n * n) as f64;
        let direct = |beam_edge: &[bool]| {
            let split = Split {
                piece: DEFAULT_SPLIT,
                shadow_splits: 0,
                beam_edge,
            };
            let cache = PatchDirectCache::build(&mesh, light, 0.0, split, None);
            let mut e = [0.0];
            cache.irradiance_into(&spot, DVec3::NEG_Z, 1.0, &mut e);
            e[0]
        };
        let (coarse, fine) = (direct(&[false]), direct(&[true]));
        assert!((fine - exact).abs() < 0.06 * exact, "{fine} lx against {exact}");
        assert!(
            (coarse - exact).abs() > 0.3 * exact,
            "{coarse} lx against {exact}"
        );
    }

    /// The per-control-point irradiance of one pass equals the irradiance of each unit curve
    /// (1 cd at one point, 0 elsewhere; a hard edge's two points at one angle included), and
    /// weighted by the curve's intensities it is the curve's irradiance.
    #[test]
    fn control_point_irradiance_is_each_unit_curve() {
        let mesh = square(6.0);
        let cache =
            PatchDirectCache::build(&mesh, DVec3::new(0.5, -0.3, 2.0), 0.02, pieces(1.0 / 16.0), None);
        let curve = Curve::new(&[
            (0.0, 900.0),
            (20.0, 700.0),
            (40.0, 700.0),
            (40.0, 100.0),
            (90.0, 0.0),
        ])
        .unwrap();
        let aim = DVec3::new(0.2, 0.1, -1.0).normalize();
        let k = curve.len();
        let every: Vec<usize> = (0..k).collect();
        let mut columns = vec![f64::NAN; cache.n_patches() * k];
        cache.control_point_irradiance_into(&curve, aim, &every, &mut columns);
        let mut e = [0.0];
        for j in 0..k {
            let mut unit = curve.clone();
            for point in 0..k {
                unit.set_intensity(point, if point == j { 1.0 } else { 0.0 })
                    .unwrap();
            }
            cache.irradiance_into(&unit, aim, 1.0, &mut e);
            assert_eq!(columns[j], e[0], "point {j}");
        }
        assert!(columns.iter().all(|&c| c >= 0.0) && columns[0] > 0.0);
        cache.irradiance_into(&curve, aim, 1.0, &mut e);
        let sum: f64 = columns
            .iter()
            .zip(curve.intensities_cd())
            .map(|(c, i)| c * i)
            .sum();
        assert!((sum - e[0]).abs() <= 1e-12 * e[0], "{sum} vs {}", e[0]);
        // A few points, in any order: the same columns.
        let mut some = vec![f64::NAN; 2];
        cache.control_point_irradiance_into(&curve, aim, &[3, 1], &mut some);
        assert_eq!(some, [columns[3], columns[1]]);
    }
}
