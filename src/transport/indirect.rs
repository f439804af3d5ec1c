//! The lights' indirect light through the interreflection engine (docs/DECISIONS.md
//! "Interreflection", "Wired into the session"): per light its exact patch direct light on the
//! engine's leaves ([`PatchDirectCache`], rebuilt only when the light moves), its solved leaf
//! irradiance and radiosity, and from those its indirect light at the fine vertices (interpolated
//! within each surface, for the display) and at any receiver (the clustered gather, for the
//! numbers).
//!
//! A light's state change (curve, aim, dimmer, colour) costs its patch direct light (one curve
//! evaluation per cached sample) and a solve warm-started from its previous indirect light; all lights
//! of a new scene are solved as one block.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use glam::{DQuat, DVec3};

use crate::error::Result;
use crate::fsio::Fnv64;
use crate::photometry::{Curve, LightState};
use crate::scene::{Light, Scene};
use crate::transport::cache::{BakeCache, CacheLoad, ValueSink, ValueSource};
use crate::transport::direct::{Receiver, fine_receivers, luminance_weight, scene_direct_at};
use crate::transport::interpolate::InterpolationWeights;
use crate::transport::interreflection::{Interreflection, InterreflectionOptions, InterreflectionStats};
use crate::transport::patchdirect::PatchDirectCache;
use crate::transport::plan::Plan;
use crate::transport::radiosity::PatchColumns;
use crate::transport::response::{
    CurveResponse, LightValues, MAX_RESPONSE_POINTS, RESPONSE_POINTS_PER_SOLVE,
};
use crate::transport::sh_response::{ESTIMATE_ORDER, ESTIMATE_TOLERANCE, ShResponse};

/// One light as the engine keeps it.
#[derive(Debug, Clone)]
struct SolvedLight {
    position: DVec3,
    radius_m: f64,
    /// Its direct sample cache; `None` once dropped to keep the lights' caches within
    /// [`DIRECT_CACHE_BUDGET_BYTES`] (its next solve builds it again).
    cache: Option<Arc<PatchDirectCache>>,
    /// Per solved channel, the leaf radiosity of the state last solved (lm/m², colour not
    /// applied; also the warm start of its next solve). In f32, like the leaf indirect light:
    /// the values are good to the solver's relative tolerance (≥ 10⁻⁶), f32 keeps 6·10⁻⁸.
    radiosity: Vec<Vec<f32>>,
    /// The light's colour (linear RGB) the radiosity is seen in.
    color: [f64; 3],
    /// Leaf indirect irradiance `H − E` (lx) per solved channel, colour not applied.
    leaf_indirect: Vec<Vec<f32>>,
    /// The curve, aim and dimmer the values above are for (`None` before the first solve).
    solved_for: Option<(Curve, DVec3, f64)>,
    /// Its values and a column per control point edited so far, once a curve edit solved them
    /// (where it stands, as aimed, at its control-point angles then): an intensity edit that
    /// [`CurveResponse::fits`] needs no solve.
    response: Option<Arc<CurveResponse>>,
    /// Its values per world-frame SH emitter where it stands, once a solve built them (with
    /// estimates on): a re-aim or curve edit is estimated from them at once while its solve runs.
    sh_response: Option<Arc<ShResponse>>,
    /// While a re-aim's or curve edit's solve is pending: the light's values for its new state
    /// estimated from the solved values above and its SH response, shown instead of them.
    estimate: Option<Estimated>,
    /// A state solved before it was asked for (where the editor's aim cursor rests, or the
    /// state the last prepared edit left): an edit to exactly that state takes these values
    /// without a solve (docs/DECISIONS.md "Re-aims prepared where the aim cursor rests").
    prepared: Option<Arc<Prepared>>,
    /// Changes whenever the values above do; unique across lights and engines of a process.
    revision: u64,
}

impl SolvedLight {
    /// True when the light stands where `light` does (position and luminous radius).
    fn stands_as(&self, light: &Light) -> bool {
        self.position == light.position && self.radius_m == light.radius
    }

    /// The light's values (per channel the leaf radiosity, and per channel the leaf indirect
    /// irradiance) for the state `light` estimated from its solved ones by its SH response;
    /// `None` without a solve, or without a response made where `light` stands.
    fn estimate_of(&self, light: &Light) -> Option<SolvedValues> {
        let (sh, (curve, aim, dimmer)) = self
            .sh_response
            .as_ref()
            .filter(|r| r.stands_as(light))
            .zip(self.solved_for.as_ref())?;
        Some(sh.estimate(
            (curve, *aim, *dimmer),
            light,
            &self.radiosity,
            &self.leaf_indirect,
        ))
    }

    /// True when the values shown are the solve of `light`'s state (where it stands, its
    /// curve, aim and dimmer), not an estimate of a pending edit.
    fn shows_solve_of(&self, light: &Light) -> bool {
        self.stands_as(light)
            && self.estimate.is_none()
            && self.solved_for.as_ref().is_some_and(|(curve, aim, dimmer)| {
                *curve == light.curve && *aim == light.aim && *dimmer == light.dimmer
            })
    }
}

/// A light's values solved for a state it may be brought to next ([`SolvedLight::prepared`]).
#[derive(Debug, Clone)]
struct Prepared {
    /// The state solved (where it stands, curve, aim, dimmer, colour).
    light: Light,
    /// Per channel the leaf radiosity, and per channel the leaf indirect irradiance (as
    /// [`SolvedLight`] keeps them).
    values: SolvedValues,
}

impl Prepared {
    fn bytes(&self) -> usize {
        4 * self
            .values
            .0
            .iter()
            .chain(&self.values.1)
            .map(Vec::len)
            .sum::<usize>()
    }
}

/// A light's values estimated for its edited state while that state's solve runs.
#[derive(Debug, Clone)]
struct Estimated {
    /// The state estimated.
    light: Light,
    /// Per channel, the leaf radiosity (lm/m², colour not applied).
    radiosity: Vec<Vec<f32>>,
    /// Per channel, the leaf indirect irradiance `H − E` (lx, colour not applied).
    leaf_indirect: Vec<Vec<f32>>,
}

impl SolvedLight {
    /// The values shown for the light: its estimate while one is held, else its solve's. Per
    /// channel the leaf radiosity, and per channel the leaf indirect irradiance.
    fn shown(&self) -> (&[Vec<f32>], &[Vec<f32>]) {
        match &self.estimate {
            Some(e) => (&e.radiosity, &e.leaf_indirect),
            None => (&self.radiosity, &self.leaf_indirect),
        }
    }
}

/// The indirect light of a scene's lights through one shared [`Interreflection`] engine.
#[derive(Debug, Clone)]
pub struct HierarchicalIndirect {
    engine: Arc<Interreflection>,
    /// Leaves → fine vertices, within each surface.
    interp: Arc<InterpolationWeights>,
    tolerance: f64,
    lights: Vec<SolvedLight>,
    /// Most bytes the lights' direct caches may hold ([`DIRECT_CACHE_BUDGET_BYTES`]).
    cache_budget: usize,
    /// The degree of the SH responses a light's solve builds for the key path's estimates
    /// ([`Self::set_estimates`]); `None`: no estimates.
    estimate_order: Option<usize>,
    /// Wall time (s) of the lights' direct caches and of their block solve at build.
    direct_caches_s: f64,
    solve_s: f64,
    /// How many lights' values were read from the disk cache at build.
    lights_from_cache: usize,
    /// Changes whenever any light's solved values do; unique across engines of a process.
    revision: u64,
}

/// Most bytes the lights' direct sample caches may hold together (docs/DECISIONS.md
/// "Interreflection", "Direct caches within a budget"). A cache holds every visible quadrature
/// sample of one light on every leaf (16 bytes each): a few MB in a small room, about 0.2 GB per
/// light on a 133 547-leaf open-plan floor (estimated). Past the budget, the caches of the lights edited longest
/// ago are dropped and rebuilt by their next solve.
pub const DIRECT_CACHE_BUDGET_BYTES: usize = 128 << 20;

/// Most bytes the lights' SH responses ([`ShResponse`]) may hold together: 9.6 MB per light on
/// the open-plan floor at degree 2, so the 13 lights solved last keep theirs.
pub const SH_RESPONSE_BUDGET_BYTES: usize = 128 << 20;

/// Most bytes the lights' curve responses ([`CurveResponse`]) may hold together: a complete
/// response of a 37-point curve holds 21 MB on the open-plan floor (one channel), so the lights
/// whose curves were edited last keep theirs.
pub const CURVE_RESPONSE_BUDGET_BYTES: usize = 128 << 20;

/// Most bytes the lights' prepared states ([`HierarchicalIndirect::prepare`]) may hold together:
/// 0.6 MB per light and channel on the open-plan floor.
pub const PREPARED_BUDGET_BYTES: usize = 64 << 20;

/// The source of [`HierarchicalIndirect::revision`]s.
static REVISIONS: AtomicU64 = AtomicU64::new(1);

fn next_revision() -> u64 {
    REVISIONS.fetch_add(1, Ordering::Relaxed)
}

/// Sizes, memory and build times of a [`HierarchicalIndirect`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IndirectStats {
    /// The engine's sizes and build times (refinement, links, balancing).
    pub engine: InterreflectionStats,
    /// Wall time (s) of every light's direct sample cache, and of the first block solve.
    pub direct_caches_s: f64,
    pub solve_s: f64,
    /// How many lights' solved values were read from the disk cache at build (the others were
    /// solved).
    pub lights_from_cache: usize,
    /// Bytes of the lights' direct caches and solved values.
    pub light_bytes: usize,
    /// Bytes of the leaves → fine vertices interpolation.
    pub interpolation_bytes: usize,
}

impl IndirectStats {
    /// Bytes in all: operator, node geometry, lights, interpolation.
    pub fn total_bytes(&self) -> usize {
        self.engine.operator_bytes + self.engine.geometry_bytes + self.light_bytes + self.interpolation_bytes
    }
}

/// What one edit of a light costs with the engine (wall seconds, measured on a copy): its new
/// patch direct light and warm-started solve, plus the interpolation to the fine vertices.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EditCosts {
    /// A curve edit (every second control point, from the second, scaled by 0.7: a change of
    /// shape for any curve with light off its axis, a narrow spot's included).
    pub curve_s: f64,
    /// After that curve edit, one control point's intensity raised by 10 %: a weighted sum of
    /// the light's response when the curve edit added that point's column (it changed at most
    /// [`RESPONSE_POINTS_PER_SOLVE`] points), else a solve that adds it.
    pub point_s: f64,
    /// The same point raised by 10 % again: the light's response weighted, no solve.
    pub point_again_s: f64,
    /// After that, the light's response grown to a column for every control point, a
    /// [`HierarchicalIndirect::grow_response`] step after another as the editor does while idle
    /// (the steps' wall time summed), and then a curve edit of every second point
    /// ([`measured_curve_edit`]) from the response alone, no solve; `None` when the curve has
    /// more than [`MAX_RESPONSE_POINTS`] points.
    pub grown: Option<GrownResponse>,
    /// A re-aim by 10°.
    pub aim_s: f64,
    /// The same re-aim estimated at once from the light's SH response of the editor's degree
    /// ([`ESTIMATE_ORDER`]), no solve: its time, the response's build (its columns' solve, as
    /// the editor's first solve of the light adds it) and its error against the solve.
    pub aim_estimate: Estimate,
    /// The same re-aim prepared first, as the editor does where its aim cursor rests
    /// ([`HierarchicalIndirect::prepare`]); `None` when the light cannot be prepared (its
    /// direct cache was dropped).
    pub aim_prepared: Option<PreparedAim>,
    /// A dimmer change to 0.8 of the current value.
    pub dimmer_s: f64,
    /// A 0.1 m move: the grading check, then the new direct cache and solve, or the whole
    /// engine rebuilt when the move changes the refinement.
    pub move_s: f64,
    /// True when the measured move needed the rebuild.
    pub move_rebuilt: bool,
}

