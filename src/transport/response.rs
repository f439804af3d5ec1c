//! A light's solved values per control point of its curve (docs/DECISIONS.md
//! "Interreflection", "Curve edits without a solve"). The curve is piecewise linear in γ, so for
//! fixed control-point angles, aim and position the light's exact patch direct light — and with
//! it the whole interreflection solve — is linear in the control points' intensities. One block
//! solve with a column per control point (the light emitting 1 cd at that point, 0 at the others)
//! turns every later intensity edit into a weighted sum of the columns: the same values as a
//! solve of the edited curve, to the solver's tolerance, without one.

use glam::DVec3;

use crate::error::{Error, Result};
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
    /// Per solved channel, the total leaf irradiance `H = E + F·B` (lx).
    pub(crate) irradiance: Vec<Vec<f64>>,
    /// The exact direct irradiance per leaf `E` (lx).
    pub(crate) direct: Vec<f64>,
}

impl LightValues {
    /// Column `c` of a block solve (per channel) whose emission column `c` was `direct`.
    pub(crate) fn of_column(solutions: &[Solution], c: usize, direct: Vec<f64>) -> Self {
        let n = direct.len();
        LightValues {
            radiosity: solutions
                .iter()
                .map(|s| PatchColumns::from_columns(n, &[s.radiosity.column(c)]))
                .collect(),
            irradiance: solutions.iter().map(|s| s.irradiance.column(c)).collect(),
            direct,
        }
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
    /// Leaves × control points: direct irradiance (lx per cd, dimmer 1).
    direct: PatchColumns,
    /// Per solved channel, leaves × control points: total irradiance (lx per cd).
    irradiance: Vec<PatchColumns>,
    /// Per solved channel, leaves × control points: radiosity (lm/m² per cd).
    radiosity: Vec<PatchColumns>,
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
        let mut e = vec![0.0; n];
        let aim = light.aim.normalize();
        for j in 0..k {
            let mut unit = light.curve.clone();
            for point in 0..k {
                unit.set_intensity(point, if point == j { 1.0 } else { 0.0 })
                    .map_err(|e| Error::internal(format!("response: control point {point}: {e}")))?;
            }
            cache.irradiance_into(&unit, aim, 1.0, &mut e);
            for (p, v) in e.iter().enumerate() {
                direct.values[p * k + j] = *v;
            }
        }
        let (irradiance, radiosity) = engine
            .solve(&direct, None, tolerance)?
            .into_iter()
            .map(|s| (s.irradiance, s.radiosity))
            .unzip();
        Ok(CurveResponse {
            position: light.position,
            radius_m: light.radius,
            aim: light.aim,
            gammas_deg: light.curve.gammas_deg().to_vec(),
            direct,
            irradiance,
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
        let combine = |block: &PatchColumns| -> Vec<f64> {
            block
                .values
                .chunks_exact(block.n_columns)
                .map(|row| row.iter().zip(&weights).map(|(v, w)| v * w).sum())
                .collect()
        };
        let n = self.direct.n_patches;
        LightValues {
            radiosity: self
                .radiosity
                .iter()
                .map(|b| PatchColumns {
                    n_patches: n,
                    n_columns: 1,
                    values: combine(b),
                })
                .collect(),
            irradiance: self.irradiance.iter().map(combine).collect(),
            direct: combine(&self.direct),
        }
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        let blocks = 1 + self.irradiance.len() + self.radiosity.len();
        8 * (blocks * self.direct.values.len() + self.gammas_deg.len())
    }
}
