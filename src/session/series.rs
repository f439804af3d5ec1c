//! The truncated, windowed series a light really emits, sampled for the polar diagram.

use crate::photometry::{ZonalWeights, auto_window, truncation_stats};
use crate::session::light::LightEdit;

/// Angular step of the samples, degrees.
pub const SAMPLE_STEP_DEG: usize = 1;

/// A light's series as the polar diagram draws it.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Samples `(γ in radians, intensity in cd before the dimmer)`, γ = 0°, 1°, …, 180°.
    pub samples: Vec<(f64, f64)>,
    /// Relative L2 truncation error of the series against the curve (0.01 = 1 %).
    pub relative_error: f64,
}

impl Series {
    /// `light`'s order-N series (`weights` are its curve's Legendre weights for l ≤ N),
    /// windowed as the light says (`Auto`: Hann where the plain series rings below −0.5 % of
    /// the peak, docs/METHOD.md §4.4).
    pub fn of(light: &LightEdit, weights: &ZonalWeights) -> Series {
        let order = light.order.min(weights.order());
        let window = light
            .window
            .forced()
            .unwrap_or_else(|| auto_window(&light.curve, weights, order));
        let series = weights.truncated(order).windowed(window);
        let samples = (0..=180)
            .step_by(SAMPLE_STEP_DEG)
            .map(|deg| {
                let gamma_rad = f64::from(deg).to_radians();
                (gamma_rad, series.eval_rad(gamma_rad))
            })
            .collect();
        let stats = truncation_stats(&light.curve, weights, order, window);
        Series {
            samples,
            relative_error: stats.rel_l2_error,
        }
    }
}