/// What [`EditCosts::aim_prepared`] measured (wall seconds).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PreparedAim {
    /// The preparation's solve (in the editor's background).
    pub prepare_s: f64,
    /// Then the re-aim, which takes the prepared values without a solve.
    pub aim_s: f64,
}

/// What [`EditCosts::grown`] measured (wall seconds).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GrownResponse {
    /// The growth steps summed, and how many there were.
    pub grow_s: f64,
    pub steps: usize,
    /// The curve edit of every second point once the response is complete.
    pub curve_s: f64,
}

/// What [`HierarchicalIndirect::measure_estimate`] found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// Wall seconds of the light's SH response (its columns' solve).
    pub build_s: f64,
    /// Wall seconds of the estimate and its interpolation to the fine vertices.
    pub estimate_s: f64,
    /// Largest difference of the estimated vertex indirect light from the solve's, relative to
    /// the solve's largest value; `unestimated_error` the same for the values before the edit.
    pub error: f64,
    pub unestimated_error: f64,
    /// The same differences relative to each vertex's total illuminance after the edit (every
    /// light's exact direct light and solved indirect light, luminance): the largest, and the
    /// median over the vertices; `unestimated_*` for the values before the edit.
    pub error_of_total: f64,
    pub median_error_of_total: f64,
    pub unestimated_error_of_total: f64,
}

/// One light's solve, detached from the engine so that it runs on any thread while the
/// session stays usable ([`HierarchicalIndirect::update_light`] → [`Self::run`] →
/// [`HierarchicalIndirect::install`]).
#[derive(Debug, Clone)]
pub struct LightSolveJob {
    engine: Arc<Interreflection>,
    /// The light's direct sample cache; `None` when the light moved (rebuilt by the job).
    cache: Option<Arc<PatchDirectCache>>,
    light: Light,
    /// The leaf indirect irradiance `H − E` per channel the light showed when the job was made
    /// — the estimate of its new state when it had one, else its last solve's (lx; the warm
    /// start [`warm_start`] makes with the new direct light; empty before any solve).
    indirect: Vec<Vec<f32>>,
    tolerance: f64,
    /// Solve the light's [`CurveResponse`] and take its values from it, instead of one column.
    response: Option<ResponseRequest>,
    /// After the solve, build the light's [`ShResponse`] of this degree where it stands.
    sh_response: Option<usize>,
}

/// What a curve edit's [`LightSolveJob`] adds to the light's [`CurveResponse`].
#[derive(Debug, Clone)]
struct ResponseRequest {
    /// The light's response whose columns still hold (it stands, is aimed and has its
    /// control-point angles as then), kept in the new one.
    carried: Option<Arc<CurveResponse>>,
    /// The control points to add a column for: those the edit changed.
    points: Vec<usize>,
}

/// A finished [`LightSolveJob`].
#[derive(Debug, Clone)]
pub struct LightSolve {
    engine: Arc<Interreflection>,
    cache: Arc<PatchDirectCache>,
    light: Light,
    values: LightValues,
    response: Option<Arc<CurveResponse>>,
    sh_response: Option<Arc<ShResponse>>,
}

impl LightSolveJob {
    /// The light's patch direct light (its sample cache first, when it moved) and its solve.
    ///
    /// Errors: the solve failing (internal).
    pub fn run(self) -> Result<LightSolve> {
        let cache = match self.cache {
            Some(cache) => cache,
            None => Arc::new(self.engine.direct_cache(&self.light)),
        };
        let emission = cache.emission(&LightState::from(&self.light));
        let initial = warm_start(&self.engine, &self.indirect, &emission);
        let (values, response) = match self.response {
            Some(request) => {
                let response = CurveResponse::solve(
                    &self.engine,
                    &cache,
                    &self.light,
                    &emission,
                    initial.as_deref(),
                    request.carried.as_deref(),
                    &request.points,
                    self.tolerance,
                )?;
                (response.values(&self.light), Some(Arc::new(response)))
            }
            None => {
                let solutions = self.engine.solve(&emission, initial.as_deref(), self.tolerance)?;
                (LightValues::of_column(&solutions, 0, &emission.values), None)
            }
        };
        drop(emission);
        let sh_response = match self.sh_response {
            Some(order) => Some(Arc::new(ShResponse::solve(
                &self.engine,
                &cache,
                &self.light,
                order,
                ESTIMATE_TOLERANCE,
            )?)),
            None => None,
        };
        Ok(LightSolve {
            engine: self.engine,
            cache,
            light: self.light,
            values,
            response,
            sh_response,
        })
    }
}

impl HierarchicalIndirect {
    /// Builds the engine for `scene` (`channels` 1 or 3, visibility rays when `visibility`) and
    /// solves every light of `lights` (their current states) in one block per channel, to the
    /// certified relative `tolerance`.
    ///
    /// Errors: the solve failing (internal).
    pub fn build(
        scene: &Scene,
        lights: &[Light],
        channels: usize,
        visibility: bool,
        tolerance: f64,
        options: &InterreflectionOptions,
    ) -> Result<Self> {
        let engine = Interreflection::build(scene, channels, visibility, options)?;
        Self::on_engine(
            Arc::new(engine),
            scene,
            lights,
            tolerance,
            DIRECT_CACHE_BUDGET_BYTES,
        )
    }

    /// [`Self::build`] for every light of `scene` with the channels and visibility that `plan`
    /// (the plan of `scene`) chose; `options` are the engine's (`InterreflectionOptions::for_leaves`
    /// of the plan's leaves unless a study varies them).
    ///
    /// Errors: the solve failing (internal).
    pub fn planned(
        scene: &Scene,
        plan: &Plan,
        tolerance: f64,
        options: &InterreflectionOptions,
    ) -> Result<Self> {
        Self::build(
            scene,
            &scene.lights,
            plan.channels,
            plan.visibility.on,
            tolerance,
            options,
        )
    }

    /// Solves every light of `lights` on `engine`, built for `scene`, as [`Self::build`] does,
    /// with the lights' direct caches held within `cache_budget` bytes.
    ///
    /// Errors: the solve failing (internal).
    pub fn on_engine(
        engine: Arc<Interreflection>,
        scene: &Scene,
        lights: &[Light],
        tolerance: f64,
        cache_budget: usize,
    ) -> Result<Self> {
        Self::on_engine_cached(engine, scene, lights, tolerance, cache_budget, None)
            .map(|(indirect, _)| indirect)
    }

    /// [`Self::on_engine`], with each light's solved values read from `cache` when it holds
    /// them for this engine, its reflectances and the light's state, else solved (the lights
    /// it does not hold, in one block) and written there (docs/DECISIONS.md "Bake cache"); an
    /// engine built without a cache has no key to file them under, and is solved as without
    /// one. The direct caches are made as without it, so that edits cost the same. With the
    /// notices to show (an invalid entry solved again, a write that failed).
    ///
    /// Errors: the solve failing (internal).
    pub fn on_engine_cached(
        engine: Arc<Interreflection>,
        scene: &Scene,
        lights: &[Light],
        tolerance: f64,
        cache_budget: usize,
        cache: Option<&BakeCache>,
    ) -> Result<(Self, Vec<String>)> {
        let interp = Arc::new(InterpolationWeights::new(&engine.solver.mesh, &scene.fine));
        let t = Instant::now();
        let n = engine.n_leaves();
        let k = lights.len();
        let mut notices = Vec::new();
        // Only a cache, and an engine built with one, give the lights keys.
        let keyed = cache.zip(engine.operator_key()).map(|(cache, operator_key)| {
            let engine_key = solutions_engine_key(&engine, operator_key, tolerance);
            let keys: Vec<u64> = lights
                .iter()
                .map(|light| solution_key(engine_key, light))
                .collect();
            (cache, keys)
        });
        let mut cached: Vec<Option<SolvedValues>> = (0..k)
            .map(|c| {
                let (cache, keys) = keyed.as_ref()?;
                match cache.read_with(keys[c], |r| read_values(r, engine.channels(), n)) {
                    CacheLoad::Hit(values) => Some(values),
                    CacheLoad::Missing => None,
                    CacheLoad::Invalid(why) => {
                        notices.push(format!("cache {why}; solving the light again"));
                        None
                    }
                }
            })
            .collect();
        // The lights to solve, and each one's column.
        let todo: Vec<usize> = (0..k).filter(|&c| cached[c].is_none()).collect();
        let mut emission = PatchColumns::zeros(n, todo.len());
        let mut e = vec![0.0; n];
        // One cache at a time: each gives its light's patch direct light and is kept while the
        // caches kept so far stay within the budget; once one does not, the later lights' direct
        // light is summed without keeping their samples (the same values). A light read from
        // the disk cache needs no direct light, but keeps its direct cache as it would have.
        let mut kept_bytes = 0;
        let mut caches = Vec::with_capacity(k);
        for (c, light) in lights.iter().enumerate() {
            let column = todo.binary_search(&c).ok();
            if kept_bytes <= cache_budget {
                let cache = engine.direct_cache(light);
                if column.is_some() {
                    cache.irradiance_into(&light.curve, light.aim.normalize(), light.dimmer, &mut e);
                }
                kept_bytes += cache.bytes();
                caches.push((kept_bytes <= cache_budget).then(|| Arc::new(cache)));
            } else {
                if column.is_some() {
                    e = engine.stream_direct(light);
                }
                caches.push(None);
            }
            if let Some(column) = column {
                for (p, v) in e.iter().enumerate() {
                    emission.values[p * todo.len() + column] = *v;
                }
            }
        }
        let direct_caches_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let solutions = if todo.is_empty() {
            Vec::new()
        } else {
            engine.solve(&emission, None, tolerance)?
        };
        let mut indirect = HierarchicalIndirect {
            engine,
            interp,
            tolerance,
            lights: Vec::with_capacity(k),
            cache_budget,
            estimate_order: None,
            direct_caches_s,
            solve_s: t.elapsed().as_secs_f64(),
            lights_from_cache: k - todo.len(),
            revision: next_revision(),
        };
        for (c, (light, direct_cache)) in lights.iter().zip(caches).enumerate() {
            let mut solved = SolvedLight {
                position: light.position,
                radius_m: light.radius,
                cache: direct_cache,
                radiosity: Vec::new(),
                color: light.color,
                leaf_indirect: Vec::new(),
                solved_for: None,
                response: None,
                sh_response: None,
                estimate: None,
                prepared: None,
                revision: 0,
            };
            match cached[c].take() {
                Some(values) => store_values(&mut solved, values, light),
                None => {
                    let column = todo.binary_search(&c).expect("a light not read is solved");
                    let direct = emission.column(column);
                    store(
                        &mut solved,
                        LightValues::of_column(&solutions, column, &direct),
                        light,
                    );
                    if let Some((cache, keys)) = &keyed
                        && let Err(e) = cache.write_with(keys[c], |w| write_values(w, &solved))
                    {
                        notices.push(format!(
                            "could not write the bake cache in {}: {e}",
                            cache.dir.display()
                        ));
                    }
                }
            }
            indirect.lights.push(solved);
        }
        drop((emission, solutions));
        crate::heap::release_free_memory();
        Ok((indirect, notices))
    }

