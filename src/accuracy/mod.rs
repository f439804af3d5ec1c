//! What accuracy costs in time (`haiko accuracy`, docs/ACCURACY.md).
//!
//! One table per knob — SH order, coarse (solver) patch size, fine (display) patch size, solver
//! tolerance, quadrature of the Legendre weights `w_l`, exact vs series direct light — each row
//! a knob value, its wall time and its error. Every table varies ONE knob and keeps the others at
//! the room's settings (in hybrid mode), and its reference is the same run with that knob
//! converged, so a row's error is what that knob alone costs:
//! * order: every light at order `min(N_max + 8, 40)`;
//! * coarse patch size: the smallest tested size / √2;
//! * tolerance: 1e-8;
//! * fine patch size: the exact value at the same points (exact direct + gathered indirect);
//! * quadrature: the exact hat-function moments; direct light: the exact curve.
//!
//! The order, coarse-size and tolerance references are checked for convergence against a second,
//! slightly less refined run; the difference is reported and must stay below the smallest error
//! of the table.
//!
//! Errors (dimensionless) are `max |E − E_ref| / max |E_ref|` over the points and the median of
//! `|E − E_ref| / |E_ref|` over the points where `E_ref` is at least 1 % of its maximum. Points:
//! a work plane (0.8 m high, 0.25 m spacing; lux from [`illuminance_at_receivers`]) and every
//! fine vertex (lux as the editor shows it, from [`Relighter::total`]).

use std::time::Instant;

use glam::DVec3;
use serde::Serialize;

use crate::error::{Error, Result};
use crate::metrics::work_plane::WorkPlane;
use crate::photometry::{Curve, ZonalWeights, auto_window};
use crate::relight::Relighter;
use crate::scene::remesh::remesh;
use crate::scene::{DirectMode, Scene, SurfaceKind};
use crate::transport::bake::{Bake, BakeOptions, bake, patch_reflectance};
use crate::transport::direct::fine_receivers;
use crate::transport::direct::{Receiver, illuminance_at, luminance_weight};
use crate::transport::gather::illuminance_at_receivers;
use crate::transport::indirect::{HierarchicalIndirect, IndirectStats, measured_curve_edit, measured_reaim};
use crate::transport::interreflection::{InterreflectionOptions, RELAXED_ETA_FAR, RELAXED_NEAR_M};
use crate::transport::occlusion::Occluders;
use crate::transport::plan::{PlanOptions, plan};
use crate::transport::refine::RefineOptions;
use crate::transport::visibility::Visibility;

pub mod lid;

/// Highest order of the order table's reference.
pub(crate) const MAX_REFERENCE_ORDER: usize = 40;
/// Solver tolerance of the references.
pub(crate) const REFERENCE_TOLERANCE: f64 = 1e-8;
/// Points whose reference is below this fraction of the maximum are left out of the median.
const MEDIAN_FLOOR: f64 = 0.01;
/// Fractional offsets (of the spacing) of the floor samples, chosen off any regular vertex grid.
const FLOOR_SAMPLE_OFFSET: [f64; 2] = [0.381_966, 0.618_034];

/// Which knob values to tabulate and where to measure (all lengths in metres).
#[derive(Debug, Clone, PartialEq)]
pub struct AccuracyOptions {
    /// SH orders N (every light at N).
    pub orders: Vec<usize>,
    /// Coarse (interreflection) patch sizes, m.
    pub solver_patch_sizes_m: Vec<f64>,
    /// Fine (display) patch sizes, m.
    pub patch_sizes_m: Vec<f64>,
    /// Solver tolerances (certified relative error of the radiosity).
    pub tolerances: Vec<f64>,
    /// Rectangle-rule steps for `w_l`, degrees.
    pub rectangle_steps_deg: Vec<f64>,
    /// Work-plane height, m.
    pub grid_height_m: f64,
    /// Work-plane (and floor-sample) spacing, m.
    pub grid_spacing_m: f64,
    /// Repeats of the fast operations (edits, weights); their median time is reported.
    pub repeats: usize,
}

impl Default for AccuracyOptions {
    /// The command's tables: orders 1…24, coarse 1.0…0.25 m, fine 0.3…0.1 m, tolerances
    /// 1e-1…1e-6, rectangle rule at 1° and 5°, work plane at 0.8 m with 0.25 m spacing.
    fn default() -> Self {
        AccuracyOptions {
            orders: vec![1, 2, 3, 5, 8, 12, 16, 24],
            solver_patch_sizes_m: vec![1.0, 0.5, 0.35, 0.25],
            patch_sizes_m: vec![0.3, 0.2, 0.15, 0.1],
            tolerances: vec![1e-1, 1e-2, 1e-3, 1e-4, 1e-6],
            rectangle_steps_deg: vec![1.0, 5.0],
            grid_height_m: 0.8,
            grid_spacing_m: 0.25,
            repeats: 5,
        }
    }
}

/// An error against a reference (dimensionless).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ErrorStats {
    /// `max |E − E_ref| / max |E_ref|`.
    pub max_rel: f64,
    /// Median of `|E − E_ref| / |E_ref|` over the points with `|E_ref| ≥ 1 %` of the maximum.
    pub median_rel: f64,
}

