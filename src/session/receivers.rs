//! Illuminance at a fixed set of receivers (calculation points, probe points, the point under
//! the editor's cursor), kept current edit by edit (docs/ARCHITECTURE.md, "Numbers").
//!
//! What an edit cannot change is computed once per set: each light's direct-light geometry
//! ([`DirectCache`]: `cosθ / (r² + a²)` with visibility; rebuilt only when the light
//! moves) and the gather from the coarse patches ([`GatherOperator`]: `F · V` per receiver and
//! patch). An edit of one light then costs one curve evaluation per receiver for its direct
//! light, its patch irradiance from its baked columns ([`light_patch_irradiance`]), and one pass
//! over the stored gather factors: no rays. The numbers are those of `haiko probe` at the same
//! points — `Session::illuminance_at` goes through this type too.

use std::sync::Arc;

use glam::DVec3;

use crate::photometry::{LightState, ShBasis, ZonalWeights, coefficients_from_weights, sh_count};
use crate::scene::{DirectMode, Scene};
use crate::session::light::LightEdit;
use crate::transport::bake::{BakedLight, patch_reflectance};
use crate::transport::direct::{DirectCache, Receiver, luminance_weight};
use crate::transport::gather::{GatherOperator, light_patch_irradiance};
use crate::transport::indirect::LeafRadiosity;
use crate::transport::interreflection::{Interreflection, NearField};
use crate::transport::occlusion::Occluders;
use crate::transport::visibility::Visibility;

/// What a [`ReceiverSet`] needs of one light to compute it.
#[derive(Debug, Clone, Copy)]
pub struct LightInput<'a> {
    /// The light's current state.
    pub light: &'a LightEdit,
    /// Its curve's Legendre weights (cd), kept current edit by edit.
    pub weights: &'a ZonalWeights,
    /// Its baked basis, if the session has a bake.
    pub baked: Option<&'a BakedLight>,
    /// Its leaf radiosity (lm/m², linear RGB, colour applied) and leaf indirect irradiance
    /// when the hierarchical engine carries the indirect light.
    pub radiosity: Option<LeafRadiosity<'a>>,
    /// A number that changes whenever anything above changes (the set recomputes the light
    /// when it differs from the one it last saw).
    pub version: u64,
}

/// One light as a receiver set keeps it.
#[derive(Debug, Clone)]
struct SetLight {
    version: u64,
    position: DVec3,
    radius_m: f64,
    cache: DirectCache,
    /// Direct illuminance at each receiver (lx, photopic: colour weighted).
    direct: Vec<f64>,
    /// Irradiance of every coarse patch (lx, linear RGB, colour applied) for the basis gather;
    /// empty otherwise (the leaves' gather reads each light's radiosity from the engine).
    irradiance: Vec<[f64; 3]>,
    /// The geometry of the direct-light points of the near-field pieces that resolve their
    /// leaf's radiosity (four per piece, [`NearField::points`]) seen from the light, and its
    /// direct illuminance there (lx, colour not applied); empty without them.
    near_cache: DirectCache,
    near_direct: Vec<f64>,
}

/// Where a receiver set's indirect light comes from.
#[derive(Debug, Clone)]
pub enum IndirectSource {
    /// None: direct light only.
    None,
    /// Gathered from the coarse patches, their radiosity blended from each light's baked basis.
    Basis,
    /// Gathered from the leaves of the hierarchical engine (each light's leaf radiosity).
    Leaves(Arc<Interreflection>),
}

/// The gather a set holds.
#[derive(Debug, Clone)]
enum Gather {
    Coarse(GatherOperator),
    /// The engine's leaves, with the pieces of leaves large for their distance to a receiver
    /// or close to it (empty when the direct light comes from the SH series).
    Leaves(Arc<Interreflection>, NearField),
}

impl Gather {
    /// The leaves' gather at `receivers` from `engine`, its near field resolved with exact
    /// direct light (docs/DECISIONS.md "Receivers beside a large leaf") unless `mode` takes
    /// the direct light from the SH series.
    fn leaves(engine: Arc<Interreflection>, receivers: &[Receiver], mode: DirectMode) -> Self {
        let near = match mode {
            DirectMode::Exact => engine.near_field(receivers),
            DirectMode::Basis => NearField::default(),
        };
        Gather::Leaves(engine, near)
    }

    /// The near-field pieces' points (none for the coarse gather).
    fn near_points(&self) -> &[Receiver] {
        match self {
            Gather::Leaves(_, near) => &near.points,
            Gather::Coarse(_) => &[],
        }
    }
}

