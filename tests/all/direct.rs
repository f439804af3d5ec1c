//! Exact direct light against the closed forms of docs/METHOD.md §8.

use glam::DVec3;
use haiko::photometry::Curve;
use haiko::transport::direct::{DirectCache, Receiver, illuminance_at, polygon_flux};

/// A piecewise-linear sampling of `f(γ)` (cd) every `step_deg` from 0 to `end_deg`.
fn sampled(f: impl Fn(f64) -> f64, step_deg: f64, end_deg: f64) -> Curve {
    let n = (end_deg / step_deg).round() as usize;
    let points: Vec<(f64, f64)> = (0..=n)
        .map(|i| {
            let g = i as f64 * step_deg;
            (g, f(g.to_radians()).max(0.0))
        })
        .collect();
    Curve::new(&points).unwrap()
}

fn floor_point(d: f64) -> Receiver {
    Receiver {
        point: DVec3::new(d, 0.0, 0.0),
        normal: DVec3::Z,
    }
}

fn assert_rel(got: f64, want: f64, rel: f64, what: &str) {
    assert!(
        (got - want).abs() <= rel * want.abs(),
        "{what}: got {got}, want {want} (rel {rel})"
    );
}

const LIGHT: DVec3 = DVec3::new(0.0, 0.0, 2.0);
const DOWN: DVec3 = DVec3::new(0.0, 0.0, -1.0);

#[test]
fn isotropic_source_over_a_plane() {
    let curve = Curve::isotropic(1000.0);
    for (d, lux) in [
        (0.0, 250.0),
        (1.0, 178.885438),
        (2.0, 88.388348),
        (4.0, 22.360680),
    ] {
        let e = illuminance_at(LIGHT, 0.0, &curve, DOWN, 1.0, &floor_point(d), None);
        assert_rel(
            e,
            lux,
            2e-8,
            &format!("isotropic d={d} (docs/METHOD.md §8 value)"),
        );
        let exact = 1000.0 * 2.0 / (4.0_f64 + d * d).powf(1.5);
        assert_rel(e, exact, 1e-13, &format!("isotropic d={d} (formula)"));
    }
}

#[test]
fn cosine_and_cos5_sources_over_a_plane_within_a_tenth_of_a_percent() {
    let cosine = sampled(|g| 1000.0 * g.cos(), 0.1, 90.0);
    let cos5 = sampled(|g| 1000.0 * g.cos().powi(5), 0.1, 90.0);
    for (d, lux_cos, lux_cos5) in [
        (0.0, 250.0, 250.0),
        (1.0, 160.0, 102.4),
        (2.0, 62.5, 15.625),
        (4.0, 10.0, 0.4),
    ] {
        let e = illuminance_at(LIGHT, 0.0, &cosine, DOWN, 1.0, &floor_point(d), None);
        assert_rel(e, lux_cos, 1e-3, &format!("cosine d={d}"));
        let e = illuminance_at(LIGHT, 0.0, &cos5, DOWN, 1.0, &floor_point(d), None);
        assert_rel(e, lux_cos5, 1e-3, &format!("cos^5 d={d}"));
    }
}

#[test]
fn cache_and_single_point_paths_agree_and_dimmer_scales() {
    let curve = sampled(|g| 800.0 * g.cos().powi(2) + 50.0, 5.0, 180.0);
    let receivers: Vec<Receiver> = (0..50).map(|i| floor_point(i as f64 * 0.1)).collect();
    let cache = DirectCache::build(LIGHT, 0.05, &receivers, None);
    let mut out = vec![0.0; receivers.len()];
    cache.illuminance_into(&receivers, &curve, DOWN, 0.5, &mut out);
    for (rx, e) in receivers.iter().zip(&out) {
        let single = illuminance_at(LIGHT, 0.05, &curve, DOWN, 0.5, rx, None);
        assert_eq!(*e, single);
    }
    // Softening: directly below, E = I cosθ/(r² + a²) with r = 2, a = 0.05.
    assert_rel(out[0], 0.5 * 850.0 / (4.0 + 0.0025), 1e-12, "softened nadir");
}

