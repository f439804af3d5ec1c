//! The preview's pixels, without a terminal: applies the editor's light states to the
//! [`Relighter`] (recomputing only the lights that changed), renders the fine mesh at the
//! preview's pixel size, draws the overlays (lights, the selected light's aim, the aim cursor)
//! and answers picks (the world point and the illuminance under a pixel).
//!
//! The render worker ([`crate::tui::workers`]) owns one [`PreviewRenderer`]; the bench drives it
//! directly. World frame: metres, z up (docs/METHOD.md §1); pixels as in [`crate::render::camera`].

use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::DVec3;

use crate::error::{Error, Result};
use crate::photometry;
use crate::relight::Relighter;
use crate::render::shade::luma;
use crate::render::{
    self, DisplayMode, DisplayShader, LightMarker, View, draw_crosshair, draw_lights, vertex_attributes,
};
use crate::scene::{AimSpec, Camera, PatchMesh, Scene};
use crate::transport::bake::{BakeOptions, Progress, bake};
use crate::tui::model::{LightEdit, Mode, Model, Window};

/// Everything one preview frame shows, snapshotted from the editor's model.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameRequest {
    /// Every light's editable state, in file order.
    pub lights: Vec<LightEdit>,
    /// Index of the selected light (its aim line is drawn).
    pub selected_light: usize,
    /// The preview camera.
    pub camera: Camera,
    /// Image size in pixels (width, height), both ≥ 1.
    pub size_px: (u32, u32),
    /// Photo or false colour.
    pub mode: DisplayMode,
    /// The aim cursor (preview pixel), drawn as a crosshair in aim mode.
    pub cursor: Option<(u32, u32)>,
}

impl FrameRequest {
    /// The frame `model` asks for; `None` while the preview has no pixels (terminal too small).
    pub fn from_model(model: &Model) -> Option<FrameRequest> {
        let (width, height) = model.preview_px;
        (width > 0 && height > 0).then(|| FrameRequest {
            lights: model.lights.clone(),
            selected_light: model.selected_light,
            camera: model.camera,
            size_px: model.preview_px,
            mode: if model.false_colour {
                DisplayMode::FalseColor
            } else {
                DisplayMode::Photo
            },
            cursor: match model.mode {
                Mode::Aim { cursor } => Some(cursor),
                _ => None,
            },
        })
    }
}

/// A rendered preview with what picking needs.
#[derive(Debug, Clone)]
pub struct PreviewFrame {
    /// Colour image with overlays, depth and patch ids.
    pub frame: render::Frame,
    /// The view it was rendered through.
    pub view: View,
    /// Luma of the total illuminance (lx) at each fine vertex when it was rendered.
    pub vertex_lux: Arc<Vec<f32>>,
}

impl PreviewFrame {
    /// The world point (m) under preview pixel `pixel` of `mesh` (the scene's fine mesh) and
    /// the illuminance there (lx, interpolated over the patch like the Gouraud shading);
    /// `None` for the background or a pixel outside the image.
    pub fn pick(&self, mesh: &PatchMesh, pixel: (u32, u32)) -> Option<(DVec3, f64)> {
        let hit = render::pick(&self.frame, &self.view, mesh, pixel.0, pixel.1)?;
        let lux = lux_at(mesh, hit.patch, hit.point, &self.vertex_lux)?;
        Some((hit.point, lux))
    }
}

/// What [`PreviewRenderer::apply_lights`] recomputed.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Applied {
    /// Lights whose illuminance was recomputed.
    pub relit: Vec<usize>,
    /// True when a light moved and every light's direct cache was rebuilt.
    pub rebuilt: bool,
}

/// The cached 3D render without overlays: reused when only the overlays change.
#[derive(Debug, Clone, PartialEq)]
struct BaseKey {
    camera: Camera,
    size_px: (u32, u32),
    mode: DisplayMode,
    lights_version: u64,
}

/// Owns the scene's relighting state and renders preview frames.
#[derive(Debug)]
pub struct PreviewRenderer {
    scene: Arc<Scene>,
    cache_dir: Option<PathBuf>,
    relighter: Relighter,
    applied: Vec<LightEdit>,
    lights_version: u64,
    vertex_lux: Arc<Vec<f32>>,
    base: Option<(BaseKey, render::Frame)>,
}

