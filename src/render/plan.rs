//! The plan view: the room seen from straight above with a parallel projection, as lighting
//! designers print and discuss it — world +x to the right, +y up, the room's footprint filling
//! the image with a margin.
//!
//! Two things can be shown at each pixel:
//! * [`PlanSurface::Floor`]: what is visible from above once the ceiling is gone — the floor,
//!   box tops, upward-facing OBJ faces. The eye sits above the ceiling, and the ceiling (and the
//!   walls, seen edge-on) are back faces from there, so back-face culling removes them; nothing
//!   else is needed to "lift the lid".
//! * [`PlanSurface::WorkPlane`]: a horizontal calculation plane at a height (0.8 m for desks),
//!   meshed like a room surface ([`work_plane_mesh`]: cells inside boxes the plane passes
//!   through are left out) and rendered alone; each pixel is the point of the plane below it,
//!   lit by the same exact per-pixel direct light, with the indirect light gathered at the
//!   plane's vertices from the coarse patches' radiosity (indirect light is smooth).
//!
//! Luminaire symbols ([`draw_plan_lights`]): a circle with a cross at each light, an arrow to
//! where its aim axis meets the shown plane, its name beside it.

use glam::DVec3;
use tiny_skia::{FillRule, Paint, Path, PathBuilder, Pixmap, Stroke, Transform};

use super::camera::View;
use super::text::{draw_text, text_height};
use crate::error::{Error, Result};
use crate::photometry::LightState;
use crate::scene::Scene;
use crate::scene::mesher::{self, AxisRect, Geometry, Shape, SurfaceLayout};
use crate::scene::model::{Aabb, PatchMesh, Reflectance, Surface, SurfaceKind};
use crate::transport::bake::Bake;
use crate::transport::direct::Receiver;
use crate::transport::gather::{GatherOperator, patch_radiosity};
use crate::transport::occlusion::Occluders;

/// Margin around the room's footprint, as a fraction of its larger side.
pub const PLAN_MARGIN: f64 = 0.04;

/// Height of the eye above the ceiling, m.
const EYE_ABOVE_CEILING_M: f64 = 1.0;

/// What the plan view shows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PlanSurface {
    /// The floor and what stands on it, seen from above.
    Floor,
    /// A horizontal work plane at this height (m).
    WorkPlane {
        /// Height above the floor, m.
        height_m: f64,
    },
}

impl PlanSurface {
    /// Height (m) of the plane the luminaires' aim arrows end on.
    pub fn height_m(&self) -> f64 {
        match *self {
            PlanSurface::Floor => 0.0,
            PlanSurface::WorkPlane { height_m } => height_m,
        }
    }
}

/// The plan view of a room of size `room_size` (m, from the origin) through a `width × height`
/// image: straight down from above the ceiling, centred on the footprint, which fills the image
/// with a margin of [`PLAN_MARGIN`] (the image's aspect decides which side touches it).
///
/// Errors (bad input): an image side the view rejects, or a room that is not a positive size.
pub fn plan_view(room_size: DVec3, width: u32, height: u32) -> Result<View> {
    plan_view_beside(room_size, width, height, 0)
}

/// As [`plan_view`], with the footprint fitted into the image's left `width − free_right_px`
/// pixels (a strip at the right edge kept free for the legend, [`super::legend_width`]); the
/// whole strip is kept free only while the footprint keeps at least half the width.
///
/// Errors as [`plan_view`].
pub fn plan_view_beside(room_size: DVec3, width: u32, height: u32, free_right_px: u32) -> Result<View> {
    if !(room_size.min_element() > 0.0 && room_size.is_finite()) {
        return Err(Error::input(
            "",
            "room.size",
            format!("{room_size} m is not a room"),
        ));
    }
    let free = free_right_px.min(width / 2);
    let margin = PLAN_MARGIN * room_size.x.max(room_size.y);
    let (footprint_w, footprint_h) = (room_size.x + 2.0 * margin, room_size.y + 2.0 * margin);
    let aspect = f64::from((width - free).max(1)) / f64::from(height.max(1));
    let view_height_m = footprint_h.max(footprint_w / aspect);
    // The image centre lies half the free strip right of the footprint's centre.
    let m_per_px = view_height_m / f64::from(height.max(1));
    let shift = DVec3::X * (0.5 * f64::from(free) * m_per_px);
    let centre = DVec3::new(0.5 * room_size.x, 0.5 * room_size.y, 0.0) + shift;
    let eye = centre + DVec3::Z * (room_size.z + EYE_ABOVE_CEILING_M);
    View::orthographic(
        eye,
        centre,
        view_height_m,
        room_size.z + 2.0 * EYE_ABOVE_CEILING_M,
        width,
        height,
    )
}

