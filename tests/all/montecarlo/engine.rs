//! The interreflection engine (`haiko::transport::interreflection`) in the hard cases of
//! docs/ACCURACY.md "After": Sumpner's `Σ A·H = Φ/(1−ρ)` in a closed room at ρ = 0.95 with a lamp
//! in the middle, 1 cm below the ceiling, 1 mm from a box face and a hard-edged spot; and the
//! engine against this module's path tracer beside a lamp 1 cm below the ceiling and a lamp
//! touching a box.

use glam::DVec3;
use haiko::photometry::LightState;
use haiko::scene::Scene;
use haiko::transport::direct::{Receiver, scene_direct_at};
use haiko::transport::interreflection::{Interreflection, InterreflectionOptions};

use super::closed_room_with_light;
use super::references::total_lux;
use super::tracer::{Rng, Tracer};

const SMOOTH: &str = "[[0, 900], [30, 800], [60, 500], [90, 200], [120, 100], [180, 50]]";
const SPOT: &str = "[[0, 9000], [17.5, 9000], [17.5, 0], [180, 0]]";

/// The lamp positions of the hard cases (TOML) in the closed 4 × 3 × 2.5 m room whose box spans
/// [1, 2] × [1, 1.8] × [0, 0.9].
const MIDDLE: &str = "[2.2, 1.4, 1.9]";
const BELOW_CEILING: &str = "[2.9, 1.4, 2.49]";
const TOUCHING_BOX: &str = "[2.001, 1.4, 0.5]";

/// The engine of `scene` with visibility (the room has a box) and one grey channel.
fn engine(scene: &Scene) -> Interreflection {
    Interreflection::build(scene, 1, true, &InterreflectionOptions::default()).unwrap()
}

/// `Σ A·H` over the engine's leaves (lm) for the scene's only light.
fn total_irradiance_flux(scene: &Scene, engine: &Interreflection) -> f64 {
    let cache = engine.direct_cache(&scene.lights[0]);
    let solution = engine
        .solve_light(&cache, &LightState::from(&scene.lights[0]), None, 1e-7)
        .expect("the solve converges");
    let areas = engine.operator.leaf_areas();
    areas
        .iter()
        .enumerate()
        .map(|(i, a)| {
            let h = solution[0].irradiance.get(i, 0);
            assert!(h.is_finite() && h >= 0.0, "leaf {i}: H = {h}");
            a * h
        })
        .sum()
}

/// Sumpner at ρ = 0.95: the lamp's whole flux lands (radius 0) and every reflection is kept, so
/// `Σ A·H = Φ/(1−ρ)` (20 Φ) within 1 % — for a lamp in the middle, 1 cm below the ceiling, 1 mm
/// from a box face and for a hard-edged 35° spot.
#[test]
fn sumpner_at_rho_0_95_in_the_hard_cases() {
    let dir = tempfile::tempdir().unwrap();
    let rho = 0.95;
    for (what, position, lid) in [
        ("middle", MIDDLE, SMOOTH),
        ("1 cm below the ceiling", BELOW_CEILING, SMOOTH),
        ("1 mm from a box face", TOUCHING_BOX, SMOOTH),
        ("hard-edged spot", MIDDLE, SPOT),
    ] {
        let scene = closed_room_with_light(dir.path(), rho, lid, false, position);
        let phi = scene.lights[0].curve.flux_lm();
        let engine = engine(&scene);
        let got = total_irradiance_flux(&scene, &engine);
        let want = phi / (1.0 - rho);
        assert!(
            (got - want).abs() < 0.01 * want,
            "{what}: Σ A·H = {got:.1} lm, Φ/(1−ρ) = {want:.1} lm ({:+.2} %)",
            100.0 * (got / want - 1.0)
        );
    }
}

/// Total illuminance (lx) of the engine at `points`: exact direct light plus the indirect light
/// gathered from its leaves.
fn engine_lux(scene: &Scene, points: &[(DVec3, DVec3)]) -> Vec<f64> {
    let engine = engine(scene);
    let receivers: Vec<Receiver> = points
        .iter()
        .map(|&(point, normal)| Receiver { point, normal })
        .collect();
    let b = engine.scene_radiosity(scene, 1e-6).expect("the solve converges");
    total_lux(
        &scene_direct_at(scene, &receivers),
        &engine.gather(&b, &receivers),
    )
}

/// Beside a lamp 1 cm below the ceiling and a lamp 1 mm from a box face (ρ = 0.6): the engine's
/// total illuminance on the ceiling next to the lamp, the floor beside the box, the box face at
/// the floor and a far wall agrees with the path tracer within 5 % plus 4 of its standard errors
/// (which are below 1 %).
#[test]
fn engine_agrees_with_the_tracer_beside_a_lamp_under_the_ceiling_and_one_touching_a_box() {
    let dir = tempfile::tempdir().unwrap();
    let points = [
        (DVec3::new(2.6, 1.4, 2.5), DVec3::NEG_Z), // ceiling 0.3 m from the lamp under it
        (DVec3::new(2.05, 1.4, 0.0), DVec3::Z),    // floor 5 cm from the box face
        (DVec3::new(2.02, 2.2, 0.0), DVec3::Z),    // floor 2 cm from the box, past its corner
        (DVec3::new(2.0, 1.6, 0.02), DVec3::X),    // box face 2 cm above the floor
        (DVec3::new(0.0, 1.5, 1.2), DVec3::X),     // far wall
    ];
    for (what, position) in [
        ("1 cm below the ceiling", BELOW_CEILING),
        ("1 mm from a box face", TOUCHING_BOX),
    ] {
        let scene = closed_room_with_light(dir.path(), 0.6, SMOOTH, false, position);
        let got = engine_lux(&scene, &points);
        let tracer = Tracer::new(&scene);
        for (k, (&(p, n), &e)) in points.iter().zip(&got).enumerate() {
            let mut rng = Rng::new(0x5eed + k as u64);
            let reference = tracer.estimate(p, n, 32, 48, &mut rng);
            assert!(
                reference.std_error < 0.01 * reference.total,
                "{what} at {p}: the reference is too noisy ({} ± {})",
                reference.total,
                reference.std_error
            );
            let err = (e - reference.total).abs();
            assert!(
                err < 0.05 * reference.total + 4.0 * reference.std_error,
                "{what} at {p}: engine {e:.2} lx, tracer {:.2} ± {:.2} lx ({:+.2} %)",
                reference.total,
                reference.std_error,
                100.0 * (e / reference.total - 1.0)
            );
        }
    }
}
