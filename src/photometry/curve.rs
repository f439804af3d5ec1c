//! The luminous intensity curve `I(γ)` of an axially symmetric luminaire.
//!
//! Control points `(γ_deg, candela)` with γ measured from the light's aim axis (0° = along the
//! axis, the nadir of a downlight). The curve is linear in γ between points, a repeated γ is a
//! step (two points at one angle), and it is 0 before the first and past the last point
//! (real files often end at 90°).

use std::f64::consts::PI;
use std::fmt;

/// Why a set of control points is not a valid curve. The caller adds the file and place.
#[derive(Debug, Clone, PartialEq)]
pub enum CurveError {
    /// Fewer than two points, or all at one angle.
    TooFewPoints,
    /// γ is NaN, infinite, or outside 0..=180°.
    GammaOutOfRange { index: usize, gamma_deg: f64 },
    /// γ decreases from one point to the next.
    GammaDecreasing {
        index: usize,
        gamma_deg: f64,
        previous_deg: f64,
    },
    /// More than two points share one angle (a step needs exactly two).
    TripleAngle { index: usize, gamma_deg: f64 },
    /// Two angles differ by less than [`MIN_GAMMA_GAP_DEG`] without being equal.
    GammaTooClose {
        index: usize,
        gamma_deg: f64,
        previous_deg: f64,
    },
    /// The intensity is NaN, infinite, negative or above [`MAX_INTENSITY_CD`].
    BadIntensity { index: usize, candela: f64 },
}

impl fmt::Display for CurveError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            CurveError::TooFewPoints => {
                write!(f, "a curve needs at least two control points at different angles")
            }
            CurveError::GammaOutOfRange { index, gamma_deg } => write!(
                f,
                "point {index}: angle {gamma_deg}° is not a number between 0 and 180"
            ),
            CurveError::GammaDecreasing {
                index,
                gamma_deg,
                previous_deg,
            } => write!(
                f,
                "point {index}: angle {gamma_deg}° is below the previous point's {previous_deg}° \
                 (angles must not decrease)"
            ),
            CurveError::TripleAngle { index, gamma_deg } => write!(
                f,
                "point {index}: a third point at {gamma_deg}° (a step is exactly two points at one angle)"
            ),
            CurveError::GammaTooClose {
                index,
                gamma_deg,
                previous_deg,
            } => write!(
                f,
                "point {index}: angle {gamma_deg:?}° is within {MIN_GAMMA_GAP_DEG:e}° of the previous \
                 point's {previous_deg:?}° (write the same angle twice for a step)"
            ),
            CurveError::BadIntensity { index, candela } => write!(
                f,
                "point {index}: intensity {candela:?} cd is not a number from 0 to {MAX_INTENSITY_CD:e} cd"
            ),
        }
    }
}

impl std::error::Error for CurveError {}

/// The highest intensity a curve may hold, in candela: above the brightest searchlights, and low
/// enough that `‖I‖²` sums and the products with dimmer, colour and `1/r²` downstream stay far
/// from overflow (docs/DECISIONS.md, "Bad input").
pub const MAX_INTENSITY_CD: f64 = 1e9;

/// The smallest difference between two control-point angles that are not equal, in degrees: far
/// below any measured grid (0.1° at the finest), and far above the gaps whose hat-function
/// moments lose every digit to cancellation (docs/DECISIONS.md, "Bad input").
pub const MIN_GAMMA_GAP_DEG: f64 = 1e-6;

/// A validated piecewise-linear intensity curve.
#[derive(Debug, Clone, PartialEq)]
pub struct Curve {
    /// Control-point angles in degrees, non-decreasing, within 0..=180.
    gamma_deg: Vec<f64>,
    /// Control-point intensities in candela, finite and ≥ 0.
    intensity_cd: Vec<f64>,
}

impl Curve {
    /// Builds a curve from `(γ_deg, candela)` points, checking every rule of the module docs.
    pub fn new(points: &[(f64, f64)]) -> Result<Self, CurveError> {
        let curve = Curve {
            gamma_deg: points.iter().map(|p| p.0).collect(),
            intensity_cd: points.iter().map(|p| p.1).collect(),
        };
        curve.validate()?;
        Ok(curve)
    }

