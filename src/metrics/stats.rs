//! Illuminance statistics of a calculation surface and their check against its targets
//! (docs/ROOM_FILE.md, "Design numbers").
//!
//! The targets of EN 12464-1 are maintained values: what the installation still gives at the
//! end of its maintenance cycle. Haiko computes new values and multiplies them by the room's
//! maintenance factor; the ratios U0 and g2 do not change with it.

use serde::Serialize;

use crate::scene::design::Targets;

/// Statistics of a grid's maintained illuminance (lx).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SurfaceStats {
    /// Number of points.
    pub points: usize,
    /// The maintenance factor applied.
    pub maintenance_factor: f64,
    /// Mean maintained illuminance Ē, lx.
    pub e_avg: f64,
    /// Lowest, lx.
    pub e_min: f64,
    /// Highest, lx.
    pub e_max: f64,
    /// Uniformity U0 = E_min / Ē (0 when Ē = 0).
    pub u0: f64,
    /// Uniformity g2 = E_min / E_max (0 when E_max = 0).
    pub g2: f64,
}

impl SurfaceStats {
    /// Statistics of the new illuminances `lux_new` (lx, one per grid point) maintained by
    /// `maintenance_factor`; `None` for an empty grid.
    pub fn of(lux_new: &[f64], maintenance_factor: f64) -> Option<Self> {
        if lux_new.is_empty() {
            return None;
        }
        let mean_new = lux_new.iter().sum::<f64>() / lux_new.len() as f64;
        let min_new = lux_new.iter().copied().fold(f64::INFINITY, f64::min);
        let max_new = lux_new.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let ratio = |num: f64, den: f64| if den > 0.0 { num / den } else { 0.0 };
        Some(SurfaceStats {
            points: lux_new.len(),
            maintenance_factor,
            e_avg: maintenance_factor * mean_new,
            e_min: maintenance_factor * min_new,
            e_max: maintenance_factor * max_new,
            u0: ratio(min_new, mean_new),
            g2: ratio(min_new, max_new),
        })
    }
}

/// A value against an optional lower bound.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Check {
    /// The value.
    pub value: f64,
    /// The target it must reach (at least), if any.
    pub target: Option<f64>,
    /// Whether it does; `None` without a target.
    pub pass: Option<bool>,
}

impl Check {
    /// `value` against "at least `target`".
    pub fn at_least(value: f64, target: Option<f64>) -> Self {
        Check {
            value,
            target,
            pass: target.map(|t| value >= t),
        }
    }

    /// The mark shown next to the value: `✓`, `✗` or empty without a target.
    pub fn mark(&self) -> &'static str {
        match self.pass {
            Some(true) => "✓",
            Some(false) => "✗",
            None => "",
        }
    }
}

/// A surface's statistics against its targets.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SurfaceCheck {
    /// Maintained mean Ē against Ē_m.
    pub e_avg: Check,
    /// U0 against its target.
    pub u0: Check,
    /// g2 against its target.
    pub g2: Check,
}

impl SurfaceCheck {
    /// `stats` against `targets`.
    pub fn of(stats: &SurfaceStats, targets: &Targets) -> Self {
        SurfaceCheck {
            e_avg: Check::at_least(stats.e_avg, targets.maintained_lux),
            u0: Check::at_least(stats.u0, targets.u0),
            g2: Check::at_least(stats.g2, targets.g2),
        }
    }

    /// `Some(true)` when every target is met, `Some(false)` when one is missed, `None` without
    /// targets.
    pub fn pass(&self) -> Option<bool> {
        let verdicts = [self.e_avg.pass, self.u0.pass, self.g2.pass];
        if verdicts.iter().all(Option::is_none) {
            None
        } else {
            Some(verdicts.iter().all(|v| *v != Some(false)))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statistics_by_hand() {
        // New values 400, 500, 600, 700 lx: mean 550, min 400, max 700; maintained with 0.8:
        // Ē = 440, E_min = 320, E_max = 560; U0 = 400/550 = 0.72727, g2 = 400/700 = 0.571429.
        let s = SurfaceStats::of(&[400.0, 500.0, 600.0, 700.0], 0.8).unwrap();
        assert_eq!(s.points, 4);
        assert!((s.e_avg - 440.0).abs() < 1e-12);
        assert!((s.e_min - 320.0).abs() < 1e-12);
        assert!((s.e_max - 560.0).abs() < 1e-12);
        assert!((s.u0 - 8.0 / 11.0).abs() < 1e-15);
        assert!((s.g2 - 4.0 / 7.0).abs() < 1e-15);
        assert_eq!(SurfaceStats::of(&[], 0.8), None);
        let dark = SurfaceStats::of(&[0.0, 0.0], 1.0).unwrap();
        assert_eq!((dark.u0, dark.g2), (0.0, 0.0));
    }

    #[test]
    fn checks_against_office_targets() {
        let s = SurfaceStats::of(&[400.0, 500.0, 600.0, 700.0], 0.8).unwrap();
        let office = Targets {
            maintained_lux: Some(500.0),
            u0: Some(0.6),
            g2: None,
            ugr_limit: Some(19.0),
        };
        let c = SurfaceCheck::of(&s, &office);
        // Ē = 440 < 500 fails; U0 0.727 ≥ 0.6 passes; no g2 target.
        assert_eq!(
            (c.e_avg.pass, c.u0.pass, c.g2.pass),
            (Some(false), Some(true), None)
        );
        assert_eq!(c.pass(), Some(false));
        assert_eq!((c.e_avg.mark(), c.u0.mark(), c.g2.mark()), ("✗", "✓", ""));
        let lenient = Targets {
            maintained_lux: Some(440.0),
            ..office
        };
        assert_eq!(SurfaceCheck::of(&s, &lenient).pass(), Some(true));
        assert_eq!(SurfaceCheck::of(&s, &Targets::default()).pass(), None);
    }
}
