//! The room file schema (docs/ROOM_FILE.md, version 1) as serde types, and byte-span → place conversion.
//!
//! Every value a later check may reject is wrapped in [`Spanned`] so that the error names the
//! line, the column and the field. Unknown fields are rejected. Arrays are read with any length
//! and their length is checked on load ([`crate::scene::load`]), so that an extra or missing
//! element is an error naming the field. Lengths are metres in the world frame (z up), angles
//! degrees, intensities candela.

use serde::Deserialize;
use std::ops::Range;
use toml::Spanned;

use crate::scene::calc_spec::{LuminousSizeSpec, ObserverSpec, SurfaceSpec};

/// A three-component vector as written in the file (`[x, y, z]`, metres or a direction); its
/// length is checked on load.
pub(crate) type Vec3Spec = Vec<f64>;

/// The whole room file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RoomFile {
    /// Schema version; only 1 is understood.
    pub version: Spanned<i64>,
    /// Display name (default: the file stem).
    pub name: Option<String>,
    /// The room box and its reflectances.
    pub room: RoomSpec,
    /// Axis-aligned boxes (furniture).
    #[serde(default, rename = "box")]
    pub boxes: Vec<Spanned<BoxSpec>>,
    /// OBJ meshes.
    #[serde(default, rename = "mesh")]
    pub meshes: Vec<Spanned<MeshSpec>>,
    /// Luminaires.
    #[serde(default, rename = "light")]
    pub lights: Vec<Spanned<LightSpec>>,
    /// Meshing and solver settings.
    #[serde(default)]
    pub settings: SettingsSpec,
    /// The preview camera (default: see [`crate::scene::load`]).
    pub camera: Option<Spanned<CameraSpec>>,
    /// Calculation surfaces (default: a work plane at 0.8 m).
    #[serde(default, rename = "surface")]
    pub surfaces: Vec<Spanned<SurfaceSpec>>,
    /// Glare observers (default: seated, in the middle of each wall).
    #[serde(default, rename = "observer")]
    pub observers: Vec<Spanned<ObserverSpec>>,
}

/// `[room]`: the room interior spans (0, 0, 0) to `size` (metres).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RoomSpec {
    /// Width (x), depth (y), height (z) in metres.
    pub size: Spanned<Vec3Spec>,
    /// Reflectances of floor, walls and ceiling.
    pub reflectance: RoomReflectanceSpec,
}

/// `[room.reflectance]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RoomReflectanceSpec {
    /// Floor (z = 0).
    pub floor: Spanned<ReflectanceSpec>,
    /// All four walls.
    pub walls: Spanned<ReflectanceSpec>,
    /// Ceiling (z = height).
    pub ceiling: Spanned<ReflectanceSpec>,
}

/// A reflectance: a number (grey) or `[r, g, b]`, each in 0..0.98.
#[derive(Debug, Clone, Deserialize)]
#[serde(
    untagged,
    expecting = "expected a reflectance: a number or [r, g, b], each in 0..0.98"
)]
pub(crate) enum ReflectanceSpec {
    /// One value for all channels.
    Grey(f64),
    /// Per channel (three numbers; checked on load).
    Rgb(Vec<f64>),
}

/// `[[box]]`: an axis-aligned box, world metres.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct BoxSpec {
    /// Minimum corner.
    pub min: Spanned<Vec3Spec>,
    /// Maximum corner.
    pub max: Spanned<Vec3Spec>,
    /// Reflectance of all six faces.
    pub reflectance: Spanned<ReflectanceSpec>,
}

/// Which OBJ axis points up.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum UpAxis {
    /// y up (the OBJ convention): (x, y, z) → (x, −z, y).
    #[default]
    Y,
    /// z up: coordinates kept.
    Z,
}