    /// The shared engine (leaves, operator, stats).
    pub fn engine(&self) -> &Arc<Interreflection> {
        &self.engine
    }

    /// Whether light `i` sits at `position` with luminous radius `radius_m` in the engine.
    pub fn light_is_at(&self, i: usize, position: DVec3, radius_m: f64) -> bool {
        self.lights
            .get(i)
            .is_some_and(|l| l.position == position && l.radius_m == radius_m)
    }

    /// Solves light `i` for its current state `light` here: [`Self::update_light`], then the
    /// job (if any) run and installed.
    ///
    /// Errors: the solve failing (internal); the light keeps its previous result.
    pub fn set_light(&mut self, i: usize, light: &Light) -> Result<()> {
        if let Some(job) = self.update_light(i, light) {
            let solved = job.run()?;
            self.install(i, solved);
        }
        Ok(())
    }

    /// Brings light `i` to its state `light` at once when that needs no solve (the solve is
    /// linear in the emission: a dimmer or colour change only scales the light's solution) and
    /// returns `None`; otherwise returns the solve to run, on any thread, then to
    /// [`Self::install`]. The job rebuilds the light's direct sample cache first when its
    /// position or radius changed, and starts from the indirect light the light shows — the
    /// estimate of `light` when one can be made (docs/DECISIONS.md "Re-aims solved from their
    /// estimate").
    pub fn update_light(&mut self, i: usize, light: &Light) -> Option<LightSolveJob> {
        let old = &self.lights[i];
        let moved = old.position != light.position || old.radius_m != light.radius;
        if let Some((curve, aim, dimmer)) = &old.solved_for
            && !moved
            && *curve == light.curve
            && *aim == light.aim
            && *dimmer > 0.0
        {
            let factor = light.dimmer / dimmer;
            let solved = &mut self.lights[i];
            for channel in solved.radiosity.iter_mut().chain(&mut solved.leaf_indirect) {
                channel
                    .iter_mut()
                    .for_each(|v| *v = (f64::from(*v) * factor) as f32);
            }
            solved.color = light.color;
            solved.solved_for = Some((light.curve.clone(), light.aim, light.dimmer));
            solved.estimate = None;
            solved.revision = next_revision();
            self.revision = next_revision();
            return None;
        }
        if let Some(response) = old.response.as_ref().filter(|r| !moved && r.fits(light)) {
            let values = response.values(light);
            store(&mut self.lights[i], values, light);
            self.revision = next_revision();
            return None;
        }
        if old
            .prepared
            .as_ref()
            .is_some_and(|p| prepared_for(&p.light, light))
        {
            self.take_prepared(i, light);
            return None;
        }
        if moved {
            self.lights[i].prepared = None;
        }
        let old = &self.lights[i];
        let response = (!moved).then(|| curve_edit_response(old, light)).flatten();
        let sh_missing = old.sh_response.as_ref().is_none_or(|r| !r.stands_as(light));
        let sh_response = self.estimate_order.filter(|_| !moved && sh_missing);
        let cache = if moved { None } else { old.cache.clone() };
        // The solve starts from the light's estimate of the new state when it shows one (docs/
        // DECISIONS.md "Re-aims solved from their estimate"), else from its solved values.
        self.show_estimate(i, light);
        let shown = &self.lights[i];
        Some(LightSolveJob {
            engine: Arc::clone(&self.engine),
            cache,
            light: light.clone(),
            indirect: if shown.solved_for.is_some() {
                shown.shown().1.to_vec()
            } else {
                Vec::new()
            },
            tolerance: self.tolerance,
            response,
            sh_response,
        })
    }

    /// Has each light's next solve (unless it moved) also build its [`ShResponse`] of degree
    /// `order` where it stands when it has none, so that its later re-aims and curve edits are
    /// estimated at once while their solves run (docs/DECISIONS.md "Interreflection", "Re-aims
    /// and curve edits estimated at once"); `None` builds none (the responses held stay).
    pub fn set_estimates(&mut self, order: Option<usize>) {
        self.estimate_order = order;
    }

    /// A solve of light `i` in the state `light` before any edit asks for it — where the
    /// editor's aim cursor rests — to run on any thread and hand to [`Self::hold_prepared`]; an
    /// edit to exactly that state then takes its values at once, exact, with no solve (docs/
    /// DECISIONS.md "Re-aims prepared where the aim cursor rests"). The values shown do not
    /// change. `None` when the light does not stand where `light` does (a move solves anew), its
    /// direct cache was dropped, it has no solve yet or one is pending, `light` is the state it
    /// shows, or that state is already prepared. The solve starts from the light's estimate of
    /// `light` when it holds an SH response, else from its solved values.
    pub fn prepare(&self, i: usize, light: &Light) -> Option<LightSolveJob> {
        let solved = self.lights.get(i)?;
        if solved.solved_for.is_none()
            || !solved.stands_as(light)
            || solved.estimate.is_some()
            || solved.shows_solve_of(light)
        {
            return None;
        }
        if solved
            .prepared
            .as_ref()
            .is_some_and(|p| prepared_for(&p.light, light))
        {
            return None;
        }
        let cache = solved.cache.clone()?;
        let indirect = solved
            .estimate_of(light)
            .map_or_else(|| solved.leaf_indirect.clone(), |(_, indirect)| indirect);
        Some(LightSolveJob {
            engine: Arc::clone(&self.engine),
            cache: Some(cache),
            light: light.clone(),
            indirect,
            tolerance: self.tolerance,
            response: None,
            sh_response: None,
        })
    }

    /// Keeps a finished [`Self::prepare`] job as light `i`'s prepared state (replacing the one
    /// held); false, keeping nothing, when it was made on another engine or the light stands
    /// elsewhere since (its move's solve installed).
    pub fn hold_prepared(&mut self, i: usize, solved: LightSolve) -> bool {
        let Some(light) = self.lights.get_mut(i) else {
            return false;
        };
        if !Arc::ptr_eq(&solved.engine, &self.engine) || !light.stands_as(&solved.light) {
            return false;
        }
        light.prepared = Some(Arc::new(Prepared {
            light: solved.light,
            values: solved.values.into_single(),
        }));
        trim_to_budget(
            &mut self.lights,
            i,
            PREPARED_BUDGET_BYTES,
            |l| &mut l.prepared,
            Prepared::bytes,
        );
        true
    }

    /// Whether light `i` holds a prepared solve of the state `light`.
    pub fn is_prepared(&self, i: usize, light: &Light) -> bool {
        self.lights
            .get(i)
            .and_then(|l| l.prepared.as_ref())
            .is_some_and(|p| prepared_for(&p.light, light))
    }

    /// Brings light `i` to its prepared state `light`, whose values become the solved ones; the
    /// state solved before becomes the prepared one (an undo lands at once too).
    fn take_prepared(&mut self, i: usize, light: &Light) {
        let solved = &mut self.lights[i];
        let Some(prepared) = solved.prepared.take() else {
            return;
        };
        let previous = solved.solved_for.take().map(|(curve, aim, dimmer)| {
            Arc::new(Prepared {
                light: Light {
                    curve,
                    aim,
                    dimmer,
                    color: solved.color,
                    ..prepared.light.clone()
                },
                values: (
                    std::mem::take(&mut solved.radiosity),
                    std::mem::take(&mut solved.leaf_indirect),
                ),
            })
        });
        store_values(solved, Arc::unwrap_or_clone(prepared).values, light);
        solved.prepared = previous;
        self.revision = next_revision();
    }

    /// Whether light `i`'s values are an estimate whose solve is pending.
    pub fn is_estimated(&self, i: usize) -> bool {
        self.lights[i].estimate.is_some()
    }

    /// Shows light `i`'s values estimated for its state `light` — its solved values plus the
    /// change its SH response gives (docs/DECISIONS.md "Interreflection", "Re-aims and curve
    /// edits estimated at once") — when it has solved values and a response where `light`
    /// stands; else leaves what it shows.
    fn show_estimate(&mut self, i: usize, light: &Light) {
        let solved = &mut self.lights[i];
        let Some((radiosity, leaf_indirect)) = solved.estimate_of(light) else {
            return;
        };
        solved.estimate = Some(Estimated {
            light: light.clone(),
            radiosity,
            leaf_indirect,
        });
        solved.color = light.color;
        solved.revision = next_revision();
        self.revision = next_revision();
    }

    /// Installs a finished solve of light `i`; when the light shows an estimate of a later state
    /// (whose solve is still to come), that estimate is made again from the new values. Returns
    /// false, changing nothing, when the solve was made on another engine (this one was rebuilt
    /// since).
    pub fn install(&mut self, i: usize, solved: LightSolve) -> bool {
        if !Arc::ptr_eq(&solved.engine, &self.engine) || i >= self.lights.len() {
            return false;
        }
        let light = &mut self.lights[i];
        light.position = solved.light.position;
        light.radius_m = solved.light.radius;
        light.cache = Some(solved.cache);
        if solved.response.is_some() {
            light.response = solved.response;
        }
        if solved.sh_response.is_some() {
            light.sh_response = solved.sh_response;
        }
        // An estimate of a later state (its solve still to come) is made again from these values.
        let later = light.estimate.take().map(|e| e.light);
        store(light, solved.values, &solved.light);
        self.revision = next_revision();
        if let Some(later) = later.filter(|l| !same_state(l, &solved.light)) {
            self.show_estimate(i, &later);
        }
        self.trim_caches(i);
        true
    }

    /// The next step of growing light `i`'s curve response towards a column for every control
    /// point, for its current state `light` (docs/DECISIONS.md "Interreflection", "Responses
    /// completed while the editor is idle"): a solve adding up to [`RESPONSE_POINTS_PER_SOLVE`]
    /// columns — the points nearest those held first, or, for a response started here, nearest
    /// the curve's peak — to [`Self::install_response`]. A response is started only when
    /// `start` (the light the designer has selected); otherwise the light must hold one that
    /// [`CurveResponse::stands_as`] `light` (a curve edit solved it where it stands, as aimed,
    /// at its control-point angles). `None` too when its values are not `light`'s solve (an edit
    /// is pending), its direct cache was dropped, its dimmer is 0, its curve has more than
    /// [`MAX_RESPONSE_POINTS`] points, or its response is complete.
    pub fn grow_response(&self, i: usize, light: &Light, start: bool) -> Option<LightSolveJob> {
        let solved = self.lights.get(i)?;
        let n = light.curve.len();
        if !solved.shows_solve_of(light) || light.dimmer <= 0.0 || n > MAX_RESPONSE_POINTS {
            return None;
        }
        let response = solved.response.as_ref().filter(|r| r.stands_as(light));
        if response.is_none() && !start {
            return None;
        }
        let cache = solved.cache.as_ref()?;
        let held: Vec<usize> = response.iter().flat_map(|r| r.points()).collect();
        let intensities = light.curve.intensities_cd();
        let peak = (0..n)
            .max_by(|&a, &b| intensities[a].total_cmp(&intensities[b]))
            .unwrap_or(0);
        let from: &[usize] = if held.is_empty() { &[peak] } else { &held };
        let distance = |k: usize| from.iter().map(|&h| h.abs_diff(k)).min().unwrap_or(0);
        let mut missing: Vec<usize> = (0..n).filter(|k| !held.contains(k)).collect();
        missing.sort_by_key(|&k| (distance(k), k));
        missing.truncate(RESPONSE_POINTS_PER_SOLVE);
        if missing.is_empty() {
            return None;
        }
        Some(LightSolveJob {
            engine: Arc::clone(&self.engine),
            cache: Some(Arc::clone(cache)),
            light: light.clone(),
            indirect: solved.leaf_indirect.clone(),
            tolerance: self.tolerance,
            response: Some(ResponseRequest {
                carried: response.cloned(),
                points: missing,
            }),
            sh_response: None,
        })
    }

