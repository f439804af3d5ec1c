//! The incremental curve editor (docs/METHOD.md §3.4): every keystroke updates the Legendre
//! weights by the change alone — the exact generalisation of the paper's eq. 6 — while the
//! control points in f64 stay the truth and the weights are rebuilt from them periodically.

use crate::photometry::weights::{HatMoments, ZonalWeights, fill_exact_weights};
use crate::photometry::{Curve, CurveError};

/// Edits between automatic re-synchronisations of the weights from the control points.
pub(crate) const RESYNC_INTERVAL: usize = 1024;

/// A curve together with its exact Legendre weights, kept current edit by edit.
#[derive(Debug, Clone)]
pub struct IncrementalWeights {
    curve: Curve,
    moments: HatMoments,
    weights: ZonalWeights,
    /// Incremental edits since the weights were last rebuilt from the curve.
    edits_since_resync: usize,
    /// Rebuild after this many incremental edits ([`RESYNC_INTERVAL`]; tests may raise it).
    resync_interval: usize,
}

impl IncrementalWeights {
    /// Takes ownership of `curve` and computes its weights for l = 0..=order.
    pub fn new(curve: Curve, order: usize) -> Self {
        let moments = HatMoments::new(&curve, order);
        let mut editor = IncrementalWeights {
            curve,
            moments,
            weights: ZonalWeights {
                w: vec![0.0; order + 1],
            },
            edits_since_resync: 0,
            resync_interval: RESYNC_INTERVAL,
        };
        editor.resync();
        editor
    }

    /// The curve being edited (the truth).
    pub fn curve(&self) -> &Curve {
        &self.curve
    }

    /// The current weights (candela), exact up to rounding accumulated since the last resync.
    pub fn weights(&self) -> &ZonalWeights {
        &self.weights
    }

    /// Sets point `k`'s intensity (candela): `Δw_l = (2l+1)/2 · ΔI · H[l][k]`, O(N), no
    /// allocation. An invalid intensity is refused and changes nothing. Panics if `k` is not a
    /// point of the curve (the caller's index, not user input).
    pub fn set_intensity(&mut self, k: usize, candela: f64) -> Result<(), CurveError> {
        let old = self.curve.intensities_cd()[k];
        self.curve.set_intensity(k, candela)?;
        let delta = candela - old;
        for (l, (wl, h)) in self.weights.w.iter_mut().zip(self.moments.column(k)).enumerate() {
            *wl += (2 * l + 1) as f64 / 2.0 * delta * h;
        }
        self.count_edit();
        Ok(())
    }

    /// Moves point `k` to `gamma_deg` degrees (between its neighbours, inclusive). Recomputes the
    /// moments of hats k−1, k, k+1 and applies the exact change of their contributions. An
    /// invalid angle is refused and changes nothing. Panics if `k` is not a point of the curve.
    pub fn set_gamma(&mut self, k: usize, gamma_deg: f64) -> Result<(), CurveError> {
        assert!(
            k < self.curve.len(),
            "point {k} of a {}-point curve",
            self.curve.len()
        );
        let old = self.curve.gammas_deg()[k];
        self.curve.set_gamma(k, gamma_deg)?;
        if old == gamma_deg {
            return Ok(());
        }
        let hats = k.saturating_sub(1)..(k + 2).min(self.curve.len());
        self.add_hat_contributions(hats.clone(), -1.0);
        self.moments.update_around(&self.curve, k);
        self.add_hat_contributions(hats, 1.0);
        self.count_edit();
        Ok(())
    }

    /// Inserts a point (kept sorted, after any points at the same angle) and rebuilds the
    /// moments and weights; returns its index. An invalid point is refused and changes nothing.
    pub fn insert(&mut self, gamma_deg: f64, candela: f64) -> Result<usize, CurveError> {
        let k = self.curve.insert(gamma_deg, candela)?;
        self.rebuild();
        Ok(k)
    }

    /// Removes point `k` and rebuilds; refused (nothing changes) when the curve would become
    /// invalid. Panics if `k` is not a point of the curve.
    pub fn remove(&mut self, k: usize) -> Result<(), CurveError> {
        self.curve.remove(k)?;
        self.rebuild();
        Ok(())
    }

    /// Recomputes the weights from the control points, `w = C·I` with `C = diag((2l+1)/2)·H`,
    /// discarding accumulated rounding. Call on key/mouse release; also done automatically
    /// every [`RESYNC_INTERVAL`] edits. No allocation.
    pub fn resync(&mut self) {
        fill_exact_weights(&self.moments, self.curve.intensities_cd(), &mut self.weights.w);
        self.edits_since_resync = 0;
    }

    /// Adds `sign · (2l+1)/2 · I_j · H[l][j]` for the hats j in `hats` to the weights.
    fn add_hat_contributions(&mut self, hats: std::ops::Range<usize>, sign: f64) {
        for j in hats {
            let f = sign * self.curve.intensities_cd()[j];
            for (l, (wl, h)) in self.weights.w.iter_mut().zip(self.moments.column(j)).enumerate() {
                *wl += (2 * l + 1) as f64 / 2.0 * f * h;
            }
        }
    }

    fn rebuild(&mut self) {
        self.moments = HatMoments::new(&self.curve, self.moments.order());
        self.resync();
    }

    fn count_edit(&mut self) {
        self.edits_since_resync += 1;
        if self.edits_since_resync >= self.resync_interval {
            self.resync();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn max_rel_diff(a: &[f64], b: &[f64]) -> f64 {
        let scale = b.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
        a.iter().zip(b).fold(0.0_f64, |m, (x, y)| m.max((x - y).abs())) / scale
    }

    /// The incremental update alone, with no automatic resync, over 10⁶ edits (docs/METHOD.md §3
    /// measured 2.9e-14 for plain f64 at K = 37, N = 60).
    #[test]
    fn million_edits_without_resync_drift_below_1e_12() {
        let points: Vec<(f64, f64)> = (0..37).map(|k| (5.0 * k as f64, 1000.0)).collect();
        let mut editor = IncrementalWeights::new(Curve::new(&points).unwrap(), 60);
        editor.resync_interval = usize::MAX;
        // A small linear congruential generator: reproducible, no dependency.
        let mut state: u64 = 0x9E37_79B9_7F4A_7C15;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..1_000_000 {
            let k = (next() * 37.0) as usize;
            editor.set_intensity(k, 2000.0 * next()).unwrap();
        }
        assert_eq!(editor.edits_since_resync, 1_000_000);
        let exact = ZonalWeights::exact(editor.curve(), 60);
        let drift = max_rel_diff(&editor.weights().w, &exact.w);
        assert!(drift < 1e-12, "drift {drift:e}");
    }

    #[test]
    fn resyncs_automatically_every_interval() {
        let mut editor = IncrementalWeights::new(Curve::isotropic(100.0), 4);
        for i in 0..RESYNC_INTERVAL - 1 {
            editor.set_intensity(0, i as f64).unwrap();
        }
        assert_eq!(editor.edits_since_resync, RESYNC_INTERVAL - 1);
        editor.set_intensity(0, 5.0).unwrap();
        assert_eq!(editor.edits_since_resync, 0);
    }
}
