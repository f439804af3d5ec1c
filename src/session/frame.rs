//! The session's preview frames: what a frame shows ([`FrameSpec`]), the buffers reused from
//! frame to frame ([`FrameBuffers`]), the overlays (every light, the selected light's aim line
//! and target, the aim cursor) and picking with the illuminance under a pixel.
//! World frame: metres, z up; pixels as in [`crate::render::camera`] (docs/METHOD.md §1).

use glam::DVec3;
use tiny_skia::Pixmap;

use crate::error::Result;
use crate::render::shade::luma;
use crate::render::{
    self, DisplayMode, DisplayShader, FalseColor, LightMarker, LuxScale, Photo, View, draw_crosshair,
    draw_lights, vertex_attributes_into,
};
use crate::scene::{AimSpec, Camera, PatchMesh, Scene};
use crate::session::light::LightEdit;

/// Largest image side (pixels) a frame may have.
pub const MAX_SIDE_PX: u32 = 8192;

/// What one preview frame shows besides the lit room: its size, display mode and overlays.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameSpec {
    /// Image size in pixels (width, height), each 1..=[`MAX_SIDE_PX`].
    pub size_px: (u32, u32),
    /// Photo or false colour.
    pub mode: DisplayMode,
    /// The selected light (its aim line and target are drawn), if any.
    pub selected_light: Option<usize>,
    /// The aim cursor (preview pixel), drawn as a crosshair.
    pub cursor: Option<(u32, u32)>,
}

/// What a pixel of the latest frame shows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PixelHit {
    /// The world point seen at the pixel centre (m).
    pub point: DVec3,
    /// Unit normal of the surface there (world).
    pub normal: DVec3,
    /// Fine patch id.
    pub patch: u32,
    /// Surface id (index into the scene's surfaces).
    pub surface: u32,
    /// Illuminance there (lx, luma of the RGB illuminance), interpolated over the patch as the
    /// preview shades it.
    pub lux: f64,
}

/// The 3D image without overlays is reused while these stay the same.
#[derive(Debug, Clone, Copy, PartialEq)]
struct BaseKey {
    camera: Camera,
    size_px: (u32, u32),
    mode: DisplayMode,
    illuminance_version: u64,
}

/// Frame buffers kept across frames: the rendered image with depth and ids, a copy of its
/// pixels without overlays, per-vertex attributes and luma, and the fitted display shaders.
/// After the first frame of a size, rendering allocates nothing.
#[derive(Debug, Default)]
pub struct FrameBuffers {
    frame: Option<render::Frame>,
    view: Option<View>,
    base_pixels: Option<Pixmap>,
    base_key: Option<BaseKey>,
    attrs: Vec<[f32; 3]>,
    markers: Vec<LightMarker>,
    /// Luma of the total illuminance (lx) at each fine vertex.
    vertex_lux: Vec<f32>,
    /// Exposure chosen at the first photo frame and kept (a dimmed room looks darker).
    photo: Option<Photo>,
    /// Lux range fitted at the first false-colour frame and kept (a fixed scale while editing).
    false_color: Option<FalseColor>,
}

impl FrameBuffers {
    /// The latest frame and the view it was rendered through.
    pub fn latest(&self) -> Option<(&render::Frame, &View)> {
        Some((self.frame.as_ref()?, self.view.as_ref()?))
    }

    /// The shader of `mode` as fitted at the first frame of that mode, if there was one.
    pub fn fitted(&self, mode: DisplayMode) -> Option<DisplayShader> {
        match mode {
            DisplayMode::Photo => self.photo.map(DisplayShader::Photo),
            DisplayMode::FalseColor => self.false_color.map(DisplayShader::FalseColor),
        }
    }

    /// Forgets the fitted exposure and lux range: the next frame fits them anew.
    pub fn refit_display(&mut self) {
        self.photo = None;
        self.false_color = None;
        self.base_key = None;
    }

    /// The shader of `mode`, fitted to the current attributes the first time.
    fn shader(&mut self, mesh: &PatchMesh, mode: DisplayMode) -> DisplayShader {
        match mode {
            DisplayMode::Photo => {
                DisplayShader::Photo(*self.photo.get_or_insert_with(|| Photo::auto(mesh, &self.attrs)))
            }
            DisplayMode::FalseColor => DisplayShader::FalseColor(
                *self
                    .false_color
                    .get_or_insert_with(|| FalseColor::fit(&self.attrs, LuxScale::Log)),
            ),
        }
    }

