//! Aiming a zonal series: the addition theorem `P_l(a·ω) = 4π/(2l+1) Σ_m Y_lm(a) Y_lm(ω)` turns
//! the Legendre weights of a curve about its axis `a` into real-SH coefficients in the world frame
//! (paper eq. 1–2, docs/METHOD.md §5).

use std::f64::consts::PI;

use glam::DVec3;

use crate::photometry::sh::{ShBasis, sh_count, sh_index};
use crate::photometry::weights::ZonalWeights;

/// Writes `c_lm = w_l · 4π/(2l+1) · Y_lm(aim)` for l ≤ `basis.order()` into
/// `out[..sh_count(basis.order())]` (candela).
///
/// `weights` are used as given (apply truncation and windows first, so `w_l` here is `σ_l w_l`);
/// degrees above `weights.order()` get 0. `aim` is the light's unit axis in the world frame (z up).
/// No allocation. Panics if `out` is shorter than `sh_count(basis.order())`.
pub fn aimed_coefficients(weights: &ZonalWeights, aim: DVec3, basis: &ShBasis, out: &mut [f64]) {
    basis.eval(aim, out);
    for l in 0..=basis.order() {
        let scale = weights
            .w
            .get(l)
            .map_or(0.0, |w| w * 4.0 * PI / (2 * l + 1) as f64);
        for c in &mut out[sh_index(l, -(l as isize))..sh_count(l)] {
            *c *= scale;
        }
    }
}

/// The aimed intensity `I(dir) = Σ_lm c_lm Y_lm(dir)` (candela) toward the unit world direction
/// `dir`. `coeffs` as written by [`aimed_coefficients`] with the same `basis`. No allocation.
pub fn eval_aimed(coeffs: &[f64], dir: DVec3, basis: &ShBasis) -> f64 {
    basis.dot(coeffs, dir)
}
