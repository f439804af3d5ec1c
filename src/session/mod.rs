//! The headless session: one path from a room file to numbers and pixels. It owns the scene,
//! the plan, the bake, the relighter, the camera and reusable frame buffers; it takes
//! [`Command`]s (plain values: a control point, a curve, an aim, a dimmer, an order, a window,
//! a move, an added or removed light, the camera) and says what changed. `haiko render`,
//! `probe`, `grid`, `pick` and the editor all go through it (docs/ARCHITECTURE.md).
//!
//! Commands only change state; the light is recomputed by [`Session::relight`] (or implicitly by
//! [`Session::render`]), once for any number of queued commands. A light that moves (or whose
//! SH order changes) needs new basis columns: the command yields a [`BakeJob`] that runs on any
//! thread ([`BakeJob::run`]) while the session stays usable — the moved light's direct light is
//! exact at once and its indirect light is the old bake's until [`Session::finish_bake`] installs
//! the new one. Superseded cache entries of a moved light are removed, so the bake cache holds
//! at most one entry per light of a session.
//!
//! ```no_run
//! use haiko::session::{Command, FrameSpec, Session, SessionOptions};
//! use haiko::render::DisplayMode;
//!
//! let mut session = Session::open("rooms/paper.toml".as_ref(), SessionOptions::default(), &mut |_| {})?;
//! session.apply(Command::SetDimmer { light: 0, dimmer: 0.5 })?;
//! let spec = FrameSpec::new((640, 480), DisplayMode::Photo);
//! let frame = session.render(&spec)?;
//! frame.pixmap.save_png("paper.png").expect("written");
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod budget;
pub mod command;
pub mod frame;
pub mod jobs;
pub mod light;
pub mod numbers;
pub mod receivers;
pub mod series;

use std::path::Path;
use std::sync::Arc;

pub use command::{Applied, Change, Command, CommandError, RoomBounds, group_aims};
pub use frame::{ExposureChoice, FrameSpec, MAX_SIDE_PX, PixelHit, ViewChoice, work_plane_height};
pub use jobs::{BakeJob, BakeOutcome};
pub use light::{DEFAULT_ORDER, LightEdit, MAX_ORDER, WindowChoice};
pub use numbers::DesignNumbers;
pub use receivers::{IndirectSource, LightInput, ReceiverSet};
pub use series::Series;

use crate::error::{Error, Result};
use crate::photometry::IncrementalWeights;
use crate::relight::Relighter;
use crate::render;
use crate::scene::{Camera, DirectMode, Light, Scene};
use crate::transport::bake::{
    Bake, BakeOptions, BakedLight, LightBakeSpec, Progress, bake_planned, plan_without_basis,
};
use crate::transport::cache::BakeCache;
use crate::transport::direct::Receiver;
use crate::transport::indirect::{DIRECT_CACHE_BUDGET_BYTES, HierarchicalIndirect, LightSolve};
use crate::transport::interreflection::{Interreflection, InterreflectionOptions};
use crate::transport::occlusion::Occluders;
use crate::transport::plan::{Plan, plan_light};
use crate::transport::refine::refine;
use crate::transport::sh_response::ESTIMATE_ORDER;
use frame::{FrameBuffers, PlaneIndirect};
use jobs::{Done, LightSnapshot, Placed, RegradeJob, Work};

/// How a session is set up.
#[derive(Debug, Clone)]
pub struct SessionOptions {
    /// Plan overrides, solver settings and the bake cache (`bake.cache`; none by default).
    pub bake: BakeOptions,
    /// False for direct light only: no bake, no interreflection (`--direct-only`).
    pub indirect: bool,
    /// True for the editor: the hierarchical engine's solves (an edited light's, or the whole
    /// engine's when a move changes its grading) leave the key path as [`BakeJob`]s, and the light
    /// keeps its previous indirect light — or, for a re-aim or curve edit once its solve built
    /// its SH response, an estimate of the new — until [`Session::finish_bake`] installs the
    /// new one.
    /// False (the CLI): every query waits for its solves.
    pub background_solves: bool,
    /// The memory limit the hierarchical engine's links are made within (what the plan's
    /// estimate leaves of it, [`budget::Estimate::max_links`]); `None`: no limit.
    pub memory_limit: Option<budget::MemoryLimit>,
}

impl Default for SessionOptions {
    fn default() -> Self {
        SessionOptions {
            bake: BakeOptions::default(),
            indirect: true,
            background_solves: false,
            memory_limit: None,
        }
    }
}

impl SessionOptions {
    /// For the editor: the same engines as the CLI, with the hierarchical engine's solves off
    /// the key path ([`SessionOptions::background_solves`]).
    pub fn interactive(mut self) -> Self {
        self.background_solves = true;
        self
    }

    /// The degree of the SH responses the hierarchical engine builds for estimates of re-aims
    /// and curve edits while their solves run: [`ESTIMATE_ORDER`] with background solves (the
    /// editor), none otherwise (every query waits for its solve).
    fn estimate_order(&self) -> Option<usize> {
        self.background_solves.then_some(ESTIMATE_ORDER)
    }

    /// Indirect light, with the user's bake cache ([`BakeCache::user`]).
    pub fn with_user_cache() -> Self {
        SessionOptions {
            bake: BakeOptions {
                cache: Some(BakeCache::user()),
                ..BakeOptions::default()
            },
            ..SessionOptions::default()
        }
    }
}

/// A light's identity within a session: indices shift when lights are inserted or removed,
/// ids do not.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct LightId(u64);

/// Whether a light's result is final.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LightStatus {
    /// Its direct and indirect light are up to date.
    Ready,
    /// It moved (or its order changed) and its new bake is pending: the direct light is exact,
    /// the indirect light is the previous bake's.
    Updating,
}

/// What of a light must be recomputed at the next [`Session::relight`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
struct Dirty {
    state: bool,
    moved: bool,
}

