//! The session's preview frames: what a frame shows ([`FrameSpec`]: size, display mode, camera
//! or plan view, exposure, isolux lines, legend, overlays), the buffers reused from frame to
//! frame ([`FrameBuffers`]) and picking with the illuminance under a pixel.
//!
//! Direct light is exact per pixel ([`PixelLighting`], docs/DECISIONS.md "Per-pixel direct
//! light"): a camera or view change rebuilds the per-pixel surfaces and casts the shadow rays
//! again; a moved light casts its own again; a curve, aim, dimmer or colour edit re-evaluates
//! only that light per lit pixel. Indirect light stays per vertex (Gouraud over each pixel's
//! triangle). In paper mode (`direct = "basis"`) the whole per-vertex illuminance is
//! interpolated instead, as the series gives it.
//! World frame: metres, z up; pixels as in [`crate::render::camera`] (docs/METHOD.md §1).

use glam::DVec3;
use tiny_skia::Pixmap;

use crate::error::Result;
use crate::photometry::LightState;
use crate::relight::Relighter;
use crate::render::exposure::room_ev100;
use crate::render::plan::{
    PlanLight, draw_plan_lights, plan_view_beside, work_plane_gather, work_plane_indirect, work_plane_mesh,
    work_plane_receivers,
};
use crate::render::shade::luma;
use crate::render::{
    self, DisplayMode, DisplayShader, FalseColor, LightMarker, LuxScale, Photo, PixelLight, PixelLighting,
    PixelSurfaces, View, draw_crosshair, draw_isolux, draw_legend, draw_lights, legend_width, luma_values,
    round_levels, vertex_attributes_into,
};
use crate::scene::design::{Design, Placement};
use crate::scene::model::{PatchMesh, Surface, SurfaceKind};
use crate::scene::{AimSpec, Camera, DirectMode, Scene};
use crate::session::light::LightEdit;
use crate::transport::bake::Bake;
use crate::transport::gather::GatherOperator;
use crate::transport::indirect::HierarchicalIndirect;
use crate::transport::occlusion::Occluders;

/// Largest image side (pixels) a frame may have.
pub const MAX_SIDE_PX: u32 = 8192;

/// At most this many isolux levels are drawn (round values over the false-colour range).
pub const MAX_ISOLUX_LEVELS: usize = 8;

/// Where the frame looks from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ViewChoice {
    /// The session's perspective camera.
    #[default]
    Camera,
    /// The plan: straight down onto the floor with a parallel projection, the room's footprint
    /// filling the image (left of the legend when one is drawn), luminaire symbols with their
    /// aim ([`crate::render::plan`]).
    Plan,
    /// The plan of the design's work plane (the height of the room's first horizontal
    /// calculation surface, `[[surface]]` in docs/ROOM_FILE.md, 0.8 m by default): each pixel
    /// is the point of the plane below it, with exact per-pixel direct light (shadows of the
    /// boxes above it included) and the indirect light gathered at the plane's vertices from the
    /// bake's coarse patches, as the numbers (`haiko grid`, `haiko probe`) compute it; cells
    /// inside boxes are left out. Photo mode shows the plane with the floor's reflectance.
    WorkPlane,
}

impl ViewChoice {
    /// True for the plan views (floor or work plane).
    pub fn is_plan(self) -> bool {
        matches!(self, ViewChoice::Plan | ViewChoice::WorkPlane)
    }
}

/// How the photo mode is exposed (docs/DECISIONS.md, "Fixed exposure").
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ExposureChoice {
    /// The room's exposure, chosen from the room at the first photo frame (or the first after a
    /// refit) and kept across edits, moved by `brighter_ev` stops (negative: darker).
    Room {
        /// Stops brighter than the room's exposure.
        brighter_ev: f64,
    },
    /// Fixed at this EV₁₀₀ of the luminance shown as mid-grey ([`crate::render::exposure`]).
    Ev100(f64),
    /// Chosen anew from the room at every frame (scaling every light leaves the picture alike).
    Auto,
}

