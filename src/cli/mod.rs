//! The command line: argument definitions (clap) and one function per subcommand.
//! `main.rs` only parses and calls [`run`].

use std::panic::AssertUnwindSafe;
use std::path::PathBuf;

use clap::{Parser, Subcommand, ValueEnum};

use crate::error::{Error, Result, panic_text, take_recorded_panic};
use crate::photometry::Window;
use crate::scene::Scene;
use crate::session::budget::{self, MemoryLimit, MemorySize};
use crate::session::{ExposureChoice, Session, SessionOptions};
use crate::transport::plan::PlanOptions;
use crate::tui::Graphics;

pub mod accuracy;
pub mod bake;
pub mod cache;
pub mod check;
pub mod glare;
pub mod grid;
pub mod lid;
pub mod pick;
pub mod probe;
pub mod render;
pub mod report;
pub mod terminal_frames;

/// Haiko — a terminal editor for interior lighting design.
#[derive(Debug, Parser)]
#[command(name = "haiko", version, about, long_about = None)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands (README "Commands").
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Edit a room in the terminal: curves, aiming, live preview.
    Edit {
        /// The room file (rooms/*.toml).
        room: PathBuf,
        /// Inline image protocol for the preview (auto: what reaches the screen, also through
        /// tmux and screen; half-blocks when nothing else does).
        #[arg(long, value_enum, default_value_t = GraphicsArg::Auto)]
        graphics: GraphicsArg,
        /// Polar diagram style: braille, blocks or ascii (default: $HAIKO_POLAR, else by terminal).
        #[arg(long, value_enum)]
        polar: Option<PolarArg>,
        /// Byte budget of an interactive frame while keys repeat: auto (from the link's speed)
        /// or a size such as 64k.
        #[arg(long, default_value = "auto")]
        frame_budget: String,
        #[command(flatten)]
        memory: MemoryArg,
    },
    /// Luminous intensity curve report: flux, asymmetry, truncation error per SH order.
    Lid {
        /// An IES LM-63 or EULUMDAT file, or ROOM.toml#LIGHT for a light of a room.
        source: String,
        /// Highest order to tabulate (default: the chosen order, at least 16).
        #[arg(long)]
        order: Option<usize>,
        /// Window applied to the truncated series (default: automatic, docs/METHOD.md §4.4).
        #[arg(long, value_enum)]
        window: Option<WindowArg>,
        /// Print one JSON object instead of tables.
        #[arg(long)]
        json: bool,
    },
    /// Illuminance at given points: CSV `x,y,z,nx,ny,nz` in, the same plus `lux` out.
    Probe {
        /// The room file.
        room: PathBuf,
        /// Input CSV with header `x,y,z,nx,ny,nz`.
        #[arg(long)]
        points: PathBuf,
        /// Direct light only (no interreflection).
        #[arg(long)]
        direct_only: bool,
        /// Direct light exact from the curve (hybrid, default) or from the SH series (paper mode).
        #[arg(long, value_enum, default_value_t = DirectArg::Exact)]
        mode: DirectArg,
        #[command(flatten)]
        memory: MemoryArg,
    },
    /// Which effects the scene calls for, and why.
    Plan {
        /// The room file.
        room: PathBuf,
        /// Print JSON.
        #[arg(long)]
        json: bool,
        #[command(flatten)]
        memory: MemoryArg,
    },
    /// Precompute and cache the SH basis (interreflection) of every light.
    Bake {
        /// The room file.
        room: PathBuf,
        /// Print JSON (the hierarchical engine's sizes, memory, times and per-edit costs).
        #[arg(long)]
        json: bool,
        #[command(flatten)]
        memory: MemoryArg,
    },
    /// Work-plane calculation grid: E_avg, E_min, E_max, U0 = E_min/E_avg.
    Grid {
        /// The room file.
        room: PathBuf,
        /// Work-plane height above the floor, m.
        #[arg(long)]
        height: f64,
        /// Grid spacing, m.
        #[arg(long)]
        spacing: f64,
        /// Distance kept from the walls, m (default: half the spacing).
        #[arg(long)]
        margin: Option<f64>,
        /// Print JSON with every point.
        #[arg(long)]
        json: bool,
        /// Direct light only (no interreflection).
        #[arg(long)]
        direct_only: bool,
        #[command(flatten)]
        memory: MemoryArg,
    },
    /// Design check: every calculation surface's maintained Ē, E_min, E_max, U0, g2 against its targets.
    Check {
        /// The room file.
        room: PathBuf,
        /// Print JSON (with every grid point's new illuminance).
        #[arg(long)]
        json: bool,
        /// Direct light only (no interreflection).
        #[arg(long)]
        direct_only: bool,
        #[command(flatten)]
        memory: MemoryArg,
    },
    /// Glare: UGR (CIE 117) at every observer, with each luminaire's luminance, solid angle and position index.
    Glare {
        /// The room file.
        room: PathBuf,
        /// Print JSON.
        #[arg(long)]
        json: bool,
        /// Direct light only (no background luminance: UGR undefined).
        #[arg(long)]
        direct_only: bool,
        #[command(flatten)]
        memory: MemoryArg,
    },
    /// Client report: one self-contained HTML file (views, surfaces, glare, schedule, settings) for A4.
    Report {
        /// The room file.
        room: PathBuf,
        /// Output HTML file.
        #[arg(short, long)]
        output: PathBuf,
        /// Width of each view, pixels.
        #[arg(long, default_value_t = 1200)]
        width: u32,
        /// Height of each view, pixels.
        #[arg(long, default_value_t = 800)]
        height: u32,
        #[command(flatten)]
        memory: MemoryArg,
    },
    /// Headless preview: render the room's camera view to a PNG, with per-stage timings.
    Render {
        /// The room file.
        room: PathBuf,
        /// Output PNG file (with --terminal: the frames go to OUTPUT.full, OUTPUT.interactive).
        #[arg(short, long, required_unless_present = "terminal")]
        output: Option<PathBuf>,
        /// Instead of a PNG: the editor's preview frames for this terminal protocol, their
        /// bytes and encode times.
        #[arg(long, value_enum)]
        terminal: Option<terminal_frames::TerminalArg>,
        /// With --terminal: the terminal's size, COLUMNSxROWS.
        #[arg(long, default_value = "160x48", requires = "terminal")]
        cells: String,
        /// With --terminal: a cell's size in pixels, WIDTHxHEIGHT.
        #[arg(long, default_value = "10x20", requires = "terminal")]
        font: String,
        /// With --terminal: print one JSON object.
        #[arg(long, requires = "terminal")]
        json: bool,
        /// Image width, pixels (1..=8192).
        #[arg(long, default_value_t = 1024)]
        width: u32,
        /// Image height, pixels (1..=8192).
        #[arg(long, default_value_t = 768)]
        height: u32,
        /// What the image shows.
        #[arg(long, value_enum, default_value_t = render::ModeArg::Photo)]
        mode: render::ModeArg,
        /// Where the image looks from: the room's camera, or the plan (top-down, parallel).
        #[arg(long, value_enum, default_value_t = render::ViewArg::Camera)]
        view: render::ViewArg,
        /// Also write the per-pixel illuminance (lx) of the visible surfaces to this Portable
        /// Float Map (`Pf`, little-endian, rows bottom to top, 0 where no surface is seen).
        #[arg(long, value_name = "PFM")]
        lux: Option<PathBuf>,
        /// Direct light only: no bake, no interreflection.
        #[arg(long)]
        direct_only: bool,
        /// Draw isolux lines at round lux values of the false-colour scale.
        #[arg(long)]
        isolux: bool,
        /// Leave out the false-colour legend (colour bar with lux ticks).
        #[arg(long)]
        no_legend: bool,
        /// Photo exposure: EV at ISO 100 of the luminance shown as mid-grey, or `auto`
        /// (default: the room's exposure, chosen from its light).
        #[arg(long, value_name = "EV100|auto")]
        exposure: Option<render::ExposureArg>,
        #[command(flatten)]
        memory: MemoryArg,
    },
    /// What a pixel of the `render` image shows (patch, surface, point, normal); aims a light at it.
    Pick {
        /// The room file.
        room: PathBuf,
        /// The pixel `X,Y` (0,0 = top left).
        #[arg(long)]
        pixel: pick::Pixel,
        /// Image width, pixels (as for `render`).
        #[arg(long, default_value_t = 1024)]
        width: u32,
        /// Image height, pixels (as for `render`).
        #[arg(long, default_value_t = 768)]
        height: u32,
        /// Print one JSON object.
        #[arg(long)]
        json: bool,
        /// Also print the unit aim vector that points this light at the picked point.
        #[arg(long, value_name = "LIGHT")]
        aim: Option<String>,
        /// The illuminance at the picked point by direct light only (no interreflection).
        #[arg(long)]
        direct_only: bool,
        #[command(flatten)]
        memory: MemoryArg,
    },
    /// What accuracy costs in time: error against time for each knob (docs/ACCURACY.md).
    Accuracy {
        /// The room file.
        room: PathBuf,
        /// Print one JSON object with one array per table.
        #[arg(long)]
        json: bool,
    },
    /// The bake cache: where it is and what it holds (`list`, the default), or empty it (`clear`).
    Cache {
        /// What to do.
        #[arg(value_enum, default_value_t = CacheAction::List)]
        action: CacheAction,
    },
}

