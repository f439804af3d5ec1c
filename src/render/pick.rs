//! Picking: pixel → ID buffer → patch → world point, for aiming lights by pointing.
//!
//! The world point is reconstructed from the depth stored at the pixel: NDC from the pixel
//! centre and the depth, unprojected with the inverse view-projection. It lies on the picked
//! triangle's plane on the ray through the pixel centre (within f32 depth precision, ≈ 1e-7
//! of the distance).

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
    let point = view.unproject(f64::from(x) + 0.5, f64::from(y) + 0.5, f64::from(depth));
    Some(Pick {
        point,
        patch: patch_id,
        surface: patch.surface,
        normal: patch.normal,
    })
}

/// The unit aim direction (world) from a light at `light_position` towards `target` (both in
/// metres); `None` when the two points coincide (closer than 1 µm) or are not finite.
pub fn aim_direction(light_position: DVec3, target: DVec3) -> Option<DVec3> {
    let d = target - light_position;
    (d.is_finite() && d.length() > 1e-6).then(|| d.normalize())
}
