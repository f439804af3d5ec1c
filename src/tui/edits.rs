//! The edits a key makes to one light, as plain functions on [`LightEdit`]. Each returns the
//! reason in words when it refuses (the light is then unchanged); the caller records undo.

use glam::DVec3;

use crate::scene::AimSpec;
use crate::tui::model::{LightEdit, MAX_ORDER};

/// Intensity step base (cd) for a curve whose peak is 0, where "5 % of the peak" would be 0.
pub const DARK_CURVE_PEAK_CD: f64 = 100.0;

/// Changes point `k`'s intensity by `fraction` of the curve's peak (cd), clamped at 0.
pub fn nudge_intensity(light: &mut LightEdit, k: usize, fraction: f64) -> Result<(), String> {
    let peak = light.curve.peak_cd();
    let base = if peak > 0.0 { peak } else { DARK_CURVE_PEAK_CD };
    let now = point_intensity(light, k)?;
    set_intensity(light, k, (now + fraction * base).max(0.0))
}

/// Sets point `k`'s intensity (cd).
pub fn set_intensity(light: &mut LightEdit, k: usize, candela: f64) -> Result<(), String> {
    point_intensity(light, k)?;
    light.curve.set_intensity(k, candela).map_err(|e| e.to_string())
}

fn point_intensity(light: &LightEdit, k: usize) -> Result<f64, String> {
    light
        .curve
        .intensities_cd()
        .get(k)
        .copied()
        .ok_or_else(|| format!("no control point {k}"))
}

/// Moves point `k`'s angle by `delta_deg`, clamped between its neighbours (and 0°..180°).
pub fn move_angle(light: &mut LightEdit, k: usize, delta_deg: f64) -> Result<(), String> {
    let gammas = light.curve.gammas_deg();
    let now = *gammas.get(k).ok_or_else(|| format!("no control point {k}"))?;
    let low = if k > 0 { gammas[k - 1] } else { 0.0 };
    let high = gammas.get(k + 1).copied().unwrap_or(180.0);
    let target = (now + delta_deg).clamp(low, high);
    light.curve.set_gamma(k, target).map_err(|e| e.to_string())
}

/// Inserts a point halfway between point `k` and the next one (between the last two when `k`
/// is the last), on the curve so its shape is unchanged. Returns the new point's index.
pub fn insert_after(light: &mut LightEdit, k: usize) -> Result<usize, String> {
    let gammas = light.curve.gammas_deg();
    let last = gammas.len() - 1;
    let (a, b) = if k < last {
        (gammas[k], gammas[k + 1])
    } else {
        (gammas[last - 1], gammas[last])
    };
    if b - a <= 0.0 {
        return Err(format!("no room for a new point between {a}° and {b}°"));
    }
    let gamma = 0.5 * (a + b);
    let candela = light.curve.eval_deg(gamma);
    light.curve.insert(gamma, candela).map_err(|e| e.to_string())
}

/// Deletes point `k` (refused when fewer than two distinct angles would remain).
pub fn delete_point(light: &mut LightEdit, k: usize) -> Result<(), String> {
    if k >= light.curve.len() {
        return Err(format!("no control point {k}"));
    }
    light.curve.remove(k).map_err(|e| e.to_string())
}

/// Changes the SH order by `delta`, clamped to 0..=[`MAX_ORDER`].
pub fn change_order(light: &mut LightEdit, delta: i32) {
    let order = i64::try_from(light.order).unwrap_or(i64::MAX) + i64::from(delta);
    light.order = usize::try_from(order.max(0)).unwrap_or(0).min(MAX_ORDER);
}

/// Moves the dimmer to the next multiple of 0.1 in the direction of `delta` (0.1 = 10 %),
/// clamped at 0; a dimmer between multiples snaps to the neighbouring one. Values are tenths
/// divided by ten, so they print without rounding noise (0.3, not 0.30000000000000004).
pub fn step_dimmer(light: &mut LightEdit, delta: f64) {
    const SNAP: f64 = 1e-9;
    let tenths = light.dimmer * 10.0;
    let next = if delta > 0.0 {
        (tenths + SNAP).floor() + 1.0
    } else {
        (tenths - SNAP).ceil() - 1.0
    };
    light.dimmer = next.max(0.0) / 10.0;
}

/// Aims the light at `point` (world, m): the axis becomes `normalize(point − position)` and the
/// file form an `aim = point` target.
pub fn aim_at(light: &mut LightEdit, point: DVec3) -> Result<(), String> {
    let axis = (point - light.position)
        .try_normalize()
        .ok_or_else(|| format!("cannot aim {} at its own position", light.name))?;
    light.aim = axis;
    light.aim_spec = AimSpec::Target(point);
    Ok(())
}

/// Moves the light by `offset_m` (world, m), kept inside the room box `(0,0,0)..room_size`.
/// A light aimed at a target point keeps aiming at it (as the room file would say on reload);
/// one aimed along a direction keeps its direction.
pub fn move_by(light: &mut LightEdit, offset_m: DVec3, room_size: DVec3) {
    light.position = (light.position + offset_m).clamp(DVec3::ZERO, room_size);
    if let AimSpec::Target(target) = light.aim_spec
        && let Some(axis) = (target - light.position).try_normalize()
    {
        light.aim = axis;
    }
}

/// Parses a typed intensity: a finite number ≥ 0 (cd).
pub fn parse_intensity(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(value) if value.is_finite() && value >= 0.0 => Ok(value),
        _ => Err(format!("'{text}' is not an intensity in cd (a number ≥ 0)")),
    }
}
