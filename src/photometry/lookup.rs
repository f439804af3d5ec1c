//! Curve evaluation without a binary search or a libm call, for the loops that evaluate a curve
//! once per pixel or per quadrature sample (the renderer's per-pixel direct light, the engine's
//! patch direct light of every edit): [`CurveLookup`] finds a
//! curve's segment through a table over γ and returns what [`Curve::eval_deg`] returns (the
//! same comparisons, so steps fall on the same side; the fraction along a segment by a stored
//! reciprocal instead of a division, within 4e-15 relative); [`acos`] is a polynomial arc cosine
//! accurate to 2.5e-8 rad.
//!
//! For a light being edited the per-pixel angle can be kept as a **curve coordinate**
//! `(k, t)` ([`CurveLookup::coordinate_deg`]): the segment's first control point `k` and the
//! fraction `t` along it. An edit that changes intensities but no angle (the usual key press)
//! then costs one interpolation per pixel ([`CurveLookup::at_coordinate`]).

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
    /// The intensities (cd) in f32, the last one repeated once (so `k + 1` is always valid),
    /// then two zeros: the segment of angles outside the curve ([`CurveLookup::outside`]).
    values: Vec<f32>,
    /// Per point `i > 0`: `1 / (γ_i − γ_{i−1})` (0 at a step).
    inv_width: Vec<f64>,
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
        let mut values: Vec<f32> = curve.intensities_cd().iter().map(|&i| i as f32).collect();
        values.push(values[values.len() - 1]);
        values.extend([0.0, 0.0]);
        let inv_width = (0..gamma_deg.len())
            .map(|i| match i {
                0 => 0.0,
                _ if gamma_deg[i] > gamma_deg[i - 1] => 1.0 / (gamma_deg[i] - gamma_deg[i - 1]),
                _ => 0.0,
            })
            .collect();
        CurveLookup {
            inv_width,
            cos_last: last.to_radians().cos() - 1e-9,
            values,
            intensity_cd: curve.intensities_cd().to_vec(),
            first,
            gamma_deg,
        }
    }

    /// Intensity (cd) at the angle whose cosine is `cos_gamma`, 0 when it lies past the last
    /// control point (tested on the cosine first, before any arc cosine).
    #[inline]
    pub fn eval_cos(&self, cos_gamma: f64) -> f64 {
        self.value(self.segment_cos(cos_gamma))
    }

    /// The segment ([`Self::segment`]) of the angle whose cosine is `cos_gamma`, as
    /// [`Self::eval_cos`] finds it: `None` past the last control point, tested on the cosine.
    #[inline]
    pub fn segment_cos(&self, cos_gamma: f64) -> Option<(usize, Option<f64>)> {
        if cos_gamma < self.cos_last {
            return None;
        }
        self.segment(acos(cos_gamma).to_degrees())
    }

    /// Intensity (cd) at `gamma_rad`: [`Curve::eval_rad`] (module docs).
    #[inline]
    pub fn eval_rad(&self, gamma_rad: f64) -> f64 {
        self.eval_deg(gamma_rad.to_degrees())
    }

    /// Intensity (cd) at `gamma_deg`: [`Curve::eval_deg`] (module docs).
    #[inline]
    pub fn eval_deg(&self, gamma_deg: f64) -> f64 {
        self.value(self.segment(gamma_deg))
    }

    /// The intensity (cd) at a [`Self::segment`].
    #[inline(always)]
    fn value(&self, segment: Option<(usize, Option<f64>)>) -> f64 {
        match segment {
            None => 0.0,
            Some((i, None)) => self.intensity_cd[i],
            Some((i, Some(t))) => {
                self.intensity_cd[i - 1] + t * (self.intensity_cd[i] - self.intensity_cd[i - 1])
            }
        }
    }

    /// The curve coordinate `(k, t)` of `gamma_deg` (module docs): the segment's first control
    /// point and the fraction along it, or `(`[`CurveLookup::outside`]`, 0)` outside the curve.
    #[inline]
    pub fn coordinate_deg(&self, gamma_deg: f64) -> (u32, f32) {
        match self.segment(gamma_deg) {
            None => (self.outside(), 0.0),
            Some((i, None)) => (i as u32, 0.0),
            Some((i, Some(t))) => ((i - 1) as u32, t as f32),
        }
    }

    /// The segment index of angles outside the curve for this lookup (its intensities are 0).
    #[inline]
    pub fn outside(&self) -> u32 {
        (self.values.len() - 2) as u32
    }

    /// Intensity (cd) at curve coordinate `(k, t)` (from [`CurveLookup::coordinate_deg`] of a
    /// curve with the same angles): no branch, no conversion, 0 outside the curve.
    #[inline]
    pub fn at_coordinate(&self, k: u32, t: f32) -> f32 {
        let k = (k as usize).min(self.values.len() - 2);
        let (a, b) = (self.values[k], self.values[k + 1]);
        a + t * (b - a)
    }

    /// True when `other` has the same control-point angles (its curve coordinates are valid here).
    pub fn same_angles(&self, other: &CurveLookup) -> bool {
        self.gamma_deg == other.gamma_deg
    }

    /// `None` outside the curve; else the first point `i` with `γ_i ≥ γ` and, unless γ is on a
    /// point (or before the first), the fraction `t` along the segment `i − 1 → i`:
    /// [`Curve::segment_deg`] (module docs).
    #[inline(always)]
    pub fn segment(&self, gamma_deg: f64) -> Option<(usize, Option<f64>)> {
        let g = &self.gamma_deg;
        let last = g.len() - 1;
        if !(gamma_deg >= g[0] && gamma_deg <= g[last]) {
            return None;
        }
        let bucket = ((gamma_deg * BUCKETS_PER_DEG) as usize).min(N_BUCKETS - 1);
        let mut i = usize::from(self.first[bucket]);
        while g[i] < gamma_deg {
            i += 1;
        }
        if i == 0 || g[i] == gamma_deg {
            return Some((i, None));
        }
        Some((i, Some((gamma_deg - g[i - 1]) * self.inv_width[i])))
    }
}

