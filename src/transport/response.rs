//! A light's solved values per control point of its curve (docs/DECISIONS.md
//! "Interreflection", "Curve edits without a solve"). The curve is piecewise linear in γ, so for
//! fixed control-point angles, aim and position the light's exact patch direct light — and with
//! it the whole interreflection solve — is linear in the control points' intensities. One block
//! solve with a column per control point (the light emitting 1 cd at that point, 0 at the others)
//! turns every later intensity edit into a weighted sum of the columns: the same values as a
//! solve of the edited curve, to the solver's tolerance, without one.

use glam::DVec3;
use rayon::prelude::*;

use crate::error::Result;
use crate::scene::Light;
use crate::transport::interreflection::Interreflection;
use crate::transport::patchdirect::PatchDirectCache;
use crate::transport::radiosity::{PatchColumns, Solution};

/// Most control points a curve may have for its response to be solved: the block solve costs
/// about one single solve per point, so a measured curve with a point per degree keeps one
/// solve per edit instead.
pub const MAX_RESPONSE_POINTS: usize = 48;

/// A light's solved values on the engine's leaves, colour not applied.
#[derive(Debug, Clone)]
pub(crate) struct LightValues {
    /// Per solved channel, the leaf radiosity (lm/m², one column).
    pub(crate) radiosity: Vec<PatchColumns>,
    /// Per solved channel, the leaf indirect irradiance `H − E = F·B` (lx).
    pub(crate) indirect: Vec<Vec<f64>>,
}

impl LightValues {
    /// Column `c` of a block solve (per channel) whose emission column `c` was `direct`.
    pub(crate) fn of_column(solutions: &[Solution], c: usize, direct: &[f64]) -> Self {
        let n = direct.len();
        LightValues {
            radiosity: solutions
                .iter()
                .map(|s| PatchColumns::from_columns(n, &[s.radiosity.column(c)]))
                .collect(),
            indirect: solutions
                .iter()
                .map(|s| (0..n).map(|p| s.irradiance.get(p, c) - direct[p]).collect())
                .collect(),
        }
    }
}

/// Leaves × control points in f32 (a response's values are to the solver's relative tolerance,
/// ≥ 10⁻⁶, so f32's 6·10⁻⁸ loses nothing and halves what an edit reads), row-major.
#[derive(Debug, Clone)]
struct ResponseBlock {
    n_columns: usize,
    values: Vec<f32>,
}

/// Leaves per rayon task when combining a response's columns.
const LEAVES_PER_TASK: usize = 4096;

impl ResponseBlock {
    fn new(n_columns: usize, values: impl Iterator<Item = f64>) -> Self {
        ResponseBlock {
            n_columns,
            values: values.map(|v| v as f32).collect(),
        }
    }

    /// `Σ_j weights[j] · column_j`, per leaf (in parallel over leaves).
    fn combine(&self, weights: &[f64]) -> Vec<f64> {
        let k = self.n_columns;
        let mut out = vec![0.0; self.values.len() / k];
        out.par_chunks_mut(LEAVES_PER_TASK)
            .zip(self.values.par_chunks(LEAVES_PER_TASK * k))
            .for_each(|(out, rows)| {
                for (o, row) in out.iter_mut().zip(rows.chunks_exact(k)) {
                    *o = row.iter().zip(weights).map(|(&v, w)| f64::from(v) * w).sum();
                }
            });
        out
    }
}

/// One light's values per control point, for the position, radius, aim and control-point
/// angles it was solved at.
#[derive(Debug, Clone)]
pub struct CurveResponse {
    position: DVec3,
    radius_m: f64,
    aim: DVec3,
    gammas_deg: Vec<f64>,
    /// Per solved channel, leaves × control points: indirect irradiance `F·B` (lx per cd,
    /// dimmer 1).
    indirect: Vec<ResponseBlock>,
    /// Per solved channel, leaves × control points: radiosity (lm/m² per cd).
    radiosity: Vec<ResponseBlock>,
}

impl CurveResponse {
    /// Solves `light`'s response on `engine` from its direct sample `cache` (for its position),
    /// to the relative `tolerance` per column.
    ///
    /// Errors: the solve failing (internal).
    pub fn solve(
        engine: &Interreflection,
        cache: &PatchDirectCache,
        light: &Light,
        tolerance: f64,
    ) -> Result<Self> {
        let n = engine.n_leaves();
        let k = light.curve.len();
        let mut direct = PatchColumns::zeros(n, k);
        cache.control_point_irradiance_into(&light.curve, light.aim.normalize(), &mut direct.values);
        let (indirect, radiosity) = engine
            .solve(&direct, None, tolerance)?
            .into_iter()
            .map(|s| {
                let indirect = s.irradiance.values.iter().zip(&direct.values).map(|(h, e)| h - e);
                (
                    ResponseBlock::new(k, indirect),
                    ResponseBlock::new(k, s.radiosity.values.into_iter()),
                )
            })
            .unzip();
        Ok(CurveResponse {
            position: light.position,
            radius_m: light.radius,
            aim: light.aim,
            gammas_deg: light.curve.gammas_deg().to_vec(),
            indirect,
            radiosity,
        })
    }

    /// True when `light` stands where the response was solved, aimed the same way, with a
    /// curve of the same control-point angles: then [`Self::values`] is its solve.
    pub fn fits(&self, light: &Light) -> bool {
        light.position == self.position
            && light.radius == self.radius_m
            && light.aim == self.aim
            && light.curve.gammas_deg() == self.gammas_deg
    }

    /// The solved values of `light` (which [`Self::fits`]): the columns weighted by its
    /// intensities times its dimmer.
    pub(crate) fn values(&self, light: &Light) -> LightValues {
        let weights: Vec<f64> = light
            .curve
            .intensities_cd()
            .iter()
            .map(|i| i * light.dimmer)
            .collect();
        LightValues {
            radiosity: self
                .radiosity
                .iter()
                .map(|b| {
                    let values = b.combine(&weights);
                    PatchColumns {
                        n_patches: values.len(),
                        n_columns: 1,
                        values,
                    }
                })
                .collect(),
            indirect: self.indirect.iter().map(|b| b.combine(&weights)).collect(),
        }
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        let values: usize = self
            .indirect
            .iter()
            .chain(&self.radiosity)
            .map(|b| b.values.len())
            .sum();
        4 * values + 8 * self.gammas_deg.len()
    }
}
