//! Which pieces of the room's own edges the solver mesh is graded towards (docs/DECISIONS.md
//! "Room edges are graded where the direct light bends").
//!
//! A point a few centimetres from a room edge sees the other surface's first decimetres over
//! almost half its hemisphere, so its indirect light follows that strip's radiosity. A coarse
//! leaf's linear radiosity follows it where the light on both surfaces next to the edge is
//! about linear across one leaf; where the direct light there bends — a spot's pool ending
//! 0.26 m from a wall, an up-light's 1/r³ fall-off on the ceiling beside a wall — both surfaces
//! are graded along that piece of the edge. So is a piece where the light is straight but
//! steep beside a surface the lights leave dark (a batwing under the ceiling lighting the
//! walls' tops): the solve holds a leaf's radiosity as its mean, which the dark surface beside
//! the edge then receives instead of the edge's own light ([`edge_step`]). The light sampled
//! is the lamps' own plus that of each lamp's spot on a room plane it almost touches
//! ([`ReflectedSpot`]): a lamp 1 cm under the ceiling lights the walls' tops through it. Where
//! the light near an edge is smooth (a downlight's gentle fall-off towards the walls) the
//! coarse leaves are kept: grading every edge doubles a small room's links.
//!
//! Every light counts at full output, whatever its dimmer: the grading follows what the lights
//! can do, so a dimmer edit never calls for another mesh.
//!
//! World frame: metres, z up; illuminance in lux.

use glam::DVec3;

use crate::scene::mesher::cells_between;
use crate::scene::{Aabb, Receiver, Scene};
use crate::transport::direct::{Dimmers, lights_direct_at, luminance_weight};
use crate::transport::occlusion::Occluders;
use crate::transport::visibility::Visibility;

/// Depths (as fractions of a profile's depth, below) at which the direct light is sampled
/// across an edge, on each side; the first is [`FIRST_DEPTH_M`] instead.
const DEPTHS: [f64; 5] = [0.0, 0.25, 0.5, 0.75, 1.0];
/// The two sample profiles across an edge, on each side: (depth in pieces, tolerance factor,
/// whether the bend along the edge is looked for). One piece deep at the tolerance; two pieces
/// deep at 5 times it, for a pool ending a little more than one piece from a wall, which
/// lights that wall's foot unevenly, without grading every gentle fall-off over 1 m
/// (docs/DECISIONS.md "Room edges are graded where the direct light bends").
const PROFILES: [(f64, f64, bool); 2] = [(1.0, 1.0, true), (2.0, 5.0, false)];
/// The first sample's depth (m) from the edge (the edge itself is where the two surfaces meet).
const FIRST_DEPTH_M: f64 = 0.01;
/// Positions along a piece (fractions of its length) where the light across the edge is sampled.
const ALONG: [f64; 5] = [0.1, 0.3, 0.5, 0.7, 0.9];
/// Fraction of a point's view (cosine-weighted) that the other surface's strip of one coarse
/// leaf covers near the edge: `(1 − d / √(d² + w²)) / 2` is 0.45 at d = w/10 (5 cm from a
/// 0.5 m leaf) and 0.4 at d = w/5.
const EDGE_VIEW: f64 = 0.4;

/// A room plane: the axis it is normal to and whether it lies at the room's far side.
#[derive(Debug, Clone, Copy, PartialEq)]
struct RoomPlane {
    axis: usize,
    far: bool,
}

impl RoomPlane {
    /// The name of the room surface on this plane (as the mesher names it).
    fn surface_name(self) -> &'static str {
        match (self.axis, self.far) {
            (0, false) => "wall-x0",
            (0, true) => "wall-x1",
            (1, false) => "wall-y0",
            (1, true) => "wall-y1",
            (_, false) => "floor",
            (_, true) => "ceiling",
        }
    }

    /// The reflectance (largest channel) of the room surface on this plane; 0 when the scene
    /// has none.
    fn reflectance(self, scene: &Scene) -> f64 {
        let name = self.surface_name();
        scene
            .surfaces
            .iter()
            .find(|s| s.name == name)
            .map_or(0.0, |s| s.reflectance.max())
    }

    /// Every room plane.
    fn all() -> impl Iterator<Item = RoomPlane> {
        (0..3).flat_map(|axis| [false, true].map(|far| RoomPlane { axis, far }))
    }

    /// Unit normal into the room.
    fn normal(self) -> DVec3 {
        let mut n = DVec3::ZERO;
        n[self.axis] = if self.far { -1.0 } else { 1.0 };
        n
    }
}

