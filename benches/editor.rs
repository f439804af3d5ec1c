//! The editor's costs per keystroke (docs/BENCHMARKS.md), on one core (wall time, and `…-cpu`:
//! CPU time of the pool's one thread, see `common/cpu_time.rs`): a key press → a new
//! 1024 × 768 preview pixmap of the paper and office rooms, of the office in false colour with
//! isolux lines and the legend, and of the office's work-plane plan (update → command → session
//! relight, per-pixel direct light, the plan's indirect light, shading and overlays, into reused
//! buffers; targets 16 ms and 33 ms), a
//! 5° camera orbit step (target 200 ms), the per-pixel light's memory (printed), the heap
//! allocations of a key press (counted with dhat), and what one full preview frame costs on the
//! wire with the editor's own encoder for each image protocol at 160 × 48 cells with a 10 × 20 px
//! font (encode time is benched; the byte counts are printed).

use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use haiko::render::DisplayMode;
use haiko::session::{FrameSpec, Session, SessionOptions, ViewChoice};
use haiko::tui::app::frame_spec;
use haiko::tui::frame_budget::FramePlan;
use haiko::tui::multiplexer::Protocol;
use haiko::tui::preview::ImageSetup;
use haiko::tui::view::preview_rect;
use haiko::tui::{Effect, Model, Msg, preview, update};
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use ratatui::layout::{Rect, Size};

#[path = "common/cpu_time.rs"]
mod cpu_time;
use cpu_time::cpu_time_of;

#[global_allocator]
static ALLOCATOR: dhat::Alloc = dhat::Alloc;

/// The terminal of the byte counts, cells.
const TERMINAL: (u16, u16) = (160, 48);
/// Half-blocks' nominal font, px.
const FONT: (u16, u16) = (10, 20);
/// The benched preview size, px.
const SIZE: (u32, u32) = (1024, 768);

fn paper() -> haiko::scene::Scene {
    room("paper")
}

fn room(name: &str) -> haiko::scene::Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("rooms/{name}.toml"));
    haiko::scene::load(&path).expect("a bundled room loads")
}

fn key(code: KeyCode) -> Msg {
    Msg::Key(KeyEvent::new(code, KeyModifiers::NONE))
}

/// The editor and its engine on a bundled room, with one frame rendered.
fn editor(name: &str) -> (Model, Session, FrameSpec) {
    editor_in_view(name, ViewChoice::Camera)
}

/// [`editor`] with the preview showing `view`.
fn editor_in_view(name: &str, view: ViewChoice) -> (Model, Session, FrameSpec) {
    let scene = room(name);
    let model = Model::new(&scene, TERMINAL, FONT);
    // The editor's options: the plan's engine, its solves off the key path.
    let options = SessionOptions::default().interactive();
    let mut session = Session::new(scene, options, &mut |_| {}).expect("bake");
    let spec = FrameSpec {
        selected_light: Some(0),
        view,
        ..FrameSpec::new(SIZE, DisplayMode::Photo)
    };
    session.render(&spec).expect("the first frame renders");
    (model, session, spec)
}

/// One key press as the editor handles it: update → the command to the session → a frame.
fn press_key(model: &mut Model, session: &mut Session, spec: &FrameSpec, code: KeyCode) {
    let effects = update(model, key(code));
    let mut changed = false;
    for effect in effects {
        if let Effect::Engine(command) = effect {
            session
                .apply(command)
                .expect("the engine accepts the model's command");
            changed = true;
        }
    }
    assert!(changed, "the key press changed nothing");
    black_box(&session.render(spec).expect("the frame renders").pixmap);
}

/// ↑ (raise the selected point 5 %) or ↓.
fn press(model: &mut Model, session: &mut Session, spec: &FrameSpec, up: bool) {
    press_key(model, session, spec, if up { KeyCode::Up } else { KeyCode::Down });
}

/// A one-thread rayon pool (the targets are for one core).
fn one_core() -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a rayon pool")
}