impl Default for ExposureChoice {
    fn default() -> Self {
        ExposureChoice::Room { brighter_ev: 0.0 }
    }
}

/// What one preview frame shows besides the lit room.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameSpec {
    /// Image size in pixels (width, height), each 1..=[`MAX_SIDE_PX`].
    pub size_px: (u32, u32),
    /// Photo or false colour.
    pub mode: DisplayMode,
    /// Camera or plan view.
    pub view: ViewChoice,
    /// The photo mode's exposure.
    pub exposure: ExposureChoice,
    /// Draw isolux lines at round values of the false-colour scale (both modes).
    pub isolux: bool,
    /// Draw the false-colour legend (a colour bar with lux ticks) at the right edge.
    pub legend: bool,
    /// Refit counter: when it differs from the previous frame's, the room's exposure and the
    /// false-colour range are chosen anew (the editor's reset key).
    pub refit: u32,
    /// The selected light (its aim line and target are drawn), if any.
    pub selected_light: Option<usize>,
    /// The aim cursor (preview pixel), drawn as a crosshair.
    pub cursor: Option<(u32, u32)>,
}

impl FrameSpec {
    /// A frame of `size_px` in `mode` through the camera: the room's exposure, the legend in
    /// false colour, no isolux lines, no selection or cursor.
    pub fn new(size_px: (u32, u32), mode: DisplayMode) -> FrameSpec {
        FrameSpec {
            size_px,
            mode,
            view: ViewChoice::Camera,
            exposure: ExposureChoice::default(),
            isolux: false,
            legend: true,
            refit: 0,
            selected_light: None,
            cursor: None,
        }
    }
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
    /// Illuminance at the pixel (lx, luma of the RGB illuminance) as the preview shades it:
    /// exact direct light plus the interpolated indirect light.
    pub lux: f64,
}

/// The per-pixel surfaces depend on these.
#[derive(Debug, Clone, Copy, PartialEq)]
struct ViewKey {
    camera: Camera,
    size_px: (u32, u32),
    view: ViewChoice,
    /// Pixels at the right edge a plan keeps free for the legend.
    free_right_px: u32,
}

/// The 3D image without overlays is reused while these stay the same.
#[derive(Debug, Clone, Copy, PartialEq)]
struct BaseKey {
    view: ViewKey,
    mode: DisplayMode,
    shader: DisplayShader,
    isolux: bool,
    legend: bool,
    /// Bumped whenever the per-pixel or per-vertex light changes.
    light_version: u64,
}

/// The design's work plane as the work-plane plan shows it.
#[derive(Debug)]
struct PlaneState {
    /// Height above the floor (m).
    height_m: f64,
    mesh: PatchMesh,
    /// Its one surface, with the floor's reflectance (for photo mode).
    surfaces: Vec<Surface>,
    /// Indirect light at its vertices (lx, linear RGB) and what it was gathered for
    /// ([`PlaneIndirect::key`]).
    indirect: Option<(PlaneKey, Vec<[f32; 3]>)>,
    /// The gather from the coarse patches to its vertices, built on first need.
    gather: Option<GatherOperator>,
}

impl PlaneState {
    /// The work plane of `scene`'s design, meshed at the room's patch size.
    fn of_scene(scene: &Scene) -> Result<PlaneState> {
        let height_m = work_plane_height(scene);
        let (mesh, mut surfaces) =
            work_plane_mesh(scene.room_size, &scene.boxes, height_m, scene.settings.patch_size)?;
        if let Some(floor) = scene.surfaces.iter().find(|s| s.kind == SurfaceKind::Floor) {
            surfaces[0].reflectance = floor.reflectance;
        }
        Ok(PlaneState {
            height_m,
            mesh,
            surfaces,
            indirect: None,
            gather: None,
        })
    }
}

