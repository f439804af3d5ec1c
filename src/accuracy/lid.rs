//! `haiko lid FILE|ROOM#LIGHT`: what a curve emits and what its SH series costs and buys.

use std::path::Path;
use std::time::Instant;

use serde::Serialize;

use crate::error::{Error, Result};
use crate::photometry::{
    Curve, IncrementalWeights, Window, ZonalWeights, auto_window, choose_order, read_lid_file,
    truncation_stats,
};
use crate::scene;

/// Target relative L2 error for the order `haiko lid` chooses (unwindowed, docs/METHOD.md §4.4).
pub(crate) const LID_TARGET_REL_L2: f64 = 0.05;
/// Highest order `haiko lid` chooses automatically.
pub(crate) const LID_MAX_AUTO_ORDER: usize = 60;
/// Sample step of the rectangle rule timed beside the exact fit (degrees).
pub(crate) const RECTANGLE_STEP_DEG: f64 = 1.0;

/// One row of the per-order table.
#[derive(Debug, Clone, Serialize)]
pub struct OrderRow {
    /// SH order N.
    pub order: usize,
    /// Window applied at this order.
    pub window: &'static str,
    /// Exact relative L2 error of the (windowed) truncated series.
    pub rel_l2_error: f64,
    /// max |I_N − I| (cd) on a 0.25° grid.
    pub max_abs_error_cd: f64,
    /// Most negative value of I_N (cd).
    pub min_cd: f64,
    /// (max I_N − peak) / peak.
    pub overshoot: f64,
    /// Median time to compute w_0..w_N exactly (µs).
    pub fit_exact_us: f64,
    /// Median time of the rectangle rule at 1° (µs).
    pub fit_rectangle_us: f64,
    /// Median time of one incremental edit (µs).
    pub edit_us: f64,
}

/// The whole report (`--json` prints it as one object).
#[derive(Debug, Clone, Serialize)]
pub struct LidReport {
    /// Luminous flux (lm), exact.
    pub flux_lm: f64,
    /// Peak intensity (cd).
    pub peak_cd: f64,
    /// Max relative deviation of a C-plane from the axial average (0 for inline curves).
    pub asymmetry: f64,
    /// The order chosen for `LID_TARGET_REL_L2`: the lowest that meets it, or
    /// `LID_MAX_AUTO_ORDER` when none up to that cap does.
    pub order: usize,
    /// Exact relative L2 error of the unwindowed series at `order`; above `LID_TARGET_REL_L2`
    /// when the cap was reached first (a hard-edged curve).
    pub order_rel_l2_error: f64,
    /// Legendre weights w_0..w_N (cd), unwindowed.
    pub weights: Vec<f64>,
    /// One row per order 0..=N.
    pub orders: Vec<OrderRow>,
}

/// Median wall time of `f` in microseconds (batches of repeats, median of 7 batches).
fn median_us(mut f: impl FnMut()) -> f64 {
    let start = Instant::now();
    f();
    let once = start.elapsed().as_secs_f64().max(1e-8);
    let repeats = ((2e-4 / once).ceil() as usize).clamp(1, 10_000);
    let mut samples: Vec<f64> = (0..7)
        .map(|_| {
            let t = Instant::now();
            for _ in 0..repeats {
                f();
            }
            t.elapsed().as_secs_f64() * 1e6 / repeats as f64
        })
        .collect();
    samples.sort_by(f64::total_cmp);
    samples[3]
}

/// Builds the report for a curve: flux, order choice, and the per-order table up to `max_order`
/// (default: the chosen order, at least 16). `window` forces a window; `None` decides per order.
pub fn report(curve: &Curve, asymmetry: f64, max_order: Option<usize>, window: Option<Window>) -> LidReport {
    let chosen = choose_order(curve, LID_TARGET_REL_L2, LID_MAX_AUTO_ORDER);
    let n = max_order.unwrap_or(chosen.max(16));
    let full = ZonalWeights::exact(curve, n);
    let edit_point = curve
        .intensities_cd()
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))
        .map_or(0, |(k, _)| k);
    let orders = (0..=n)
        .map(|order| {
            let truncated = full.truncated(order);
            let window = window.unwrap_or_else(|| auto_window(curve, &truncated, order));
            let stats = truncation_stats(curve, &truncated, order, window);
            let mut editor = IncrementalWeights::new(curve.clone(), order);
            let peak = curve.intensities_cd()[edit_point];
            let mut toggle = false;
            // Lowered, not raised, so the edit stays valid at the top of the intensity range.
            let edit_us = median_us(|| {
                toggle = !toggle;
                let value = if toggle { peak * 0.99 } else { peak };
                editor
                    .set_intensity(edit_point, value)
                    .expect("a fraction of a valid intensity is valid");
            });
            OrderRow {
                order,
                window: window.name(),
                rel_l2_error: stats.rel_l2_error,
                max_abs_error_cd: stats.max_abs_error_cd,
                min_cd: stats.min_cd,
                overshoot: stats.overshoot,
                fit_exact_us: median_us(|| {
                    std::hint::black_box(ZonalWeights::exact(curve, order));
                }),
                fit_rectangle_us: median_us(|| {
                    std::hint::black_box(ZonalWeights::rectangle_rule(curve, order, RECTANGLE_STEP_DEG));
                }),
                edit_us,
            }
        })
        .collect();
    LidReport {
        flux_lm: curve.flux_lm(),
        peak_cd: curve.peak_cd(),
        asymmetry,
        order: chosen,
        order_rel_l2_error: truncation_stats(
            curve,
            &ZonalWeights::exact(curve, chosen),
            chosen,
            Window::None,
        )
        .rel_l2_error,
        weights: full.w,
        orders,
    }
}

/// Loads the curve named by `source`: a photometric file, or `ROOM.toml#LIGHT` (a `#` elsewhere
/// belongs to the file name).
pub(crate) fn load_curve(source: &str) -> Result<(Curve, f64)> {
    if let Some((room, light)) = source
        .rsplit_once('#')
        .filter(|(room, _)| room.ends_with(".toml"))
    {
        let scene = scene::load(Path::new(room))?;
        let found = scene.lights.iter().find(|l| l.name == light).ok_or_else(|| {
            let names: Vec<&str> = scene.lights.iter().map(|l| l.name.as_str()).collect();
            Error::input(
                room,
                "",
                format!("no light named `{light}` (lights: {})", names.join(", ")),
            )
        })?;
        let asymmetry = match &found.lid_source {
            scene::LidSource::File { asymmetry, .. } => *asymmetry,
            scene::LidSource::Inline => 0.0,
        };
        return Ok((found.curve.clone(), asymmetry));
    }
    let file = read_lid_file(Path::new(source))?;
    Ok((file.curve, file.asymmetry))
}