/// A piece of a room edge along which the direct light next to it bends.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BendingPiece {
    /// The piece as a degenerate box (zero extent in two axes).
    pub segment: Aabb,
    /// Whether the light bends along the edge too (a pool narrower than the piece, centred
    /// near it), not only across it.
    pub along: bool,
}

/// The pieces of the room's twelve edges, about `piece_m` long, along which the direct light on
/// either surface next to the edge bends enough, across or along the edge within `piece_m`, for
/// the indirect light a few centimetres from the edge to be off by more than `tolerance` of the
/// room's indirect irradiance.
pub fn bending_edge_pieces(scene: &Scene, piece_m: f64, tolerance: f64) -> Vec<BendingPiece> {
    let size = scene.room_size;
    let reflectance = |plane: RoomPlane| plane.reflectance(scene);
    // Every piece with its axis and two sides: the plane, the direction into the room along it,
    // its reflectance and, per profile, the sample depths (m).
    let mut pieces = Vec::new();
    for along in 0..3 {
        let (a, b) = ((along + 1) % 3, (along + 2) % 3);
        // As many pieces as the mesher makes patches along the edge.
        let n = cells_between(0.0, size[along], piece_m) as usize;
        let step = size[along] / n as f64;
        for far_a in [false, true] {
            for far_b in [false, true] {
                let (plane_a, plane_b) = (
                    RoomPlane { axis: a, far: far_a },
                    RoomPlane { axis: b, far: far_b },
                );
                // The plane normal to `a` reaches into the room along `b`, and the other way.
                let sides =
                    [(plane_a, plane_b, b), (plane_b, plane_a, a)].map(|(plane, other, reach_axis)| Side {
                        plane,
                        inward: other.normal(),
                        rho: reflectance(plane),
                        depths: PROFILES.map(|(pieces_deep, _, _)| {
                            let width = (pieces_deep * piece_m).min(size[reach_axis]);
                            DEPTHS.map(|depth| (depth * width).max(FIRST_DEPTH_M))
                        }),
                    });
                let mut base = DVec3::ZERO;
                base[a] = if far_a { size[a] } else { 0.0 };
                base[b] = if far_b { size[b] } else { 0.0 };
                for i in 0..n {
                    let (mut min, mut max) = (base, base);
                    min[along] = i as f64 * step;
                    max[along] = (i + 1) as f64 * step;
                    pieces.push((Aabb { min, max }, along, sides));
                }
            }
        }
    }
    // The direct light at every sample point of every piece, in one parallel call: per piece,
    // side and profile, `ALONG.len()` rows of `DEPTHS.len()` samples.
    let mut receivers = Vec::new();
    for (piece, along, sides) in &pieces {
        for side in sides {
            let normal = side.plane.normal();
            for depths in &side.depths {
                for t in ALONG {
                    let mut p = piece.min;
                    p[*along] += t * (piece.max[*along] - piece.min[*along]);
                    receivers.extend(depths.iter().map(|&d| Receiver {
                        point: p + side.inward * d + normal * 1e-6,
                        normal,
                    }));
                }
            }
        }
    }
    // A sample inside a box standing against the wall (or on the floor) is no light of the room
    // surface: its rows and columns are left out (NaN, which `bend` skips).
    // The spots of lights almost touching a room plane light the other surfaces as lights of
    // their own: their light counts with the direct light.
    let occluders = Occluders::of_scene(scene);
    let spots = reflected_spots(scene, SPOT_RADIUS_PIECES * piece_m, occluders.as_ref());
    let mut lux = lights_direct_at(scene, occluders.as_ref(), &receivers, Dimmers::Full);
    for (e, rx) in lux.iter_mut().zip(&receivers) {
        if scene.boxes.iter().any(|b| b.contains_strictly(rx.point)) {
            *e = f64::NAN;
        } else {
            *e += spots
                .iter()
                .map(|spot| spot.illuminance_at(rx, occluders.as_ref()))
                .sum::<f64>();
        }
    }
    let spot_flux = spots.iter().map(|spot| spot.received_lm).sum();
    let indirect = indirect_scale(scene, occluders.as_ref(), spot_flux);
    let per_profile = ALONG.len() * DEPTHS.len();
    let mut rows = lux.chunks(per_profile);
    let mut out = Vec::new();
    for (piece, along, sides) in &pieces {
        let length = piece.max[*along] - piece.min[*along];
        let positions = ALONG.map(|t| t * length);
        let (mut across_bends, mut along_bends) = (false, false);
        // Per side and profile, row `a` holds the depths at along-position `a`.
        let blocks: [[&[f64]; PROFILES.len()]; 2] = std::array::from_fn(|_| {
            std::array::from_fn(|_| rows.next().expect("one block of samples per side and profile"))
        });
        for (s, side) in sides.iter().enumerate() {
            for ((depths, &(_, factor, look_along)), e) in side.depths.iter().zip(&PROFILES).zip(blocks[s]) {
                let off = |bend: f64| side.rho * EDGE_VIEW * bend > factor * tolerance * indirect;
                across_bends |= e.chunks(DEPTHS.len()).any(|row| off(bend(depths, row)));
                along_bends |= look_along
                    && (0..DEPTHS.len()).any(|d| {
                        let column: Vec<f64> = (0..ALONG.len()).map(|a| e[a * DEPTHS.len() + d]).collect();
                        off(bend(&positions, &column))
                    });
            }
            // The step over the one-piece profile, against the light the other surface has at
            // the edge at the same place along it (its first sample).
            let (own, other) = (blocks[s][0], blocks[1 - s][0]);
            across_bends |= own
                .chunks(DEPTHS.len())
                .zip(other.chunks(DEPTHS.len()))
                .any(|(row, beside)| {
                    let level = indirect + beside[0].max(0.0);
                    side.rho * EDGE_VIEW * edge_step(row) > STEP_FACTOR * tolerance * level
                });
        }
        if across_bends || along_bends {
            out.push(BendingPiece {
                segment: *piece,
                along: along_bends,
            });
        }
    }
    out
}

