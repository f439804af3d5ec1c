//! A light's solved values and their change per control point of its curve (docs/DECISIONS.md
//! "Interreflection", "Curve edits without a solve", "Responses grown a point at a time"). The
//! curve is piecewise linear in γ, so for fixed control-point angles, aim and position the
//! light's exact patch direct light — and with it the whole interreflection solve — is linear in
//! the control points' intensities. A response holds the light's values for one curve (its base)
//! and a column for each control point edited so far (the light emitting 1 cd at that point, 0 at
//! the others): every later edit of those points' intensities is the base plus a weighted sum of
//! their columns — the same values as a solve of the edited curve, to the solver's tolerance,
//! without one. A curve edit's solve adds the edited point's column to the light's response.

use glam::DVec3;
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::scene::Light;
use crate::transport::interreflection::Interreflection;
use crate::transport::patchdirect::PatchDirectCache;
use crate::transport::radiosity::{PatchColumns, Solution};

/// Most control-point columns a light's response holds (about a solve's worth of memory each:
/// `2 × channels × leaves × 4` bytes); past it, an edit of another point is solved alone.
pub const MAX_RESPONSE_POINTS: usize = 48;

/// Most control points one curve edit adds columns for: an edit of one or a few points is
/// likely followed by more edits of the same points; a change of the whole curve's shape (a
/// scaled curve, every second point changed) is solved without columns.
pub const RESPONSE_POINTS_PER_SOLVE: usize = 4;

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

    /// The values in f32, as the engine keeps them (good to the solver's relative tolerance,
    /// ≥ 10⁻⁶; f32 keeps 6·10⁻⁸): per channel the radiosity, and per channel the indirect
    /// irradiance.
    pub(crate) fn into_single(self) -> (Vec<Vec<f32>>, Vec<Vec<f32>>) {
        let single = |values: &[f64]| values.iter().map(|&v| v as f32).collect();
        (
            self.radiosity.iter().map(|c| single(&c.values)).collect(),
            self.indirect.iter().map(|c| single(c)).collect(),
        )
    }
}

/// Leaves per rayon task when combining a response's columns.
const LEAVES_PER_TASK: usize = 4096;

/// Solved values per channel on the engine's leaves, in f32 (the values are good to the solver's
/// relative tolerance, ≥ 10⁻⁶; f32 keeps 6·10⁻⁸ and halves what an edit reads).
#[derive(Debug, Clone)]
struct Columns {
    /// Per channel, the leaf radiosity (lm/m²).
    radiosity: Vec<Vec<f32>>,
    /// Per channel, the leaf indirect irradiance `H − E = F·B` (lx).
    indirect: Vec<Vec<f32>>,
}

impl Columns {
    /// Column `c` of a block solve (per channel) whose emission was `emission`.
    fn of_column(solutions: &[Solution], c: usize, emission: &PatchColumns) -> Self {
        let (radiosity, indirect) = LightValues::of_column(solutions, c, &emission.column(c)).into_single();
        Columns { radiosity, indirect }
    }

    fn len(&self) -> usize {
        self.radiosity.iter().chain(&self.indirect).map(Vec::len).sum()
    }
}

/// `base_scale · base + Σ weight_j · column_j`, per leaf (in parallel over leaves).
fn combine(base: &[f32], base_scale: f64, columns: &[(&[f32], f64)]) -> Vec<f64> {
    let mut out = vec![0.0; base.len()];
    out.par_chunks_mut(LEAVES_PER_TASK)
        .enumerate()
        .for_each(|(chunk, out)| {
            let start = chunk * LEAVES_PER_TASK;
            let range = start..start + out.len();
            for (o, &b) in out.iter_mut().zip(&base[range.clone()]) {
                *o = base_scale * f64::from(b);
            }
            for &(column, w) in columns {
                for (o, &v) in out.iter_mut().zip(&column[range.clone()]) {
                    *o += w * f64::from(v);
                }
            }
        });
    out
}

/// One light's values for a base curve, and per edited control point the change of its values
/// per candela at that point, for the position, radius, aim and control-point angles it was
/// solved at.
#[derive(Debug, Clone)]
pub struct CurveResponse {
    position: DVec3,
    radius_m: f64,
    aim: DVec3,
    gammas_deg: Vec<f64>,
    /// The control points' intensities (cd) and the dimmer (> 0) the base was solved for.
    base_cd: Vec<f64>,
    base_dimmer: f64,
    /// The light's values for its base curve and dimmer.
    base: Columns,
    /// Per control point with a column: its index and its values per cd (dimmer 1).
    points: Vec<(usize, Columns)>,
}

