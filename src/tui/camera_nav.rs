//! Camera navigation for the preview: orbit, pan and dolly around the camera's target.
//! World frame: metres, z up (docs/METHOD.md §1).

use glam::{DQuat, DVec3};

use crate::scene::Camera;

/// Steepest view the orbit allows, degrees from the horizontal (keeps the view off the pole,
/// where "up" would be undefined).
pub const MAX_ELEVATION_DEG: f64 = 85.0;

/// The camera's unit right axis (world): forward × z.
fn right_axis(camera: &Camera) -> DVec3 {
    let forward = (camera.target - camera.eye).normalize_or_zero();
    forward.cross(DVec3::Z).normalize_or(DVec3::X)
}

/// Orbits the eye around the target: `yaw_deg` about world z, then `pitch_deg` up or down,
/// keeping the distance and the elevation within ±[`MAX_ELEVATION_DEG`].
pub fn orbit(camera: &Camera, yaw_deg: f64, pitch_deg: f64) -> Camera {
    let offset = camera.eye - camera.target;
    let distance = offset.length();
    if distance == 0.0 {
        return *camera;
    }
    let yawed = DQuat::from_rotation_z(yaw_deg.to_radians()) * offset;
    let horizontal = yawed.truncate().length();
    let elevation_deg = yawed.z.atan2(horizontal).to_degrees();
    let new_elevation = (elevation_deg + pitch_deg)
        .clamp(-MAX_ELEVATION_DEG, MAX_ELEVATION_DEG)
        .to_radians();
    let azimuth = yawed.y.atan2(yawed.x);
    let direction = DVec3::new(
        new_elevation.cos() * azimuth.cos(),
        new_elevation.cos() * azimuth.sin(),
        new_elevation.sin(),
    );
    Camera {
        eye: camera.target + direction * distance,
        ..*camera
    }
}

/// Moves eye and target together along the camera's right and up axes (metres).
pub fn pan(camera: &Camera, right_m: f64, up_m: f64) -> Camera {
    let right = right_axis(camera);
    let forward = (camera.target - camera.eye).normalize_or_zero();
    let up = right.cross(forward).normalize_or(DVec3::Z);
    let shift = right * right_m + up * up_m;
    Camera {
        eye: camera.eye + shift,
        target: camera.target + shift,
        ..*camera
    }
}

/// Scales the eye-to-target distance by `factor` (< 1 moves closer).
pub fn dolly(camera: &Camera, factor: f64) -> Camera {
    Camera {
        eye: camera.target + (camera.eye - camera.target) * factor,
        ..*camera
    }
}