/// Height (m) of `scene`'s work plane: its design's first horizontal calculation surface, else
/// the default 0.8 m (at most half the room's height).
pub fn work_plane_height(scene: &Scene) -> f64 {
    scene
        .design
        .surfaces
        .iter()
        .find_map(|s| match s.placement {
            Placement::Horizontal { height_m, .. } => Some(height_m),
            Placement::Room { .. } => None,
        })
        .unwrap_or_else(
            || match &Design::default_for(scene.room_size).surfaces[0].placement {
                Placement::Horizontal { height_m, .. } => *height_m,
                Placement::Room { .. } => 0.5 * scene.room_size.z,
            },
        )
}

/// The per-pixel direct light for one view and what it was built for.
#[derive(Debug)]
struct PixelState {
    lighting: PixelLighting,
    view: View,
    key: ViewKey,
}

/// Where the work plane's indirect light comes from: the SH basis bake through the plane's
/// gather from the coarse patches, or the hierarchical engine's clustered gather from its leaves
/// (what `haiko probe` and `grid` use).
#[derive(Debug, Clone, Copy)]
pub enum PlaneIndirect<'a> {
    Basis(&'a Bake),
    Leaves(&'a HierarchicalIndirect),
}

/// What a work plane's gathered indirect light was computed for ([`PlaneIndirect::key`]).
type PlaneKey = (bool, u64);

impl PlaneIndirect<'_> {
    /// What the plane's gathered values depend on: the lights' state (`illuminance_version`)
    /// for the basis, only the engine's solved values for the leaves — an edit whose solve is
    /// still pending gathers nothing new.
    fn key(&self, illuminance_version: u64) -> PlaneKey {
        match self {
            PlaneIndirect::Basis(_) => (false, illuminance_version),
            PlaneIndirect::Leaves(engine) => (true, engine.revision()),
        }
    }
}

/// Frame buffers kept across frames: the rendered image with depth and ids, a copy of its
/// pixels without overlays, the per-pixel direct light, the per-vertex light interpolated over
/// it, and the fitted exposure and lux range. After the first frame of a view, a light edit
/// allocates nothing.
#[derive(Debug, Default)]
pub struct FrameBuffers {
    frame: Option<render::Frame>,
    pixel: Option<PixelState>,
    /// The scene's occluders (boxes, OBJ triangles), built at the first frame.
    occluders: Option<Option<Occluders>>,
    /// The work plane, built at the first work-plane plan.
    plane: Option<PlaneState>,
    base_pixels: Option<Pixmap>,
    base_key: Option<BaseKey>,
    /// Per-vertex light the pixels interpolate: indirect light (lx, linear RGB), or in paper
    /// mode the whole illuminance; `None` when there is none (direct light only).
    vertex_light: Option<Vec<[f32; 3]>>,
    /// `illuminance_version` of `vertex_light`.
    vertex_version: Option<u64>,
    /// Per-vertex display attributes (to fit the exposure and the lux range).
    attrs: Vec<[f32; 3]>,
    /// Per-pixel illuminance of the latest frame (lx, linear RGB), when isolux lines needed it.
    lux: Vec<[f32; 3]>,
    markers: Vec<LightMarker>,
    /// EV₁₀₀ of the room's exposure, chosen at the first photo frame and kept.
    room_ev100: Option<f64>,
    /// The photo shader of the latest photo frame.
    photo: Option<Photo>,
    /// Lux range fitted at the first frame that needed it and kept (a fixed scale while editing).
    false_color: Option<FalseColor>,
    /// `FrameSpec::refit` of the latest frame.
    refit: Option<u32>,
    light_version: u64,
}

impl FrameBuffers {
    /// The latest frame and the view it was rendered through.
    pub fn latest(&self) -> Option<(&render::Frame, &View)> {
        Some((self.frame.as_ref()?, &self.pixel.as_ref()?.view))
    }

    /// The shader of `mode` the latest frame of that mode used (exposure or lux range).
    pub fn fitted(&self, mode: DisplayMode) -> Option<DisplayShader> {
        match mode {
            DisplayMode::Photo => self.photo.map(DisplayShader::Photo),
            DisplayMode::FalseColor => self.false_color.map(DisplayShader::FalseColor),
        }
    }

