//! The hierarchical indirect engine (docs/BENCHMARKS.md "Hierarchical engine"): on
//! `rooms/paper.toml`, the engine's build with every light solved (target: paper bake ≤ 0.5 s),
//! a curve edit of light 0 (its leaf direct light and warm-started solve, and its indirect light
//! interpolated to the fine vertices; target ≤ 1 ms), a dimmer edit (a scaling) and a 0.1 m move
//! that keeps the refinement (a new direct cache and a solve).

use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use haiko::photometry::Curve;
use haiko::scene::Light;
use haiko::transport::indirect::HierarchicalIndirect;
use haiko::transport::interreflection::InterreflectionOptions;
use haiko::transport::plan::{PlanOptions, plan};

fn configured() -> Criterion {
    Criterion::default()
        .sample_size(10)
        .measurement_time(Duration::from_secs(5))
        .warm_up_time(Duration::from_millis(100))
}

fn paper(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("rooms/paper.toml");
    let scene = haiko::scene::load(&path).unwrap_or_else(|e| panic!("bench room: {e}"));
    let p = plan(&scene, PlanOptions::default());
    let build = || {
        HierarchicalIndirect::build(
            &scene,
            &scene.lights,
            p.channels,
            p.visibility.on,
            scene.settings.tolerance,
            &InterreflectionOptions::default(),
        )
        .unwrap_or_else(|e| panic!("bench room: {e}"))
    };
    let mut group = c.benchmark_group("indirect");
    group.bench_function("paper_build", |b| b.iter(|| black_box(build())));
    let mut engine = build();
    let light = scene.lights[0].clone();
    let lowered: Vec<(f64, f64)> = light.curve.points().map(|(g, i)| (g, 0.9 * i)).collect();
    let variants = [
        light.clone(),
        Light {
            curve: Curve::new(&lowered).unwrap_or_else(|e| panic!("{e}")),
            ..light.clone()
        },
    ];
    let mut k = 0;
    group.bench_function("paper_curve_edit", |b| {
        b.iter(|| {
            k ^= 1;
            engine
                .set_light(0, &variants[k])
                .unwrap_or_else(|e| panic!("{e}"));
            black_box(engine.vertex_indirect(0))
        })
    });
    let dimmed = [
        light.clone(),
        Light {
            dimmer: 0.5 * light.dimmer,
            ..light.clone()
        },
    ];
    group.bench_function("paper_dimmer_edit", |b| {
        b.iter(|| {
            k ^= 1;
            engine.set_light(0, &dimmed[k]).unwrap_or_else(|e| panic!("{e}"));
            black_box(engine.vertex_indirect(0))
        })
    });
    // Light 0 hangs in the middle of the ceiling: a 0.1 m step keeps its refinement pattern's
    // size only by chance, so the move measured is the engine's part (cache and solve).
    let moved = [
        light.clone(),
        Light {
            position: light.position + glam::DVec3::new(0.1, 0.0, 0.0),
            ..light.clone()
        },
    ];
    group.bench_function("paper_move_without_regrade", |b| {
        b.iter(|| {
            k ^= 1;
            engine.set_light(0, &moved[k]).unwrap_or_else(|e| panic!("{e}"));
            black_box(engine.vertex_indirect(0))
        })
    });
    group.finish();
}

criterion_group! {
    name = benches;
    config = configured();
    targets = paper
}
criterion_main!(benches);
