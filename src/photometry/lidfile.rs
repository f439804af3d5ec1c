//! Photometric files (IES LM-63, EULUMDAT) reduced to an axially symmetric curve.
//!
//! Each format's reader ([`crate::photometry::ies`], [`crate::photometry::ldt`]) turns a file into
//! [`StoredPlanes`]: the γ grid, the C-planes the file stores (absolute candela) and the symmetry
//! that generates the others. This module expands them to the full 0–360° C range and averages
//! each γ over C with weights proportional to the angular width each plane represents (the
//! periodic trapezoid rule in C), so unequal C spacing averages correctly.
//!
//! Angles are in degrees: γ from the luminaire's nadir (0° = straight down the aim axis,
//! 180° = straight up), C around the axis from the C0 plane.

use std::path::Path;

use crate::error::{Error, Result, quoted};
use crate::fsio::{self, FileKind};
use crate::photometry::{Curve, LuminousShape, MAX_INTENSITY_CD, ies, ldt};

/// The most angles (γ or C) a file may list. A 0.02° γ grid over 0–180° has 9 001 angles; a
/// count above this is a broken or hostile file, and is refused before anything is read.
pub(crate) const MAX_ANGLES: usize = 10_000;

/// Above this [`LidFile::asymmetry`] the editor warns that the axial average misrepresents the
/// luminaire: some C-plane differs from the average by more than 10 % of the average's peak
/// (docs/DECISIONS.md, "Photometric files").
pub const ASYMMETRY_WARNING: f64 = 0.1;

/// Which format a file was in.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LidFormat {
    /// IES LM-63, with the version line as found (`IESNA:LM-63-2002`, or `LM-63-1986` if none).
    Ies { version: String },
    /// EULUMDAT.
    Eulumdat,
}

/// A photometric file as Haiko uses it: the C-plane average as an axially symmetric curve.
#[derive(Debug, Clone, PartialEq)]
pub struct LidFile {
    /// Absolute intensities (cd), averaged over C-planes, on the file's γ grid.
    pub curve: Curve,
    /// How far the source is from axial symmetry: the maximum over C-planes and γ of
    /// `|I_C(γ) − I_avg(γ)| / max I_avg` (0 for an axially symmetric file).
    pub asymmetry: f64,
    /// Number of distinct C-planes in the file after symmetry expansion (1 if axially symmetric).
    pub n_planes: usize,
    /// The format.
    pub format: LidFormat,
    /// The luminaire's name or catalogue number from the file (may be empty).
    pub luminaire: String,
    /// How the C-planes spread around the average, per point of [`Self::curve`].
    pub spread: CSpread,
    /// The luminous area the file describes (IES width/length/height, EULUMDAT fields 16–21);
    /// `None` when the file gives none (a point source) or a shape Haiko does not know.
    pub luminous: Option<LuminousShape>,
}

/// The lowest and highest intensity over all C-planes at each γ of a file's curve (cd), for
/// drawing the spread of an asymmetric file around its axial average.
#[derive(Debug, Clone, PartialEq)]
pub struct CSpread {
    /// Minimum over C-planes, one per curve point, cd.
    pub min_cd: Vec<f64>,
    /// Maximum over C-planes, one per curve point, cd.
    pub max_cd: Vec<f64>,
}

impl LidFile {
    /// True when the file is asymmetric enough for the editor to warn ([`ASYMMETRY_WARNING`]).
    pub fn warns_asymmetry(&self) -> bool {
        self.asymmetry > ASYMMETRY_WARNING
    }
}

/// Reads an IES (`.ies`) or EULUMDAT (`.ldt`) file; the extension decides, case-insensitively.
///
/// The file is read through [`crate::fsio`] (a regular file of at most 16 MiB), then parsed by
/// [`parse_lid_bytes`]. Bad content is an input error naming the file and the line or field.
pub fn read_lid_file(path: &Path) -> Result<LidFile> {
    let kind = match lid_kind(path)? {
        LidKind::Ies => FileKind::Ies,
        LidKind::Ldt => FileKind::Ldt,
    };
    let bytes = fsio::read(path, kind)?;
    parse_lid_bytes(path, &bytes)
}

