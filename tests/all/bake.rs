//! The bake: conservation (Sumpner, zero-flux basis emitters), linearity of the blend, the plan's
//! decisions and that they change no answer, and the cache's integrity (docs/METHOD.md §7, §8).

use std::path::Path;

use glam::DVec3;
use haiko::photometry::{Curve, ShBasis, sh_count, sh_index};
use haiko::relight::{LightState, Relighter, light_coefficients};
use haiko::scene::{Scene, load};
use haiko::transport::bake::{Bake, BakeOptions, bake, default_form_factor_options, patch_reflectance};
use haiko::transport::cache;
use haiko::transport::direct::polygon_flux;
use haiko::transport::formfactor::FormFactors;
use haiko::transport::plan::{PlanOptions, plan};
use haiko::transport::radiosity::{PatchColumns, SolveOptions, solve};
use haiko::transport::visibility::Unoccluded;

/// Writes a room file into `dir` and loads it.
fn room(dir: &Path, name: &str, text: &str) -> Scene {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    load(&path).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// A closed 4 × 3 × 2.5 m room with uniform reflectance and one light.
fn uniform_room(dir: &Path, rho: f64, light: &str) -> Scene {
    uniform_room_tol(dir, rho, light, 1e-5)
}

/// [`uniform_room`] with a given solver tolerance.
fn uniform_room_tol(dir: &Path, rho: f64, light: &str, tolerance: f64) -> Scene {
    room(
        dir,
        &format!("uniform-{rho}.toml"),
        &format!(
            r#"version = 1
[room]
size = [4.0, 3.0, 2.5]
[room.reflectance]
floor = {rho}
walls = {rho}
ceiling = {rho}
{light}
[settings]
patch_size = 0.25
solver_patch_size = 0.25
tolerance = {tolerance:e}
"#
        ),
    )
}

const CENTRE_LIGHT: &str = r#"[[light]]
name = "l"
position = [1.7, 1.4, 1.6]
aim_dir = [0.3, 0.2, -1.0]
lid = [[0, 900], [30, 800], [60, 500], [90, 200], [120, 100], [180, 50]]
order = 6
"#;

fn bake_plain(scene: &Scene) -> Bake {
    bake(scene, &BakeOptions::default(), &mut |_| {}).unwrap()
}

/// Σ_p A_p H_p for light 0's current state, blended from the baked columns (lm).
fn total_flux_on_patches(scene: &Scene, b: &Bake) -> (f64, f64) {
    let light = &b.lights[0];
    let basis = ShBasis::new(light.plan.order);
    let state = LightState::from(&scene.lights[0]);
    let (c, _) = light_coefficients(&state, light.plan.order, None, &basis);
    let k = light.n_columns;
    let (mut direct, mut total) = (0.0, 0.0);
    for (p, patch) in scene.coarse.patches.iter().enumerate() {
        let e: f64 = (0..k).map(|j| f64::from(light.direct[p * k + j]) * c[j]).sum();
        let i: f64 = (0..k)
            .map(|j| f64::from(light.indirect[0][p * k + j]) * c[j])
            .sum();
        direct += patch.area * e;
        total += patch.area * (e + i);
    }
    (direct, total)
}

#[test]
fn sumpner_closed_room_total_flux_is_phi_over_one_minus_rho() {
    let dir = tempfile::tempdir().unwrap();
    for rho in [0.5, 0.95] {
        let scene = uniform_room(dir.path(), rho, CENTRE_LIGHT);
        let b = bake_plain(&scene);
        let phi = scene.lights[0].curve.flux_lm();
        let (direct, total) = total_flux_on_patches(&scene, &b);
        assert!(
            (direct / phi - 1.0).abs() < 1e-3,
            "ρ={rho}: direct flux {direct} vs Φ {phi}"
        );
        let want = phi / (1.0 - rho);
        assert!(
            (total / want - 1.0).abs() < 0.01,
            "ρ={rho}: Σ A H = {total}, Φ/(1−ρ) = {want}"
        );
        // The same through the fine vertices the editor shows (vertex-averaged over fine patches).
        let relit = Relighter::with_bake(&scene, &b);
        let fine_total: f64 = scene
            .fine
            .patches
            .iter()
            .map(|p| {
                let ids = p.vertex_ids();
                p.area * ids.iter().map(|&v| relit.total()[v as usize][0]).sum::<f64>() / ids.len() as f64
            })
            .sum();
        assert!(
            (fine_total / want - 1.0).abs() < 0.02,
            "ρ={rho}: fine Σ A E = {fine_total}, want {want}"
        );
    }
}

#[test]
fn every_basis_emitter_above_l0_has_zero_net_flux() {
    let dir = tempfile::tempdir().unwrap();
    // A tight solve: the certified tolerance bounds what the solve may leave.
    let scene = uniform_room_tol(dir.path(), 0.6, CENTRE_LIGHT, 1e-9);
    let b = bake_plain(&scene);
    let light = &b.lights[0];
    let k = light.n_columns;
    let flux = |j: usize, with_indirect: bool| -> f64 {
        scene
            .coarse
            .patches
            .iter()
            .enumerate()
            .map(|(p, patch)| {
                let ind = if with_indirect {
                    f64::from(light.indirect[0][p * k + j])
                } else {
                    0.0
                };
                patch.area * (f64::from(light.direct[p * k + j]) + ind)
            })
            .sum()
    };
    let scale = flux(0, true).abs();
    assert!(scale > 1.0);
    for l in 1..=light.plan.order {
        for m in -(l as isize)..=l as isize {
            let j = sh_index(l, m);
            assert!(
                flux(j, false).abs() < 1e-6 * scale,
                "direct (l={l}, m={m}): {}",
                flux(j, false)
            );
            assert!(
                flux(j, true).abs() < 1e-6 * scale,
                "total (l={l}, m={m}): {}",
                flux(j, true)
            );
        }
    }
}

#[test]
fn black_room_plans_no_solve_and_has_exactly_zero_indirect() {
    let dir = tempfile::tempdir().unwrap();
    let scene = uniform_room(dir.path(), 0.0, CENTRE_LIGHT);
    let p = plan(&scene, PlanOptions::default());
    assert!(!p.interreflection.on, "{}", p.interreflection.reason);
    assert_eq!((p.form_factor_bytes, p.basis_bytes), (0, 0));
    let b = bake_plain(&scene);
    assert!(b.lights.iter().all(|l| !l.has_indirect()));
    assert_eq!(b.form_factor_bytes, 0);
    let direct_only = Relighter::new(&scene);
    let baked = Relighter::with_bake(&scene, &b);
    assert_eq!(
        direct_only.total(),
        baked.total(),
        "indirect must be exactly zero"
    );
}

#[test]
fn empty_box_room_plans_no_visibility_and_furniture_does() {
    let dir = tempfile::tempdir().unwrap();
    let empty = uniform_room(dir.path(), 0.5, CENTRE_LIGHT);
    let p = plan(&empty, PlanOptions::default());
    assert!(
        !p.visibility.on && p.form_factor_rays == 0,
        "{}",
        p.visibility.reason
    );
    let b = bake_plain(&empty);
    assert_eq!(
        b.form_factor_rays, 0,
        "no rays may be cast in an empty convex room"
    );
    let furnished = load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("rooms/office.toml")).unwrap();
    let p = plan(&furnished, PlanOptions::default());
    assert!(p.visibility.on, "{}", p.visibility.reason);
    assert_eq!(
        p.channels, 3,
        "the office cabinet is coloured: {}",
        p.channels_reason
    );
    let grey = load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("rooms/paper.toml")).unwrap();
    assert_eq!(plan(&grey, PlanOptions::default()).channels, 1);
}