impl ErrorStats {
    /// The error of `values` against `reference` (same points, same order).
    pub fn between(values: &[f64], reference: &[f64]) -> Self {
        let max_ref = reference.iter().fold(0.0f64, |m, r| m.max(r.abs()));
        if max_ref == 0.0 {
            let zero = values.iter().all(|&v| v == 0.0);
            let e = if zero { 0.0 } else { f64::INFINITY };
            return ErrorStats {
                max_rel: e,
                median_rel: e,
            };
        }
        let max_abs = values
            .iter()
            .zip(reference)
            .fold(0.0f64, |m, (v, r)| m.max((v - r).abs()));
        let mut rel: Vec<f64> = values
            .iter()
            .zip(reference)
            .filter(|(_, r)| r.abs() >= MEDIAN_FLOOR * max_ref)
            .map(|(v, r)| (v - r).abs() / r.abs())
            .collect();
        ErrorStats {
            max_rel: max_abs / max_ref,
            median_rel: median(&mut rel),
        }
    }
}

/// Errors of one run on the work plane and on the fine vertices.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FieldErrors {
    /// On the work-plane grid.
    pub grid: ErrorStats,
    /// On every fine vertex.
    pub vertices: ErrorStats,
}

/// Table 1: one SH order for every light.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OrderRow {
    /// SH order N.
    pub order: usize,
    /// Basis columns over all lights, Σ (N + 1)².
    pub columns: usize,
    /// Bake wall time, ms.
    pub bake_ms: f64,
    /// One edit of the first light (hybrid mode), median, ms.
    pub edit_ms: f64,
    /// One edit of the first light in paper mode, median, ms.
    pub edit_paper_ms: f64,
    /// Hybrid mode (exact direct, indirect from the series).
    pub hybrid: FieldErrors,
    /// Paper mode (direct from the series too).
    pub paper: FieldErrors,
}

/// Table 2: one coarse (solver) patch size.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CoarseRow {
    /// Coarse patch size, m.
    pub solver_patch_size_m: f64,
    /// Coarse patches.
    pub patches: usize,
    /// Bake wall time, ms.
    pub bake_ms: f64,
    /// Errors (hybrid mode).
    pub errors: FieldErrors,
}

/// Table 3: one fine (display) patch size.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FineRow {
    /// Fine patch size, m.
    pub patch_size_m: f64,
    /// Fine vertices.
    pub vertices: usize,
    /// Building the relighter (direct-light caches, interpolation weights, first blend), ms.
    pub relighter_build_ms: f64,
    /// One edit of the first light, median, ms.
    pub edit_ms: f64,
    /// Fine-vertex values against the exact value at the same vertex (what interpolating the
    /// indirect light from coarse patches loses).
    pub at_vertices: ErrorStats,
    /// The display's linear interpolation of the fine-vertex values at floor points between
    /// vertices against the exact value there (what the displayed mesh loses).
    pub between_vertices: ErrorStats,
}

/// Table 4: one solver tolerance.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ToleranceRow {
    /// Requested certified relative error.
    pub tolerance: f64,
    /// Solve wall time, ms.
    pub solve_ms: f64,
    /// Largest GMRES iteration count over the lights.
    pub iterations: usize,
    /// Largest certified relative radiosity error over the columns.
    pub certified_error: f64,
    /// Largest true relative radiosity error over the columns, `‖B̃ − B_ref‖∞ / ‖B̃‖∞`.
    pub true_error: f64,
    /// Errors of the illuminance (hybrid mode).
    pub errors: FieldErrors,
}

/// Table 5: one quadrature of one light's weights.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct QuadratureRow {
    /// The light's name.
    pub light: String,
    /// `exact` or `rectangle <step>°`.
    pub method: String,
    /// Rectangle step, degrees (`None`: exact).
    pub step_deg: Option<f64>,
    /// Time to compute the weights up to the highest tested order, median, ms.
    pub time_ms: f64,
    /// `max_l |w_l − w_l^exact| / max_l |w_l^exact|` for l up to the highest tested order.
    pub weight_error: f64,
    /// The light's direct illuminance on the work plane from its series at its room order
    /// (paper mode) against the same from the exact weights.
    pub illuminance: ErrorStats,
}

/// Table 6: exact vs series direct light of one light at its room order.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DirectRow {
    /// The light's name.
    pub light: String,
    /// `hybrid` (exact direct) or `paper` (direct from the series).
    pub mode: String,
    /// SH order of the light in that mode.
    pub order: usize,
    /// One edit of this light (direct + indirect), median, ms.
    pub edit_ms: f64,
    /// The light's direct illuminance against the exact one.
    pub direct: FieldErrors,
}

/// Table 7: one setting of the hierarchical engine's knobs (docs/DECISIONS.md
/// "Interreflection").
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EngineRow {
    /// What differs from the engine's defaults.
    pub variant: String,
    /// Solver leaves and symmetric links.
    pub leaves: usize,
    pub links: usize,
    /// The engine's build (refinement, links, balancing), ms.
    pub build_ms: f64,
    /// Every light's leaf direct light and the block solve, ms.
    pub solve_ms: f64,
    /// Exact direct light plus the engine's indirect light (gathered on the work plane,
    /// interpolated at the fine vertices) against the reference's.
    pub errors: FieldErrors,
}

/// One row of table 8: the editor's estimate of an edit of light 0 while its solve runs, from
/// the light's SH response of one degree (docs/DECISIONS.md "Re-aims and curve edits estimated
/// at once").
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EstimateRow {
    /// The response's degree N ((N + 1)² columns); `None`: no estimate, the light's values
    /// before the edit.
    pub order: Option<usize>,
    /// The response's build (the solve of its columns) and one estimate with its interpolation
    /// to the fine vertices, ms.
    pub build_ms: f64,
    pub estimate_ms: f64,
    /// Largest difference of the light's indirect light at the fine vertices from the edit's
    /// solve, relative to the solve's largest value: after a 10° re-aim, and after a curve edit
    /// (every second control point × 0.7).
    pub reaim: f64,
    pub curve: f64,
    /// The same differences relative to each vertex's total illuminance after the edit (all
    /// lights, direct and indirect), largest over the vertices.
    pub reaim_of_total: f64,
    pub curve_of_total: f64,
}