/// `[[mesh]]`: an OBJ file placed in the room.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct MeshSpec {
    /// Path of the OBJ, relative to the room file.
    pub file: Spanned<String>,
    /// Translation (metres, world) applied after the up conversion and the scale.
    #[serde(default)]
    pub translate: Option<Spanned<Vec3Spec>>,
    /// Uniform scale (> 0), applied after the up conversion. Default 1.
    #[serde(default)]
    pub scale: Option<Spanned<f64>>,
    /// The OBJ's up axis. Default `"y"`.
    #[serde(default)]
    pub up: UpAxis,
}

/// `[[light]]`: a luminaire.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct LightSpec {
    /// Unique name.
    pub name: Spanned<String>,
    /// Position (world, metres).
    pub position: Spanned<Vec3Spec>,
    /// Aim target point (world, metres).
    pub aim: Option<Spanned<Vec3Spec>>,
    /// Aim direction (world; normalised on load). Default `[0, 0, -1]`.
    pub aim_dir: Option<Spanned<Vec3Spec>>,
    /// Inline curve: `[γ_deg, candela]` points (each checked on load to have two numbers).
    pub lid: Option<Spanned<Vec<Spanned<Vec<f64>>>>>,
    /// Photometric file (IES / EULUMDAT), relative to the room file.
    pub lid_file: Option<Spanned<String>>,
    /// Fixed SH order (≤ 150).
    pub order: Option<Spanned<i64>>,
    /// Luminous radius, metres (≥ 0). Default 0.
    pub radius: Option<Spanned<f64>>,
    /// Dimmer factor (≥ 0). Default 1.
    pub dimmer: Option<Spanned<f64>>,
    /// Linear RGB multipliers (≥ 0). Default `[1, 1, 1]`.
    pub color: Option<Spanned<Vec3Spec>>,
    /// Size of the luminous area (m), overriding the photometric file's.
    pub luminous_size: Option<Spanned<LuminousSizeSpec>>,
}

/// How direct light is computed, as written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub(crate) enum DirectSpec {
    /// Hybrid: exact direct light.
    Exact,
    /// Paper mode: direct light from the SH basis.
    Basis,
}

/// The indirect-light engine, as written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub(crate) enum IndirectSpec {
    /// Chosen by the plan.
    Auto,
    /// The SH basis bake.
    Basis,
    /// The hierarchical engine.
    Hierarchical,
}

/// `[settings]`, all optional.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct SettingsSpec {
    /// Fine patch edge, metres.
    pub patch_size: Option<Spanned<f64>>,
    /// Coarse patch edge, metres.
    pub solver_patch_size: Option<Spanned<f64>>,
    /// Direct-light mode.
    pub direct: Option<DirectSpec>,
    /// Relative tolerance of the interreflection solve, in (0, 0.5].
    pub tolerance: Option<Spanned<f64>>,
    /// The indirect-light engine.
    pub indirect: Option<IndirectSpec>,
    /// Maintained / new illuminance, in (0, 1]. Default 0.8.
    pub maintenance_factor: Option<Spanned<f64>>,
}

/// `[camera]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct CameraSpec {
    /// Eye position (world, metres).
    pub eye: Spanned<Vec3Spec>,
    /// Point looked at (world, metres).
    pub target: Spanned<Vec3Spec>,
    /// Vertical field of view, degrees. Default 60.
    pub fov_deg: Option<Spanned<f64>>,
}

/// `line L, column C` (both 1-based; the column counts characters) of byte `offset` in `text`.
pub(crate) fn line_column(text: &str, offset: usize) -> String {
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let column = before[line_start..].chars().count() + 1;
    format!("line {line}, column {column}")
}

/// The place of a spanned value: `line L, column C (field)`.
pub fn place(text: &str, span: &Range<usize>, field: &str) -> String {
    format!("{} ({field})", line_column(text, span.start))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_column_counts_from_one_and_counts_characters() {
        let text = "a = 1\nγγ = 2\n";
        assert_eq!(line_column(text, 0), "line 1, column 1");
        assert_eq!(line_column(text, 4), "line 1, column 5");
        // "γγ" is 4 bytes, so byte 11 is the `=` on line 2, its 4th character.
        assert_eq!(line_column(text, 11), "line 2, column 4");
    }
}