/// The session's bookkeeping of one light.
#[derive(Debug, Clone)]
struct LightSlot {
    id: LightId,
    /// The curve's Legendre weights at the light's order, kept current edit by edit.
    weights: IncrementalWeights,
    dirty: Dirty,
    /// Generation of the latest bake asked for; `installed` is the one in use.
    generation: u64,
    installed: u64,
    /// Cache key of the installed bake.
    key: Option<u64>,
    /// Bumped whenever anything the light's illuminance depends on changes (its state, its
    /// position, its installed bake): receiver sets recompute a light whose version moved.
    version: u64,
    /// The version the hierarchical engine last solved the light for.
    solved: u64,
    /// Bumped by every command that changes the light (not by installed results): what a
    /// rebuilt engine checks to know whether the light changed after it was queued.
    edits: u64,
    /// The engine's revision of the light's values that the relighter holds (0: none).
    given: u64,
}

impl LightSlot {
    /// The light was brought up to date at once (a scaling, its response, back to its solved
    /// state): work queued or running for an older state of it must not land.
    fn settle(&mut self) {
        self.generation += 1;
        self.installed = self.generation;
    }
}

/// The headless engine under the CLI and the editor.
#[derive(Debug)]
pub struct Session {
    scene: Scene,
    /// True when `scene.lights` lag behind `lights`.
    scene_lights_stale: bool,
    lights: Vec<LightEdit>,
    slots: Vec<LightSlot>,
    next_id: u64,
    camera: Camera,
    bounds: RoomBounds,
    options: SessionOptions,
    bake: Option<Bake>,
    /// The hierarchical indirect engine with every light solved, when the plan chose it
    /// (docs/DECISIONS.md "Interreflection").
    hierarchical: Option<HierarchicalIndirect>,
    /// A failed solve of the hierarchical engine, reported by the next render or query.
    indirect_failure: Option<Error>,
    /// A light was added or removed: the hierarchical engine's grading is checked at the next
    /// solve.
    regrade: bool,
    /// Regrades queued so far, and the one pending (its number), in background mode: while one
    /// is pending no light is solved on the old engine.
    regrades: u64,
    regrading: Option<u64>,
    relighter: Option<Relighter>,
    /// Bumped whenever the fine-vertex illuminance changes.
    illuminance_version: u64,
    jobs: Vec<BakeJob>,
    /// The light whose idle work (a step of growing its curve response, or a prepared state) is
    /// running, and its generation then ([`Session::queue_idle_work`]); stale once that
    /// generation moved on.
    idle: Option<(LightId, u64)>,
    /// The states lights may be brought to next, to solve while the editor is idle, in the
    /// order asked ([`Session::prepare`]).
    wanted: Vec<(LightId, Light)>,
    /// The light whose last idle work (a growth step or a prepared state) failed, and its
    /// generation then: not grown again until it changes (a failing step would otherwise be
    /// asked again at every batch).
    growth_failed: Option<(LightId, u64)>,
    buffers: FrameBuffers,
    /// The furniture that casts shadows (the bake's, else built on first need); `None` inside
    /// when nothing occludes.
    occluders: Option<Option<Arc<Occluders>>>,
    /// Receiver sets kept lit edit by edit ([`Session::watch`]).
    watches: Vec<(WatchId, ReceiverSet)>,
    next_watch: u64,
    /// The calculation grids and observers' eyes behind [`Session::design_numbers`].
    design: Option<numbers::DesignWatch>,
}

/// A receiver set the session keeps lit ([`Session::watch`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct WatchId(u64);

/// Receivers per set when [`Session::illuminance_at`] evaluates many points at once (bounds the
/// memory of the gather factors).
const RECEIVERS_PER_CHUNK: usize = 4096;

/// What a receiver set needs of each light, in order (a free function so that it borrows only
/// these fields).
fn light_inputs<'a>(
    lights: &'a [LightEdit],
    slots: &'a [LightSlot],
    bake: Option<&'a Bake>,
    hierarchical: Option<&'a HierarchicalIndirect>,
) -> Vec<LightInput<'a>> {
    lights
        .iter()
        .zip(slots)
        .enumerate()
        .map(|(i, (light, slot))| LightInput {
            light,
            weights: slot.weights.weights(),
            baked: bake.map(|b| &b.lights[i]),
            radiosity: hierarchical.map(|h| h.light_radiosity(i)),
            version: slot.version,
        })
        .collect()
}

/// The lights of `scene` as a session starts them: the room file's values, each light's order
/// the file's or else the plan's choice.
pub fn initial_lights(scene: &Scene, plan: &Plan) -> Vec<LightEdit> {
    scene
        .lights
        .iter()
        .zip(&plan.lights)
        .map(|(light, lp)| LightEdit {
            order: lp.order.min(MAX_ORDER),
            ..LightEdit::from_light(light)
        })
        .collect()
}

impl Session {
    /// Loads the room file at `path` and starts a session on it ([`Session::new`]).
    ///
    /// Errors: the room file (bad input), the bake (internal).
    pub fn open(path: &Path, options: SessionOptions, progress: &mut dyn FnMut(Progress)) -> Result<Session> {
        Session::new(crate::scene::load(path)?, options, progress)
    }