#[test]
fn aimed_spotlight_matches_the_curve_at_the_angle_to_the_axis() {
    // A hard 20° spot (a step at 20°) aimed sideways and down at a wall point.
    let spot = Curve::new(&[
        (0.0, 5000.0),
        (10.0, 4000.0),
        (20.0, 3000.0),
        (20.0, 0.0),
        (180.0, 0.0),
    ])
    .unwrap();
    let light = DVec3::new(1.0, 1.0, 2.5);
    let aim = (DVec3::new(4.0, 2.0, 1.0) - light).normalize();
    let receivers: Vec<Receiver> = (0..40)
        .flat_map(|i| {
            (0..20).map(move |j| Receiver {
                point: DVec3::new(4.0, i as f64 * 0.1, j as f64 * 0.13),
                normal: DVec3::NEG_X,
            })
        })
        .collect();
    let cache = DirectCache::build(light, 0.0, &receivers, None);
    let mut out = vec![0.0; receivers.len()];
    cache.illuminance_into(&receivers, &spot, aim, 1.0, &mut out);
    let mut lit = 0;
    for (rx, e) in receivers.iter().zip(&out) {
        let to = rx.point - light;
        let gamma_deg = aim.dot(to.normalize()).acos().to_degrees();
        let want = if gamma_deg <= 20.0 {
            spot.eval_deg(gamma_deg) * (-rx.normal.dot(to.normalize())) / to.length_squared()
        } else {
            0.0
        };
        assert!(
            (e - want).abs() <= 1e-9 * want.max(1.0),
            "at {}: {e} vs {want}",
            rx.point
        );
        lit += usize::from(*e > 0.0);
    }
    assert!(
        lit > 20 && lit < receivers.len() - 20,
        "the spot must light some points and not others: {lit}"
    );
}

#[test]
fn receivers_facing_away_or_inside_the_luminaire_get_nothing() {
    let curve = Curve::isotropic(100.0);
    let away = Receiver {
        point: DVec3::ZERO,
        normal: DVec3::NEG_Z,
    };
    assert_eq!(illuminance_at(LIGHT, 0.0, &curve, DOWN, 1.0, &away, None), 0.0);
    let at_light = Receiver {
        point: LIGHT,
        normal: DVec3::Z,
    };
    assert_eq!(
        illuminance_at(LIGHT, 0.0, &curve, DOWN, 1.0, &at_light, None),
        0.0
    );
    // 1 mm from a light with a 5 cm radius: finite, bounded by I / a².
    let near = Receiver {
        point: LIGHT - DVec3::new(0.0, 0.0, 0.001),
        normal: DVec3::Z,
    };
    let e = illuminance_at(LIGHT, 0.05, &curve, DOWN, 1.0, &near, None);
    assert!(e.is_finite() && e > 0.0 && e <= 100.0 / 0.0025);
}

#[test]
fn flux_onto_a_disc_and_a_closed_box_equals_the_closed_forms() {
    // Disc R = h = 2 under an isotropic source: 2πI(1 − h/√(h²+R²)) = 1.84030237 I (docs/METHOD.md §8).
    let disc: Vec<DVec3> = (0..4096)
        .map(|k| {
            let t = k as f64 / 4096.0 * std::f64::consts::TAU;
            DVec3::new(2.0 * t.cos(), 2.0 * t.sin(), 0.0)
        })
        .collect();
    let flux = polygon_flux(LIGHT, 0.0, &disc, DVec3::Z, |_| 1.0);
    assert_rel(flux, 1.84030237, 1e-5, "disc");
    // A closed unit box around an off-centre cosine-ish source: the flux of the six faces is Φ.
    let curve = sampled(|g| 1000.0 * g.cos().max(0.0).powf(1.5) + 100.0, 2.5, 180.0);
    let aim = DVec3::new(0.3, -0.2, -1.0).normalize();
    let source = DVec3::new(0.3, 0.6, 0.95);
    let c = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
    let faces: [([DVec3; 4], DVec3); 6] = [
        (
            [c(0., 0., 0.), c(1., 0., 0.), c(1., 1., 0.), c(0., 1., 0.)],
            DVec3::Z,
        ),
        (
            [c(0., 0., 1.), c(0., 1., 1.), c(1., 1., 1.), c(1., 0., 1.)],
            DVec3::NEG_Z,
        ),
        (
            [c(0., 0., 0.), c(0., 1., 0.), c(0., 1., 1.), c(0., 0., 1.)],
            DVec3::X,
        ),
        (
            [c(1., 0., 0.), c(1., 0., 1.), c(1., 1., 1.), c(1., 1., 0.)],
            DVec3::NEG_X,
        ),
        (
            [c(0., 0., 0.), c(0., 0., 1.), c(1., 0., 1.), c(1., 0., 0.)],
            DVec3::Y,
        ),
        (
            [c(0., 1., 0.), c(1., 1., 0.), c(1., 1., 1.), c(0., 1., 1.)],
            DVec3::NEG_Y,
        ),
    ];
    let total: f64 = faces
        .iter()
        .map(|(poly, n)| {
            polygon_flux(source, 0.0, poly, *n, |dir| {
                curve.eval_rad(aim.dot(dir).clamp(-1.0, 1.0).acos())
            })
        })
        .sum();
    assert_rel(total, curve.flux_lm(), 2e-3, "closed box");
}