/// `--max-memory`, shared by the commands that plan a session.
#[derive(Debug, Clone, Copy, clap::Args)]
pub struct MemoryArg {
    /// Most memory the simulation may plan to use (`8G`, `512M`; binary units); default: half
    /// the memory available (README "Memory").
    #[arg(long, value_name = "SIZE")]
    pub max_memory: Option<MemorySize>,
}

impl MemoryArg {
    /// The limit this option sets ([`MemoryLimit::from_option`]).
    pub fn limit(self) -> MemoryLimit {
        MemoryLimit::from_option(self.max_memory)
    }
}

/// `haiko cache` actions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum CacheAction {
    /// List the entries, their sizes and when they were last used.
    List,
    /// Remove every entry.
    Clear,
}

/// `--graphics` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum GraphicsArg {
    /// Ask the terminal, fall back to half-blocks.
    Auto,
    /// DEC sixel.
    Sixel,
    /// kitty graphics protocol.
    Kitty,
    /// iTerm2 inline images.
    Iterm2,
    /// Unicode half-blocks (works everywhere).
    Halfblocks,
}

impl From<GraphicsArg> for Graphics {
    fn from(g: GraphicsArg) -> Self {
        match g {
            GraphicsArg::Auto => Graphics::Auto,
            GraphicsArg::Sixel => Graphics::Sixel,
            GraphicsArg::Kitty => Graphics::Kitty,
            GraphicsArg::Iterm2 => Graphics::Iterm2,
            GraphicsArg::Halfblocks => Graphics::Halfblocks,
        }
    }
}

