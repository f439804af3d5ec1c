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
use crate::transport::formfactor::triangle_quarters;
use crate::transport::visibility::Visibility;

pub use crate::scene::Receiver;

/// Receivers closer than this to a light (m) get no light: they are inside the luminaire.
pub(crate) const MIN_DISTANCE_M: f64 = 1e-6;

/// Per (light, receiver) geometry: the factor `cosθ / (r² + a²) · V` (1/m²), one entry per
/// receiver (0 for receivers that cannot be lit), so an edit writes every receiver's illuminance
/// in one parallel pass without allocating. The direction from the light to each receiver is
/// made again at each evaluation from the receiver's point ([`direction_to`], the same bits as
/// at build): 24 bytes a receiver less per light than keeping it, for about the same reads
/// (docs/DECISIONS.md "Direct caches without directions").
#[derive(Debug, Clone)]
pub struct DirectCache {
    /// Number of receivers with a non-zero factor.
    n_lit: usize,
    /// The light's position (world, m) the factors were made for.
    position: DVec3,
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
        let factors: Vec<f64> = receivers
            .par_iter()
            .map(|rx| match geometry_factor(position, radius_m, rx) {
                Some((_, factor)) if occluders.is_none_or(|vis| vis.visible(position, rx.point)) => factor,
                _ => 0.0,
            })
            .collect();
        DirectCache {
            n_lit: factors.iter().filter(|&&f| f != 0.0).count(),
            position,
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
    /// aimed along the unit vector `aim` and scaled by `scale` (dimmer). `receivers` are those
    /// the cache was built for. Receivers that cannot be lit get 0.
    pub fn illuminance_into(
        &self,
        receivers: &[Receiver],
        curve: &Curve,
        aim: DVec3,
        scale: f64,
        out: &mut [f64],
    ) {
        self.illuminance_with(
            receivers,
            |dir| curve.eval_rad(aim.dot(dir).clamp(-1.0, 1.0).acos()),
            scale,
            out,
        );
    }

    /// Like [`Self::illuminance_into`] for any intensity `I(dir)` (cd) of the unit world direction
    /// from the light, e.g. a truncated SH series in paper mode.
    pub fn illuminance_with(
        &self,
        receivers: &[Receiver],
        intensity: impl Fn(DVec3) -> f64 + Sync,
        scale: f64,
        out: &mut [f64],
    ) {
        assert_eq!(
            receivers.len(),
            self.factors.len(),
            "the receivers must be those the cache was built for"
        );
        assert_eq!(
            out.len(),
            self.factors.len(),
            "output length must match the receivers"
        );
        let position = self.position;
        out.par_chunks_mut(DIRECTION_CHUNK)
            .zip(
                receivers
                    .par_chunks(DIRECTION_CHUNK)
                    .zip(self.factors.par_chunks(DIRECTION_CHUNK)),
            )
            .with_min_len(MIN_RECEIVERS_PER_TASK / DIRECTION_CHUNK)
            .for_each(|(out, (receivers, factors))| {
                // The directions first, in a loop of their own: one at a time, each square root
                // and division would wait in line before the curve's evaluation.
                let mut dirs = [DVec3::ZERO; DIRECTION_CHUNK];
                for (d, rx) in dirs.iter_mut().zip(receivers) {
                    *d = direction_to(position, rx.point).0;
                }
                for ((o, &dir), &factor) in out.iter_mut().zip(&dirs).zip(factors) {
                    *o = if factor == 0.0 {
                        0.0
                    } else {
                        scale * intensity(dir) * factor
                    };
                }
            });
    }
}

/// Receivers per rayon task when evaluating a cache: enough to amortise the task overhead.
const MIN_RECEIVERS_PER_TASK: usize = 4096;

/// Receivers whose directions [`DirectCache::illuminance_with`] makes at a time, on the stack.
const DIRECTION_CHUNK: usize = 256;

/// Unit direction from a light at `position` to `point` (world, m), and their squared distance
/// (m²). Undefined (not finite) when the two coincide.
#[inline]
pub fn direction_to(position: DVec3, point: DVec3) -> (DVec3, f64) {
    let to = point - position;
    let r2 = to.length_squared();
    (to * (1.0 / r2.sqrt()), r2) // one division, not three
}

/// Unit direction light → receiver and `cosθ / (r² + a²)`, or `None` when the receiver faces
/// away or sits inside the luminaire.
pub fn geometry_factor(position: DVec3, radius_m: f64, rx: &Receiver) -> Option<(DVec3, f64)> {
    let (dir, r2) = direction_to(position, rx.point);
    if r2 < MIN_DISTANCE_M * MIN_DISTANCE_M {
        return None;
    }
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
    crate::scene::obj::signed_solid_angle(a, b, c).abs()
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
    visit: impl FnMut(DVec3, f64, DVec3),
) {
    quadrature(
        position,
        radius_m,
        polygon,
        normal,
        split,
        f64::INFINITY,
        None,
        visit,
    );
}

/// [`polygon_quadrature_split`], with pieces no longer than `max_piece_m` either (m; infinite
/// for none), visiting only the samples whose point `visible` says the source sees; a piece
/// whose three samples disagree (a shadow line crosses it) is split again, up to
/// `shadow_splits` more times ([`SHADOW_SPLIT_DEPTH`] by default; 0 keeps the pieces), and so
/// is every piece whose corners disagree once the polygon's corners do (a straight line through
/// a triangle leaves a corner on each side), so that the visible part of the polygon is resolved
/// to `4^-depth` of a piece instead of being weighted by where its edge-midpoint samples fall
/// (docs/DECISIONS.md "Interreflection", "Shadow lines in the patch direct light").
#[allow(clippy::too_many_arguments)]
pub fn polygon_quadrature_visible(
    position: DVec3,
    radius_m: f64,
    polygon: &[DVec3],
    normal: DVec3,
    split: f64,
    max_piece_m: f64,
    shadow_splits: u32,
    visible: &dyn Fn(DVec3) -> bool,
    visit: impl FnMut(DVec3, f64, DVec3),
) {
    // A straight shadow line through the polygon leaves a corner on each side of it.
    let crossed = shadow_splits > 0 && {
        let corners: Vec<bool> = polygon.iter().map(|&q| visible(q)).collect();
        corners.contains(&true) && corners.contains(&false)
    };
    let shadow = Shadow {
        visible,
        crossed,
        splits: shadow_splits,
    };
    quadrature(
        position,
        radius_m,
        polygon,
        normal,
        split,
        max_piece_m,
        Some(shadow),
        visit,
    );
}

/// Extra splits of a piece that a shadow line crosses ([`polygon_quadrature_visible`]) by
/// default: 4 takes a piece to 1/256 of its solid angle along the line.
pub const SHADOW_SPLIT_DEPTH: u32 = 4;

/// What [`quadrature`] needs to follow shadow lines.
struct Shadow<'a> {
    visible: &'a dyn Fn(DVec3) -> bool,
    /// The polygon's corners disagree: every piece checks its corners too.
    crossed: bool,
    /// Most extra splits of a crossed piece.
    splits: u32,
}

