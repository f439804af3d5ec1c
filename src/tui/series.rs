//! The truncated, windowed series a light really emits, sampled for the polar diagram
//! ([`crate::tui::msg::Msg::Series`]).

use crate::photometry::{self, ZonalWeights, auto_window, truncation_stats};
use crate::tui::model::{LightEdit, Window};
use crate::tui::msg::Msg;

/// Angular step of the samples: 1°.
pub const SAMPLE_STEP_DEG: usize = 1;

/// The photometry window a light's editor window stands for (`Auto`: the plan's rule, Hann
/// where the plain series rings below −0.5 % of the peak).
pub fn effective_window(light: &LightEdit, exact: &ZonalWeights) -> photometry::Window {
    match light.window {
        Window::Auto => auto_window(&light.curve, exact, light.order),
        Window::None => photometry::Window::None,
        Window::Hann => photometry::Window::Hann,
        Window::Lanczos => photometry::Window::Lanczos,
        Window::Cesaro2 => photometry::Window::Cesaro2,
    }
}

/// [`Msg::Series`] for light `index`: its order-N series windowed as the light says, sampled
/// at γ = 0°, 1°, …, 180° (as radians, intensity in cd, before the dimmer), and the series'
/// relative L2 error against the curve.
pub fn series_msg(index: usize, light: &LightEdit) -> Msg {
    let exact = ZonalWeights::exact(&light.curve, light.order);
    let window = effective_window(light, &exact);
    let series = exact.windowed(window);
    let samples = (0..=180)
        .step_by(SAMPLE_STEP_DEG)
        .map(|deg| {
            let gamma_rad = f64::from(deg).to_radians();
            (gamma_rad, series.eval_rad(gamma_rad))
        })
        .collect();
    let stats = truncation_stats(&light.curve, &exact, light.order, window);
    Msg::Series {
        light: index,
        samples,
        relative_error: stats.rel_l2_error,
    }
}
