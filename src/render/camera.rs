//! The view: a [`Camera`] plus an image size, as world → clip → pixel transforms.
//!
//! World frame: metres, right-handed, z up (docs/METHOD.md §1). Camera frame: x right, y up, looking
//! down −z. Two projections, both with **reversed depth** (larger = nearer, 0 = nothing):
//! * perspective ([`View::new`]) with a vertical field of view and an infinite far plane: clip
//!   `w` is the distance along the view axis (m), clip `z` is the near distance, and the NDC depth
//!   is `near / w`, so 1 is on the near plane and 0 at infinity. Reversed depth keeps f32 depth
//!   precision relative (≈ 6e-8 of the distance) at every range.
//! * orthographic ([`View::orthographic`], the plan view) with a view height in metres: clip
//!   `w = 1` and the depth `1 − d / far` is affine in the distance `d` along the view axis (1 at
//!   the eye plane, 0 at `far`; farther points are never drawn).
//!
//! In both, a point is in front of the eye when clip `w − z ≥ 0`.
//! Pixel (x, y) covers `[x, x+1) × [y, y+1)` with y down; its centre is `(x + 0.5, y + 0.5)`.

use glam::{DMat4, DVec3, DVec4};

use crate::error::{Error, Result};
use crate::scene::model::Camera;

/// Default near-plane distance in metres (1 mm): an eye 1 cm from a wall still sees the wall.
pub const DEFAULT_NEAR_M: f64 = 0.001;

/// Largest accepted image side in pixels.
pub const MAX_IMAGE_SIDE: u32 = 16_384;

/// How the view maps the camera frame onto the image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Projection {
    /// Perspective with the camera's vertical field of view.
    Perspective,
    /// Parallel projection showing `height_m` metres from the bottom to the top of the image;
    /// nothing farther than `far_m` from the eye plane is drawn.
    Orthographic {
        /// Height of the image in world metres.
        height_m: f64,
        /// Largest drawn distance from the eye plane, m.
        far_m: f64,
    },
}

/// Pixel rays as affine functions of pixel coordinates ([`View::pixel_ray_basis`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayBasis {
    /// Origin at pixel (0, 0) and its change per pixel in x and in y (world, m).
    pub origin: [DVec3; 3],
    /// Direction (not normalised) at pixel (0, 0) and its change per pixel in x and in y.
    pub dir: [DVec3; 3],
}

impl RayBasis {
    /// Origin and (not normalised) direction of the ray through `(x, y)`.
    #[inline]
    pub fn ray(&self, x: f64, y: f64) -> (DVec3, DVec3) {
        (
            self.origin[0] + x * self.origin[1] + y * self.origin[2],
            self.dir[0] + x * self.dir[1] + y * self.dir[2],
        )
    }
}

/// A camera looking at the scene through an image of `width × height` pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    camera: Camera,
    projection: Projection,
    width: u32,
    height: u32,
    near_m: f64,
    cull_back_faces: bool,
    clip_from_world: DMat4,
    world_from_clip: DMat4,
}

impl View {
    /// A view of `camera` through a `width × height` pixel image (aspect = width / height),
    /// near plane [`DEFAULT_NEAR_M`], back faces culled (see [`View::with_back_face_culling`]).
    ///
    /// Errors (bad input): an image side of 0 or above [`MAX_IMAGE_SIDE`], a field of view
    /// outside (0°, 180°), a non-finite eye or target, or the eye on the target.
    pub fn new(camera: Camera, width: u32, height: u32) -> Result<View> {
        View::with_near(camera, width, height, DEFAULT_NEAR_M)
    }

    /// As [`View::new`] with a near-plane distance `near_m` (metres, > 0).
    pub fn with_near(camera: Camera, width: u32, height: u32, near_m: f64) -> Result<View> {
        check_sides(width, height)?;
        if !(camera.fov_deg > 0.0 && camera.fov_deg < 180.0) {
            return Err(Error::input(
                "",
                "camera.fov_deg",
                format!("vertical field of view {}° is outside (0°, 180°)", camera.fov_deg),
            ));
        }
        if !(near_m > 0.0 && near_m.is_finite()) {
            return Err(Error::input(
                "",
                "near plane",
                format!("{near_m} m is not a positive distance"),
            ));
        }
        let forward = check_eye_and_target(&camera)?;
        let world_to_camera = look_at(camera.eye, forward);
        let aspect = f64::from(width) / f64::from(height);
        let projection = reversed_infinite_perspective(camera.fov_deg.to_radians(), aspect, near_m);
        let clip_from_world = projection * world_to_camera;
        Ok(View {
            camera,
            projection: Projection::Perspective,
            width,
            height,
            near_m,
            cull_back_faces: true,
            clip_from_world,
            world_from_clip: clip_from_world.inverse(),
        })
    }