    /// Plans `scene` and, unless `options.indirect` is false, computes its indirect light: with
    /// the hierarchical engine when the plan chose it (every light solved now), else by baking
    /// the SH basis (from the cache when valid), reporting progress. The relighter is built on
    /// first need.
    ///
    /// Errors: more links than `options.memory_limit` leaves room for (bad input), the
    /// interreflection solve failing (internal).
    pub fn new(scene: Scene, options: SessionOptions, progress: &mut dyn FnMut(Progress)) -> Result<Session> {
        let t = std::time::Instant::now();
        let (planned, graded) = crate::transport::plan::plan_graded(&scene, options.bake.plan);
        let plan_s = t.elapsed().as_secs_f64();
        let mut hierarchical = None;
        let (bake, plan) = if options.indirect && planned.hierarchical.on {
            let mut bake = plan_without_basis(&scene, planned.clone(), plan_s, &options.bake);
            progress(Progress {
                stage: "interreflection engine",
                done: 0,
                total: 1,
            });
            // The engine is built on the plan's graded mesh (the default refinement, which the
            // engine's options keep) instead of refining the room again.
            let engine_options = InterreflectionOptions {
                max_links: options
                    .memory_limit
                    .map(|limit| budget::Estimate::of(&planned, true).max_links(&limit)),
                ..InterreflectionOptions::for_leaves(planned.leaves)
            };
            let solver = graded.unwrap_or_else(|| refine(&scene, &engine_options.refine));
            let (engine, notices) = Interreflection::build_cached(
                &scene,
                solver,
                planned.channels,
                planned.visibility.on,
                &engine_options,
                options.bake.cache.as_ref(),
            )?;
            bake.notices.extend(notices);
            let (mut engine, notices) = HierarchicalIndirect::on_engine_cached(
                Arc::new(engine),
                &scene,
                &scene.lights,
                options.bake.tolerance.unwrap_or(scene.settings.tolerance),
                DIRECT_CACHE_BUDGET_BYTES,
                options.bake.cache.as_ref(),
            )?;
            bake.notices.extend(notices);
            engine.set_estimates(options.estimate_order());
            hierarchical = Some(engine);
            progress(Progress {
                stage: "interreflection engine",
                done: 1,
                total: 1,
            });
            (Some(bake), planned)
        } else if options.indirect {
            let mut bake = bake_planned(&scene, planned, &options.bake, progress)?;
            bake.timings.plan_s = plan_s;
            let plan = bake.plan.clone();
            (Some(bake), plan)
        } else {
            (None, planned)
        };
        let lights = initial_lights(&scene, &plan);
        let slots = lights
            .iter()
            .enumerate()
            .map(|(i, light)| LightSlot {
                id: LightId(i as u64),
                weights: IncrementalWeights::new(light.curve.clone(), light.order),
                dirty: Dirty::default(),
                generation: 0,
                installed: 0,
                version: 1,
                solved: 1,
                edits: 0,
                given: 0,
                key: bake.as_ref().map(|b| {
                    b.transport
                        .light_key(&LightBakeSpec::new(&scene.lights[i], &b.plan.lights[i]))
                }),
            })
            .collect();
        Ok(Session {
            camera: scene.camera,
            bounds: RoomBounds::of(&scene),
            next_id: lights.len() as u64,
            scene_lights_stale: false,
            scene,
            lights,
            slots,
            options,
            bake,
            hierarchical,
            indirect_failure: None,
            regrade: false,
            regrades: 0,
            regrading: None,
            relighter: None,
            illuminance_version: 0,
            jobs: Vec::new(),
            idle: None,
            wanted: Vec::new(),
            growth_failed: None,
            buffers: FrameBuffers::default(),
            occluders: None,
            watches: Vec::new(),
            next_watch: 0,
            design: None,
        })
    }

    /// The room's geometry, surfaces and settings. Its `lights` are as loaded; the current ones
    /// are [`Session::lights`].
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The lights as the commands left them, in order.
    pub fn lights(&self) -> &[LightEdit] {
        &self.lights
    }

    /// The id of light `i`.
    pub fn light_id(&self, i: usize) -> Option<LightId> {
        self.slots.get(i).map(|s| s.id)
    }

    /// The index of the light with id `id`, if it still exists.
    pub fn light_index(&self, id: LightId) -> Option<usize> {
        self.slots.iter().position(|s| s.id == id)
    }

    /// The preview camera.
    pub fn camera(&self) -> Camera {
        self.camera
    }

    /// The bake (plan, transport, per-light basis), unless the session is direct-only.
    pub fn bake(&self) -> Option<&Bake> {
        self.bake.as_ref()
    }

    /// Whether light `i`'s result is final or a bake for it is pending.
    pub fn light_status(&self, i: usize) -> LightStatus {
        let slot = &self.slots[i];
        // While a regrade is out every light's values may still change (a rebuilt engine).
        if slot.generation == slot.installed && self.regrading.is_none() {
            LightStatus::Ready
        } else {
            LightStatus::Updating
        }
    }

    /// Applies `command`, or refuses it and changes nothing. The light is recomputed at the next
    /// [`Session::relight`]; a move, an order change or an inserted light queue a [`BakeJob`]
    /// ([`Session::take_bake_jobs`]).
    pub fn apply(&mut self, command: Command) -> std::result::Result<Applied, CommandError> {
        let applied = command.apply(&mut self.lights, &mut self.camera, &self.bounds)?;
        if let Some(slot) = applied.change.light().and_then(|i| self.slots.get_mut(i)) {
            slot.version += 1;
            slot.edits += 1;
            // The states wished for were the lights as they stood ([`Session::prepare`]).
            self.wanted.clear();
        }
        match applied.change {
            Change::Point { light, point } => {
                let slot = &mut self.slots[light];
                let curve = &self.lights[light].curve;
                // The model's curve already holds the new value; the weights follow in O(N).
                let synced = match command {
                    Command::SetIntensity { .. } => {
                        slot.weights.set_intensity(point, curve.intensities_cd()[point])
                    }
                    _ => slot.weights.set_gamma(point, curve.gammas_deg()[point]),
                };
                if synced.is_err() {
                    slot.weights = IncrementalWeights::new(curve.clone(), self.lights[light].order);
                }
                slot.dirty.state = true;
            }
            Change::Curve { light } => {
                self.slots[light].weights =
                    IncrementalWeights::new(self.lights[light].curve.clone(), self.lights[light].order);
                self.slots[light].dirty.state = true;
            }
            Change::Aim { light } | Change::Dimmer { light } | Change::Window { light } => {
                self.slots[light].dirty.state = true;
            }
            Change::Order { light } => {
                self.slots[light].weights =
                    IncrementalWeights::new(self.lights[light].curve.clone(), self.lights[light].order);
                self.slots[light].dirty.state = true;
                self.queue_bake(light);
            }
            Change::Moved { light } => {
                self.slots[light].dirty = Dirty {
                    state: true,
                    moved: true,
                };
                self.queue_bake(light);
            }
            Change::Inserted { at } => self.insert_slot(at),
            Change::Removed { at } => self.remove_slot(at),
            Change::Camera => {}
        }
        self.scene_lights_stale |= applied.change != Change::Camera;
        Ok(applied)
    }

