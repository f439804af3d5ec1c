//! The numbers panel's cost per edit (docs/BENCHMARKS.md, "Numbers"): the office's design numbers
//! — the work plane's 54 grid points and 3 observers' eyes through the session's receiver sets,
//! statistics against targets and UGR — after one light's dimmer or one control point changed,
//! with nothing changed (the fixed part: statistics and glare), the illuminance at one watched
//! cursor point after an edit, and the one-time build of the set (direct caches with shadow rays
//! and the gather factors, 4 rays per point and coarse patch). Target: well inside a frame
//! (16 ms) with the relight. The bake comes from a cache in a temporary directory.

use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use glam::DVec3;
use haiko::metrics::{eye_receivers, surface_grids};
use haiko::scene::Receiver;
use haiko::session::{Command, Session, SessionOptions};
use haiko::transport::bake::BakeOptions;
use haiko::transport::cache::BakeCache;

fn office(cache: &Path) -> Session {
    let room = Path::new(env!("CARGO_MANIFEST_DIR")).join("rooms/office.toml");
    let options = SessionOptions {
        bake: BakeOptions {
            cache: Some(BakeCache::in_dir(cache)),
            ..BakeOptions::default()
        },
        indirect: true,
        ..SessionOptions::default()
    };
    Session::open(&room, options, &mut |_| {}).expect("the office bakes")
}

fn numbers(c: &mut Criterion) {
    let cache = tempfile::tempdir().expect("a temporary directory");
    let mut session = office(cache.path());
    session.design_numbers();
    let mut group = c.benchmark_group("numbers");
    group.measurement_time(Duration::from_secs(5));

    let mut step = 0_usize;
    group.bench_function("dimmer_edit/office", |b| {
        b.iter(|| {
            step += 1;
            let dimmer = if step.is_multiple_of(2) { 0.35 } else { 0.24 };
            session
                .apply(Command::SetDimmer { light: 0, dimmer })
                .expect("a dimmer");
            black_box(session.design_numbers().surfaces[0].stats)
        })
    });

    let first = session.lights()[0].curve.intensities_cd()[0];
    group.bench_function("point_edit/office", |b| {
        b.iter(|| {
            step += 1;
            let candela = if step.is_multiple_of(2) {
                first
            } else {
                0.9 * first
            };
            let edit = Command::SetIntensity {
                light: 0,
                point: 0,
                candela,
            };
            session.apply(edit).expect("an intensity");
            black_box(session.design_numbers().surfaces[0].stats)
        })
    });

    group.bench_function("unchanged/office", |b| {
        b.iter(|| black_box(session.design_numbers().surfaces[0].stats))
    });

    let cursor = session.watch(vec![Receiver {
        point: DVec3::new(2.8, 1.6, 0.75),
        normal: DVec3::Z,
    }]);
    group.bench_function("cursor_dimmer_edit/office", |b| {
        b.iter(|| {
            step += 1;
            let dimmer = if step.is_multiple_of(2) { 0.35 } else { 0.24 };
            session
                .apply(Command::SetDimmer { light: 0, dimmer })
                .expect("a dimmer");
            black_box(session.watched(cursor).map(|s| s.lux()[0]))
        })
    });

    let scene = session.scene().clone();
    let mut receivers: Vec<Receiver> = surface_grids(&scene)
        .iter()
        .flat_map(|g| g.receivers.iter().copied())
        .collect();
    receivers.extend(eye_receivers(&scene));
    group.sample_size(10);
    group.bench_function("build/office", |b| {
        b.iter(|| {
            let id = session.watch(receivers.clone());
            let lux = session.watched(id).map(|s| s.lux()[0]);
            session.unwatch(id);
            black_box(lux)
        })
    });
    group.finish();
}

criterion_group!(benches, numbers);
criterion_main!(benches);