/// The two photometric formats, by file extension.
enum LidKind {
    Ies,
    Ldt,
}

/// The format `path`'s extension names (case-insensitive); anything else is an input error.
fn lid_kind(path: &Path) -> Result<LidKind> {
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    match extension.as_str() {
        "ies" => Ok(LidKind::Ies),
        "ldt" => Ok(LidKind::Ldt),
        _ => Err(Error::input(
            path,
            "file extension",
            format!(
                "unknown photometric file type {} (expected .ies for IES LM-63 or .ldt for EULUMDAT)",
                quoted(&format!(".{extension}"))
            ),
        )),
    }
}

/// Parses the bytes of a photometric file; `path`'s extension chooses the format and names the
/// file in errors (nothing is read from it).
///
/// IES text is read as UTF-8, falling back to Latin-1; EULUMDAT text as Latin-1 (every byte is a
/// character, so text fields never fail to decode). A leading byte-order mark is skipped.
pub fn parse_lid_bytes(path: &Path, bytes: &[u8]) -> Result<LidFile> {
    let kind = lid_kind(path)?;
    let text = match kind {
        LidKind::Ies => std::str::from_utf8(bytes).map_or_else(|_| latin1(bytes), str::to_string),
        LidKind::Ldt => latin1(bytes),
    };
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    match kind {
        LidKind::Ies => ies::parse_ies(path, text),
        LidKind::Ldt => ldt::parse_ldt(path, text),
    }
}

/// Decodes bytes as Latin-1: byte `b` is the character `U+00b`.
fn latin1(bytes: &[u8]) -> String {
    bytes.iter().map(|&b| char::from(b)).collect()
}

/// The factor from a file's intensity values to candela (multipliers, lamp flux): it must be a
/// finite number > 0; `what` names its parts for the error message.
pub(crate) fn check_scale(path: &Path, place: &str, scale: f64, what: &str) -> Result<f64> {
    if scale.is_finite() && scale > 0.0 {
        return Ok(scale);
    }
    Err(Error::input(
        path,
        place,
        format!("the product of {what} is {scale}, not a finite number > 0"),
    ))
}

/// An error message unless the file's intensity `value` times `scale` is a candela value Haiko
/// accepts: from 0 to [`MAX_INTENSITY_CD`].
pub(crate) fn check_scaled_intensity(value: f64, scale: f64) -> Option<String> {
    let cd = value * scale;
    if value < 0.0 {
        Some("an intensity cannot be negative".into())
    } else if cd > MAX_INTENSITY_CD {
        Some(format!(
            "{cd:e} cd after scaling by {scale}, above the limit of {MAX_INTENSITY_CD:e} cd"
        ))
    } else {
        None
    }
}

/// How the C-planes a file stores generate the full 0–360° range.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum CSymmetry {
    /// The stored planes are all there is (one stored plane = axially symmetric).
    None,
    /// Mirror symmetric about the C0–C180 plane: `I(360° − C) = I(C)`.
    AboutC0C180,
    /// Mirror symmetric about the C90–C270 plane: `I(180° − C) = I(C)`.
    AboutC90C270,
    /// Symmetric about both: the C0–C90 quadrant generates the rest.
    Quadrant,
}

impl CSymmetry {
    /// The angles (degrees, not yet reduced to 0–360°) that a plane stored at `c_deg` stands for.
    fn images(self, c_deg: f64) -> Vec<f64> {
        match self {
            CSymmetry::None => vec![c_deg],
            CSymmetry::AboutC0C180 => vec![c_deg, 360.0 - c_deg],
            CSymmetry::AboutC90C270 => vec![c_deg, 180.0 - c_deg],
            CSymmetry::Quadrant => vec![c_deg, 180.0 - c_deg, 180.0 + c_deg, 360.0 - c_deg],
        }
    }
}

/// What a reader extracted from a file: absolute intensities on a C × γ grid.
#[derive(Debug, Clone)]
pub(crate) struct StoredPlanes {
    /// The γ grid in degrees (validated with [`check_gamma_grid`]).
    pub gamma_deg: Vec<f64>,
    /// The stored planes: C angle in degrees and the candela for each γ of the grid.
    pub planes: Vec<(f64, Vec<f64>)>,
    /// How the stored planes generate the rest of the circle.
    pub symmetry: CSymmetry,
    /// The luminous area the file describes, if any.
    pub luminous: Option<LuminousShape>,
}

