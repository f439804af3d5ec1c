//! The relight API the editor calls: change one light's curve, aim or dimmer and get the new
//! fine-vertex illuminance, recomputing only that light (docs/METHOD.md §5; docs/BENCHMARKS.md).
//!
//! Per light the relighter keeps what its contribution to every fine vertex (lx, linear RGB) is
//! made of: the exact direct light from the [`DirectCache`] (or, in paper mode, the truncated SH
//! series through the same cache), the indirect light — given by the hierarchical engine, or
//! blended from the baked basis on the coarse patches, `Σ_k c_k (H_k − E_k)`, and interpolated
//! to the fine vertices within each surface — and the colour they were computed with. The
//! contribution itself, `colour · (direct + indirect)`, is formed where it is used, not kept
//! (docs/DECISIONS.md "The relighter keeps no contributions"). An edit replaces one light's parts
//! and updates the total by the difference between its new and its old contribution; the total is
//! re-summed from scratch every [`RESUM_EVERY`] edits so rounding cannot accumulate over a long
//! session.
//!
//! Lights can move ([`Relighter::move_light`] rebuilds that light's direct cache; its indirect
//! light stays the old bake's until [`Relighter::install_baked`] brings the new one), and be
//! added or removed, without touching the other lights.

use std::sync::Arc;

use glam::DVec3;
use rayon::prelude::*;

pub use crate::photometry::emission::{LightState, light_coefficients};
use crate::photometry::{Curve, ShBasis, Window, ZonalWeights, coefficients_from_weights, sh_count};
use crate::scene::{DirectMode, Light, Scene};
use crate::transport::bake::{Bake, BakedLight};
use crate::transport::direct::{DirectCache, Receiver, fine_receivers};
use crate::transport::interpolate::InterpolationWeights;
use crate::transport::occlusion::Occluders;
use crate::transport::visibility::Visibility;

/// Edits between two full re-sums of the total.
pub const RESUM_EVERY: usize = 1024;

/// Fine vertices per rayon task when updating a light's contribution.
const MIN_VERTICES_PER_TASK: usize = 16384;

/// A light's baked basis and its SH basis functions.
#[derive(Debug, Clone)]
struct LightBasis {
    baked: BakedLight,
    sh: ShBasis,
}

impl LightBasis {
    fn new(baked: BakedLight) -> Self {
        LightBasis {
            sh: ShBasis::new(baked.plan.order),
            baked,
        }
    }
}

/// A light's indirect irradiance at the fine vertices (lx, colour not applied), as its
/// contribution holds it.
#[derive(Debug, Clone)]
enum VertexIndirect {
    /// No indirect light (no bake, or a bake without interreflection).
    None,
    /// Given by the hierarchical engine ([`Relighter::give_indirect`]), per channel. In f32,
    /// like the engine's leaf values it is interpolated from (good to the solver's tolerance,
    /// ≥ 10⁻⁶): 12 bytes a vertex instead of 24 (docs/DECISIONS.md "The relighter's indirect
    /// light in f32").
    Given(Vec<[f32; 3]>),
    /// Blended from the baked basis: vertex-major, `channels` (1 or 3) values per vertex.
    Blended { values: Vec<f64>, channels: usize },
}

impl VertexIndirect {
    /// The values (lx, per channel) of vertices `start..start + out.len()` into `out`.
    fn values_into(&self, start: usize, out: &mut [[f64; 3]]) {
        match self {
            VertexIndirect::None => out.fill([0.0; 3]),
            VertexIndirect::Given(values) => {
                for (o, g) in out.iter_mut().zip(&values[start..]) {
                    *o = g.map(f64::from);
                }
            }
            &VertexIndirect::Blended { ref values, channels } => {
                for (o, v) in out
                    .iter_mut()
                    .zip(values[start * channels..].chunks_exact(channels))
                {
                    *o = std::array::from_fn(|ch| v[ch.min(channels - 1)]);
                }
            }
        }
    }
}

/// Vertices a contribution pass forms at a time, on the stack.
const CHUNK: usize = 256;

/// Contributions `colour · (direct + indirect)` (lx, linear RGB) of vertices
/// `start..start + out.len()` into `out`, from the light's parts (`direct` and `indirect` over all
/// vertices).
fn contributions_into(
    color: [f64; 3],
    direct: &[f64],
    indirect: &VertexIndirect,
    start: usize,
    out: &mut [[f64; 3]],
) {
    indirect.values_into(start, out);
    for (o, &d) in out.iter_mut().zip(&direct[start..]) {
        for ch in 0..3 {
            o[ch] = color[ch] * (d + o[ch]);
        }
    }
}

