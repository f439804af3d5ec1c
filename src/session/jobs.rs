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
use crate::transport::interreflection::InterreflectionOptions;

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
    /// The hierarchical engine rebuilt for the scene's lights where they are now.
    Regrade(Box<RegradeJob>),
}

/// The hierarchical engine rebuilt for `scene` (its lights where they stand), with what each
/// light's bookkeeping was when the job was queued.
#[derive(Debug, Clone)]
pub(super) struct RegradeJob {
    pub(super) scene: Scene,
    pub(super) channels: usize,
    pub(super) visibility: bool,
    pub(super) tolerance: f64,
    pub(super) options: InterreflectionOptions,
    pub(super) snapshot: Vec<LightSnapshot>,
}

/// A light as a regrade found it: its id, version and generation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct LightSnapshot {
    pub(super) id: LightId,
    pub(super) version: u64,
    pub(super) generation: u64,
}

impl RegradeJob {
    /// Builds and solves the engine.
    ///
    /// Errors: the solve failing (internal).
    pub(super) fn run(&self) -> Result<HierarchicalIndirect> {
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
    /// The rebuilt engine, with the lights as the job found them.
    Regraded {
        engine: Box<HierarchicalIndirect>,
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
            Work::Regrade(job) => job.run().map(|engine| Done::Regraded {
                engine: Box::new(engine),
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
