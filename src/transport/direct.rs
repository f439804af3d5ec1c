//! Exact direct illuminance from a point (or small disc) source with an axially symmetric curve.
//!
//! `E = I(γ) · cosθ / (r² + a²) · V` (docs/METHOD.md §5): γ is the angle between the light's aim axis
//! and the direction to the receiver, θ the angle of incidence at the receiver, `a` the luminous
//! radius (near-field softening) and V the visibility. Everything that does not depend on the
//! curve or the aim is cached per (light, receiver) in [`DirectCache`], so an edit or a re-aim
//! costs one curve evaluation per lit receiver and casts no rays.

use glam::DVec3;
use rayon::prelude::*;

use crate::photometry::Curve;
use crate::transport::visibility::Visibility;

pub use crate::scene::Receiver;

/// Receivers closer than this to a light (m) get no light: they are inside the luminaire.
pub(crate) const MIN_DISTANCE_M: f64 = 1e-6;

/// Per (light, receiver) geometry: the unit direction from the light and the factor
/// `cosθ / (r² + a²) · V` (1/m²), one entry per receiver (factor 0 for receivers that cannot be
/// lit), so an edit writes every receiver's illuminance in one parallel pass without allocating.
#[derive(Debug, Clone)]
pub struct DirectCache {
    /// Number of receivers with a non-zero factor.
    n_lit: usize,
    /// Unit direction light → receiver (world), one per receiver (zero when unlit).
    dirs: Vec<DVec3>,
    /// `cosθ / (r² + a²) · V` in 1/m², one per receiver (0 when unlit).
    factors: Vec<f64>,
}

impl DirectCache {
    /// Caches the geometry of `receivers` seen from a light at `position` (world, m) with
    /// luminous radius `radius_m`. Visibility is tested only when `occluders` is given.
    pub fn build(
        position: DVec3,
        radius_m: f64,
        receivers: &[Receiver],
        occluders: Option<&dyn Visibility>,
    ) -> Self {
        let (dirs, factors): (Vec<DVec3>, Vec<f64>) = receivers
            .par_iter()
            .map(|rx| {
                let Some((dir, factor)) = geometry_factor(position, radius_m, rx) else {
                    return (DVec3::ZERO, 0.0);
                };
                if occluders.is_some_and(|vis| !vis.visible(position, rx.point)) {
                    return (DVec3::ZERO, 0.0);
                }
                (dir, factor)
            })
            .unzip();
        DirectCache {
            n_lit: factors.iter().filter(|&&f| f != 0.0).count(),
            dirs,
            factors,
        }
    }

    /// Number of receivers the cache was built for.
    pub fn n_receivers(&self) -> usize {
        self.factors.len()
    }

    /// Number of receivers that can be lit (facing the light, visible).
    pub fn n_lit(&self) -> usize {
        self.n_lit
    }

    /// Direct illuminance (lx) at every receiver into `out` (len = receivers), for `curve` (cd)
    /// aimed along the unit vector `aim` and scaled by `scale` (dimmer). Receivers that cannot be
    /// lit get 0.
    pub fn illuminance_into(&self, curve: &Curve, aim: DVec3, scale: f64, out: &mut [f64]) {
        self.illuminance_with(
            |dir| curve.eval_rad(aim.dot(dir).clamp(-1.0, 1.0).acos()),
            scale,
            out,
        );
    }

    /// Like [`Self::illuminance_into`] for any intensity `I(dir)` (cd) of the unit world direction
    /// from the light, e.g. a truncated SH series in paper mode.
    pub fn illuminance_with(&self, intensity: impl Fn(DVec3) -> f64 + Sync, scale: f64, out: &mut [f64]) {
        assert_eq!(
            out.len(),
            self.factors.len(),
            "output length must match the receivers"
        );
        out.par_iter_mut()
            .zip(self.dirs.par_iter().zip(&self.factors))
            .with_min_len(MIN_RECEIVERS_PER_TASK)
            .for_each(|(o, (&dir, &factor))| {
                *o = if factor == 0.0 {
                    0.0
                } else {
                    scale * intensity(dir) * factor
                };
            });
    }
}