    /// Queues a bake of light `i` for its current position and order (replacing a queued one).
    /// The hierarchical engine needs none: it re-solves the light at the next relight.
    fn queue_bake(&mut self, i: usize) {
        let Some(bake) = self.bake.as_ref().filter(|_| self.hierarchical.is_none()) else {
            return;
        };
        let light = self.lights[i].to_light();
        let spec = LightBakeSpec::new(&light, &plan_light(&self.scene, &light, self.options.bake.plan));
        let slot = &mut self.slots[i];
        slot.generation += 1;
        let job = BakeJob {
            light: Some(slot.id),
            name: light.name,
            generation: slot.generation,
            work: Work::Basis {
                transport: Arc::clone(&bake.transport),
                spec,
                cache: self.options.bake.cache.clone(),
            },
        };
        self.push_job(job);
    }

    /// Queues `job`, replacing a queued one for the same light (or engine).
    fn push_job(&mut self, job: BakeJob) {
        self.jobs.retain(|j| j.light != job.light);
        self.jobs.push(job);
    }

    fn insert_slot(&mut self, at: usize) {
        self.each_receiver_set(|set| set.insert_light(at));
        let light = &self.lights[at];
        let id = LightId(self.next_id);
        self.next_id += 1;
        self.slots.insert(
            at,
            LightSlot {
                id,
                weights: IncrementalWeights::new(light.curve.clone(), light.order),
                dirty: Dirty::default(),
                generation: 0,
                installed: 0,
                key: None,
                version: 1,
                // Solved below (or never, without the hierarchical engine).
                solved: 1,
                edits: 0,
                given: 0,
            },
        );
        if let Some(h) = &mut self.hierarchical {
            // Solved (or the engine regraded) at the next solve; the relighter gets its
            // indirect light at the next relight.
            h.insert_light(at, &light.to_light());
            self.slots[at].solved = 0;
            self.slots[at].dirty.state = true;
            self.regrade = true;
        }
        let scene_light = light.to_light();
        if let Some(bake) = &mut self.bake {
            let lp = plan_light(&self.scene, &scene_light, self.options.bake.plan);
            // Until its bake arrives the light has no indirect light.
            bake.lights.insert(at, BakedLight::without_indirect(&lp));
            bake.plan.lights.insert(at, lp);
        }
        if let Some(relighter) = &mut self.relighter {
            let baked = self.bake.as_ref().map(|b| b.lights[at].clone());
            relighter.insert_light(at, &scene_light, baked);
            self.illuminance_version += 1;
        }
        self.queue_bake(at);
    }

    fn remove_slot(&mut self, at: usize) {
        let slot = self.slots.remove(at);
        self.each_receiver_set(|set| set.remove_light(at));
        self.jobs.retain(|j| j.light != Some(slot.id));
        if let Some(h) = &mut self.hierarchical {
            h.remove_light(at);
            self.regrade = true;
        }
        if let Some(bake) = &mut self.bake {
            bake.lights.remove(at);
            bake.plan.lights.remove(at);
        }
        if let Some(relighter) = &mut self.relighter {
            relighter.remove_light(at);
            self.illuminance_version += 1;
        }
        if let Some(key) = slot.key {
            self.forget_cache_entry(key);
        }
    }

    /// Removes the cache entry `key` unless a light of the session still uses it.
    fn forget_cache_entry(&self, key: u64) {
        if let Some(cache) = &self.options.bake.cache
            && !self.slots.iter().any(|s| s.key == Some(key))
        {
            cache.remove(key);
        }
    }

    /// Asks for the states `commands` would bring their lights to — the aims under the
    /// editor's aim cursor, of the selected light and of the rest of its group — to be solved
    /// while the editor is idle ([`Session::queue_idle_work`]), in this order, so that the
    /// commands, when they come, land exact at once instead of as an estimate followed by a
    /// solve (docs/DECISIONS.md "Re-aims prepared where the aim cursor rests"). The commands
    /// are applied in turn to a copy of the lights (a group's re-aims, one per light). Changes
    /// nothing shown; replaces the earlier wishes. Returns how many states were asked for: none
    /// without the hierarchical engine, and none for anything but valid re-aims.
    pub fn prepare(&mut self, commands: &[Command]) -> usize {
        self.wanted.clear();
        if self.hierarchical.is_none() {
            return 0;
        }
        let mut lights = self.lights.clone();
        let mut camera = self.camera;
        for command in commands {
            if !matches!(command, Command::Aim { .. }) {
                continue;
            }
            let Ok(applied) = command.apply(&mut lights, &mut camera, &self.bounds) else {
                continue;
            };
            if let Some(i) = applied.change.light() {
                self.wanted.push((self.slots[i].id, lights[i].to_light()));
            }
        }
        self.wanted.len()
    }

    /// When nothing else is pending — no command unsolved, no job queued or running, no regrade
    /// — queues one piece of work for the editor's idle time and returns whether it did: first
    /// the states [`Session::prepare`] asked for (a solve the light keeps beside its values),
    /// else the next step of growing a light's curve response towards a column for every
    /// control point, so that its curve edits are answered exactly from it without a solve
    /// ([`HierarchicalIndirect::grow_response`]; docs/DECISIONS.md "Interreflection",
    /// "Responses completed while the editor is idle"): the `selected` light's first (its
    /// response started if it has none), then the light with the latest values among those
    /// whose curve was edited where they stand. One piece at a time, each a few hundred ms at
    /// most on a large floor, so that an edit waits at most one. The editor calls it after
    /// each batch of work, headless use never does.
    pub fn queue_idle_work(&mut self, selected: Option<usize>) -> bool {
        let Some(h) = self.hierarchical.as_ref() else {
            return false;
        };
        let running = self.idle.is_some_and(|(id, generation)| {
            self.light_index(id)
                .is_some_and(|i| self.slots[i].generation == generation)
        });
        let busy = running
            || !self.jobs.is_empty()
            || self.regrading.is_some()
            || self
                .slots
                .iter()
                .any(|s| s.generation != s.installed || s.solved != s.version);
        if busy {
            return false;
        }
        while !self.wanted.is_empty() {
            let (id, light) = self.wanted.remove(0);
            if let Some(i) = self.light_index(id)
                && let Some(job) = h.prepare(i, &light)
            {
                let slot = &self.slots[i];
                self.idle = Some((id, slot.generation));
                self.jobs.push(BakeJob {
                    light: Some(id),
                    name: light.name,
                    generation: slot.generation,
                    work: Work::Prepare(job),
                });
                return true;
            }
        }
        let mut order: Vec<usize> = (0..self.slots.len()).collect();
        order.sort_by_key(|&i| (Some(i) != selected, std::cmp::Reverse(h.light_revision(i))));
        for i in order {
            let slot = &self.slots[i];
            if self.growth_failed == Some((slot.id, slot.generation)) {
                continue;
            }
            let light = self.lights[i].to_light();
            if let Some(job) = h.grow_response(i, &light, Some(i) == selected) {
                self.idle = Some((slot.id, slot.generation));
                self.jobs.push(BakeJob {
                    light: Some(slot.id),
                    name: light.name,
                    generation: slot.generation,
                    work: Work::Grow(job),
                });
                return true;
            }
        }
        self.idle = None;
        false
    }

