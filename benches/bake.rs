//! Full bake cost (docs/BENCHMARKS.md): plan, form factors, basis direct light and the certified
//! interreflection solve for every light, without a cache, of `rooms/paper.toml` (target: a few
//! seconds) and the furnished `rooms/office.toml` (target: under a minute on 2 cores).

use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use haiko::transport::bake::{BakeOptions, bake};

const ROOMS: [&str; 2] = ["rooms/paper.toml", "rooms/office.toml"];

fn configured() -> Criterion {
    Criterion::default()
        .sample_size(10)
        .measurement_time(Duration::from_secs(5))
        .warm_up_time(Duration::from_millis(100))
}

fn full_bake(c: &mut Criterion) {
    let mut group = c.benchmark_group("bake");
    for path in ROOMS {
        let full = Path::new(env!("CARGO_MANIFEST_DIR")).join(path);
        let scene = haiko::scene::load(&full).unwrap_or_else(|e| panic!("bench room {path}: {e}"));
        let stem = Path::new(path)
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or(path);
        group.bench_function(stem, |b| {
            b.iter(|| {
                bake(black_box(&scene), &BakeOptions::default(), &mut |_| {})
                    .unwrap_or_else(|e| panic!("bench room {path}: {e}"))
            })
        });
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = configured();
    targets = full_bake
}
criterion_main!(benches);