    /// Renders `scene` lit by `illuminance_lx` (per fine vertex, lx, linear RGB; its version
    /// number changes whenever it does) through `camera` as `spec` says, with the overlays of
    /// `lights`. The 3D image is re-rasterised only when the camera, size, mode or illuminance
    /// changed; otherwise its saved pixels are copied back and the overlays drawn anew.
    ///
    /// Errors: a bad size or camera (bad input), an internal render failure.
    pub fn render(
        &mut self,
        scene: &Scene,
        illuminance_lx: (&[[f64; 3]], u64),
        camera: Camera,
        spec: &FrameSpec,
        lights: &[LightEdit],
    ) -> Result<&render::Frame> {
        let (width, height) = spec.size_px;
        check_size(width, height, ["width", "height"])?;
        let key = BaseKey {
            camera,
            size_px: spec.size_px,
            mode: spec.mode,
            illuminance_version: illuminance_lx.1,
        };
        if self.base_key != Some(key) {
            let view = View::new(camera, width, height)?;
            self.fill_attributes(scene, illuminance_lx.0, spec.mode)?;
            let shader = self.shader(&scene.fine, spec.mode);
            let frame = match &mut self.frame {
                Some(frame) => frame,
                none => none.insert(render::Frame::new(width, height)?),
            };
            render::render_into(frame, &scene.fine, &self.attrs, &view, &shader)?;
            match &mut self.base_pixels {
                Some(pixels) if pixels.width() == width && pixels.height() == height => {
                    pixels.data_mut().copy_from_slice(frame.pixmap.data());
                }
                slot => *slot = Some(frame.pixmap.clone()),
            }
            self.view = Some(view);
            self.base_key = Some(key);
        } else if let (Some(frame), Some(pixels)) = (&mut self.frame, &self.base_pixels) {
            frame.pixmap.data_mut().copy_from_slice(pixels.data());
        }
        let (Some(frame), Some(view)) = (self.frame.as_mut(), self.view.as_ref()) else {
            unreachable!("a frame was rendered above");
        };
        self.markers.clear();
        self.markers
            .extend(lights.iter().enumerate().map(|(i, light)| LightMarker {
                position: light.position,
                aim_target: aim_target(light, scene.room_size),
                selected: spec.selected_light == Some(i),
            }));
        draw_lights(frame, view, &self.markers);
        if let Some((x, y)) = spec.cursor {
            draw_crosshair(&mut frame.pixmap, x, y);
        }
        Ok(frame)
    }

    /// Per-vertex attributes of `mode` and the per-vertex luma, into the kept buffers.
    fn fill_attributes(
        &mut self,
        scene: &Scene,
        illuminance_lx: &[[f64; 3]],
        mode: DisplayMode,
    ) -> Result<()> {
        vertex_attributes_into(
            mode,
            &scene.fine,
            &scene.surfaces,
            illuminance_lx,
            &mut self.attrs,
        )?;
        self.vertex_lux.clear();
        self.vertex_lux
            .extend(illuminance_lx.iter().map(|&e| luma(e) as f32));
        Ok(())
    }

    /// What pixel `(x, y)` of the latest frame shows; `None` for the background, a pixel outside
    /// it, or before the first frame.
    pub fn pick(&self, mesh: &PatchMesh, (x, y): (u32, u32)) -> Option<PixelHit> {
        let (frame, view) = self.latest()?;
        let hit = render::pick(frame, view, mesh, x, y)?;
        let lux = lux_at(mesh, hit.patch, hit.point, &self.vertex_lux)?;
        Some(PixelHit {
            point: hit.point,
            normal: hit.normal,
            patch: hit.patch,
            surface: hit.surface,
            lux,
        })
    }
}

/// Refuses an image side of 0 or above [`MAX_SIDE_PX`]: bad input naming the side as `names`
/// call them (e.g. `["--width", "--height"]` on the command line).
pub fn check_size(width: u32, height: u32, names: [&str; 2]) -> Result<()> {
    for (side, name) in [(width, names[0]), (height, names[1])] {
        if side == 0 || side > MAX_SIDE_PX {
            return Err(crate::error::Error::input(
                name,
                "",
                format!("{side} pixels is outside 1..={MAX_SIDE_PX}"),
            ));
        }
    }
    Ok(())
}

/// Where the light's aim line ends (world, m): its target point, or for an aim given as a
/// direction, where the ray along it leaves the room box `(0, 0, 0)..room_size`.
pub fn aim_target(light: &LightEdit, room_size: DVec3) -> DVec3 {
    match light.aim_spec {
        AimSpec::Target(point) => point,
        AimSpec::Direction(_) => {
            light.position + light.aim * ray_exit_distance(light.position, light.aim, room_size)
        }
    }
}

/// Distance (m) along the unit `dir` from `origin` to the boundary of the box
/// `(0, 0, 0)..size`; 0 when the ray starts outside or on the way out.
fn ray_exit_distance(origin: DVec3, dir: DVec3, size: DVec3) -> f64 {
    (0..3)
        .filter(|&axis| dir[axis] != 0.0)
        .map(|axis| {
            let wall = if dir[axis] > 0.0 { size[axis] } else { 0.0 };
            ((wall - origin[axis]) / dir[axis]).max(0.0)
        })
        .fold(f64::INFINITY, f64::min)
        .min(size.length())
}