    /// Grows light `i`'s curve response (it must hold one that stands as `light`, its current
    /// state) to every control point here, one [`Self::grow_response`] step after another as
    /// the editor does while idle; returns the number of steps.
    ///
    /// Errors: a step's solve failing (internal).
    pub fn complete_response(&mut self, i: usize, light: &Light) -> Result<usize> {
        let mut steps = 0;
        while let Some(job) = self.grow_response(i, light, false) {
            let grown = job.run()?;
            if !self.install_response(i, grown) {
                break;
            }
            steps += 1;
        }
        Ok(steps)
    }

    /// Keeps the grown curve response of a finished [`Self::grow_response`] step for light `i`
    /// when the light is still in the state it was grown for, on this engine; its values stay
    /// as they are (the step's are the same solve). Returns whether it was kept.
    pub fn install_response(&mut self, i: usize, grown: LightSolve) -> bool {
        if !Arc::ptr_eq(&grown.engine, &self.engine) {
            return false;
        }
        let Some(light) = self.lights.get_mut(i) else {
            return false;
        };
        if !light.shows_solve_of(&grown.light) || grown.response.is_none() {
            return false;
        }
        light.response = grown.response;
        self.trim_caches(i);
        true
    }

    /// Drops the direct caches, the SH responses and the curve responses of the lights solved
    /// longest ago (never light `keep`'s) until each kind held is within its budget.
    fn trim_caches(&mut self, keep: usize) {
        trim_to_budget(
            &mut self.lights,
            keep,
            self.cache_budget,
            |l| &mut l.cache,
            |c| c.bytes(),
        );
        trim_to_budget(
            &mut self.lights,
            keep,
            SH_RESPONSE_BUDGET_BYTES,
            |l| &mut l.sh_response,
            |r| r.bytes(),
        );
        trim_to_budget(
            &mut self.lights,
            keep,
            CURVE_RESPONSE_BUDGET_BYTES,
            |l| &mut l.response,
            |r| r.bytes(),
        );
    }

    /// Whether light `i`'s direct sample cache is held (else its next solve builds it).
    #[cfg(test)]
    fn holds_direct_cache(&self, i: usize) -> bool {
        self.lights[i].cache.is_some()
    }

    /// Adds `light` at index `at` (≤ [`Self::n_lights`]) without indirect light until the next
    /// [`Self::set_light`] solves it.
    pub fn insert_light(&mut self, at: usize, light: &Light) {
        let n = self.engine.n_leaves();
        self.lights.insert(
            at,
            SolvedLight {
                position: light.position,
                radius_m: light.radius,
                cache: None,
                radiosity: Vec::new(),
                color: light.color,
                leaf_indirect: vec![vec![0.0; n]; self.engine.channels()],
                solved_for: None,
                response: None,
                sh_response: None,
                estimate: None,
                prepared: None,
                revision: next_revision(),
            },
        );
    }

    /// Removes light `i`.
    pub fn remove_light(&mut self, i: usize) {
        self.lights.remove(i);
        self.revision = next_revision();
    }

    /// A number that changes whenever the lights' solved values do (an install, a scaling, a
    /// removed light), never shared by two engines: what a cache of gathered values is keyed on.
    pub fn revision(&self) -> u64 {
        self.revision
    }

    /// A number that changes whenever light `i`'s solved values do, never shared by two lights
    /// or engines: what a copy of its interpolated indirect light is keyed on.
    pub fn light_revision(&self, i: usize) -> u64 {
        self.lights[i].revision
    }

    /// Light `i`'s leaf radiosity (lm/m², linear RGB, colour applied) and leaf indirect
    /// irradiance, read where they are kept: its estimate while its solve is pending
    /// ([`Self::is_estimated`]).
    pub fn light_radiosity(&self, i: usize) -> LeafRadiosity<'_> {
        let light = &self.lights[i];
        let (channels, indirect) = light.shown();
        LeafRadiosity {
            channels,
            indirect,
            color: light.color,
        }
    }

    /// Light `i`'s indirect irradiance at the fine vertices (lx, one value per channel 0..3 per
    /// vertex, colour not applied), interpolated from its leaves within each surface: its
    /// estimate while its solve is pending ([`Self::is_estimated`]).
    pub fn vertex_indirect(&self, i: usize) -> Vec<[f64; 3]> {
        let leaf_indirect = self.lights[i].shown().1;
        let channels = leaf_indirect.len();
        let columns: Vec<f64> = (0..self.engine.n_leaves())
            .flat_map(|p| leaf_indirect.iter().map(move |c| f64::from(c[p])))
            .collect();
        let values = self.interp.apply_columns(&columns, channels);
        values
            .chunks_exact(channels)
            .map(|v| [0, 1, 2].map(|ch| v[ch.min(channels - 1)]))
            .collect()
    }

    /// Every light's indirect illuminance summed (lx, linear RGB) at `receivers`, through the
    /// clustered gather from the lights' summed leaf radiosity.
    pub fn gather_all(&self, receivers: &[Receiver]) -> Vec<[f64; 3]> {
        let mut radiosity = vec![[0.0; 3]; self.engine.n_leaves()];
        for i in 0..self.lights.len() {
            self.light_radiosity(i).add_to(&mut radiosity);
        }
        self.gather(&radiosity, receivers)
    }

    /// Indirect illuminance (lx, linear RGB) at `receivers` from the summed leaf radiosity
    /// `radiosity` (lm/m², linear RGB per leaf) through the engine's clustered gather.
    pub fn gather(&self, radiosity: &[[f64; 3]], receivers: &[Receiver]) -> Vec<[f64; 3]> {
        self.engine.gather(radiosity, receivers)
    }

    /// Number of leaves.
    pub fn n_leaves(&self) -> usize {
        self.engine.n_leaves()
    }

    /// Sizes, memory by part and build times.
    pub fn stats(&self) -> IndirectStats {
        IndirectStats {
            engine: self.engine.stats,
            direct_caches_s: self.direct_caches_s,
            solve_s: self.solve_s,
            lights_from_cache: self.lights_from_cache,
            light_bytes: self.light_bytes(),
            interpolation_bytes: self.interp.bytes(),
        }
    }

    /// Measures, on copies, what a curve edit (then an intensity edit after it), a re-aim, a
    /// dimmer change and a 0.1 m move (along x, or back when that leaves the room) of light `i`
    /// of `scene` cost, each from the light's current state, including the interpolation of its
    /// indirect light to the fine vertices, and the editor's estimate of the re-aim. Consumes the
    /// engine: a move that regrades builds the moved room's engine after this one is dropped,
    /// so that the two are never held together (the editor holds both while it rebuilds, since
    /// it answers edits on the current one meanwhile).
    ///
    /// Errors: a solve failing (internal).
    pub fn measure_edits(self, scene: &Scene, i: usize) -> Result<EditCosts> {
        let light = &scene.lights[i];
        let timed = |edited: &Light| -> Result<f64> {
            let mut copy = self.clone();
            let t = Instant::now();
            copy.set_light(i, edited)?;
            let _ = copy.vertex_indirect(i);
            Ok(t.elapsed().as_secs_f64())
        };
        let curve = measured_curve_edit(light);
        let aim = measured_reaim(light);
        let dimmer = Light {
            dimmer: 0.8 * light.dimmer,
            ..light.clone()
        };
        let (aim_s, dimmer_s) = (timed(&aim)?, timed(&dimmer)?);
        let mut copy = self.clone();
        let t = Instant::now();
        let aim_prepared = match copy.prepare(i, &aim) {
            Some(job) => {
                copy.hold_prepared(i, job.run()?);
                let prepare_s = t.elapsed().as_secs_f64();
                let t = Instant::now();
                copy.set_light(i, &aim)?;
                let _ = copy.vertex_indirect(i);
                Some(PreparedAim {
                    prepare_s,
                    aim_s: t.elapsed().as_secs_f64(),
                })
            }
            None => None,
        };
        let mut copy = self.clone();
        let t = Instant::now();
        copy.set_light(i, &curve)?;
        let _ = copy.vertex_indirect(i);
        let curve_s = t.elapsed().as_secs_f64();
        let k = usize::from(curve.curve.len() > 1);
        let raised = |from: &Light| -> Result<Light> {
            let mut raised = from.clone();
            let candela = 1.1 * raised.curve.intensities_cd()[k];
            raised
                .curve
                .set_intensity(k, candela)
                .map_err(|e| crate::error::Error::internal(e.to_string()))?;
            Ok(raised)
        };
        let point = raised(&curve)?;
        let t = Instant::now();
        copy.set_light(i, &point)?;
        let _ = copy.vertex_indirect(i);
        let point_s = t.elapsed().as_secs_f64();
        let again = raised(&point)?;
        let t = Instant::now();
        copy.set_light(i, &again)?;
        let _ = copy.vertex_indirect(i);
        let point_again_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let steps = copy.complete_response(i, &again)?;
        let grow_s = t.elapsed().as_secs_f64();
        let grown = if steps > 0 {
            let t = Instant::now();
            copy.set_light(i, &measured_curve_edit(&again))?;
            let _ = copy.vertex_indirect(i);
            Some(GrownResponse {
                grow_s,
                steps,
                curve_s: t.elapsed().as_secs_f64(),
            })
        } else {
            None
        };
        let step = if light.position.x + 0.1 < scene.room_size.x {
            0.1
        } else {
            -0.1
        };
        drop(copy);
        let aim_estimate = self.measure_estimate(scene, i, &aim, ESTIMATE_ORDER)?;
        let mut moved_scene = scene.clone();
        moved_scene.lights[i].position.x += step;
        let t = Instant::now();
        let regraded = self.engine.regrade(&moved_scene);
        let move_rebuilt = regraded.is_some();
        if let Some(solver) = regraded {
            let (tolerance, cache_budget) = (self.tolerance, self.cache_budget);
            let HierarchicalIndirect {
                engine,
                lights,
                interp,
                ..
            } = self;
            drop((lights, interp));
            let engine = match Arc::try_unwrap(engine) {
                Ok(engine) => engine.into_rebuilt(&moved_scene, solver)?,
                Err(shared) => shared.rebuilt(&moved_scene, solver)?,
            };
            let rebuilt = Self::on_engine(
                Arc::new(engine),
                &moved_scene,
                &moved_scene.lights,
                tolerance,
                cache_budget,
            )?;
            let _ = rebuilt.vertex_indirect(i);
        } else {
            let mut copy = self;
            copy.set_light(i, &moved_scene.lights[i])?;
            let _ = copy.vertex_indirect(i);
        }
        let move_s = t.elapsed().as_secs_f64();
        Ok(EditCosts {
            curve_s,
            point_s,
            point_again_s,
            grown,
            aim_s,
            aim_estimate,
            aim_prepared,
            dimmer_s,
            move_s,
            move_rebuilt,
        })
    }

    /// Measures, on a copy, light `i`'s SH response of degree `order` where it stands (its
    /// state in `scene`), then `edited`'s estimate from it (with the interpolation to the fine
    /// vertices), and compares the estimate, and the values before, with `edited`'s solve.
    ///
    /// Errors: a solve failing (internal).
    pub fn measure_estimate(
        &self,
        scene: &Scene,
        i: usize,
        edited: &Light,
        order: usize,
    ) -> Result<Estimate> {
        let light = &scene.lights[i];
        let mut copy = self.clone();
        copy.set_estimates(Some(order));
        let t = Instant::now();
        let cache = match &copy.lights[i].cache {
            Some(cache) => Arc::clone(cache),
            None => Arc::new(self.engine.direct_cache(light)),
        };
        let response = ShResponse::solve(&self.engine, &cache, light, order, ESTIMATE_TOLERANCE)?;
        let build_s = t.elapsed().as_secs_f64();
        copy.lights[i].sh_response = Some(Arc::new(response));
        let before = copy.vertex_indirect(i);
        let t = Instant::now();
        let job = copy.update_light(i, edited);
        let estimated = copy.vertex_indirect(i);
        let estimate_s = t.elapsed().as_secs_f64();
        if let Some(job) = job {
            let solved = job.run()?;
            copy.install(i, solved);
        }
        let exact = copy.vertex_indirect(i);
        let mut edited_scene = scene.clone();
        edited_scene.lights[i] = edited.clone();
        let total = copy.vertex_totals(&edited_scene);
        let luminance = |v: &[f64; 3]| luminance_weight(std::array::from_fn(|c| v[c] * edited.color[c]));
        let peak = exact
            .iter()
            .fold(f64::MIN_POSITIVE, |m, v| m.max(luminance(v).abs()));
        let differences = |values: &[[f64; 3]]| -> Vec<f64> {
            values
                .iter()
                .zip(&exact)
                .map(|(a, b)| (luminance(a) - luminance(b)).abs())
                .collect()
        };
        let of_total = |d: &[f64]| -> Vec<f64> {
            let mut r: Vec<f64> = d
                .iter()
                .zip(&total)
                .filter(|(_, t)| **t > 0.0)
                .map(|(d, t)| d / t)
                .collect();
            r.sort_by(f64::total_cmp);
            r
        };
        let largest = |d: &[f64]| d.iter().fold(0.0f64, |m, &v| m.max(v));
        let (estimated, before) = (differences(&estimated), differences(&before));
        let (estimated_of_total, before_of_total) = (of_total(&estimated), of_total(&before));
        Ok(Estimate {
            build_s,
            estimate_s,
            error: largest(&estimated) / peak,
            unestimated_error: largest(&before) / peak,
            error_of_total: largest(&estimated_of_total),
            median_error_of_total: estimated_of_total
                .get(estimated_of_total.len() / 2)
                .copied()
                .unwrap_or(0.0),
            unestimated_error_of_total: largest(&before_of_total),
        })
    }

    /// The total illuminance (lx, luminance) at each fine vertex of `scene` (whose lights are
    /// this engine's, in their solved states): every light's exact direct light and its indirect
    /// light as shown.
    fn vertex_totals(&self, scene: &Scene) -> Vec<f64> {
        let mut total = scene_direct_at(scene, &fine_receivers(scene));
        for (j, light) in self.lights.iter().enumerate() {
            for (t, v) in total.iter_mut().zip(self.vertex_indirect(j)) {
                *t += luminance_weight(std::array::from_fn(|c| v[c] * light.color[c]));
            }
        }
        total
    }

    /// Bytes held by the lights' direct caches and solved values.
    pub fn light_bytes(&self) -> usize {
        self.lights
            .iter()
            .map(|l| {
                l.cache.as_ref().map_or(0, |c| c.bytes())
                    + l.prepared.as_ref().map_or(0, |p| p.bytes())
                    + l.response.as_ref().map_or(0, |r| r.bytes())
                    + l.sh_response.as_ref().map_or(0, |r| r.bytes())
                    + 4 * l
                        .radiosity
                        .iter()
                        .chain(&l.leaf_indirect)
                        .chain(
                            l.estimate
                                .iter()
                                .flat_map(|e| e.radiosity.iter().chain(&e.leaf_indirect)),
                        )
                        .map(Vec::len)
                        .sum::<usize>()
            })
            .sum()
    }
}