/// ↑ then ↓ alternately (so every press changes the curve), on one core: the curve edit, the
/// relight of the per-vertex (indirect) light, the per-pixel curve evaluation of the edited
/// light, shading and overlays. Also prints the per-pixel light's memory.
fn key_to_pixmap(c: &mut Criterion) {
    let pool = one_core();
    let mut group = c.benchmark_group("editor/key_to_pixmap_1024x768");
    let views = [
        ("paper", ViewChoice::Camera, DisplayMode::Photo),
        ("office", ViewChoice::Camera, DisplayMode::Photo),
        ("office-false-colour", ViewChoice::Camera, DisplayMode::FalseColor),
        ("office-work-plane", ViewChoice::WorkPlane, DisplayMode::Photo),
    ];
    for (name, view, mode) in views {
        let room_name = name.split('-').next().expect("a room name");
        let (mut model, mut session, mut spec) = pool.install(|| editor_in_view(room_name, view));
        if mode == DisplayMode::FalseColor {
            // As a designer reads lux: false colour with isolux lines and the legend.
            (spec.mode, spec.isolux, spec.legend) = (mode, true, true);
        }
        if let Some((shared, per_light)) = session.preview_memory_per_pixel() {
            let lights = session.lights().len() as f64;
            println!(
                "{name}: per-pixel light {shared:.1} bytes per pixel + {per_light:.3} per light and pixel ({:.1} MiB at 1024×768 with {lights} lights)",
                (shared + per_light * lights) * f64::from(SIZE.0 * SIZE.1) / (1024.0 * 1024.0)
            );
        }
        let mut up = true;
        group.bench_function(name, |b| {
            b.iter(|| {
                pool.install(|| press(&mut model, &mut session, &spec, up));
                up = !up;
            })
        });
        group.bench_function(format!("{name}-cpu"), |b| {
            b.iter_custom(|iters| {
                pool.install(|| {
                    cpu_time_of(iters, || {
                        press(&mut model, &mut session, &spec, up);
                        up = !up;
                    })
                })
            })
        });
    }
    group.finish();
}

/// A key press until the picture is final, on one core: the press as [`key_to_pixmap`] times
/// it, then the background work it queued (the hierarchical engine's solve of the edited light,
/// where the plan chose that engine) run here and installed, and the frame rendered again.
fn key_to_settled(c: &mut Criterion) {
    let pool = one_core();
    let mut group = c.benchmark_group("editor/key_to_settled_1024x768");
    for name in ["paper", "gallery"] {
        let (mut model, mut session, spec) = pool.install(|| editor(name));
        let engine = if session.hierarchical().is_some() {
            "hierarchical"
        } else {
            "SH basis"
        };
        println!("{name}: the {engine} engine");
        let mut up = true;
        group.bench_function(name, |b| {
            b.iter(|| {
                pool.install(|| {
                    press(&mut model, &mut session, &spec, up);
                    session
                        .run_bake_jobs(&mut |_| {})
                        .expect("the queued work finishes");
                    black_box(&session.render(&spec).expect("the frame renders").pixmap);
                });
                up = !up;
            })
        });
    }
    group.finish();
}

/// One 5° orbit step (alternately left and right), on one core: new per-pixel surfaces, every
/// light's shadow rays and direct light, shading and overlays.
fn camera_orbit(c: &mut Criterion) {
    let pool = one_core();
    let mut group = c.benchmark_group("editor/orbit_step_1024x768");
    for name in ["paper", "office"] {
        let (mut model, mut session, spec) = pool.install(|| editor(name));
        let mut left = true;
        let mut orbit = |model: &mut Model, session: &mut Session| {
            let code = KeyCode::Char(if left { '[' } else { ']' });
            press_key(model, session, &spec, code);
            left = !left;
        };
        group.bench_function(name, |b| {
            b.iter(|| pool.install(|| orbit(&mut model, &mut session)))
        });
        group.bench_function(format!("{name}-cpu"), |b| {
            b.iter_custom(|iters| pool.install(|| cpu_time_of(iters, || orbit(&mut model, &mut session))))
        });
    }
    group.finish();
}