    /// Forgets the fitted exposure and lux range: the next frame fits them anew.
    pub fn refit_display(&mut self) {
        self.room_ev100 = None;
        self.false_color = None;
        self.base_key = None;
    }

    /// Bytes the per-pixel light holds per pixel whatever the number of lights, and per
    /// (light, pixel); `None` before the first frame.
    pub fn memory_per_pixel(&self) -> Option<(f64, f64)> {
        self.pixel.as_ref().map(|p| p.lighting.memory_per_pixel())
    }

    /// Renders `scene` lit by `relighter` (its `illuminance_version` changes whenever its light
    /// does) with the current `lights` through `camera` as `spec` says. The per-pixel surfaces
    /// are rebuilt only when the view changed, a light's shadow rays only when it moved, and the
    /// 3D image only when something it shows changed; otherwise its saved pixels are copied back
    /// and the overlays drawn anew.
    ///
    /// Errors: a bad size or camera (bad input), an internal render failure.
    pub fn render(
        &mut self,
        scene: &Scene,
        (relighter, illuminance_version): (&Relighter, u64),
        indirect: Option<PlaneIndirect<'_>>,
        camera: Camera,
        spec: &FrameSpec,
        lights: &[LightEdit],
    ) -> Result<&render::Frame> {
        let (width, height) = spec.size_px;
        check_size(width, height, ["width", "height"])?;
        if self.refit != Some(spec.refit) {
            if self.refit.is_some() {
                self.refit_display();
            }
            self.refit = Some(spec.refit);
        }
        let paper_mode = scene.settings.direct == DirectMode::Basis;
        self.sync_vertex_light(relighter, illuminance_version, paper_mode);
        let shader = self.shader(scene, relighter, spec)?;
        // A plan's footprint stands left of the legend, not under it.
        let free_right_px = match (spec.view, spec.legend, shader) {
            (view, true, DisplayShader::FalseColor(scale)) if view.is_plan() => {
                legend_width(width, height, &scale)
            }
            _ => 0,
        };
        self.sync_pixels(scene, camera, spec, lights, paper_mode, free_right_px)?;
        if spec.view == ViewChoice::WorkPlane {
            let source = relighter.has_indirect().then_some(indirect).flatten();
            self.sync_plane_light(scene, source, lights, illuminance_version);
        }
        let pixel = self
            .pixel
            .as_ref()
            .ok_or_else(|| crate::error::Error::internal("frame: no per-pixel light after building it"))?;
        let key = BaseKey {
            view: pixel.key,
            mode: spec.mode,
            shader,
            isolux: spec.isolux,
            legend: spec.legend,
            light_version: self.light_version,
        };
        let frame = self
            .frame
            .as_mut()
            .ok_or_else(|| crate::error::Error::internal("frame: no frame after the surfaces"))?;
        if self.base_key != Some(key) {
            let vertex_light = shown_vertex_light(pixel.key.view, &self.vertex_light, &self.plane);
            let lux = spec.isolux.then_some(&mut self.lux);
            pixel.lighting.render_into(frame, vertex_light, &shader, lux)?;
            if spec.isolux {
                let scale = kept_false_color(&mut self.false_color, scene, relighter, &mut self.attrs)?;
                let (lo, hi) = scale.range();
                let surfaces = pixel.lighting.surfaces();
                draw_isolux(
                    &mut frame.pixmap,
                    &luma_values(&self.lux),
                    |i| surfaces.surface(i),
                    &round_levels(lo, hi, MAX_ISOLUX_LEVELS),
                );
            }
            if let (true, DisplayShader::FalseColor(scale)) = (spec.legend, shader) {
                draw_legend(&mut frame.pixmap, &scale);
            }
            match &mut self.base_pixels {
                Some(pixels) if pixels.width() == width && pixels.height() == height => {
                    pixels.data_mut().copy_from_slice(frame.pixmap.data());
                }
                slot => *slot = Some(frame.pixmap.clone()),
            }
            self.base_key = Some(key);
        } else if let Some(pixels) = &self.base_pixels {
            frame.pixmap.data_mut().copy_from_slice(pixels.data());
        }
        match pixel.key.view {
            ViewChoice::Camera => {
                self.markers.clear();
                self.markers
                    .extend(lights.iter().enumerate().map(|(i, light)| LightMarker {
                        position: light.position,
                        aim_target: aim_target(light, scene.room_size),
                        selected: spec.selected_light == Some(i),
                    }));
                draw_lights(frame, &pixel.view, &self.markers);
            }
            view @ (ViewChoice::Plan | ViewChoice::WorkPlane) => {
                let symbols: Vec<PlanLight> = lights
                    .iter()
                    .enumerate()
                    .map(|(i, light)| PlanLight {
                        name: light.name.clone(),
                        position: light.position,
                        aim: light.aim,
                        selected: spec.selected_light == Some(i),
                    })
                    .collect();
                let plane_z = match (view, &self.plane) {
                    (ViewChoice::WorkPlane, Some(plane)) => plane.height_m,
                    _ => 0.0,
                };
                draw_plan_lights(&mut frame.pixmap, &pixel.view, &symbols, plane_z);
            }
        }
        if let Some((x, y)) = spec.cursor {
            draw_crosshair(&mut frame.pixmap, x, y);
        }
        Ok(frame)
    }