/// How many times the tolerance the edge's own light may differ from the mean over one piece
/// across it ([`edge_step`]) before the piece is graded: a steep but straight profile, which a
/// leaf's constant radiosity in the solve cannot follow either.
const STEP_FACTOR: f64 = 4.0;

/// How far the light at the edge (the first sample) is from the mean of the samples across it;
/// 0 when a value is NaN (a sample left out).
fn edge_step(values: &[f64]) -> f64 {
    if values.iter().any(|v| v.is_nan()) {
        return 0.0;
    }
    let mean = values.iter().sum::<f64>() / values.len() as f64;
    (values[0] - mean).abs()
}

/// One surface beside a piece of room edge, as sampled.
#[derive(Debug, Clone, Copy)]
struct Side {
    plane: RoomPlane,
    /// Unit direction from the edge into the room along the plane.
    inward: DVec3,
    /// The surface's reflectance (largest channel).
    rho: f64,
    /// Per profile of [`PROFILES`], the sample depths (m) from the edge.
    depths: [[f64; DEPTHS.len()]; PROFILES.len()],
}

/// The largest deviation of `values` at `x` from their least-squares line; 0 when a value is
/// NaN (a sample left out).
fn bend(x: &[f64], values: &[f64]) -> f64 {
    if values.iter().any(|v| v.is_nan()) {
        return 0.0;
    }
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, values.iter().sum::<f64>() / n);
    let sxx: f64 = x.iter().map(|&xi| (xi - mx) * (xi - mx)).sum();
    let sxy: f64 = x.iter().zip(values).map(|(&xi, &yi)| (xi - mx) * (yi - my)).sum();
    let slope = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    x.iter()
        .zip(values)
        .map(|(&xi, &yi)| (yi - my - slope * (xi - mx)).abs())
        .fold(0.0, f64::max)
}

