//! `haiko render ROOM -o out.png`: the headless preview — load, relight, rasterise with the room's
//! camera, draw the light markers, save a PNG, and say how long each stage took.

use std::path::Path;
use std::time::Instant;

use clap::ValueEnum;
use glam::DVec3;

use crate::error::{Error, Result};
use crate::relight::Relighter;
use crate::render::{
    DisplayMode, DisplayShader, Frame, LightMarker, LuxScale, View, draw_lights, render, vertex_attributes,
};
use crate::scene::{self, Scene};

/// Largest image side (pixels) `render` and `pick` accept.
pub const MAX_SIDE_PX: u32 = 8192;

/// `--mode` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ModeArg {
    /// Luminance ρE/π, auto-exposed and tone-mapped (a photograph of the lit room).
    Photo,
    /// Illuminance (lx) on a logarithmic viridis scale.
    FalseColor,
}

impl From<ModeArg> for DisplayMode {
    fn from(mode: ModeArg) -> Self {
        match mode {
            ModeArg::Photo => DisplayMode::Photo,
            ModeArg::FalseColor => DisplayMode::FalseColor,
        }
    }
}

/// The view of the room's camera (docs/METHOD.md §1) through a `width × height` pixel image.
///
/// Errors (bad input, naming `--width` / `--height`): a side of 0 or above [`MAX_SIDE_PX`].
pub fn scene_view(scene: &Scene, width: u32, height: u32) -> Result<View> {
    for (side, flag) in [(width, "--width"), (height, "--height")] {
        if side == 0 || side > MAX_SIDE_PX {
            return Err(Error::input(
                flag,
                "",
                format!("{side} pixels is outside 1..={MAX_SIDE_PX}"),
            ));
        }
    }
    View::new(scene.camera, width, height)
}

/// The scene rendered in `mode` from per-fine-vertex illuminance `illuminance_lx` (lx, linear
/// RGB, e.g. [`Relighter::total`]), with the shader fitted to it (exposure or lux range).
/// No overlays.
pub fn shade_scene(
    scene: &Scene,
    illuminance_lx: &[[f64; 3]],
    view: &View,
    mode: DisplayMode,
) -> Result<(Frame, DisplayShader)> {
    let attrs = vertex_attributes(mode, &scene.fine, &scene.surfaces, illuminance_lx)?;
    let shader = DisplayShader::fit(mode, &scene.fine, &attrs);
    Ok((render(&scene.fine, &attrs, view, &shader)?, shader))
}

/// One marker per light of the scene, none selected; the aim target is where the light's aim
/// axis leaves the room box (world, m).
pub fn light_markers(scene: &Scene) -> Vec<LightMarker> {
    scene
        .lights
        .iter()
        .map(|light| LightMarker {
            position: light.position,
            aim_target: room_exit(scene.room_size, light.position, light.aim),
            selected: false,
        })
        .collect()
}

/// Where the ray `origin + t·dir` (t ≥ 0, unit `dir`) leaves the box (0, 0, 0)–`size` (m),
/// for an origin inside it.
fn room_exit(size: DVec3, origin: DVec3, dir: DVec3) -> DVec3 {
    let exit_along = |o: f64, d: f64, len: f64| {
        if d > 0.0 {
            (len - o) / d
        } else if d < 0.0 {
            -o / d
        } else {
            f64::INFINITY
        }
    };
    let t = exit_along(origin.x, dir.x, size.x)
        .min(exit_along(origin.y, dir.y, size.y))
        .min(exit_along(origin.z, dir.z, size.z))
        .max(0.0);
    origin + t * dir
}

/// Wall time of each stage of `haiko render`, milliseconds.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StageTimes {
    /// Reading, validating and meshing the room file.
    pub load_ms: f64,
    /// Direct (and, once baked, indirect) illuminance at the fine vertices.
    pub relight_ms: f64,
    /// Loading the bake from the cache, or baking (ms).
    pub bake_ms: f64,
    /// Vertex attributes, shader fit and rasterisation.
    pub raster_ms: f64,
    /// Light markers.
    pub overlays_ms: f64,
    /// PNG encoding and writing the file.
    pub encode_ms: f64,
}

fn ms_since(start: Instant) -> f64 {
    start.elapsed().as_secs_f64() * 1e3
}

/// Runs the command: renders `room` into the PNG `output` and prints the stage times (and the
/// lux range in false-colour mode, the exposure in photo mode).
pub fn run(room: &Path, output: &Path, width: u32, height: u32, mode: DisplayMode) -> Result<()> {
    let mut times = StageTimes::default();
    let start = Instant::now();
    let scene = scene::load(room)?;
    let view = scene_view(&scene, width, height)?;
    times.load_ms = ms_since(start);

    let start = Instant::now();
    let bake = crate::cli::bake::bake_for_cli(&scene)?;
    times.bake_ms = ms_since(start);

    let start = Instant::now();
    let relighter = Relighter::with_bake(&scene, &bake);
    times.relight_ms = ms_since(start);

    let start = Instant::now();
    let (mut frame, shader) = shade_scene(&scene, relighter.total(), &view, mode)?;
    times.raster_ms = ms_since(start);

    let start = Instant::now();
    draw_lights(&mut frame, &view, &light_markers(&scene));
    times.overlays_ms = ms_since(start);

    let start = Instant::now();
    let png = frame
        .pixmap
        .encode_png()
        .map_err(|e| Error::internal(format!("render: PNG encoding failed: {e}")))?;
    std::fs::write(output, png)
        .map_err(|e| Error::input(output, "", format!("cannot write the image: {e}")))?;
    times.encode_ms = ms_since(start);

    println!(
        "{}: {width}×{height} {} image written to {}",
        room.display(),
        mode_name(mode),
        output.display()
    );
    println!("{}", shader_summary(&shader));
    println!(
        "load+mesh {:.1} ms   bake (or cache) {:.1} ms   relight {:.1} ms   raster {:.1} ms   overlays {:.1} ms   png {:.1} ms",
        times.load_ms, times.bake_ms, times.relight_ms, times.raster_ms, times.overlays_ms, times.encode_ms
    );
    Ok(())
}

fn mode_name(mode: DisplayMode) -> &'static str {
    match mode {
        DisplayMode::Photo => "photo",
        DisplayMode::FalseColor => "false-colour",
    }
}

/// One line on what the shader shows: the exposure, or the lux range of the colour scale.
pub fn shader_summary(shader: &DisplayShader) -> String {
    match shader {
        DisplayShader::Photo(photo) => format!(
            "exposure {:.4} m²/cd (a luminance of {:.2} cd/m² shows as mid-grey)",
            photo.exposure(),
            crate::render::shade::MID_GREY / (1.0 - crate::render::shade::MID_GREY) / photo.exposure()
        ),
        DisplayShader::FalseColor(scale) => {
            let (lo, hi) = scale.range();
            let kind = match scale.scale() {
                LuxScale::Log => "logarithmic",
                LuxScale::Linear => "linear",
            };
            format!("lux range {lo:.1} lx (violet) to {hi:.1} lx (yellow), {kind} scale")
        }
    }
}
