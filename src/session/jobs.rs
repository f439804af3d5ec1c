//! Work a session hands to another thread so that edits stay interactive (docs/ARCHITECTURE.md
//! "The editor's threads"): a moved light's new SH basis columns, an edited light's solve through the
//! hierarchical engine, a step of growing its curve response or the solve of a state it may be
//! brought to next while the editor is idle, or the whole engine rebuilt when a move changes its
//! graded mesh. Each
//! [`BakeJob`] runs on any thread ([`BakeJob::run`]) and its [`BakeOutcome`] goes back to
//! [`super::Session::finish_bake`], which installs it unless something newer superseded it.

use std::sync::Arc;

use crate::error::{Error, Result};
use crate::scene::Scene;
use crate::transport::bake::{BakedLight, LightBakeSpec, Progress, Transport};
use crate::transport::cache::BakeCache;
use crate::transport::indirect::{
    DIRECT_CACHE_BUDGET_BYTES, HierarchicalIndirect, LightSolve, LightSolveJob,
};
use crate::transport::interreflection::Interreflection;
use crate::transport::refine::SolverMesh;

use super::LightId;

/// One piece of background work for a session: runs on any thread, then goes back to
/// [`super::Session::finish_bake`].
#[derive(Debug, Clone)]
pub struct BakeJob {
    /// The light it is for; `None` for the whole engine (a regrade).
    pub(super) light: Option<LightId>,
    pub(super) name: String,
    /// The light's (or, for a regrade, the session's regrade) generation it was queued at.
    pub(super) generation: u64,
    pub(super) work: Work,
}

/// What a [`BakeJob`] computes.
#[derive(Debug, Clone)]
pub(super) enum Work {
    /// A light's SH basis columns (from the cache when valid).
    Basis {
        transport: Arc<Transport>,
        spec: LightBakeSpec,
        cache: Option<BakeCache>,
    },
    /// A light's solve through the hierarchical engine.
    Solve(LightSolveJob),
    /// A step of growing a light's curve response while the editor is idle
    /// ([`super::Session::queue_idle_work`]).
    Grow(LightSolveJob),
    /// A state a light may be brought to next, solved while the editor is idle
    /// ([`super::Session::prepare`]).
    Prepare(LightSolveJob),
    /// Lights moved, or were added or removed: the graded mesh checked, and the whole engine
    /// rebuilt when it no longer holds (the lights' own solves on the current engine are
    /// separate [`Work::Solve`] jobs, queued with it).
    Regrade(Box<RegradeJob>),
}

/// After lights moved (or were added or removed): whether `engine`'s graded mesh is still the
/// one `scene` (its lights where they stand now) calls for; if not, the engine rebuilt for
/// `scene`. With what each light's bookkeeping was when the job was queued, and which lights
/// were queued a solve on the current engine beside it (docs/DECISIONS.md "Interreflection",
/// "Moves answered on the current engine").
#[derive(Debug, Clone)]
pub(super) struct RegradeJob {
    pub(super) scene: Scene,
    pub(super) engine: Arc<Interreflection>,
    pub(super) tolerance: f64,
    pub(super) snapshot: Vec<LightSnapshot>,
    /// The lights (indices) whose solve on `engine` was queued with this check: their solve,
    /// not the check, brings them up to date when the grading holds.
    pub(super) solving: Vec<usize>,
}

/// What a [`RegradeJob`] found.
#[derive(Debug)]
pub(super) enum Placed {
    /// The grading holds: the current engine stays.
    Kept,
    /// The engine rebuilt for the new grading, every light solved.
    Rebuilt(Box<HierarchicalIndirect>),
}

/// A light as a regrade found it: its id, edit count and generation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct LightSnapshot {
    pub(super) id: LightId,
    pub(super) edits: u64,
    pub(super) generation: u64,
}

impl RegradeJob {
    /// Checks the grading and rebuilds the engine when it changed.
    ///
    /// Errors: the rebuilt engine's solve failing (internal).
    pub(super) fn run(&self) -> Result<Placed> {
        match self.engine.regrade(&self.scene) {
            None => Ok(Placed::Kept),
            Some(solver) => self.build(solver).map(|engine| Placed::Rebuilt(Box::new(engine))),
        }
    }

    /// Builds the engine for the scene on its graded mesh `solver` ([`Interreflection::regrade`])
    /// and solves every light.
    ///
    /// Errors: more links than the memory limit allows (bad input), the solve failing
    /// (internal).
    pub(super) fn build(&self, solver: SolverMesh) -> Result<HierarchicalIndirect> {
        let engine = self.engine.rebuilt(&self.scene, solver)?;
        HierarchicalIndirect::on_engine(
            Arc::new(engine),
            &self.scene,
            &self.scene.lights,
            self.tolerance,
            DIRECT_CACHE_BUDGET_BYTES,
        )
    }
}

/// A finished [`BakeJob`].
#[derive(Debug)]
pub struct BakeOutcome {
    pub(super) light: Option<LightId>,
    pub(super) generation: u64,
    pub(super) result: Result<Done>,
}

/// What a [`BakeJob`] produced.
#[derive(Debug)]
pub(super) enum Done {
    /// A light's basis columns and their cache key.
    Basis { key: u64, baked: Box<BakedLight> },
    /// A light's solve.
    Solved(Box<LightSolve>),
    /// A light's curve response grown by a step (its values unchanged).
    Grown(Box<LightSolve>),
    /// A light's prepared state (its values unchanged).
    Prepared(Box<LightSolve>),
    /// The grading kept or the rebuilt engine, with the lights as the job found them and
    /// those whose own solve was queued beside it.
    Regraded {
        placed: Placed,
        snapshot: Vec<LightSnapshot>,
        solving: Vec<usize>,
    },
}

impl BakeJob {
    /// The light it is for; `None` for the whole engine. A later job with the same answer
    /// supersedes an earlier one still queued.
    pub fn light(&self) -> Option<LightId> {
        self.light
    }

    /// The light's name (or "interreflection engine").
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Does the work, reporting progress (the basis bake only).
    pub fn run(self, progress: &mut dyn FnMut(Progress)) -> BakeOutcome {
        let result = match self.work {
            Work::Basis {
                transport,
                spec,
                cache,
            } => {
                let key = transport.light_key(&spec);
                transport
                    .bake_lights(std::slice::from_ref(&spec), cache.as_ref(), progress)
                    .and_then(|(mut lights, _)| {
                        lights
                            .pop()
                            .ok_or_else(|| Error::internal("the bake returned no light"))
                    })
                    .map(|baked| Done::Basis {
                        key,
                        baked: Box::new(baked),
                    })
            }
            Work::Solve(job) => job.run().map(|solved| Done::Solved(Box::new(solved))),
            Work::Grow(job) => job.run().map(|grown| Done::Grown(Box::new(grown))),
            Work::Prepare(job) => job.run().map(|solved| Done::Prepared(Box::new(solved))),
            Work::Regrade(job) => job.run().map(|placed| Done::Regraded {
                placed,
                snapshot: job.snapshot,
                solving: job.solving,
            }),
        };
        BakeOutcome {
            light: self.light,
            generation: self.generation,
            result,
        }
    }
}