/// The quadrature behind [`polygon_quadrature_split`] and [`polygon_quadrature_visible`].
#[allow(clippy::too_many_arguments)]
fn quadrature(
    position: DVec3,
    radius_m: f64,
    polygon: &[DVec3],
    normal: DVec3,
    split: f64,
    max_piece_m: f64,
    shadow: Option<Shadow<'_>>,
    mut visit: impl FnMut(DVec3, f64, DVec3),
) {
    let visible = shadow.as_ref().map(|s| s.visible);
    let crossed_polygon = shadow.as_ref().is_some_and(|s| s.crossed);
    let max_splits = shadow.as_ref().map_or(0, |s| s.splits);
    let split2 = split * split;
    let max_piece2 = max_piece_m * max_piece_m;
    if (polygon[0] - position).dot(normal) >= 0.0 {
        return; // the source is behind (or in the plane of) the polygon
    }
    // Each piece with its depth and the shadow splits it took.
    let mut stack: Vec<([DVec3; 3], u32, u32)> = (1..polygon.len() - 1)
        .map(|k| {
            (
                [
                    polygon[0] - position,
                    polygon[k] - position,
                    polygon[k + 1] - position,
                ],
                0,
                0,
            )
        })
        .collect();
    while let Some(([a, b, c], depth, shadow)) = stack.pop() {
        let mid = (a + b + c) / 3.0;
        let r2 = mid.length_squared();
        let longest2 = (b - a)
            .length_squared()
            .max((c - b).length_squared())
            .max((a - c).length_squared());
        if longest2 > (r2 * split2).min(max_piece2) && depth < MAX_SPLIT_DEPTH {
            stack.extend(triangle_quarters([a, b, c]).map(|tri| (tri, depth + 1, shadow)));
            continue;
        }
        let points = [(a + b) / 2.0, (b + c) / 2.0, (c + a) / 2.0];
        let seen = visible.map_or([true; 3], |v| points.map(|q| v(position + q)));
        // Inside a crossed polygon or piece the corners are checked too: a straight line through
        // a triangle always leaves a corner on each side, so no crossed part is missed there.
        let crossed = |seen: &[bool]| seen.contains(&true) && seen.contains(&false);
        let corners_differ = || {
            visible.is_some_and(|v| {
                let corners = [a, b, c].map(|q| v(position + q));
                crossed(&[corners[0], corners[1], corners[2], seen[0]])
            })
        };
        let check_corners = shadow > 0 || crossed_polygon;
        if shadow < max_splits && (crossed(&seen) || (check_corners && corners_differ())) {
            stack.extend(triangle_quarters([a, b, c]).map(|tri| (tri, depth + 1, shadow + 1)));
            continue;
        }
        // Edge-midpoint rule on the flat triangle (exact for quadratics) applied to the solid-angle
        // density, which is ∝ 1/|q|³ on a plane; the weights are rescaled to the exact solid angle.
        let omega = triangle_solid_angle(a, b, c);
        let density = points.map(|q| {
            let r2 = q.length_squared();
            1.0 / (r2 * r2.sqrt())
        });
        let norm = omega / (density[0] + density[1] + density[2]);
        for ((q, d), seen) in points.into_iter().zip(density).zip(seen) {
            if !seen {
                continue;
            }
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

/// The receivers of a scene's fine mesh: every vertex with its surface normal.
pub fn fine_receivers(scene: &crate::scene::Scene) -> Vec<Receiver> {
    scene
        .fine
        .positions
        .iter()
        .zip(&scene.fine.normals)
        .map(|(&point, &normal)| Receiver { point, normal })
        .collect()
}

/// Exact direct illuminance (lx) of all of a scene's lights at arbitrary receivers, with
/// visibility when the scene has occluders. Coloured lights count with [`luminance_weight`].
pub fn scene_direct_at(scene: &crate::scene::Scene, receivers: &[Receiver]) -> Vec<f64> {
    let occluders = crate::transport::occlusion::Occluders::of_scene(scene);
    lights_direct_at(scene, occluders.as_ref(), receivers, Dimmers::AsSet)
}

/// How the lights' dimmers count in [`lights_direct_at`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dimmers {
    /// Each light at its dimmer.
    AsSet,
    /// Every light at full output (what the light can do, whatever its dimmer now).
    Full,
}

/// [`scene_direct_at`] with the scene's `occluders` already built (`None`: nothing occludes)
/// and the lights' dimmers counted as `dimmers` says.
pub fn lights_direct_at(
    scene: &crate::scene::Scene,
    occluders: Option<&crate::transport::occlusion::Occluders>,
    receivers: &[Receiver],
    dimmers: Dimmers,
) -> Vec<f64> {
    let vis = occluders.map(|o| o as &dyn Visibility);
    receivers
        .par_iter()
        .map(|rx| {
            scene
                .lights
                .iter()
                .map(|l| luminance_weight(l.color) * light_direct_at(l, rx, vis, dimmers))
                .sum()
        })
        .collect()
}

/// [`lights_direct_at`] per channel: the direct irradiance (lx, linear RGB, the lights'
/// colours applied) of all of a scene's lights at `receivers`.
pub fn lights_direct_rgb_at(
    scene: &crate::scene::Scene,
    occluders: Option<&crate::transport::occlusion::Occluders>,
    receivers: &[Receiver],
    dimmers: Dimmers,
) -> Vec<[f64; 3]> {
    let vis = occluders.map(|o| o as &dyn Visibility);
    receivers
        .par_iter()
        .map(|rx| {
            scene.lights.iter().fold([0.0; 3], |sum, l| {
                let e = light_direct_at(l, rx, vis, dimmers);
                std::array::from_fn(|ch| sum[ch] + l.color[ch] * e)
            })
        })
        .collect()
}

/// The direct illuminance (lx, colour not applied) of light `l` at `rx`.
fn light_direct_at(
    l: &crate::scene::Light,
    rx: &Receiver,
    vis: Option<&dyn Visibility>,
    dimmers: Dimmers,
) -> f64 {
    let scale = match dimmers {
        Dimmers::AsSet => l.dimmer,
        Dimmers::Full => 1.0,
    };
    illuminance_at(l.position, l.radius, &l.curve, l.aim, scale, rx, vis)
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

    /// A 5 cm patch 3 m below an isotropic source, a hard shadow line crossing it at `x = s`:
    /// the visible solid angle is that of the lit rectangle (exact here to 10⁻⁸). As one piece
    /// (the patch direct light's usual size) its six edge-midpoint samples give 1/6 or 5/6 of the
    /// patch wherever the line falls; split along the line it is within 2 % of the lit part.
    #[test]
    fn a_shadow_line_through_a_piece_is_resolved() {
        let source = DVec3::new(0.0, 0.0, 3.0);
        let rect = |x0: f64, x1: f64| {
            [
                DVec3::new(x0, 0.0, 0.0),
                DVec3::new(x1, 0.0, 0.0),
                DVec3::new(x1, 0.05, 0.0),
                DVec3::new(x0, 0.05, 0.0),
            ]
        };
        let patch = rect(0.0, 0.05);
        let whole = polygon_flux(source, 0.0, &patch, DVec3::Z, |_| 1.0);
        for s in [0.003, 0.011, 0.02, 0.031, 0.047] {
            let lit = polygon_flux(source, 0.0, &rect(0.0, s), DVec3::Z, |_| 1.0);
            let visible = |q: DVec3| q.x < s;
            let mut flux = 0.0;
            // Split 1 (one piece per fan triangle) as the patch direct light makes it.
            polygon_quadrature_visible(
                source,
                0.0,
                &patch,
                DVec3::Z,
                1.0,
                f64::INFINITY,
                SHADOW_SPLIT_DEPTH,
                &visible,
                |_, w, _| flux += w,
            );
            assert!(
                (flux - lit).abs() < 0.02 * whole,
                "line at {s}: {flux} against {lit} ({:.3} of the patch)",
                (flux - lit) / whole
            );
            let mut unresolved = 0.0;
            polygon_quadrature_split(source, 0.0, &patch, DVec3::Z, 1.0, |_, w, q| {
                if visible(q) {
                    unresolved += w;
                }
            });
            let fraction = unresolved / whole;
            assert!(
                [0.0, 1.0 / 6.0, 0.5, 5.0 / 6.0, 1.0]
                    .iter()
                    .any(|f| (fraction - f).abs() < 0.01),
                "without the shadow splits the samples decide: {fraction}"
            );
        }
    }
}
