//! Legendre weights `w_l` of a piecewise-linear intensity curve (docs/METHOD.md §3):
//! exact hat-function moments, the exact weights built from them, and the paper's rectangle rule
//! kept for the accuracy report.

use std::f64::consts::PI;

use crate::photometry::Curve;
use crate::photometry::gauss::GaussLegendre;
use crate::photometry::legendre::{legendre_series, legendre_table};
use crate::photometry::truncation::Window;

/// The hat-function moments `H[l][k] = ∫ hat_k(γ) P_l(cos γ) sin γ dγ` (γ in radians) of a
/// curve's knots, for l ≤ order.
///
/// `hat_k` is 1 at knot k, 0 at the other knots, linear in γ between them and 0 outside the
/// knots' span, so the curve is `Σ_k I_k hat_k` exactly (a repeated angle is a step). Each segment
/// is integrated by Gauss–Legendre in γ with `n = ceil(0.5 (L+2) h + 0.5 log2(L+2) + 8)` nodes
/// (h in radians), which is exact to ~1e-15 · h (docs/METHOD.md §3).
#[derive(Debug, Clone)]
pub struct HatMoments {
    order: usize,
    knots: usize,
    /// Column-major: `h[k * (order + 1) + l]`, so one knot's column is contiguous.
    h: Vec<f64>,
}

impl HatMoments {
    /// Computes the moments of every hat of `curve` for l = 0..=order.
    pub fn new(curve: &Curve, order: usize) -> Self {
        let knots = curve.len();
        let mut moments = HatMoments {
            order,
            knots,
            h: vec![0.0; knots * (order + 1)],
        };
        let mut scratch = SegmentScratch::new(order);
        for segment in 0..knots - 1 {
            moments.add_segment(curve, segment, 0..knots, &mut scratch);
        }
        moments
    }

    /// The highest Legendre degree tabulated.
    pub fn order(&self) -> usize {
        self.order
    }

    /// The number of knots (hats).
    pub fn knots(&self) -> usize {
        self.knots
    }

    /// `H[l][k]` (radians, dimensionless integrand). Panics if `l > order` or `k ≥ knots`.
    pub fn get(&self, l: usize, k: usize) -> f64 {
        assert!(
            l <= self.order && k < self.knots,
            "hat moment ({l}, {k}) out of range"
        );
        self.h[k * (self.order + 1) + l]
    }

    /// Knot k's column `H[0..=order][k]`.
    pub fn column(&self, k: usize) -> &[f64] {
        let n = self.order + 1;
        &self.h[k * n..(k + 1) * n]
    }

    /// Recomputes the columns of hats k−1, k, k+1 after knot k of `curve` moved (its angle
    /// changed); every other column is unaffected by that move.
    pub(crate) fn update_around(&mut self, curve: &Curve, k: usize) {
        assert_eq!(
            curve.len(),
            self.knots,
            "the curve's knot count changed: rebuild instead"
        );
        let hats = k.saturating_sub(1)..(k + 2).min(self.knots);
        let n = self.order + 1;
        self.h[hats.start * n..hats.end * n].fill(0.0);
        let mut scratch = SegmentScratch::new(self.order);
        // Segments touching those hats: [k−2, k−1] … [k+1, k+2].
        for segment in k.saturating_sub(2)..(k + 2).min(self.knots - 1) {
            self.add_segment(curve, segment, hats.clone(), &mut scratch);
        }
    }

    /// Adds segment `[γ_s, γ_(s+1)]`'s part of the moments of hats s and s+1, if in `hats`.
    fn add_segment(
        &mut self,
        curve: &Curve,
        segment: usize,
        hats: std::ops::Range<usize>,
        scratch: &mut SegmentScratch,
    ) {
        let g = curve.gammas_deg();
        let (a, b) = (g[segment].to_radians(), g[segment + 1].to_radians());
        let h = b - a;
        if h <= 0.0 {
            return; // a step: zero length, no contribution
        }
        let big_l = (self.order + 2) as f64;
        let nodes = (0.5 * big_l * h + 0.5 * big_l.log2() + 8.0).ceil() as usize;
        let SegmentScratch { p: legendre, rules } = scratch;
        let rule = cached_rule(rules, nodes);
        let n = self.order + 1;
        let (left, right) = (segment, segment + 1);
        for (&x, &weight) in rule.nodes.iter().zip(&rule.weights) {
            let t = 0.5 * (x + 1.0); // position in the segment, 0 at a, 1 at b
            let gamma = a + h * t;
            legendre_table(gamma.cos(), self.order, legendre);
            let common = 0.5 * h * weight * gamma.sin();
            if hats.contains(&left) {
                let f = common * (1.0 - t);
                for (dst, p) in self.h[left * n..(left + 1) * n].iter_mut().zip(legendre.iter()) {
                    *dst += f * p;
                }
            }
            if hats.contains(&right) {
                let f = common * t;
                for (dst, p) in self.h[right * n..(right + 1) * n].iter_mut().zip(legendre.iter()) {
                    *dst += f * p;
                }
            }
        }
    }
}

