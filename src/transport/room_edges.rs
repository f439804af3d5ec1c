//! Which pieces of the room's own edges the solver mesh is graded towards (docs/DECISIONS.md
//! "Room edges are graded where the direct light bends").
//!
//! A point a few centimetres from a room edge sees the other surface's first decimetres over
//! almost half its hemisphere, so its indirect light follows that strip's radiosity. A coarse
//! leaf's linear radiosity follows it where the light on both surfaces next to the edge is
//! about linear across one leaf; where the direct light there bends — a spot's pool ending
//! 0.26 m from a wall, an up-light's 1/r³ fall-off on the ceiling beside a wall — both surfaces
//! are graded along that piece of the edge. Where the direct light near an edge is smooth (a
//! downlight's gentle fall-off towards the walls) the coarse leaves are kept: grading every edge
//! doubles a small room's links.
//!
//! World frame: metres, z up; illuminance in lux.

use glam::DVec3;

use crate::scene::{Aabb, Receiver, Scene};
use crate::transport::direct::scene_direct_at;

/// Depths (as fractions of the piece length) at which the direct light is sampled across an
/// edge, on each side; the first is [`FIRST_DEPTH_M`] instead.
const DEPTHS: [f64; 5] = [0.0, 0.25, 0.5, 0.75, 1.0];
/// The first sample's depth (m) from the edge (the edge itself is where the two surfaces meet).
const FIRST_DEPTH_M: f64 = 0.01;
/// Positions along a piece (fractions of its length) where the light across the edge is sampled.
const ALONG: [f64; 3] = [1.0 / 6.0, 0.5, 5.0 / 6.0];
/// Fraction of a point's view (cosine-weighted) that the other surface's strip of one coarse
/// leaf covers, a few centimetres from the edge (`(1 − d / √(d² + w²)) / 2` with d ≪ w).
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

    /// Unit normal into the room.
    fn normal(self) -> DVec3 {
        let mut n = DVec3::ZERO;
        n[self.axis] = if self.far { -1.0 } else { 1.0 };
        n
    }
}

/// The pieces of the room's twelve edges, about `piece_m` long, along which the direct light on
/// either surface next to the edge bends enough, across `piece_m`, for the indirect light a few
/// centimetres from the edge to be off by more than `tolerance` of the room's indirect
/// irradiance; each piece as a degenerate box (zero extent in two axes).
pub fn bending_edge_pieces(scene: &Scene, piece_m: f64, tolerance: f64) -> Vec<Aabb> {
    let size = scene.room_size;
    let reflectance = |plane: RoomPlane| {
        let name = plane.surface_name();
        scene
            .surfaces
            .iter()
            .find(|s| s.name == name)
            .map_or(0.0, |s| s.reflectance.mean())
    };
    // Every piece with its two sides: (piece, [(plane, direction into that plane, ρ)]).
    let mut pieces = Vec::new();
    for along in 0..3 {
        let (a, b) = ((along + 1) % 3, (along + 2) % 3);
        let n = (size[along] / piece_m).ceil().max(1.0) as usize;
        let step = size[along] / n as f64;
        for far_a in [false, true] {
            for far_b in [false, true] {
                let mut base = DVec3::ZERO;
                base[a] = if far_a { size[a] } else { 0.0 };
                base[b] = if far_b { size[b] } else { 0.0 };
                let into = |axis: usize, far: bool| {
                    let mut d = DVec3::ZERO;
                    d[axis] = if far { -1.0 } else { 1.0 };
                    d
                };
                // The plane normal to `a` reaches into the room along `b`, and the other way.
                let sides = [
                    (RoomPlane { axis: a, far: far_a }, into(b, far_b), size[b]),
                    (RoomPlane { axis: b, far: far_b }, into(a, far_a), size[a]),
                ];
                for i in 0..n {
                    let mut min = base;
                    let mut max = base;
                    min[along] = i as f64 * step;
                    max[along] = (i + 1) as f64 * step;
                    pieces.push((Aabb { min, max }, along, sides));
                }
            }
        }
    }
    // The direct light at every sample point of every piece, in one parallel call.
    let mut receivers = Vec::new();
    for (piece, along, sides) in &pieces {
        for &(plane, inward, reach) in sides {
            let width = piece_m.min(reach);
            for t in ALONG {
                let mut p = piece.min;
                p[*along] += t * (piece.max[*along] - piece.min[*along]);
                for depth in DEPTHS {
                    let d = (depth * width).max(FIRST_DEPTH_M);
                    receivers.push(Receiver {
                        point: p + inward * d + plane.normal() * 1e-6,
                        normal: plane.normal(),
                    });
                }
            }
        }
    }
    let lux = scene_direct_at(scene, &receivers);
    let indirect = indirect_scale(scene);
    let mut out = Vec::new();
    let per_side = ALONG.len() * DEPTHS.len();
    for (k, (piece, _, sides)) in pieces.iter().enumerate() {
        let bends = sides.iter().enumerate().any(|(s, &(plane, _, reach))| {
            let width = piece_m.min(reach);
            let depths = DEPTHS.map(|depth| (depth * width).max(FIRST_DEPTH_M));
            let start = (2 * k + s) * per_side;
            lux[start..start + per_side]
                .chunks(DEPTHS.len())
                .any(|e| reflectance(plane) * EDGE_VIEW * bend(&depths, e) > tolerance * indirect)
        });
        if bends {
            out.push(*piece);
        }
    }
    out
}