/// A pair of dimensionless errors: on the work plane and on the fine vertices.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct GridVertices {
    /// On the work plane.
    pub grid: f64,
    /// On the fine vertices.
    pub vertices: f64,
}

/// How a table's reference was made and how converged it is.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Reference {
    /// The table.
    pub table: String,
    /// What the reference is.
    pub made: String,
    /// The second, less refined run it was checked against (`None`: exact by construction).
    pub checked_against: Option<String>,
    /// `max |E_ref − E_check| / max |E_ref|` (`None`: exact by construction).
    pub difference: Option<GridVertices>,
    /// The smallest max error of the table's rows away from the reference settings.
    pub smallest_error: Option<GridVertices>,
    /// The difference is below the smallest error on both point sets (true when exact).
    pub converged: bool,
}

/// Everything `haiko accuracy` reports.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AccuracyReport {
    /// The room's name.
    pub room: String,
    /// Fine vertices and coarse patches at the room's settings.
    pub fine_vertices: usize,
    /// Coarse patches at the room's settings.
    pub coarse_patches: usize,
    /// Work-plane points.
    pub grid_points: usize,
    /// Floor points between vertices (fine table).
    pub floor_points: usize,
    /// Each table's reference.
    pub references: Vec<Reference>,
    /// Table 1.
    pub order: Vec<OrderRow>,
    /// Table 2.
    pub coarse: Vec<CoarseRow>,
    /// Table 3.
    pub fine: Vec<FineRow>,
    /// Table 4.
    pub tolerance: Vec<ToleranceRow>,
    /// Table 5.
    pub quadrature: Vec<QuadratureRow>,
    /// Table 6.
    pub direct: Vec<DirectRow>,
    /// Table 7 (empty when the room reflects no light).
    pub engine: Vec<EngineRow>,
    /// Table 8 (empty when the room reflects no light or has no lights).
    pub estimate: Vec<EstimateRow>,
}

/// Illuminance of one run (lx) on the work plane and on the fine vertices.
struct Fields {
    grid: Vec<f64>,
    vertices: Vec<f64>,
}

impl Fields {
    fn errors_against(&self, reference: &Fields) -> FieldErrors {
        FieldErrors {
            grid: ErrorStats::between(&self.grid, &reference.grid),
            vertices: ErrorStats::between(&self.vertices, &reference.vertices),
        }
    }
}

/// Measures every table for `scene` (its lights' curves and aims as loaded); `progress` gets a
/// line per step.
pub fn accuracy(
    scene: &Scene,
    options: &AccuracyOptions,
    progress: &mut dyn FnMut(&str),
) -> Result<AccuracyReport> {
    validate(options)?;
    let base = in_mode(scene, DirectMode::Exact);
    let plane = WorkPlane::new(
        &base,
        options.grid_height_m,
        options.grid_spacing_m,
        options.grid_spacing_m / 2.0,
    )?;
    if plane.receivers.is_empty() {
        return Err(Error::input(
            &scene.path,
            "",
            "every work-plane point lies inside furniture",
        ));
    }
    let grid = plane.receivers;
    let mut references = Vec::new();

    progress("order table");
    let (order, reference) = order_table(&base, options, &grid, progress)?;
    references.push(reference);
    progress("coarse patch size table");
    let (coarse, reference) = coarse_table(&base, options, &grid, progress)?;
    references.push(reference);
    progress("solver tolerance table");
    let (tolerance, reference) = tolerance_table(&base, options, &grid)?;
    references.push(reference);
    progress("fine patch size table");
    let room_bake = bake_with(&base, None)?;
    let floor = floor_samples(&base, options.grid_spacing_m);
    let fine = fine_table(&base, &room_bake, options, &floor)?;
    references.push(exact_reference(
        "fine patch size",
        "exact direct light plus indirect light gathered from the coarse patches at the same points",
    ));
    progress("quadrature and direct-light tables");
    let quadrature = quadrature_table(&base, &room_bake, options, &grid);
    references.push(exact_reference(
        "quadrature",
        "exact hat-function moments (Gauss–Legendre per segment)",
    ));
    let direct = direct_table(&base, &room_bake, options, &grid)?;
    references.push(exact_reference(
        "direct light",
        "the exact curve evaluated per point",
    ));
    progress("hierarchical engine table");
    let (engine, reference) = engine_table(&base, &grid)?;
    references.push(reference);
    progress("estimate table");
    let estimate = estimate_table(&base)?;
    references.push(exact_reference(
        "estimate",
        "the edited light's solve on the same engine",
    ));
    Ok(AccuracyReport {
        room: scene.name.clone(),
        fine_vertices: base.fine.n_vertices(),
        coarse_patches: base.coarse.patches.len(),
        grid_points: grid.len(),
        floor_points: floor.len(),
        references,
        order,
        coarse,
        fine,
        tolerance,
        quadrature,
        direct,
        engine,
        estimate,
    })
}

/// Every list non-empty and every value in range.
fn validate(options: &AccuracyOptions) -> Result<()> {
    let bad = |what: &str, why: &str| Err(Error::input("accuracy options", what, why));
    if options.orders.is_empty()
        || options.solver_patch_sizes_m.is_empty()
        || options.patch_sizes_m.is_empty()
        || options.tolerances.is_empty()
        || options.rectangle_steps_deg.is_empty()
    {
        return bad("", "every knob needs at least one value");
    }
    let positive = |v: &[f64]| v.iter().all(|&x| x > 0.0 && x.is_finite());
    if !positive(&options.solver_patch_sizes_m) || !positive(&options.patch_sizes_m) {
        return bad("patch sizes", "must be positive numbers of metres");
    }
    if !options.tolerances.iter().all(|&t| t > 0.0 && t <= 0.5) {
        return bad("tolerances", "must be in (0, 0.5]");
    }
    if !options.rectangle_steps_deg.iter().all(|&s| s > 0.0 && s <= 90.0) {
        return bad("rectangle steps", "must be in (0°, 90°]");
    }
    if options.repeats == 0 {
        return bad("repeats", "must be at least 1");
    }
    Ok(())
}