/// Drops what `slot` holds (`bytes` each) from the lights solved longest ago, never light
/// `keep`'s, until what the lights hold there together is within `budget` bytes.
fn trim_to_budget<T>(
    lights: &mut [SolvedLight],
    keep: usize,
    budget: usize,
    slot: impl Fn(&mut SolvedLight) -> &mut Option<Arc<T>>,
    bytes: impl Fn(&T) -> usize,
) {
    let mut held: usize = lights
        .iter_mut()
        .filter_map(|l| slot(l).as_deref().map(&bytes))
        .sum();
    while held > budget {
        let mut oldest: Option<(u64, usize)> = None;
        for (j, l) in lights.iter_mut().enumerate() {
            if j != keep && slot(l).is_some() && oldest.is_none_or(|(r, _)| l.revision < r) {
                oldest = Some((l.revision, j));
            }
        }
        let Some((_, j)) = oldest else {
            return;
        };
        held -= slot(&mut lights[j]).take().map_or(0, |c| bytes(&c));
    }
}

/// The curve edit the engine's measures make of `light` ([`EditCosts::curve_s`]): every second
/// control point, from the second, scaled by 0.7.
pub fn measured_curve_edit(light: &Light) -> Light {
    let points: Vec<(f64, f64)> = light
        .curve
        .points()
        .enumerate()
        .map(|(k, (g, c))| (g, if k % 2 == 1 { 0.7 * c } else { c }))
        .collect();
    Light {
        curve: Curve::new(&points).unwrap_or_else(|_| light.curve.clone()),
        ..light.clone()
    }
}

/// The re-aim the engine's measures make of `light` ([`EditCosts::aim_s`]): 10° about a
/// direction across its aim.
pub fn measured_reaim(light: &Light) -> Light {
    let axis = light.aim.any_orthonormal_vector();
    Light {
        aim: DQuat::from_axis_angle(axis, 10f64.to_radians()) * light.aim,
        ..light.clone()
    }
}

/// The start of a light's solve for its new leaf direct light `emission`: per channel
/// `ρ (I_old + E_new)`, `I_old` the light's previous leaf indirect irradiance (`None` when it has
/// none for every channel). That is its previous radiosity `ρ (E_old + I_old)` with the first
/// reflection brought up to date, so GMRES starts one bounce closer; it needs neither the old
/// direct light nor the cache it came from (docs/DECISIONS.md "Interreflection", "Warm starts
/// with the first reflection").
fn warm_start(
    engine: &Interreflection,
    indirect: &[Vec<f32>],
    emission: &PatchColumns,
) -> Option<Vec<PatchColumns>> {
    if indirect.len() != engine.channels() {
        return None;
    }
    Some(
        indirect
            .iter()
            .zip(&engine.reflectance)
            .map(|(channel, rho)| PatchColumns {
                values: channel
                    .iter()
                    .zip(&emission.values)
                    .zip(rho)
                    .map(|((&i, e), r)| r * (f64::from(i) + e))
                    .collect(),
                ..*emission
            })
            .collect(),
    )
}

/// What a solve of `light` (where `old` stands) adds to its curve response, when it is a curve
/// edit at the same control-point angles, as aimed, with the dimmer on: more edits of the same
/// control points are likely to follow (docs/DECISIONS.md "Interreflection", "Responses grown a
/// point at a time"). A column for each point the edit changed, unless it changed more than
/// [`RESPONSE_POINTS_PER_SOLVE`] (a new shape) or the response would hold more than
/// [`MAX_RESPONSE_POINTS`]; the columns of the light's response kept when they still hold.
fn curve_edit_response(old: &SolvedLight, light: &Light) -> Option<ResponseRequest> {
    let (curve, aim, _) = old.solved_for.as_ref()?;
    let same_angles = curve.gammas_deg() == light.curve.gammas_deg();
    if *aim != light.aim || !same_angles || *curve == light.curve || light.dimmer <= 0.0 {
        return None;
    }
    let carried = old.response.clone().filter(|r| r.stands_as(light));
    let held: Vec<usize> = carried.iter().flat_map(|r| r.points()).collect();
    let changed: Vec<usize> = curve
        .intensities_cd()
        .iter()
        .zip(light.curve.intensities_cd())
        .enumerate()
        .filter(|(k, (was, is))| was != is && !held.contains(k))
        .map(|(k, _)| k)
        .collect();
    let fits =
        changed.len() <= RESPONSE_POINTS_PER_SOLVE && held.len() + changed.len() <= MAX_RESPONSE_POINTS;
    let points = if fits { changed } else { Vec::new() };
    (carried.is_some() || !points.is_empty()).then_some(ResponseRequest { carried, points })
}

/// True when `a` and `b` are the same state of a light: where it stands, its curve, aim and
/// dimmer (what its solve depends on).
fn same_state(a: &Light, b: &Light) -> bool {
    same_but_aim(a, b) && a.aim == b.aim
}

/// True when a light's values prepared for the state `prepared` are those of `light`: the same
/// state, its aim allowed to differ by rounding (a target aimed at again, an aim undone: 10⁻¹²
/// rad, far below the solve's tolerance).
fn prepared_for(prepared: &Light, light: &Light) -> bool {
    same_but_aim(prepared, light) && prepared.aim.distance(light.aim) <= 1e-12
}

/// [`same_state`] but for the aim.
fn same_but_aim(a: &Light, b: &Light) -> bool {
    a.position == b.position && a.radius == b.radius && a.curve == b.curve && a.dimmer == b.dimmer
}

/// Bumped whenever a light's solve makes something else of the same engine and state: the
/// lights' solved values are cached under keys made with it (3: the solve's error is relative
/// to the interreflected radiosity, docs/DECISIONS.md "The solve's scale").
const SOLUTION_FORMAT: u64 = 3;

/// The part of every light's solution key that is the engine's: its operator key, its options,
/// the leaves whose direct light is sampled finely and the leaf reflectances, and the tolerance
/// (hashed once for all lights).
fn solutions_engine_key(engine: &Interreflection, operator_key: u64, tolerance: f64) -> u64 {
    let mut h = Fnv64::default();
    h.u64(SOLUTION_FORMAT)
        .str("haiko-light-solution")
        .u64(operator_key)
        .str(&format!("{:?}", engine.options()))
        .f64(tolerance);
    for &fine in &engine.solver.beam_edge {
        h.u64(u64::from(fine));
    }
    for channel in &engine.reflectance {
        for &r in channel {
            h.f64(r);
        }
    }
    h.finish()
}