    /// Brings the per-vertex light up to `illuminance_version`: the relighter's indirect light,
    /// or in paper mode its whole illuminance; none without interreflection.
    fn sync_vertex_light(&mut self, relighter: &Relighter, illuminance_version: u64, paper_mode: bool) {
        if self.vertex_version == Some(illuminance_version) {
            return;
        }
        self.vertex_version = Some(illuminance_version);
        self.light_version += 1;
        if paper_mode {
            let values = self.vertex_light.get_or_insert_with(Vec::new);
            values.clear();
            values.extend(relighter.total().iter().map(|e| e.map(|x| x as f32)));
        } else if relighter.has_indirect() {
            relighter.indirect_into(self.vertex_light.get_or_insert_with(Vec::new));
        } else {
            self.vertex_light = None;
        }
    }

    /// Gathers the indirect light at the work plane's vertices for the lights' current state
    /// when the light changed since (`bake`: the session's, `None` without indirect light),
    /// through the plane's gather operator (its form factors and shadow rays computed once).
    fn sync_plane_light(
        &mut self,
        scene: &Scene,
        indirect: Option<PlaneIndirect<'_>>,
        lights: &[LightEdit],
        version: u64,
    ) {
        let Some(plane) = self.plane.as_mut() else {
            return;
        };
        let Some(indirect) = indirect else {
            plane.indirect = None;
            return;
        };
        let key = indirect.key(version);
        if plane.indirect.as_ref().is_some_and(|(k, _)| *k == key) {
            return;
        }
        let values = match indirect {
            PlaneIndirect::Basis(bake) => {
                let gather = plane
                    .gather
                    .get_or_insert_with(|| work_plane_gather(scene, &plane.mesh));
                let states: Vec<LightState> = lights.iter().map(|l| pixel_light(l).state).collect();
                work_plane_indirect(scene, bake, &states, gather)
            }
            PlaneIndirect::Leaves(engine) => engine
                .gather_all(&work_plane_receivers(&plane.mesh))
                .into_iter()
                .map(|e| e.map(|x| x as f32))
                .collect(),
        };
        plane.indirect = Some((key, values));
        self.light_version += 1;
    }

