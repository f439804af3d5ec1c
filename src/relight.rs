//! The relight API the editor calls: change one light's curve, aim or dimmer and get the new
//! fine-vertex illuminance, recomputing only that light (DESIGN §3, §9).
//!
//! Per light the relighter keeps its contribution to every fine vertex (lx, linear RGB, colour
//! applied): the exact direct light from the [`DirectCache`] (or, in paper mode, the truncated SH
//! series through the same cache) plus, when a bake is given, the indirect light blended from the
//! baked basis on the coarse patches, `Σ_k c_k (H_k − E_k)`, interpolated to the fine vertices
//! within each surface. An edit replaces one light's contribution and updates the total by the
//! difference; the total is re-summed from scratch every [`RESUM_EVERY`] edits so rounding cannot
//! accumulate over a long session.

use glam::DVec3;
use rayon::prelude::*;

use crate::photometry::{Curve, ShBasis, Window, ZonalWeights, aimed_coefficients, auto_window, sh_count};
use crate::scene::{DirectMode, Light, Scene};
use crate::transport::bake::{Bake, BakedLight};
use crate::transport::direct::{DirectCache, Receiver};
use crate::transport::interpolate::InterpolationWeights;
use crate::transport::occlusion::Occluders;
use crate::transport::visibility::Visibility;

/// Edits between two full re-sums of the total.
pub const RESUM_EVERY: usize = 1024;

/// Fine vertices per rayon task when updating a light's contribution.
const MIN_VERTICES_PER_TASK: usize = 4096;

/// The editable state of one light: what an edit may change without a new bake.
#[derive(Debug, Clone, PartialEq)]
pub struct LightState {
    /// Intensity curve (cd).
    pub curve: Curve,
    /// Unit aim axis (world).
    pub aim: DVec3,
    /// Dimmer factor, ≥ 0.
    pub dimmer: f64,
    /// Linear RGB colour multipliers.
    pub color: [f64; 3],
}

impl From<&Light> for LightState {
    fn from(light: &Light) -> Self {
        LightState {
            curve: light.curve.clone(),
            aim: light.aim,
            dimmer: light.dimmer,
            color: light.color,
        }
    }
}

/// The receivers of a scene's fine mesh: every vertex with its surface normal.
pub fn fine_receivers(scene: &Scene) -> Vec<Receiver> {
    scene
        .fine
        .positions
        .iter()
        .zip(&scene.fine.normals)
        .map(|(&point, &normal)| Receiver { point, normal })
        .collect()
}

/// The SH coefficients `c_k = dimmer · σ_l w_l 4π/(2l+1) Y_lm(aim)` of a light for a baked order,
/// with the window chosen automatically (`window = None`) or forced.
pub fn light_coefficients(
    state: &LightState,
    order: usize,
    window: Option<Window>,
    basis: &ShBasis,
) -> (Vec<f64>, Window) {
    let weights = ZonalWeights::exact(&state.curve, order);
    let window = window.unwrap_or_else(|| auto_window(&state.curve, &weights, order));
    let mut coeffs = vec![0.0; sh_count(order)];
    aimed_coefficients(&weights.windowed(window), state.aim, basis, &mut coeffs);
    coeffs.iter_mut().for_each(|c| *c *= state.dimmer);
    (coeffs, window)
}

/// The baked indirect light and what blending it needs.
#[derive(Debug, Clone)]
struct Indirect {
    interp: InterpolationWeights,
    lights: Vec<BakedLight>,
    bases: Vec<ShBasis>,
    n_patches: usize,
}

impl Indirect {
    /// Light `i`'s indirect irradiance (lx) for coefficients `c`: vertex-major, one value per
    /// baked channel (1 or 3) per fine vertex. `coarse` is scratch space for the coarse values.
    fn blend(&self, i: usize, coeffs: &[f64], coarse: &mut Vec<f64>) -> Vec<f64> {
        let light = &self.lights[i];
        let rows = light.n_columns.max(1);
        let channels = light.indirect.len();
        coarse.clear();
        coarse.resize(self.n_patches * channels, 0.0);
        for (ch, channel) in light.indirect.iter().enumerate() {
            // Σ_k c_k column_k on every coarse patch (columns stored patch-major, f32).
            for (p, row) in channel.chunks_exact(rows).enumerate() {
                coarse[p * channels + ch] = row.iter().zip(coeffs).map(|(&e, &c)| f64::from(e) * c).sum();
            }
        }
        self.interp.apply_columns(coarse, channels)
    }
}