/// A copy of `scene` with direct light computed in `mode`.
fn in_mode(scene: &Scene, mode: DirectMode) -> Scene {
    let mut out = scene.clone();
    out.settings.direct = mode;
    out
}

/// A copy of `scene` with every light fixed at SH order `order`.
fn at_order(scene: &Scene, order: usize) -> Scene {
    let mut out = scene.clone();
    out.lights.iter_mut().for_each(|l| l.order = Some(order));
    out
}

/// Bakes without a cache at `tolerance` (the room's when `None`).
fn bake_with(scene: &Scene, tolerance: Option<f64>) -> Result<Bake> {
    let options = BakeOptions {
        plan: PlanOptions::default(),
        cache: None,
        tolerance,
        form_factors: None,
    };
    bake(scene, &options, &mut |_| {})
}

/// Bakes and returns the bake with its wall time in ms.
fn timed_bake(scene: &Scene, tolerance: Option<f64>) -> Result<(Bake, f64)> {
    let t = Instant::now();
    let b = bake_with(scene, tolerance)?;
    Ok((b, ms_since(t)))
}

fn ms_since(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// The median of `values` (0 for none); sorts them.
fn median(values: &mut [f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    values.sort_by(f64::total_cmp);
    let n = values.len();
    if n % 2 == 1 {
        values[n / 2]
    } else {
        0.5 * (values[n / 2 - 1] + values[n / 2])
    }
}

/// Lux (photopic) of linear-RGB illuminances.
fn lux(rgb: &[[f64; 3]]) -> Vec<f64> {
    rgb.iter().map(|&c| luminance_weight(c)).collect()
}

/// The illuminance of `scene` (in its direct mode) baked as `bake`: gathered on the work plane,
/// as the editor shows it on the fine vertices.
fn fields(scene: &Scene, bake: &Bake, grid: &[Receiver]) -> Fields {
    Fields {
        grid: illuminance_at_receivers(scene, Some(bake), scene.settings.direct, grid),
        vertices: lux(Relighter::with_bake(scene, bake).total()),
    }
}

/// Median wall time (ms) of one edit of light `light` (its dimmer toggled), over `repeats`.
/// Leaves the light as it was.
fn edit_ms(relighter: &mut Relighter, light: usize, repeats: usize) -> f64 {
    let dimmer = relighter.light(light).dimmer;
    let mut times: Vec<f64> = (0..repeats)
        .map(|r| {
            let t = Instant::now();
            relighter.set_dimmer(light, if r % 2 == 0 { 0.5 * dimmer } else { dimmer });
            ms_since(t)
        })
        .collect();
    relighter.set_dimmer(light, dimmer);
    median(&mut times)
}

/// `max |a − b| / max |b|` on the work plane and on the vertices.
fn field_difference(a: &Fields, b: &Fields) -> GridVertices {
    max_errors(&a.errors_against(b))
}

/// The max errors of `e`.
fn max_errors(e: &FieldErrors) -> GridVertices {
    GridVertices {
        grid: e.grid.max_rel,
        vertices: e.vertices.max_rel,
    }
}

/// A reference checked against a second, less refined run: converged when the two differ by
/// less than the smallest error of `rows` on both point sets.
fn checked_reference(
    table: &str,
    made: String,
    checked_against: String,
    difference: GridVertices,
    rows: impl Iterator<Item = FieldErrors>,
) -> Reference {
    let smallest = rows.map(|e| max_errors(&e)).fold(
        GridVertices {
            grid: f64::INFINITY,
            vertices: f64::INFINITY,
        },
        |m, e| GridVertices {
            grid: m.grid.min(e.grid),
            vertices: m.vertices.min(e.vertices),
        },
    );
    Reference {
        table: table.to_string(),
        made,
        checked_against: Some(checked_against),
        converged: difference.grid < smallest.grid && difference.vertices < smallest.vertices,
        difference: Some(difference),
        smallest_error: Some(smallest),
    }
}

/// A reference that is exact by construction.
fn exact_reference(table: &str, made: &str) -> Reference {
    Reference {
        table: table.to_string(),
        made: made.to_string(),
        checked_against: None,
        difference: None,
        smallest_error: None,
        converged: true,
    }
}

/// Table 1: every light at each order; hybrid and paper mode against a high-order hybrid run.
fn order_table(
    base: &Scene,
    options: &AccuracyOptions,
    grid: &[Receiver],
    progress: &mut dyn FnMut(&str),
) -> Result<(Vec<OrderRow>, Reference)> {
    let highest = options.orders.iter().copied().max().unwrap_or(0);
    let reference_order = (highest + 8).min(MAX_REFERENCE_ORDER).max(highest);
    let check_order = reference_order.saturating_sub(4).max(highest);
    progress(&format!("  reference: order {reference_order}"));
    let reference_scene = at_order(base, reference_order);
    let reference_bake = bake_with(&reference_scene, Some(REFERENCE_TOLERANCE))?;
    let reference = fields(&reference_scene, &reference_bake, grid);
    let mut rows = Vec::new();
    for &n in &options.orders {
        progress(&format!("  order {n}"));
        let hybrid_scene = at_order(base, n);
        let paper_scene = in_mode(&hybrid_scene, DirectMode::Basis);
        let (b, bake_ms) = timed_bake(&hybrid_scene, Some(REFERENCE_TOLERANCE))?;
        let hybrid = fields(&hybrid_scene, &b, grid);
        let paper = fields(&paper_scene, &b, grid);
        rows.push(OrderRow {
            order: n,
            columns: b.lights.iter().map(|l| l.n_columns).sum(),
            bake_ms,
            edit_ms: edit_ms(&mut Relighter::with_bake(&hybrid_scene, &b), 0, options.repeats),
            edit_paper_ms: edit_ms(&mut Relighter::with_bake(&paper_scene, &b), 0, options.repeats),
            hybrid: hybrid.errors_against(&reference),
            paper: paper.errors_against(&reference),
        });
    }
    let difference = if check_order < reference_order {
        progress(&format!("  convergence check: order {check_order}"));
        let check_scene = at_order(base, check_order);
        let check_bake = bake_with(&check_scene, Some(REFERENCE_TOLERANCE))?;
        field_difference(&fields(&check_scene, &check_bake, grid), &reference)
    } else {
        GridVertices {
            grid: 0.0,
            vertices: 0.0,
        }
    };
    let smallest = rows
        .iter()
        .filter(|r| r.order != reference_order)
        .map(|r| r.hybrid);
    let reference = checked_reference(
        "order",
        format!(
            "every light at order {reference_order}, hybrid mode, solver tolerance {REFERENCE_TOLERANCE:.0e}, \
             the room's patch sizes"
        ),
        format!("order {check_order}"),
        difference,
        smallest,
    );
    Ok((rows, reference))
}

/// Table 2: each coarse patch size against one smaller than all of them.
fn coarse_table(
    base: &Scene,
    options: &AccuracyOptions,
    grid: &[Receiver],
    progress: &mut dyn FnMut(&str),
) -> Result<(Vec<CoarseRow>, Reference)> {
    let fine_size = base.settings.patch_size;
    let smallest_size = options
        .solver_patch_sizes_m
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min);
    let reference_size = smallest_size / 2f64.sqrt();
    let check_size = smallest_size / 2f64.powf(0.25);
    let run = |size: f64| -> Result<(Scene, Bake, f64)> {
        let scene = remesh(base, fine_size, size)?;
        let (b, ms) = timed_bake(&scene, Some(REFERENCE_TOLERANCE))?;
        Ok((scene, b, ms))
    };
    progress(&format!("  reference: {reference_size:.3} m"));
    let (reference_scene, reference_bake, _) = run(reference_size)?;
    let reference = fields(&reference_scene, &reference_bake, grid);
    let mut rows = Vec::new();
    for &size in &options.solver_patch_sizes_m {
        progress(&format!("  coarse patches {size} m"));
        let (scene, b, bake_ms) = run(size)?;
        rows.push(CoarseRow {
            solver_patch_size_m: size,
            patches: scene.coarse.patches.len(),
            bake_ms,
            errors: fields(&scene, &b, grid).errors_against(&reference),
        });
    }
    progress(&format!("  convergence check: {check_size:.3} m"));
    let (check_scene, check_bake, _) = run(check_size)?;
    let difference = field_difference(&fields(&check_scene, &check_bake, grid), &reference);
    let smallest = rows.iter().map(|r| r.errors);
    let reference = checked_reference(
        "coarse patch size",
        format!(
            "coarse patches of {reference_size:.3} m (smallest tested / √2), the room's orders, solver tolerance \
             {REFERENCE_TOLERANCE:.0e}"
        ),
        format!("coarse patches of {check_size:.3} m"),
        difference,
        smallest,
    );
    Ok((rows, reference))
}

/// Largest true relative radiosity error over all columns of `bake` against `reference`:
/// `max_p |ρ_p (H_p − H_ref,p)| / max_p |ρ_p H_p|` per column and channel.
fn true_radiosity_error(scene: &Scene, bake: &Bake, reference: &Bake) -> f64 {
    let mut worst = 0.0f64;
    for (light, reference_light) in bake.lights.iter().zip(&reference.lights) {
        let k = light.n_columns;
        for (ch, (indirect, reference_indirect)) in
            light.indirect.iter().zip(&reference_light.indirect).enumerate()
        {
            let rho = patch_reflectance(scene, &scene.coarse, ch);
            for c in 0..k {
                let (mut diff, mut norm) = (0.0f64, 0.0f64);
                for (p, &r) in rho.iter().enumerate() {
                    let i = p * k + c;
                    let h = f64::from(light.direct[i]) + f64::from(indirect[i]);
                    diff = diff.max((r * (f64::from(indirect[i]) - f64::from(reference_indirect[i]))).abs());
                    norm = norm.max((r * h).abs());
                }
                if norm > 0.0 {
                    worst = worst.max(diff / norm);
                }
            }
        }
    }
    worst
}

/// Table 4: each solver tolerance against a 1e-8 solve of the same system.
fn tolerance_table(
    base: &Scene,
    options: &AccuracyOptions,
    grid: &[Receiver],
) -> Result<(Vec<ToleranceRow>, Reference)> {
    let reference_bake = bake_with(base, Some(REFERENCE_TOLERANCE))?;
    let reference = fields(base, &reference_bake, grid);
    let mut rows = Vec::new();
    for &tolerance in &options.tolerances {
        let b = bake_with(base, Some(tolerance))?;
        rows.push(ToleranceRow {
            tolerance,
            solve_ms: b.timings.solve_s * 1e3,
            iterations: b.lights.iter().map(|l| l.iterations).max().unwrap_or(0),
            certified_error: b.lights.iter().map(|l| l.certified_error).fold(0.0, f64::max),
            true_error: true_radiosity_error(base, &b, &reference_bake),
            errors: fields(base, &b, grid).errors_against(&reference),
        });
    }
    let check_tolerance = REFERENCE_TOLERANCE * 10.0;
    let check_bake = bake_with(base, Some(check_tolerance))?;
    let difference = field_difference(&fields(base, &check_bake, grid), &reference);
    let smallest = rows
        .iter()
        .filter(|r| r.tolerance > REFERENCE_TOLERANCE)
        .map(|r| r.errors);
    let reference = checked_reference(
        "solver tolerance",
        format!("solver tolerance {REFERENCE_TOLERANCE:.0e}, the room's orders and patch sizes"),
        format!("solver tolerance {check_tolerance:.0e}"),
        difference,
        smallest,
    );
    Ok((rows, reference))
}

/// The solver tolerance of every engine run of table 7 (so that the rows differ by their knobs).
const ENGINE_TOLERANCE: f64 = 1e-6;

/// The engine's knobs varied one at a time in table 7, from its defaults.
fn engine_variants() -> Vec<(&'static str, InterreflectionOptions)> {
    let with = |change: &dyn Fn(&mut InterreflectionOptions)| {
        let mut o = InterreflectionOptions::default();
        change(&mut o);
        o
    };
    vec![
        ("defaults (links 0.1)", InterreflectionOptions::default()),
        (
            "links relaxed: 0.1, up to 0.3 beyond 0.5 m",
            with(&|o| {
                o.links.near_m = RELAXED_NEAR_M;
                o.links.eta_far = RELAXED_ETA_FAR;
            }),
        ),
        ("links 0.2", with(&|o| o.links.eta = 0.2)),
        (
            "grading ratios 1 (lamps, contacts)",
            with(&|o| {
                o.refine.lamp_ratio = 1.0;
                o.refine.contact_ratio = 1.0;
            }),
        ),
        ("room edges not graded", with(&|o| o.refine.room_edge_min_m = 0.0)),
        ("no refinement", with(&|o| o.refine = RefineOptions::none())),
        (
            "direct pieces 1/8 of distance",
            with(&|o| o.direct_split = 1.0 / 8.0),
        ),
        (
            "gather clusters at 0.5 of distance",
            with(&|o| o.gather_eta = 0.5),
        ),
        ("gather constant on each leaf", with(&|o| o.linear_gather = false)),
        (
            "no shadow splits in the direct pieces",
            with(&|o| o.shadow_splits = 0),
        ),
    ]
}

/// The engine finer than its defaults in every knob of table 7, by `factor` (< 1).
fn finer_engine(factor: f64) -> InterreflectionOptions {
    let mut o = InterreflectionOptions::default();
    o.links.eta *= factor;
    o.refine.lamp_ratio *= factor;
    o.refine.contact_ratio *= factor;
    o.direct_split *= factor;
    o.gather_eta *= factor;
    o
}

/// One engine run of table 7: the engine with `options`, every light solved; its fields and its
/// sizes and times. `direct` holds the exact direct light on the work plane and at the fine
/// vertices.
fn engine_run(
    base: &Scene,
    options: &InterreflectionOptions,
    grid: &[Receiver],
    direct: &Fields,
) -> Result<(Fields, IndirectStats)> {
    let engine = HierarchicalIndirect::planned(
        base,
        &plan(base, PlanOptions::default()),
        ENGINE_TOLERANCE,
        options,
    )?;
    let stats = engine.stats();
    let gathered = lux(&engine.gather_all(grid));
    let mut vertex_indirect = vec![[0.0; 3]; direct.vertices.len()];
    for (i, light) in base.lights.iter().enumerate() {
        for (sum, v) in vertex_indirect.iter_mut().zip(engine.vertex_indirect(i)) {
            (0..3).for_each(|ch| sum[ch] += light.color[ch] * v[ch]);
        }
    }
    let add = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x + y).collect();
    let fields = Fields {
        grid: add(&direct.grid, &gathered),
        vertices: add(&direct.vertices, &lux(&vertex_indirect)),
    };
    Ok((fields, stats))
}