    /// Brings the per-pixel direct light up to the view and the lights: new surfaces (and every
    /// shadow ray) when the view changed, new shadow rays for a moved light, the curve, aim,
    /// dimmer or colour of an edited one. In paper mode it holds no lights.
    fn sync_pixels(
        &mut self,
        scene: &Scene,
        camera: Camera,
        spec: &FrameSpec,
        lights: &[LightEdit],
        paper_mode: bool,
        free_right_px: u32,
    ) -> Result<()> {
        let (width, height) = spec.size_px;
        let key = ViewKey {
            camera,
            size_px: spec.size_px,
            view: spec.view,
            free_right_px,
        };
        let occluders = self
            .occluders
            .get_or_insert_with(|| Occluders::of_scene(scene))
            .as_ref();
        if spec.view == ViewChoice::WorkPlane && self.plane.is_none() {
            self.plane = Some(PlaneState::of_scene(scene)?);
        }
        // The work plane is no mesh of the room: its direct light is exact per pixel even in
        // paper mode.
        let wanted: Vec<PixelLight> = if paper_mode && spec.view != ViewChoice::WorkPlane {
            Vec::new()
        } else {
            lights.iter().map(pixel_light).collect()
        };
        let frame = match &mut self.frame {
            Some(frame) => frame,
            none => none.insert(render::Frame::new(width, height)?),
        };
        let stale = self.pixel.as_ref().is_none_or(|pixel| pixel.key != key);
        if stale {
            let view = match spec.view {
                ViewChoice::Camera => View::new(camera, width, height)?,
                ViewChoice::Plan | ViewChoice::WorkPlane => {
                    plan_view_beside(scene.room_size, width, height, free_right_px)?
                }
            };
            let (mesh, mesh_surfaces) = match (spec.view, &self.plane) {
                (ViewChoice::WorkPlane, Some(plane)) => (&plane.mesh, &plane.surfaces[..]),
                _ => (&scene.fine, &scene.surfaces[..]),
            };
            match &mut self.pixel {
                // The lights' own changes follow below, with those of an unchanged view.
                Some(pixel) => {
                    pixel
                        .lighting
                        .set_view(frame, mesh, mesh_surfaces, &view, occluders)?;
                    pixel.view = view;
                    pixel.key = key;
                }
                none => {
                    let surfaces = PixelSurfaces::build(frame, mesh, mesh_surfaces, &view)?;
                    *none = Some(PixelState {
                        lighting: PixelLighting::new(surfaces, wanted.clone(), occluders),
                        view,
                        key,
                    });
                }
            }
            self.light_version += 1;
        }
        let pixel = self
            .pixel
            .as_mut()
            .ok_or_else(|| crate::error::Error::internal("frame: no per-pixel light after building it"))?;
        let lighting = &mut pixel.lighting;
        if lighting.n_lights() != wanted.len() {
            lighting.set_lights(wanted, occluders);
            self.light_version += 1;
            return Ok(());
        }
        for (i, light) in wanted.into_iter().enumerate() {
            let now = lighting.light(i);
            if now.position != light.position || now.radius_m != light.radius_m {
                lighting.set_position(i, light.position, light.radius_m, occluders)?;
                self.light_version += 1;
            }
            if lighting.light(i).state != light.state {
                lighting.set_state(i, light.state)?;
                self.light_version += 1;
            }
        }
        Ok(())
    }

    /// The display shader of `spec`: the photo exposure it asks for (the room's chosen at the
    /// first photo frame and kept), or the false-colour range fitted at the first frame that
    /// needed it and kept.
    fn shader(&mut self, scene: &Scene, relighter: &Relighter, spec: &FrameSpec) -> Result<DisplayShader> {
        Ok(match spec.mode {
            DisplayMode::Photo => {
                let photo = match spec.exposure {
                    ExposureChoice::Ev100(ev100) => Photo::with_ev100(ev100),
                    ExposureChoice::Room { brighter_ev } => {
                        let ev100 = match self.room_ev100 {
                            Some(ev100) => ev100,
                            None => {
                                photo_attributes(scene, relighter, &mut self.attrs)?;
                                *self.room_ev100.insert(room_ev100(&scene.fine, &self.attrs))
                            }
                        };
                        Photo::with_ev100(ev100 - brighter_ev)
                    }
                    ExposureChoice::Auto => {
                        photo_attributes(scene, relighter, &mut self.attrs)?;
                        Photo::auto(&scene.fine, &self.attrs)
                    }
                };
                self.photo = Some(photo);
                DisplayShader::Photo(photo)
            }
            DisplayMode::FalseColor => DisplayShader::FalseColor(kept_false_color(
                &mut self.false_color,
                scene,
                relighter,
                &mut self.attrs,
            )?),
        })
    }