/// The room's indirect irradiance (lx) by the integrating-sphere estimate: the area-weighted
/// mean direct irradiance of the coarse patches, with `extra_lm` (the flux of spots their
/// centroids miss) spread over their area, times `ρ̄ / (1 − ρ̄)`, `ρ̄` their area-weighted mean
/// reflectance.
fn indirect_scale(scene: &Scene, occluders: Option<&Occluders>, extra_lm: f64) -> f64 {
    let patches = &scene.coarse.patches;
    let receivers: Vec<Receiver> = patches
        .iter()
        .map(|p| Receiver {
            point: p.centroid + p.normal * 1e-6,
            normal: p.normal,
        })
        .collect();
    let lux = lights_direct_at(scene, occluders, &receivers, Dimmers::Full);
    let (mut area, mut flux, mut rho) = (0.0, 0.0, 0.0);
    for (p, e) in patches.iter().zip(lux) {
        area += p.area;
        flux += p.area * e;
        rho += p.area * scene.surfaces[p.surface as usize].reflectance.max();
    }
    if area <= 0.0 {
        return 0.0;
    }
    let rho = (rho / area).min(0.99);
    (flux + extra_lm) / area * rho / (1.0 - rho)
}

/// The radius of a light's spot on a room plane, in pieces: a light closer to the plane than
/// this is taken to make a spot there that lights the room as a light of its own.
const SPOT_RADIUS_PIECES: f64 = 0.5;
/// Steps of a spot's flux quadrature: polar angle about the plane's normal, and azimuth.
const SPOT_STEPS: (usize, usize) = (48, 24);

/// The bright spot a light makes on a room plane it almost touches, taken as a light of its own
/// (docs/DECISIONS.md "Room edges are graded where the direct light bends"): a lamp 1 cm under
/// a white ceiling sends its up-light onto a few square centimetres of it, which then light the
/// walls' tops at grazing incidence, in the steep profile a batwing's own light has there. Its
/// light on the room is the plane's Lambertian reflection of the flux landing within the spot's
/// radius, from the light's foot on the plane.
#[derive(Debug, Clone, Copy, PartialEq)]
struct ReflectedSpot {
    /// The light's foot on the plane (world, m).
    position: DVec3,
    /// The plane's unit normal into the room.
    normal: DVec3,
    /// The flux (lm) the light sends onto the plane within the spot's radius, at full output.
    received_lm: f64,
    /// The spot's intensity (cd) along the normal: `ρ · received_lm / π`.
    intensity_cd: f64,
}

impl ReflectedSpot {
    /// The spot's illuminance (lx) at `rx`: `I cos θ_out cos θ_in / r²`, 0 where blocked.
    fn illuminance_at(&self, rx: &Receiver, occluders: Option<&Occluders>) -> f64 {
        let d = rx.point - self.position;
        let r2 = d.length_squared();
        if r2 < 1e-12 {
            return 0.0;
        }
        let r = r2.sqrt();
        let (cos_out, cos_in) = (self.normal.dot(d) / r, -rx.normal.dot(d) / r);
        if cos_out <= 0.0 || cos_in <= 0.0 {
            return 0.0;
        }
        if occluders.is_some_and(|o| !o.visible(self.position + self.normal * 1e-4, rx.point)) {
            return 0.0;
        }
        self.intensity_cd * cos_out * cos_in / r2
    }
}