/// One light as the relighter keeps it.
#[derive(Debug, Clone)]
struct LitLight {
    state: LightState,
    /// Legendre weights of `state.curve` (cd) used for the SH coefficients; any order (degrees
    /// above the baked order are ignored, missing ones are 0).
    weights: ZonalWeights,
    window: Option<Window>,
    position: DVec3,
    radius_m: f64,
    cache: DirectCache,
    /// The baked basis (None without a bake).
    basis: Option<LightBasis>,
    /// The hierarchical engine's indirect light given since the last recomputation
    /// ([`Relighter::give_indirect`]): it becomes `indirect` at the next one.
    given: Option<Vec<[f32; 3]>>,
    /// Direct illuminance (lx) at each fine vertex, dimmer applied, colour not.
    direct: Vec<f64>,
    /// Indirect irradiance at each fine vertex; once given by the engine, the basis is no longer
    /// blended for it.
    indirect: VertexIndirect,
    /// The colour (linear RGB multipliers) `direct` and `indirect` were combined with.
    color: [f64; 3],
}

impl LitLight {
    /// Its contributions to vertices `start..start + out.len()` (lx, linear RGB, colour applied).
    fn contributions_into(&self, start: usize, out: &mut [[f64; 3]]) {
        contributions_into(self.color, &self.direct, &self.indirect, start, out);
    }
}

/// Illuminance of every light at the fine vertices, kept per light.
#[derive(Debug, Clone)]
pub struct Relighter {
    lights: Vec<LitLight>,
    receivers: Arc<Vec<Receiver>>,
    occluders: Option<Arc<Occluders>>,
    /// Coarse → fine interpolation of indirect light (None without a bake).
    interp: Option<Arc<InterpolationWeights>>,
    n_patches: usize,
    paper_mode: bool,
    /// Σ of the contributions.
    total: Vec<[f64; 3]>,
    edits_since_resum: usize,
    /// Scratch for the blended coarse indirect values, coefficients and a light's new direct
    /// light (reused across edits).
    coarse_scratch: Vec<f64>,
    coeff_scratch: Vec<f64>,
    direct_scratch: Vec<f64>,
}

impl Relighter {
    /// Direct light only (no bake): caches the geometry of every light against the fine
    /// vertices (visibility rays only when the scene has occluders).
    pub fn new(scene: &Scene) -> Self {
        Self::build(scene, None, Occluders::of_scene(scene).map(Arc::new))
    }

    /// Direct light plus the baked indirect light (and, in paper mode, direct light from the SH
    /// series of the baked order).
    pub fn with_bake(scene: &Scene, bake: &Bake) -> Self {
        Self::build(scene, Some(bake), bake.transport.occluders().cloned())
    }

    fn build(scene: &Scene, bake: Option<&Bake>, occluders: Option<Arc<Occluders>>) -> Self {
        let receivers = Arc::new(fine_receivers(scene));
        let n = receivers.len();
        let mut relighter = Relighter {
            lights: Vec::with_capacity(scene.lights.len()),
            receivers,
            occluders,
            interp: bake.map(|_| Arc::new(InterpolationWeights::new(&scene.coarse, &scene.fine))),
            n_patches: scene.coarse.patches.len(),
            paper_mode: bake.is_some() && scene.settings.direct == DirectMode::Basis,
            total: vec![[0.0; 3]; n],
            edits_since_resum: 0,
            coarse_scratch: Vec::new(),
            coeff_scratch: Vec::new(),
            direct_scratch: Vec::new(),
        };
        for (i, light) in scene.lights.iter().enumerate() {
            let baked = bake.map(|b| b.lights[i].clone());
            let lit = relighter.lit_light(light, baked);
            relighter.lights.push(lit);
            relighter.recompute_light(i, false);
        }
        relighter.resum();
        relighter
    }

    /// A light's record with its direct cache built (contribution not yet computed).
    fn lit_light(&self, light: &Light, baked: Option<BakedLight>) -> LitLight {
        let basis = baked.map(LightBasis::new);
        let order = basis.as_ref().map_or(0, |b| b.baked.plan.order);
        LitLight {
            weights: ZonalWeights::exact(&light.curve, order),
            state: LightState::from(light),
            window: None,
            position: light.position,
            radius_m: light.radius,
            cache: self.direct_cache(light.position, light.radius),
            basis,
            given: None,
            direct: vec![0.0; self.receivers.len()],
            indirect: VertexIndirect::None,
            color: light.color,
        }
    }