/// Illuminance of every light at the fine vertices, kept per light.
#[derive(Debug, Clone)]
pub struct Relighter {
    lights: Vec<LightState>,
    windows: Vec<Option<Window>>,
    caches: Vec<DirectCache>,
    paper_mode: bool,
    indirect: Option<Indirect>,
    /// Per light, direct illuminance (lx) at each fine vertex, dimmer applied, colour not.
    direct: Vec<Vec<f64>>,
    /// Per light, its contribution to every fine vertex (lx, linear RGB, colour applied).
    contributions: Vec<Vec<[f64; 3]>>,
    /// Σ of the contributions.
    total: Vec<[f64; 3]>,
    edits_since_resum: usize,
    /// Scratch for the blended coarse indirect values (reused across edits).
    coarse_scratch: Vec<f64>,
}

impl Relighter {
    /// Direct light only (no bake): caches the geometry of every light against the fine
    /// vertices (visibility rays only when the scene has occluders).
    pub fn new(scene: &Scene) -> Self {
        Self::build(scene, None)
    }

    /// Direct light plus the baked indirect light (and, in paper mode, direct light from the SH
    /// series of the baked order).
    pub fn with_bake(scene: &Scene, bake: &Bake) -> Self {
        Self::build(scene, Some(bake))
    }

    fn build(scene: &Scene, bake: Option<&Bake>) -> Self {
        let occluders = Occluders::of_scene(scene);
        let receivers = fine_receivers(scene);
        let caches: Vec<DirectCache> = scene
            .lights
            .iter()
            .map(|l| {
                DirectCache::build(
                    l.position,
                    l.radius,
                    &receivers,
                    occluders.as_ref().map(|o| o as &dyn Visibility),
                )
            })
            .collect();
        let indirect = bake.map(|b| Indirect {
            interp: InterpolationWeights::new(&scene.coarse, &scene.fine),
            bases: b.lights.iter().map(|l| ShBasis::new(l.plan.order)).collect(),
            lights: b.lights.clone(),
            n_patches: scene.coarse.patches.len(),
        });
        let n = receivers.len();
        let n_lights = scene.lights.len();
        let mut relighter = Relighter {
            lights: scene.lights.iter().map(LightState::from).collect(),
            windows: vec![None; n_lights],
            caches,
            paper_mode: bake.is_some() && scene.settings.direct == DirectMode::Basis,
            indirect,
            direct: vec![vec![0.0; n]; n_lights],
            contributions: vec![vec![[0.0; 3]; n]; n_lights],
            total: vec![[0.0; 3]; n],
            edits_since_resum: 0,
            coarse_scratch: Vec::new(),
        };
        for i in 0..n_lights {
            relighter.recompute_light(i, false);
        }
        relighter.resum();
        relighter
    }

    /// The current state of light `i`.
    pub fn light(&self, i: usize) -> &LightState {
        &self.lights[i]
    }

    /// Number of lights.
    pub fn n_lights(&self) -> usize {
        self.lights.len()
    }

    /// True when indirect light from a bake is included.
    pub fn has_indirect(&self) -> bool {
        self.indirect
            .as_ref()
            .is_some_and(|ind| ind.lights.iter().any(BakedLight::has_indirect))
    }

    /// Total illuminance per fine vertex (lx, linear RGB).
    pub fn total(&self) -> &[[f64; 3]] {
        &self.total
    }

    /// Light `i`'s direct illuminance per fine vertex (lx, dimmer applied, before colour).
    pub fn light_direct(&self, i: usize) -> &[f64] {
        &self.direct[i]
    }