    /// A parallel (orthographic) view from the eye plane through `eye` looking at `target`,
    /// showing `height_m` metres from the image's bottom to its top (the width follows from the
    /// aspect `width / height`) and nothing farther than `far_m` from the eye plane. Looking
    /// straight down, world +x points right and +y up in the image (a plan). The camera's
    /// `fov_deg` is not used (reported as 0). Back faces are culled.
    ///
    /// Errors (bad input): an image side of 0 or above [`MAX_IMAGE_SIDE`], a height or far
    /// distance that is not positive and finite, a non-finite eye or target, or the eye on the
    /// target.
    pub fn orthographic(
        eye: DVec3,
        target: DVec3,
        height_m: f64,
        far_m: f64,
        width: u32,
        height: u32,
    ) -> Result<View> {
        check_sides(width, height)?;
        for (value, name) in [(height_m, "view height"), (far_m, "far distance")] {
            if !(value > 0.0 && value.is_finite()) {
                return Err(Error::input(
                    "",
                    name,
                    format!("{value} m is not a positive distance"),
                ));
            }
        }
        let camera = Camera {
            eye,
            target,
            fov_deg: 0.0,
        };
        let forward = check_eye_and_target(&camera)?;
        let world_to_camera = look_at(eye, forward);
        let aspect = f64::from(width) / f64::from(height);
        let half_h = 0.5 * height_m;
        let projection = DMat4::from_cols(
            DVec4::new(1.0 / (half_h * aspect), 0.0, 0.0, 0.0),
            DVec4::new(0.0, 1.0 / half_h, 0.0, 0.0),
            DVec4::new(0.0, 0.0, 1.0 / far_m, 0.0),
            DVec4::new(0.0, 0.0, 1.0, 1.0),
        );
        let clip_from_world = projection * world_to_camera;
        Ok(View {
            camera,
            projection: Projection::Orthographic { height_m, far_m },
            width,
            height,
            near_m: 0.0,
            cull_back_faces: true,
            clip_from_world,
            world_from_clip: clip_from_world.inverse(),
        })
    }

    /// The same view with back-face culling on or off. With culling on (the default) a patch
    /// is drawn only from the side its normal points to, so from outside the room one sees in.
    pub fn with_back_face_culling(mut self, cull: bool) -> View {
        self.cull_back_faces = cull;
        self
    }

    /// The camera (`fov_deg` is 0 for an orthographic view).
    pub fn camera(&self) -> &Camera {
        &self.camera
    }
    /// The projection.
    pub fn projection(&self) -> Projection {
        self.projection
    }
    /// Unit viewing direction (world): from the eye towards the target.
    pub fn forward(&self) -> DVec3 {
        (self.camera.target - self.camera.eye).normalize()
    }
    /// Image width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }
    /// Image height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }
    /// Near-plane distance along the view axis, metres (0 for an orthographic view, which
    /// draws everything in front of the eye plane).
    pub fn near_m(&self) -> f64 {
        self.near_m
    }
    /// True when patches facing away from the eye are skipped.
    pub fn culls_back_faces(&self) -> bool {
        self.cull_back_faces
    }

    /// True when a surface with unit normal `normal` (world) at `point` faces the eye: its
    /// front side is seen (perspective: the eye is on the normal's side of its plane;
    /// orthographic: the normal points against the viewing direction).
    pub fn sees_front(&self, normal: DVec3, point: DVec3) -> bool {
        match self.projection {
            Projection::Perspective => normal.dot(self.camera.eye - point) > 0.0,
            Projection::Orthographic { .. } => normal.dot(self.forward()) < 0.0,
        }
    }

    /// The ray through continuous pixel coordinates `(x, y)`: its origin (the eye, or the
    /// point on the eye plane for an orthographic view; world, m) and unit direction (world).
    pub fn pixel_ray(&self, x: f64, y: f64) -> (DVec3, DVec3) {
        match self.projection {
            Projection::Perspective => {
                let on_near = self.unproject(x, y, 1.0);
                (self.camera.eye, (on_near - self.camera.eye).normalize())
            }
            Projection::Orthographic { .. } => (self.unproject(x, y, 1.0), self.forward()),
        }
    }

    /// The pixel rays as affine functions of the continuous pixel coordinates: the ray through
    /// `(x, y)` starts at `origin[0] + x·origin[1] + y·origin[2]` and runs along
    /// `dir[0] + x·dir[1] + y·dir[2]` (not normalised) — the same rays as
    /// [`View::pixel_ray`], without a matrix product per pixel.
    pub fn pixel_ray_basis(&self) -> RayBasis {
        let at = |x: f64, y: f64| {
            let (o, _) = self.pixel_ray(x, y);
            let d = match self.projection {
                Projection::Perspective => self.unproject(x, y, 1.0) - self.camera.eye,
                Projection::Orthographic { .. } => self.forward(),
            };
            (o, d)
        };
        let ((o0, d0), (ox, dx), (oy, dy)) = (at(0.0, 0.0), at(1.0, 0.0), at(0.0, 1.0));
        RayBasis {
            origin: [o0, ox - o0, oy - o0],
            dir: [d0, dx - d0, dy - d0],
        }
    }