/// Intervals of a [`SinHalfTable`]: `s = sin(γ/2)` from 0 to 1 in steps of 1/4096 (γ steps of
/// at most 0.028° up to 90°, 0.08° at 150°).
const SIN_HALF_STEPS: usize = 4096;

/// A curve sampled uniformly in `s = sin(γ/2) = √((1 − cos γ) / 2)` (f32), for adding up the
/// lights that are not being edited: the intensity from cos γ costs one square root and one
/// linear interpolation — no search, no arc cosine (docs/DECISIONS.md, "Light-major sum of the
/// other lights"). Between control points the curve is linear in γ and γ is smooth in `s`, so
/// the interpolation is within f32 rounding there; a step of the table that holds a control
/// point (a corner, a step of the curve, its end) is evaluated exactly by the [`CurveLookup`].
/// Angles past the last control point read exactly 0.
#[derive(Debug, Clone, PartialEq)]
pub struct SinHalfTable {
    /// Intensity (cd) at `s = j / SIN_HALF_STEPS`, the last value repeated once (`j + 1` always
    /// valid).
    values: Vec<f32>,
    /// Bit `j` set when step `j` (from `s = j / SIN_HALF_STEPS` to the next) holds a control
    /// point.
    exact: Vec<u64>,
    lookup: CurveLookup,
}

impl SinHalfTable {
    /// The table of the curve behind `lookup`.
    pub fn new(lookup: &CurveLookup) -> SinHalfTable {
        let n = SIN_HALF_STEPS as f64;
        let mut values: Vec<f32> = (0..=SIN_HALF_STEPS)
            .map(|j| lookup.eval_rad(2.0 * (j as f64 / n).asin()) as f32)
            .collect();
        values.push(values[SIN_HALF_STEPS]);
        let mut exact = vec![0u64; (SIN_HALF_STEPS + 1).div_ceil(64)];
        for &g in &lookup.gamma_deg {
            // The step(s) whose closed interval holds γ (both, when γ falls on a sample).
            let x = (g.to_radians() / 2.0).sin() * n;
            for j in [x.floor() - 1.0, x.floor(), x.ceil()] {
                let j = j.clamp(0.0, n) as usize;
                exact[j / 64] |= 1 << (j % 64);
            }
        }
        SinHalfTable {
            values,
            exact,
            lookup: lookup.clone(),
        }
    }