/// Fresh simulation of one light's truncated, windowed series at its aim: the series as a single
/// emitter, its own direct irradiance on the patches and its own solve.
fn fresh_total(scene: &Scene, b: &Bake, state: &LightState) -> Vec<f64> {
    let light = &b.lights[0];
    let basis = ShBasis::new(light.plan.order);
    let (c, _) = light_coefficients(state, light.plan.order, None, &basis);
    let pos = scene.lights[0].position;
    let mesh = &scene.coarse;
    let e: Vec<f64> = mesh
        .patches
        .iter()
        .map(|p| {
            let poly: Vec<DVec3> = p
                .vertex_ids()
                .iter()
                .map(|&v| mesh.positions[v as usize])
                .collect();
            polygon_flux(pos, scene.lights[0].radius, &poly, p.normal, |dir| {
                basis.dot(&c, dir)
            }) / p.area
        })
        .collect();
    let mut ff = FormFactors::build(mesh, &Unoccluded, default_form_factor_options());
    ff.balance(&mesh.patches.iter().map(|p| p.area).collect::<Vec<_>>());
    let rho = patch_reflectance(scene, mesh, 0);
    let sol = solve(
        &ff,
        &rho,
        &PatchColumns::from_columns(e.len(), &[e]),
        &SolveOptions {
            tolerance: 1e-6,
            ..SolveOptions::default()
        },
    )
    .unwrap();
    sol.irradiance.column(0)
}

