//! Display modes: per-vertex attributes from illuminance, and per-pixel shaders that turn an
//! interpolated linear RGB triple into sRGB8.
//!
//! * [`DisplayMode::Photo`]: the attribute is luminance `L = ρ E / π` per channel (cd/m²). A
//!   pixel shows the tone curve of `x = L · k` per channel ([`super::tone`]: Reinhard up to
//!   mid-grey, a highlight shoulder above, sRGB-encoded, by one table within one sRGB8 level);
//!   the exposure `k = (0.18 / 0.82) / L_key` shows the key luminance `L_key` as mid-grey (sRGB8
//!   118). The key is fixed or automatic ([`super::exposure`]); with the automatic key scaling
//!   every light leaves the picture unchanged.
//! * [`DisplayMode::FalseColor`]: the attribute is illuminance `E` (lx); its luma is placed on
//!   a logarithmic or linear lux range and coloured with the viridis scale (dark violet at the
//!   bottom of the range, yellow at the top). The range is returned for the UI's legend.

use std::f64::consts::PI;

use super::exposure::{DEFAULT_EV100, auto_key, ev100_of_key, exposure_of_key, key_of_ev100};
use super::tone::{self, tone_srgb8};
use crate::error::{Error, Result};
use crate::scene::model::{PatchMesh, Surface};

/// Turns an interpolated per-pixel attribute (linear RGB triple) into an sRGB8 colour.
pub trait Shader: Sync {
    /// The displayed colour for `value`.
    fn shade(&self, value: [f32; 3]) -> [u8; 3];
}

/// What the preview shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DisplayMode {
    /// The lit room as a photograph: luminance, auto-exposed, tone-mapped.
    #[default]
    Photo,
    /// Illuminance on a false-colour scale.
    FalseColor,
}

/// Display value (after the tone curve) of a surface at the key luminance.
pub const MID_GREY: f64 = 0.18;

/// Rec. 709 / sRGB luma of a linear RGB triple.
pub fn luma(rgb: [f64; 3]) -> f64 {
    0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]
}

/// Per-vertex attributes for `mode` from per-vertex illuminance (lx, RGB): luminance
/// `ρ E / π` (cd/m², reflectance of the vertex's surface) for photo, `E` for false colour.
///
/// Errors (internal): lengths that do not match the mesh, or a vertex surface index outside
/// `surfaces`.
pub fn vertex_attributes(
    mode: DisplayMode,
    mesh: &PatchMesh,
    surfaces: &[Surface],
    illuminance_lx: &[[f64; 3]],
) -> Result<Vec<[f32; 3]>> {
    let mut attrs = Vec::new();
    vertex_attributes_into(mode, mesh, surfaces, illuminance_lx, &mut attrs)?;
    Ok(attrs)
}

/// As [`vertex_attributes`], into `out` (cleared first; its capacity is reused, so a preview
/// that redraws every edit allocates nothing here).
///
/// Errors as [`vertex_attributes`]; `out` is then left empty.
pub fn vertex_attributes_into(
    mode: DisplayMode,
    mesh: &PatchMesh,
    surfaces: &[Surface],
    illuminance_lx: &[[f64; 3]],
    out: &mut Vec<[f32; 3]>,
) -> Result<()> {
    out.clear();
    let n = mesh.n_vertices();
    if illuminance_lx.len() != n || mesh.vertex_surface.len() != n {
        return Err(Error::internal(format!(
            "render: {} illuminance values and {} vertex surfaces for {n} vertices",
            illuminance_lx.len(),
            mesh.vertex_surface.len()
        )));
    }
    for (e, &s) in illuminance_lx.iter().zip(&mesh.vertex_surface) {
        let factor = match mode {
            DisplayMode::FalseColor => [1.0; 3],
            DisplayMode::Photo => {
                let Some(surface) = surfaces.get(s as usize) else {
                    out.clear();
                    return Err(Error::internal(format!(
                        "render: vertex surface {s} of {} surfaces",
                        surfaces.len()
                    )));
                };
                surface.reflectance.0.map(|rho| rho / PI)
            }
        };
        out.push([0, 1, 2].map(|c| (factor[c] * e[c]) as f32));
    }
    Ok(())
}

/// The area each vertex stands for (m²): a third or a quarter of each patch it belongs to.
pub fn vertex_areas(mesh: &PatchMesh) -> Vec<f64> {
    let mut areas = vec![0.0; mesh.n_vertices()];
    for patch in &mesh.patches {
        let share = patch.area / f64::from(patch.n_vertices);
        for &v in patch.vertex_ids() {
            if let Some(a) = areas.get_mut(v as usize) {
                *a += share;
            }
        }
    }
    areas
}

