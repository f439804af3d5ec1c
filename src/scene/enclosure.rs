//! Whether furniture closes a point in on every side although the point is inside none of it: a
//! light on the face two touching boxes (or two stacked closed meshes) share is on a face of each,
//! so inside neither, yet it would light both from within (docs/DECISIONS.md "A light enclosed by
//! furniture"). World frame, metres.

use glam::DVec3;

use crate::scene::Aabb;

/// Directions looked along: enough that a free half-space or a free octant holds several.
const PROBES: usize = 32;

/// How far from the point the probes lie, as a fraction of `1 + ` the room's largest size (m).
const HAIR: f64 = 1e-7;

/// A point and the hair-wide sphere of probes around it.
#[derive(Debug, Clone, Copy)]
pub struct Neighbourhood {
    point: DVec3,
    hair: f64,
    room_size: DVec3,
}

impl Neighbourhood {
    /// The neighbourhood of `point` in a room of `room_size` (m).
    pub fn new(point: DVec3, room_size: DVec3) -> Self {
        Neighbourhood {
            point,
            hair: HAIR * (1.0 + room_size.max_element()),
            room_size,
        }
    }

    /// Whether `bounds` reach within a hair of the point (only such furniture can close it in).
    pub fn touches(&self, bounds: &Aabb) -> bool {
        let hair = DVec3::splat(self.hair);
        (self.point - bounds.min).cmpge(-hair).all() && (bounds.max - self.point).cmpge(-hair).all()
    }

    /// Whether every probe — a hair from the point, in [`PROBES`] directions off every axis
    /// plane — is outside the room or `inside` furniture. A point on a free face has a free
    /// half-space and is not.
    pub fn closed_in(&self, inside: impl Fn(DVec3) -> bool) -> bool {
        (0..PROBES).all(|k| {
            let probe = self.point + self.hair * fibonacci_direction(k);
            !(probe.cmpgt(DVec3::ZERO).all() && probe.cmplt(self.room_size).all()) || inside(probe)
        })
    }

    /// [`Neighbourhood::closed_in`] by the `boxes` that touch the point (false when none does).
    pub fn closed_in_by_boxes(&self, boxes: &[Aabb]) -> bool {
        let near: Vec<&Aabb> = boxes.iter().filter(|b| self.touches(b)).collect();
        !near.is_empty() && self.closed_in(|q| near.iter().any(|b| b.contains_strictly(q)))
    }
}

/// Direction `k` of [`PROBES`] spread evenly over the sphere (a Fibonacci lattice): `z` steps
/// through `1 − (2k+1)/PROBES`, never 0, and the golden-angle turns keep `x` and `y` off 0, so no
/// direction lies in an axis plane, where the faces of boxes lie.
fn fibonacci_direction(k: usize) -> DVec3 {
    let z = 1.0 - (2 * k + 1) as f64 / PROBES as f64;
    let radius = (1.0 - z * z).sqrt();
    let phi = k as f64 * std::f64::consts::PI * (3.0 - 5f64.sqrt()) + 0.5;
    DVec3::new(radius * phi.cos(), radius * phi.sin(), z)
}

#[cfg(test)]
mod tests {
    use super::*;

    const ROOM: DVec3 = DVec3::new(3.0, 2.0, 2.5);

    fn cube(min: [f64; 3], max: [f64; 3]) -> Aabb {
        Aabb {
            min: DVec3::from_array(min),
            max: DVec3::from_array(max),
        }
    }

    fn closed_in_by(p: DVec3, boxes: &[Aabb]) -> bool {
        Neighbourhood::new(p, ROOM).closed_in_by_boxes(boxes)
    }

    #[test]
    fn the_directions_are_unit_and_off_every_axis_plane() {
        let mut sum = DVec3::ZERO;
        for k in 0..PROBES {
            let d = fibonacci_direction(k);
            assert!((d.length() - 1.0).abs() < 1e-12, "{d}");
            assert!(d.abs().min_element() > 0.01, "direction {k}: {d}");
            sum += d;
        }
        // Spread evenly: they nearly cancel.
        assert!(sum.length() < 0.1 * PROBES as f64, "{sum}");
    }

    #[test]
    fn a_shared_face_an_edge_and_a_corner_between_boxes_are_closed_in() {
        let left = cube([1.0, 0.5, 0.0], [1.5, 1.5, 1.0]);
        let right = cube([1.5, 0.5, 0.0], [2.0, 1.5, 1.0]);
        assert!(closed_in_by(DVec3::new(1.5, 1.0, 0.5), &[left, right]));
        // Where that face meets the floor, the room's outside closes the rest.
        assert!(closed_in_by(DVec3::new(1.5, 1.0, 0.0), &[left, right]));
        // Four boxes meeting along the edge x = 1.5, y = 1.0.
        let quarter = |x: f64, y: f64| cube([x, y, 0.0], [x + 0.5, y + 0.5, 1.0]);
        let four = [
            quarter(1.0, 0.5),
            quarter(1.5, 0.5),
            quarter(1.0, 1.0),
            quarter(1.5, 1.0),
        ];
        assert!(closed_in_by(DVec3::new(1.5, 1.0, 0.5), &four));
        // Three of them leave a free quarter of space: kept.
        assert!(!closed_in_by(DVec3::new(1.5, 1.0, 0.5), &four[..3]));
    }

    #[test]
    fn free_faces_edges_and_gaps_are_not_closed_in() {
        let left = cube([1.0, 0.5, 0.0], [1.5, 1.5, 1.0]);
        // On the top face, on a vertical edge, and at a corner of one box.
        for p in [[1.2, 1.0, 1.0], [1.5, 0.5, 0.5], [1.5, 1.5, 1.0]] {
            assert!(!closed_in_by(DVec3::from_array(p), &[left]), "{p:?}");
        }
        // Between two boxes 1 mm apart: a free slot.
        let apart = cube([1.501, 0.5, 0.0], [2.0, 1.5, 1.0]);
        assert!(!closed_in_by(DVec3::new(1.5, 1.0, 0.5), &[left, apart]));
        // Far from every box: nothing to ask.
        assert!(!closed_in_by(DVec3::new(0.3, 0.3, 2.0), &[left, apart]));
        // On the floor by a box, and where a box in the room's corner meets the floor and a
        // wall: free above, and free in one octant.
        assert!(!closed_in_by(DVec3::new(1.0, 1.0, 0.0), &[left]));
        let in_corner = cube([0.0, 0.0, 0.0], [0.5, 0.5, 0.5]);
        assert!(!closed_in_by(DVec3::new(0.5, 0.0, 0.0), &[in_corner]));
    }
}