/// Largest number of vertices of a work-plane mesh.
const MAX_PLANE_VERTICES: usize = 4_000_000;

/// The work plane at `height_m` as a one-surface mesh of quads of about `cell_m` (facing up),
/// conforming to the boxes the plane passes through, whose insides are left out; with its one
/// surface (`work-plane`, reflectance 0: it is a calculation surface, not a thing).
///
/// Errors (bad input): a height not strictly inside the room or a cell that is not positive, or
/// a mesh above 4 million vertices.
pub fn work_plane_mesh(
    room_size: DVec3,
    boxes: &[Aabb],
    height_m: f64,
    cell_m: f64,
) -> Result<(PatchMesh, Vec<Surface>)> {
    if !(height_m > 0.0 && height_m < room_size.z) {
        return Err(Error::input(
            "",
            "work plane height",
            format!("{height_m} m is not inside the room (0 to {} m)", room_size.z),
        ));
    }
    if !(cell_m > 0.0 && cell_m.is_finite()) {
        return Err(Error::input(
            "",
            "work plane cell",
            format!("{cell_m} m is not a positive length"),
        ));
    }
    let geometry = Geometry {
        room_size,
        boxes,
        meshes: &[],
    };
    let layout = SurfaceLayout {
        name: "work-plane".into(),
        kind: SurfaceKind::Floor,
        shape: Shape::Rect(AxisRect {
            axis: 2,
            offset: height_m,
            facing_positive: true,
            min: [0.0, 0.0],
            max: [room_size.x, room_size.y],
        }),
    };
    let mesh = mesher::mesh(&geometry, &[layout], cell_m, MAX_PLANE_VERTICES).map_err(|e| {
        Error::input(
            "",
            "work plane cell",
            format!("{cell_m} m gives about {:.0} vertices", e.estimated),
        )
    })?;
    let surface = Surface {
        name: "work-plane".into(),
        kind: SurfaceKind::Floor,
        reflectance: Reflectance::grey(0.0),
    };
    Ok((mesh, vec![surface]))
}

/// The gather from `scene`'s coarse patches to every vertex of a work-plane mesh (from
/// [`work_plane_mesh`]; normals up): exact point-to-patch form factors with visibility past
/// occluders, as `haiko grid` gathers. Costs about (vertices × coarse patches) form factors and
/// their shadow rays; built once per plane, then [`work_plane_indirect`] costs one pass over the
/// stored factors per light change.
pub fn work_plane_gather(scene: &Scene, plane: &PatchMesh) -> GatherOperator {
    GatherOperator::build(
        scene,
        Occluders::of_scene(scene).as_ref(),
        &work_plane_receivers(plane),
    )
}

/// The vertices of a work plane ([`work_plane_mesh`]) as receivers facing up.
pub fn work_plane_receivers(plane: &PatchMesh) -> Vec<Receiver> {
    plane
        .positions
        .iter()
        .map(|&point| Receiver {
            point,
            normal: DVec3::Z,
        })
        .collect()
}

/// Indirect illuminance (lx, linear RGB) at every vertex of a work plane for the lights' current
/// `states`: the coarse patches' radiosity blended from `bake`, through the plane's `gather`
/// ([`work_plane_gather`]).
pub fn work_plane_indirect(
    scene: &Scene,
    bake: &Bake,
    states: &[LightState],
    gather: &GatherOperator,
) -> Vec<[f32; 3]> {
    gather
        .apply(&patch_radiosity(scene, bake, states))
        .into_iter()
        .map(|e| e.map(|x| x as f32))
        .collect()
}

/// A luminaire as the plan shows it.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanLight {
    /// Name shown beside the symbol.
    pub name: String,
    /// Position (world, m).
    pub position: DVec3,
    /// Unit aim axis (world).
    pub aim: DVec3,
    /// True for the light being edited (drawn larger, highlighted).
    pub selected: bool,
}

