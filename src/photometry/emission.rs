//! What one luminaire emits right now, as the relighter and the gather need it: its curve, aim,
//! dimmer and colour, and the SH coefficients of its aimed, windowed series
//! (`c_lm = dimmer · σ_l w_l · 4π/(2l+1) · Y_lm(aim)`, docs/METHOD.md §5).

use glam::DVec3;

use crate::photometry::{Curve, ShBasis, Window, ZonalWeights, aimed_coefficients, auto_window, sh_count};

/// The editable state of one light: what an edit may change without a new bake.
#[derive(Debug, Clone, PartialEq)]
pub struct LightState {
    /// Intensity curve (cd).
    pub curve: Curve,
    /// Unit aim axis (world).
    pub aim: DVec3,
    /// Dimmer factor, ≥ 0.
    pub dimmer: f64,
    /// Linear RGB colour multipliers.
    pub color: [f64; 3],
}

/// The SH coefficients `c_k = dimmer · σ_l w_l 4π/(2l+1) Y_lm(aim)` (cd) of a light for a baked
/// order, with the window chosen automatically (`window = None`) or forced; returns the window
/// used.
pub fn light_coefficients(
    state: &LightState,
    order: usize,
    window: Option<Window>,
    basis: &ShBasis,
) -> (Vec<f64>, Window) {
    let weights = ZonalWeights::exact(&state.curve, order);
    let mut coeffs = vec![0.0; sh_count(basis.order())];
    let window = coefficients_from_weights(state, &weights, window, basis, &mut coeffs);
    (coeffs, window)
}

/// As [`light_coefficients`], from the curve's weights `weights` (exact, or kept current edit
/// by edit with [`crate::photometry::IncrementalWeights`]; degrees above `basis.order()` are
/// ignored) into `out[..sh_count(basis.order())]`. Returns the window used. No allocation
/// beyond the windowed weights.
pub fn coefficients_from_weights(
    state: &LightState,
    weights: &ZonalWeights,
    window: Option<Window>,
    basis: &ShBasis,
    out: &mut [f64],
) -> Window {
    let order = basis.order().min(weights.order());
    let truncated = weights.truncated(order);
    let window = window.unwrap_or_else(|| auto_window(&state.curve, &truncated, order));
    aimed_coefficients(&truncated.windowed(window), state.aim, basis, out);
    out.iter_mut().for_each(|c| *c *= state.dimmer);
    window
}