impl PreviewRenderer {
    /// Loads the bake from the cache in `cache_dir` (or bakes without a cache when `None`),
    /// reporting `progress`, and caches every light's direct illuminance at the fine vertices:
    /// the slow start-up step, run on a worker.
    ///
    /// Errors: the interreflection solve failing (an internal error).
    pub fn new(
        scene: Arc<Scene>,
        cache_dir: Option<PathBuf>,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<PreviewRenderer> {
        let relighter = baked_relighter(&scene, cache_dir.as_deref(), progress)?;
        let applied = scene.lights.iter().map(LightEdit::from_light).collect();
        let mut renderer = PreviewRenderer {
            scene,
            cache_dir,
            relighter,
            applied,
            lights_version: 0,
            vertex_lux: Arc::default(),
            base: None,
        };
        renderer.refresh_vertex_lux();
        Ok(renderer)
    }

    /// The scene rendered.
    pub fn scene(&self) -> &Arc<Scene> {
        &self.scene
    }

    /// Brings the illuminance up to date with `lights` (the editor's states, in file order):
    /// a light whose curve, aim or dimmer changed is re-blended alone; when a light moved,
    /// the direct caches are rebuilt for the new positions.
    ///
    /// Errors (internal): a light count that differs from the scene's.
    pub fn apply_lights(&mut self, lights: &[LightEdit]) -> Result<Applied> {
        if lights.len() != self.applied.len() {
            return Err(Error::internal(format!(
                "preview: {} light states for {} lights",
                lights.len(),
                self.applied.len()
            )));
        }
        let mut applied = Applied::default();
        if lights
            .iter()
            .zip(&self.applied)
            .any(|(now, was)| now.position != was.position || now.order != was.order)
        {
            self.rebuild(lights)?;
            applied.rebuilt = true;
            applied.relit = (0..lights.len()).collect();
        } else {
            for (i, (now, was)) in lights.iter().zip(&self.applied).enumerate() {
                let mut changed = false;
                if now.curve != was.curve {
                    self.relighter.set_curve(i, now.curve.clone());
                    changed = true;
                }
                if now.aim != was.aim {
                    self.relighter.set_aim(i, now.aim);
                    changed = true;
                }
                if now.dimmer != was.dimmer {
                    self.relighter.set_dimmer(i, now.dimmer);
                    changed = true;
                }
                if now.window != was.window {
                    self.relighter.set_window(i, relight_window(now.window));
                    changed = true;
                }
                if changed {
                    applied.relit.push(i);
                }
            }
        }
        self.applied = lights.to_vec();
        if !applied.relit.is_empty() {
            self.lights_version += 1;
            self.refresh_vertex_lux();
        }
        Ok(applied)
    }

    /// Renders `request` (its lights must have been applied with [`Self::apply_lights`]): the
    /// 3D image is re-rasterised only when the camera, size, mode or illuminance changed;
    /// the overlays are drawn afresh on every call.
    ///
    /// Errors: a request the view rejects (bad camera), or an internal render failure.
    pub fn render(&mut self, request: &FrameRequest) -> Result<PreviewFrame> {
        let (width, height) = request.size_px;
        let view = View::new(request.camera, width, height)?;
        let key = BaseKey {
            camera: request.camera,
            size_px: request.size_px,
            mode: request.mode,
            lights_version: self.lights_version,
        };
        let mut frame = match &self.base {
            Some((cached, frame)) if *cached == key => frame.clone(),
            _ => {
                let frame = self.render_base(request.mode, &view)?;
                self.base = Some((key, frame.clone()));
                frame
            }
        };
        draw_overlays(&mut frame, &view, request, self.scene.room_size);
        Ok(PreviewFrame {
            frame,
            view,
            vertex_lux: Arc::clone(&self.vertex_lux),
        })
    }

    fn render_base(&self, mode: DisplayMode, view: &View) -> Result<render::Frame> {
        let mesh = &self.scene.fine;
        let attrs = vertex_attributes(mode, mesh, &self.scene.surfaces, self.relighter.total())?;
        let shader = DisplayShader::fit(mode, mesh, &attrs);
        render::render(mesh, &attrs, view, &shader)
    }

    /// Re-bakes after a light moved or its order changed: the per-light cache keys change only
    /// for that light, so the others load from the cache and only it is solved again.
    fn rebuild(&mut self, lights: &[LightEdit]) -> Result<()> {
        let mut scene = Scene::clone(&self.scene);
        for (light, edit) in scene.lights.iter_mut().zip(lights) {
            light.position = edit.position;
            light.aim = edit.aim;
            light.curve = edit.curve.clone();
            light.dimmer = edit.dimmer;
            light.order = Some(edit.order);
        }
        self.relighter = baked_relighter(&scene, self.cache_dir.as_deref(), &mut |_| {})?;
        for (i, edit) in lights.iter().enumerate() {
            if edit.window != Window::Auto {
                self.relighter.set_window(i, relight_window(edit.window));
            }
        }
        Ok(())
    }

    fn refresh_vertex_lux(&mut self) {
        self.vertex_lux = Arc::new(self.relighter.total().iter().map(|&e| luma(e) as f32).collect());
    }
}

/// A relighter with the scene's bake (from the bake cache in `cache_dir` when valid).
pub fn baked_relighter(
    scene: &Scene,
    cache_dir: Option<&Path>,
    progress: &mut dyn FnMut(Progress),
) -> Result<Relighter> {
    let options = BakeOptions {
        cache: cache_dir.map(crate::transport::cache::BakeCache::in_dir),
        ..BakeOptions::default()
    };
    let bake = bake(scene, &options, progress)?;
    Ok(Relighter::with_bake(scene, &bake))
}

/// The relighter's window for the editor's choice (`Auto`: decided per edit).
fn relight_window(window: Window) -> Option<photometry::Window> {
    match window {
        Window::Auto => None,
        Window::None => Some(photometry::Window::None),
        Window::Hann => Some(photometry::Window::Hann),
        Window::Lanczos => Some(photometry::Window::Lanczos),
        Window::Cesaro2 => Some(photometry::Window::Cesaro2),
    }
}

/// Draws every light, the selected light's aim line and target, and the aim cursor.
fn draw_overlays(frame: &mut render::Frame, view: &View, request: &FrameRequest, room_size: DVec3) {
    let markers: Vec<LightMarker> = request
        .lights
        .iter()
        .enumerate()
        .map(|(i, light)| LightMarker {
            position: light.position,
            aim_target: aim_target(light, room_size),
            selected: i == request.selected_light,
        })
        .collect();
    draw_lights(frame, view, &markers);
    if let Some((x, y)) = request.cursor {
        draw_crosshair(&mut frame.pixmap, x, y);
    }
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
    use std::path::Path;

    use super::*;
    use crate::photometry::Curve;
    use crate::render::overlay::CROSSHAIR_ARM_PX;
    use crate::render::render_attributes;
    use crate::scene::model::Patch;

    fn paper() -> Arc<Scene> {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("rooms/paper.toml");
        Arc::new(crate::scene::load(&path).unwrap())
    }

    fn request(scene: &Scene, lights: Vec<LightEdit>, cursor: Option<(u32, u32)>) -> FrameRequest {
        FrameRequest {
            lights,
            selected_light: 0,
            camera: scene.camera,
            size_px: (160, 120),
            mode: DisplayMode::Photo,
            cursor,
        }
    }

    fn edits(scene: &Scene) -> Vec<LightEdit> {
        scene.lights.iter().map(LightEdit::from_light).collect()
    }

    /// The total a fresh relighter computes for `scene` with `lights` applied.
    fn fresh_total(scene: &Scene, lights: &[LightEdit]) -> Vec<[f64; 3]> {
        let mut scene = scene.clone();
        for (light, edit) in scene.lights.iter_mut().zip(lights) {
            light.position = edit.position;
            light.aim = edit.aim;
            light.curve = edit.curve.clone();
            light.dimmer = edit.dimmer;
            light.order = Some(edit.order);
        }
        baked_relighter(&scene, None, &mut |_| {})
            .unwrap()
            .total()
            .to_vec()
    }

    fn assert_totals_close(a: &[[f64; 3]], b: &[[f64; 3]]) {
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(b) {
            for c in 0..3 {
                assert!((x[c] - y[c]).abs() <= 1e-9 * (1.0 + y[c].abs()), "{x:?} vs {y:?}");
            }
        }
    }

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
        let scene = paper();
        let mut light = LightEdit::from_light(&scene.lights[0]);
        light.position = DVec3::new(1.0, 1.0, 2.5);
        light.aim = DVec3::new(1.0, 0.0, -1.0).normalize();
        light.aim_spec = AimSpec::Direction(light.aim);
        // z falls 2.5 m over 2.5 m of x: the floor at (3.5, 1, 0), before the wall x = 6.
        let end = aim_target(&light, DVec3::new(6.0, 4.0, 2.7));
        assert!((end - DVec3::new(3.5, 1.0, 0.0)).length() < 1e-12, "{end}");
        light.aim_spec = AimSpec::Target(DVec3::new(2.0, 2.0, 2.0));
        assert_eq!(
            aim_target(&light, DVec3::new(6.0, 4.0, 2.7)),
            DVec3::new(2.0, 2.0, 2.0)
        );
    }