/// Illuminance at fixed receivers for the lights' current states.
#[derive(Debug, Clone)]
pub struct ReceiverSet {
    receivers: Vec<Receiver>,
    mode: DirectMode,
    /// The gather; `None` for direct light only.
    gather: Option<Gather>,
    /// Coarse patch reflectance per channel (for `B = ρ H`).
    reflectance: [Vec<f64>; 3],
    /// Per light; `None` until first computed (a new set, an inserted light).
    lights: Vec<Option<SetLight>>,
    /// True when the sums below must be redone.
    stale: bool,
    /// Total illuminance per receiver, lx (photopic).
    total: Vec<f64>,
    /// The indirect part of `total`, lx (photopic).
    indirect: Vec<f64>,
}

impl ReceiverSet {
    /// A set for `receivers` in `scene` with `n_lights` lights (computed at the first
    /// [`Self::update`]). With the basis as `indirect` source, the gather from the coarse
    /// patches is built here (four visibility rays per receiver and patch against `occluders`);
    /// with the leaves, each update gathers from the summed leaf radiosity. `mode` chooses how
    /// direct light is evaluated (exact, or from each light's SH series as in paper mode).
    pub fn new(
        scene: &Scene,
        receivers: Vec<Receiver>,
        n_lights: usize,
        indirect: IndirectSource,
        mode: DirectMode,
        occluders: Option<&Occluders>,
    ) -> Self {
        let gather = match indirect {
            IndirectSource::None => None,
            IndirectSource::Basis => Some(Gather::Coarse(GatherOperator::build(
                scene, occluders, &receivers,
            ))),
            IndirectSource::Leaves(engine) => Some(Gather::leaves(engine, &receivers, mode)),
        };
        let reflectance = if matches!(gather, Some(Gather::Coarse(_))) {
            [0, 1, 2].map(|ch| patch_reflectance(scene, &scene.coarse, ch))
        } else {
            Default::default()
        };
        let n = receivers.len();
        ReceiverSet {
            receivers,
            mode,
            gather,
            reflectance,
            lights: vec![None; n_lights],
            stale: true,
            total: vec![0.0; n],
            indirect: vec![0.0; n],
        }
    }

    /// The receivers.
    pub fn receivers(&self) -> &[Receiver] {
        &self.receivers
    }

    /// Total illuminance at each receiver (lx, photopic), as of the last [`Self::update`].
    pub fn lux(&self) -> &[f64] {
        &self.total
    }

    /// The indirect part of [`Self::lux`] (lx, photopic; 0 for direct light only).
    pub fn indirect_lux(&self) -> &[f64] {
        &self.indirect
    }

    /// The hierarchical engine was rebuilt (its leaves changed): gather from `engine` from now
    /// on; every light is recomputed at the next update.
    pub fn use_engine(&mut self, engine: Arc<Interreflection>) {
        if matches!(self.gather, Some(Gather::Leaves(..))) {
            self.gather = Some(Gather::leaves(engine, &self.receivers, self.mode));
            self.lights.iter_mut().for_each(|l| *l = None);
            self.stale = true;
        }
    }

    /// A light was inserted at `at`: computed at the next update.
    pub fn insert_light(&mut self, at: usize) {
        self.lights.insert(at, None);
        self.stale = true;
    }

    /// Light `at` was removed.
    pub fn remove_light(&mut self, at: usize) {
        self.lights.remove(at);
        self.stale = true;
    }

