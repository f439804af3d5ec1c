//! Gauss–Legendre quadrature nodes and weights on [−1, 1], computed by Newton iteration on the
//! Legendre polynomial (Golub–Welsch accuracy without the eigenproblem).

/// An `n`-point Gauss–Legendre rule.
#[derive(Debug, Clone)]
pub struct GaussLegendre {
    /// Nodes on [−1, 1], ascending.
    pub nodes: Vec<f64>,
    /// Weights, summing to 2.
    pub weights: Vec<f64>,
}

impl GaussLegendre {
    /// The `n`-point rule (n ≥ 1); exact for polynomials of degree ≤ 2n − 1.
    pub fn new(n: usize) -> Self {
        assert!(n >= 1, "a Gauss–Legendre rule needs at least one node");
        let mut nodes = vec![0.0; n];
        let mut weights = vec![0.0; n];
        let nf = n as f64;
        for i in 0..n.div_ceil(2) {
            // Tricomi's initial guess, then Newton on P_n.
            let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (nf + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                let (p, d) = legendre_and_derivative(n, x);
                dp = d;
                let dx = p / d;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            let (_, d) = legendre_and_derivative(n, x);
            dp = if d.is_finite() { d } else { dp };
            let w = 2.0 / ((1.0 - x * x) * dp * dp);
            nodes[i] = -x;
            nodes[n - 1 - i] = x;
            weights[i] = w;
            weights[n - 1 - i] = w;
        }
        GaussLegendre { nodes, weights }
    }

    /// `∫_a^b f(x) dx` with this rule mapped onto [a, b].
    pub fn integrate(&self, a: f64, b: f64, mut f: impl FnMut(f64) -> f64) -> f64 {
        let (mid, half) = ((a + b) / 2.0, (b - a) / 2.0);
        let mut sum = 0.0;
        for (&x, &w) in self.nodes.iter().zip(&self.weights) {
            sum += w * f(mid + half * x);
        }
        sum * half
    }
}

/// `(P_n(x), P_n'(x))` by Bonnet's recurrence.
fn legendre_and_derivative(n: usize, x: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, x);
    for l in 1..n {
        let lf = l as f64;
        let p2 = ((2.0 * lf + 1.0) * x * p1 - lf * p0) / (lf + 1.0);
        p0 = p1;
        p1 = p2;
    }
    if n == 0 {
        return (1.0, 0.0);
    }
    let nf = n as f64;
    (p1, nf * (x * p1 - p0) / (x * x - 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_sum_to_two_and_integrate_polynomials_exactly() {
        for n in [1, 2, 5, 12, 40, 90] {
            let rule = GaussLegendre::new(n);
            let sum: f64 = rule.weights.iter().sum();
            assert!((sum - 2.0).abs() < 1e-13, "n={n}: {sum}");
            // x^(2n-2) integrates to 2/(2n-1) on [-1, 1].
            let deg = 2 * n - 2;
            let got = rule.integrate(-1.0, 1.0, |x| x.powi(deg as i32));
            let want = 2.0 / (deg as f64 + 1.0);
            assert!((got - want).abs() < 1e-13, "n={n}: {got} vs {want}");
        }
    }

    #[test]
    fn integrates_sine_on_an_interval() {
        let rule = GaussLegendre::new(12);
        let got = rule.integrate(0.0, std::f64::consts::PI, f64::sin);
        assert!((got - 2.0).abs() < 1e-14);
    }
}