/// Illuminance (lx) at `point` on patch `patch`, linear over the patch's triangle that holds
/// it (quads split along the 0–2 diagonal, as the renderer does), from per-vertex values.
pub fn lux_at(mesh: &PatchMesh, patch: u32, point: DVec3, vertex_lux: &[f32]) -> Option<f64> {
    let p = mesh.patches.get(patch as usize)?;
    let v = p.vertices;
    let triangles = [[v[0], v[1], v[2]], [v[0], v[2], v[3]]];
    let count = if p.n_vertices == 4 { 2 } else { 1 };
    let corner = |id: u32| {
        let i = id as usize;
        Some((*mesh.positions.get(i)?, f64::from(*vertex_lux.get(i)?)))
    };
    let mut best: Option<(f64, f64)> = None; // (smallest barycentric weight, value)
    for triangle in &triangles[..count] {
        let [a, b, c] = [corner(triangle[0])?, corner(triangle[1])?, corner(triangle[2])?];
        let Some(weights) = barycentric(point, a.0, b.0, c.0) else {
            continue;
        };
        let inside = weights.min_element();
        let w = weights.max(DVec3::ZERO);
        let value = (w.x * a.1 + w.y * b.1 + w.z * c.1) / w.element_sum();
        if best.is_none_or(|(b, _)| inside > b) {
            best = Some((inside, value));
        }
    }
    best.map(|(_, value)| value)
}

/// Barycentric weights of `p` (projected onto the triangle's plane) in triangle `a b c`;
/// `None` for a degenerate triangle.
fn barycentric(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> Option<DVec3> {
    let (e0, e1, d) = (b - a, c - a, p - a);
    let (d00, d01, d11) = (e0.dot(e0), e0.dot(e1), e1.dot(e1));
    let (d20, d21) = (d.dot(e0), d.dot(e1));
    let denom = d00 * d11 - d01 * d01;
    if denom.abs() <= f64::EPSILON * d00 * d11 {
        return None;
    }
    let v = (d11 * d20 - d01 * d21) / denom;
    let w = (d00 * d21 - d01 * d20) / denom;
    Some(DVec3::new(1.0 - v - w, v, w))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::model::Patch;

    #[test]
    fn lux_at_reproduces_a_linear_field_on_a_quad() {
        let positions = vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(2.0, 1.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
        ];
        let field = |p: DVec3| 10.0 * p.x + 20.0 * p.y + 5.0;
        let lux: Vec<f32> = positions.iter().map(|&p| field(p) as f32).collect();
        let mesh = PatchMesh {
            normals: vec![DVec3::Z; 4],
            vertex_surface: vec![0; 4],
            patches: vec![Patch {
                vertices: [0, 1, 2, 3],
                n_vertices: 4,
                surface: 0,
                normal: DVec3::Z,
                area: 2.0,
                centroid: DVec3::new(1.0, 0.5, 0.0),
            }],
            positions,
        };
        for point in [
            DVec3::new(0.3, 0.8, 0.0),
            DVec3::new(1.7, 0.2, 0.0),
            DVec3::new(1.0, 0.5, 0.0),
            DVec3::new(2.0, 1.0, 0.0),
        ] {
            let got = lux_at(&mesh, 0, point, &lux).unwrap();
            assert!(
                (got - field(point)).abs() < 1e-4,
                "{point}: {got} vs {}",
                field(point)
            );
        }
        assert_eq!(lux_at(&mesh, 1, DVec3::ZERO, &lux), None);
    }

    #[test]
    fn aim_along_a_direction_ends_where_the_ray_leaves_the_room() {
        let curve = crate::photometry::Curve::isotropic(100.0);
        let mut light = LightEdit {
            name: "l".into(),
            position: DVec3::new(1.0, 1.0, 2.5),
            aim: DVec3::new(1.0, 0.0, -1.0).normalize(),
            aim_spec: AimSpec::Direction(DVec3::new(1.0, 0.0, -1.0).normalize()),
            curve,
            lid_source: crate::scene::LidSource::Inline,
            dimmer: 1.0,
            order: 3,
            window: crate::session::WindowChoice::Auto,
            radius_m: 0.0,
            color: [1.0; 3],
            luminous: None,
        };
        // z falls 2.5 m over 2.5 m of x: the floor at (3.5, 1, 0), before the wall x = 6.
        let end = aim_target(&light, DVec3::new(6.0, 4.0, 2.7));
        assert!((end - DVec3::new(3.5, 1.0, 0.0)).length() < 1e-12, "{end}");
        light.aim_spec = AimSpec::Target(DVec3::new(2.0, 2.0, 2.0));
        assert_eq!(
            aim_target(&light, DVec3::new(6.0, 4.0, 2.7)),
            DVec3::new(2.0, 2.0, 2.0)
        );
    }
}
