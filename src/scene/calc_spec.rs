//! The room file's design tables as written (docs/ROOM_FILE.md, "Design numbers"):
//! `[[surface]]` calculation surfaces, `[[observer]]` glare observers and a light's
//! `luminous_size`. Validated into [`crate::scene::design`] by the loader; every value a check
//! may reject is [`Spanned`] so errors name the line, the column and the field.

use serde::Deserialize;
use toml::Spanned;

use crate::scene::room_file::Vec3Spec;

/// `[[surface]]`: a work plane or task area (a horizontal rectangle, the default), or room
/// surfaces (`on = "floor" | "ceiling" | "walls" | "wall-x0" | …`).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct SurfaceSpec {
    /// Name shown in tables (default `surface[i]`, or the `on` value).
    pub name: Option<Spanned<String>>,
    /// Height of a horizontal surface above the floor, m (default 0.8).
    pub height: Option<Spanned<f64>>,
    /// Corner `[x, y]` with the smaller coordinates, m (with `max`; default: the room without
    /// `margin`).
    pub min: Option<Spanned<Vec<f64>>>,
    /// Corner `[x, y]` with the larger coordinates, m.
    pub max: Option<Spanned<Vec<f64>>>,
    /// Room surfaces instead of a horizontal rectangle.
    pub on: Option<Spanned<String>>,
    /// Band left out along the walls (work plane covering the room, default 0.5 m) or along
    /// the edges of room surfaces (default 0), m.
    pub margin: Option<Spanned<f64>>,
    /// Largest grid cell, m (default: the EN 12464-1 rule).
    pub spacing: Option<Spanned<f64>>,
    /// A task preset (`office-writing`, …) giving the targets.
    pub task: Option<Spanned<String>>,
    /// Maintained mean illuminance Ē_m to reach, lx.
    pub target_lux: Option<Spanned<f64>>,
    /// Uniformity U0 = E_min / Ē to reach.
    pub target_u0: Option<Spanned<f64>>,
    /// Uniformity g2 = E_min / E_max to reach.
    pub target_g2: Option<Spanned<f64>>,
    /// UGR limit UGR_L of the task.
    pub target_ugr: Option<Spanned<f64>>,
}

/// `[[observer]]`: a glare observer.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ObserverSpec {
    /// Name shown in tables (default `observer[i]`).
    pub name: Option<Spanned<String>>,
    /// Eye position (world, m).
    pub eye: Spanned<Vec3Spec>,
    /// Line of sight (world); must be horizontal (z = 0).
    pub view_dir: Spanned<Vec3Spec>,
    /// UGR limit for this position (default: the lowest `target_ugr` of the surfaces).
    pub ugr_limit: Option<Spanned<f64>>,
}

/// A light's `luminous_size`: a disc diameter, `[length, width]` of a flat rectangle, or
/// `[length, width, height]` of a box with luminous sides (m, length along C0).
#[derive(Debug, Clone, Deserialize)]
#[serde(
    untagged,
    expecting = "expected a luminous size: a diameter in m, [length, width] or [length, width, height]"
)]
pub(crate) enum LuminousSizeSpec {
    /// Diameter of a disc facing along the aim, m.
    Diameter(f64),
    /// `[length, width]` or `[length, width, height]`, m.
    Sides(Vec<f64>),
}