/// Receivers per rayon task when evaluating a cache: enough to amortise the task overhead.
const MIN_RECEIVERS_PER_TASK: usize = 4096;

/// Unit direction light → receiver and `cosθ / (r² + a²)`, or `None` when the receiver faces
/// away or sits inside the luminaire.
pub fn geometry_factor(position: DVec3, radius_m: f64, rx: &Receiver) -> Option<(DVec3, f64)> {
    let to = rx.point - position;
    let r2 = to.length_squared();
    if r2 < MIN_DISTANCE_M * MIN_DISTANCE_M {
        return None;
    }
    let dir = to * (1.0 / r2.sqrt()); // one division, not three
    let cos_incidence = -rx.normal.dot(dir);
    (cos_incidence > 0.0).then(|| (dir, cos_incidence / (r2 + radius_m * radius_m)))
}

/// Direct illuminance (lx) at one receiver: exact, with optional visibility.
pub fn illuminance_at(
    position: DVec3,
    radius_m: f64,
    curve: &Curve,
    aim: DVec3,
    scale: f64,
    rx: &Receiver,
    occluders: Option<&dyn Visibility>,
) -> f64 {
    let Some((dir, factor)) = geometry_factor(position, radius_m, rx) else {
        return 0.0;
    };
    if occluders.is_some_and(|v| !v.visible(position, rx.point)) {
        return 0.0;
    }
    scale * curve.eval_rad(aim.dot(dir).clamp(-1.0, 1.0).acos()) * factor
}

/// Solid angle (sr) of the triangle `a, b, c` seen from the origin (Van Oosterom & Strackee 1983).
pub fn triangle_solid_angle(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let numerator = a.dot(b.cross(c)).abs();
    let denominator = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    2.0 * numerator.atan2(denominator)
}

/// Solid-angle quadrature over a planar convex polygon (world, m) seen from a source at
/// `position`: the polygon is fanned into triangles, each split recursively until its longest
/// edge is below a sixteenth of its distance to the source; `visit(dir, weight, point)` is called
/// three times per piece, at its edge midpoints, with the unit direction to the point, the piece's
/// exact solid angle (sr) shared in proportion to the solid-angle density `1/|q|³` at the three
/// points times the near-field softening `r²/(r² + a²)`, and the point (world). Only the side the
/// polygon's `normal` faces is visited. `Σ weight · I(dir)` is the flux (lm) onto the polygon.
pub fn polygon_quadrature(
    position: DVec3,
    radius_m: f64,
    polygon: &[DVec3],
    normal: DVec3,
    visit: impl FnMut(DVec3, f64, DVec3),
) {
    polygon_quadrature_split(position, radius_m, polygon, normal, FLUX_SPLIT, visit)
}

/// Pieces of [`polygon_quadrature`] are split until their longest edge is below this fraction of
/// their distance to the source.
pub const FLUX_SPLIT: f64 = 1.0 / 16.0;

/// [`polygon_quadrature`] with pieces split until their longest edge is below `split ×` their
/// distance to the source (coarser pieces: fewer samples, the same exact solid angle per piece).
pub fn polygon_quadrature_split(
    position: DVec3,
    radius_m: f64,
    polygon: &[DVec3],
    normal: DVec3,
    split: f64,
    mut visit: impl FnMut(DVec3, f64, DVec3),
) {
    let split2 = split * split;
    if (polygon[0] - position).dot(normal) >= 0.0 {
        return; // the source is behind (or in the plane of) the polygon
    }
    let mut stack: Vec<([DVec3; 3], u32)> = (1..polygon.len() - 1)
        .map(|k| {
            (
                [
                    polygon[0] - position,
                    polygon[k] - position,
                    polygon[k + 1] - position,
                ],
                0,
            )
        })
        .collect();
    while let Some(([a, b, c], depth)) = stack.pop() {
        let mid = (a + b + c) / 3.0;
        let r2 = mid.length_squared();
        let longest2 = (b - a)
            .length_squared()
            .max((c - b).length_squared())
            .max((a - c).length_squared());
        if longest2 > r2 * split2 && depth < MAX_SPLIT_DEPTH {
            let (ab, bc, ca) = ((a + b) / 2.0, (b + c) / 2.0, (c + a) / 2.0);
            for tri in [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]] {
                stack.push((tri, depth + 1));
            }
            continue;
        }
        // Edge-midpoint rule on the flat triangle (exact for quadratics) applied to the solid-angle
        // density, which is ∝ 1/|q|³ on a plane; the weights are rescaled to the exact solid angle.
        let omega = triangle_solid_angle(a, b, c);
        let points = [(a + b) / 2.0, (b + c) / 2.0, (c + a) / 2.0];
        let density = points.map(|q| q.length_squared().powf(-1.5));
        let norm = omega / (density[0] + density[1] + density[2]);
        for (q, d) in points.into_iter().zip(density) {
            let q2 = q.length_squared();
            visit(
                q / q2.sqrt(),
                norm * d * q2 / (q2 + radius_m * radius_m),
                position + q,
            );
        }
    }
}