    fn direct_cache(&self, position: DVec3, radius_m: f64) -> DirectCache {
        DirectCache::build(
            position,
            radius_m,
            &self.receivers,
            self.occluders.as_deref().map(|o| o as &dyn Visibility),
        )
    }

    /// The current state of light `i`.
    pub fn light(&self, i: usize) -> &LightState {
        &self.lights[i].state
    }

    /// Number of lights.
    pub fn n_lights(&self) -> usize {
        self.lights.len()
    }

    /// True when indirect light from a bake (or given by the hierarchical engine) is included.
    pub fn has_indirect(&self) -> bool {
        self.lights.iter().any(|l| {
            l.given.is_some()
                || matches!(l.indirect, VertexIndirect::Given(_))
                || l.basis.as_ref().is_some_and(|b| b.baked.has_indirect())
        })
    }

    /// Gives light `i`'s indirect irradiance per fine vertex (lx, per channel, colour not
    /// applied; from the hierarchical engine, [`crate::transport::indirect`]): it replaces the
    /// baked basis's indirect light from the light's next recomputation on (the caller follows
    /// with [`Self::set_light`] or another setter).
    pub fn give_indirect(&mut self, i: usize, indirect: &[[f64; 3]]) {
        assert_eq!(indirect.len(), self.receivers.len(), "one value per fine vertex");
        self.lights[i].given = Some(indirect.iter().map(|v| v.map(|x| x as f32)).collect());
    }

    /// Total illuminance per fine vertex (lx, linear RGB).
    pub fn total(&self) -> &[[f64; 3]] {
        &self.total
    }

    /// Light `i`'s direct illuminance per fine vertex (lx, dimmer applied, before colour).
    pub fn light_direct(&self, i: usize) -> &[f64] {
        &self.lights[i].direct
    }

    /// Light `i`'s contribution per fine vertex (lx, linear RGB, colour applied), formed from
    /// its parts.
    pub fn light_contribution(&self, i: usize) -> Vec<[f64; 3]> {
        let mut out = vec![[0.0; 3]; self.receivers.len()];
        self.lights[i].contributions_into(0, &mut out);
        out
    }

    /// Light `i`'s baked basis, if any.
    pub fn baked(&self, i: usize) -> Option<&BakedLight> {
        self.lights[i].basis.as_ref().map(|b| &b.baked)
    }

    /// Indirect illuminance per fine vertex summed over the lights (lx, linear RGB, colour
    /// applied) into `out` (resized): each light's contribution less its direct light. The
    /// per-pixel preview adds it to the exact direct light of every pixel. O(lights × vertices).
    pub fn indirect_into(&self, out: &mut Vec<[f32; 3]>) {
        out.clear();
        out.resize(self.total.len(), [0.0; 3]);
        let mut c = [[0.0; 3]; CHUNK];
        for light in &self.lights {
            for (k, out) in out.chunks_mut(CHUNK).enumerate() {
                let (start, c) = (k * CHUNK, &mut c[..out.len()]);
                light.contributions_into(start, c);
                for ((o, c), &d) in out.iter_mut().zip(&*c).zip(&light.direct[start..]) {
                    for ch in 0..3 {
                        o[ch] += (c[ch] - light.color[ch] * d) as f32;
                    }
                }
            }
        }
    }

    /// Replaces light `i`'s curve and updates the illuminance (only that light is recomputed).
    pub fn set_curve(&mut self, i: usize, curve: Curve) {
        let order = self.baked_order(i);
        self.lights[i].weights = ZonalWeights::exact(&curve, order);
        self.lights[i].state.curve = curve;
        self.update(i);
    }

    /// Replaces light `i`'s curve together with its Legendre weights, computed by the caller
    /// (e.g. kept current by [`crate::photometry::IncrementalWeights`], O(N) per point edit):
    /// the SH coefficients use `weights` as given, up to the baked order.
    pub fn set_curve_with_weights(&mut self, i: usize, curve: &Curve, weights: &ZonalWeights) {
        let light = &mut self.lights[i];
        light.state.curve.clone_from(curve);
        light.weights.w.clone_from(&weights.w);
        self.update(i);
    }