    /// Intensity (cd) at the angle whose cosine is `cos_gamma`.
    #[inline]
    pub fn eval_cos(&self, cos_gamma: f32) -> f32 {
        if f64::from(cos_gamma) < self.lookup.cos_last {
            return 0.0;
        }
        let x = ((0.5 - 0.5 * cos_gamma).max(0.0).sqrt() * SIN_HALF_STEPS as f32).min(SIN_HALF_STEPS as f32);
        let j = x as usize;
        if self.exact[j / 64] >> (j % 64) & 1 == 1 {
            return self.lookup.eval_cos(f64::from(cos_gamma)) as f32;
        }
        let t = x - j as f32;
        let (a, b) = (self.values[j], self.values[j + 1]);
        a + t * (b - a)
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
    // Estrin's scheme (three dependent steps instead of seven); not `mul_add`, which without a
    // target FMA instruction is a slow library call.
    let (a2, a4) = (a * a, a * a * a * a);
    let low = (A[0] + A[1] * a) + a2 * (A[2] + A[3] * a);
    let high = (A[4] + A[5] * a) + a2 * (A[6] + A[7] * a);
    let r = (1.0 - a).sqrt() * (low + a4 * high);
    if x >= 0.0 { r } else { std::f64::consts::PI - r }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_lookup_returns_the_curves_own_values() {
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
                let (got, want) = (lookup.eval_deg(gamma_deg), curve.eval_deg(gamma_deg));
                assert!(
                    (got - want).abs() <= 4e-15 * want.abs(),
                    "γ = {gamma_deg}°: {got} vs {want}"
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
    fn curve_coordinates_survive_intensity_edits() {
        let curve = Curve::new(&[
            (0.0, 4000.0),
            (8.0, 4000.0),
            (8.0, 1500.0),
            (15.0, 1500.0),
            (40.0, 0.0),
        ])
        .unwrap();
        let mut edited = curve.clone();
        edited.set_intensity(3, 2500.0).unwrap();
        edited.set_intensity(0, 100.0).unwrap();
        let (lookup, after) = (CurveLookup::new(&curve), CurveLookup::new(&edited));
        assert!(lookup.same_angles(&after));
        for k in 0..=4_000 {
            let gamma = -1.0 + 50.0 * f64::from(k) / 4_000.0;
            let (k, t) = lookup.coordinate_deg(gamma);
            for (l, c) in [(&lookup, &curve), (&after, &edited)] {
                let exact = c.eval_deg(gamma);
                let got = f64::from(l.at_coordinate(k, t));
                assert!(
                    (got - exact).abs() <= 1e-6 * 4000.0,
                    "γ = {gamma}: {got} vs {exact}"
                );
            }
        }
        let mut moved = curve.clone();
        moved.set_gamma(4, 45.0).unwrap();
        assert!(!lookup.same_angles(&CurveLookup::new(&moved)));
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
    fn the_sin_half_table_follows_the_curve_within_f32_rounding() {
        let points = [(0.0, 1000.0), (30.0, 950.0), (60.0, 700.0), (90.0, 0.0)];
        let curve = Curve::new(&points).unwrap();
        let table = SinHalfTable::new(&CurveLookup::new(&curve));
        let mut worst = 0.0f64;
        for k in 0..=200_000 {
            let c = -1.0 + 2.0 * k as f32 / 200_000.0;
            let gamma = f64::from(c).acos();
            let (got, exact) = (f64::from(table.eval_cos(c)), curve.eval_rad(gamma));
            if gamma.to_degrees() > 90.0 {
                assert_eq!(got, 0.0, "cos γ = {c}: past the curve");
            }
            worst = worst.max((got - exact).abs());
        }
        // f32 rounding of cos γ (the slope is at most 1337 cd/rad) and of the values: 1e-6 of
        // the peak; the steps holding a control point are evaluated exactly.
        assert!(worst <= 1e-3, "worst {worst} cd");
    }

    #[test]
    fn the_sin_half_table_keeps_the_step_of_a_spot_sharp() {
        let curve = Curve::new(&[(0.0, 2500.0), (12.0, 2500.0), (12.0, 0.0), (90.0, 0.0)]).unwrap();
        let table = SinHalfTable::new(&CurveLookup::new(&curve));
        for k in 0..=20_000 {
            let gamma_deg = 11.0 + 2.0 * f64::from(k) / 20_000.0;
            let c = gamma_deg.to_radians().cos() as f32;
            let exact = curve.eval_rad(f64::from(c).acos());
            assert!(
                (f64::from(table.eval_cos(c)) - exact).abs() <= 1e-3,
                "γ = {gamma_deg}°"
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
