//! Overlays drawn with tiny-skia over the rendered 3D image: light positions, the selected
//! light's aim line and target, and a cursor crosshair. Pixel coordinates as in
//! [`super::camera`] (y down, pixel centres at +0.5). Paths are anti-aliased on tiny-skia's
//! high-quality pipeline so results do not depend on the CPU.

use glam::{DVec3, DVec4};
use tiny_skia::{FillRule, Paint, Path, PathBuilder, Pixmap, Stroke, Transform};

use super::Frame;
use super::camera::View;

/// Light marker fill colour (sRGB8).
pub const LIGHT_RGB: [u8; 3] = [255, 196, 0];
/// Aim line and target colour (sRGB8).
pub const AIM_RGB: [u8; 3] = [0, 220, 255];
/// Opacity of a light marker hidden behind geometry (0–255).
pub const OCCLUDED_ALPHA: u8 = 80;
/// Radius of a light marker in pixels (the selected light's is 1.5 ×).
pub const LIGHT_RADIUS_PX: f32 = 4.0;
/// Half-length of the crosshair arms in pixels.
pub const CROSSHAIR_ARM_PX: f32 = 8.0;
/// Half-size of the crosshair's empty centre in pixels (the pointed-at pixel stays visible).
pub const CROSSHAIR_GAP_PX: f32 = 2.0;

/// A light to mark on the preview.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightMarker {
    /// Light position (world, m).
    pub position: DVec3,
    /// Aim target point (world, m); drawn with the aim line when the light is selected.
    pub aim_target: DVec3,
    /// True for the light being edited.
    pub selected: bool,
}

/// Draws `lights` over `frame` (rendered through `view`). A light behind the near plane is not
/// drawn; one hidden by geometry (per the frame's depth buffer) is drawn dimmed. The selected
/// light also gets its aim line (clipped at the near plane) and a ring at its target.
pub fn draw_lights(frame: &mut Frame, view: &View, lights: &[LightMarker]) {
    for light in lights.iter().filter(|l| l.selected) {
        draw_aim(&mut frame.pixmap, view, light);
    }
    for light in lights {
        let Some(pixel) = view.project(light.position) else {
            continue;
        };
        let hidden = is_occluded(frame, pixel);
        let alpha = if hidden { OCCLUDED_ALPHA } else { 255 };
        let radius = if light.selected {
            1.5 * LIGHT_RADIUS_PX
        } else {
            LIGHT_RADIUS_PX
        };
        if let Some(dot) = PathBuilder::from_circle(pixel.x as f32, pixel.y as f32, radius) {
            frame.pixmap.fill_path(
                &dot,
                &paint(LIGHT_RGB, alpha),
                FillRule::Winding,
                Transform::identity(),
                None,
            );
            stroke(&mut frame.pixmap, &dot, [0, 0, 0], alpha, 1.0);
        }
    }
}

/// True when the frame shows something nearer than the projected point `pixel` (x, y, depth).
fn is_occluded(frame: &Frame, pixel: DVec3) -> bool {
    let (x, y) = (pixel.x.floor(), pixel.y.floor());
    if x < 0.0 || y < 0.0 {
        return false;
    }
    // Reversed depth: larger is nearer; 0.1 % slack keeps lights mounted on a surface visible.
    frame
        .depth_at(x as u32, y as u32)
        .is_some_and(|d| f64::from(d) > pixel.z * 1.001)
}

fn draw_aim(pixmap: &mut Pixmap, view: &View, light: &LightMarker) {
    let Some((from, to)) = clip_segment(view, light.position, light.aim_target) else {
        return;
    };
    let mut builder = PathBuilder::new();
    builder.move_to(from.x as f32, from.y as f32);
    builder.line_to(to.x as f32, to.y as f32);
    if let Some(line) = builder.finish() {
        stroke(pixmap, &line, [0, 0, 0], 255, 3.0);
        stroke(pixmap, &line, AIM_RGB, 255, 1.5);
    }
    if let Some(target) = view.project(light.aim_target)
        && let Some(ring) = PathBuilder::from_circle(target.x as f32, target.y as f32, 5.0)
    {
        stroke(pixmap, &ring, AIM_RGB, 255, 1.5);
    }
}

/// Pixel end points of the part of segment `a → b` (world) in front of the near plane.
fn clip_segment(view: &View, a: DVec3, b: DVec3) -> Option<(DVec3, DVec3)> {
    let (ca, cb) = (view.clip_from_world(a), view.clip_from_world(b));
    let (da, db) = (ca.w - ca.z, cb.w - cb.z);
    let cut =
        |inside: DVec4, d_in: f64, outside: DVec4, d_out: f64| inside.lerp(outside, d_in / (d_in - d_out));
    let (ca, cb) = match (da >= 0.0, db >= 0.0) {
        (true, true) => (ca, cb),
        (true, false) => (ca, cut(ca, da, cb, db)),
        (false, true) => (cut(cb, db, ca, da), cb),
        (false, false) => return None,
    };
    Some((view.pixel_from_clip(ca), view.pixel_from_clip(cb)))
}

/// Draws a crosshair centred on pixel (x, y): four arms with a white core and a dark outline,
/// leaving the pixel itself and its immediate neighbours untouched.
pub fn draw_crosshair(pixmap: &mut Pixmap, x: u32, y: u32) {
    let (cx, cy) = (x as f32 + 0.5, y as f32 + 0.5);
    let mut builder = PathBuilder::new();
    for (dx, dy) in [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)] {
        builder.move_to(cx + dx * CROSSHAIR_GAP_PX, cy + dy * CROSSHAIR_GAP_PX);
        builder.line_to(cx + dx * CROSSHAIR_ARM_PX, cy + dy * CROSSHAIR_ARM_PX);
    }
    if let Some(arms) = builder.finish() {
        stroke(pixmap, &arms, [0, 0, 0], 255, 3.0);
        stroke(pixmap, &arms, [255, 255, 255], 255, 1.0);
    }
}

fn paint(rgb: [u8; 3], alpha: u8) -> Paint<'static> {
    let mut paint = Paint {
        anti_alias: true,
        force_hq_pipeline: true,
        ..Paint::default()
    };
    paint.set_color_rgba8(rgb[0], rgb[1], rgb[2], alpha);
    paint
}

fn stroke(pixmap: &mut Pixmap, path: &Path, rgb: [u8; 3], alpha: u8, width: f32) {
    let stroke = Stroke {
        width,
        ..Stroke::default()
    };
    pixmap.stroke_path(path, &paint(rgb, alpha), &stroke, Transform::identity(), None);
}
