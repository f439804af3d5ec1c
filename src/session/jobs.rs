//! Work a session hands to another thread so that edits stay interactive (docs/ARCHITECTURE.md
//! "Threads"): a moved light's new SH basis columns, an edited light's solve through the
//! hierarchical engine, or the whole engine rebuilt when a move changes its graded mesh. Each
//! [`BakeJob`] runs on any thread ([`BakeJob::run`]) and its [`BakeOutcome`] goes back to
//! [`super::Session::finish_bake`], which installs it unless something newer superseded it.

use std::sync::Arc;

use crate::error::{Error, Result};
use crate::scene::Scene;
use crate::transport::bake::{BakedLight, LightBakeSpec, Progress, Transport};
use crate::transport::cache::BakeCache;
use crate::transport::indirect::{HierarchicalIndirect, LightSolve, LightSolveJob};
use crate::transport::interreflection::{Interreflection, InterreflectionOptions};

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
    /// Lights moved, or were added or removed: the graded mesh checked, then their solves or
    /// the whole engine rebuilt.
    Regrade(Box<RegradeJob>),
}

/// After lights moved (or were added or removed): whether `engine`'s graded mesh is still the
/// one `scene` (its lights where they stand now) calls for; if so the pending lights' `solves`,
/// else the engine rebuilt for `scene`. With what each light's bookkeeping was when the job was
/// queued.
#[derive(Debug, Clone)]
pub(super) struct RegradeJob {
    pub(super) scene: Scene,
    pub(super) engine: Arc<Interreflection>,
    pub(super) channels: usize,
    pub(super) visibility: bool,
    pub(super) tolerance: f64,
    pub(super) options: InterreflectionOptions,
    pub(super) snapshot: Vec<LightSnapshot>,
    /// The solves the lights need on `engine` (light index, job) if its grading holds.
    pub(super) solves: Vec<(usize, LightSolveJob)>,
}

/// What a [`RegradeJob`] found.
#[derive(Debug)]
pub(super) enum Placed {
    /// The grading holds: the pending lights' solves on the current engine.
    Kept(Vec<(usize, Result<LightSolve>)>),
    /// The engine rebuilt for the new grading, every light solved.
    Rebuilt(Box<HierarchicalIndirect>),
}

/// A light as a regrade found it: its id, version and generation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct LightSnapshot {
    pub(super) id: LightId,
    pub(super) version: u64,
    pub(super) generation: u64,
}

impl RegradeJob {
    /// Checks the grading, then solves the pending lights or rebuilds the engine.
    ///
    /// Errors: the rebuilt engine's solve failing (internal; a failed light solve is kept in
    /// [`Placed::Kept`]).
    pub(super) fn run(&self) -> Result<Placed> {
        if self.engine.grading_matches(&self.scene) {
            let solves = self
                .solves
                .iter()
                .map(|(i, job)| (*i, job.clone().run()))
                .collect();
            return Ok(Placed::Kept(solves));
        }
        self.build().map(|engine| Placed::Rebuilt(Box::new(engine)))
    }

    /// Builds and solves the engine for the scene.
    ///
    /// Errors: the solve failing (internal).
    pub(super) fn build(&self) -> Result<HierarchicalIndirect> {
        HierarchicalIndirect::build(
            &self.scene,
            &self.scene.lights,
            self.channels,
            self.visibility,
            self.tolerance,
            &self.options,
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
    /// The lights' solves or the rebuilt engine, with the lights as the job found them.
    Regraded {
        placed: Placed,
        snapshot: Vec<LightSnapshot>,
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
            Work::Regrade(job) => job.run().map(|placed| Done::Regraded {
                placed,
                snapshot: job.snapshot,
            }),
        };
        BakeOutcome {
            light: self.light,
            generation: self.generation,
            result,
        }
    }
}