/// Per-build scratch: a Legendre table and the Gauss–Legendre rules used so far, by node count.
struct SegmentScratch {
    p: Vec<f64>,
    rules: Vec<Option<GaussLegendre>>,
}

impl SegmentScratch {
    fn new(order: usize) -> Self {
        SegmentScratch {
            p: vec![0.0; order + 1],
            rules: Vec::new(),
        }
    }
}

/// The `nodes`-point Gauss–Legendre rule, built on first use.
fn cached_rule(rules: &mut Vec<Option<GaussLegendre>>, nodes: usize) -> &GaussLegendre {
    if rules.len() <= nodes {
        rules.resize_with(nodes + 1, || None);
    }
    rules[nodes].get_or_insert_with(|| GaussLegendre::new(nodes))
}

/// Legendre weights `w_l`, l = 0..=order, of the zonal series `I(γ) ≈ Σ_l w_l P_l(cos γ)`
/// (candela; γ from the light's aim axis).
#[derive(Debug, Clone, PartialEq)]
pub struct ZonalWeights {
    /// `w[l]` in candela.
    pub w: Vec<f64>,
}

impl ZonalWeights {
    /// The exact weights of the piecewise-linear curve, `w_l = (2l+1)/2 Σ_k I_k H[l][k]`.
    pub fn exact(curve: &Curve, order: usize) -> Self {
        let moments = HatMoments::new(curve, order);
        let mut w = vec![0.0; order + 1];
        fill_exact_weights(&moments, curve.intensities_cd(), &mut w);
        ZonalWeights { w }
    }

    /// The paper's rectangle rule (eq. 4–5): `w_l = (2l+1)/2 Σ_j I(jΔγ) P_l(cos jΔγ) sin(jΔγ) Δγ`
    /// over the samples `jΔγ ≤ 180°`, with `Δγ = step_deg` degrees. Kept only to show its error
    /// against [`ZonalWeights::exact`].
    ///
    /// Panics unless `step_deg` is finite and > 0 (callers validate user-supplied steps).
    pub fn rectangle_rule(curve: &Curve, order: usize, step_deg: f64) -> Self {
        assert!(
            step_deg.is_finite() && step_deg > 0.0,
            "rectangle step must be > 0°, got {step_deg}"
        );
        let step_rad = step_deg.to_radians();
        let samples = (180.0 / step_deg + 1e-9).floor() as usize;
        let mut w = vec![0.0; order + 1];
        let mut p = vec![0.0; order + 1];
        for j in 0..=samples {
            let gamma_deg = j as f64 * step_deg;
            let gamma = gamma_deg.to_radians();
            legendre_table(gamma.cos(), order, &mut p);
            let f = curve.eval_deg(gamma_deg) * gamma.sin() * step_rad;
            for (wl, pl) in w.iter_mut().zip(&p) {
                *wl += f * pl;
            }
        }
        for (l, wl) in w.iter_mut().enumerate() {
            *wl *= (2 * l + 1) as f64 / 2.0;
        }
        ZonalWeights { w }
    }

    /// The highest degree N (there are N+1 weights).
    pub fn order(&self) -> usize {
        self.w.len() - 1
    }

    /// Luminous flux of the series, `4π w_0` (lumens); independent of truncation and windows.
    pub fn flux_lm(&self) -> f64 {
        4.0 * PI * self.w[0]
    }

    /// The series' intensity `Σ_l w_l P_l(cos γ)` (candela) at `gamma_rad` radians from the axis.
    pub fn eval_rad(&self, gamma_rad: f64) -> f64 {
        legendre_series(&self.w, gamma_rad.cos())
    }

    /// The first `min(order, self.order()) + 1` weights.
    pub fn truncated(&self, order: usize) -> ZonalWeights {
        ZonalWeights {
            w: self.w[..=order.min(self.order())].to_vec(),
        }
    }

    /// The weights multiplied by `window`'s factors `σ_l` for this order (σ_0 = 1: flux kept).
    pub fn windowed(&self, window: Window) -> ZonalWeights {
        let sigma = window.factors(self.order());
        ZonalWeights {
            w: self.w.iter().zip(&sigma).map(|(w, s)| w * s).collect(),
        }
    }
}

/// `w[l] = (2l+1)/2 Σ_k intensity_cd[k] H[l][k]` for l < w.len() (≤ moments.order() + 1).
/// No allocation: also the incremental editor's resync.
pub(crate) fn fill_exact_weights(moments: &HatMoments, intensity_cd: &[f64], w: &mut [f64]) {
    w.fill(0.0);
    for (k, &i_k) in intensity_cd.iter().enumerate() {
        for (wl, h) in w.iter_mut().zip(moments.column(k)) {
            *wl += i_k * h;
        }
    }
    for (l, wl) in w.iter_mut().enumerate() {
        *wl *= (2 * l + 1) as f64 / 2.0;
    }
}
