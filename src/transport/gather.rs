//! Illuminance at arbitrary receivers (probe points, work-plane grids): exact direct light plus
//! the indirect light gathered from the coarse patches' radiosity, `E_ind(p) = Σ_j B_j F_{p→j} V`
//! (docs/METHOD.md §5), with `B_j = ρ_j H_j` blended from the baked basis for the lights' current
//! curves and aims. Gathering (rather than interpolating vertex values) stays accurate beside
//! furniture, where interpolation across an occluder's shadow fails (docs/METHOD.md §5.8).
//!
//! The gather is split so that fixed receivers can be re-evaluated per edit without casting rays:
//! [`GatherOperator`] holds `F_{p→j} V` for every receiver and patch (built once), and
//! [`light_patch_irradiance`] one light's `H_j` for its current coefficients.

use glam::DVec3;
use rayon::prelude::*;

use crate::photometry::{LightState, ShBasis, light_coefficients};
use crate::scene::{DirectMode, Scene};
use crate::transport::bake::{Bake, BakedLight, patch_reflectance};
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

/// One light's irradiance `H = E + (H − E)` on every coarse patch (lx, linear RGB, `color`
/// applied) for its SH coefficients `coeffs` (cd, dimmer included), from its baked columns.
/// All zero when the light has no indirect basis. `out` is resized to the patch count.
pub fn light_patch_irradiance(light: &BakedLight, coeffs: &[f64], color: [f64; 3], out: &mut Vec<[f64; 3]>) {
    let k = light.n_columns;
    let n = light.direct.len().checked_div(k).unwrap_or(0);
    out.clear();
    out.resize(n, [0.0; 3]);
    if !light.has_indirect() {
        return;
    }
    let dot = |column: &[f32]| -> f64 { column.iter().zip(coeffs).map(|(&e, &c)| f64::from(e) * c).sum() };
    for (p, h) in out.iter_mut().enumerate() {
        let direct = dot(&light.direct[p * k..(p + 1) * k]);
        for (ch, hc) in h.iter_mut().enumerate() {
            let channel = &light.indirect[ch.min(light.indirect.len() - 1)];
            *hc = color[ch] * (direct + dot(&channel[p * k..(p + 1) * k]));
        }
    }
}

/// Radiosity `B = ρ H` (lm/m², linear RGB) of every coarse patch for the lights' current states.
pub fn patch_radiosity(scene: &Scene, bake: &Bake, states: &[LightState]) -> Vec<[f64; 3]> {
    let n = scene.coarse.patches.len();
    let mut h = vec![[0.0; 3]; n];
    let mut light_h = Vec::new();
    for (i, (light, state)) in bake.lights.iter().zip(states).enumerate() {
        if !light.has_indirect() {
            continue;
        }
        let basis = ShBasis::new(light.plan.order);
        let (coeffs, _) = light_coefficients(state, light.plan.order, None, &basis);
        light_patch_irradiance(light, &coeffs, scene.lights[i].color, &mut light_h);
        for (sum, add) in h.iter_mut().zip(&light_h) {
            (0..3).for_each(|ch| sum[ch] += add[ch]);
        }
    }
    radiosity_of(scene, &h)
}

/// `B = ρ H` per coarse patch and channel, from the summed irradiance `h` (lx, linear RGB).
pub fn radiosity_of(scene: &Scene, h: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let rho: Vec<Vec<f64>> = (0..3)
        .map(|ch| patch_reflectance(scene, &scene.coarse, ch))
        .collect();
    h.iter()
        .enumerate()
        .map(|(p, hp)| [rho[0][p] * hp[0], rho[1][p] * hp[1], rho[2][p] * hp[2]])
        .collect()
}

/// The gather from coarse patches to fixed receivers: `F_{p→j} V` for every receiver `p` and
/// every patch `j` it sees (sparse rows), so that the indirect illuminance for any radiosity is
/// one pass over the stored factors, without rays.
#[derive(Debug, Clone)]
pub struct GatherOperator {
    /// Row `r` is `entries[offsets[r]..offsets[r + 1]]`.
    offsets: Vec<usize>,
    /// Patch index of each entry.
    patches: Vec<u32>,
    /// `F · V` of each entry (form factor times the fraction of visibility samples seen).
    factors: Vec<f64>,
}

impl GatherOperator {
    /// Builds the factors from `scene`'s coarse patches to `receivers`, testing visibility
    /// against `occluders` when given (four rays per receiver and patch).
    pub fn build(scene: &Scene, occluders: Option<&Occluders>, receivers: &[Receiver]) -> Self {
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
        let rows: Vec<Vec<(u32, f64)>> = receivers
            .par_iter()
            .map(|rx| {
                let p = rx.point + rx.normal * RECEIVER_LIFT_M;
                let mut row = Vec::new();
                for (j, (target, points)) in targets.iter().zip(&samples).enumerate() {
                    let mut f = target.form_factor_from(p, rx.normal, NEAR_FIELD_RATIO);
                    if f == 0.0 {
                        continue;
                    }
                    if let Some(occ) = occluders {
                        let seen = points.iter().filter(|&&q| occ.visible(p, q)).count();
                        f *= seen as f64 / points.len() as f64;
                    }
                    if f != 0.0 {
                        row.push((j as u32, f));
                    }
                }
                row
            })
            .collect();
        let mut offsets = Vec::with_capacity(rows.len() + 1);
        offsets.push(0);
        let total: usize = rows.iter().map(Vec::len).sum();
        let (mut patches, mut factors) = (Vec::with_capacity(total), Vec::with_capacity(total));
        for row in rows {
            for (j, f) in row {
                patches.push(j);
                factors.push(f);
            }
            offsets.push(patches.len());
        }
        GatherOperator {
            offsets,
            patches,
            factors,
        }
    }

    /// Number of receivers.
    pub fn n_receivers(&self) -> usize {
        self.offsets.len() - 1
    }

    /// Indirect illuminance (lx, linear RGB) at each receiver for patch radiosity `radiosity`
    /// (lm/m², linear RGB, one per coarse patch), into `out` (one per receiver).
    pub fn apply_into(&self, radiosity: &[[f64; 3]], out: &mut [[f64; 3]]) {
        assert_eq!(
            out.len(),
            self.n_receivers(),
            "output length must match the receivers"
        );
        out.par_iter_mut().enumerate().for_each(|(r, e)| {
            *e = [0.0; 3];
            let span = self.offsets[r]..self.offsets[r + 1];
            for (&j, &f) in self.patches[span.clone()].iter().zip(&self.factors[span]) {
                let b = radiosity[j as usize];
                (0..3).for_each(|ch| e[ch] += b[ch] * f);
            }
        });
    }

    /// As [`Self::apply_into`], into a new vector.
    pub fn apply(&self, radiosity: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let mut out = vec![[0.0; 3]; self.n_receivers()];
        self.apply_into(radiosity, &mut out);
        out
    }
}

/// Indirect illuminance (lx, linear RGB) at each receiver, gathered from patch radiosity.
pub fn gather_indirect(scene: &Scene, radiosity: &[[f64; 3]], receivers: &[Receiver]) -> Vec<[f64; 3]> {
    let occluders = Occluders::of_scene(scene);
    GatherOperator::build(scene, occluders.as_ref(), receivers).apply(radiosity)
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
