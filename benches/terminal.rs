//! What a preview frame costs on the wire (docs/BENCHMARKS.md "Terminal frames"): one frame of
//! the office and of the paper room at 160 × 48 cells with a 10 × 20 px font (a 940 × 880 px
//! preview), encoded as sixel by our encoder (full frame, and interactive frames rendered at 1/2
//! and 1/3) and by ratatui-image's (icy_sixel, today's frame), and the kitty payload as zlib of
//! the raw RGBA and as PNG. Encode times are benched; byte counts are printed.

use std::hint::black_box;
use std::io::Write;
use std::path::Path;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use haiko::session::{FrameSpec, Session, SessionOptions};
use haiko::tui::app::frame_spec;
use haiko::tui::{Model, preview, sixel};
use image::ImageEncoder;
use image::codecs::png::{CompressionType, FilterType, PngEncoder};
use ratatui::layout::Size;
use ratatui_image::picker::{Picker, ProtocolType};

/// The terminal, cells, and its font, px.
const TERMINAL: (u16, u16) = (160, 48);
const FONT: (u16, u16) = (10, 20);

/// A rendered frame: the room's name, the pixel size, RGBA.
struct Frame {
    room: &'static str,
    size: (u32, u32),
    rgba: Vec<u8>,
}

/// The preview of `room` at 940 × 880 px (the preview of a 160 × 48 terminal before the
/// numbers panel took its rows; the size issue 13's targets name) and at 1/2 and 1/3 of it.
fn render(room: &'static str) -> Vec<Frame> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("rooms/{room}.toml"));
    let scene = haiko::scene::load(&path).expect("the room loads");
    let model = Model::new(&scene, TERMINAL, FONT);
    let mut session = Session::new(scene, SessionOptions::default(), &mut |_| {}).expect("bake");
    session.relight();
    let full = FrameSpec {
        size_px: (940, 880),
        ..frame_spec(&model).expect("the preview has pixels")
    };
    [1, 2, 3]
        .map(|d| {
            let mut spec = full;
            spec.size_px = (full.size_px.0.div_ceil(d), full.size_px.1.div_ceil(d));
            let frame = session.render(&spec).expect("the frame renders");
            Frame {
                room,
                size: spec.size_px,
                rgba: frame.pixmap.data().to_vec(),
            }
        })
        .into()
}

fn zlib(rgba: &[u8]) -> Vec<u8> {
    let mut encoder = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
    encoder.write_all(rgba).expect("writing to memory");
    encoder.finish().expect("writing to memory")
}

fn png(frame: &Frame) -> Vec<u8> {
    let mut bytes = Vec::new();
    PngEncoder::new_with_quality(&mut bytes, CompressionType::Fast, FilterType::Adaptive)
        .write_image(
            &frame.rgba,
            frame.size.0,
            frame.size.1,
            image::ExtendedColorType::Rgba8,
        )
        .expect("writing to memory");
    bytes
}

fn kib(bytes: usize) -> String {
    format!("{bytes} B ({:.1} KiB)", bytes as f64 / 1024.0)
}

fn frames(c: &mut Criterion) {
    let rooms: Vec<Vec<Frame>> = ["office", "paper"].map(render).into();
    let shown = (940, 880);
    let mut group = c.benchmark_group("terminal/sixel");
    for frames in &rooms {
        for (d, frame) in (1u32..).zip(frames) {
            let size = (frame.size.0 as usize, frame.size.1 as usize);
            let encode = || sixel::encode_frame(&frame.rgba, size, d, shown, false).expect("encodes");
            println!(
                "sixel {} 1/{d} ({}×{} px): {}",
                frame.room,
                size.0,
                size.1,
                kib(encode().len())
            );
            group.bench_function(BenchmarkId::new(frame.room, format!("1_{d}")), |b| {
                b.iter(|| black_box(encode()))
            });
        }
    }
    for frames in &rooms {
        let frame = &frames[0];
        let size = (frame.size.0 as usize, frame.size.1 as usize);
        let encode = || sixel::encode_frame(&frame.rgba, size, 1, shown, true).expect("encodes");
        println!("sixel {} dithered: {}", frame.room, kib(encode().len()));
        group.bench_function(BenchmarkId::new(frame.room, "dithered"), |b| {
            b.iter(|| black_box(encode()))
        });
    }
    group.finish();

    let mut group = c.benchmark_group("terminal/kitty");
    for frames in &rooms {
        for (d, frame) in (1u32..).zip(frames) {
            let base64 = |n: usize| n.div_ceil(3) * 4;
            println!(
                "kitty {} 1/{d}: raw {}, zlib {}, PNG {} (base64)",
                frame.room,
                kib(base64(frame.rgba.len())),
                kib(base64(zlib(&frame.rgba).len())),
                kib(base64(png(frame).len()))
            );
            group.bench_function(
                BenchmarkId::new(format!("zlib_{}", frame.room), format!("1_{d}")),
                |b| b.iter(|| black_box(zlib(&frame.rgba))),
            );
            group.bench_function(
                BenchmarkId::new(format!("png_{}", frame.room), format!("1_{d}")),
                |b| b.iter(|| black_box(png(frame))),
            );
        }
    }
    group.finish();

    // Half-blocks: text, every cell its two colours.
    let blocks = preview::ImageSetup::settle(
        haiko::tui::multiplexer::Choice {
            protocol: haiko::tui::multiplexer::Protocol::Halfblocks,
            passthrough: false,
            hint: None,
        },
        None,
        None,
    );
    for frames in &rooms {
        let frame = &frames[0];
        let image = preview::encode_frame(
            &blocks,
            &frame.rgba,
            frame.size,
            haiko::tui::frame_budget::FramePlan::Full { dither: false },
            Size::new(94, 44),
        )
        .expect("encodes");
        let bytes = preview::frame_bytes(&image, ratatui::layout::Rect::new(0, 0, 94, 44)).expect("measured");
        println!("half-blocks {}: {}", frame.room, kib(bytes));
    }

    // Today's frame: ratatui-image's sixel (icy_sixel: Wu quantiser, Floyd–Steinberg).
    let mut group = c.benchmark_group("terminal/ratatui_image_sixel");
    let mut picker = Picker::halfblocks();
    picker.set_protocol_type(ProtocolType::Sixel);
    let cells = Size::new(94, 44);
    for frames in &rooms {
        let frame = &frames[0];
        let pixmap = tiny_skia::Pixmap::from_vec(
            frame.rgba.clone(),
            tiny_skia::IntSize::from_wh(frame.size.0, frame.size.1).expect("a size"),
        )
        .expect("a pixmap");
        let bytes = preview::bytes_on_wire(
            &preview::encode(&picker, &pixmap, cells).expect("encodes"),
            ratatui::layout::Rect::new(0, 0, cells.width, cells.height),
        )
        .expect("measured");
        println!("ratatui-image sixel {}: {}", frame.room, kib(bytes));
        group.bench_function(frame.room, |b| {
            b.iter(|| black_box(preview::encode(&picker, &pixmap, cells).expect("encodes")))
        });
    }
    group.finish();
}

fn configured() -> Criterion {
    Criterion::default()
        .sample_size(20)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
}

criterion_group! {
    name = benches;
    config = configured();
    targets = frames
}
criterion_main!(benches);
