//! `haiko render ROOM -o out.png`: the headless preview through the session — load, bake (or
//! the cache), relight, rasterise with the room's camera, draw the light markers, save a PNG —
//! and how long each stage took.

use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::ValueEnum;

use crate::cli::{load_room, open_session};
use crate::error::{Error, Result, printable};
use crate::fsio;
use crate::render::{DisplayMode, DisplayShader, LuxScale, write_pfm};
use crate::session::budget::MemoryLimit;
use crate::session::frame::check_size;
use crate::session::{ExposureChoice, FrameSpec, ViewChoice};

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

/// `--view` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ViewArg {
    /// The room file's camera.
    Camera,
    /// Straight down onto the floor, parallel projection, with luminaire symbols.
    Plan,
    /// The plan of the design's work plane (0.8 m unless the room's `[[surface]]` says),
    /// with luminaire symbols.
    WorkPlane,
}

impl From<ViewArg> for ViewChoice {
    fn from(view: ViewArg) -> Self {
        match view {
            ViewArg::Camera => ViewChoice::Camera,
            ViewArg::Plan => ViewChoice::Plan,
            ViewArg::WorkPlane => ViewChoice::WorkPlane,
        }
    }
}

/// `--exposure` values: an EV₁₀₀ or `auto`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ExposureArg {
    /// Fixed at this EV₁₀₀.
    Ev100(f64),
    /// Chosen from the room's light.
    Auto,
}

impl std::str::FromStr for ExposureArg {
    type Err = String;

    fn from_str(text: &str) -> std::result::Result<Self, String> {
        if text.eq_ignore_ascii_case("auto") {
            return Ok(ExposureArg::Auto);
        }
        match text.parse::<f64>() {
            Ok(ev) if ev.is_finite() && ev.abs() <= 40.0 => Ok(ExposureArg::Ev100(ev)),
            _ => Err(format!("`{text}` is neither `auto` nor an EV between -40 and 40")),
        }
    }
}

impl From<ExposureArg> for ExposureChoice {
    fn from(exposure: ExposureArg) -> Self {
        match exposure {
            ExposureArg::Ev100(ev100) => ExposureChoice::Ev100(ev100),
            ExposureArg::Auto => ExposureChoice::Auto,
        }
    }
}

/// What `haiko render` draws and writes besides the PNG.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderOptions {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Photo or false colour.
    pub mode: DisplayMode,
    /// Camera or plan.
    pub view: ViewChoice,
    /// Where to write the per-pixel illuminance (PFM), if anywhere.
    pub lux: Option<PathBuf>,
    /// Direct light only.
    pub direct_only: bool,
    /// Isolux lines.
    pub isolux: bool,
    /// The false-colour legend.
    pub legend: bool,
    /// The photo exposure.
    pub exposure: ExposureChoice,
}

fn ms_since(start: Instant) -> f64 {
    start.elapsed().as_secs_f64() * 1e3
}

/// Runs the command: renders `room` into the PNG `output` as `options` say (and the lux PFM)
/// within the memory `limit`, and prints the stage times and the lux range in false-colour
/// mode, the exposure in photo mode.
pub fn run(room: &Path, output: &Path, options: &RenderOptions, limit: &MemoryLimit) -> Result<()> {
    let (width, height, mode) = (options.width, options.height, options.mode);
    let start = Instant::now();
    let scene = load_room(room)?;
    check_size(width, height, ["--width", "--height"])?;
    // Every file the room named has been read: none of them may be the output.
    fsio::check_not_an_input(output, &[room])?;
    if let Some(lux) = &options.lux {
        fsio::check_not_an_input(lux, &[room])?;
    }
    let load_ms = ms_since(start);

    let start = Instant::now();
    let mut session = open_session(scene, !options.direct_only, limit)?;
    let bake_ms = ms_since(start);

    let start = Instant::now();
    session.relight();
    let relight_ms = ms_since(start);

    let start = Instant::now();
    let spec = FrameSpec {
        view: options.view,
        exposure: options.exposure,
        isolux: options.isolux,
        legend: options.legend,
        ..FrameSpec::new((width, height), mode)
    };
    let png = session
        .render(&spec)?
        .pixmap
        .encode_png()
        .map_err(|e| Error::internal(format!("render: PNG encoding failed: {e}")))?;
    let raster_ms = ms_since(start);

    let start = Instant::now();
    fsio::write_atomic(output, &png)?;
    if let Some(path) = &options.lux {
        let lux = session
            .lux_image()
            .ok_or_else(|| Error::internal("render: no per-pixel illuminance after the frame"))?;
        write_pfm(path, width, height, &lux)?;
    }
    let write_ms = ms_since(start);

    println!(
        "{}: {width}×{height} {} image written to {}",
        printable(&room.display().to_string()),
        mode_name(mode),
        printable(&output.display().to_string())
    );
    if let Some(path) = &options.lux {
        println!(
            "per-pixel illuminance (lx) written to {}",
            printable(&path.display().to_string())
        );
    }
    if let Some(shader) = session.fitted_shader(mode) {
        println!("{}", shader_summary(&shader));
    }
    println!(
        "load+mesh {load_ms:.1} ms   bake (or cache) {bake_ms:.1} ms   relight {relight_ms:.1} ms   raster+shadow rays+shade+overlays+png encode {raster_ms:.1} ms   write {write_ms:.1} ms"
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
pub(crate) fn shader_summary(shader: &DisplayShader) -> String {
    match shader {
        DisplayShader::Photo(photo) => format!(
            "exposure EV100 {:.2}: {:.4} m²/cd (a luminance of {:.2} cd/m² shows as mid-grey)",
            photo.ev100(),
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