/// Two angles closer than this (degrees) are the same C-plane.
const SAME_ANGLE_DEG: f64 = 1e-9;

impl StoredPlanes {
    /// Expands to the full 0–360° range, averages over C and builds the [`LidFile`].
    pub(crate) fn into_lid_file(self, path: &Path, format: LidFormat, luminaire: String) -> Result<LidFile> {
        let full = self.expand();
        let weights = c_weights(&full.iter().map(|p| p.0).collect::<Vec<_>>());
        let mut average_cd = vec![0.0; self.gamma_deg.len()];
        for (&(_, values), weight) in full.iter().zip(&weights) {
            for (avg, &value) in average_cd.iter_mut().zip(values) {
                *avg += weight * value;
            }
        }
        let peak_cd = average_cd.iter().copied().fold(0.0, f64::max);
        let mut largest_deviation_cd: f64 = 0.0;
        let mut spread = CSpread {
            min_cd: vec![f64::INFINITY; self.gamma_deg.len()],
            max_cd: vec![0.0; self.gamma_deg.len()],
        };
        for &(_, values) in &full {
            for (k, (&avg, &value)) in average_cd.iter().zip(values).enumerate() {
                largest_deviation_cd = largest_deviation_cd.max((value - avg).abs());
                spread.min_cd[k] = spread.min_cd[k].min(value);
                spread.max_cd[k] = spread.max_cd[k].max(value);
            }
        }
        // All intensities are ≥ 0 and the weights > 0, so a zero peak means an all-zero file.
        let asymmetry = if peak_cd > 0.0 {
            largest_deviation_cd / peak_cd
        } else {
            0.0
        };
        let points: Vec<(f64, f64)> = self.gamma_deg.iter().copied().zip(average_cd).collect();
        let curve = Curve::new(&points).map_err(|e| Error::input(path, "vertical angles", e.to_string()))?;
        Ok(LidFile {
            curve,
            asymmetry,
            n_planes: full.len(),
            format,
            luminaire,
            spread,
            luminous: self.luminous,
        })
    }

    /// The distinct planes over 0 ≤ C < 360°, sorted by C (a 360° plane is the 0° plane).
    fn expand(&self) -> Vec<(f64, &[f64])> {
        let mut full: Vec<(f64, &[f64])> = Vec::new();
        for (c_deg, values) in &self.planes {
            for image in self.symmetry.images(*c_deg) {
                let reduced = image.rem_euclid(360.0);
                let c = if 360.0 - reduced < SAME_ANGLE_DEG {
                    0.0
                } else {
                    reduced
                };
                full.push((c, values));
            }
        }
        // Stable sort: of two images at one angle the first stored plane wins.
        full.sort_by(|a, b| a.0.total_cmp(&b.0));
        full.dedup_by(|later, earlier| later.0 - earlier.0 < SAME_ANGLE_DEG);
        full
    }
}

/// The fraction of the full circle each plane stands for: half the gap to each neighbour,
/// periodically (the trapezoid rule in C). `c_deg` is sorted within 0 ≤ C < 360°.
fn c_weights(c_deg: &[f64]) -> Vec<f64> {
    let n = c_deg.len();
    if n == 1 {
        return vec![1.0];
    }
    (0..n)
        .map(|i| {
            let next = if i + 1 < n { c_deg[i + 1] } else { c_deg[0] + 360.0 };
            let previous = if i > 0 { c_deg[i - 1] } else { c_deg[n - 1] - 360.0 };
            (next - previous) / 2.0 / 360.0
        })
        .collect()
}

