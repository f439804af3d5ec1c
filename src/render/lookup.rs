//! Per-pixel curve evaluation without a binary search or a libm call: [`CurveLookup`] finds a
//! curve's segment through a table over γ and returns exactly what [`Curve::eval_deg`] returns
//! (same comparisons, same arithmetic); [`acos`] is a polynomial arc cosine accurate to 2.5e-8 rad.

use crate::photometry::Curve;

/// Buckets per degree of the segment table (γ from 0° to 180°).
const BUCKETS_PER_DEG: f64 = 4.0;
const N_BUCKETS: usize = (180.0 * BUCKETS_PER_DEG) as usize + 1;

/// A curve with a table from γ to its first candidate control point.
#[derive(Debug, Clone, PartialEq)]
pub struct CurveLookup {
    gamma_deg: Vec<f64>,
    intensity_cd: Vec<f64>,
    /// Per bucket `[b/4°, (b+1)/4°)`: the first control point with γ ≥ b/4°.
    first: Vec<u16>,
    /// `cos` of the last control point's angle minus a margin: below it the curve is 0.
    cos_last: f64,
}

impl CurveLookup {
    /// The table of `curve`.
    pub fn new(curve: &Curve) -> CurveLookup {
        let gamma_deg = curve.gammas_deg().to_vec();
        let first = (0..N_BUCKETS)
            .map(|b| {
                let lo = b as f64 / BUCKETS_PER_DEG;
                gamma_deg.partition_point(|&g| g < lo) as u16
            })
            .collect();
        let last = gamma_deg[gamma_deg.len() - 1];
        CurveLookup {
            cos_last: last.to_radians().cos() - 1e-9,
            intensity_cd: curve.intensities_cd().to_vec(),
            first,
            gamma_deg,
        }
    }

    /// Intensity (cd) at the angle whose cosine is `cos_gamma`, 0 when it lies past the last
    /// control point (tested on the cosine first, before any arc cosine).
    #[inline]
    pub fn eval_cos(&self, cos_gamma: f64) -> f64 {
        if cos_gamma < self.cos_last {
            return 0.0;
        }
        self.eval_rad(acos(cos_gamma))
    }

    /// Intensity (cd) at `gamma_rad`: [`Curve::eval_rad`], bit for bit.
    #[inline]
    pub fn eval_rad(&self, gamma_rad: f64) -> f64 {
        self.eval_deg(gamma_rad.to_degrees())
    }

    /// Intensity (cd) at `gamma_deg`: [`Curve::eval_deg`], bit for bit.
    #[inline]
    pub fn eval_deg(&self, gamma_deg: f64) -> f64 {
        let g = &self.gamma_deg;
        let last = g.len() - 1;
        if !(gamma_deg >= g[0] && gamma_deg <= g[last]) {
            return 0.0;
        }
        let bucket = ((gamma_deg * BUCKETS_PER_DEG) as usize).min(N_BUCKETS - 1);
        let mut i = usize::from(self.first[bucket]);
        while g[i] < gamma_deg {
            i += 1;
        }
        if i == 0 || g[i] == gamma_deg {
            return self.intensity_cd[i];
        }
        let (a, b) = (g[i - 1], g[i]);
        let t = (gamma_deg - a) / (b - a);
        self.intensity_cd[i - 1] + t * (self.intensity_cd[i] - self.intensity_cd[i - 1])
    }
}

/// Arc cosine (radians) of `x ∈ [−1, 1]` (clamped), within 2.5e-8 rad of the exact value
/// (Abramowitz & Stegun 4.4.46: `acos x = √(1−x) Σ a_k x^k` on [0, 1], `π − acos(−x)` below).
#[inline]
pub fn acos(x: f64) -> f64 {
    const A: [f64; 8] = [
        1.570_796_305_0,
        -0.214_598_801_6,
        0.088_978_987_4,
        -0.050_174_304_6,
        0.030_891_881_0,
        -0.017_088_125_6,
        0.006_670_090_1,
        -0.001_262_491_1,
    ];
    let x = x.clamp(-1.0, 1.0);
    let a = x.abs();
    let mut poly = A[7];
    for k in (0..7).rev() {
        poly = poly.mul_add(a, A[k]);
    }
    let r = (1.0 - a).sqrt() * poly;
    if x >= 0.0 { r } else { std::f64::consts::PI - r }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_lookup_returns_the_curves_own_values_bit_for_bit() {
        let curves = [
            Curve::new(&[(0.0, 6000.0), (12.0, 6000.0), (12.0, 0.0), (90.0, 0.0)]).unwrap(),
            Curve::new(&[
                (0.0, 4000.0),
                (8.0, 4000.0),
                (8.0, 1500.0),
                (15.0, 1500.0),
                (15.0, 0.0),
            ])
            .unwrap(),
            Curve::new(&[(10.0, 50.0), (10.1, 900.0), (33.3, 120.0), (179.9, 7.0)]).unwrap(),
            Curve::isotropic(100.0),
        ];
        for curve in &curves {
            let lookup = CurveLookup::new(curve);
            for k in 0..=200_000 {
                let gamma_deg = -1.0 + 182.0 * f64::from(k) / 200_000.0;
                assert_eq!(
                    lookup.eval_deg(gamma_deg).to_bits(),
                    curve.eval_deg(gamma_deg).to_bits(),
                    "γ = {gamma_deg}°"
                );
            }
            // Exactly on every control point (steps return the first of the two values).
            for &g in curve.gammas_deg() {
                assert_eq!(lookup.eval_deg(g), curve.eval_deg(g), "γ = {g}°");
                assert_eq!(lookup.eval_rad(g.to_radians()), curve.eval_rad(g.to_radians()));
            }
        }
    }

    #[test]
    fn the_cosine_entry_agrees_with_the_exact_arc_cosine() {
        let curve = Curve::new(&[(0.0, 1000.0), (30.0, 950.0), (60.0, 700.0), (90.0, 0.0)]).unwrap();
        let lookup = CurveLookup::new(&curve);
        for k in 0..=10_000 {
            let c = -1.0 + 2.0 * f64::from(k) / 10_000.0;
            let exact = curve.eval_rad(c.acos());
            // The slope is at most 1000 cd over 30° (1910 cd/rad); 2.5e-8 rad of angle error.
            assert!(
                (lookup.eval_cos(c) - exact).abs() <= 1910.0 * 2.5e-8 + 1e-9,
                "cos γ = {c}"
            );
        }
    }

    #[test]
    fn the_polynomial_arc_cosine_is_within_2_5e_8_rad() {
        let mut worst = 0.0f64;
        for k in 0..=1_000_000 {
            let x = -1.0 + 2.0 * f64::from(k) / 1_000_000.0;
            worst = worst.max((acos(x) - x.acos()).abs());
        }
        assert!(worst <= 2.5e-8, "worst error {worst} rad");
        assert!(worst > 0.0, "a polynomial is not exact");
        assert_eq!(acos(1.0), 0.0);
        assert!((acos(-1.0) - std::f64::consts::PI).abs() < 1e-15);
        assert_eq!(acos(2.0), 0.0, "clamped");
    }
}