    /// Sets light `i`'s curve (with its Legendre weights, as for
    /// [`Self::set_curve_with_weights`]), aim (world; normalised here), dimmer and window at once:
    /// one recomputation for any number of changes.
    pub fn set_light(
        &mut self,
        i: usize,
        curve: &Curve,
        weights: &ZonalWeights,
        aim: DVec3,
        dimmer: f64,
        window: Option<Window>,
    ) {
        let light = &mut self.lights[i];
        light.state.curve.clone_from(curve);
        light.weights.w.clone_from(&weights.w);
        light.state.aim = aim.normalize();
        light.state.dimmer = dimmer;
        light.window = window;
        self.update(i);
    }

    /// Re-aims light `i` along `aim` (world; normalised here).
    pub fn set_aim(&mut self, i: usize, aim: DVec3) {
        self.lights[i].state.aim = aim.normalize();
        self.update(i);
    }

    /// Sets light `i`'s dimmer (≥ 0).
    pub fn set_dimmer(&mut self, i: usize, dimmer: f64) {
        self.lights[i].state.dimmer = dimmer;
        self.update(i);
    }

    /// Sets light `i`'s colour (linear RGB multipliers).
    pub fn set_color(&mut self, i: usize, color: [f64; 3]) {
        self.lights[i].state.color = color;
        self.update(i);
    }

    /// Forces light `i`'s window (`None`: chosen automatically per edit, docs/METHOD.md §4.4).
    pub fn set_window(&mut self, i: usize, window: Option<Window>) {
        self.lights[i].window = window;
        self.update(i);
    }

    /// Replaces light `i`'s whole state at once (one recomputation).
    pub fn set_state(&mut self, i: usize, state: LightState) {
        let order = self.baked_order(i);
        let light = &mut self.lights[i];
        light.weights = ZonalWeights::exact(&state.curve, order);
        light.state = LightState {
            aim: state.aim.normalize(),
            ..state
        };
        self.update(i);
    }

    /// Moves light `i` to `position` (world, m): its direct cache is rebuilt for the new position
    /// (shadow rays where the scene has occluders). Its indirect light stays that of the
    /// current bake until [`Self::install_baked`] gives the bake for the new position.
    pub fn move_light(&mut self, i: usize, position: DVec3) {
        let radius = self.lights[i].radius_m;
        self.lights[i].cache = self.direct_cache(position, radius);
        self.lights[i].position = position;
        self.update(i);
    }

    /// Installs light `i`'s new baked basis (after a move or an order change) and recomputes it.
    pub fn install_baked(&mut self, i: usize, baked: BakedLight) {
        let light = &mut self.lights[i];
        if light.weights.order() < baked.plan.order {
            light.weights = ZonalWeights::exact(&light.state.curve, baked.plan.order);
        }
        light.basis = Some(LightBasis::new(baked));
        self.update(i);
    }

    /// Adds `light` (with its baked basis when the relighter has a bake) at index `at`
    /// (≤ [`Self::n_lights`]); the lights after it shift up by one.
    pub fn insert_light(&mut self, at: usize, light: &Light, baked: Option<BakedLight>) {
        let baked = baked.filter(|_| self.interp.is_some());
        let lit = self.lit_light(light, baked);
        self.lights.insert(at, lit);
        self.recompute_light(at, true);
    }

    /// Removes light `i` and its contribution; the lights after it shift down by one.
    pub fn remove_light(&mut self, i: usize) {
        let removed = self.lights.remove(i);
        self.total
            .par_chunks_mut(CHUNK)
            .enumerate()
            .with_min_len(MIN_VERTICES_PER_TASK / CHUNK)
            .for_each(|(k, total)| {
                let mut c = [[0.0; 3]; CHUNK];
                removed.contributions_into(k * CHUNK, &mut c[..total.len()]);
                for (t, c) in total.iter_mut().zip(&c) {
                    (0..3).for_each(|ch| t[ch] -= c[ch]);
                }
            });
        if self.count_edit() {
            self.resum();
        }
    }

    fn baked_order(&self, i: usize) -> usize {
        self.lights[i].basis.as_ref().map_or(0, |b| b.baked.plan.order)
    }