#[test]
fn blend_of_the_basis_equals_a_fresh_simulation_of_the_truncated_curve() {
    let dir = tempfile::tempdir().unwrap();
    let scene = uniform_room(dir.path(), 0.7, CENTRE_LIGHT);
    let b = bake_plain(&scene);
    let light = &b.lights[0];
    let k = light.n_columns;
    let basis = ShBasis::new(light.plan.order);
    for aim in [
        DVec3::Z,
        DVec3::NEG_Z,
        DVec3::new(1.0, 0.0, 0.0),
        DVec3::new(0.3, -0.8, 0.2).normalize(),
    ] {
        let state = LightState {
            aim,
            ..LightState::from(&scene.lights[0])
        };
        let (c, _) = light_coefficients(&state, light.plan.order, None, &basis);
        let blended: Vec<f64> = (0..scene.coarse.patches.len())
            .map(|p| {
                (0..k)
                    .map(|j| {
                        (f64::from(light.direct[p * k + j]) + f64::from(light.indirect[0][p * k + j])) * c[j]
                    })
                    .sum()
            })
            .collect();
        let fresh = fresh_total(&scene, &b, &state);
        let max = fresh.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let worst = blended
            .iter()
            .zip(&fresh)
            .map(|(a, f)| (a - f).abs())
            .fold(0.0, f64::max);
        // Bake tolerance 1e-5 and f32 storage: agreement to a few 1e-5 of the maximum.
        assert!(worst <= 5e-5 * max, "aim {aim}: worst {worst} of {max}");
    }
    assert_eq!(sh_count(light.plan.order), k);
}

#[test]
fn a_corrupted_cache_is_rebuilt_with_a_notice() {
    let dir = tempfile::tempdir().unwrap();
    let cache_dir = dir.path().join("cache");
    let scene = uniform_room(dir.path(), 0.5, CENTRE_LIGHT);
    let options = BakeOptions {
        cache: Some(haiko::transport::cache::BakeCache::in_dir(cache_dir.clone())),
        ..BakeOptions::default()
    };
    let first = bake(&scene, &options, &mut |_| {}).unwrap();
    assert!(!first.lights[0].from_cache && first.notices.is_empty());
    let second = bake(&scene, &options, &mut |_| {}).unwrap();
    assert!(second.lights[0].from_cache);
    assert_eq!(
        second.lights[0].indirect, first.lights[0].indirect,
        "the cache must round-trip exactly"
    );
    let file = std::fs::read_dir(&cache_dir)
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    let good = std::fs::read(&file).unwrap();
    let damages: [(&str, Vec<u8>); 3] = [
        ("truncated", good[..good.len() / 2].to_vec()),
        ("checksum", {
            let mut d = good.clone();
            let at = d.len() - 7;
            d[at] ^= 0x40;
            d
        }),
        ("version", {
            let mut d = good.clone();
            d[8..12].copy_from_slice(&(cache::FORMAT_VERSION - 1).to_le_bytes());
            d
        }),
    ];
    for (what, bytes) in damages {
        std::fs::write(&file, bytes).unwrap();
        let rebuilt = bake(&scene, &options, &mut |_| {}).unwrap();
        assert!(
            !rebuilt.lights[0].from_cache,
            "{what}: must not trust the damaged file"
        );
        assert_eq!(
            rebuilt.notices.len(),
            1,
            "{what}: one notice, got {:?}",
            rebuilt.notices
        );
        assert!(
            rebuilt.notices[0].contains(what) && !rebuilt.notices[0].contains('\n'),
            "{}",
            rebuilt.notices[0]
        );
        assert_eq!(rebuilt.lights[0].indirect, first.lights[0].indirect);
        assert!(
            bake(&scene, &options, &mut |_| {}).unwrap().lights[0].from_cache,
            "{what}: rewritten"
        );
    }
    // Moving the light changes the key: a new bake, not a stale hit.
    let moved = uniform_room(
        dir.path(),
        0.5,
        &CENTRE_LIGHT.replace("[1.7, 1.4, 1.6]", "[1.2, 1.4, 1.6]"),
    );
    assert!(!bake(&moved, &options, &mut |_| {}).unwrap().lights[0].from_cache);
}