/// The photo shader: exposure, Reinhard tone curve per channel, sRGB encoding.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Photo {
    exposure: f64,
}

impl Photo {
    /// A photo shader multiplying luminance (cd/m²) by `exposure` (m²/cd) before the tone curve.
    pub fn with_exposure(exposure: f64) -> Photo {
        Photo { exposure }
    }

    /// A photo shader showing the luminance of EV₁₀₀ `ev100` as mid-grey
    /// ([`super::exposure`]).
    pub fn with_ev100(ev100: f64) -> Photo {
        Photo::with_exposure(exposure_of_key(key_of_ev100(ev100)))
    }

    /// Auto-exposure ([`super::exposure::auto_key`]) from per-vertex luminance
    /// `luminance_cd_m2` (as made by [`vertex_attributes`] in photo mode). A scene without light
    /// gets [`DEFAULT_EV100`], so it shows black.
    pub fn auto(mesh: &PatchMesh, luminance_cd_m2: &[[f32; 3]]) -> Photo {
        match auto_key(mesh, luminance_cd_m2) {
            Some(key) => Photo::with_exposure(exposure_of_key(key)),
            None => Photo::with_ev100(DEFAULT_EV100),
        }
    }

    /// EV₁₀₀ of the luminance this shader shows as mid-grey.
    pub fn ev100(&self) -> f64 {
        ev100_of_key(exposure_of_key(self.exposure()))
    }

    /// The exposure factor (m²/cd).
    pub fn exposure(&self) -> f64 {
        self.exposure
    }
}

impl Shader for Photo {
    #[inline]
    fn shade(&self, luminance: [f32; 3]) -> [u8; 3] {
        let table = tone::table();
        let k = self.exposure as f32;
        [
            tone_srgb8(table, luminance[0] * k),
            tone_srgb8(table, luminance[1] * k),
            tone_srgb8(table, luminance[2] * k),
        ]
    }
}

/// The area quantile of `(value, area)` pairs: the smallest value such that at least the
/// fraction `q` of the total area has a value at or below it. Sorts `pairs`; `None` when empty.
pub(crate) fn area_quantile(pairs: &mut [(f64, f64)], q: f64) -> Option<f64> {
    pairs.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
    let total: f64 = pairs.iter().map(|p| p.1).sum();
    let mut below = 0.0;
    for &(value, area) in pairs.iter() {
        below += area;
        if below >= q * total {
            return Some(value);
        }
    }
    pairs.last().map(|p| p.0)
}

/// How lux values are placed on the false-colour scale.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LuxScale {
    /// Proportional to `ln E`.
    #[default]
    Log,
    /// Proportional to `E`.
    Linear,
}

/// Lowest lux value of a fitted logarithmic range, relative to its top.
pub const LOG_RANGE_FLOOR: f64 = 1e-3;

/// The false-colour shader (viridis) over a lux range.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FalseColor {
    min_lx: f64,
    max_lx: f64,
    scale: LuxScale,
    /// Where the scale starts in its own unit (`min_lx`, or `ln min_lx` for a log scale) and the
    /// inverse of its span: a pixel's position costs one logarithm, not two and a division.
    start: f64,
    inv_span: f64,
}

impl FalseColor {
    /// A scale from `min_lx` (bottom colour) to `max_lx` (top colour).
    ///
    /// Errors (bad input): a range that is not increasing and finite, or a log range that does
    /// not start above 0.
    pub fn new(min_lx: f64, max_lx: f64, scale: LuxScale) -> Result<FalseColor> {
        let ok = min_lx.is_finite() && max_lx.is_finite() && min_lx < max_lx;
        if !ok || (scale == LuxScale::Log && min_lx <= 0.0) {
            return Err(Error::input(
                "",
                "false-colour range",
                format!("[{min_lx}, {max_lx}] lx is not an increasing {scale:?} range"),
            ));
        }
        Ok(FalseColor::with_range(min_lx, max_lx, scale))
    }

    /// The scale over `[min_lx, max_lx]` (already checked), with its start and inverse span.
    fn with_range(min_lx: f64, max_lx: f64, scale: LuxScale) -> FalseColor {
        let (start, end) = match scale {
            LuxScale::Linear => (min_lx, max_lx),
            LuxScale::Log => (min_lx.ln(), max_lx.ln()),
        };
        FalseColor {
            min_lx,
            max_lx,
            scale,
            start,
            inv_span: 1.0 / (end - start),
        }
    }