/// Table 7: the hierarchical engine's knobs one at a time, against the engine finer in all of
/// them (links, grading, direct pieces and gather at 0.5 of the defaults), checked against it at
/// 0.7. Empty when the room reflects no light.
fn engine_table(base: &Scene, grid: &[Receiver]) -> Result<(Vec<EngineRow>, Reference)> {
    if !plan(base, PlanOptions::default()).interreflection.on {
        return Ok((
            Vec::new(),
            exact_reference("hierarchical engine", "no interreflection: nothing to compare"),
        ));
    }
    let vertices = fine_receivers(base);
    let direct = Fields {
        grid: illuminance_at_receivers(base, None, DirectMode::Exact, grid),
        vertices: illuminance_at_receivers(base, None, DirectMode::Exact, &vertices),
    };
    let (reference, _) = engine_run(base, &finer_engine(0.5), grid, &direct)?;
    let mut rows = Vec::new();
    for (variant, options) in engine_variants() {
        let (fields, stats) = engine_run(base, &options, grid, &direct)?;
        let e = &stats.engine;
        rows.push(EngineRow {
            variant: variant.to_string(),
            leaves: e.leaves,
            links: e.links,
            build_ms: 1e3 * (e.refine_s + e.links_s + e.balance_s),
            solve_ms: 1e3 * (stats.direct_caches_s + stats.solve_s),
            errors: fields.errors_against(&reference),
        });
    }
    let (check, _) = engine_run(base, &finer_engine(0.7), grid, &direct)?;
    let reference = checked_reference(
        "hierarchical engine",
        "the engine at 0.5 of its default link ratio, grading ratios, direct pieces and gather ratio (tolerance 1e-6)".into(),
        "the same at 0.7".into(),
        field_difference(&check, &reference),
        rows.iter().map(|r| r.errors),
    );
    Ok((rows, reference))
}

