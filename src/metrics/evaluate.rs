//! The design numbers of a scene: every calculation surface's statistics against its targets,
//! and every observer's glare rating, from the illuminance at the grids' receivers and the
//! indirect illuminance at the observers' eyes. The illuminance itself comes from the session
//! (`Session::design_numbers`), through the same path as `haiko probe`, so the numbers agree at
//! the same points.

use serde::Serialize;

use crate::metrics::glare::{GlareSource, ObserverGlare, observer_glare};
use crate::metrics::grid::CalcGrid;
use crate::metrics::stats::{SurfaceCheck, SurfaceStats};
use crate::scene::Scene;
use crate::scene::design::{Targets, TaskPreset};
use crate::transport::direct::{Receiver, luminance_weight};
use crate::transport::visibility::Visibility;

/// A calculation surface with its illuminance and verdicts.
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceResult {
    /// The grid.
    pub grid: CalcGrid,
    /// New illuminance at each kept receiver (lx), parallel to `grid.receivers`.
    pub lux: Vec<f64>,
    /// Maintained statistics; `None` when furniture covers every point.
    pub stats: Option<SurfaceStats>,
    /// The statistics against the targets.
    pub check: Option<SurfaceCheck>,
    /// The surface's targets.
    pub targets: Targets,
    /// The task preset the targets came from.
    pub task: Option<&'static TaskPreset>,
}

/// What a surface result reports in JSON and tables.
#[derive(Debug, Clone, Serialize)]
pub struct SurfaceSummary<'a> {
    /// The surface's name.
    pub name: &'a str,
    /// The task preset's name.
    pub task: Option<&'static str>,
    /// Grid points kept.
    pub points: usize,
    /// Grid points left out under furniture.
    pub skipped_in_furniture: usize,
    /// Largest cell size the grid was divided from, m (per part).
    pub max_cell_m: Vec<f64>,
    /// Statistics.
    pub stats: Option<SurfaceStats>,
    /// Verdicts.
    pub check: Option<SurfaceCheck>,
    /// All targets met (`None` without targets or points).
    pub pass: Option<bool>,
}

impl SurfaceResult {
    /// The summary for reports.
    pub(crate) fn summary(&self) -> SurfaceSummary<'_> {
        SurfaceSummary {
            name: &self.grid.name,
            task: self.task.map(|t| t.name),
            points: self.grid.receivers.len(),
            skipped_in_furniture: self.grid.skipped_in_furniture,
            max_cell_m: self.grid.parts.iter().map(|p| p.cells.max_cell_m).collect(),
            stats: self.stats,
            check: self.check,
            pass: self.check.and_then(|c| c.pass()),
        }
    }
}

/// The grids of every calculation surface of `scene`, in file order.
pub fn surface_grids(scene: &Scene) -> Vec<CalcGrid> {
    scene
        .design
        .surfaces
        .iter()
        .map(|s| CalcGrid::lay_out(scene, s))
        .collect()
}

/// Results from the grids and the new illuminance at all their receivers, concatenated in grid
/// order (`lux.len()` = total receivers).
pub fn surface_results(scene: &Scene, grids: Vec<CalcGrid>, lux: &[f64]) -> Vec<SurfaceResult> {
    let mf = scene.design.maintenance_factor;
    let mut start = 0;
    grids
        .into_iter()
        .zip(&scene.design.surfaces)
        .map(|(grid, surface)| {
            let end = start + grid.receivers.len();
            let lux = lux[start..end].to_vec();
            start = end;
            let stats = SurfaceStats::of(&lux, mf);
            SurfaceResult {
                check: stats.map(|s| SurfaceCheck::of(&s, &surface.targets)),
                grid,
                lux,
                stats,
                targets: surface.targets,
                task: surface.task,
            }
        })
        .collect()
}

/// The scene's lights as glare sources (dimmed, weighted by their colour's luminance).
pub(crate) fn glare_sources(scene: &Scene) -> Vec<GlareSource<'_>> {
    scene
        .lights
        .iter()
        .map(|l| GlareSource {
            name: &l.name,
            position: l.position,
            aim: l.aim,
            curve: &l.curve,
            scale: l.dimmer * luminance_weight(l.color),
            luminous: l.luminous.as_ref(),
        })
        .collect()
}

/// The observers' eyes as receivers facing along their lines of sight.
pub fn eye_receivers(scene: &Scene) -> Vec<Receiver> {
    scene
        .design
        .observers
        .iter()
        .map(|o| Receiver {
            point: o.eye,
            normal: o.view,
        })
        .collect()
}

/// Every observer's glare rating, given the indirect illuminance at each eye (lx, in observer
/// order, at the [`eye_receivers`]) and the furniture that may hide a luminaire (`None`: nothing
/// can).
pub fn glare_with(
    scene: &Scene,
    eye_indirect_lux: &[f64],
    vis: Option<&dyn Visibility>,
) -> Vec<ObserverGlare> {
    let sources = glare_sources(scene);
    scene
        .design
        .observers
        .iter()
        .zip(eye_indirect_lux)
        .map(|(o, &e)| observer_glare(o, &sources, e, vis, scene.design.ugr_limit(o)))
        .collect()
}