    #[test]
    fn applying_lights_relights_only_the_changed_one_and_matches_a_fresh_relighter() {
        let scene = paper();
        let mut renderer = PreviewRenderer::new(Arc::clone(&scene), None, &mut |_| {}).unwrap();
        let mut lights = edits(&scene);
        assert_eq!(renderer.apply_lights(&lights).unwrap(), Applied::default());

        lights[1].curve = Curve::new(&[(0.0, 3000.0), (20.0, 2000.0), (50.0, 0.0)]).unwrap();
        lights[1].dimmer = 0.5;
        let applied = renderer.apply_lights(&lights).unwrap();
        assert_eq!(applied.relit, [1]);
        assert!(!applied.rebuilt);
        assert_totals_close(renderer.relighter.total(), &fresh_total(&scene, &lights));

        lights[0].position += DVec3::new(-1.0, 0.5, 0.0);
        let applied = renderer.apply_lights(&lights).unwrap();
        assert!(applied.rebuilt);
        assert_totals_close(renderer.relighter.total(), &fresh_total(&scene, &lights));
        let expected_lux: Vec<f32> = renderer
            .relighter
            .total()
            .iter()
            .map(|&e| luma(e) as f32)
            .collect();
        assert_eq!(*renderer.vertex_lux, expected_lux);

        assert!(renderer.apply_lights(&lights[..1]).is_err());
    }