    /// The range fitted to per-vertex illuminance `illuminance_lx` (luma, lx): from the lowest
    /// to the highest value; a log range starts no lower than [`LOG_RANGE_FLOOR`] × the top.
    /// A flat or dark scene gets `[0, max(top, 1)]` (linear) or `[top/10, top]` (log).
    pub fn fit(illuminance_lx: &[[f32; 3]], scale: LuxScale) -> FalseColor {
        let (lo, hi) = illuminance_lx
            .iter()
            .map(|e| luma(e.map(f64::from)))
            .filter(|y| y.is_finite())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), y| {
                (lo.min(y), hi.max(y))
            });
        let (min_lx, max_lx) = match scale {
            LuxScale::Linear if lo < hi => (lo, hi),
            LuxScale::Linear => (0.0, hi.max(1.0)),
            LuxScale::Log => {
                let top = if hi > 0.0 { hi } else { 1.0 };
                let bottom = lo.max(top * LOG_RANGE_FLOOR);
                if bottom < top {
                    (bottom, top)
                } else {
                    (top / 10.0, top)
                }
            }
        };
        FalseColor::with_range(min_lx, max_lx, scale)
    }

    /// The lux range `(min, max)` that the scale's two ends stand for.
    pub fn range(&self) -> (f64, f64) {
        (self.min_lx, self.max_lx)
    }

    /// The scale.
    pub fn scale(&self) -> LuxScale {
        self.scale
    }

    /// Position of `illuminance_lx` on the scale, clamped to [0, 1].
    pub fn position(&self, illuminance_lx: f64) -> f64 {
        let t = match self.scale {
            LuxScale::Linear => (illuminance_lx - self.start) * self.inv_span,
            LuxScale::Log => (illuminance_lx.max(self.min_lx).ln() - self.start) * self.inv_span,
        };
        if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) }
    }
}

impl Shader for FalseColor {
    fn shade(&self, illuminance_lx: [f32; 3]) -> [u8; 3] {
        viridis(self.position(luma(illuminance_lx.map(f64::from))))
    }
}

/// Relative width of a [`FalseColorTable`] entry: 2⁻¹⁰ of the value (the f32 bit pattern with
/// its 13 lowest mantissa bits dropped).
const TABLE_SHIFT: u32 = 13;

/// Values below this fraction of the scale's top are shaded exactly instead of from the table
/// (a linear scale from 0 would otherwise need entries down to the smallest f32).
const TABLE_FLOOR: f64 = 1e-6;

/// Widest entry a [`FalseColorTable`] may have, as a fraction of its scale: well under one of the
/// 255 colour levels, so that an entry's middle colour is within one level of every value's.
const TABLE_MAX_ENTRY: f64 = 1.1e-3;

/// A [`FalseColor`] tabulated for one frame's pixels: positive f32 values order like their bit
/// patterns, so the pattern with its low mantissa bits dropped indexes entries 2⁻¹⁰ of the value
/// wide, each holding the colour at its middle — one table load per pixel instead of a
/// logarithm and the viridis blend. The table is built only when an entry spans at most
/// [`TABLE_MAX_ENTRY`] of the scale, so that a pixel's colour is within one level of
/// [`FalseColor::shade`]'s; a narrower range (a fitted scale over a nearly uniform room) gets an
/// empty table and every pixel is shaded exactly, as are values outside the table's span.
#[derive(Debug, Clone)]
pub struct FalseColorTable {
    scale: FalseColor,
    /// Bit pattern of the table's first value, and the first value and the end (lx).
    start_bits: u32,
    start: f32,
    end: f32,
    colors: Vec<[u8; 3]>,
}

