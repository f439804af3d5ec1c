//! The commands a key makes for one light, computed from the light's current state. Each
//! returns the reason in words when there is nothing sensible to do; the commands themselves
//! validate what they change ([`crate::session::Command::apply`]).

use glam::DVec3;

use crate::session::{Command, LightEdit, MAX_ORDER};

/// Intensity step base (cd) for a curve whose peak is 0, where "5 % of the peak" would be 0.
pub const DARK_CURVE_PEAK_CD: f64 = 100.0;

/// How far inside the room box a moved light is kept (m): a light on a wall could not be
/// loaded again.
pub const MOVE_MARGIN_M: f64 = 0.01;

/// Why a key made no command.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EditError {
    /// The selected control point does not exist.
    #[error("no control point {0}")]
    NoPoint(usize),
    /// Two neighbouring points at one angle leave no room for a point between them.
    #[error("no room for a new point between {low}° and {high}°")]
    NoRoom {
        /// Lower angle, degrees.
        low: f64,
        /// Upper angle, degrees.
        high: f64,
    },
    /// The curve refused the change (e.g. fewer than two points would remain).
    #[error("{0}")]
    Curve(#[from] crate::photometry::CurveError),
    /// A typed value that is not an intensity.
    #[error("'{0}' is not an intensity in cd (a number ≥ 0)")]
    NotAnIntensity(String),
    /// A typed dimmer that is not a percentage.
    #[error("'{0}' is not a dimmer in percent (a number ≥ 0, e.g. 24 for 24 %)")]
    NotADimmer(String),
    /// The light cannot aim at its own position.
    #[error("cannot aim {0} at its own position")]
    AimAtItself(String),
}

fn point_intensity(light: &LightEdit, k: usize) -> Result<f64, EditError> {
    light
        .curve
        .intensities_cd()
        .get(k)
        .copied()
        .ok_or(EditError::NoPoint(k))
}

/// Changes point `k`'s intensity by `fraction` of the curve's peak (cd), clamped at 0.
pub fn nudge_intensity(light: &LightEdit, i: usize, k: usize, fraction: f64) -> Result<Command, EditError> {
    let peak = light.curve.peak_cd();
    let base = if peak > 0.0 { peak } else { DARK_CURVE_PEAK_CD };
    let now = point_intensity(light, k)?;
    Ok(Command::SetIntensity {
        light: i,
        point: k,
        candela: (now + fraction * base).max(0.0),
    })
}

/// Sets point `k`'s intensity (cd).
pub fn set_intensity(light: &LightEdit, i: usize, k: usize, candela: f64) -> Result<Command, EditError> {
    point_intensity(light, k)?;
    Ok(Command::SetIntensity {
        light: i,
        point: k,
        candela,
    })
}

/// Moves point `k`'s angle by `delta_deg`, clamped between its neighbours (and 0°..180°).
pub fn move_angle(light: &LightEdit, i: usize, k: usize, delta_deg: f64) -> Result<Command, EditError> {
    let gammas = light.curve.gammas_deg();
    let now = *gammas.get(k).ok_or(EditError::NoPoint(k))?;
    let low = if k > 0 { gammas[k - 1] } else { 0.0 };
    let high = gammas.get(k + 1).copied().unwrap_or(180.0);
    Ok(Command::SetGamma {
        light: i,
        point: k,
        gamma_deg: (now + delta_deg).clamp(low, high),
    })
}

/// Inserts a point halfway between point `k` and the next one (between the last two when `k`
/// is the last), on the curve so its shape is unchanged. Returns the command and the new
/// point's index.
pub fn insert_after(light: &LightEdit, i: usize, k: usize) -> Result<(Command, usize), EditError> {
    let gammas = light.curve.gammas_deg();
    let last = gammas.len() - 1;
    let (a, b) = if k < last {
        (gammas[k], gammas[k + 1])
    } else {
        (gammas[last - 1], gammas[last])
    };
    if b - a <= 0.0 {
        return Err(EditError::NoRoom { low: a, high: b });
    }
    let gamma = 0.5 * (a + b);
    let mut curve = light.curve.clone();
    let index = curve.insert(gamma, light.curve.eval_deg(gamma))?;
    Ok((Command::SetCurve { light: i, curve }, index))
}

/// Deletes point `k` (refused when fewer than two distinct angles would remain).
pub fn delete_point(light: &LightEdit, i: usize, k: usize) -> Result<Command, EditError> {
    if k >= light.curve.len() {
        return Err(EditError::NoPoint(k));
    }
    let mut curve = light.curve.clone();
    curve.remove(k)?;
    Ok(Command::SetCurve { light: i, curve })
}

/// Changes the SH order by `delta`, clamped to 0..=[`MAX_ORDER`].
pub fn change_order(light: &LightEdit, i: usize, delta: i32) -> Command {
    let order = i64::try_from(light.order).unwrap_or(i64::MAX) + i64::from(delta);
    Command::SetOrder {
        light: i,
        order: usize::try_from(order.max(0)).unwrap_or(0).min(MAX_ORDER),
    }
}

/// Moves the dimmer to the next multiple of 0.1 in the direction of `delta` (0.1 = 10 %),
/// clamped at 0; a dimmer between multiples snaps to the neighbouring one. Values are tenths
/// divided by ten, so they print without rounding noise (0.3, not 0.30000000000000004).
pub fn step_dimmer(light: &LightEdit, i: usize, delta: f64) -> Command {
    const SNAP: f64 = 1e-9;
    let tenths = light.dimmer * 10.0;
    let next = if delta > 0.0 {
        (tenths + SNAP).floor() + 1.0
    } else {
        (tenths - SNAP).ceil() - 1.0
    };
    Command::SetDimmer {
        light: i,
        dimmer: next.max(0.0) / 10.0,
    }
}

/// Moves the light by `offset_m` (world, m), kept [`MOVE_MARGIN_M`] inside the room box
/// `(0,0,0)..room_size`.
pub fn move_by(light: &LightEdit, i: usize, offset_m: DVec3, room_size: DVec3) -> Command {
    let margin = DVec3::splat(MOVE_MARGIN_M).min(room_size * 0.5);
    Command::Move {
        light: i,
        position: (light.position + offset_m).clamp(margin, room_size - margin),
    }
}

/// Parses a typed intensity: a finite number ≥ 0 (cd).
pub fn parse_intensity(text: &str) -> Result<f64, EditError> {
    match text.parse::<f64>() {
        Ok(value) if value.is_finite() && value >= 0.0 => Ok(value),
        _ => Err(EditError::NotAnIntensity(text.to_string())),
    }
}