    /// Light `i`'s indirect irradiance (lx) for coefficients `coeffs`: vertex-major, one value
    /// per baked channel (1 or 3) per fine vertex.
    fn blend_indirect(&mut self, i: usize, coeffs: &[f64]) -> Option<(Vec<f64>, usize)> {
        let interp = self.interp.as_ref()?;
        let baked = &self.lights[i].basis.as_ref()?.baked;
        if !baked.has_indirect() {
            return None;
        }
        let rows = baked.n_columns.max(1);
        let channels = baked.indirect.len();
        let coarse = &mut self.coarse_scratch;
        coarse.clear();
        coarse.resize(self.n_patches * channels, 0.0);
        for (ch, channel) in baked.indirect.iter().enumerate() {
            // Σ_k c_k column_k on every coarse patch (columns stored patch-major, f32).
            for (p, row) in channel.chunks_exact(rows).enumerate() {
                coarse[p * channels + ch] = row.iter().zip(coeffs).map(|(&e, &c)| f64::from(e) * c).sum();
            }
        }
        Some((interp.apply_columns(coarse, channels), channels))
    }

    /// Recomputes light `i`'s direct and indirect light for its state; with `update_total`, also
    /// moves the total by the difference between the new and the old contribution (in one pass,
    /// the old contribution formed from the parts it was made of, so the same bits as if kept).
    fn recompute_light(&mut self, i: usize, update_total: bool) {
        let mut coeffs = std::mem::take(&mut self.coeff_scratch);
        let has_basis = {
            let light = &self.lights[i];
            match &light.basis {
                Some(basis) => {
                    coeffs.clear();
                    coeffs.resize(sh_count(basis.sh.order()), 0.0);
                    coefficients_from_weights(
                        &light.state,
                        &light.weights,
                        light.window,
                        &basis.sh,
                        &mut coeffs,
                    );
                    true
                }
                None => false,
            }
        };
        let mut direct = std::mem::take(&mut self.direct_scratch);
        direct.resize(self.receivers.len(), 0.0);
        {
            let light = &self.lights[i];
            match (&light.basis, self.paper_mode) {
                (Some(basis), true) => {
                    // Paper mode: direct light from the series Σ c_lm Y_lm(dir), masked like the basis.
                    let mask = basis.baked.plan.mask.map(DVec3::from);
                    let (sh, c) = (&basis.sh, &coeffs);
                    light.cache.illuminance_with(
                        &self.receivers,
                        |dir| {
                            if mask.is_some_and(|n| dir.dot(n) <= 0.0) {
                                0.0
                            } else {
                                sh.dot(c, dir)
                            }
                        },
                        1.0,
                        &mut direct,
                    );
                }
                _ => light.cache.illuminance_into(
                    &self.receivers,
                    &light.state.curve,
                    light.state.aim,
                    light.state.dimmer,
                    &mut direct,
                ),
            }
        }
        // The new indirect light: the engine's when given (it stays until the next is given),
        // else the basis blended for the new coefficients. `None`: unchanged.
        let new_indirect = match self.lights[i].given.take() {
            Some(given) => Some(VertexIndirect::Given(given)),
            None if matches!(self.lights[i].indirect, VertexIndirect::Given(_)) => None,
            None => Some(
                has_basis
                    .then(|| self.blend_indirect(i, &coeffs))
                    .flatten()
                    .map_or(VertexIndirect::None, |(values, channels)| {
                        VertexIndirect::Blended { values, channels }
                    }),
            ),
        };
        self.coeff_scratch = coeffs;
        let light = &mut self.lights[i];
        let color = light.state.color;
        if update_total {
            let old = &*light;
            let new_indirect = new_indirect.as_ref().unwrap_or(&old.indirect);
            self.total
                .par_chunks_mut(CHUNK)
                .enumerate()
                .with_min_len(MIN_VERTICES_PER_TASK / CHUNK)
                .for_each(|(k, total)| {
                    let (mut before, mut after) = ([[0.0; 3]; CHUNK], [[0.0; 3]; CHUNK]);
                    let n = total.len();
                    old.contributions_into(k * CHUNK, &mut before[..n]);
                    contributions_into(color, &direct, new_indirect, k * CHUNK, &mut after[..n]);
                    for ((t, b), a) in total.iter_mut().zip(&before).zip(&after) {
                        (0..3).for_each(|ch| t[ch] += a[ch] - b[ch]);
                    }
                });
        }
        if let Some(indirect) = new_indirect {
            light.indirect = indirect;
        }
        light.color = color;
        std::mem::swap(&mut light.direct, &mut direct);
        self.direct_scratch = direct;
    }

    fn update(&mut self, i: usize) {
        let resum = self.count_edit();
        self.recompute_light(i, !resum);
        if resum {
            self.resum();
        }
    }

    /// Counts one edit; true when the total is due for a re-sum.
    fn count_edit(&mut self) -> bool {
        self.edits_since_resum += 1;
        self.edits_since_resum >= RESUM_EVERY
    }