impl FalseColorTable {
    /// The table of `scale` over its range (from no lower than [`TABLE_FLOOR`] of its top).
    pub fn new(scale: &FalseColor) -> FalseColorTable {
        let (min_lx, max_lx) = scale.range();
        let start = (min_lx.max(max_lx * TABLE_FLOOR) as f32).max(f32::MIN_POSITIVE);
        let end = max_lx as f32;
        let start_bits = start.to_bits() >> TABLE_SHIFT << TABLE_SHIFT;
        // An entry is 2⁻¹⁰ of its value wide: on a log scale that is the same share of the scale
        // everywhere, on a linear one it is widest at the top.
        let relative = f64::from(2f32.powi(-10));
        let widest = match scale.scale {
            LuxScale::Log => relative * scale.inv_span,
            LuxScale::Linear => relative * max_lx * scale.inv_span,
        };
        let n = if end > start && widest <= TABLE_MAX_ENTRY {
            ((end.to_bits() - start_bits) >> TABLE_SHIFT) as usize + 1
        } else {
            0
        };
        let colors = (0..n)
            .map(|k| {
                let lo = f32::from_bits(start_bits + ((k as u32) << TABLE_SHIFT));
                let hi = f32::from_bits(start_bits + ((k as u32 + 1) << TABLE_SHIFT));
                viridis(scale.position(0.5 * (f64::from(lo) + f64::from(hi))))
            })
            .collect();
        FalseColorTable {
            scale: *scale,
            start_bits,
            start,
            end,
            colors,
        }
    }

    /// Number of entries (1 024 per doubling of the value over the tabulated span).
    pub fn entries(&self) -> usize {
        self.colors.len()
    }

    /// The colour of illuminance `illuminance_lx` (lx, linear RGB; its luma is placed).
    #[inline]
    pub fn shade(&self, illuminance_lx: [f32; 3]) -> [u8; 3] {
        let [r, g, b] = illuminance_lx;
        let y = 0.2126 * r + 0.7152 * g + 0.0722 * b;
        let entry = (y >= self.start && y < self.end)
            .then(|| {
                self.colors
                    .get(((y.to_bits() - self.start_bits) >> TABLE_SHIFT) as usize)
            })
            .flatten();
        match entry {
            Some(color) => *color,
            None => self.scale.shade(illuminance_lx),
        }
    }
}

/// Either display shader, chosen at run time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DisplayShader {
    /// Photo mode.
    Photo(Photo),
    /// False-colour mode.
    FalseColor(FalseColor),
}

impl DisplayShader {
    /// The shader for `mode` fitted to the scene: auto-exposure for photo, the log lux range
    /// of the vertices for false colour. `attrs` come from [`vertex_attributes`] for `mode`.
    pub fn fit(mode: DisplayMode, mesh: &PatchMesh, attrs: &[[f32; 3]]) -> DisplayShader {
        match mode {
            DisplayMode::Photo => DisplayShader::Photo(Photo::auto(mesh, attrs)),
            DisplayMode::FalseColor => DisplayShader::FalseColor(FalseColor::fit(attrs, LuxScale::Log)),
        }
    }
}

impl Shader for DisplayShader {
    #[inline]
    fn shade(&self, value: [f32; 3]) -> [u8; 3] {
        match self {
            DisplayShader::Photo(s) => s.shade(value),
            DisplayShader::FalseColor(s) => s.shade(value),
        }
    }
}

/// Viridis (matplotlib's perceptually uniform scale) at 9 evenly spaced stops, sRGB8.
pub const VIRIDIS: [[u8; 3]; 9] = [
    [0x44, 0x01, 0x54],
    [0x47, 0x2D, 0x7B],
    [0x3B, 0x52, 0x8B],
    [0x2C, 0x72, 0x8E],
    [0x21, 0x90, 0x8C],
    [0x27, 0xAD, 0x81],
    [0x5D, 0xC8, 0x63],
    [0xAA, 0xDC, 0x32],
    [0xFD, 0xE7, 0x25],
];

/// The viridis colour at `t ∈ [0, 1]` (linear between stops).
pub fn viridis(t: f64) -> [u8; 3] {
    // s ≥ 0 (NaN clamps to NaN, which `as` turns into 0): truncation is the floor, and adding ½
    // before truncating rounds to nearest — no calls into libm per pixel.
    let s = t.clamp(0.0, 1.0) * (VIRIDIS.len() - 1) as f64;
    let i = (s as usize).min(VIRIDIS.len() - 2);
    let f = s - i as f64;
    [0, 1, 2].map(|c| {
        let (a, b) = (f64::from(VIRIDIS[i][c]), f64::from(VIRIDIS[i + 1][c]));
        (a + (b - a) * f + 0.5) as u8
    })
}

/// The sRGB transfer function (IEC 61966-2-1) of a linear display value in [0, 1].
pub fn srgb_encode(linear: f64) -> f64 {
    if linear <= 0.003_130_8 {
        12.92 * linear
    } else {
        1.055 * linear.powf(1.0 / 2.4) - 0.055
    }
}
