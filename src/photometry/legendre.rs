//! Legendre polynomials `P_l(x)` by Bonnet's recurrence (docs/METHOD.md §2): stable on [−1, 1], no
//! factorials, accurate to ~2e-13 up to l = 200.

/// Writes `P_0(x) ..= P_lmax(x)` into `out[..=lmax]` by Bonnet's recurrence
/// `(l+1) P_{l+1} = (2l+1) x P_l − l P_{l−1}`.
///
/// `x` is usually `cos γ` (dimensionless, in [−1, 1]). Panics if `out.len() <= lmax`
/// (a caller's sizing bug, not user input).
pub fn legendre_table(x: f64, lmax: usize, out: &mut [f64]) {
    let out = &mut out[..=lmax];
    out[0] = 1.0;
    if lmax == 0 {
        return;
    }
    out[1] = x;
    for l in 1..lmax {
        let lf = l as f64;
        out[l + 1] = ((2.0 * lf + 1.0) * x * out[l] - lf * out[l - 1]) / (lf + 1.0);
    }
}

/// The Legendre series `Σ_l coeffs[l] · P_l(x)` (same unit as `coeffs`), evaluated with the
/// recurrence on the fly: no allocation, O(len).
pub fn legendre_series(coeffs: &[f64], x: f64) -> f64 {
    let (mut p_prev, mut p) = (0.0, 1.0);
    let mut sum = 0.0;
    for (l, &c) in coeffs.iter().enumerate() {
        sum += c * p;
        let lf = l as f64;
        let p_next = ((2.0 * lf + 1.0) * x * p - lf * p_prev) / (lf + 1.0);
        p_prev = p;
        p = p_next;
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn low_orders_match_closed_forms() {
        let mut p = [0.0; 5];
        for x in [-1.0, -0.3, 0.0, 0.7, 1.0] {
            legendre_table(x, 4, &mut p);
            let want = [
                1.0,
                x,
                (3.0 * x * x - 1.0) / 2.0,
                (5.0 * x * x * x - 3.0 * x) / 2.0,
                (35.0 * x.powi(4) - 30.0 * x * x + 3.0) / 8.0,
            ];
            for l in 0..5 {
                assert!(
                    (p[l] - want[l]).abs() < 1e-15,
                    "P_{l}({x}) = {} vs {}",
                    p[l],
                    want[l]
                );
            }
        }
    }

    #[test]
    fn endpoints_are_exactly_plus_minus_one_at_high_order() {
        let mut p = vec![0.0; 151];
        legendre_table(1.0, 150, &mut p);
        assert!(p.iter().all(|&v| v == 1.0));
        legendre_table(-1.0, 150, &mut p);
        for (l, &v) in p.iter().enumerate() {
            assert_eq!(v, if l % 2 == 0 { 1.0 } else { -1.0 }, "l = {l}");
        }
    }

    #[test]
    fn series_equals_table_dot_product() {
        let coeffs: Vec<f64> = (0..40).map(|l| 1.0 / (1.0 + l as f64)).collect();
        let mut p = vec![0.0; 40];
        let x = 0.37;
        legendre_table(x, 39, &mut p);
        let want: f64 = coeffs.iter().zip(&p).map(|(c, p)| c * p).sum();
        assert!((legendre_series(&coeffs, x) - want).abs() < 1e-14);
        assert_eq!(legendre_series(&[], x), 0.0);
    }
}
