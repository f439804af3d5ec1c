//! Real orthonormal spherical harmonics `Y_lm` (∫ Y² dΩ = 1, with the Condon–Shortley phase),
//! evaluated as polynomials in the unit direction (x, y, z) of the world frame (z up) by the fully
//! normalised forward-column recurrence of docs/METHOD.md §2: no θ/φ, no pole special case, no
//! factorials, accurate to ~1e-13 at l = 150.

use std::f64::consts::{PI, SQRT_2};

use glam::DVec3;

/// Position of `Y_lm` (−l ≤ m ≤ l) in a coefficient vector ordered by l, then m: `l² + l + m`.
pub const fn sh_index(l: usize, m: isize) -> usize {
    (l * l + l).wrapping_add_signed(m)
}

/// Number of real SH functions of degree `l ≤ order`: `(order + 1)²`.
pub const fn sh_count(order: usize) -> usize {
    (order + 1) * (order + 1)
}

/// The recurrence coefficients of the real SH up to one order, tabulated once.
#[derive(Debug, Clone)]
pub struct ShBasis {
    order: usize,
    /// `−sqrt((2m+1)/(2m))` for m ≥ 1 (index m; entry 0 unused): `p_mm = diag[m] · p_(m−1)(m−1)`.
    diag: Vec<f64>,
    /// `sqrt(2m+3)`: `p_(m+1)m = sub[m] · z · p_mm`.
    sub: Vec<f64>,
    /// `(a_lm, b_lm)` for m = 0..=order, then l = m+2..=order, in that (column) order:
    /// `p_lm = a_lm z p_(l−1)m − b_lm p_(l−2)m`.
    ab: Vec<(f64, f64)>,
}

impl ShBasis {
    /// Tabulates the recurrence up to degree `order` ((N+1)(N+2)/2 entries).
    pub fn new(order: usize) -> Self {
        let diag = (0..=order)
            .map(|m| {
                let mf = m as f64;
                if m == 0 {
                    0.0
                } else {
                    -((2.0 * mf + 1.0) / (2.0 * mf)).sqrt()
                }
            })
            .collect();
        let sub = (0..=order).map(|m| (2.0 * m as f64 + 3.0).sqrt()).collect();
        let mut ab = Vec::new();
        for m in 0..=order {
            let mf = m as f64;
            for l in m + 2..=order {
                let lf = l as f64;
                let l2m2 = lf * lf - mf * mf;
                let a = ((4.0 * lf * lf - 1.0) / l2m2).sqrt();
                let b =
                    ((2.0 * lf + 1.0) * (lf - mf - 1.0) * (lf + mf - 1.0) / ((2.0 * lf - 3.0) * l2m2)).sqrt();
                ab.push((a, b));
            }
        }
        ShBasis { order, diag, sub, ab }
    }

    /// The highest degree l this basis evaluates.
    pub fn order(&self) -> usize {
        self.order
    }

    /// Writes `Y_lm(dir)` for all l ≤ order into `out[..sh_count(order)]` at [`sh_index`]`(l, m)`.
    ///
    /// `dir` must be a unit vector in the world frame (z up). No allocation. Panics if `out` is
    /// shorter than `sh_count(self.order())`.
    pub fn eval(&self, dir: DVec3, out: &mut [f64]) {
        let out = &mut out[..sh_count(self.order)];
        self.for_each(dir, |i, y| out[i] = y);
    }

    /// `Σ coeffs[i] · Y_i(dir)` over all l ≤ order (i = [`sh_index`]), without storing the `Y_i`.
    ///
    /// `dir` must be a unit vector (world frame). Panics if `coeffs` is shorter than
    /// `sh_count(self.order())`.
    pub fn dot(&self, coeffs: &[f64], dir: DVec3) -> f64 {
        let coeffs = &coeffs[..sh_count(self.order)];
        let mut sum = 0.0;
        self.for_each(dir, |i, y| sum += coeffs[i] * y);
        sum
    }

    /// Calls `emit(sh_index(l, m), Y_lm(dir))` once for every l ≤ order, −l ≤ m ≤ l.
    fn for_each(&self, dir: DVec3, mut emit: impl FnMut(usize, f64)) {
        debug_assert!(
            (dir.length_squared() - 1.0).abs() < 1e-9,
            "SH direction must be unit length"
        );
        let (x, y, z) = (dir.x, dir.y, dir.z);
        let n = self.order;
        // p_mm without its sin^m θ factor, which lives in C_m + i S_m = (x + iy)^m.
        let mut p_mm = 1.0 / (4.0 * PI).sqrt();
        let (mut c, mut s) = (1.0, 0.0);
        let mut next_ab = 0;
        for m in 0..=n {
            if m > 0 {
                p_mm *= self.diag[m];
                (c, s) = (x * c - y * s, x * s + y * c);
            }
            // Y_l0 = p_l0;  Y_l,+m = √2 p_lm C_m;  Y_l,−m = √2 p_lm S_m.
            let (cos_part, sin_part) = (SQRT_2 * c, SQRT_2 * s);
            let mut put = |l: usize, p: f64| {
                if m == 0 {
                    emit(sh_index(l, 0), p);
                } else {
                    emit(sh_index(l, m as isize), p * cos_part);
                    emit(sh_index(l, -(m as isize)), p * sin_part);
                }
            };
            put(m, p_mm);
            if m == n {
                break;
            }
            let (mut p_l2, mut p_l1) = (p_mm, self.sub[m] * z * p_mm);
            put(m + 1, p_l1);
            for l in m + 2..=n {
                let (a, b) = self.ab[next_ab];
                next_ab += 1;
                let p = a * z * p_l1 - b * p_l2;
                put(l, p);
                (p_l2, p_l1) = (p_l1, p);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_layout_is_dense_and_ordered() {
        assert_eq!(sh_index(0, 0), 0);
        assert_eq!(sh_index(1, -1), 1);
        assert_eq!(sh_index(1, 1), 3);
        assert_eq!(sh_index(2, -2), 4);
        assert_eq!(sh_index(5, 5) + 1, sh_count(5));
    }

    #[test]
    fn eval_and_dot_agree() {
        let basis = ShBasis::new(12);
        let dir = DVec3::new(0.2, -0.6, 0.4).normalize();
        let mut y = vec![0.0; sh_count(12)];
        basis.eval(dir, &mut y);
        let coeffs: Vec<f64> = (0..y.len()).map(|i| (i as f64 * 0.37).sin()).collect();
        let want: f64 = coeffs.iter().zip(&y).map(|(c, y)| c * y).sum();
        assert!((basis.dot(&coeffs, dir) - want).abs() < 1e-14);
    }
}