    fn validate(&self) -> Result<(), CurveError> {
        for (index, (&gamma_deg, &candela)) in self.gamma_deg.iter().zip(&self.intensity_cd).enumerate() {
            if !(0.0..=180.0).contains(&gamma_deg) {
                return Err(CurveError::GammaOutOfRange { index, gamma_deg });
            }
            if !(0.0..=MAX_INTENSITY_CD).contains(&candela) {
                return Err(CurveError::BadIntensity { index, candela });
            }
            if index > 0 {
                let previous_deg = self.gamma_deg[index - 1];
                if gamma_deg < previous_deg {
                    return Err(CurveError::GammaDecreasing {
                        index,
                        gamma_deg,
                        previous_deg,
                    });
                }
                if index > 1 && gamma_deg == previous_deg && gamma_deg == self.gamma_deg[index - 2] {
                    return Err(CurveError::TripleAngle { index, gamma_deg });
                }
                if gamma_deg != previous_deg && gamma_deg - previous_deg < MIN_GAMMA_GAP_DEG {
                    return Err(CurveError::GammaTooClose {
                        index,
                        gamma_deg,
                        previous_deg,
                    });
                }
            }
        }
        if self.gamma_deg.len() < 2 || self.gamma_deg[0] == self.gamma_deg[self.gamma_deg.len() - 1] {
            return Err(CurveError::TooFewPoints);
        }
        Ok(())
    }

    /// An isotropic curve of `candela` in every direction (two points, 0° and 180°).
    pub fn isotropic(candela: f64) -> Self {
        Curve {
            gamma_deg: vec![0.0, 180.0],
            intensity_cd: vec![candela, candela],
        }
    }

    /// Number of control points.
    pub fn len(&self) -> usize {
        self.gamma_deg.len()
    }

    /// Always false: a valid curve has at least two points.
    pub fn is_empty(&self) -> bool {
        self.gamma_deg.is_empty()
    }

    /// Control-point angles (degrees).
    pub fn gammas_deg(&self) -> &[f64] {
        &self.gamma_deg
    }

    /// Control-point intensities (candela).
    pub fn intensities_cd(&self) -> &[f64] {
        &self.intensity_cd
    }

    /// The control points as `(γ_deg, candela)` pairs.
    pub fn points(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        self.gamma_deg
            .iter()
            .copied()
            .zip(self.intensity_cd.iter().copied())
    }

    /// Intensity (cd) at `gamma_deg`. At a step (two points at one angle) the value of the
    /// first of the two is returned; outside the points' span the curve is 0.
    pub fn eval_deg(&self, gamma_deg: f64) -> f64 {
        match self.segment_deg(gamma_deg) {
            None => 0.0,
            Some((i, None)) => self.intensity_cd[i],
            Some((i, Some(t))) => {
                self.intensity_cd[i - 1] + t * (self.intensity_cd[i] - self.intensity_cd[i - 1])
            }
        }
    }

    /// Where `gamma_deg` falls among the control points: `None` outside the curve, `(i, None)`
    /// on point `i`, `(i, Some(t))` at `t ∈ (0, 1)` from point `i − 1` to point `i` — so the
    /// intensity is linear in the points' intensities with these weights (the hat functions).
    pub fn segment_deg(&self, gamma_deg: f64) -> Option<(usize, Option<f64>)> {
        let g = &self.gamma_deg;
        let last = g.len() - 1;
        if !(gamma_deg >= g[0] && gamma_deg <= g[last]) {
            return None;
        }
        // First index with g[i] >= gamma_deg; the segment is [i-1, i].
        let i = g.partition_point(|&x| x < gamma_deg);
        if i == 0 || g[i] == gamma_deg {
            return Some((i, None));
        }
        let (a, b) = (g[i - 1], g[i]);
        Some((i, Some((gamma_deg - a) / (b - a))))
    }

    /// Intensity (cd) at `gamma_rad`.
    pub fn eval_rad(&self, gamma_rad: f64) -> f64 {
        self.eval_deg(gamma_rad.to_degrees())
    }

    /// Luminous flux `Φ = 2π ∫ I(γ) sin γ dγ` in lumens, integrated exactly per linear segment.
    pub fn flux_lm(&self) -> f64 {
        let mut integral = 0.0;
        for k in 1..self.len() {
            let (a, b) = (self.gamma_deg[k - 1].to_radians(), self.gamma_deg[k].to_radians());
            let h = b - a;
            if h <= 0.0 {
                continue;
            }
            let (ia, ib) = (self.intensity_cd[k - 1], self.intensity_cd[k]);
            // ∫_a^b sinγ dγ = cos a − cos b = 2 sin((a + b)/2) sin(h/2), and with t = γ − a,
            // ∫_0^h t sin(a + t) dt = sin a ∫ t cos t + cos a ∫ t sin t, each without the
            // cancellation of the differences of cosines a narrow segment (a 0.01° spike) would
            // suffer.
            let cos_diff = 2.0 * ((a + b) / 2.0).sin() * (h / 2.0).sin();
            let t_cos_t = h * h.sin() - 2.0 * (h / 2.0).sin().powi(2);
            let ramp = a.sin() * t_cos_t + a.cos() * t_sin_t_integral(h);
            integral += ia * cos_diff + (ib - ia) / h * ramp;
        }
        2.0 * PI * integral
    }

