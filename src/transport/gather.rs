//! Illuminance at arbitrary receivers (probe points, work-plane grids): exact direct light plus
//! the indirect light gathered from the coarse patches' radiosity, `E_ind(p) = Σ_j B_j F_{p→j} V`
//! (docs/METHOD.md §5), with `B_j = ρ_j H_j` blended from the baked basis for the lights' current
//! curves and aims. Gathering (rather than interpolating vertex values) stays accurate beside
//! furniture, where interpolation across an occluder's shadow fails (docs/METHOD.md §5.8).

use glam::DVec3;
use rayon::prelude::*;

use crate::photometry::{LightState, ShBasis, light_coefficients};
use crate::scene::{DirectMode, Scene};
use crate::transport::bake::{Bake, patch_reflectance};
use crate::transport::direct::{Receiver, illuminance_at, luminance_weight};
use crate::transport::formfactor::TargetPatch;
use crate::transport::occlusion::Occluders;
use crate::transport::visibility::Visibility;

/// Exact direct light below this ratio of distance to patch size, differential beyond.
const NEAR_FIELD_RATIO: f64 = 3.0;
/// Visibility samples per patch edge when gathering past occluders (2 → 4 rays per patch).
const GATHER_SAMPLES_PER_EDGE: usize = 2;
/// Receivers are lifted this far along their normal so they do not sit exactly on a surface.
const RECEIVER_LIFT_M: f64 = 1e-6;

/// Radiosity `B = ρ H` (lm/m², linear RGB) of every coarse patch for the lights' current states.
pub fn patch_radiosity(scene: &Scene, bake: &Bake, states: &[LightState]) -> Vec<[f64; 3]> {
    let n = scene.coarse.patches.len();
    let mut h = vec![[0.0; 3]; n];
    for (i, (light, state)) in bake.lights.iter().zip(states).enumerate() {
        if !light.has_indirect() {
            continue;
        }
        let basis = ShBasis::new(light.plan.order);
        let (coeffs, _) = light_coefficients(state, light.plan.order, None, &basis);
        let k = light.n_columns;
        let color = scene.lights[i].color;
        for p in 0..n {
            let direct: f64 = light.direct[p * k..(p + 1) * k]
                .iter()
                .zip(&coeffs)
                .map(|(&e, &c)| f64::from(e) * c)
                .sum();
            for ch in 0..3 {
                let channel = &light.indirect[ch.min(light.indirect.len() - 1)];
                let indirect: f64 = channel[p * k..(p + 1) * k]
                    .iter()
                    .zip(&coeffs)
                    .map(|(&e, &c)| f64::from(e) * c)
                    .sum();
                h[p][ch] += color[ch] * (direct + indirect);
            }
        }
    }
    let rho: Vec<Vec<f64>> = (0..3)
        .map(|ch| patch_reflectance(scene, &scene.coarse, ch))
        .collect();
    h.iter()
        .enumerate()
        .map(|(p, hp)| [rho[0][p] * hp[0], rho[1][p] * hp[1], rho[2][p] * hp[2]])
        .collect()
}

/// Indirect illuminance (lx, linear RGB) at each receiver, gathered from patch radiosity.
pub fn gather_indirect(scene: &Scene, radiosity: &[[f64; 3]], receivers: &[Receiver]) -> Vec<[f64; 3]> {
    let targets: Vec<TargetPatch> = scene
        .coarse
        .patches
        .iter()
        .map(|p| TargetPatch::new(&scene.coarse, p))
        .collect();
    let samples: Vec<Vec<DVec3>> = targets
        .iter()
        .map(|t| t.sample_points(GATHER_SAMPLES_PER_EDGE))
        .collect();
    let occluders = Occluders::of_scene(scene);
    receivers
        .par_iter()
        .map(|rx| {
            let p = rx.point + rx.normal * RECEIVER_LIFT_M;
            let mut e = [0.0; 3];
            for ((target, b), points) in targets.iter().zip(radiosity).zip(&samples) {
                if b.iter().all(|&x| x == 0.0) {
                    continue;
                }
                let mut f = target.form_factor_from(p, rx.normal, NEAR_FIELD_RATIO);
                if f == 0.0 {
                    continue;
                }
                if let Some(occ) = &occluders {
                    let seen = points.iter().filter(|&&q| occ.visible(p, q)).count();
                    f *= seen as f64 / points.len() as f64;
                }
                for ch in 0..3 {
                    e[ch] += b[ch] * f;
                }
            }
            e
        })
        .collect()
}

/// A light's truncated series in paper mode: its basis, coefficients and mask normal.
type SeriesEmitter = (ShBasis, Vec<f64>, Option<DVec3>);

/// Total illuminance (lx) at receivers: direct (exact, or from the SH series in `DirectMode::Basis`)
/// plus gathered indirect light when a bake is given. Coloured light counts with its photopic
/// weight ([`luminance_weight`]).
pub fn illuminance_at_receivers(
    scene: &Scene,
    bake: Option<&Bake>,
    mode: DirectMode,
    receivers: &[Receiver],
) -> Vec<f64> {
    let states: Vec<LightState> = scene.lights.iter().map(LightState::from).collect();
    let occluders = Occluders::of_scene(scene);
    let vis = occluders.as_ref().map(|o| o as &dyn Visibility);
    let series: Vec<Option<SeriesEmitter>> = scene
        .lights
        .iter()
        .enumerate()
        .map(|(i, _)| {
            let light = bake.filter(|_| mode == DirectMode::Basis).map(|b| &b.lights[i])?;
            let basis = ShBasis::new(light.plan.order);
            let (coeffs, _) = light_coefficients(&states[i], light.plan.order, None, &basis);
            Some((basis, coeffs, light.plan.mask.map(DVec3::from)))
        })
        .collect();
    let direct: Vec<f64> = receivers
        .par_iter()
        .map(|rx| {
            scene
                .lights
                .iter()
                .zip(&series)
                .map(|(l, s)| {
                    let e = match s {
                        None => illuminance_at(l.position, l.radius, &l.curve, l.aim, l.dimmer, rx, vis),
                        Some((basis, coeffs, mask)) => {
                            let unit = crate::photometry::Curve::isotropic(1.0);
                            let g = illuminance_at(l.position, l.radius, &unit, l.aim, 1.0, rx, vis);
                            let dir = (rx.point - l.position).normalize_or_zero();
                            if g == 0.0 || mask.is_some_and(|n| dir.dot(n) <= 0.0) {
                                0.0
                            } else {
                                g * basis.dot(coeffs, dir)
                            }
                        }
                    };
                    luminance_weight(l.color) * e
                })
                .sum()
        })
        .collect();
    match bake {
        Some(b) if b.lights.iter().any(|l| l.has_indirect()) => {
            let radiosity = patch_radiosity(scene, b, &states);
            let indirect = gather_indirect(scene, &radiosity, receivers);
            direct
                .iter()
                .zip(indirect)
                .map(|(d, e)| d + luminance_weight(e))
                .collect()
        }
        _ => direct,
    }
}
