//! `haiko render ROOM -o out.png`: the headless preview through the session — load, bake (or
//! the cache), relight, rasterise with the room's camera, draw the light markers, save a PNG —
//! and how long each stage took.

use std::path::Path;
use std::time::Instant;

use clap::ValueEnum;

use crate::cli::open_session;
use crate::error::{Error, Result};
use crate::render::{DisplayMode, DisplayShader, LuxScale};
use crate::scene;
use crate::session::FrameSpec;
use crate::session::frame::check_size;

/// `--mode` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ModeArg {
    /// Luminance ρE/π, exposed once for the room and tone-mapped (a photograph of the lit room).
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

fn ms_since(start: Instant) -> f64 {
    start.elapsed().as_secs_f64() * 1e3
}

/// Runs the command: renders `room` into the PNG `output` and prints the stage times (and the
/// lux range in false-colour mode, the exposure in photo mode).
pub fn run(room: &Path, output: &Path, width: u32, height: u32, mode: DisplayMode) -> Result<()> {
    let start = Instant::now();
    let scene = scene::load(room)?;
    check_size(width, height, ["--width", "--height"])?;
    let load_ms = ms_since(start);

    let start = Instant::now();
    let mut session = open_session(scene, true)?;
    let bake_ms = ms_since(start);

    let start = Instant::now();
    session.relight();
    let relight_ms = ms_since(start);

    let start = Instant::now();
    let spec = FrameSpec {
        size_px: (width, height),
        mode,
        selected_light: None,
        cursor: None,
    };
    let png = session
        .render(&spec)?
        .pixmap
        .encode_png()
        .map_err(|e| Error::internal(format!("render: PNG encoding failed: {e}")))?;
    let raster_ms = ms_since(start);

    let start = Instant::now();
    std::fs::write(output, png)
        .map_err(|e| Error::input(output, "", format!("cannot write the image: {e}")))?;
    let png_ms = ms_since(start);

    println!(
        "{}: {width}×{height} {} image written to {}",
        room.display(),
        mode_name(mode),
        output.display()
    );
    if let Some(shader) = session.fitted_shader(mode) {
        println!("{}", shader_summary(&shader));
    }
    println!(
        "load+mesh {load_ms:.1} ms   bake (or cache) {bake_ms:.1} ms   relight {relight_ms:.1} ms   raster+overlays+png encode {raster_ms:.1} ms   png write {png_ms:.1} ms"
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