    /// `‖I‖² = ∫ I(γ)² sin γ dγ` (cd² · rad), exact per segment; the denominator of the
    /// relative L2 truncation error (docs/METHOD.md §4).
    pub fn norm_squared(&self) -> f64 {
        // I² is quadratic in γ, so I² sin γ is smooth on each segment: 12-point Gauss–Legendre
        // (exact to degree 23) leaves an error far below f64 rounding even on one 180° segment.
        let nodes = crate::photometry::gauss::GaussLegendre::new(12);
        let mut sum = 0.0;
        for k in 1..self.len() {
            let (a, b) = (self.gamma_deg[k - 1].to_radians(), self.gamma_deg[k].to_radians());
            if b <= a {
                continue;
            }
            let (ia, ib) = (self.intensity_cd[k - 1], self.intensity_cd[k]);
            sum += nodes.integrate(a, b, |g| {
                let i = ia + (ib - ia) * (g - a) / (b - a);
                i * i * g.sin()
            });
        }
        sum
    }

    /// The largest control-point intensity (cd), which is the curve's maximum.
    pub fn peak_cd(&self) -> f64 {
        self.intensity_cd.iter().copied().fold(0.0, f64::max)
    }

    /// Sets point `k`'s intensity. Errors leave the curve unchanged.
    pub fn set_intensity(&mut self, k: usize, candela: f64) -> Result<(), CurveError> {
        if !(0.0..=MAX_INTENSITY_CD).contains(&candela) {
            return Err(CurveError::BadIntensity { index: k, candela });
        }
        self.intensity_cd[k] = candela;
        Ok(())
    }

    /// Moves point `k` to `gamma_deg`, which must stay between its neighbours (inclusive).
    /// Errors leave the curve unchanged.
    pub fn set_gamma(&mut self, k: usize, gamma_deg: f64) -> Result<(), CurveError> {
        let old = self.gamma_deg[k];
        self.gamma_deg[k] = gamma_deg;
        let result = self.validate();
        if result.is_err() {
            self.gamma_deg[k] = old;
        }
        result
    }

    /// Inserts a point, keeping γ sorted (after any points at the same angle); returns its index.
    pub fn insert(&mut self, gamma_deg: f64, candela: f64) -> Result<usize, CurveError> {
        let k = self.gamma_deg.partition_point(|&x| x <= gamma_deg);
        self.gamma_deg.insert(k, gamma_deg);
        self.intensity_cd.insert(k, candela);
        if let Err(e) = self.validate() {
            self.gamma_deg.remove(k);
            self.intensity_cd.remove(k);
            return Err(e);
        }
        Ok(k)
    }

    /// Removes point `k`; refused when the curve would become invalid.
    pub fn remove(&mut self, k: usize) -> Result<(), CurveError> {
        let (g, i) = (self.gamma_deg.remove(k), self.intensity_cd.remove(k));
        if let Err(e) = self.validate() {
            self.gamma_deg.insert(k, g);
            self.intensity_cd.insert(k, i);
            return Err(e);
        }
        Ok(())
    }
}

/// `∫_0^h t sin t dt = sin h − h cos h` (h in radians), by its alternating series below 1 rad
/// where that difference cancels (it is h³/3 for small h).
fn t_sin_t_integral(h: f64) -> f64 {
    if h > 1.0 {
        return h.sin() - h * h.cos();
    }
    // Σ (−1)^k h^(2k+3) / ((2k+1)! (2k+3)); the 12th term is below 1e-20 of the first.
    let (mut sum, mut power, mut factorial, mut sign) = (0.0, h.powi(3), 1.0, 1.0);
    for k in 0..12 {
        let n = 2.0 * k as f64;
        sum += sign * power / (factorial * (n + 3.0));
        power *= h * h;
        factorial *= (n + 2.0) * (n + 3.0);
        sign = -sign;
    }
    sum
}