/// One 0.1 m move of light 0 (alternating back and forth), as the editor completes it: the
/// command (its direct cache rebuilt), the queued work (with the SH engine that light's bake on
/// the shared transport; with the hierarchical engine the grading check, then the light's solve
/// or the engine rebuilt), installed, the light recomputed; and the key path alone.
fn light_move(c: &mut Criterion) {
    let mut group = c.benchmark_group("editor/light_move");
    for name in ["paper", "office"] {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("rooms/{name}.toml"));
        let scene = haiko::scene::load(&path).expect("a bundled room loads");
        // The editor's options: the plan's engine, its solves off the key path.
        let options = SessionOptions::default().interactive();
        let mut session = Session::new(scene, options, &mut |_| {}).expect("bake");
        session.relight();
        let start = session.lights()[0].position;
        let mut forth = true;
        // Light 0 0.1 m along x and back, alternately.
        let mut step = move |session: &mut Session| {
            let offset = if forth { 0.1 } else { 0.0 };
            forth = !forth;
            let position = start + glam::DVec3::new(offset, 0.0, 0.0);
            session
                .apply(haiko::session::Command::Move { light: 0, position })
                .expect("a valid move");
        };
        group.bench_function(name, |b| {
            b.iter(|| {
                step(&mut session);
                session.relight();
                session.run_bake_jobs(&mut |_| {}).expect("the light bakes");
                black_box(session.relight())
            })
        });
        // What the key press itself costs: the command and the relight (the moved light's
        // direct light exact); the queued work is dropped here, the editor's bake worker runs it.
        group.bench_function(format!("{name}-key-path"), |b| {
            b.iter(|| {
                step(&mut session);
                black_box(session.relight());
                black_box(session.take_bake_jobs())
            })
        });
    }
    group.finish();
}

/// Heap allocations of one key press (after the first frame), printed: the frame buffers are
/// reused, so what is left is a few small vectors.
fn allocations_per_key(_: &mut Criterion) {
    let (mut model, mut session, spec) = editor("paper");
    press(&mut model, &mut session, &spec, true);
    let _profiler = dhat::Profiler::builder().testing().build();
    let before = dhat::HeapStats::get();
    press(&mut model, &mut session, &spec, false);
    let after = dhat::HeapStats::get();
    println!(
        "allocations per key press (paper, 1024×768): {} blocks, {} bytes in all, largest live {} bytes",
        after.total_blocks - before.total_blocks,
        after.total_bytes - before.total_bytes,
        after.max_bytes
    );
}

/// Encode time per protocol, and the bytes a terminal receives for one preview frame.
fn bytes_per_frame(c: &mut Criterion) {
    let scene = paper();
    let model = Model::new(&scene, TERMINAL, FONT);
    // The editor's options: the plan's engine, its solves off the key path.
    let options = SessionOptions::default().interactive();
    let mut session = Session::new(scene, options, &mut |_| {}).expect("bake");
    let spec = frame_spec(&model).expect("the preview has pixels");
    let pixmap = session.render(&spec).expect("the frame renders").pixmap.clone();
    let area = preview_rect(Rect::new(0, 0, TERMINAL.0, TERMINAL.1));
    let cells = Size::new(area.width, area.height);
    println!(
        "preview at {}×{} cells: {}×{} cells, {}×{} px",
        TERMINAL.0,
        TERMINAL.1,
        cells.width,
        cells.height,
        pixmap.width(),
        pixmap.height()
    );
    // The editor's own encoders (`preview::encode_frame`), each frame the full one sent after
    // input went idle (sixel dithered).
    let mut group = c.benchmark_group("editor/encode");
    let plan = FramePlan::Full { dither: true };
    let size = (pixmap.width(), pixmap.height());
    for protocol in [
        Protocol::Halfblocks,
        Protocol::Sixel,
        Protocol::Kitty,
        Protocol::Iterm2,
    ] {
        let setup = ImageSetup {
            protocol,
            passthrough: false,
            cell_px: if protocol == Protocol::Halfblocks {
                preview::HALFBLOCK_CELL_PX
            } else {
                FONT
            },
            hint: None,
        };
        let encode =
            || preview::encode_frame(&setup, pixmap.data(), size, plan, cells).expect("the frame encodes");
        let bytes = preview::frame_sequence(&encode(), area)
            .expect("bytes measured")
            .len();
        println!(
            "bytes per frame, {protocol:?}: {bytes} ({:.0} KiB)",
            bytes as f64 / 1024.0
        );
        group.bench_function(BenchmarkId::from_parameter(format!("{protocol:?}")), |b| {
            b.iter(|| black_box(encode()))
        });
    }
    group.finish();
}

fn configured() -> Criterion {
    Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3))
}

criterion_group! {
    name = benches;
    config = configured();
    targets = key_to_pixmap, key_to_settled, camera_orbit, light_move, allocations_per_key, bytes_per_frame
}
criterion_main!(benches);