    /// Recomputes the lights whose version changed (the direct cache only for a light that
    /// moved) and the sums; returns true when anything changed. `lights` must have one entry
    /// per light of the set, in order.
    pub fn update(&mut self, lights: &[LightInput<'_>], occluders: Option<&Occluders>) -> bool {
        assert_eq!(lights.len(), self.lights.len(), "one input per light of the set");
        let vis = occluders.map(|o| o as &dyn Visibility);
        for (slot, input) in self.lights.iter_mut().zip(lights) {
            if slot.as_ref().is_some_and(|s| s.version == input.version) {
                continue;
            }
            let light = input.light;
            let near_points = self.gather.as_ref().map_or(&[][..], Gather::near_points);
            // (The near field changes only with the engine, which drops every light.)
            let reuse = slot
                .take()
                .filter(|s| s.position == light.position && s.radius_m == light.radius_m);
            let (cache, near_cache) = match reuse {
                Some(s) => (s.cache, s.near_cache),
                None => (
                    DirectCache::build(light.position, light.radius_m, &self.receivers, vis),
                    DirectCache::build(light.position, light.radius_m, near_points, vis),
                ),
            };
            let mut computed = SetLight {
                version: input.version,
                position: light.position,
                radius_m: light.radius_m,
                cache,
                direct: vec![0.0; self.receivers.len()],
                irradiance: Vec::new(),
                near_direct: vec![0.0; near_points.len()],
                near_cache,
            };
            compute_light(
                &mut computed,
                &self.receivers,
                near_points,
                input,
                self.mode,
                self.gather.as_ref(),
            );
            *slot = Some(computed);
            self.stale = true;
        }
        if !self.stale {
            return false;
        }
        self.resum(lights);
        self.stale = false;
        true
    }

    /// Redoes the sums from the lights as computed and, for the leaves' gather, their
    /// current leaf radiosity (and leaf indirect irradiance, when the near field reads it) in
    /// `inputs`.
    fn resum(&mut self, inputs: &[LightInput<'_>]) {
        let lights: Vec<&SetLight> = self.lights.iter().flatten().collect();
        for (r, total) in self.total.iter_mut().enumerate() {
            *total = lights.iter().map(|l| l.direct[r]).sum();
        }
        let n_patches = match &self.gather {
            None => {
                self.indirect.fill(0.0);
                return;
            }
            Some(Gather::Coarse(_)) => self.reflectance[0].len(),
            Some(Gather::Leaves(engine, _)) => engine.n_leaves(),
        };
        // Summed irradiance per coarse patch (times ρ below), or summed leaf radiosity.
        let mut radiosity = vec![[0.0; 3]; n_patches];
        for light in lights.iter().filter(|l| l.irradiance.len() == n_patches) {
            for (b, h) in radiosity.iter_mut().zip(&light.irradiance) {
                (0..3).for_each(|ch| b[ch] += h[ch]);
            }
        }
        if matches!(self.gather, Some(Gather::Leaves(..))) {
            for leaves in inputs.iter().filter_map(|input| input.radiosity) {
                leaves.add_to(&mut radiosity);
            }
        }
        let gathered = match &self.gather {
            Some(Gather::Coarse(gather)) => {
                for (p, b) in radiosity.iter_mut().enumerate() {
                    (0..3).for_each(|ch| b[ch] *= self.reflectance[ch][p]);
                }
                gather.apply(&radiosity)
            }
            Some(Gather::Leaves(engine, near)) => {
                // Every light's direct irradiance at the near field's points, colour applied.
                let mut direct = vec![[0.0; 3]; near.points.len()];
                for (light, input) in self.lights.iter().zip(inputs) {
                    let Some(light) = light else { continue };
                    let color = input.light.color;
                    for (d, e) in direct.iter_mut().zip(&light.near_direct) {
                        (0..3).for_each(|ch| d[ch] += color[ch] * e);
                    }
                }
                // The leaves' indirect irradiance, when a piece resolves it.
                let mut leaf_indirect = Vec::new();
                if near.resolves_indirect() {
                    leaf_indirect = vec![[0.0; 3]; n_patches];
                    for leaves in inputs.iter().filter_map(|input| input.radiosity) {
                        leaves.add_indirect_to(&mut leaf_indirect);
                    }
                }
                engine.gather_near(&radiosity, &leaf_indirect, &self.receivers, near, &direct)
            }
            None => return,
        };
        for ((total, indirect), e) in self.total.iter_mut().zip(&mut self.indirect).zip(gathered) {
            *indirect = luminance_weight(e);
            *total += *indirect;
        }
    }
}

/// Fills `out.direct` at `receivers` and `out.near_direct` at `near_points` (those its caches
/// were built for) and, with the basis gather, `out.irradiance`, for the light's current state.
fn compute_light(
    out: &mut SetLight,
    receivers: &[Receiver],
    near_points: &[Receiver],
    input: &LightInput<'_>,
    mode: DirectMode,
    gather: Option<&Gather>,
) {
    let light = input.light;
    let state = LightState {
        curve: light.curve.clone(),
        aim: light.aim,
        dimmer: light.dimmer,
        color: light.color,
    };
    let weight = luminance_weight(light.color);
    // The SH coefficients of the baked order, when a basis needs them.
    let series = input.baked.map(|baked| {
        let basis = ShBasis::new(baked.plan.order);
        let mut coeffs = vec![0.0; sh_count(baked.plan.order)];
        coefficients_from_weights(&state, input.weights, light.window.forced(), &basis, &mut coeffs);
        (basis, coeffs, baked)
    });
    match (&series, mode) {
        (Some((basis, coeffs, baked)), DirectMode::Basis) => {
            let mask = baked.plan.mask.map(DVec3::from);
            out.cache.illuminance_with(
                receivers,
                |dir| {
                    if mask.is_some_and(|n| dir.dot(n) <= 0.0) {
                        0.0
                    } else {
                        basis.dot(coeffs, dir)
                    }
                },
                1.0,
                &mut out.direct,
            );
        }
        _ => out
            .cache
            .illuminance_into(receivers, &light.curve, light.aim, light.dimmer, &mut out.direct),
    }
    if weight != 1.0 {
        out.direct.iter_mut().for_each(|e| *e *= weight);
    }
    out.near_cache.illuminance_into(
        near_points,
        &light.curve,
        light.aim,
        light.dimmer,
        &mut out.near_direct,
    );
    if let (Some(Gather::Coarse(_)), Some((_, coeffs, baked))) = (gather, &series) {
        light_patch_irradiance(baked, coeffs, light.color, &mut out.irradiance);
    }
}