/// Symbol colour (sRGB8).
pub const SYMBOL_RGB: [u8; 3] = [255, 196, 0];
/// Aim arrow colour (sRGB8).
pub const ARROW_RGB: [u8; 3] = [0, 220, 255];

/// Where the aim axis of a light at `position` along the unit `aim` meets the horizontal plane
/// at `plane_z` (world, m); `None` when it does not go down to it.
pub fn aim_on_plane(position: DVec3, aim: DVec3, plane_z: f64) -> Option<DVec3> {
    let drop = position.z - plane_z;
    (aim.z < -1e-9 && drop > 0.0).then(|| position + aim * (drop / -aim.z))
}

/// Draws each light's plan symbol over `pixmap` (rendered through the plan `view`): a filled
/// circle with a cross, an arrow from it to where its aim meets the plane at `plane_z` (when the
/// aim is tilted by more than a pixel's worth), and its name beside it.
pub fn draw_plan_lights(pixmap: &mut Pixmap, view: &View, lights: &[PlanLight], plane_z: f64) {
    let s = (pixmap.height() / 240).max(1) as f32;
    for light in lights {
        let Some(at) = view.project(light.position) else {
            continue;
        };
        let (x, y) = (at.x as f32, at.y as f32);
        let radius = if light.selected { 7.0 } else { 5.0 } * s;
        if let Some(target) = aim_on_plane(light.position, light.aim, plane_z).and_then(|t| view.project(t)) {
            let (tx, ty) = (target.x as f32, target.y as f32);
            let length = (tx - x).hypot(ty - y);
            if length > radius + 2.0 * s {
                let (ux, uy) = ((tx - x) / length, (ty - y) / length);
                let mut arrow = PathBuilder::new();
                arrow.move_to(x + ux * radius, y + uy * radius);
                arrow.line_to(tx, ty);
                let head = 4.0 * s;
                arrow.move_to(tx - ux * head - uy * head * 0.6, ty - uy * head + ux * head * 0.6);
                arrow.line_to(tx, ty);
                arrow.line_to(tx - ux * head + uy * head * 0.6, ty - uy * head - ux * head * 0.6);
                if let Some(path) = arrow.finish() {
                    stroke(pixmap, &path, [0, 0, 0], 3.0 * s);
                    stroke(pixmap, &path, ARROW_RGB, 1.5 * s);
                }
            }
        }
        if let Some(circle) = PathBuilder::from_circle(x, y, radius) {
            let mut paint = paint(SYMBOL_RGB);
            if light.selected {
                paint.set_color_rgba8(255, 255, 255, 255);
            }
            pixmap.fill_path(&circle, &paint, FillRule::Winding, Transform::identity(), None);
            stroke(pixmap, &circle, [0, 0, 0], s);
        }
        let mut cross = PathBuilder::new();
        let d = radius * std::f32::consts::FRAC_1_SQRT_2;
        cross.move_to(x - d, y - d);
        cross.line_to(x + d, y + d);
        cross.move_to(x - d, y + d);
        cross.line_to(x + d, y - d);
        if let Some(path) = cross.finish() {
            stroke(pixmap, &path, [0, 0, 0], s);
        }
        let scale = s as u32;
        let (lx, ly) = (x + radius + 2.0 * s, y - radius - text_height(scale) as f32);
        draw_text(
            pixmap,
            lx as i64 + 1,
            ly as i64 + 1,
            &light.name,
            scale,
            [0, 0, 0],
        );
        draw_text(pixmap, lx as i64, ly as i64, &light.name, scale, [255, 255, 255]);
    }
}

fn paint(rgb: [u8; 3]) -> Paint<'static> {
    let mut paint = Paint {
        anti_alias: true,
        force_hq_pipeline: true,
        ..Paint::default()
    };
    paint.set_color_rgba8(rgb[0], rgb[1], rgb[2], 255);
    paint
}

fn stroke(pixmap: &mut Pixmap, path: &Path, rgb: [u8; 3], width: f32) {
    let stroke = Stroke {
        width,
        ..Stroke::default()
    };
    pixmap.stroke_path(path, &paint(rgb), &stroke, Transform::identity(), None);
}
