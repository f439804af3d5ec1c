//! The hierarchical indirect engine (docs/BENCHMARKS.md "Hierarchical engine"): on
//! `rooms/paper.toml`, the engine's build with every light solved (target: paper bake ≤ 0.5 s);
//! edits of light 0, each with its indirect light interpolated to the fine vertices (target for
//! a curve edit ≤ 1 ms): the first edit of a control point's intensity (a solve with that
//! point's column), more edits of it (a weighted sum of the light's response), a change of the
//! whole shape once the light's response is grown to every control point, one control
//! point's angle (a solve), a re-aim between ±5° (a warm-started solve), a dimmer edit (a scaling) and a 0.1 m move
//! that keeps the refinement (a new direct cache and a solve), and the editor's estimate of a
//! re-aim while its solve runs (from the light's SH response). The same edits on the open-plan
//! floor of `benches/rooms/open-plan.toml` (targets: a curve edit or re-aim ≤ 10 ms). The
//! clustered gather at the furnished office's work plane, with linear and constant leaf radiosity.

use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use glam::DVec3;
use haiko::photometry::Curve;
use haiko::scene::Light;
use haiko::transport::direct::Receiver;
use haiko::transport::indirect::{HierarchicalIndirect, measured_curve_edit};
use haiko::transport::interreflection::InterreflectionOptions;
use haiko::transport::plan::{PlanOptions, plan};
use haiko::transport::sh_response::ESTIMATE_ORDER;

fn configured() -> Criterion {
    Criterion::default()
        .sample_size(10)
        .measurement_time(Duration::from_secs(5))
        .warm_up_time(Duration::from_millis(100))
}

