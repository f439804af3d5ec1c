//! The editable state of one luminaire as the session, the editor and the save see it: the
//! room file's light plus the session choices (SH order, ringing window).
//! World frame: metres, z up (docs/METHOD.md §1).

use glam::DVec3;

use crate::photometry::{self, Curve, LuminousShape};
use crate::scene::{AimSpec, LidSource, Light};

/// SH order used for a light whose room file fixes none, until the plan's choice replaces it.
pub const DEFAULT_ORDER: usize = 16;
/// Highest SH order the editor offers (the recurrence is accurate to l = 150, docs/METHOD.md §2).
pub const MAX_ORDER: usize = 150;

/// The ringing window applied to a light's truncated series (docs/METHOD.md §4). Not stored in
/// the room file: it is a session choice (the plan's rule decides it when `Auto`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum WindowChoice {
    /// The plan's rule: Hann only where the series dips below −0.5 % of the peak.
    #[default]
    Auto,
    /// No window (σ_l = 1).
    None,
    /// Hann `½(1 + cos(π l / (N + 1)))`.
    Hann,
    /// Lanczos `sinc(l / (N + 1))`.
    Lanczos,
    /// Cesàro (C, 2): a positive kernel, never negative, but blurs edges.
    Cesaro2,
}

impl WindowChoice {
    /// The next window in the cycle the editor's window key walks through.
    pub fn next(self) -> Self {
        match self {
            WindowChoice::Auto => WindowChoice::None,
            WindowChoice::None => WindowChoice::Hann,
            WindowChoice::Hann => WindowChoice::Lanczos,
            WindowChoice::Lanczos => WindowChoice::Cesaro2,
            WindowChoice::Cesaro2 => WindowChoice::Auto,
        }
    }

    /// The name shown in the UI.
    pub fn label(self) -> &'static str {
        match self {
            WindowChoice::Auto => "auto",
            WindowChoice::None => "none",
            WindowChoice::Hann => "Hann",
            WindowChoice::Lanczos => "Lanczos",
            WindowChoice::Cesaro2 => "Cesàro-2",
        }
    }

    /// The window it forces, or `None` for the automatic rule.
    pub fn forced(self) -> Option<photometry::Window> {
        match self {
            WindowChoice::Auto => None,
            WindowChoice::None => Some(photometry::Window::None),
            WindowChoice::Hann => Some(photometry::Window::Hann),
            WindowChoice::Lanczos => Some(photometry::Window::Lanczos),
            WindowChoice::Cesaro2 => Some(photometry::Window::Cesaro2),
        }
    }
}

/// The editable state of one light: everything a command (and so undo) can change.
#[derive(Debug, Clone, PartialEq)]
pub struct LightEdit {
    /// Name from the room file.
    pub name: String,
    /// Position (world, m).
    pub position: DVec3,
    /// Unit aim axis (world); γ = 0 points along it.
    pub aim: DVec3,
    /// The aim as it will be written to the room file.
    pub aim_spec: AimSpec,
    /// Intensity curve (cd), before the dimmer.
    pub curve: Curve,
    /// Where the curve came from.
    pub lid_source: LidSource,
    /// Dimmer factor, ≥ 0.
    pub dimmer: f64,
    /// SH order of the light's series.
    pub order: usize,
    /// Ringing window of the light's series.
    pub window: WindowChoice,
    /// Luminous radius (m), from the room file.
    pub radius_m: f64,
    /// Linear RGB colour multipliers, from the room file.
    pub color: [f64; 3],
    /// The luminous area (for glare ratings), from the room file or the photometric file.
    pub luminous: Option<LuminousShape>,
}

impl LightEdit {
    /// The editable state of a scene light; `order` is the file's, else [`DEFAULT_ORDER`].
    pub fn from_light(light: &Light) -> Self {
        LightEdit {
            name: light.name.clone(),
            position: light.position,
            aim: light.aim,
            aim_spec: light.aim_spec,
            curve: light.curve.clone(),
            lid_source: light.lid_source.clone(),
            dimmer: light.dimmer,
            order: light.order.unwrap_or(DEFAULT_ORDER),
            window: WindowChoice::Auto,
            radius_m: light.radius,
            color: light.color,
            luminous: light.luminous,
        }
    }

    /// The scene light this state describes, its order fixed to [`LightEdit::order`].
    pub fn to_light(&self) -> Light {
        Light {
            name: self.name.clone(),
            position: self.position,
            aim: self.aim,
            aim_spec: self.aim_spec,
            curve: self.curve.clone(),
            lid_source: self.lid_source.clone(),
            order: Some(self.order),
            radius: self.radius_m,
            dimmer: self.dimmer,
            color: self.color,
            luminous: self.luminous,
        }
    }

    /// True when the values a save writes (curve, aim, position, dimmer, order) are equal; the
    /// window is a session choice and not compared.
    pub fn same_saved_values(&self, other: &LightEdit) -> bool {
        self.curve == other.curve
            && self.aim_spec == other.aim_spec
            && self.position == other.position
            && self.dimmer == other.dimmer
            && self.order == other.order
    }
}