/// The spots of every light closer to a room plane than `radius_m` (and not on it), each light
/// at full output: the flux it sends within `radius_m` of its foot, by a quadrature over the
/// cone of directions to that disc (`dω = sin t dt dφ`, `t` from the plane's normal).
fn reflected_spots(scene: &Scene, radius_m: f64, occluders: Option<&Occluders>) -> Vec<ReflectedSpot> {
    let (steps_t, steps_phi) = SPOT_STEPS;
    let mut spots = Vec::new();
    for light in &scene.lights {
        for plane in RoomPlane::all() {
            let coordinate = if plane.far {
                scene.room_size[plane.axis]
            } else {
                0.0
            };
            let height = (light.position[plane.axis] - coordinate).abs();
            if height <= 0.0 || height >= radius_m {
                continue;
            }
            let normal = plane.normal();
            let mut position = light.position;
            position[plane.axis] = coordinate;
            let (u, v) = normal.any_orthonormal_pair();
            let cone = (radius_m / height).atan();
            let (dt, dphi) = (cone / steps_t as f64, std::f64::consts::TAU / steps_phi as f64);
            let mut received_lm = 0.0;
            for i in 0..steps_t {
                let t = (i as f64 + 0.5) * dt;
                for j in 0..steps_phi {
                    let phi = (j as f64 + 0.5) * dphi;
                    let dir = -normal * t.cos() + (u * phi.cos() + v * phi.sin()) * t.sin();
                    let hit = light.position + dir * (height / t.cos());
                    if occluders.is_some_and(|o| !o.visible(light.position, hit)) {
                        continue;
                    }
                    let gamma = light.aim.dot(dir).clamp(-1.0, 1.0).acos();
                    received_lm += light.curve.eval_rad(gamma) * t.sin() * dt * dphi;
                }
            }
            received_lm *= luminance_weight(light.color);
            if received_lm > 0.0 {
                spots.push(ReflectedSpot {
                    position,
                    normal,
                    received_lm,
                    intensity_cd: plane.reflectance(scene) * received_lm / std::f64::consts::PI,
                });
            }
        }
    }
    spots
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The refinement tests' 4 × 3 × 2.5 m room with its light at `position` (aimed down) and
    /// the curve `lid`.
    fn room(position: &str, lid: &str) -> Scene {
        crate::scene::load::test_room(
            &crate::transport::refine::tests::EMPTY
                .replace("[2.0, 1.5, 1.2]", position)
                .replace("[[0, 100], [90, 0]]", lid),
        )
    }

    /// A step from 0 to 1 between the third and fourth of five samples: its least-squares line
    /// is 0.4 + 0.3 (x − 2), farthest from the third sample (0.4); a line does not bend.
    #[test]
    fn bend_is_the_largest_deviation_from_the_fitted_line() {
        let x = [0.0, 1.0, 2.0, 3.0, 4.0];
        assert!((bend(&x, &[0.0, 0.0, 0.0, 1.0, 1.0]) - 0.4).abs() < 1e-12);
        assert!(bend(&x, &[3.0, 2.5, 2.0, 1.5, 1.0]) < 1e-12);
    }

    /// The edge sample's distance from the mean of its profile; a profile with a sample left
    /// out has none.
    #[test]
    fn edge_step_is_the_first_samples_distance_from_the_mean() {
        assert!((edge_step(&[1.0, 2.0, 3.0, 4.0, 5.0]) - 2.0).abs() < 1e-12);
        assert!((edge_step(&[5.0, 1.0, 1.0, 1.0, 1.0]) - 3.2).abs() < 1e-12);
        assert_eq!(edge_step(&[1.0, f64::NAN, 3.0, 4.0, 5.0]), 0.0);
    }

    /// A batwing 5 cm under the ceiling (peak at 60°, still 120 cd at the horizontal) lights
    /// each wall's top in a straight, steep profile — a third of the light at the ceiling that
    /// it has 0.5 m lower — beside a ceiling it hardly lights: a leaf's constant radiosity in the
    /// solve gives the ceiling beside the wall the wall's mean instead of its dim top (a
    /// Monte-Carlo reference room like it was 7 % high there). The step grades at least the four
    /// middle pieces of each end wall's top; the bend test alone graded none of them (checked by
    /// setting `STEP_FACTOR` out of reach). The floor's edges, under the batwing's gentle light,
    /// stay as they are.
    #[test]
    fn a_steep_straight_profile_beside_a_dark_surface_grades_the_edge() {
        let batwing = "[[0, 300], [30, 550], [60, 900], [75, 500], [90, 120], [100, 60], [110, 0], [180, 0]]";
        let pieces = bending_edge_pieces(&room("[2.0, 1.5, 2.45]", batwing), 0.5, 0.02);
        for x in [0.0, 4.0] {
            let end_wall = pieces
                .iter()
                .filter(|p| {
                    let g = p.segment;
                    g.min.x == x && g.max.x == x && g.min.z == 2.5 && g.max.z == 2.5
                })
                .count();
            assert!(end_wall >= 4, "the wall x = {x}'s top: {pieces:?}");
        }
        assert!(
            pieces
                .iter()
                .all(|p| p.segment.min.z == 2.5 && p.segment.max.z == 2.5),
            "the walls' tops only: {pieces:?}"
        );
    }

    /// A light of 100 cd in every direction 5 cm under the ceiling sends
    /// `2π I (1 − h / √(R² + h²))` = 505.1 lm onto the ceiling within R = 0.25 m of its foot:
    /// one spot there (the other planes are farther than R), whose intensity is the ceiling's
    /// ρ = 0.7 times that over π.
    #[test]
    fn a_spots_flux_is_what_the_light_sends_within_its_radius() {
        let s = room("[2.0, 1.5, 2.45]", "[[0, 100], [180, 100]]");
        let spots = reflected_spots(&s, 0.25, None);
        assert_eq!(spots.len(), 1, "{spots:?}");
        let spot = spots[0];
        let (h, r) = (0.05_f64, 0.25_f64);
        let expected = std::f64::consts::TAU * 100.0 * (1.0 - h / (r * r + h * h).sqrt());
        assert!(
            (spot.received_lm / expected - 1.0).abs() < 1e-3,
            "{} vs {expected}",
            spot.received_lm
        );
        assert!((spot.intensity_cd - 0.7 * spot.received_lm / std::f64::consts::PI).abs() < 1e-9);
        assert_eq!(
            (spot.position, spot.normal),
            (glam::DVec3::new(2.0, 1.5, 2.5), glam::DVec3::NEG_Z)
        );
    }

    /// An up-light 1 cm under the ceiling whose light leaves at least 10° above the horizontal
    /// lands all of it within 6 cm of its foot: no wall gets any of its direct light, so the
    /// direct light bends and steps nowhere. Its spot then lights the walls' tops at grazing
    /// incidence (nothing at the ceiling, rising downwards) beside a ceiling left dark: the step
    /// grades the tops of the long walls, 1.5 m from it, along their middle 3 m (the end walls,
    /// 2 m away, get a flatter profile), and nothing else (a Monte-Carlo reference room with
    /// such a lamp was 6 % high on the ceiling 2 cm from a wall before the spots counted).
    #[test]
    fn a_lamps_spot_on_the_ceiling_grades_the_walls_tops() {
        let s = room("[2.0, 1.5, 2.49]", "[[0, 0], [90, 0], [100, 300], [180, 350]]");
        assert_eq!(reflected_spots(&s, 0.25, None).len(), 1);
        let pieces = bending_edge_pieces(&s, 0.5, 0.02);
        for y in [0.0, 3.0] {
            let top: Vec<(f64, f64)> = pieces
                .iter()
                .map(|p| p.segment)
                .filter(|g| g.min.y == y && g.max.y == y && g.min.z == 2.5 && g.max.z == 2.5)
                .map(|g| (g.min.x, g.max.x))
                .collect();
            assert_eq!(
                top,
                [
                    (0.5, 1.0),
                    (1.0, 1.5),
                    (1.5, 2.0),
                    (2.0, 2.5),
                    (2.5, 3.0),
                    (3.0, 3.5)
                ],
                "the top of the wall y = {y}: {pieces:?}"
            );
        }
        assert_eq!(pieces.len(), 12, "the long walls' tops only: {pieces:?}");
    }

    /// A hard-edged 40° spot 2.4 m above (2, 1) lights a floor pool of radius 0.87 m, which ends
    /// 0.13 m from the wall y = 0 and 1.13 m or more from the other walls: the floor/wall edge at
    /// y = 0 bends under the pool (x 1–3, four 0.5 m pieces) and nowhere else.
    #[test]
    fn a_pool_ending_near_a_wall_bends_that_edge_only() {
        let s = room("[2.0, 1.0, 2.4]", "[[0, 5000], [20, 5000], [20, 0], [180, 0]]");
        let pieces = bending_edge_pieces(&s, 0.5, 0.02);
        let mut spans: Vec<(f64, f64)> = pieces
            .iter()
            .map(|p| {
                let p = p.segment;
                assert_eq!([p.min.y, p.max.y, p.min.z, p.max.z], [0.0; 4], "{p:?}");
                (p.min.x, p.max.x)
            })
            .collect();
        spans.sort_by(|a, b| a.0.total_cmp(&b.0));
        assert_eq!(spans, [(1.0, 1.5), (1.5, 2.0), (2.0, 2.5), (2.5, 3.0)]);
        // The light counts at full output: switched off, it grades the same pieces.
        let mut off = s.clone();
        off.lights[0].dimmer = 0.0;
        assert_eq!(bending_edge_pieces(&off, 0.5, 0.02), pieces);
    }

    /// A soft downlight hung 1.5 m up in the middle of the room lights the floor and the walls'
    /// lower parts smoothly and leaves the ceiling and the walls' tops dark: no edge bends. The
    /// same light 0.1 m under the ceiling bends the walls' top edges only: its horizon, where the
    /// wall goes dark, lies 0.1 m under them (the long walls' profiles bend there; the end walls',
    /// 2 m away, are straighter but step from their dark top to a bright mean beside a ceiling
    /// the light leaves dark: [`edge_step`]).
    #[test]
    fn a_lamps_horizon_bends_the_walls_tops_and_a_smooth_light_no_edge() {
        let lid = "[[0, 100], [30, 95], [60, 70], [90, 0]]";
        let high = bending_edge_pieces(&room("[2.0, 1.5, 2.4]", lid), 0.5, 0.02);
        assert!(!high.is_empty());
        assert!(high.iter().any(|p| p.segment.min.y == p.segment.max.y));
        assert!(
            high.iter()
                .all(|p| p.segment.min.z == 2.5 && p.segment.max.z == 2.5)
        );
        let s = room("[2.0, 1.5, 1.5]", lid);
        assert_eq!(bending_edge_pieces(&s, 0.5, 0.02), Vec::new());
        // A box standing against the wall y = 0 under that light (x 1.2–2.2): the samples inside
        // it are left out, so the piece it covers (x 1.5–2) does not bend, while its shadow on
        // the floor and the wall beside it does.
        let boxed = crate::scene::load::test_room(
            &crate::transport::refine::tests::EMPTY
                .replace("[2.0, 1.5, 1.2]", "[2.0, 1.5, 1.5]")
                .replace("[[0, 100], [90, 0]]", lid)
                .replace(
                    "[[light]]",
                    "[[box]]\nmin = [1.2, 0.0, 0.0]\nmax = [2.2, 0.4, 0.9]\nreflectance = 0.5\n[[light]]",
                ),
        );
        let boxed = bending_edge_pieces(&boxed, 0.5, 0.02);
        assert!(
            !boxed
                .iter()
                .any(|p| p.segment.min.x == 1.5 && p.segment.max.x == 2.0),
            "{boxed:?}"
        );
    }

    /// A hard 10° spot 0.1 m under the ceiling aimed at the wall x = 4 makes a pool 0.5 m wide
    /// just under the ceiling: the wall/ceiling edge above it bends along the edge as well as
    /// across it (the cells there are kept short along the edge); a soft light's horizon 0.1 m
    /// under the ceiling, a straight line along the walls, bends them across only.
    #[test]
    fn a_narrow_pool_bends_its_edge_along_it_too() {
        let mut s = room("[2.5, 1.5, 2.4]", "[[0, 8000], [10, 8000], [10, 0], [180, 0]]");
        s.lights[0].aim = glam::DVec3::new(1.5, 0.0, -0.4).normalize();
        let pieces = bending_edge_pieces(&s, 0.5, 0.02);
        let above = pieces
            .iter()
            .find(|p| {
                let g = p.segment;
                g.min.x == 4.0 && g.min.z == 2.5 && g.min.y <= 1.5 && g.max.y >= 1.5
            })
            .expect("the piece above the pool bends");
        assert!(above.along, "{above:?}");
        let horizon = bending_edge_pieces(
            &room("[2.0, 1.5, 2.4]", "[[0, 100], [30, 95], [60, 70], [90, 0]]"),
            0.5,
            0.02,
        );
        assert!(
            !horizon.is_empty() && horizon.iter().all(|p| !p.along),
            "{horizon:?}"
        );
    }
}