/// Degrees of table 8's SH responses.
const ESTIMATE_ORDERS: [usize; 4] = [2, 4, 6, 8];

/// Table 8: light 0's re-aim and curve edit estimated from its SH response at each of
/// [`ESTIMATE_ORDERS`], and its values before the edit, against each edit's solve. Empty when
/// the room reflects no light or has no lights.
fn estimate_table(base: &Scene) -> Result<Vec<EstimateRow>> {
    let p = plan(base, PlanOptions::default());
    let Some(light) = base.lights.first().filter(|_| p.interreflection.on) else {
        return Ok(Vec::new());
    };
    let engine = HierarchicalIndirect::planned(
        base,
        &p,
        ENGINE_TOLERANCE,
        &InterreflectionOptions::for_leaves(p.leaves),
    )?;
    let (reaim, curve) = (measured_reaim(light), measured_curve_edit(light));
    let mut rows = Vec::new();
    for order in ESTIMATE_ORDERS {
        let aimed = engine.measure_estimate(base, 0, &reaim, order)?;
        let edited = engine.measure_estimate(base, 0, &curve, order)?;
        if rows.is_empty() {
            rows.push(EstimateRow {
                order: None,
                build_ms: 0.0,
                estimate_ms: 0.0,
                reaim: aimed.unestimated_error,
                curve: edited.unestimated_error,
                reaim_of_total: aimed.unestimated_error_of_total,
                curve_of_total: edited.unestimated_error_of_total,
            });
        }
        rows.push(EstimateRow {
            order: Some(order),
            build_ms: 1e3 * aimed.build_s,
            estimate_ms: 1e3 * aimed.estimate_s,
            reaim: aimed.error,
            curve: edited.error,
            reaim_of_total: aimed.error_of_total,
            curve_of_total: edited.error_of_total,
        });
    }
    Ok(rows)
}