    /// Homogeneous clip coordinates of a world point (m). Perspective: `w` is its distance
    /// along the view axis in metres (negative behind the eye) and `z = near`; orthographic:
    /// `w = 1` and `z` the depth (module docs). In front of the eye when `w − z ≥ 0`.
    pub fn clip_from_world(&self, world: DVec3) -> DVec4 {
        self.clip_from_world * world.extend(1.0)
    }

    /// Pixel coordinates `(x, y)` (y down, continuous: pixel centres at +0.5) and NDC depth of
    /// a clip-space point with `w > 0`.
    pub fn pixel_from_clip(&self, clip: DVec4) -> DVec3 {
        let inv_w = 1.0 / clip.w;
        DVec3::new(
            (clip.x * inv_w + 1.0) * 0.5 * f64::from(self.width),
            (1.0 - clip.y * inv_w) * 0.5 * f64::from(self.height),
            clip.z * inv_w,
        )
    }

    /// Pixel coordinates and NDC depth of a world point, or `None` when it is not in front of
    /// the near plane. The point may project outside the image.
    pub fn project(&self, world: DVec3) -> Option<DVec3> {
        let clip = self.clip_from_world(world);
        (clip.w - clip.z >= 0.0).then(|| self.pixel_from_clip(clip))
    }

    /// The world point (m) seen at continuous pixel coordinates `(x, y)` with NDC depth
    /// `depth` (> 0, as stored in the depth buffer): the inverse of [`View::project`].
    pub fn unproject(&self, x: f64, y: f64, depth: f64) -> DVec3 {
        let ndc_x = 2.0 * x / f64::from(self.width) - 1.0;
        let ndc_y = 1.0 - 2.0 * y / f64::from(self.height);
        let world = self.world_from_clip * DVec4::new(ndc_x, ndc_y, depth, 1.0);
        world.truncate() / world.w
    }
}

/// Errors (bad input) for an image side of 0 or above [`MAX_IMAGE_SIDE`].
fn check_sides(width: u32, height: u32) -> Result<()> {
    for (side, name) in [(width, "width"), (height, "height")] {
        if side == 0 || side > MAX_IMAGE_SIDE {
            return Err(Error::input(
                "",
                format!("image {name}"),
                format!("{side} pixels is outside 1..={MAX_IMAGE_SIDE}"),
            ));
        }
    }
    Ok(())
}

/// The unit direction from the camera's eye to its target. Errors (bad input) for non-finite
/// points or an eye on the target.
fn check_eye_and_target(camera: &Camera) -> Result<DVec3> {
    if !camera.eye.is_finite() || !camera.target.is_finite() {
        return Err(Error::input("", "camera", "eye and target must be finite points"));
    }
    let forward = camera.target - camera.eye;
    if forward.length() < 1e-9 {
        return Err(Error::input("", "camera", "eye and target are the same point"));
    }
    Ok(forward.normalize())
}

/// World → camera transform for an eye looking along the unit vector `forward`, z up (y up
/// instead when looking straight up or down).
fn look_at(eye: DVec3, forward: DVec3) -> DMat4 {
    let up_hint = if forward.z.abs() > 0.999_999 {
        DVec3::Y
    } else {
        DVec3::Z
    };
    let right = forward.cross(up_hint).normalize();
    let up = right.cross(forward);
    DMat4::from_cols(
        DVec4::new(right.x, up.x, -forward.x, 0.0),
        DVec4::new(right.y, up.y, -forward.y, 0.0),
        DVec4::new(right.z, up.z, -forward.z, 0.0),
        DVec4::new(-right.dot(eye), -up.dot(eye), forward.dot(eye), 1.0),
    )
}

/// Right-handed perspective with vertical field of view `fov_y` (radians), infinite far plane
/// and reversed depth: `x_c = g/aspect·x`, `y_c = g·y`, `z_c = near`, `w_c = −z` with
/// `g = 1 / tan(fov_y / 2)`.
fn reversed_infinite_perspective(fov_y: f64, aspect: f64, near: f64) -> DMat4 {
    let g = 1.0 / (0.5 * fov_y).tan();
    DMat4::from_cols(
        DVec4::new(g / aspect, 0.0, 0.0, 0.0),
        DVec4::new(0.0, g, 0.0, 0.0),
        DVec4::new(0.0, 0.0, 0.0, -1.0),
        DVec4::new(0.0, 0.0, near, 0.0),
    )
}
