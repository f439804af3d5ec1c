//! How bright the photo view is: an exposure that stays fixed while the user edits (so a dimmed
//! room looks darker), or follows the scene (automatic).
//!
//! Exposures are given as EV at ISO 100 of the **key luminance** `L_key` (cd/m²), the luminance
//! the photo view shows as mid-grey: `EV₁₀₀ = log₂(L_key · 100 / 12.5)` (the reflected-light
//! meter equation with the usual calibration constant K = 12.5 cd s/m²). One EV up doubles the
//! key: the picture gets one stop darker. The automatic key is the room's (docs/DECISIONS.md,
//! "Renderer"): the area-weighted geometric mean of the lit vertices' luminance, which does not
//! depend on the camera, so orbiting does not re-expose.

use super::shade::{MID_GREY, Photo, area_quantile, luma, vertex_areas};
use crate::scene::model::PatchMesh;

/// The auto-exposure's reference level is this area quantile of the lit vertices' luminance.
pub const KEY_REFERENCE_QUANTILE: f64 = 0.9;

/// Vertices darker than this fraction of the reference level are left out of the key: they
/// show as near-black instead of dragging the exposure up (a ceiling no light reaches).
pub const KEY_DARK_FRACTION: f64 = 0.01;

/// Keys below this luminance (cd/m²) count as a room without light: it gets
/// [`DEFAULT_EV100`] and shows black, never amplified rounding noise.
pub const MIN_KEY_CD_M2: f64 = 1e-6;

/// Exposure of a room that opens without light: mid-grey at 500 lx on a ρ = 0.5 surface
/// (79.6 cd/m², EV₁₀₀ ≈ 9.3).
pub const DEFAULT_EV100: f64 = 9.314_2;

/// How the photo view is exposed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Exposure {
    /// Re-chosen from the scene on every frame (scaling every light leaves the picture alike).
    Auto,
    /// Fixed at this EV₁₀₀ of the key luminance.
    Fixed {
        /// EV at ISO 100 of the luminance shown as mid-grey.
        ev100: f64,
    },
}

impl Exposure {
    /// The fixed exposure a room opens with: its automatic key now (per-vertex luminance
    /// `luminance_cd_m2`, as [`super::vertex_attributes`] makes in photo mode), or
    /// [`DEFAULT_EV100`] for a room without light.
    pub fn fixed_for(mesh: &PatchMesh, luminance_cd_m2: &[[f32; 3]]) -> Exposure {
        Exposure::Fixed {
            ev100: room_ev100(mesh, luminance_cd_m2),
        }
    }

    /// The photo shader for this exposure; the automatic one is keyed on `luminance_cd_m2`.
    pub fn photo(&self, mesh: &PatchMesh, luminance_cd_m2: &[[f32; 3]]) -> Photo {
        match *self {
            Exposure::Auto => Photo::auto(mesh, luminance_cd_m2),
            Exposure::Fixed { ev100 } => Photo::with_ev100(ev100),
        }
    }

    /// This exposure moved by `delta_ev` (positive: darker). The automatic exposure becomes a
    /// fixed one, starting from `current` (the shader the view shows now).
    pub fn stepped(&self, delta_ev: f64, current: &Photo) -> Exposure {
        let ev100 = match *self {
            Exposure::Auto => current.ev100(),
            Exposure::Fixed { ev100 } => ev100,
        };
        Exposure::Fixed {
            ev100: ev100 + delta_ev,
        }
    }
}

/// EV₁₀₀ of the room's exposure: of its automatic key (per-vertex luminance `luminance_cd_m2`),
/// or [`DEFAULT_EV100`] for a room without light.
pub fn room_ev100(mesh: &PatchMesh, luminance_cd_m2: &[[f32; 3]]) -> f64 {
    auto_key(mesh, luminance_cd_m2).map_or(DEFAULT_EV100, ev100_of_key)
}

/// EV₁₀₀ of a key luminance (cd/m²).
pub fn ev100_of_key(key_cd_m2: f64) -> f64 {
    (key_cd_m2 * 100.0 / 12.5).log2()
}

/// The key luminance (cd/m²) of an EV₁₀₀.
pub fn key_of_ev100(ev100: f64) -> f64 {
    ev100.exp2() * 12.5 / 100.0
}

/// The exposure factor (m²/cd) that shows `key_cd_m2` as mid-grey.
pub fn exposure_of_key(key_cd_m2: f64) -> f64 {
    MID_GREY / (1.0 - MID_GREY) / key_cd_m2
}

/// The automatic key luminance (cd/m²) of per-vertex luminance: over the vertices with a
/// positive luma, the level `L_90` that 90 % of their area is at or below; the area-weighted
/// geometric mean of the vertices at least `L_90 / 100` bright. `None` when no vertex is lit
/// or the key is below [`MIN_KEY_CD_M2`].
pub fn auto_key(mesh: &PatchMesh, luminance_cd_m2: &[[f32; 3]]) -> Option<f64> {
    let areas = vertex_areas(mesh);
    let mut lit: Vec<(f64, f64)> = areas
        .iter()
        .zip(luminance_cd_m2)
        .map(|(&area, l)| (luma(l.map(f64::from)), area))
        .filter(|&(y, area)| area > 0.0 && y > 0.0 && y.is_finite())
        .collect();
    let reference = area_quantile(&mut lit, KEY_REFERENCE_QUANTILE)?;
    let floor = reference * KEY_DARK_FRACTION;
    let (weight, log_sum) = lit
        .iter()
        .filter(|&&(y, _)| y >= floor)
        .fold((0.0, 0.0), |(w, s), &(y, area)| (w + area, s + area * y.ln()));
    let key = (log_sum / weight).exp();
    (key >= MIN_KEY_CD_M2).then_some(key)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ev_and_key_are_inverse_and_one_ev_doubles_the_key() {
        // The meter equation: EV 0 at ISO 100 is 0.125 cd/m²; EV 10 is 128 cd/m².
        assert!((key_of_ev100(0.0) - 0.125).abs() < 1e-15);
        assert!((key_of_ev100(10.0) - 128.0).abs() < 1e-12);
        for key in [1e-3, 0.7, 79.577, 4000.0] {
            assert!((key_of_ev100(ev100_of_key(key)) - key).abs() < 1e-12 * key);
            assert!((key_of_ev100(ev100_of_key(key) + 1.0) - 2.0 * key).abs() < 1e-12 * key);
        }
        // The default: 500 lx on ρ = 0.5 is 500 · 0.5 / π cd/m².
        let default_key = 500.0 * 0.5 / std::f64::consts::PI;
        assert!((ev100_of_key(default_key) - DEFAULT_EV100).abs() < 1e-4);
    }

    #[test]
    fn stepping_fixes_the_automatic_exposure_and_moves_a_fixed_one() {
        let current = Photo::with_ev100(7.0);
        assert_eq!(
            Exposure::Auto.stepped(0.5, &current),
            Exposure::Fixed { ev100: 7.5 }
        );
        assert_eq!(
            Exposure::Fixed { ev100: 3.0 }.stepped(-1.0, &current),
            Exposure::Fixed { ev100: 2.0 }
        );
    }
}