/// Floor points (normal +z) on a grid offset from any regular vertex grid, inside floor patches.
fn floor_samples(scene: &Scene, spacing_m: f64) -> Vec<Receiver> {
    let size = scene.room_size;
    let along = |len: f64, offset: f64| {
        (0..)
            .map(move |i| (i as f64 + offset) * spacing_m)
            .take_while(move |&x| x < len)
    };
    along(size.y, FLOOR_SAMPLE_OFFSET[1])
        .flat_map(|y| along(size.x, FLOOR_SAMPLE_OFFSET[0]).map(move |x| DVec3::new(x, y, 0.0)))
        .filter(|&p| {
            !scene
                .boxes
                .iter()
                .chain(&scene.mesh_bounds)
                .any(|b| b.contains_strictly(p + DVec3::Z * 1e-6))
        })
        .map(|point| Receiver {
            point,
            normal: DVec3::Z,
        })
        .collect()
}

/// The fine-vertex field at floor `points` as the display interpolates it (linearly within the
/// triangles of the fine patches, quads split along their 0–2 diagonal); `None` where a point is
/// on no floor triangle.
fn on_floor(scene: &Scene, values: &[f64], points: &[Receiver]) -> Vec<Option<f64>> {
    let floor: Vec<[u32; 3]> = scene
        .fine
        .triangles()
        .filter(|(_, pid)| {
            let surface = scene.fine.patches[*pid as usize].surface as usize;
            scene.surfaces[surface].kind == SurfaceKind::Floor
        })
        .map(|(tri, _)| tri)
        .collect();
    points
        .iter()
        .map(|rx| {
            floor.iter().find_map(|tri| {
                let [a, b, c] = tri.map(|v| scene.fine.positions[v as usize].truncate());
                let p = rx.point.truncate();
                let det = (b - a).perp_dot(c - a);
                if det.abs() < 1e-15 {
                    return None;
                }
                let l1 = (p - a).perp_dot(c - a) / det;
                let l2 = (b - a).perp_dot(p - a) / det;
                let l0 = 1.0 - l1 - l2;
                let eps = -1e-9;
                (l0 >= eps && l1 >= eps && l2 >= eps).then(|| {
                    let [va, vb, vc] = tri.map(|v| values[v as usize]);
                    l0 * va + l1 * vb + l2 * vc
                })
            })
        })
        .collect()
}

/// Table 3: each fine patch size with the room's coarse mesh and bake.
fn fine_table(
    base: &Scene,
    bake: &Bake,
    options: &AccuracyOptions,
    floor: &[Receiver],
) -> Result<Vec<FineRow>> {
    let exact_floor = illuminance_at_receivers(base, Some(bake), DirectMode::Exact, floor);
    let mut rows = Vec::new();
    for &size in &options.patch_sizes_m {
        let mut scene = remesh(base, size, base.settings.solver_patch_size)?;
        scene.coarse = base.coarse.clone();
        let t = Instant::now();
        let mut relighter = Relighter::with_bake(&scene, bake);
        let relighter_build_ms = ms_since(t);
        let shown = lux(relighter.total());
        let exact_vertices =
            illuminance_at_receivers(&scene, Some(bake), DirectMode::Exact, &fine_receivers(&scene));
        let (interpolated, exact): (Vec<f64>, Vec<f64>) = on_floor(&scene, &shown, floor)
            .into_iter()
            .zip(&exact_floor)
            .filter_map(|(v, &e)| v.map(|v| (v, e)))
            .unzip();
        rows.push(FineRow {
            patch_size_m: size,
            vertices: scene.fine.n_vertices(),
            relighter_build_ms,
            edit_ms: edit_ms(&mut relighter, 0, options.repeats),
            at_vertices: ErrorStats::between(&shown, &exact_vertices),
            between_vertices: ErrorStats::between(&interpolated, &exact),
        });
    }
    Ok(rows)
}