/// Benches the engine on the room at `path` (relative to the crate) under `name_*`: the build
/// when `time_build`, then the edits of light 0. The γ edit is timed only when `time_gamma`
/// (otherwise an untimed intensity edit adds that point's column to the light's response first).
fn room(c: &mut Criterion, name: &str, path: &str, time_build: bool, time_gamma: bool) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(path);
    let scene = haiko::scene::load(&path).unwrap_or_else(|e| panic!("bench room: {e}"));
    let p = plan(&scene, PlanOptions::default());
    let build = || {
        HierarchicalIndirect::planned(
            &scene,
            &p,
            scene.settings.tolerance,
            &InterreflectionOptions::for_leaves(p.leaves),
        )
        .unwrap_or_else(|e| panic!("bench room: {e}"))
    };
    let mut group = c.benchmark_group("indirect");
    if time_build {
        group.bench_function(format!("{name}_build"), |b| b.iter(|| black_box(build())));
    }
    let mut engine = build();
    let light = scene.lights[0].clone();
    // Light 0 as it is and with one change; each iteration switches between the two.
    let with_curve = |change: &dyn Fn(&mut Curve)| {
        let mut curve = light.curve.clone();
        change(&mut curve);
        [
            light.clone(),
            Light {
                curve,
                ..light.clone()
            },
        ]
    };
    let raised = with_curve(&|c| {
        let raised = 1.1 * c.intensities_cd()[1];
        c.set_intensity(1, raised).unwrap_or_else(|e| panic!("{e}"));
    });
    // The first edit of a control point: a solve of the light with a column for that point
    // (docs/DECISIONS.md "Interreflection", "Responses grown a point at a time"), each on a
    // fresh copy of the engine.
    let point_two = with_curve(&|c| {
        let raised = 1.1 * c.intensities_cd()[2];
        c.set_intensity(2, raised).unwrap_or_else(|e| panic!("{e}"));
    });
    group.bench_function(format!("{name}_first_point_edit"), |b| {
        b.iter_batched(
            || engine.clone(),
            |mut copy| {
                copy.set_light(0, &point_two[1]).unwrap_or_else(|e| panic!("{e}"));
                black_box(copy.vertex_indirect(0))
            },
            criterion::BatchSize::PerIteration,
        )
    });
    let widened = with_curve(&|c| {
        let wider = c.gammas_deg()[1] + 0.5 * (c.gammas_deg()[2] - c.gammas_deg()[1]);
        c.set_gamma(1, wider).unwrap_or_else(|e| panic!("{e}"));
    });
    if !time_gamma {
        // The first edit of the point, which solves its column, untimed.
        engine.set_light(0, &raised[1]).unwrap_or_else(|e| panic!("{e}"));
    }
    let edit = |b: &mut criterion::Bencher, engine: &mut HierarchicalIndirect, pair: &[Light; 2]| {
        let mut k = 0;
        b.iter(|| {
            k ^= 1;
            engine.set_light(0, &pair[k]).unwrap_or_else(|e| panic!("{e}"));
            black_box(engine.vertex_indirect(0))
        })
    };
    // A γ edit first when timed; the intensity edit's first two iterations (in the warm-up)
    // then solve the light at the angles it is left with and point 1's column, and the timed
    // ones weigh the response.
    if time_gamma {
        group.bench_function(format!("{name}_gamma_edit"), |b| edit(b, &mut engine, &widened));
    }
    group.bench_function(format!("{name}_intensity_edit"), |b| {
        edit(b, &mut engine, &raised)
    });
    // A change of the whole shape (every second point scaled by 0.7) once the light's curve
    // response holds every control point, grown step by step as the editor does while idle
    // (untimed): a weighted sum of the response, no solve.
    engine.set_light(0, &light).unwrap_or_else(|e| panic!("{e}"));
    engine
        .complete_response(0, &light)
        .unwrap_or_else(|e| panic!("{e}"));
    let reshaped = [light.clone(), measured_curve_edit(&light)];
    group.bench_function(format!("{name}_curve_edit_from_grown_response"), |b| {
        edit(b, &mut engine, &reshaped)
    });
    let axis = light.aim.any_orthonormal_vector();
    // Both aims differ from the one the light's per-control-point solve was made for.
    let reaimed = [5f64, -5.0].map(|degrees| Light {
        aim: glam::DQuat::from_axis_angle(axis, degrees.to_radians()) * light.aim,
        ..light.clone()
    });
    group.bench_function(format!("{name}_reaim"), |b| edit(b, &mut engine, &reaimed));
    let dimmed = [
        light.clone(),
        Light {
            dimmer: 0.5 * light.dimmer,
            ..light.clone()
        },
    ];
    group.bench_function(format!("{name}_dimmer_edit"), |b| edit(b, &mut engine, &dimmed));
    // A 0.1 m step: the engine's part of a move (the light's direct cache and solve), whether or
    // not the room's grading would call for a rebuild.
    let moved = [
        light.clone(),
        Light {
            position: light.position + glam::DVec3::new(0.1, 0.0, 0.0),
            ..light.clone()
        },
    ];
    group.bench_function(format!("{name}_move_without_regrade"), |b| {
        edit(b, &mut engine, &moved)
    });
    // The editor's estimate of a re-aim while its solve runs: the light's values from its SH
    // response (built by the untimed solves aimed −5° then +5° first: at least one is a solve,
    // whatever the light was left at), interpolated to the vertices; the solve's job is made
    // and dropped. The estimated aims, −5° and −2.5°, are ones no curve response was solved
    // for (the light's own aim may be: that edit would be exact, with no estimate), so the
    // bench does not depend on which benches ran before it.
    engine.set_estimates(Some(ESTIMATE_ORDER));
    for aimed in [&reaimed[1], &reaimed[0]] {
        engine.set_light(0, aimed).unwrap_or_else(|e| panic!("{e}"));
    }
    let mut k = 0;
    let estimated = [
        reaimed[1].clone(),
        Light {
            aim: glam::DQuat::from_axis_angle(axis, (-2.5f64).to_radians()) * light.aim,
            ..light.clone()
        },
    ];
    group.bench_function(format!("{name}_reaim_estimate"), |b| {
        b.iter(|| {
            k ^= 1;
            let job = engine.update_light(0, &estimated[k]);
            assert!(engine.is_estimated(0), "an estimate, not a solve");
            black_box((job, engine.vertex_indirect(0)))
        })
    });
    // The same re-aims as `_reaim`, solved with the estimates on: each solve starts from the
    // estimate of its new aim instead of the values of the old one.
    group.bench_function(format!("{name}_reaim_from_estimate"), |b| {
        edit(b, &mut engine, &reaimed)
    });
    // A re-aim the editor prepared while its aim cursor rested there (docs/DECISIONS.md
    // "Re-aims prepared where the aim cursor rests"): the light's values are taken, no solve,
    // and interpolated to the vertices. Between two aims, the one left is kept prepared in turn
    // (as for an undo), so every timed re-aim is a prepared one.
    engine.set_light(0, &reaimed[0]).unwrap_or_else(|e| panic!("{e}"));
    let job = engine.prepare(0, &reaimed[1]).expect("a re-aim to prepare");
    assert!(engine.hold_prepared(0, job.run().unwrap_or_else(|e| panic!("{e}"))));
    group.bench_function(format!("{name}_reaim_prepared"), |b| {
        let mut k = 0;
        b.iter(|| {
            k ^= 1;
            let job = engine.update_light(0, &reaimed[k]);
            assert!(job.is_none(), "prepared: no solve");
            black_box(engine.vertex_indirect(0))
        })
    });
    group.finish();
}