/// Checks a γ grid (degrees): every angle within 0–180°, none below the one before, at most two
/// at one angle (a step), and at least two different angles. `place(k)` names angle `k`.
///
/// The LM-63 ranges are 0–90°, 0–180° and 90–180°; any grid inside 0–180° is accepted (the curve
/// is 0 outside it) so that every valid [`Curve`] can be written and read back.
pub(crate) fn check_gamma_grid(
    path: &Path,
    gamma_deg: &[f64],
    place: impl Fn(usize) -> String,
) -> Result<()> {
    for (k, &g) in gamma_deg.iter().enumerate() {
        if !(0.0..=180.0).contains(&g) {
            return Err(Error::input(
                path,
                place(k),
                format!("γ = {g}° is outside 0–180° (Haiko reads Type C files, γ measured from nadir)"),
            ));
        }
        if k > 0 && g < gamma_deg[k - 1] {
            return Err(Error::input(
                path,
                place(k),
                format!(
                    "γ = {g}° is below the previous angle {}° (angles must increase)",
                    gamma_deg[k - 1]
                ),
            ));
        }
        if k > 1 && g == gamma_deg[k - 1] && g == gamma_deg[k - 2] {
            return Err(Error::input(
                path,
                place(k),
                format!("a third angle at γ = {g}° (at most two equal angles, for a step)"),
            ));
        }
    }
    match (gamma_deg.first(), gamma_deg.last()) {
        (Some(first), Some(last)) if first < last => Ok(()),
        _ => Err(Error::input(
            path,
            place(0),
            "the γ angles need at least two different values",
        )),
    }
}

/// Checks listed C angles (degrees): starting at 0°, strictly increasing, at most 360°.
/// `place(k)` names angle `k`.
pub(crate) fn check_c_angles(path: &Path, c_deg: &[f64], place: impl Fn(usize) -> String) -> Result<()> {
    for (k, &c) in c_deg.iter().enumerate() {
        if k == 0 && c != 0.0 {
            return Err(Error::input(
                path,
                place(k),
                format!("the C-plane angles must start at 0°, not {c}°"),
            ));
        }
        if !(0.0..=360.0).contains(&c) {
            return Err(Error::input(
                path,
                place(k),
                format!("C = {c}° is outside 0–360°"),
            ));
        }
        if k > 0 && c <= c_deg[k - 1] {
            return Err(Error::input(
                path,
                place(k),
                format!(
                    "C = {c}° does not increase from the previous angle {}°",
                    c_deg[k - 1]
                ),
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn planes(symmetry: CSymmetry, planes: Vec<(f64, Vec<f64>)>) -> StoredPlanes {
        StoredPlanes {
            gamma_deg: vec![0.0, 90.0],
            planes,
            symmetry,
            luminous: None,
        }
    }

    #[test]
    fn weights_are_half_gaps_and_sum_to_one() {
        // Planes 0, 45, 90, 180, 270: widths 67.5, 45, 67.5, 90, 90 degrees.
        let w = c_weights(&[0.0, 45.0, 90.0, 180.0, 270.0]);
        let expected = [67.5, 45.0, 67.5, 90.0, 90.0].map(|x| x / 360.0);
        for (a, b) in w.iter().zip(expected) {
            assert!((a - b).abs() < 1e-15, "{w:?}");
        }
    }

    #[test]
    fn quadrant_expands_to_the_full_circle() {
        let stored = planes(
            CSymmetry::Quadrant,
            [0.0, 30.0, 60.0, 90.0]
                .iter()
                .map(|&c| (c, vec![c, 1.0]))
                .collect(),
        );
        let full = stored.expand();
        let angles: Vec<f64> = full.iter().map(|p| p.0).collect();
        assert_eq!(angles, (0..12).map(|k| 30.0 * k as f64).collect::<Vec<_>>());
        // C = 210° mirrors C = 30° (210 = 180 + 30); C = 300° mirrors C = 60° (300 = 360 − 60).
        assert_eq!(full[7].1[0], 30.0);
        assert_eq!(full[10].1[0], 60.0);
    }

    #[test]
    fn c90_c270_symmetry_mirrors_across_the_c90_axis() {
        let stored = planes(
            CSymmetry::AboutC90C270,
            [90.0, 180.0, 270.0].iter().map(|&c| (c, vec![c, 1.0])).collect(),
        );
        let full = stored.expand();
        let angles: Vec<f64> = full.iter().map(|p| p.0).collect();
        assert_eq!(angles, vec![0.0, 90.0, 180.0, 270.0]);
        // C = 0° is the mirror image of C = 180°.
        assert_eq!(full[0].1[0], 180.0);
    }
}