    /// The bake jobs queued by commands since the last call (one per light at most).
    pub fn take_bake_jobs(&mut self) -> Vec<BakeJob> {
        std::mem::take(&mut self.jobs)
    }

    /// Installs finished background work: a light's basis columns if they are still the latest
    /// for it (else they are dropped and their cache entry removed), a light's solve if it is
    /// newer than the one installed and made on the current engine, a rebuilt engine if it is
    /// the pending regrade and the session still has the same lights. Returns the index of the
    /// light it updated (the first light for a rebuilt engine).
    ///
    /// Errors: the work itself failed (internal); the light keeps its previous result (a failed
    /// solve or regrade is tried again at the next relight).
    pub fn finish_bake(&mut self, outcome: BakeOutcome) -> Result<Option<usize>> {
        let BakeOutcome {
            light,
            generation,
            result,
        } = outcome;
        let index = light.and_then(|id| self.light_index(id));
        let idle = light.is_some_and(|id| self.idle == Some((id, generation)));
        if idle {
            self.idle = None;
        }
        let done = match result {
            Ok(done) => done,
            // Idle work that failed leaves the light's values as they are, and the light is not
            // grown again until it changes.
            Err(e) if idle => {
                self.growth_failed = light.map(|id| (id, generation));
                return Err(e);
            }
            Err(e) => {
                match (light, index) {
                    (None, _) if self.regrading == Some(generation) => {
                        self.regrading = None;
                        self.regrade = true;
                    }
                    (Some(_), Some(i)) if self.slots[i].generation == generation => {
                        self.slots[i].solved = 0;
                    }
                    _ => {}
                }
                return Err(e);
            }
        };
        match done {
            Done::Basis { key, baked } => {
                let Some(i) = index.filter(|&i| self.slots[i].generation == generation) else {
                    self.forget_cache_entry(key);
                    return Ok(None);
                };
                let slot = &mut self.slots[i];
                slot.installed = generation;
                slot.version += 1;
                if let Some(old) = slot.key.replace(key)
                    && old != key
                {
                    self.forget_cache_entry(old);
                }
                if let Some(bake) = &mut self.bake {
                    bake.plan.lights[i] = baked.plan.clone();
                    bake.lights[i] = (*baked).clone();
                }
                if let Some(relighter) = &mut self.relighter {
                    relighter.install_baked(i, *baked);
                    self.illuminance_version += 1;
                }
                Ok(Some(i))
            }
            Done::Solved(solved) => Ok(index.filter(|&i| self.install_solve(i, generation, *solved))),
            Done::Grown(grown) => {
                // Only while the light is as it was: any newer job or settled edit moved its
                // generation on. The values shown do not change.
                if let Some(i) = index.filter(|&i| self.slots[i].generation == generation)
                    && let Some(h) = self.hierarchical.as_mut()
                {
                    h.install_response(i, *grown);
                }
                Ok(None)
            }
            Done::Prepared(solved) => {
                // Kept only on the engine it was made on, for the light where it stood.
                if let Some(i) = index
                    && let Some(h) = self.hierarchical.as_mut()
                {
                    h.hold_prepared(i, *solved);
                }
                Ok(None)
            }
            Done::Regraded {
                placed,
                snapshot,
                solving,
            } => {
                if self.regrading != Some(generation) {
                    return Ok(None);
                }
                self.regrading = None;
                let same_lights = snapshot.len() == self.slots.len()
                    && snapshot.iter().zip(&self.slots).all(|(s, slot)| s.id == slot.id);
                if !same_lights {
                    self.regrade = true;
                    return Ok(None);
                }
                match placed {
                    Placed::Rebuilt(engine) => self.install_engine(*engine, &snapshot),
                    Placed::Kept => self.install_kept(&snapshot, &solving),
                }
                Ok((!self.slots.is_empty()).then_some(0))
            }
        }
    }

    /// Installs light `i`'s solve queued at `generation` unless a newer one is installed or it
    /// was made on an engine since replaced; true when installed.
    fn install_solve(&mut self, i: usize, generation: u64, solved: LightSolve) -> bool {
        if self.slots[i].installed >= generation {
            return false;
        }
        let Some(h) = self.hierarchical.as_mut() else {
            return false;
        };
        if !h.install(i, solved) {
            return false;
        }
        let slot = &mut self.slots[i];
        slot.installed = generation;
        let up_to_date = slot.solved == slot.version;
        slot.version += 1;
        if up_to_date {
            slot.solved = slot.version;
        }
        slot.dirty.state = true;
        true
    }

    /// A grading check kept the engine: every light it covered is up to date, except those
    /// in `solving`, whose own solve (queued beside the check) brings them up to date when it
    /// lands.
    fn install_kept(&mut self, snapshot: &[LightSnapshot], solving: &[usize]) {
        for (i, (slot, snap)) in self.slots.iter_mut().zip(snapshot).enumerate() {
            if !solving.contains(&i) {
                slot.installed = slot.installed.max(snap.generation);
            }
        }
    }

