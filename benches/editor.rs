//! The editor's costs per keystroke (docs/BENCHMARKS.md): a key press → a new 1024 × 768
//! preview pixmap of the paper room (update + relight + render + overlays), and what one
//! preview frame costs on the wire for each image protocol at 160 × 48 cells with a 10 × 20 px
//! font (encode time is benched; the byte counts are printed).

use std::hint::black_box;
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use haiko::tui::renderer::{FrameRequest, PreviewRenderer};
use haiko::tui::view::preview_rect;
use haiko::tui::workers::render_one;
use haiko::tui::{Model, Msg, preview, update};
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use ratatui::layout::{Rect, Size};
use ratatui_image::picker::{Picker, ProtocolType};

/// The terminal of the byte counts, cells.
const TERMINAL: (u16, u16) = (160, 48);
/// Half-blocks' nominal font, px.
const FONT: (u16, u16) = (10, 20);

fn paper() -> Arc<haiko::scene::Scene> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("rooms/paper.toml");
    Arc::new(haiko::scene::load(&path).expect("the paper room loads"))
}

fn key(code: KeyCode) -> Msg {
    Msg::Key(KeyEvent::new(code, KeyModifiers::NONE))
}

/// ↑ then ↓ alternately (so every press changes the curve): update → relight → render.
fn key_to_pixmap(c: &mut Criterion) {
    let scene = paper();
    let mut model = Model::new(&scene, TERMINAL, FONT);
    let mut renderer = PreviewRenderer::new(Arc::clone(&scene), None, &mut |_| {}).expect("bake");
    let mut up = true;
    c.bench_function("editor/key_to_pixmap_paper_1024x768", |b| {
        b.iter(|| {
            let effects = update(&mut model, key(if up { KeyCode::Up } else { KeyCode::Down }));
            up = !up;
            assert!(!effects.is_empty(), "the key press changed nothing");
            let mut request = FrameRequest::from_model(&model).expect("the preview has pixels");
            request.size_px = (1024, 768);
            black_box(render_one(&mut renderer, &request).expect("the frame renders"))
        })
    });
}

/// Encode time per protocol, and the bytes a terminal receives for one preview frame.
fn bytes_per_frame(c: &mut Criterion) {
    let scene = paper();
    let model = Model::new(&scene, TERMINAL, FONT);
    let mut renderer = PreviewRenderer::new(Arc::clone(&scene), None, &mut |_| {}).expect("bake");
    let request = FrameRequest::from_model(&model).expect("the preview has pixels");
    let frame = render_one(&mut renderer, &request).expect("the frame renders");
    let pixmap = &frame.preview.frame.pixmap;
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
    let mut group = c.benchmark_group("editor/encode");
    for protocol in [
        ProtocolType::Halfblocks,
        ProtocolType::Sixel,
        ProtocolType::Kitty,
        ProtocolType::Iterm2,
    ] {
        let mut picker = Picker::halfblocks();
        picker.set_protocol_type(protocol);
        let image = preview::encode(&picker, pixmap, cells).expect("the frame encodes");
        let bytes = preview::bytes_on_wire(&image, area).expect("bytes measured");
        println!(
            "bytes per frame, {protocol:?}: {bytes} ({:.0} KiB)",
            bytes as f64 / 1024.0
        );
        group.bench_with_input(
            BenchmarkId::from_parameter(format!("{protocol:?}")),
            &picker,
            |b, p| b.iter(|| black_box(preview::encode(p, pixmap, cells).expect("the frame encodes"))),
        );
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
    targets = key_to_pixmap, bytes_per_frame
}
criterion_main!(benches);