/// `--polar` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum PolarArg {
    /// Braille dots (2 × 4 a cell).
    Braille,
    /// Quadrant blocks (2 × 2 a cell).
    Blocks,
    /// ASCII only.
    Ascii,
}

impl From<PolarArg> for crate::tui::polar::PolarStyle {
    fn from(p: PolarArg) -> Self {
        use crate::tui::polar::PolarStyle;
        match p {
            PolarArg::Braille => PolarStyle::Braille,
            PolarArg::Blocks => PolarStyle::Blocks,
            PolarArg::Ascii => PolarStyle::Ascii,
        }
    }
}

/// `--mode` values of `probe`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum DirectArg {
    /// Exact direct light from the curve (hybrid mode).
    Exact,
    /// Direct light from the truncated SH series (paper mode).
    Basis,
}

impl From<DirectArg> for crate::scene::DirectMode {
    fn from(d: DirectArg) -> Self {
        match d {
            DirectArg::Exact => crate::scene::DirectMode::Exact,
            DirectArg::Basis => crate::scene::DirectMode::Basis,
        }
    }
}

/// `--window` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum WindowArg {
    /// No window (plain truncation).
    None,
    /// Hann window.
    Hann,
    /// Lanczos σ-factors.
    Lanczos,
    /// Cesàro (C,2) means: never negative, but blurred.
    Cesaro2,
}

/// Runs one parsed command line.
pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Edit {
            room,
            graphics,
            polar,
            frame_budget,
            memory,
        } => crate::tui::app::run(
            &room,
            crate::tui::app::EditorOptions {
                graphics: graphics.into(),
                polar: polar.map(Into::into),
                budget: crate::tui::frame_budget::Budget::parse("--frame-budget", &frame_budget)?,
            },
            &memory.limit(),
        ),
        Command::Lid {
            source,
            order,
            window,
            json,
        } => lid::run(&source, order, window.map(Window::from), json),
        Command::Plan { room, json, memory } => bake::run_plan(&room, json, &memory.limit()),
        Command::Bake { room, json, memory } => bake::run_bake(&room, json, &memory.limit()),
        Command::Probe {
            room,
            points,
            direct_only,
            mode,
            memory,
        } => probe::run(&room, &points, direct_only, mode.into(), &memory.limit()),
        Command::Grid {
            room,
            height,
            spacing,
            margin,
            json,
            direct_only,
            memory,
        } => grid::run(&room, height, spacing, margin, json, direct_only, &memory.limit()),
        Command::Check {
            room,
            json,
            direct_only,
            memory,
        } => check::run(&room, json, direct_only, &memory.limit()),
        Command::Glare {
            room,
            json,
            direct_only,
            memory,
        } => glare::run(&room, json, direct_only, &memory.limit()),
        Command::Report {
            room,
            output,
            width,
            height,
            memory,
        } => report::run(&room, &output, width, height, &memory.limit()),
        Command::Render {
            room,
            output,
            terminal,
            cells,
            font,
            json,
            width,
            height,
            mode,
            view,
            lux,
            direct_only,
            isolux,
            no_legend,
            exposure,
            memory,
        } => match (terminal, output) {
            (Some(terminal), output) => terminal_frames::run(
                &room,
                terminal,
                &cells,
                &font,
                output.as_deref(),
                json,
                &memory.limit(),
            ),
            (None, Some(output)) => render::run(
                &room,
                &output,
                &render::RenderOptions {
                    width,
                    height,
                    mode: mode.into(),
                    view: view.into(),
                    lux,
                    direct_only,
                    isolux,
                    legend: !no_legend,
                    exposure: exposure.map_or_else(ExposureChoice::default, Into::into),
                },
                &memory.limit(),
            ),
            (None, None) => Err(Error::input("--output", "", "required without --terminal")),
        },
        Command::Pick {
            room,
            pixel,
            width,
            height,
            json,
            aim,
            direct_only,
            memory,
        } => pick::run(
            &room,
            pixel,
            (width, height),
            json,
            aim.as_deref(),
            direct_only,
            &memory.limit(),
        ),
        Command::Accuracy { room, json } => accuracy::run(&room, json),
        Command::Cache { action } => match action {
            CacheAction::List => cache::run_list(),
            CacheAction::Clear => cache::run_clear(),
        },
    }
}