    /// Runs the queued bake jobs here and installs them (headless use).
    ///
    /// Errors: a bake failed (internal).
    pub fn run_bake_jobs(&mut self, progress: &mut dyn FnMut(Progress)) -> Result<()> {
        for job in self.take_bake_jobs() {
            let outcome = job.run(progress);
            self.finish_bake(outcome)?;
        }
        Ok(())
    }

    /// The scene with its lights as the commands left them (for schedules and reports; the
    /// geometry and settings are the room file's).
    pub fn current_scene(&mut self) -> &Scene {
        self.synced_scene()
    }

    /// The scene with its lights brought up to date (for building the relighter and gathers).
    fn synced_scene(&mut self) -> &Scene {
        if self.scene_lights_stale {
            self.scene.lights = self.lights.iter().map(LightEdit::to_light).collect();
            self.scene_lights_stale = false;
        }
        &self.scene
    }

    /// Re-solves, with the hierarchical engine, every light changed since its last solve, here
    /// or — with [`SessionOptions::background_solves`] — as queued [`BakeJob`]s. A dimmer or
    /// colour change needs no solve and is applied at once either way.
    ///
    /// Errors: a solve failed (internal); that light keeps its previous indirect light and is
    /// tried again at the next call.
    fn solve_indirect(&mut self) -> Result<()> {
        let Some(h) = &self.hierarchical else {
            return Ok(());
        };
        // While a regrade is out, edited lights are solved on the current engine all the same
        // (a rebuild can take a minute); the rebuilt engine solves them again if they changed
        // after it was queued.
        let background = self.options.background_solves;
        let placed = |i: usize, l: &LightEdit| h.light_is_at(i, l.position, l.radius_m);
        let pending = |i: usize| self.slots[i].solved != self.slots[i].version;
        let moved = self.regrade
            || self
                .lights
                .iter()
                .enumerate()
                .any(|(i, l)| pending(i) && !placed(i, l));
        if moved {
            self.synced_scene();
            if background {
                // The grading check (a refinement of the whole scene) leaves the key path too.
                self.regrade = false;
                self.queue_placement();
                return Ok(());
            }
            let h = self.hierarchical.as_ref().expect("checked above");
            if let Some(solver) = h.engine().regrade(&self.scene) {
                let Some(job) = self.regrade_job() else {
                    return Ok(());
                };
                let engine = job.build(solver)?;
                self.install_engine(engine, &job.snapshot);
                self.regrade = false;
                return Ok(());
            }
            self.regrade = false;
        }
        let Some(h) = &mut self.hierarchical else {
            return Ok(());
        };
        for (i, (slot, light)) in self.slots.iter_mut().zip(&self.lights).enumerate() {
            if slot.solved == slot.version {
                continue;
            }
            let light = light.to_light();
            if !background {
                h.set_light(i, &light)?;
            } else if let Some(job) = h.update_light(i, &light) {
                slot.generation += 1;
                let job = BakeJob {
                    light: Some(slot.id),
                    name: light.name,
                    generation: slot.generation,
                    work: Work::Solve(job),
                };
                self.jobs.retain(|j| j.light != job.light);
                self.jobs.push(job);
            } else {
                slot.settle();
                self.jobs.retain(|j| j.light != Some(slot.id));
            }
            slot.solved = slot.version;
        }
        Ok(())
    }

    /// The check of the hierarchical engine's grading for the current lights and its rebuild
    /// when they call for another (its graded mesh follows where they are), with each light's
    /// bookkeeping as it is now and no solves yet.
    fn regrade_job(&mut self) -> Option<RegradeJob> {
        let engine = Arc::clone(self.hierarchical.as_ref()?.engine());
        let tolerance = self
            .options
            .bake
            .tolerance
            .unwrap_or(self.scene.settings.tolerance);
        let scene = self.synced_scene().clone();
        let snapshot = self
            .slots
            .iter()
            .map(|s| LightSnapshot {
                id: s.id,
                edits: s.edits,
                generation: s.generation,
            })
            .collect();
        Some(RegradeJob {
            scene,
            engine,
            tolerance,
            snapshot,
            solving: Vec::new(),
        })
    }

    /// Queues the grading check after lights moved (or were added or removed), and ahead of it
    /// the changed lights' solves on the current engine: they land in the time of a solve while
    /// the check (and, when the grading changed, the rebuild) runs on (docs/DECISIONS.md
    /// "Interreflection", "Moves answered on the current engine").
    fn queue_placement(&mut self) {
        let Some(job) = self.regrade_job() else {
            return;
        };
        if let Some(h) = self.hierarchical.as_mut() {
            let mut solves = Vec::new();
            // The changed lights: any job still queued for them is for an older state.
            let mut changed = Vec::new();
            for (i, (slot, light)) in self.slots.iter_mut().zip(&self.lights).enumerate() {
                if slot.solved == slot.version {
                    continue;
                }
                changed.push(Some(slot.id));
                match h.update_light(i, &light.to_light()) {
                    Some(solve) => solves.push(BakeJob {
                        light: Some(slot.id),
                        name: light.name.clone(),
                        generation: slot.generation,
                        work: Work::Solve(solve),
                    }),
                    None => slot.settle(),
                }
            }
            self.jobs.retain(|j| !changed.contains(&j.light));
            self.jobs.splice(0..0, solves);
        }
        self.queue_regrade(job);
    }

    /// Queues `job`: every light is `Updating` until it arrives, and a light whose solve on
    /// the current engine is still queued until that solve lands too (the queued solves keep
    /// their place, under the light's new generation; the check leaves those lights to them).
    fn queue_regrade(&mut self, mut job: RegradeJob) {
        self.regrades += 1;
        self.regrading = Some(self.regrades);
        for (slot, snap) in self.slots.iter_mut().zip(&mut job.snapshot) {
            slot.generation += 1;
            slot.solved = slot.version;
            snap.generation = slot.generation;
        }
        let slots = &self.slots;
        let index = |id: Option<LightId>| id.and_then(|id| slots.iter().position(|s| s.id == id));
        self.jobs
            .retain(|j| !matches!(j.work, Work::Solve(_)) || index(j.light).is_some());
        for queued in &mut self.jobs {
            if let (Work::Solve(_), Some(i)) = (&queued.work, index(queued.light)) {
                queued.generation = slots[i].generation;
                job.solving.push(i);
            }
        }
        self.push_job(BakeJob {
            light: None,
            name: "interreflection engine".into(),
            generation: self.regrades,
            work: Work::Regrade(Box::new(job)),
        });
    }

