//! A light's solved values per world-frame SH basis emitter, for the key path's estimate of a
//! re-aim or curve edit while its exact solve runs (docs/DECISIONS.md "Interreflection",
//! "Re-aims and curve edits estimated at once").
//!
//! The solve is linear in the light's intensity distribution, and an aimed zonal curve is, in
//! the world frame, `Σ_k c_k Y_k` with `c_k = w_l · 4π/(2l+1) · Y_k(aim)` (docs/METHOD.md §5).
//! With the light's values solved for each `Y_k` up to a low order N (where it stands), the
//! change of its values between two states is `Σ_k (c_k(new) − c_k(old)) · R_k`: exact for the
//! part of the change of intensity below degree N, and missing only the rest. The estimate is
//! made from the light's last solved values at once; the edit's solve replaces it.

use glam::DVec3;
use rayon::prelude::*;

use crate::error::Result;
use crate::photometry::sh::{ShBasis, sh_count};
use crate::photometry::weights::ZonalWeights;
use crate::photometry::{Curve, aimed_coefficients};
use crate::scene::Light;
use crate::transport::interreflection::Interreflection;
use crate::transport::patchdirect::PatchDirectCache;
use crate::transport::radiosity::PatchColumns;

/// Degree N of the estimate's SH columns ((N + 1)² = 9 columns): on the open-plan floor higher
/// degrees cost more (a response's build 2.7 / 6.4 / 12.3 s at N = 2 / 4 / 6) for no smaller
/// error (docs/DECISIONS.md "Re-aims and curve edits estimated at once").
pub const ESTIMATE_ORDER: usize = 2;

/// Relative tolerance of the estimate's column solves: its error is that of the truncation,
/// far above 10⁻³.
pub const ESTIMATE_TOLERANCE: f64 = 1e-3;

/// Leaves per rayon task when applying an estimate.
const LEAVES_PER_TASK: usize = 2048;

/// A light's leaf values per real SH basis emitter `Y_k` (k < (N + 1)², 1 cd·`Y_k`, world frame),
/// for the position and luminous radius it was solved at.
#[derive(Debug, Clone)]
pub struct ShResponse {
    position: DVec3,
    radius_m: f64,
    basis: ShBasis,
    /// Per channel, the leaf radiosity (lm/m²) per SH function, leaf-major ((N + 1)² per leaf).
    radiosity: Vec<Vec<f32>>,
    /// Per channel, the leaf indirect irradiance `H − E` (lx) per SH function, leaf-major.
    indirect: Vec<Vec<f32>>,
}

impl ShResponse {
    /// Solves the response of `light` (where it stands; `cache` is its direct sample cache
    /// there) on `engine`, to degree `order`, each column to the relative `tolerance`.
    ///
    /// Errors: the solve failing (internal).
    pub(crate) fn solve(
        engine: &Interreflection,
        cache: &PatchDirectCache,
        light: &Light,
        order: usize,
        tolerance: f64,
    ) -> Result<Self> {
        let basis = ShBasis::new(order);
        let (n, m) = (engine.n_leaves(), sh_count(order));
        let mut block = PatchColumns::zeros(n, m);
        cache.sh_irradiance_into(&basis, &mut block.values);
        // Each column starts one bounce in, from its first reflection `ρ e_k`.
        let initial: Vec<PatchColumns> = engine
            .reflectance
            .iter()
            .map(|rho| PatchColumns {
                values: block
                    .values
                    .iter()
                    .enumerate()
                    .map(|(i, e)| rho[i / m] * e)
                    .collect(),
                ..block
            })
            .collect();
        let solutions = engine.solve(&block, Some(&initial), tolerance)?;
        let single = |values: &[f64]| values.iter().map(|&v| v as f32).collect::<Vec<f32>>();
        Ok(ShResponse {
            position: light.position,
            radius_m: light.radius,
            radiosity: solutions.iter().map(|s| single(&s.radiosity.values)).collect(),
            indirect: solutions
                .iter()
                .map(|s| {
                    let indirect: Vec<f64> = s
                        .irradiance
                        .values
                        .iter()
                        .zip(&block.values)
                        .map(|(h, e)| h - e)
                        .collect();
                    single(&indirect)
                })
                .collect(),
            basis,
        })
    }

    /// True when `light` stands where the response was solved (its columns hold at any aim,
    /// curve and dimmer).
    pub fn stands_as(&self, light: &Light) -> bool {
        light.position == self.position && light.radius == self.radius_m
    }

    /// The degree N of its SH columns.
    pub fn order(&self) -> usize {
        self.basis.order()
    }

    /// World-frame SH coefficients (cd) of `curve` aimed along `aim`, times `dimmer`, to the
    /// response's degree: the exact Legendre weights of the piecewise-linear curve, rotated.
    pub fn coefficients(&self, curve: &Curve, aim: DVec3, dimmer: f64) -> Vec<f64> {
        let order = self.order();
        let mut c = vec![0.0; sh_count(order)];
        aimed_coefficients(
            &ZonalWeights::exact(curve, order),
            aim.normalize(),
            &self.basis,
            &mut c,
        );
        c.iter_mut().for_each(|c| *c *= dimmer);
        c
    }

    /// The light's values estimated for `to`'s state from its per-channel leaf `radiosity` and
    /// `indirect` (colour not applied) for the state `(curve, aim, dimmer)` = `from`: those
    /// values plus the change of the state's SH coefficients weighted by the columns. Per
    /// channel the radiosity, and per channel the indirect irradiance.
    pub(crate) fn estimate(
        &self,
        from: (&Curve, DVec3, f64),
        to: &Light,
        radiosity: &[Vec<f32>],
        indirect: &[Vec<f32>],
    ) -> (Vec<Vec<f32>>, Vec<Vec<f32>>) {
        let old = self.coefficients(from.0, from.1, from.2);
        let new = self.coefficients(&to.curve, to.aim, to.dimmer);
        let change: Vec<f64> = new.iter().zip(&old).map(|(n, o)| n - o).collect();
        let m = change.len();
        let changed = |values: &[f32], columns: &[f32]| -> Vec<f32> {
            let mut out = vec![0.0; values.len()];
            out.par_chunks_mut(LEAVES_PER_TASK)
                .zip(values.par_chunks(LEAVES_PER_TASK))
                .zip(columns.par_chunks(LEAVES_PER_TASK * m))
                .for_each(|((out, values), columns)| {
                    for ((o, &v), row) in out.iter_mut().zip(values).zip(columns.chunks_exact(m)) {
                        let sum: f64 = row.iter().zip(&change).map(|(&r, c)| f64::from(r) * c).sum();
                        *o = (f64::from(v) + sum) as f32;
                    }
                });
            out
        };
        let each = |values: &[Vec<f32>], columns: &[Vec<f32>]| -> Vec<Vec<f32>> {
            values.iter().zip(columns).map(|(v, c)| changed(v, c)).collect()
        };
        (each(radiosity, &self.radiosity), each(indirect, &self.indirect))
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        4 * self
            .radiosity
            .iter()
            .chain(&self.indirect)
            .map(Vec::len)
            .sum::<usize>()
    }
}
