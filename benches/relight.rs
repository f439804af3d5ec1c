//! Relight costs per edit (docs/BENCHMARKS.md): one light's new fine-vertex illuminance after
//! a curve edit (one control point changed) or a re-aim, with and without a bake, at about 10 000
//! and 100 000 fine vertices, plus the time to build the [`Relighter`] (direct caches, visibility
//! rays, interpolation weights). Targets: an edit under 1 ms for the paper room, under 10 ms at
//! 100 000 fine vertices. Rooms: `rooms/` and the bench copies in `benches/rooms/`.

use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

use criterion::{
    BenchmarkGroup, BenchmarkId, Criterion, criterion_group, criterion_main, measurement::WallTime,
};
use glam::DVec3;
use haiko::photometry::Curve;
use haiko::relight::Relighter;
use haiko::scene::Scene;
use haiko::transport::bake::{Bake, BakeOptions, bake};

/// Direct light only (issue 3): empty rooms (no visibility) and the furnished office (boxes).
const DIRECT_ROOMS: [&str; 4] = [
    "benches/rooms/empty-10k.toml",
    "benches/rooms/empty-100k.toml",
    "rooms/office.toml",
    "benches/rooms/office-100k.toml",
];

/// With a bake (issue 4): the paper room and the office, each at about 10k and 100k vertices.
const BAKED_ROOMS: [&str; 4] = [
    "rooms/paper.toml",
    "benches/rooms/paper-100k.toml",
    "rooms/office.toml",
    "benches/rooms/office-100k.toml",
];

/// The light every bench edits.
const EDITED: usize = 0;

fn load(path: &str) -> Scene {
    let full = Path::new(env!("CARGO_MANIFEST_DIR")).join(path);
    haiko::scene::load(&full).unwrap_or_else(|e| panic!("bench room {path}: {e}"))
}

/// A bench id naming the room file and its fine vertex count, e.g. `office/93679`.
fn id(path: &str, scene: &Scene) -> BenchmarkId {
    let stem = Path::new(path)
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or(path);
    BenchmarkId::new(stem, scene.fine.positions.len())
}

/// `curve` with its peak control point lowered by 10 % (one control point changed).
fn edited(curve: &Curve) -> Curve {
    let intensities = curve.intensities_cd();
    let (peak, &candela) = intensities
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))
        .expect("a curve has control points");
    let mut out = curve.clone();
    out.set_intensity(peak, 0.9 * candela)
        .expect("0.9 × a valid intensity is valid");
    out
}

/// Alternates light [`EDITED`]'s curve between its own and [`edited`] at every iteration, so each
/// iteration is a real change.
fn bench_curve_edit(group: &mut BenchmarkGroup<WallTime>, id: BenchmarkId, relighter: &mut Relighter) {
    let curves = [
        relighter.light(EDITED).curve.clone(),
        edited(&relighter.light(EDITED).curve),
    ];
    let mut step = 0_usize;
    group.bench_function(id, |b| {
        b.iter(|| {
            step += 1;
            relighter.set_curve(EDITED, curves[step % 2].clone());
            black_box(relighter.total()[0])
        })
    });
}

/// Alternates light [`EDITED`]'s aim between its own and one tilted by about 10°.
fn bench_aim_edit(group: &mut BenchmarkGroup<WallTime>, id: BenchmarkId, relighter: &mut Relighter) {
    let aim = relighter.light(EDITED).aim;
    let tilted = (aim + 0.18 * aim.any_orthonormal_vector()).normalize();
    let aims: [DVec3; 2] = [aim, tilted];
    let mut step = 0_usize;
    group.bench_function(id, |b| {
        b.iter(|| {
            step += 1;
            relighter.set_aim(EDITED, aims[step % 2]);
            black_box(relighter.total()[0])
        })
    });
}

fn configured() -> Criterion {
    Criterion::default()
        .sample_size(20)
        .measurement_time(Duration::from_secs(2))
        .warm_up_time(Duration::from_millis(500))
}

fn direct(c: &mut Criterion) {
    let scenes: Vec<(&str, Scene)> = DIRECT_ROOMS.iter().map(|&p| (p, load(p))).collect();

    let mut group = c.benchmark_group("direct_build");
    group.sample_size(10);
    for (path, scene) in &scenes {
        group.bench_function(id(path, scene), |b| b.iter(|| Relighter::new(black_box(scene))));
    }
    group.finish();

    let mut group = c.benchmark_group("direct_curve_edit");
    for (path, scene) in &scenes {
        bench_curve_edit(&mut group, id(path, scene), &mut Relighter::new(scene));
    }
    group.finish();
}

fn with_bake(c: &mut Criterion) {
    let baked: Vec<(&str, Scene, Bake)> = BAKED_ROOMS
        .iter()
        .map(|&p| {
            let scene = load(p);
            let b = bake(&scene, &BakeOptions::default(), &mut |_| {})
                .unwrap_or_else(|e| panic!("bench room {p}: {e}"));
            (p, scene, b)
        })
        .collect();

    let mut group = c.benchmark_group("baked_build");
    group.sample_size(10);
    for (path, scene, b) in &baked {
        group.bench_function(id(path, scene), |bencher| {
            bencher.iter(|| Relighter::with_bake(black_box(scene), b))
        });
    }
    group.finish();

    let mut group = c.benchmark_group("baked_curve_edit");
    for (path, scene, b) in &baked {
        bench_curve_edit(&mut group, id(path, scene), &mut Relighter::with_bake(scene, b));
    }
    group.finish();

    let mut group = c.benchmark_group("baked_aim_edit");
    for (path, scene, b) in &baked {
        bench_aim_edit(&mut group, id(path, scene), &mut Relighter::with_bake(scene, b));
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = configured();
    targets = direct, with_bake
}
criterion_main!(benches);