impl CurveResponse {
    /// Solves `light`'s response on `engine`, to the relative `tolerance` per column: its values
    /// (its patch direct light `emission`, dimmer applied, started from `warm` per channel when
    /// given) and a column for each control point of `new_points`, in one block solve, keeping
    /// the columns of `carried` (a response of the light where it stands, as aimed, at the same
    /// control-point angles; the caller checks with [`Self::stands_as`]). `cache` is the
    /// light's direct sample cache for its position.
    ///
    /// Errors: the solve failing, or a dimmer ≤ 0 (internal: such a light has nothing to
    /// respond with).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn solve(
        engine: &Interreflection,
        cache: &PatchDirectCache,
        light: &Light,
        emission: &PatchColumns,
        warm: Option<&[PatchColumns]>,
        carried: Option<&CurveResponse>,
        new_points: &[usize],
        tolerance: f64,
    ) -> Result<Self> {
        if light.dimmer <= 0.0 {
            return Err(Error::internal(
                "a curve response of a light dimmed to 0".to_string(),
            ));
        }
        let n = engine.n_leaves();
        let m = 1 + new_points.len();
        let mut hats = vec![0.0; n * new_points.len()];
        cache.control_point_irradiance_into(&light.curve, light.aim.normalize(), new_points, &mut hats);
        let mut block = PatchColumns::zeros(n, m);
        for (p, row) in block.values.chunks_exact_mut(m).enumerate() {
            row[0] = emission.values[p];
            row[1..].copy_from_slice(&hats[p * (m - 1)..(p + 1) * (m - 1)]);
        }
        // Each column starts one bounce in: the light's from its warm start, each point's from
        // its first reflection `ρ e_k`.
        let initial: Vec<PatchColumns> = engine
            .reflectance
            .iter()
            .enumerate()
            .map(|(ch, rho)| {
                let mut x0 = PatchColumns::zeros(n, m);
                let warm = warm.and_then(|w| w.get(ch));
                for (p, row) in x0.values.chunks_exact_mut(m).enumerate() {
                    row[0] = warm.map_or(0.0, |w| w.values[p]);
                    for (x, e) in row[1..].iter_mut().zip(&hats[p * (m - 1)..]) {
                        *x = rho[p] * e;
                    }
                }
                x0
            })
            .collect();
        let solutions = engine.solve(&block, Some(&initial), tolerance)?;
        let kept = carried.map_or(&[][..], |r| &r.points[..]);
        let points = kept
            .iter()
            .filter(|(k, _)| !new_points.contains(k))
            .cloned()
            .chain(
                new_points
                    .iter()
                    .enumerate()
                    .map(|(j, &k)| (k, Columns::of_column(&solutions, 1 + j, &block))),
            )
            .collect();
        Ok(CurveResponse {
            position: light.position,
            radius_m: light.radius,
            aim: light.aim,
            gammas_deg: light.curve.gammas_deg().to_vec(),
            base_cd: light.curve.intensities_cd().to_vec(),
            base_dimmer: light.dimmer,
            base: Columns::of_column(&solutions, 0, &block),
            points,
        })
    }

    /// True when `light` stands where the response was solved, aimed the same way, with a curve
    /// of the same control-point angles: its columns hold for it.
    pub fn stands_as(&self, light: &Light) -> bool {
        light.position == self.position
            && light.radius == self.radius_m
            && light.aim == self.aim
            && light.curve.gammas_deg() == self.gammas_deg
    }

    /// The control points with a column.
    pub fn points(&self) -> impl Iterator<Item = usize> + '_ {
        self.points.iter().map(|(k, _)| *k)
    }

    /// True when [`Self::values`] is `light`'s solve: it [`Self::stands_as`] solved, and every
    /// control point without a column has its base intensity.
    pub fn fits(&self, light: &Light) -> bool {
        self.stands_as(light)
            && light
                .curve
                .intensities_cd()
                .iter()
                .zip(&self.base_cd)
                .enumerate()
                .all(|(k, (i, base))| i == base || self.points().any(|p| p == k))
    }

    /// The solved values of `light` (which [`Self::fits`]): the base scaled by the dimmer's
    /// ratio, plus each column weighted by its point's change of intensity times the dimmer.
    pub(crate) fn values(&self, light: &Light) -> LightValues {
        let intensities = light.curve.intensities_cd();
        let weighted: Vec<(&Columns, f64)> = self
            .points
            .iter()
            .map(|(k, c)| (c, light.dimmer * (intensities[*k] - self.base_cd[*k])))
            .filter(|(_, w)| *w != 0.0)
            .collect();
        let scale = light.dimmer / self.base_dimmer;
        let channel = |base: &[f32], pick: &dyn Fn(&Columns) -> &[f32]| {
            let columns: Vec<(&[f32], f64)> = weighted.iter().map(|(c, w)| (pick(c), *w)).collect();
            combine(base, scale, &columns)
        };
        LightValues {
            radiosity: (0..self.base.radiosity.len())
                .map(|ch| {
                    let values = channel(&self.base.radiosity[ch], &|c| &c.radiosity[ch]);
                    PatchColumns {
                        n_patches: values.len(),
                        n_columns: 1,
                        values,
                    }
                })
                .collect(),
            indirect: (0..self.base.indirect.len())
                .map(|ch| channel(&self.base.indirect[ch], &|c| &c.indirect[ch]))
                .collect(),
        }
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        let values = self.base.len() + self.points.iter().map(|(_, c)| c.len()).sum::<usize>();
        4 * values + 8 * (self.gammas_deg.len() + self.base_cd.len() + self.points.len())
    }
}
