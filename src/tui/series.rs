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

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use super::*;
    use crate::photometry::Curve;
    use crate::scene::{AimSpec, LidSource, Light};
    use glam::DVec3;

    fn light(points: &[(f64, f64)], order: usize, window: Window) -> LightEdit {
        let mut edit = LightEdit::from_light(&Light {
            name: "test".into(),
            position: DVec3::new(1.0, 1.0, 2.0),
            aim: DVec3::NEG_Z,
            aim_spec: AimSpec::Direction(DVec3::NEG_Z),
            curve: Curve::new(points).unwrap(),
            lid_source: LidSource::Inline,
            order: Some(order),
            radius: 0.05,
            dimmer: 0.5,
            color: [1.0; 3],
            luminous: None,
        });
        edit.window = window;
        edit
    }

    fn unpack(msg: Msg) -> (usize, Vec<(f64, f64)>, f64) {
        match msg {
            Msg::Series {
                light,
                samples,
                relative_error,
            } => (light, samples, relative_error),
            other => panic!("not a series: {other:?}"),
        }
    }

    const SPOT: [(f64, f64); 4] = [(0.0, 2500.0), (15.0, 2000.0), (30.0, 600.0), (45.0, 0.0)];

    #[test]
    fn an_isotropic_curve_is_its_own_series() {
        let (index, samples, error) = unpack(series_msg(
            3,
            &light(&[(0.0, 100.0), (180.0, 100.0)], 5, Window::None),
        ));
        assert_eq!(index, 3);
        assert_eq!(samples.len(), 181);
        for (i, &(gamma, cd)) in samples.iter().enumerate() {
            assert!((gamma - (i as f64).to_radians()).abs() < 1e-12);
            assert!((cd - 100.0).abs() < 1e-9, "{cd} at {gamma}");
        }
        // The error is √(‖I‖² − captured energy): the square root of a rounding-level difference.
        assert!(error < 1e-7, "{error}");
    }

    #[test]
    fn every_window_keeps_the_flux_of_the_curve() {
        for window in [
            Window::None,
            Window::Hann,
            Window::Lanczos,
            Window::Cesaro2,
            Window::Auto,
        ] {
            let edit = light(&SPOT, 8, window);
            let (_, samples, _) = unpack(series_msg(0, &edit));
            // Φ = 2π ∫ I(γ) sin γ dγ, trapezoid rule on the 1° samples.
            let step = 1f64.to_radians();
            let flux: f64 = samples
                .windows(2)
                .map(|p| 0.5 * step * (p[0].1 * p[0].0.sin() + p[1].1 * p[1].0.sin()))
                .sum::<f64>()
                * 2.0
                * PI;
            let expected = edit.curve.flux_lm();
            assert!(
                (flux - expected).abs() < 1e-3 * expected,
                "{window:?}: {flux} vs {expected}"
            );
        }
    }

    #[test]
    fn windows_trade_error_for_ringing_and_auto_picks_hann_for_a_ringing_spot() {
        let (_, plain, plain_error) = unpack(series_msg(0, &light(&SPOT, 5, Window::None)));
        let (_, hann, hann_error) = unpack(series_msg(0, &light(&SPOT, 5, Window::Hann)));
        let (_, auto, _) = unpack(series_msg(0, &light(&SPOT, 5, Window::Auto)));
        // The 5th-order spot rings below zero; a window only removes energy (σ_l ≤ 1).
        let min = |s: &[(f64, f64)]| s.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
        assert!(min(&plain) < -0.005 * 2500.0, "{}", min(&plain));
        assert!(min(&hann) > min(&plain));
        assert!(hann_error >= plain_error);
        assert_eq!(auto, hann);
    }
}