    /// Light `i`'s contribution per fine vertex (lx, linear RGB, colour applied).
    pub fn light_contribution(&self, i: usize) -> &[[f64; 3]] {
        &self.contributions[i]
    }

    /// Replaces light `i`'s curve and updates the illuminance (only that light is recomputed).
    pub fn set_curve(&mut self, i: usize, curve: Curve) {
        self.lights[i].curve = curve;
        self.update(i);
    }

    /// Re-aims light `i` along `aim` (world; normalised here).
    pub fn set_aim(&mut self, i: usize, aim: DVec3) {
        self.lights[i].aim = aim.normalize();
        self.update(i);
    }

    /// Sets light `i`'s dimmer (≥ 0).
    pub fn set_dimmer(&mut self, i: usize, dimmer: f64) {
        self.lights[i].dimmer = dimmer;
        self.update(i);
    }

    /// Forces light `i`'s window (`None`: chosen automatically per edit, NUMERICS §3.4).
    pub fn set_window(&mut self, i: usize, window: Option<Window>) {
        self.windows[i] = window;
        self.update(i);
    }

    /// Replaces light `i`'s whole state at once (one recomputation).
    pub fn set_state(&mut self, i: usize, state: LightState) {
        self.lights[i] = LightState {
            aim: state.aim.normalize(),
            ..state
        };
        self.update(i);
    }

    /// Recomputes light `i`'s direct light and contribution; with `update_total`, also moves the
    /// total by the difference between the new and the old contribution (in the same pass).
    fn recompute_light(&mut self, i: usize, update_total: bool) {
        let state = &self.lights[i];
        let baked = self
            .indirect
            .as_ref()
            .map(|ind| (ind, &ind.lights[i], &ind.bases[i]));
        let coeffs = baked
            .map(|(_, light, basis)| light_coefficients(state, light.plan.order, self.windows[i], basis).0);
        match (self.paper_mode, baked, &coeffs) {
            (true, Some((_, light, basis)), Some(c)) => {
                // Paper mode: direct light from the series Σ c_lm Y_lm(dir), masked like the basis.
                let mask = light.plan.mask.map(DVec3::from);
                self.caches[i].illuminance_with(
                    |dir| {
                        if mask.is_some_and(|n| dir.dot(n) <= 0.0) {
                            0.0
                        } else {
                            basis.dot(c, dir)
                        }
                    },
                    1.0,
                    &mut self.direct[i],
                );
            }
            _ => self.caches[i].illuminance_into(&state.curve, state.aim, state.dimmer, &mut self.direct[i]),
        }
        let indirect = match (baked, &coeffs) {
            (Some((ind, light, _)), Some(c)) if light.has_indirect() => {
                Some((ind.blend(i, c, &mut self.coarse_scratch), light.indirect.len()))
            }
            _ => None,
        };
        let color = state.color;
        let direct = &self.direct[i];
        self.contributions[i]
            .par_iter_mut()
            .zip(self.total.par_iter_mut())
            .enumerate()
            .with_min_len(MIN_VERTICES_PER_TASK)
            .for_each(|(v, (out, total))| {
                for ch in 0..3 {
                    let ind = indirect.as_ref().map_or(0.0, |(values, channels)| {
                        values[v * channels + ch.min(channels - 1)]
                    });
                    let new = color[ch] * (direct[v] + ind);
                    if update_total {
                        total[ch] += new - out[ch];
                    }
                    out[ch] = new;
                }
            });
    }

    fn update(&mut self, i: usize) {
        self.edits_since_resum += 1;
        let resum = self.edits_since_resum >= RESUM_EVERY;
        self.recompute_light(i, !resum);
        if resum {
            self.resum();
        }
    }

    /// Re-sums the total from the per-light contributions.
    fn resum(&mut self) {
        self.total.iter_mut().for_each(|t| *t = [0.0; 3]);
        for contribution in &self.contributions {
            for (t, c) in self.total.iter_mut().zip(contribution) {
                for ch in 0..3 {
                    t[ch] += c[ch];
                }
            }
        }
        self.edits_since_resum = 0;
    }
}
