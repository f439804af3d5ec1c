//! The relight API the editor calls: change one light's curve, aim or dimmer and get the new
//! fine-vertex illuminance, recomputing only that light (docs/METHOD.md §5; docs/BENCHMARKS.md).
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

pub use crate::photometry::emission::{LightState, light_coefficients};
use crate::photometry::{Curve, ShBasis, Window};
use crate::scene::{DirectMode, Scene};
use crate::transport::bake::{Bake, BakedLight};
use crate::transport::direct::{DirectCache, Receiver};
use crate::transport::interpolate::InterpolationWeights;
use crate::transport::occlusion::Occluders;
use crate::transport::visibility::Visibility;

/// Edits between two full re-sums of the total.
pub const RESUM_EVERY: usize = 1024;

/// Fine vertices per rayon task when updating a light's contribution.
const MIN_VERTICES_PER_TASK: usize = 16384;

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

    /// Indirect illuminance per fine vertex summed over the lights (lx, linear RGB, colour
    /// applied) into `out` (resized): each light's contribution less its direct light. The
    /// per-pixel preview adds it to the exact direct light of every pixel. O(lights × vertices).
    pub fn indirect_into(&self, out: &mut Vec<[f32; 3]>) {
        out.clear();
        out.resize(self.total.len(), [0.0; 3]);
        for ((contribution, direct), state) in self.contributions.iter().zip(&self.direct).zip(&self.lights) {
            for ((o, c), &d) in out.iter_mut().zip(contribution).zip(direct) {
                for ch in 0..3 {
                    o[ch] += (c[ch] - state.color[ch] * d) as f32;
                }
            }
        }
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

    /// Forces light `i`'s window (`None`: chosen automatically per edit, docs/METHOD.md §4.4).
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
        let dir = tempfile::tempdir().expect("a temporary directory");
        let path = dir.path().join("room.toml");
        std::fs::write(&path, text).expect("the room file is written");
        crate::scene::load(&path).expect("the test room is valid")
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
        for (v, o) in out.iter().enumerate() {
            for ch in 0..3 {
                let expected: f64 = (0..2)
                    .map(|i| {
                        relighter.light_contribution(i)[v][ch]
                            - original.lights[i].color[ch] * relighter.light_direct(i)[v]
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
}