/// The key of a light's solved values on the engine of `engine_key`
/// ([`solutions_engine_key`]): the light where it stands (position, radius) and its state
/// (curve, aim, dimmer). Its colour is not in it (the values are kept without it).
fn solution_key(engine_key: u64, light: &Light) -> u64 {
    let mut h = Fnv64::default();
    let (p, a) = (light.position, light.aim);
    h.u64(engine_key).f64(p.x).f64(p.y).f64(p.z).f64(light.radius);
    h.str(&format!("{:?}", light.curve));
    h.f64(a.x).f64(a.y).f64(a.z).f64(light.dimmer);
    h.finish()
}

/// Writes a light's solved values into its cache entry.
fn write_values(w: &mut impl ValueSink, solved: &SolvedLight) {
    w.u64(solved.radiosity.len() as u64);
    for channel in solved.radiosity.iter().chain(&solved.leaf_indirect) {
        w.f32s(channel);
    }
}

/// The values [`write_values`] wrote, if they are `channels` channels of `n` finite values.
fn read_values(r: &mut impl ValueSource, channels: usize, n: usize) -> Option<SolvedValues> {
    if r.u64()? != channels as u64 {
        return None;
    }
    let mut read = || {
        (0..channels)
            .map(|_| {
                r.f32s()
                    .filter(|v| v.len() == n && v.iter().all(|x| x.is_finite()))
            })
            .collect::<Option<Vec<_>>>()
    };
    let radiosity = read()?;
    Some((radiosity, read()?))
}

/// Keeps what a light's solve for `light` gives: the radiosity per channel (also the next warm
/// start), the light's colour, the leaf indirect irradiance `H − E` per channel.
fn store(solved: &mut SolvedLight, values: LightValues, light: &Light) {
    store_values(solved, values.into_single(), light);
}

/// Per solved channel a light's leaf radiosity, then per channel its leaf indirect irradiance
/// (colour not applied), as the engine keeps them.
type SolvedValues = (Vec<Vec<f32>>, Vec<Vec<f32>>);

/// [`store`] for values already in the engine's f32.
fn store_values(solved: &mut SolvedLight, (radiosity, leaf_indirect): SolvedValues, light: &Light) {
    (solved.radiosity, solved.leaf_indirect) = (radiosity, leaf_indirect);
    solved.color = light.color;
    solved.solved_for = Some((light.curve.clone(), light.aim, light.dimmer));
    solved.estimate = None;
    solved.revision = next_revision();
}

/// One light's leaf radiosity and leaf indirect irradiance in linear RGB, read from its
/// per-channel solution and colour (kept once, in the engine: receiver sets sum them without
/// copies).
#[derive(Debug, Clone, Copy)]
pub struct LeafRadiosity<'a> {
    /// Per solved channel, one value per leaf (lm/m², colour not applied); empty before the
    /// light's first solve.
    channels: &'a [Vec<f32>],
    /// Per solved channel, the leaves' indirect irradiance `H − E` (lx, colour not applied);
    /// empty or zero before the light's first solve.
    indirect: &'a [Vec<f32>],
    /// The light's colour (linear RGB).
    color: [f64; 3],
}

impl LeafRadiosity<'_> {
    /// Adds the light's leaf radiosity (lm/m², linear RGB, colour applied) to `sum`, one entry
    /// per leaf; adds nothing before its first solve.
    pub fn add_to(&self, sum: &mut [[f64; 3]]) {
        add_coloured(self.channels, self.color, sum);
    }

    /// Adds the light's leaf indirect irradiance (lx, linear RGB, colour applied) to `sum`, one
    /// entry per leaf; adds nothing before its first solve.
    pub fn add_indirect_to(&self, sum: &mut [[f64; 3]]) {
        add_coloured(self.indirect, self.color, sum);
    }

    /// The light's leaf radiosity (lm/m², linear RGB, colour applied) over `n_leaves` leaves.
    pub fn values(&self, n_leaves: usize) -> Vec<[f64; 3]> {
        let mut values = vec![[0.0; 3]; n_leaves];
        self.add_to(&mut values);
        values
    }
}