/// Luminous flux (lm) that a source at `position` sends onto a planar convex polygon (world, m),
/// `∫ I(ω) dΩ` by [`polygon_quadrature`]. `intensity(dir)` is in cd for a unit world direction; it
/// may be negative (SH basis emitters). Divide by the area for the patch-averaged illuminance.
pub fn polygon_flux(
    position: DVec3,
    radius_m: f64,
    polygon: &[DVec3],
    normal: DVec3,
    intensity: impl Fn(DVec3) -> f64,
) -> f64 {
    let mut flux = 0.0;
    polygon_quadrature(position, radius_m, polygon, normal, |dir, weight, _| {
        flux += intensity(dir) * weight
    });
    flux
}

/// Recursion limit of [`polygon_quadrature`]: 4^10 pieces per triangle at most.
const MAX_SPLIT_DEPTH: u32 = 10;

/// Photopic weight of a linear-RGB colour multiplier (Rec. 709 luminance coefficients), so a
/// white light `[1, 1, 1]` weighs 1 and lux stays lux for coloured lights.
pub fn luminance_weight(color: [f64; 3]) -> f64 {
    0.2126 * color[0] + 0.7152 * color[1] + 0.0722 * color[2]
}

/// Exact direct illuminance (lx) of all of a scene's lights at arbitrary receivers, with
/// visibility when the scene has occluders. Coloured lights count with [`luminance_weight`].
pub fn scene_direct_at(scene: &crate::scene::Scene, receivers: &[Receiver]) -> Vec<f64> {
    let occluders = crate::transport::occlusion::Occluders::of_scene(scene);
    let vis = occluders.as_ref().map(|o| o as &dyn Visibility);
    receivers
        .par_iter()
        .map(|rx| {
            scene
                .lights
                .iter()
                .map(|l| {
                    luminance_weight(l.color)
                        * illuminance_at(l.position, l.radius, &l.curve, l.aim, l.dimmer, rx, vis)
                })
                .sum()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn octant_solid_angle_is_an_eighth_of_the_sphere() {
        let omega = triangle_solid_angle(DVec3::X, DVec3::Y, DVec3::Z);
        assert!((omega - std::f64::consts::PI / 2.0).abs() < 1e-14);
    }

    #[test]
    fn isotropic_flux_onto_a_centred_square_matches_the_closed_form() {
        // docs/METHOD.md §8: a = 6, h = 2 gives 3.05872871 sr; a = 4, h = 3 gives 1.25106689 sr.
        for (a, h, sr) in [(6.0, 2.0, 3.05872871), (4.0, 3.0, 1.25106689)] {
            let half: f64 = a / 2.0;
            let square = [
                DVec3::new(-half, -half, 0.0),
                DVec3::new(half, -half, 0.0),
                DVec3::new(half, half, 0.0),
                DVec3::new(-half, half, 0.0),
            ];
            let flux = polygon_flux(DVec3::new(0.0, 0.0, h), 0.0, &square, DVec3::Z, |_| 1.0);
            assert!((flux - sr).abs() < 1e-8, "a={a} h={h}: {flux}");
        }
    }
}