/// Runs one command at the command boundary: a panic anywhere below (the last resort; no input
/// should reach one) becomes an internal error, exit code 1, with one line naming the message
/// and where it happened. Unwinding drops the editor's terminal guard, so the terminal is
/// restored first. The binary installs [`crate::error::install_panic_recorder`] first.
pub fn catch_panics(command: impl FnOnce() -> Result<()>) -> Result<()> {
    std::panic::catch_unwind(AssertUnwindSafe(command)).unwrap_or_else(|payload| {
        let text = take_recorded_panic().unwrap_or_else(|| panic_text(payload.as_ref()));
        Err(Error::internal(format!(
            "internal error: {text} (a bug in Haiko; please report it with the input files)"
        )))
    })
}

/// Loads the room file `room` for a command and writes what loading repaired
/// ([`Scene::notes`]) to standard error, one `haiko: note:` line each, so that what a command
/// prints for files and pipes stays as it was.
pub(crate) fn load_room(room: &std::path::Path) -> Result<Scene> {
    let scene = crate::scene::load(room)?;
    for note in &scene.notes {
        eprintln!("haiko: note: {note}");
    }
    Ok(scene)
}

/// Opens a session on `scene` for a command: the plan's estimate checked against `limit` first,
/// then the user's bake cache, the progress bar on standard error, cache notices printed;
/// `indirect` false for direct light only (no bake).
///
/// Errors: the estimate above the limit (bad input), the bake failing (internal).
pub(crate) fn open_session(scene: Scene, indirect: bool, limit: &MemoryLimit) -> Result<Session> {
    budget::check_scene(&scene, PlanOptions::default(), indirect, limit)?;
    let options = SessionOptions {
        indirect,
        memory_limit: Some(*limit),
        ..SessionOptions::with_user_cache()
    };
    let session = Session::new(scene, options, &mut bake::progress_printer())?;
    for notice in session.bake().map_or(&[][..], |b| &b.notices[..]) {
        eprintln!("haiko: {notice}");
    }
    Ok(session)
}

impl From<WindowArg> for Window {
    fn from(w: WindowArg) -> Self {
        match w {
            WindowArg::None => Window::None,
            WindowArg::Hann => Window::Hann,
            WindowArg::Lanczos => Window::Lanczos,
            WindowArg::Cesaro2 => Window::Cesaro2,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_panic_at_the_command_boundary_is_a_one_line_internal_error() {
        let e = catch_panics(|| {
            let lights: Vec<usize> = Vec::new();
            let i = lights.len() + 2;
            panic!("light {i} of {}\nsecond line", lights.len())
        })
        .unwrap_err();
        assert_eq!(e.exit_code(), 1);
        let text = e.to_string();
        assert!(
            text.starts_with("internal error: light 2 of 0\\nsecond line")
                && text.ends_with("(a bug in Haiko; please report it with the input files)"),
            "{text}"
        );
        assert_eq!(text.lines().count(), 1);
        // No panic: the command's own result passes through.
        assert!(catch_panics(|| Ok(())).is_ok());
        let bad = catch_panics(|| Err(Error::input("room.toml", "line 1", "bad"))).unwrap_err();
        assert_eq!(bad.exit_code(), 2);
    }
}
