//! Truncating and windowing the zonal series (docs/METHOD.md §4): window factors, the exact L2 error
//! from Parseval, ringing measured on a 0.25° grid, the automatic order and window choice.

use std::f64::consts::PI;

use crate::photometry::Curve;
use crate::photometry::legendre::legendre_series;
use crate::photometry::weights::ZonalWeights;

/// Ringing (Gibbs) control: factors `σ_l` multiplying `w_l`. Every window has `σ_0 = 1`, so the
/// flux `4π w_0` is unchanged.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Window {
    /// `σ_l = 1`.
    None,
    /// `σ_l = ½ (1 + cos(π l / (N+1)))`: removes ~90 % of a hard edge's negative lobe.
    Hann,
    /// `σ_l = sinc(l / (N+1)) = sin(π l/(N+1)) / (π l/(N+1))`.
    Lanczos,
    /// Cesàro (C,2) means: `σ_l = (N−l+1)(N−l+2) / ((N+1)(N+2))`; a positive kernel, so the
    /// series of a non-negative curve is never negative (but blurs heavily).
    Cesaro2,
}

impl Window {
    /// `σ_0 ..= σ_order` for a series truncated at degree `order` (N).
    pub fn factors(self, order: usize) -> Vec<f64> {
        let n1 = (order + 1) as f64;
        (0..=order)
            .map(|l| {
                let lf = l as f64;
                match self {
                    Window::None => 1.0,
                    Window::Hann => 0.5 * (1.0 + (PI * lf / n1).cos()),
                    Window::Lanczos if l == 0 => 1.0,
                    Window::Lanczos => {
                        let x = PI * lf / n1;
                        x.sin() / x
                    }
                    Window::Cesaro2 => (n1 - lf) * (n1 - lf + 1.0) / (n1 * (n1 + 1.0)),
                }
            })
            .collect()
    }

    /// Lower-case name for reports and files: `none`, `hann`, `lanczos`, `cesaro2`.
    pub fn name(self) -> &'static str {
        match self {
            Window::None => "none",
            Window::Hann => "hann",
            Window::Lanczos => "lanczos",
            Window::Cesaro2 => "cesaro2",
        }
    }
}

/// Step of the grid on which ringing is measured (degrees).
const GRID_STEP_DEG: f64 = 0.25;

/// A negative lobe deeper than this fraction of the peak calls for a window (docs/METHOD.md §4.4).
const NEGATIVE_LOBE_LIMIT: f64 = 0.005;

/// How well the windowed series of order N represents its curve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruncationStats {
    /// The truncation degree N.
    pub order: usize,
    /// The window applied.
    pub window: Window,
    /// `‖I_N − I‖ / ‖I‖` over the sphere, exact (Parseval); 0 for an all-zero curve.
    pub rel_l2_error: f64,
    /// `max |I_N(γ) − I(γ)|` on the 0.25° grid (candela).
    pub max_abs_error_cd: f64,
    /// `min I_N(γ)` on the 0.25° grid (candela; negative = ringing lobe).
    pub min_cd: f64,
    /// `(max I_N − peak) / peak` on the grid (dimensionless; 0 for an all-zero curve).
    pub overshoot: f64,
}

/// Error and ringing of the series of `curve` truncated at `order` and windowed by `window`.
///
/// `weights` must be the curve's exact weights (e.g. [`ZonalWeights::exact`]) of order ≥ `order`
/// (fewer are treated as zero). The L2 error is
/// `e² = [Σ_{l≤N} (1−σ_l)² w_l² 2/(2l+1) + ‖I‖² − Σ_{l≤N} w_l² 2/(2l+1)] / ‖I‖²`
/// with `‖I‖²` from [`Curve::norm_squared`] (docs/METHOD.md §4).
pub fn truncation_stats(
    curve: &Curve,
    weights: &ZonalWeights,
    order: usize,
    window: Window,
) -> TruncationStats {
    let sigma = window.factors(order);
    let exact = &weights.w[..weights.w.len().min(order + 1)];
    let norm2 = curve.norm_squared();
    let mut window_loss = 0.0;
    let mut captured = 0.0;
    for (l, (&w, &s)) in exact.iter().zip(&sigma).enumerate() {
        let energy = w * w * 2.0 / (2 * l + 1) as f64;
        window_loss += (1.0 - s) * (1.0 - s) * energy;
        captured += energy;
    }
    let rel_l2_error = if norm2 > 0.0 {
        ((window_loss + (norm2 - captured).max(0.0)) / norm2).sqrt()
    } else {
        0.0
    };

    let series: Vec<f64> = exact.iter().zip(&sigma).map(|(w, s)| w * s).collect();
    let mut max_abs_error_cd: f64 = 0.0;
    let mut min_cd = f64::INFINITY;
    let mut max_cd = f64::NEG_INFINITY;
    for gamma_deg in grid_deg() {
        let value = legendre_series(&series, gamma_deg.to_radians().cos());
        max_abs_error_cd = max_abs_error_cd.max((value - curve.eval_deg(gamma_deg)).abs());
        min_cd = min_cd.min(value);
        max_cd = max_cd.max(value);
    }
    let peak = curve.peak_cd();
    TruncationStats {
        order,
        window,
        rel_l2_error,
        max_abs_error_cd,
        min_cd,
        overshoot: if peak > 0.0 { (max_cd - peak) / peak } else { 0.0 },
    }
}

/// The angles 0°, 0.25°, …, 180°.
fn grid_deg() -> impl Iterator<Item = f64> {
    let steps = (180.0 / GRID_STEP_DEG) as usize;
    (0..=steps).map(|i| i as f64 * GRID_STEP_DEG)
}

/// The smallest N ≤ `max_order` whose unwindowed relative L2 error is ≤ `target_rel_l2`, from the
/// exact tail energy `‖I‖² − Σ_{l≤N} w_l² 2/(2l+1)` (docs/METHOD.md §4.4); `max_order` if none is.
pub fn choose_order(curve: &Curve, target_rel_l2: f64, max_order: usize) -> usize {
    let norm2 = curve.norm_squared();
    if norm2 <= 0.0 {
        return 0;
    }
    let weights = ZonalWeights::exact(curve, max_order);
    let mut captured = 0.0;
    for (l, w) in weights.w.iter().enumerate() {
        captured += w * w * 2.0 / (2 * l + 1) as f64;
        let rel_l2 = ((norm2 - captured).max(0.0) / norm2).sqrt();
        if rel_l2 <= target_rel_l2 {
            return l;
        }
    }
    max_order
}

/// [`Window::Hann`] when the unwindowed series at `order` dips below −0.5 % of the curve's peak
/// on the 0.25° grid, else [`Window::None`] (docs/METHOD.md §4.4). `weights` as in [`truncation_stats`].
pub fn auto_window(curve: &Curve, weights: &ZonalWeights, order: usize) -> Window {
    let stats = truncation_stats(curve, weights, order, Window::None);
    if stats.min_cd < -NEGATIVE_LOBE_LIMIT * curve.peak_cd() {
        Window::Hann
    } else {
        Window::None
    }
}
