//! Picking: pixel → ID buffer → patch → world point, for aiming lights by pointing.
//!
//! The world point is reconstructed from the depth stored at the pixel: NDC from the pixel
//! centre and the depth, unprojected with the inverse view-projection. That point lies on the
//! ray through the pixel centre only within f32 depth precision (≈ 1e-6 of the distance: a few
//! µm, on either side of the surface), so it is then moved to the closest point of the picked
//! patch itself: a point a few µm behind a box face is inside the box, and its shadow ray to
//! any light starts inside the box (docs/DECISIONS.md "Renderer", "Picked points lie on their
//! patch").

use glam::DVec3;

use super::Frame;
use super::camera::View;
use crate::scene::model::PatchMesh;

/// What a pixel shows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pick {
    /// The world point seen at the pixel centre (m).
    pub point: DVec3,
    /// Patch id (index into the mesh's patches).
    pub patch: u32,
    /// Surface id of the patch (index into the scene's surfaces).
    pub surface: u32,
    /// Unit patch normal (world), pointing into the room.
    pub normal: DVec3,
}

/// What pixel (x, y) of `frame` (rendered from `mesh` through `view`) shows; `None` for the
/// background, a pixel outside the image, or a frame that does not match the view or mesh.
pub fn pick(frame: &Frame, view: &View, mesh: &PatchMesh, x: u32, y: u32) -> Option<Pick> {
    if frame.ids.width() != view.width() || frame.ids.height() != view.height() {
        return None;
    }
    let patch_id = frame.ids.get(x, y)?;
    let depth = frame.depth_at(x, y)?;
    let patch = mesh.patches.get(patch_id as usize)?;
    let seen = view.unproject(f64::from(x) + 0.5, f64::from(y) + 0.5, f64::from(depth));
    let point = closest_point_on_patch(mesh, patch_id as usize, seen)?;
    Some(Pick {
        point,
        patch: patch_id,
        surface: patch.surface,
        normal: patch.normal,
    })
}

/// The point of patch `patch` of `mesh` (a planar convex polygon, counter-clockwise seen from
/// its normal's side) closest to `point` (world, m): `point` projected onto the patch's plane,
/// moved onto the nearest edge when it falls outside. `None` for a patch id outside the mesh or
/// a non-finite point.
pub fn closest_point_on_patch(mesh: &PatchMesh, patch: usize, point: DVec3) -> Option<DVec3> {
    let p = mesh.patches.get(patch)?;
    let corners: Vec<DVec3> = p
        .vertex_ids()
        .iter()
        .map(|&v| mesh.positions.get(v as usize).copied())
        .collect::<Option<_>>()?;
    let n = p.normal;
    let on_plane = point - n * (point - corners[0]).dot(n);
    if !on_plane.is_finite() {
        return None;
    }
    let edges = || (0..corners.len()).map(|i| (corners[i], corners[(i + 1) % corners.len()]));
    if edges().all(|(a, b)| (b - a).cross(on_plane - a).dot(n) >= 0.0) {
        return Some(on_plane);
    }
    edges()
        .map(|(a, b)| {
            let ab = b - a;
            let t = ((on_plane - a).dot(ab) / ab.length_squared().max(f64::MIN_POSITIVE)).clamp(0.0, 1.0);
            a + ab * t
        })
        .min_by(|u, v| {
            u.distance_squared(on_plane)
                .total_cmp(&v.distance_squared(on_plane))
        })
}

/// The unit aim direction (world) from a light at `light_position` towards `target` (both in
/// metres); `None` when the two points coincide (closer than 1 µm) or are not finite.
pub fn aim_direction(light_position: DVec3, target: DVec3) -> Option<DVec3> {
    let d = target - light_position;
    (d.is_finite() && d.length() > 1e-6).then(|| d.normalize())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::model::Patch;

    /// One 2 × 1 m quad on the plane x = 0.45 facing +x (a box face), counter-clockwise seen
    /// from +x.
    fn face() -> PatchMesh {
        let positions = vec![
            DVec3::new(0.45, 1.0, 0.0),
            DVec3::new(0.45, 3.0, 0.0),
            DVec3::new(0.45, 3.0, 1.0),
            DVec3::new(0.45, 1.0, 1.0),
        ];
        PatchMesh {
            normals: vec![DVec3::X; 4],
            vertex_surface: vec![0; 4],
            patches: vec![Patch {
                vertices: [0, 1, 2, 3],
                n_vertices: 4,
                surface: 0,
                normal: DVec3::X,
                area: 2.0,
                centroid: DVec3::new(0.45, 2.0, 0.5),
            }],
            positions,
        }
    }

    #[test]
    fn points_move_onto_the_patch_plane_and_inside_its_edges() {
        let mesh = face();
        let on = |p: DVec3| closest_point_on_patch(&mesh, 0, p).unwrap();
        // A few µm behind or in front of the face: onto its plane, nothing else moves.
        assert_eq!(on(DVec3::new(0.449_998, 2.1, 0.7)), DVec3::new(0.45, 2.1, 0.7));
        assert_eq!(on(DVec3::new(0.450_003, 1.5, 0.2)), DVec3::new(0.45, 1.5, 0.2));
        // Past an edge or a corner: onto the nearest edge point.
        assert_eq!(
            on(DVec3::new(0.449_99, 3.000_002, 0.5)),
            DVec3::new(0.45, 3.0, 0.5)
        );
        assert_eq!(on(DVec3::new(0.46, 0.9, 1.2)), DVec3::new(0.45, 1.0, 1.0));
        assert_eq!(closest_point_on_patch(&mesh, 1, DVec3::ZERO), None);
        assert_eq!(closest_point_on_patch(&mesh, 0, DVec3::NAN), None);
    }
}