    /// Re-sums the total from the per-light contributions (added light by light, in order).
    fn resum(&mut self) {
        let lights = &self.lights;
        self.total
            .par_chunks_mut(CHUNK)
            .enumerate()
            .with_min_len(MIN_VERTICES_PER_TASK / CHUNK)
            .for_each(|(k, total)| {
                total.fill([0.0; 3]);
                let mut c = [[0.0; 3]; CHUNK];
                for light in lights {
                    light.contributions_into(k * CHUNK, &mut c[..total.len()]);
                    for (t, c) in total.iter_mut().zip(&c) {
                        (0..3).for_each(|ch| t[ch] += c[ch]);
                    }
                }
            });
        self.edits_since_resum = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transport::bake::{BakeOptions, bake};

    /// A 5 × 4 × 2.7 m room with a desk and two lights; `walls` is a TOML reflectance (grey or
    /// RGB), `color` the second light's colour.
    fn scene(walls: &str, color: &str) -> Scene {
        let text = format!(
            r#"
version = 1
name = "relight test"
[room]
size = [5.0, 4.0, 2.7]
[room.reflectance]
floor = 0.2
walls = {walls}
ceiling = 0.7
[[box]]
min = [2.0, 1.5, 0.0]
max = [3.0, 2.5, 0.75]
reflectance = 0.4
[[light]]
name = "a"
position = [2.5, 2.0, 2.6]
aim_dir = [0.0, 0.0, -1.0]
lid = [[0, 1000], [30, 950], [60, 700], [90, 0]]
order = 3
radius = 0.05
[[light]]
name = "b"
position = [4.5, 0.5, 2.6]
aim = [3.0, 4.0, 1.2]
lid = [[0, 2500], [15, 2000], [30, 600], [45, 0]]
order = 3
radius = 0.03
color = {color}
[settings]
patch_size = 0.4
solver_patch_size = 1.0
"#
        );
        crate::scene::load::test_room(&text)
    }

    fn edited_curve() -> Curve {
        Curve::new(&[(0.0, 1000.0), (30.0, 700.0), (60.0, 700.0), (90.0, 0.0)]).expect("a valid curve")
    }

    fn assert_totals_close(got: &[[f64; 3]], want: &[[f64; 3]]) {
        let peak = want.iter().flatten().fold(0.0_f64, |m, &x| m.max(x.abs()));
        assert!(peak > 0.0, "the room is lit");
        for (v, (g, w)) in got.iter().zip(want).enumerate() {
            for ch in 0..3 {
                assert!(
                    (g[ch] - w[ch]).abs() <= 1e-12 * peak,
                    "vertex {v} channel {ch}: {g:?} vs {w:?}"
                );
            }
        }
    }

    /// Curve, aim and dimmer edits, applied incrementally, give the total and the per-light
    /// contributions of a relighter built from scratch for the edited scene (grey and RGB rooms,
    /// with and without a bake).
    #[test]
    fn incremental_edits_match_a_fresh_build() {
        for (walls, color) in [("0.5", "[1.0, 1.0, 1.0]"), ("[0.6, 0.5, 0.4]", "[1.0, 0.8, 0.6]")] {
            let original = scene(walls, color);
            let baked = bake(&original, &BakeOptions::default(), &mut |_| {}).expect("the test room bakes");
            let new_aim = DVec3::new(-1.0, 2.0, -1.5);
            let mut edited = original.clone();
            edited.lights[0].curve = edited_curve();
            edited.lights[0].dimmer = 0.4;
            edited.lights[1].aim = new_aim.normalize();
            let build = |scene: &Scene, with_bake: bool| {
                if with_bake {
                    Relighter::with_bake(scene, &baked)
                } else {
                    Relighter::new(scene)
                }
            };
            for with_bake in [false, true] {
                let mut relighter = build(&original, with_bake);
                assert_eq!(relighter.has_indirect(), with_bake);
                relighter.set_curve(0, edited_curve());
                relighter.set_dimmer(0, 0.4);
                relighter.set_aim(1, new_aim);
                let fresh = build(&edited, with_bake);
                for i in 0..2 {
                    assert_eq!(
                        relighter.light_contribution(i),
                        fresh.light_contribution(i),
                        "light {i}"
                    );
                    assert_eq!(relighter.light_direct(i), fresh.light_direct(i), "light {i}");
                }
                assert_totals_close(relighter.total(), fresh.total());
                assert!(
                    relighter.total() != build(&original, with_bake).total(),
                    "the edits change the light"
                );
            }
        }
    }

    /// The indirect total is each light's contribution less its coloured direct light, summed:
    /// zero without a bake or with every light off, positive in a baked room.
    #[test]
    fn indirect_into_is_the_contributions_less_the_direct_light() {
        let original = scene("[0.6, 0.5, 0.4]", "[1.0, 0.8, 0.6]");
        let baked = bake(&original, &BakeOptions::default(), &mut |_| {}).expect("the test room bakes");
        let mut out = Vec::new();
        Relighter::new(&original).indirect_into(&mut out);
        assert_eq!(out.len(), original.fine.n_vertices());
        assert!(
            out.iter().flatten().all(|&x| x == 0.0),
            "no bake, no indirect light"
        );
        let mut relighter = Relighter::with_bake(&original, &baked);
        relighter.indirect_into(&mut out);
        let contributions = [relighter.light_contribution(0), relighter.light_contribution(1)];
        for (v, o) in out.iter().enumerate() {
            for ch in 0..3 {
                let expected: f64 = (0..2)
                    .map(|i| {
                        contributions[i][v][ch] - original.lights[i].color[ch] * relighter.light_direct(i)[v]
                    })
                    .sum();
                assert!((f64::from(o[ch]) - expected).abs() <= 1e-5 * (1.0 + expected.abs()));
            }
        }
        assert!(
            out.iter().all(|o| o[1] > 0.0),
            "a closed room with ρ > 0 reflects light everywhere"
        );
        for i in 0..2 {
            relighter.set_dimmer(i, 0.0);
        }
        relighter.indirect_into(&mut out);
        assert!(
            out.iter().flatten().all(|&x| x.to_bits() == 0),
            "every light off: exactly +0"
        );
    }

    /// After exactly [`RESUM_EVERY`] edits the total is re-summed from the contributions, so it
    /// equals a fresh build bit for bit; one edit earlier it carries the incremental rounding only.
    #[test]
    fn the_total_is_resummed_every_resum_every_edits() {
        let original = scene("[0.6, 0.5, 0.4]", "[1.0, 0.8, 0.6]");
        let baked = bake(&original, &BakeOptions::default(), &mut |_| {}).expect("the test room bakes");
        let mut relighter = Relighter::with_bake(&original, &baked);
        let dimmers = [0.3, 0.7];
        for edit in 1..RESUM_EVERY {
            relighter.set_dimmer(1, dimmers[edit % 2]);
        }
        let mut edited = original.clone();
        edited.lights[1].dimmer = dimmers[(RESUM_EVERY - 1) % 2];
        let fresh = Relighter::with_bake(&edited, &baked);
        assert_totals_close(relighter.total(), fresh.total());
        // Non-vacuous: the incremental updates have drifted in the last bits by now.
        assert_ne!(relighter.total(), fresh.total());
        relighter.set_dimmer(1, dimmers[RESUM_EVERY % 2]);
        edited.lights[1].dimmer = dimmers[RESUM_EVERY % 2];
        assert_eq!(relighter.total(), Relighter::with_bake(&edited, &baked).total());
    }

    /// A moved light's direct light is exact at once; once the bake for the new position is
    /// installed, the whole relighter equals one built from scratch for the moved scene.
    #[test]
    fn a_moved_light_is_exact_after_its_new_bake_is_installed() {
        let original = scene("0.5", "[1.0, 0.8, 0.6]");
        let baked = bake(&original, &BakeOptions::default(), &mut |_| {}).expect("the test room bakes");
        let mut relighter = Relighter::with_bake(&original, &baked);
        let mut moved = original.clone();
        moved.lights[1].position = DVec3::new(1.0, 3.0, 2.4);
        let moved_bake = bake(&moved, &BakeOptions::default(), &mut |_| {}).expect("the moved room bakes");
        let fresh = Relighter::with_bake(&moved, &moved_bake);

        relighter.move_light(1, moved.lights[1].position);
        assert_eq!(
            relighter.light_direct(1),
            fresh.light_direct(1),
            "direct light moves at once"
        );
        assert_eq!(
            relighter.light_contribution(0),
            fresh.light_contribution(0),
            "light 0 untouched"
        );
        assert_ne!(
            relighter.light_contribution(1),
            fresh.light_contribution(1),
            "the indirect light is still the old position's"
        );
        relighter.install_baked(1, moved_bake.lights[1].clone());
        assert_eq!(relighter.light_contribution(1), fresh.light_contribution(1));
        assert_totals_close(relighter.total(), fresh.total());
    }

    /// Removing a light leaves the others' sum; inserting it back restores the original.
    #[test]
    fn removing_and_inserting_a_light_matches_fresh_builds() {
        let original = scene("[0.6, 0.5, 0.4]", "[1.0, 0.8, 0.6]");
        let baked = bake(&original, &BakeOptions::default(), &mut |_| {}).expect("the test room bakes");
        let full = Relighter::with_bake(&original, &baked);
        let mut relighter = full.clone();
        relighter.remove_light(0);
        assert_eq!(relighter.n_lights(), 1);
        assert_totals_close(relighter.total(), &full.light_contribution(1));
        relighter.insert_light(0, &original.lights[0], Some(baked.lights[0].clone()));
        assert_eq!(relighter.light_contribution(0), full.light_contribution(0));
        assert_totals_close(relighter.total(), full.total());
    }

    /// Indirect light given by the engine replaces the basis's at the light's next recomputation,
    /// and the total follows it by the difference: the same as a relighter given the same values
    /// before the same edit, and the light's contribution is its colour times direct plus given.
    #[test]
    fn given_indirect_light_replaces_the_basis_at_the_next_recomputation() {
        let original = scene("[0.6, 0.5, 0.4]", "[1.0, 0.8, 0.6]");
        let baked = bake(&original, &BakeOptions::default(), &mut |_| {}).expect("the test room bakes");
        let n = original.fine.n_vertices();
        let given = |scale: f64| -> Vec<[f64; 3]> {
            (0..n)
                .map(|v| [scale * (1.0 + 0.01 * v as f64), 2.0 * scale, 0.5])
                .collect()
        };
        let mut relighter = Relighter::with_bake(&original, &baked);
        let before = relighter.total().to_vec();
        relighter.give_indirect(1, &given(1.0));
        assert_eq!(
            relighter.total(),
            &before[..],
            "given values wait for the next recomputation"
        );
        assert!(relighter.has_indirect());
        relighter.set_dimmer(1, 0.5);
        relighter.give_indirect(1, &given(3.0));
        relighter.set_aim(1, DVec3::new(-1.0, 2.0, -1.5));

        let mut fresh = Relighter::with_bake(&original, &baked);
        fresh.set_dimmer(1, 0.5);
        fresh.give_indirect(1, &given(3.0));
        fresh.set_aim(1, DVec3::new(-1.0, 2.0, -1.5));
        assert_totals_close(relighter.total(), fresh.total());
        let contribution = relighter.light_contribution(1);
        assert_eq!(contribution, fresh.light_contribution(1));
        let color = original.lights[1].color;
        for (v, (c, g)) in contribution.iter().zip(given(3.0)).enumerate() {
            for ch in 0..3 {
                let want = color[ch] * (relighter.light_direct(1)[v] + f64::from(g[ch] as f32));
                assert_eq!(c[ch], want, "vertex {v} channel {ch}");
            }
        }
        let other = relighter.light_contribution(0);
        let sum: Vec<[f64; 3]> = (0..n)
            .map(|v| std::array::from_fn(|ch| other[v][ch] + contribution[v][ch]))
            .collect();
        assert_totals_close(relighter.total(), &sum);
    }

    /// Weights kept current point edit by point edit give the same light as exact weights.
    #[test]
    fn incremental_weights_give_the_exact_relight() {
        use crate::photometry::IncrementalWeights;
        let original = scene("0.5", "[1.0, 1.0, 1.0]");
        let baked = bake(&original, &BakeOptions::default(), &mut |_| {}).expect("the test room bakes");
        let mut incremental = Relighter::with_bake(&original, &baked);
        let mut exact = incremental.clone();
        let mut weights = IncrementalWeights::new(original.lights[0].curve.clone(), 3);
        for (k, cd) in [(1, 990.0), (2, 650.0), (1, 1010.0), (0, 1200.0)] {
            weights.set_intensity(k, cd).expect("a valid intensity");
            incremental.set_curve_with_weights(0, weights.curve(), weights.weights());
        }
        exact.set_curve(0, weights.curve().clone());
        let (a, b) = (incremental.light_contribution(0), exact.light_contribution(0));
        assert_totals_close(&a, &b);
        assert_ne!(a, Relighter::with_bake(&original, &baked).light_contribution(0));
    }
}