#[test]
fn the_plan_changes_no_answer_on_the_bundled_rooms() {
    // Planned bake vs a forced full one (visibility everywhere, RGB, order + 4): fine-vertex
    // totals agree within 2 % of the room's maximum illuminance.
    for name in ["paper", "office", "gallery", "white-box", "sculpture"] {
        let scene = load(&Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("rooms/{name}.toml"))).unwrap();
        let planned = Relighter::with_bake(&scene, &bake_plain(&scene));
        let full_options = BakeOptions {
            plan: PlanOptions {
                force_visibility: true,
                force_rgb: true,
                order_boost: 4,
                ..PlanOptions::default()
            },
            ..BakeOptions::default()
        };
        let full = Relighter::with_bake(&scene, &bake(&scene, &full_options, &mut |_| {}).unwrap());
        let max = planned.total().iter().map(|e| e[1]).fold(0.0, f64::max);
        let worst = planned
            .total()
            .iter()
            .zip(full.total())
            .map(|(a, b)| (a[1] - b[1]).abs())
            .fold(0.0, f64::max);
        eprintln!("{name}: worst difference {worst:.3} lx of max {max:.1} lx");
        assert!(
            worst <= 0.02 * max,
            "{name}: worst difference {worst:.2} lx of max {max:.1} lx"
        );
    }
}

#[test]
fn hybrid_and_paper_mode_agree_for_a_smooth_curve_and_not_for_a_hard_spot() {
    let dir = tempfile::tempdir().unwrap();
    let smooth = uniform_room(dir.path(), 0.5, CENTRE_LIGHT);
    let paper_text = |light: &str| {
        format!(
            "version = 1\n[room]\nsize = [4.0, 3.0, 2.5]\n[room.reflectance]\nfloor = 0.5\nwalls = 0.5\nceiling = 0.5\n{light}\n[settings]\npatch_size = 0.25\nsolver_patch_size = 0.25\ndirect = \"basis\"\n"
        )
    };
    let smooth_paper = room(dir.path(), "smooth-paper.toml", &paper_text(CENTRE_LIGHT));
    let spot = CENTRE_LIGHT.replace(
        "lid = [[0, 900], [30, 800], [60, 500], [90, 200], [120, 100], [180, 50]]",
        "lid = [[0, 900], [20, 900], [20, 0], [180, 0]]",
    );
    let spot_exact = uniform_room(dir.path(), 0.51, &spot);
    let spot_paper = room(
        dir.path(),
        "spot-paper.toml",
        &paper_text(&spot).replace("0.5\n", "0.51\n"),
    );
    let diff = |a: &Scene, b: &Scene| {
        let ra = Relighter::with_bake(a, &bake_plain(a));
        let rb = Relighter::with_bake(b, &bake_plain(b));
        let max = ra.total().iter().map(|e| e[0]).fold(0.0, f64::max);
        ra.total()
            .iter()
            .zip(rb.total())
            .map(|(x, y)| (x[0] - y[0]).abs())
            .fold(0.0, f64::max)
            / max
    };
    let smooth_diff = diff(&smooth, &smooth_paper);
    let spot_diff = diff(&spot_exact, &spot_paper);
    assert!(smooth_diff < 0.05, "smooth curve at order 6: {smooth_diff}");
    assert!(
        spot_diff > 0.1,
        "a hard spot cannot be represented by its series: {spot_diff}"
    );
    let _ = Curve::isotropic(1.0);
}