    /// Installs a rebuilt engine made for the lights as `snapshot` found them (the session's
    /// lights, same order): receiver sets follow it, and lights edited since are solved again
    /// at the next relight.
    fn install_engine(&mut self, mut engine: HierarchicalIndirect, snapshot: &[LightSnapshot]) {
        engine.set_estimates(self.options.estimate_order());
        let shared = Arc::clone(engine.engine());
        self.hierarchical = Some(engine);
        self.each_receiver_set(|set| set.use_engine(Arc::clone(&shared)));
        for (slot, snap) in self.slots.iter_mut().zip(snapshot) {
            // Every light's indirect light changed: receiver sets recompute them all.
            let current = slot.edits == snap.edits;
            slot.version += 1;
            slot.solved = if current { slot.version } else { 0 };
            slot.installed = slot.installed.max(snap.generation);
            slot.dirty.state = true;
        }
    }

    /// [`Session::solve_indirect`], keeping a failure for the next render or query.
    pub(crate) fn solve_indirect_or_keep(&mut self) {
        if let Err(e) = self.solve_indirect() {
            self.indirect_failure = Some(e);
        }
    }

    /// Recomputes the lights that commands changed (building the relighter on first use);
    /// returns their indices. A failed solve of the hierarchical engine leaves that light's
    /// indirect light as it was; the next [`Session::render`] or [`Session::illuminance_at`]
    /// returns the error.
    pub fn relight(&mut self) -> Vec<usize> {
        self.solve_indirect_or_keep();
        if self.relighter.is_none() {
            self.synced_scene();
            let relighter = match &self.bake {
                Some(bake) => Relighter::with_bake(&self.scene, bake),
                None => Relighter::new(&self.scene),
            };
            self.relighter = Some(relighter);
            for slot in &mut self.slots {
                slot.dirty.moved = false;
                // The hierarchical engine's indirect light is given to the new relighter below.
                slot.given = 0;
            }
        }
        let Some(relighter) = self.relighter.as_mut() else {
            return Vec::new();
        };
        let mut relit = Vec::new();
        for (i, (slot, light)) in self.slots.iter_mut().zip(&self.lights).enumerate() {
            if slot.dirty.moved {
                relighter.move_light(i, light.position);
            }
            // The engine's values for the light, interpolated to the vertices only when they
            // changed (not at an edit whose solve is still pending).
            if let Some(h) = &self.hierarchical
                && h.light_revision(i) != slot.given
            {
                relighter.give_indirect(i, &h.vertex_indirect(i));
                slot.given = h.light_revision(i);
                slot.dirty.state = true;
            }
            if slot.dirty.state || slot.dirty.moved {
                relighter.set_light(
                    i,
                    &light.curve,
                    slot.weights.weights(),
                    light.aim,
                    light.dimmer,
                    light.window.forced(),
                );
                relit.push(i);
            }
            slot.dirty = Dirty::default();
        }
        if !relit.is_empty() {
            self.illuminance_version += 1;
        }
        relit
    }

    /// The error of a failed solve since the last call, if any.
    fn take_indirect_failure(&mut self) -> Result<()> {
        self.indirect_failure.take().map_or(Ok(()), Err)
    }

    /// Total illuminance per fine vertex (lx, linear RGB), recomputed first if commands changed
    /// a light.
    pub fn vertex_illuminance(&mut self) -> &[[f64; 3]] {
        self.relight();
        self.relighter.as_ref().map_or(&[], |r| r.total())
    }

    /// Renders the current state through the session's camera as `spec` says (relighting first
    /// if needed), into buffers kept across calls.
    ///
    /// Errors: a bad size (bad input naming `width`/`height`), an internal render failure.
    pub fn render(&mut self, spec: &FrameSpec) -> Result<&render::Frame> {
        self.relight();
        self.take_indirect_failure()?;
        let relighter = self
            .relighter
            .as_ref()
            .ok_or_else(|| Error::internal("session: no relighter"))?;
        let indirect = match (&self.hierarchical, &self.bake) {
            (Some(h), _) => Some(PlaneIndirect::Leaves(h)),
            (None, Some(bake)) => Some(PlaneIndirect::Basis(bake)),
            (None, None) => None,
        };
        self.buffers.render(
            &self.scene,
            (relighter, self.illuminance_version),
            indirect,
            self.camera,
            spec,
            &self.lights,
        )
    }

    /// The latest frame and the view it was rendered through.
    pub fn latest_frame(&self) -> Option<(&render::Frame, &render::View)> {
        self.buffers.latest()
    }

    /// The display shader of `mode` as fitted at its first frame (exposure or lux range).
    pub fn fitted_shader(&self, mode: render::DisplayMode) -> Option<render::DisplayShader> {
        self.buffers.fitted(mode)
    }

    /// The index of the light named `name`.
    ///
    /// Errors (bad input naming the room file and `place`): no such light; the message lists
    /// the lights.
    pub fn light_named(&self, name: &str, place: &str) -> Result<usize> {
        self.lights.iter().position(|l| l.name == name).ok_or_else(|| {
            let names: Vec<&str> = self.lights.iter().map(|l| l.name.as_str()).collect();
            Error::input(
                &self.scene.path,
                place,
                format!("no light named `{name}` (lights: {})", names.join(", ")),
            )
        })
    }

    /// Forgets the exposure and lux range fitted at the first frame: the next frame fits anew.
    pub fn refit_display(&mut self) {
        self.buffers.refit_display();
    }

    /// What pixel `pixel` of the latest frame shows, with the illuminance there.
    pub fn pick(&self, pixel: (u32, u32)) -> Option<PixelHit> {
        self.buffers.pick(&self.scene, pixel)
    }

    /// Per-pixel illuminance (lx, luma) of the latest frame's visible surfaces, row-major from
    /// the top-left pixel, 0 where no surface is seen (for `--lux` PFM files); `None` before
    /// the first frame.
    pub fn lux_image(&mut self) -> Option<Vec<f32>> {
        self.buffers.lux_image()
    }