    /// What pixel `(x, y)` of the latest frame shows; `None` for the background, a pixel outside
    /// it, or before the first frame.
    pub fn pick(&self, scene: &Scene, (x, y): (u32, u32)) -> Option<PixelHit> {
        let (frame, view) = self.latest()?;
        let pixel = self.pixel.as_ref()?;
        let mesh = match (pixel.key.view, &self.plane) {
            (ViewChoice::WorkPlane, Some(plane)) => &plane.mesh,
            _ => &scene.fine,
        };
        let hit = render::pick(frame, view, mesh, x, y)?;
        let lighting = &pixel.lighting;
        let i = y as usize * lighting.surfaces().width() as usize + x as usize;
        let vertex_light = shown_vertex_light(pixel.key.view, &self.vertex_light, &self.plane);
        let rgb = lighting.illuminance_at(i, vertex_light).ok()??;
        Some(PixelHit {
            point: hit.point,
            normal: hit.normal,
            patch: hit.patch,
            surface: hit.surface,
            lux: luma(rgb.map(f64::from)),
        })
    }

    /// Per-pixel illuminance (lx, luma) of the latest frame, row-major from the top-left pixel,
    /// 0 where no surface is seen; `None` before the first frame.
    pub fn lux_image(&mut self) -> Option<Vec<f32>> {
        let pixel = self.pixel.as_ref()?;
        let lighting = &pixel.lighting;
        match shown_vertex_light(pixel.key.view, &self.vertex_light, &self.plane) {
            Some(values) => lighting.illuminance_into(values, &mut self.lux).ok()?,
            None => lighting.direct_into(&mut self.lux),
        }
        Some(luma_values(&self.lux))
    }
}

/// The per-vertex light the pixels of `view` interpolate: the work plane's gathered indirect
/// light in its plan, else the room mesh's (`vertex_light`).
fn shown_vertex_light<'a>(
    view: ViewChoice,
    vertex_light: &'a Option<Vec<[f32; 3]>>,
    plane: &'a Option<PlaneState>,
) -> Option<&'a [[f32; 3]]> {
    match view {
        ViewChoice::WorkPlane => plane.as_ref()?.indirect.as_ref().map(|(_, v)| &v[..]),
        ViewChoice::Camera | ViewChoice::Plan => vertex_light.as_deref(),
    }
}

/// A session light as the per-pixel direct light sees it.
fn pixel_light(light: &LightEdit) -> PixelLight {
    PixelLight::new(
        light.position,
        light.radius_m,
        crate::photometry::LightState {
            curve: light.curve.clone(),
            aim: light.aim,
            dimmer: light.dimmer,
            color: light.color,
        },
    )
}

/// Per-vertex photo attributes (luminance, cd/m²) of the relighter's light into `attrs`.
fn photo_attributes(scene: &Scene, relighter: &Relighter, attrs: &mut Vec<[f32; 3]>) -> Result<()> {
    vertex_attributes_into(
        DisplayMode::Photo,
        &scene.fine,
        &scene.surfaces,
        relighter.total(),
        attrs,
    )
}

/// The false-colour range of `spec`'s frames: fitted to the relighter's per-vertex illuminance
/// (logarithmic scale) the first time and kept in `kept`.
fn kept_false_color(
    kept: &mut Option<FalseColor>,
    scene: &Scene,
    relighter: &Relighter,
    attrs: &mut Vec<[f32; 3]>,
) -> Result<FalseColor> {
    if let Some(scale) = kept {
        return Ok(*scale);
    }
    vertex_attributes_into(
        DisplayMode::FalseColor,
        &scene.fine,
        &scene.surfaces,
        relighter.total(),
        attrs,
    )?;
    Ok(*kept.insert(FalseColor::fit(attrs, LuxScale::Log)))
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

#[cfg(test)]
mod tests {
    use super::*;

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