/// One light's direct illuminance (lx, dimmer applied, colour not) at `receivers` from an
/// intensity function of γ (radians), masked to the half-space `mask` faces when given.
fn light_direct(
    scene: &Scene,
    i: usize,
    intensity: &dyn Fn(f64) -> f64,
    mask: Option<DVec3>,
    receivers: &[Receiver],
) -> Vec<f64> {
    let light = &scene.lights[i];
    let occluders = Occluders::of_scene(scene);
    let vis = occluders.as_ref().map(|o| o as &dyn Visibility);
    let unit = Curve::isotropic(1.0);
    receivers
        .iter()
        .map(|rx| {
            let g = illuminance_at(
                light.position,
                light.radius,
                &unit,
                light.aim,
                light.dimmer,
                rx,
                vis,
            );
            let dir = (rx.point - light.position).normalize_or_zero();
            if g == 0.0 || mask.is_some_and(|n| dir.dot(n) <= 0.0) {
                0.0
            } else {
                g * intensity(light.aim.dot(dir).clamp(-1.0, 1.0).acos())
            }
        })
        .collect()
}

/// Median wall time (ms) of `f` over `repeats`.
fn median_ms<T>(repeats: usize, mut f: impl FnMut() -> T) -> f64 {
    let mut times: Vec<f64> = (0..repeats)
        .map(|_| {
            let t = Instant::now();
            std::hint::black_box(f());
            ms_since(t)
        })
        .collect();
    median(&mut times)
}

/// Table 5: exact weights vs the rectangle rule, per light.
fn quadrature_table(
    base: &Scene,
    bake: &Bake,
    options: &AccuracyOptions,
    grid: &[Receiver],
) -> Vec<QuadratureRow> {
    let highest = options.orders.iter().copied().max().unwrap_or(0);
    let mut rows = Vec::new();
    for (i, (light, baked)) in base.lights.iter().zip(&bake.lights).enumerate() {
        let order = baked.plan.order;
        let mask = baked.plan.mask.map(DVec3::from);
        let exact_high = ZonalWeights::exact(&light.curve, highest);
        let exact = ZonalWeights::exact(&light.curve, order);
        let window = auto_window(&light.curve, &exact, order);
        let direct_from = |w: &ZonalWeights| {
            let series = w.truncated(order).windowed(window);
            light_direct(base, i, &|g| series.eval_rad(g), mask, grid)
        };
        let exact_direct = direct_from(&exact);
        let w_max = exact_high.w.iter().fold(0.0f64, |m, w| m.max(w.abs()));
        let methods = std::iter::once(None).chain(options.rectangle_steps_deg.iter().map(|&s| Some(s)));
        for step in methods {
            let compute = || match step {
                None => ZonalWeights::exact(&light.curve, highest),
                Some(s) => ZonalWeights::rectangle_rule(&light.curve, highest, s),
            };
            let time_ms = median_ms(options.repeats, compute);
            let w = compute();
            let w_diff =
                w.w.iter()
                    .zip(&exact_high.w)
                    .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            rows.push(QuadratureRow {
                light: light.name.clone(),
                method: step.map_or("exact".to_string(), |s| format!("rectangle {s}°")),
                step_deg: step,
                time_ms,
                weight_error: if w_max > 0.0 { w_diff / w_max } else { 0.0 },
                illuminance: ErrorStats::between(&direct_from(&w), &exact_direct),
            });
        }
    }
    rows
}

/// Table 6: per light, its direct light exact (hybrid) and from its series (paper) at the order
/// each mode's plan gives it, against the exact curve.
fn direct_table(
    base: &Scene,
    hybrid_bake: &Bake,
    options: &AccuracyOptions,
    grid: &[Receiver],
) -> Result<Vec<DirectRow>> {
    let paper_scene = in_mode(base, DirectMode::Basis);
    let paper_bake = bake_with(&paper_scene, None)?;
    let mut hybrid = Relighter::with_bake(base, hybrid_bake);
    let mut paper = Relighter::with_bake(&paper_scene, &paper_bake);
    let paper_plan = plan(&paper_scene, PlanOptions::default());
    let mut rows = Vec::new();
    for (i, light) in base.lights.iter().enumerate() {
        let exact = Fields {
            grid: light_direct(base, i, &|g| light.curve.eval_rad(g), None, grid),
            vertices: hybrid.light_direct(i).to_vec(),
        };
        let lp = &paper_plan.lights[i];
        let series = ZonalWeights::exact(&light.curve, lp.order).windowed(lp.window);
        let from_series = Fields {
            grid: light_direct(base, i, &|g| series.eval_rad(g), lp.mask.map(DVec3::from), grid),
            vertices: paper.light_direct(i).to_vec(),
        };
        let hybrid_errors = exact.errors_against(&exact);
        let paper_errors = from_series.errors_against(&exact);
        rows.push(DirectRow {
            light: light.name.clone(),
            mode: "hybrid".into(),
            order: hybrid_bake.lights[i].plan.order,
            edit_ms: edit_ms(&mut hybrid, i, options.repeats),
            direct: hybrid_errors,
        });
        rows.push(DirectRow {
            light: light.name.clone(),
            mode: "paper".into(),
            order: lp.order,
            edit_ms: edit_ms(&mut paper, i, options.repeats),
            direct: paper_errors,
        });
    }
    Ok(rows)
}