    /// Bytes the preview's per-pixel light holds per pixel whatever the number of lights, and
    /// per (light, pixel); `None` before the first frame.
    pub fn preview_memory_per_pixel(&self) -> Option<(f64, f64)> {
        self.buffers.memory_per_pixel()
    }

    /// Illuminance (lx, photopic) at `receivers` for the current lights: exact direct light plus,
    /// unless `direct_only`, the indirect light gathered from the bake. `mode` chooses how direct
    /// light is evaluated (exact, or from the SH series as in paper mode). The same path as
    /// [`Session::watch`] and [`Session::design_numbers`] ([`ReceiverSet`]), so the numbers agree
    /// at the same points.
    ///
    /// Errors (bad input): paper mode asked for with `direct_only` or without a bake.
    pub fn illuminance_at(
        &mut self,
        receivers: &[Receiver],
        direct_only: bool,
        mode: DirectMode,
    ) -> Result<Vec<f64>> {
        let indirect = !direct_only && self.has_indirect();
        if mode == DirectMode::Basis && (direct_only || self.bake.is_none()) {
            return Err(Error::input(
                "--mode",
                "",
                "basis mode needs the bake: drop --direct-only",
            ));
        }
        self.solve_indirect()?;
        let occluders = self.occluders();
        let mut lux = Vec::with_capacity(receivers.len());
        for chunk in receivers.chunks(RECEIVERS_PER_CHUNK) {
            let mut set = ReceiverSet::new(
                &self.scene,
                chunk.to_vec(),
                self.lights.len(),
                if indirect {
                    self.indirect_source()
                } else {
                    IndirectSource::None
                },
                mode,
                occluders.as_deref(),
            );
            set.update(&self.light_inputs(), occluders.as_deref());
            lux.extend_from_slice(set.lux());
        }
        Ok(lux)
    }

    /// Starts keeping the illuminance at `receivers` current (exact direct light plus, with a
    /// bake, the gathered indirect light): the geometry is cached now, and each
    /// [`Session::watched`] recomputes only the lights changed since. Returns its handle.
    pub fn watch(&mut self, receivers: Vec<Receiver>) -> WatchId {
        let occluders = self.occluders();
        let set = self.exact_receiver_set(receivers, occluders.as_deref());
        let id = WatchId(self.next_watch);
        self.next_watch += 1;
        self.watches.push((id, set));
        id
    }

    /// The watched set `id` brought up to date for the current lights (`None` once
    /// [`Session::unwatch`]ed).
    pub fn watched(&mut self, id: WatchId) -> Option<&ReceiverSet> {
        let k = self.watches.iter().position(|(w, _)| *w == id)?;
        self.solve_indirect_or_keep();
        let occluders = self.occluders();
        let mut set = self.watches.swap_remove(k).1;
        set.update(&self.light_inputs(), occluders.as_deref());
        self.watches.push((id, set));
        self.watches.last().map(|(_, set)| set)
    }

    /// Stops keeping set `id` lit.
    pub fn unwatch(&mut self, id: WatchId) {
        self.watches.retain(|(w, _)| *w != id);
    }

    /// Runs `f` on every receiver set the session keeps (watches and the design numbers').
    fn each_receiver_set(&mut self, mut f: impl FnMut(&mut ReceiverSet)) {
        self.watches.iter_mut().for_each(|(_, set)| f(set));
        if let Some(design) = &mut self.design {
            f(&mut design.set);
        }
    }

    /// True when the session has indirect light to gather (the hierarchical engine, or a bake
    /// with an indirect basis).
    fn has_indirect(&self) -> bool {
        self.hierarchical.is_some()
            || self
                .bake
                .as_ref()
                .is_some_and(|b| b.lights.iter().any(|l| l.has_indirect()))
    }

    /// Where receiver sets gather indirect light from.
    fn indirect_source(&self) -> IndirectSource {
        match &self.hierarchical {
            Some(h) => IndirectSource::Leaves(Arc::clone(h.engine())),
            None if self.has_indirect() => IndirectSource::Basis,
            None => IndirectSource::None,
        }
    }

    /// The session's scene (its lights as the commands left them), bake and hierarchical
    /// indirect engine, the rest of the session dropped and nothing copied: `haiko bake` frees
    /// the session, then the engine, before its measured move builds another as large.
    pub fn into_parts(mut self) -> (Scene, Option<Bake>, Option<HierarchicalIndirect>) {
        self.synced_scene();
        (self.scene, self.bake, self.hierarchical)
    }

    /// The hierarchical indirect engine, when the plan chose it.
    pub fn hierarchical(&self) -> Option<&HierarchicalIndirect> {
        self.hierarchical.as_ref()
    }

    /// A receiver set at `receivers` for this session's lights, as the numbers use it: exact
    /// direct light, plus the gathered indirect light when the session has a bake.
    fn exact_receiver_set(&self, receivers: Vec<Receiver>, occluders: Option<&Occluders>) -> ReceiverSet {
        ReceiverSet::new(
            &self.scene,
            receivers,
            self.lights.len(),
            self.indirect_source(),
            DirectMode::Exact,
            occluders,
        )
    }

    /// The furniture that casts shadows: the bake's, else the scene's built once.
    fn occluders(&mut self) -> Option<Arc<Occluders>> {
        if self.occluders.is_none() {
            let occluders = match &self.bake {
                Some(bake) => bake.transport.occluders().cloned(),
                None => Occluders::of_scene(&self.scene).map(Arc::new),
            };
            self.occluders = Some(occluders);
        }
        self.occluders.clone().flatten()
    }

    /// What a receiver set needs of each light, in order.
    fn light_inputs(&self) -> Vec<LightInput<'_>> {
        light_inputs(
            &self.lights,
            &self.slots,
            self.bake.as_ref(),
            self.hierarchical.as_ref(),
        )
    }

    /// Light `i`'s series as the polar diagram shows it: its order-N series windowed as the
    /// light says, from the weights kept edit by edit.
    pub fn series(&self, i: usize) -> Series {
        Series::of(&self.lights[i], self.slots[i].weights.weights())
    }
}