/// The largest deviation of `values` at `x` from their least-squares line.
fn bend(x: &[f64], values: &[f64]) -> f64 {
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
/// mean direct irradiance of the coarse patches times `ρ̄ / (1 − ρ̄)`, `ρ̄` their area-weighted
/// mean reflectance.
fn indirect_scale(scene: &Scene) -> f64 {
    let patches = &scene.coarse.patches;
    let receivers: Vec<Receiver> = patches
        .iter()
        .map(|p| Receiver {
            point: p.centroid + p.normal * 1e-6,
            normal: p.normal,
        })
        .collect();
    let lux = scene_direct_at(scene, &receivers);
    let (mut area, mut flux, mut rho) = (0.0, 0.0, 0.0);
    for (p, e) in patches.iter().zip(lux) {
        area += p.area;
        flux += p.area * e;
        rho += p.area * scene.surfaces[p.surface as usize].reflectance.mean();
    }
    if area <= 0.0 {
        return 0.0;
    }
    let rho = (rho / area).min(0.99);
    flux / area * rho / (1.0 - rho)
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
                assert_eq!([p.min.y, p.max.y, p.min.z, p.max.z], [0.0; 4], "{p:?}");
                (p.min.x, p.max.x)
            })
            .collect();
        spans.sort_by(|a, b| a.0.total_cmp(&b.0));
        assert_eq!(spans, [(1.0, 1.5), (1.5, 2.0), (2.0, 2.5), (2.5, 3.0)]);
    }

    /// A soft downlight hung 1.5 m up in the middle of the room lights the floor and the walls'
    /// lower parts smoothly and leaves the ceiling and the walls' tops dark: no edge bends. The
    /// same light 0.1 m under the ceiling bends the long walls' top edges (its horizon, where
    /// the wall goes dark, lies 0.1 m under them).
    #[test]
    fn smooth_light_bends_no_edge() {
        let lid = "[[0, 100], [30, 95], [60, 70], [90, 0]]";
        let high = bending_edge_pieces(&room("[2.0, 1.5, 2.4]", lid), 0.5, 0.02);
        assert!(!high.is_empty());
        assert!(
            high.iter()
                .all(|p| p.min.z == 2.5 && p.max.z == 2.5 && p.min.y == p.max.y)
        );
        let s = room("[2.0, 1.5, 1.5]", lid);
        assert_eq!(bending_edge_pieces(&s, 0.5, 0.02), Vec::<Aabb>::new());
    }
}