fn paper(c: &mut Criterion) {
    room(c, "paper", "rooms/paper.toml", true, true);
}

/// The open-plan floor of issue 10 (133 781 leaves, 48 lights): its build (≈ 1 min) is measured
/// by `haiko bake --json`, not repeated here; its γ edit is not timed.
fn open_plan(c: &mut Criterion) {
    room(c, "open_plan", "benches/rooms/open-plan.toml", false, false);
}

/// The clustered gather at a work plane of the furnished office (`rooms/office.toml`, its lights
/// solved): 0.8 m high, a 0.25 m grid, with the leaves' radiosity linear (the default),
/// constant on each leaf (docs/DECISIONS.md "Interreflection", "Linear radiosity in the near
/// gather"), and without the second looks where rays may have missed a gap (docs/DECISIONS.md
/// "The gather looks again where its rays may have missed a gap").
fn gather(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("rooms/office.toml");
    let scene = haiko::scene::load(&path).unwrap_or_else(|e| panic!("bench room: {e}"));
    let p = plan(&scene, PlanOptions::default());
    let size = scene.room_size;
    let spacing = 0.25;
    let (nx, ny) = ((size.x / spacing) as usize, (size.y / spacing) as usize);
    let plane: Vec<Receiver> = (0..nx * ny)
        .map(|k| Receiver {
            point: DVec3::new(
                (0.5 + (k % nx) as f64) * spacing,
                (0.5 + (k / nx) as f64) * spacing,
                0.8,
            ),
            normal: DVec3::Z,
        })
        .collect();
    let mut group = c.benchmark_group("indirect");
    let planned = InterreflectionOptions::for_leaves(p.leaves);
    for (name, linear_gather, gather_doubt) in [
        ("office_gather_plane", true, planned.gather_doubt),
        ("office_gather_plane_constant", false, planned.gather_doubt),
        ("office_gather_plane_first_looks", true, f64::MAX),
    ] {
        let options = InterreflectionOptions {
            linear_gather,
            gather_doubt,
            ..planned
        };
        let engine = HierarchicalIndirect::planned(&scene, &p, scene.settings.tolerance, &options)
            .unwrap_or_else(|e| panic!("bench room: {e}"));
        group.bench_function(name, |b| b.iter(|| black_box(engine.gather_all(&plane))));
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = configured();
    targets = paper, gather, open_plan
}
criterion_main!(benches);