/// Adds per-channel leaf values `channels` (colour not applied; one channel stands for all
/// three, none adds nothing) times `color` to `sum`, one entry per leaf.
fn add_coloured(channels: &[Vec<f32>], color: [f64; 3], sum: &mut [[f64; 3]]) {
    let Some(last) = channels.len().checked_sub(1) else {
        return;
    };
    for (p, b) in sum.iter_mut().enumerate() {
        (0..3).for_each(|ch| b[ch] += color[ch] * f64::from(channels[ch.min(last)][p]));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn room() -> Scene {
        let text = r#"version = 1
[room]
size = [4.0, 3.0, 2.5]
[room.reflectance]
floor = 0.3
walls = 0.6
ceiling = 0.8
[[light]]
name = "l"
position = [2.1, 1.4, 1.7]
lid = [[0, 800], [60, 500], [120, 300], [180, 100]]
[[light]]
name = "m"
position = [1.0, 1.0, 1.5]
lid = [[0, 300], [90, 300], [180, 0]]
[settings]
solver_patch_size = 0.5
"#;
        crate::scene::load::test_room(text)
    }

    fn build(scene: &Scene) -> HierarchicalIndirect {
        HierarchicalIndirect::build(
            scene,
            &scene.lights,
            1,
            false,
            1e-6,
            &InterreflectionOptions::default(),
        )
        .expect("solves")
    }

    /// Light `i`'s leaf radiosity (linear RGB, colour applied).
    fn radiosity(engine: &HierarchicalIndirect, i: usize) -> Vec<[f64; 3]> {
        engine.light_radiosity(i).values(engine.n_leaves())
    }

    /// Light 0's leaf radiosity (first channel) in a fresh engine of `scene`.
    fn fresh_radiosity(scene: &Scene) -> Vec<f64> {
        radiosity(&build(scene), 0).iter().map(|b| b[0]).collect()
    }

    fn max_difference(a: &[f64], b: &[f64]) -> f64 {
        a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
    }

    fn peak_difference(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x[0] - y[0]).abs())
            .fold(0.0, f64::max)
    }

    /// Light 0 of `engine` equals light 0 of a fresh engine of `scene` within the tolerance: its
    /// leaf radiosity and its indirect light at the fine vertices.
    fn assert_matches_fresh(engine: &HierarchicalIndirect, scene: &Scene, what: &str) {
        let fresh = build(scene);
        let peak = radiosity(&fresh, 0).iter().map(|b| b[0]).fold(0.0, f64::max);
        assert!(peak > 0.0, "{what}");
        let difference = peak_difference(&radiosity(engine, 0), &radiosity(&fresh, 0));
        assert!(difference < 1e-5 * peak, "{what}: {difference} of {peak}");
        let fresh_indirect = fresh.vertex_indirect(0);
        let peak = fresh_indirect.iter().map(|v| v[0]).fold(0.0, f64::max);
        let difference = peak_difference(&engine.vertex_indirect(0), &fresh_indirect);
        assert!(
            difference < 1e-5 * peak,
            "{what}: vertices {difference} of {peak}"
        );
    }

    /// The first edit of a control point's intensity is solved with a column for that point; later
    /// edits of the points with a column need no solve, at any dimmer, and equal a fresh engine of
    /// the edited room within the tolerance; an edit of another point adds its column and keeps
    /// the others; a γ edit, a move away and back and a re-aim are solved.
    #[test]
    fn intensity_edits_after_a_curve_edit_need_no_solve() {
        let scene = room();
        let mut engine = build(&scene);
        let mut edited = scene.clone();
        let scale = |edited: &mut Scene, point: usize, factor: f64| {
            let curve = &mut edited.lights[0].curve;
            let candela = curve.intensities_cd()[point] * factor;
            curve.set_intensity(point, candela).expect("a valid intensity");
        };
        let solve = |engine: &mut HierarchicalIndirect, edited: &Scene, what: &str| {
            let job = engine
                .update_light(0, &edited.lights[0])
                .unwrap_or_else(|| panic!("{what}: a solve"));
            assert!(engine.install(0, job.run().expect("solves")), "{what}");
            assert_matches_fresh(engine, edited, what);
        };
        let blend = |engine: &mut HierarchicalIndirect, edited: &Scene, what: &str| {
            assert!(
                engine.update_light(0, &edited.lights[0]).is_none(),
                "{what}: no solve"
            );
            assert_matches_fresh(engine, edited, what);
        };
        scale(&mut edited, 1, 1.5);
        solve(&mut engine, &edited, "point 1 first");
        scale(&mut edited, 1, 0.5);
        blend(&mut engine, &edited, "point 1 again");
        scale(&mut edited, 3, 0.0);
        solve(&mut engine, &edited, "point 3 first");
        scale(&mut edited, 1, 3.0);
        blend(&mut engine, &edited, "point 1 after point 3");
        edited.lights[0].curve.set_intensity(3, 40.0).expect("valid");
        blend(&mut engine, &edited, "point 3 again");
        edited.lights[0].dimmer = 0.5;
        blend(&mut engine, &edited, "dimmed");
        scale(&mut edited, 1, 0.8);
        blend(&mut engine, &edited, "point 1 dimmed");
        scale(&mut edited, 2, 1.2);
        solve(&mut engine, &edited, "point 2 first, dimmed");
        for point in 1..4 {
            scale(&mut edited, point, 0.9);
        }
        blend(&mut engine, &edited, "every point held");
        edited.lights[0].curve =
            Curve::new(&[(0.0, 900.0), (40.0, 700.0), (90.0, 400.0), (180.0, 50.0)]).expect("a curve");
        solve(&mut engine, &edited, "new angles");
        edited.lights[0].curve.set_intensity(0, 950.0).expect("valid");
        solve(&mut engine, &edited, "point 0 at the new angles");
        edited.lights[0].curve.set_intensity(0, 500.0).expect("valid");
        blend(&mut engine, &edited, "point 0 again at the new angles");
        // Moved away and back: the response fits the light again, but the engine's light stands
        // elsewhere, so the way back is a solve that puts it where it is.
        let home = edited.lights[0].clone();
        let away = Light {
            position: home.position + DVec3::new(0.2, 0.0, 0.0),
            ..home.clone()
        };
        engine.set_light(0, &away).expect("solves");
        let back = engine.update_light(0, &home).expect("moving back is solved");
        let solved = back.run().expect("solves");
        assert!(engine.install(0, solved));
        assert!(engine.light_is_at(0, home.position, home.radius));
        edited.lights[0].aim = DVec3::new(0.3, 0.0, -1.0).normalize();
        assert!(
            engine.update_light(0, &edited.lights[0]).is_some(),
            "a re-aim is solved"
        );
    }

    /// A light's curve response is grown once a curve edit solved it where it stands (or from
    /// nothing when asked to start, from the curve's peak), a few columns a step, the points
    /// nearest those held first, until every control point has one; then an edit of every point's intensity needs no solve and equals a fresh engine of
    /// the edited room. A grown step is not kept once the light has changed since it was asked.
    #[test]
    fn a_grown_response_answers_every_curve_edit_without_a_solve() {
        let mut scene = room();
        scene.lights[0].curve = Curve::new(&[
            (0.0, 900.0),
            (20.0, 850.0),
            (40.0, 700.0),
            (60.0, 500.0),
            (90.0, 300.0),
            (130.0, 150.0),
            (180.0, 60.0),
        ])
        .expect("a curve");
        let mut engine = build(&scene);
        let mut edited = scene.clone();
        assert!(
            engine.grow_response(0, &edited.lights[0], false).is_none(),
            "nothing to grow before a curve edit"
        );
        // Started for a selected light that was never edited: the points nearest its peak
        // (point 0), then an edit of those needs no solve.
        let mut started = engine.clone();
        let job = started
            .grow_response(0, &edited.lights[0], true)
            .expect("a step started");
        assert_eq!(
            job.response.as_ref().expect("a response step").points,
            vec![0, 1, 2, 3]
        );
        assert!(started.install_response(0, job.run().expect("solves")));
        let mut reshaped = edited.clone();
        for point in 0..4 {
            let curve = &mut reshaped.lights[0].curve;
            let candela = 0.8 * curve.intensities_cd()[point];
            curve.set_intensity(point, candela).expect("valid");
        }
        assert!(
            started.update_light(0, &reshaped.lights[0]).is_none(),
            "held: no solve"
        );
        assert_matches_fresh(&started, &reshaped, "the points of a started response edited");
        edited.lights[0].curve.set_intensity(2, 800.0).expect("valid");
        engine.set_light(0, &edited.lights[0]).expect("solves");
        // A step asked for the light as it is, then the light dimmed: the step is not kept.
        let stale = engine.grow_response(0, &edited.lights[0], false).expect("a step");
        let dimmed = Light {
            dimmer: 0.5,
            ..edited.lights[0].clone()
        };
        assert!(
            engine.grow_response(0, &dimmed, false).is_none(),
            "not the light's state"
        );
        assert!(
            engine.update_light(0, &dimmed).is_none(),
            "a dimmer change scales"
        );
        assert!(!engine.install_response(0, stale.run().expect("solves")));
        edited.lights[0].dimmer = 0.5;
        let mut steps = Vec::new();
        while let Some(job) = engine.grow_response(0, &edited.lights[0], false) {
            steps.push(job.response.as_ref().expect("a response step").points.clone());
            assert!(engine.install_response(0, job.run().expect("solves")));
        }
        assert_eq!(steps, vec![vec![1, 3, 0, 4], vec![5, 6]]);
        for point in 0..7 {
            let curve = &mut edited.lights[0].curve;
            let candela = curve.intensities_cd()[point] * (0.4 + 0.2 * point as f64);
            curve.set_intensity(point, candela).expect("valid");
        }
        assert!(
            engine.update_light(0, &edited.lights[0]).is_none(),
            "every point held: no solve"
        );
        assert_matches_fresh(&engine, &edited, "every point edited from the grown response");
        assert!(
            engine.grow_response(0, &edited.lights[0], false).is_none(),
            "complete"
        );
    }

    /// With estimates on, a light's first solve builds its SH response; a later re-aim, curve
    /// edit or raise of the whole curve is then estimated at once — much closer to its solve
    /// than the values before, and for the raise (a change of degree 0) equal to it within the
    /// response's tolerance — until the solve lands and replaces the estimate. A return to the
    /// solved state needs no solve and shows the solved values again.
    #[test]
    fn edits_are_estimated_until_their_solve_lands() {
        let scene = room();
        let mut engine = build(&scene);
        engine.set_estimates(Some(ESTIMATE_ORDER));
        let mut solved_scene = scene.clone();
        solved_scene.lights[0].aim = DVec3::new(0.2, 0.1, -1.0).normalize();
        let job = engine
            .update_light(0, &solved_scene.lights[0])
            .expect("a re-aim is solved");
        assert!(!engine.is_estimated(0), "no response yet to estimate from");
        assert!(engine.install(0, job.run().expect("solves")));
        assert!(engine.lights[0].sh_response.is_some(), "the solve built it");
        let solved = engine.vertex_indirect(0);
        let reaim = |l: &mut Light| l.aim = DVec3::new(-0.4, 0.3, -1.0).normalize();
        let reshape = |l: &mut Light| *l = measured_curve_edit(l);
        let raise = |l: &mut Light| {
            for k in 0..l.curve.len() {
                let candela = l.curve.intensities_cd()[k] + 150.0;
                l.curve.set_intensity(k, candela).expect("valid");
            }
        };
        type Edit<'a> = &'a dyn Fn(&mut Light);
        let edits: [(&str, Edit, f64); 3] = [
            ("re-aim", &reaim, 0.25),
            ("curve edit", &reshape, 0.25),
            ("raise", &raise, 1e-3),
        ];
        for (what, edit, most) in edits {
            let mut edited = solved_scene.clone();
            edit(&mut edited.lights[0]);
            let job = engine
                .update_light(0, &edited.lights[0])
                .unwrap_or_else(|| panic!("{what}: a solve"));
            assert!(engine.is_estimated(0), "{what}");
            let fresh = build(&edited).vertex_indirect(0);
            let (estimate, before) = (
                peak_difference(&engine.vertex_indirect(0), &fresh),
                peak_difference(&solved, &fresh),
            );
            assert!(
                estimate < most * before,
                "{what}: the estimate is {estimate} from the solve, the values before {before}"
            );
            // Back to the solved state: no solve, the solved values again.
            assert!(
                engine.update_light(0, &solved_scene.lights[0]).is_none(),
                "{what}"
            );
            assert!(!engine.is_estimated(0), "{what}");
            assert_eq!(engine.vertex_indirect(0), solved, "{what}");
            drop(job);
        }
        // Two edits, each with its solve; the older solve lands first and the later edit's
        // estimate is made again from it; the later solve replaces that.
        let mut edited = solved_scene.clone();
        reaim(&mut edited.lights[0]);
        let older = engine.update_light(0, &edited.lights[0]).expect("a solve");
        edited.lights[0].aim = DVec3::new(0.1, -0.3, -1.0).normalize();
        let newer = engine.update_light(0, &edited.lights[0]).expect("a solve");
        assert!(engine.install(0, older.run().expect("solves")));
        assert!(engine.is_estimated(0), "the later edit is still estimated");
        assert_eq!(
            engine.lights[0].estimate.as_ref().map(|e| e.light.aim),
            Some(edited.lights[0].aim)
        );
        assert!(engine.install(0, newer.run().expect("solves")));
        assert!(!engine.is_estimated(0), "the solve replaced the estimate");
        assert_matches_fresh(&engine, &edited, "re-aimed twice, solved");
    }

    /// A re-aim's solve starts from the old radiosity with its first reflection brought up to
    /// date: that start is much closer to the new solution than the old radiosity is, and the
    /// solve from it ends at a fresh engine's answer.
    #[test]
    fn a_warm_start_takes_the_first_reflection_along() {
        let scene = room();
        let mut engine = build(&scene);
        let mut reaimed = scene.clone();
        reaimed.lights[0].aim = DVec3::new(0.6, 0.2, -1.0).normalize();
        let job = engine
            .update_light(0, &reaimed.lights[0])
            .expect("a re-aim is solved");
        let cache = job.cache.clone().expect("the light kept its direct cache");
        let e = cache.emission(&LightState::from(&reaimed.lights[0]));
        let old = [PatchColumns {
            values: radiosity(&engine, 0).iter().map(|b| b[0]).collect(),
            ..e
        }];
        let start = warm_start(&job.engine, &job.indirect, &e).expect("a start");
        let new = fresh_radiosity(&reaimed);
        let (from_old, from_start) = (
            max_difference(&old[0].values, &new),
            max_difference(&start[0].values, &new),
        );
        assert!(
            from_start < 0.2 * from_old,
            "the start is {from_start} from the solution, the old radiosity {from_old}"
        );
        assert!(engine.install(0, job.run().expect("solves")));
        assert_matches_fresh(&engine, &reaimed, "re-aimed");
    }

    /// The test room's engine with the SH estimates on, light 0 re-aimed once and solved (which
    /// builds its SH response); that scene, and the scene with light 0 aimed elsewhere again.
    fn estimating_engine_reaimed_once() -> (HierarchicalIndirect, Scene, Scene) {
        let scene = room();
        let mut engine = build(&scene);
        engine.set_estimates(Some(ESTIMATE_ORDER));
        let mut first = scene.clone();
        first.lights[0].aim = DVec3::new(0.2, 0.1, -1.0).normalize();
        engine.set_light(0, &first.lights[0]).expect("solves");
        let mut reaimed = first.clone();
        reaimed.lights[0].aim = DVec3::new(-0.4, 0.3, -1.0).normalize();
        (engine, first, reaimed)
    }

    /// With the estimates on, a re-aim's solve starts from the estimate of the new aim, not from
    /// the values solved for the old one: a start nearer the solution (fewer GMRES steps), and
    /// the solve from it ends at a fresh engine's answer.
    #[test]
    fn a_re_aims_solve_starts_from_its_estimate() {
        let (mut engine, _, reaimed) = estimating_engine_reaimed_once();
        let solved = engine.lights[0].leaf_indirect.clone();
        let job = engine
            .update_light(0, &reaimed.lights[0])
            .expect("a re-aim is solved");
        let estimate = engine.lights[0].estimate.as_ref().expect("an estimate");
        assert_eq!(job.indirect, estimate.leaf_indirect);
        let cache = job.cache.clone().expect("the light kept its direct cache");
        let e = cache.emission(&LightState::from(&reaimed.lights[0]));
        let new = fresh_radiosity(&reaimed);
        let distance = |indirect: &[Vec<f32>]| {
            let start = warm_start(&job.engine, indirect, &e).expect("a start");
            max_difference(&start[0].values, &new)
        };
        let (from_estimate, from_solved) = (distance(&job.indirect), distance(&solved));
        assert!(
            from_estimate < 0.25 * from_solved,
            "from the estimate {from_estimate}, from the solved values {from_solved}"
        );
        assert!(engine.install(0, job.run().expect("solves")));
        assert_matches_fresh(&engine, &reaimed, "re-aimed from the estimate");
    }

    /// A re-aim prepared before it is asked for lands at once, exact, with no solve; the state
    /// left becomes the prepared one (its undo lands at once too); another aim, or a move, is
    /// solved as before, and a move drops what was prepared.
    #[test]
    fn a_prepared_re_aim_lands_without_a_solve() {
        let (mut engine, first, reaimed) = estimating_engine_reaimed_once();
        let shown = radiosity(&engine, 0);
        assert!(engine.prepare(0, &first.lights[0]).is_none(), "the state shown");
        let job = engine.prepare(0, &reaimed.lights[0]).expect("a job");
        assert!(engine.hold_prepared(0, job.run().expect("solves")));
        assert_eq!(radiosity(&engine, 0), shown, "preparing changes nothing shown");
        assert!(
            engine.prepare(0, &reaimed.lights[0]).is_none(),
            "already prepared"
        );
        assert!(engine.update_light(0, &reaimed.lights[0]).is_none(), "no solve");
        assert!(!engine.is_estimated(0));
        assert_matches_fresh(&engine, &reaimed, "the prepared re-aim");
        // Back to the first aim (an undo): the state left was kept.
        assert!(engine.is_prepared(0, &first.lights[0]));
        assert!(
            engine.update_light(0, &first.lights[0]).is_none(),
            "the undo: no solve"
        );
        assert_eq!(radiosity(&engine, 0), shown);
        assert!(engine.is_prepared(0, &reaimed.lights[0]), "the state left, again");
        // A preparation made where the light stands now, held only after the move below.
        let mut elsewhere = first.clone();
        elsewhere.lights[0].aim = DVec3::new(-0.3, -0.3, -1.0).normalize();
        let stale = engine.prepare(0, &elsewhere.lights[0]).expect("a job");
        // An aim nobody prepared is solved; nothing is prepared while its solve is pending.
        let mut other = first.clone();
        other.lights[0].aim = DVec3::new(0.5, -0.2, -1.0).normalize();
        assert!(engine.update_light(0, &other.lights[0]).is_some());
        assert!(
            engine.prepare(0, &reaimed.lights[0]).is_none(),
            "not while a solve is pending"
        );
        // A move drops the prepared state (and solves anew); once its solve is in, the
        // preparation made on the old place is refused.
        let mut moved = reaimed.clone();
        moved.lights[0].position += DVec3::new(0.1, 0.0, 0.0);
        let job = engine.update_light(0, &moved.lights[0]).expect("a solve");
        assert!(!engine.is_prepared(0, &reaimed.lights[0]));
        assert!(engine.install(0, job.run().expect("solves")));
        assert!(!engine.hold_prepared(0, stale.run().expect("solves")));
    }

    /// An edit of more than [`RESPONSE_POINTS_PER_SOLVE`] points (a new shape) is solved without
    /// adding their columns, and keeps the columns already held: an edit of a held point after it
    /// needs no solve, one of the reshaped points does.
    #[test]
    fn a_new_shape_keeps_the_held_columns_without_adding_its_own() {
        let mut scene = room();
        let points = [
            (0.0, 900.0),
            (15.0, 850.0),
            (30.0, 800.0),
            (45.0, 600.0),
            (60.0, 300.0),
            (90.0, 50.0),
            (180.0, 0.0),
        ];
        scene.lights[0].curve = Curve::new(&points).expect("a curve");
        let mut engine = build(&scene);
        let mut edited = scene.clone();
        let set = |edited: &mut Scene, point: usize, candela: f64| {
            edited.lights[0]
                .curve
                .set_intensity(point, candela)
                .expect("valid");
        };
        set(&mut edited, 2, 700.0);
        let job = engine
            .update_light(0, &edited.lights[0])
            .expect("a first edit is solved");
        assert!(engine.install(0, job.run().expect("solves")));
        for point in [0, 1, 3, 4, 5, 6] {
            let candela = 0.8 * edited.lights[0].curve.intensities_cd()[point];
            set(&mut edited, point, candela);
        }
        let job = engine
            .update_light(0, &edited.lights[0])
            .expect("a new shape is solved");
        assert!(engine.install(0, job.run().expect("solves")));
        assert_matches_fresh(&engine, &edited, "new shape");
        set(&mut edited, 2, 750.0);
        assert!(
            engine.update_light(0, &edited.lights[0]).is_none(),
            "point 2 is held"
        );
        assert_matches_fresh(&engine, &edited, "point 2 after the new shape");
        set(&mut edited, 4, 200.0);
        assert!(
            engine.update_light(0, &edited.lights[0]).is_some(),
            "point 4 has no column"
        );
    }

    /// The block solve at build equals solving each light alone; a dimmer change scales the
    /// light's radiosity exactly (no solve: the solve is linear); a curve edit re-solved from the
    /// previous values equals a fresh engine of the edited room within the tolerance.
    #[test]
    fn edits_match_fresh_engines() {
        let scene = room();
        let engine = build(&scene);
        let mut alone = scene.clone();
        alone.lights.truncate(1);
        let first = build(&alone);
        let peak = radiosity(&engine, 0).iter().map(|b| b[0]).fold(0.0, f64::max);
        assert!(peak > 0.0);
        assert!(peak_difference(&radiosity(&engine, 0), &radiosity(&first, 0)) < 1e-5 * peak);

        let mut edited = engine.clone();
        let dimmed = Light {
            dimmer: 0.25,
            ..scene.lights[1].clone()
        };
        edited.set_light(1, &dimmed).expect("scales");
        for (d, b) in radiosity(&edited, 1).iter().zip(&radiosity(&engine, 1)) {
            assert!((d[0] - 0.25 * b[0]).abs() <= 1e-12 * b[0].abs(), "{d:?} vs {b:?}");
        }

        let curve = Curve::new(&[(0.0, 2000.0), (30.0, 1500.0), (60.0, 0.0)]).expect("a curve");
        let mut changed = scene.clone();
        changed.lights[0].curve = curve;
        edited.set_light(0, &changed.lights[0]).expect("solves");
        let fresh = build(&changed);
        let peak = radiosity(&fresh, 0).iter().map(|b| b[0]).fold(0.0, f64::max);
        assert!(peak_difference(&radiosity(&edited, 0), &radiosity(&fresh, 0)) < 1e-5 * peak);
    }

    /// With a direct-cache budget smaller than two lights' caches, the build keeps one, an edit
    /// rebuilds the edited light's cache in its job and gives the same values as a fresh engine,
    /// and the edit after that drops the cache of the light edited before (the budget holds).
    #[test]
    fn edits_rebuild_dropped_direct_caches_within_the_budget() {
        let scene = room();
        let full = build(&scene);
        let one_cache = full.engine.direct_cache(&scene.lights[0]).bytes();
        let on_budget = |budget| {
            let engine = Arc::clone(&full.engine);
            HierarchicalIndirect::on_engine(engine, &scene, &scene.lights, 1e-6, budget).expect("solves")
        };
        let mut tight = on_budget(one_cache);
        assert!(full.holds_direct_cache(0) && full.holds_direct_cache(1));
        // No budget: the second light's direct light is summed without a cache, to the same
        // values.
        let none = on_budget(0);
        assert!(!none.holds_direct_cache(0) && !none.holds_direct_cache(1));
        for i in 0..2 {
            assert_eq!(radiosity(&none, i), radiosity(&full, i), "light {i}");
        }
        assert!(
            tight.holds_direct_cache(0) && !tight.holds_direct_cache(1),
            "the second cache is over the budget"
        );
        assert_eq!(
            &radiosity(&tight, 1),
            &radiosity(&full, 1),
            "the build's values do not depend on the budget"
        );

        let mut changed = scene.clone();
        changed.lights[1].aim = DVec3::new(0.4, 0.2, -1.0).normalize();
        tight.set_light(1, &changed.lights[1]).expect("solves");
        assert!(
            tight.holds_direct_cache(1) && !tight.holds_direct_cache(0),
            "the cache of the light edited before is dropped"
        );
        let fresh = build(&changed);
        let peak = radiosity(&fresh, 1).iter().map(|b| b[0]).fold(0.0, f64::max);
        assert!(peak > 0.0);
        assert!(peak_difference(&radiosity(&tight, 1), &radiosity(&fresh, 1)) < 1e-5 * peak);

        changed.lights[0].aim = DVec3::new(-0.3, 0.1, -1.0).normalize();
        tight.set_light(0, &changed.lights[0]).expect("solves");
        assert!(tight.holds_direct_cache(0) && !tight.holds_direct_cache(1));
        let fresh = build(&changed);
        let peak = radiosity(&fresh, 0).iter().map(|b| b[0]).fold(0.0, f64::max);
        assert!(peak_difference(&radiosity(&tight, 0), &radiosity(&fresh, 0)) < 1e-5 * peak);
    }

    /// A light whose state was solved before on the same engine is read from the disk cache,
    /// to the same values, and keeps its direct cache as a solved light does (so edits cost
    /// the same); a light with another dimmer (as saved after an edit) is solved and agrees with
    /// a fresh engine, while another colour keeps the entry (values are kept without it). A
    /// damaged entry is solved again with a notice naming it. An engine built without a cache
    /// has no key for them and solves every light.
    #[test]
    fn lights_solved_before_are_read_from_the_cache() {
        let dir = tempfile::tempdir().unwrap();
        let cache = BakeCache::in_dir(dir.path());
        let scene = room();
        // Built with the cache, so that it has a key to file its lights under.
        let options = InterreflectionOptions::default();
        let solver = crate::transport::refine::refine(&scene, &options.refine);
        let (engine, _) =
            Interreflection::build_cached(&scene, solver, 1, false, &options, Some(&cache)).unwrap();
        let engine = Arc::new(engine);
        let open = |scene: &Scene| {
            HierarchicalIndirect::on_engine_cached(
                Arc::clone(&engine),
                scene,
                &scene.lights,
                1e-6,
                DIRECT_CACHE_BUDGET_BYTES,
                Some(&cache),
            )
            .expect("solves")
        };
        let (first, notices) = open(&scene);
        assert!(notices.is_empty(), "{notices:?}");
        assert_eq!(first.stats().lights_from_cache, 0);
        assert_eq!(
            cache.entries().len(),
            1 + 2,
            "the operator's entry and one per light"
        );
        let (second, notices) = open(&scene);
        assert!(notices.is_empty(), "{notices:?}");
        assert_eq!(second.stats().lights_from_cache, 2);
        for i in 0..2 {
            assert_eq!(radiosity(&second, i), radiosity(&first, i), "light {i}");
            assert_eq!(second.vertex_indirect(i), first.vertex_indirect(i), "light {i}");
            assert!(second.holds_direct_cache(i), "light {i}");
        }
        let mut edited = scene.clone();
        edited.lights[0].dimmer = 0.5;
        edited.lights[1].color = [1.0, 0.8, 0.6];
        let (third, _) = open(&edited);
        assert_eq!(third.stats().lights_from_cache, 1);
        let fresh = build(&edited);
        for i in 0..2 {
            let peak = radiosity(&fresh, i).iter().map(|b| b[0]).fold(0.0, f64::max);
            assert!(peak > 0.0);
            let difference = peak_difference(&radiosity(&third, i), &radiosity(&fresh, i));
            assert!(difference < 1e-5 * peak, "light {i}: {difference} of {peak}");
        }
        for entry in cache.entries() {
            let mut bytes = std::fs::read(&entry.path).unwrap();
            let last = bytes.len() - 1;
            bytes[last] ^= 4;
            std::fs::write(&entry.path, bytes).unwrap();
        }
        let unkeyed = HierarchicalIndirect::on_engine_cached(
            Arc::clone(&build(&scene).engine),
            &scene,
            &scene.lights,
            1e-6,
            DIRECT_CACHE_BUDGET_BYTES,
            Some(&cache),
        )
        .expect("solves")
        .0;
        assert_eq!(unkeyed.stats().lights_from_cache, 0);
        let (again, notices) = open(&scene);
        assert_eq!(again.stats().lights_from_cache, 0);
        assert_eq!(notices.len(), 2, "{notices:?}");
        assert!(notices.iter().all(|n| n.contains("checksum")), "{notices:?}");
        for i in 0..2 {
            assert_eq!(radiosity(&again, i), radiosity(&first, i), "light {i}");
        }
    }
}