    #[test]
    fn a_cursor_move_redraws_only_the_overlay() {
        let scene = paper();
        let mut renderer = PreviewRenderer::new(Arc::clone(&scene), None, &mut |_| {}).unwrap();
        let plain = renderer.render(&request(&scene, edits(&scene), None)).unwrap();
        let cursor = (80, 60);
        let with_cursor = renderer
            .render(&request(&scene, edits(&scene), Some(cursor)))
            .unwrap();
        assert_eq!(plain.frame.ids, with_cursor.frame.ids);
        assert_eq!(plain.frame.depth, with_cursor.frame.depth);
        let reach = CROSSHAIR_ARM_PX as i64 + 2;
        let mut changed = 0;
        for (i, (a, b)) in plain
            .frame
            .pixmap
            .pixels()
            .iter()
            .zip(with_cursor.frame.pixmap.pixels())
            .enumerate()
        {
            if a != b {
                changed += 1;
                let (x, y) = ((i % 160) as i64, (i / 160) as i64);
                assert!(
                    (x - 80).abs() <= reach && (y - 60).abs() <= reach,
                    "pixel ({x}, {y}) changed"
                );
            }
        }
        assert!(changed > 0, "the crosshair was not drawn");
    }

    #[test]
    fn a_pick_reads_the_same_lux_as_the_rasterised_illuminance() {
        let scene = paper();
        let mut renderer = PreviewRenderer::new(Arc::clone(&scene), None, &mut |_| {}).unwrap();
        let req = request(&scene, edits(&scene), None);
        let preview = renderer.render(&req).unwrap();
        let attrs = vertex_attributes(
            DisplayMode::FalseColor,
            &scene.fine,
            &scene.surfaces,
            renderer.relighter.total(),
        )
        .unwrap();
        let raster = render_attributes(&scene.fine, &attrs, &preview.view).unwrap();
        for pixel in [(80, 60), (20, 100), (140, 15)] {
            let (point, lux) = preview.pick(&scene.fine, pixel).expect("the room fills the view");
            let inside = (0..3).all(|a| point[a] > -1e-3 && point[a] < scene.room_size[a] + 1e-3);
            assert!(inside, "{point}");
            let expected = luma(raster.pixels[(pixel.1 * 160 + pixel.0) as usize].map(f64::from));
            assert!(
                (lux - expected).abs() <= 0.01 * expected,
                "{pixel:?}: {lux} vs {expected}"
            );
        }
    }
}
