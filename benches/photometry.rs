//! Photometry costs per keystroke (docs/BENCHMARKS.md): exact weights, the paper's rectangle rule, and one
//! incremental intensity edit, for orders 5, 16, 30, 60 on a realistic 37-knot curve (5° steps).

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use haiko::photometry::{Curve, IncrementalWeights, ZonalWeights};

const ORDERS: [usize; 4] = [5, 16, 30, 60];

/// A batwing-like downlight curve with 37 knots every 5° (peak at 30°, 0 from 90° on).
fn realistic_curve() -> Curve {
    let points: Vec<(f64, f64)> = (0..37)
        .map(|k| {
            let gamma = 5.0 * k as f64;
            let candela = if gamma < 90.0 {
                1000.0 * (gamma.to_radians() * 1.5).cos().abs().max(0.2) * (90.0 - gamma) / 90.0
            } else {
                0.0
            };
            (gamma, candela)
        })
        .collect();
    Curve::new(&points).expect("the bench curve is valid")
}

fn configured() -> Criterion {
    Criterion::default()
        .sample_size(20)
        .measurement_time(Duration::from_secs(2))
        .warm_up_time(Duration::from_millis(500))
}

fn weights(c: &mut Criterion) {
    let curve = realistic_curve();
    let mut group = c.benchmark_group("exact_fit");
    for order in ORDERS {
        group.bench_with_input(BenchmarkId::from_parameter(order), &order, |b, &order| {
            b.iter(|| ZonalWeights::exact(black_box(&curve), order))
        });
    }
    group.finish();

    let mut group = c.benchmark_group("rectangle_rule");
    for order in ORDERS {
        group.bench_with_input(BenchmarkId::from_parameter(order), &order, |b, &order| {
            b.iter(|| ZonalWeights::rectangle_rule(black_box(&curve), order, 5.0))
        });
    }
    group.finish();

    let mut group = c.benchmark_group("incremental_edit");
    for order in ORDERS {
        let mut editor = IncrementalWeights::new(curve.clone(), order);
        let mut step = 0_u32;
        group.bench_with_input(BenchmarkId::from_parameter(order), &order, |b, _| {
            b.iter(|| {
                step = step.wrapping_add(1);
                let candela = 500.0 + f64::from(step % 100);
                editor
                    .set_intensity(black_box(7), black_box(candela))
                    .expect("valid intensity");
            })
        });
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = configured();
    targets = weights
}
criterion_main!(benches);
