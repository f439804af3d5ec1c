//! EULUMDAT (`.ldt`) photometric files: one value per line in a fixed order (docs/FORMATS.md).
//!
//! Fields 1–26 are lines 1–26: company, Ityp, Isym, Mc, Dc, Ng, Dg, report, luminaire name and
//! number, file name, date, dimensions (mm), DFF, LORL, the conversion factor for intensities,
//! the tilt, and the number of lamp sets; then six lines per lamp set (number of lamps, type,
//! total flux in lm, colour, CRI group, watts), ten direct ratios, the Mc C-angles and the Ng
//! γ-angles (degrees), and the intensities in cd/klm for the planes the symmetry Isym stores:
//! 0 → all Mc, 1 → one, 2 → C0…C180 (Mc/2+1), 3 → C90…C270 (Mc/2+1), 4 → C0…C90 (Mc/4+1).
//!
//! Absolute candela = value × conversion factor × Σ(lamp-set flux) / 1000. A negative number of
//! lamps in any set marks absolute photometry: the values are then already candela (× the
//! conversion factor) and the lamp flux is not used. Decimal commas are accepted; Dc and Dg are
//! not used because the listed angles are the truth when the file contradicts itself.

use std::path::Path;

use crate::error::{Error, Result, quoted};
use crate::photometry::LuminousShape;
use crate::photometry::lidfile::{
    CSymmetry, LidFile, LidFormat, MAX_ANGLES, StoredPlanes, check_c_angles, check_gamma_grid, check_scale,
    check_scaled_intensity,
};
use crate::photometry::luminous::MAX_LUMINOUS_SIZE_M;

/// The most lamp sets a file may declare; more is a broken count.
const MAX_LAMP_SETS: usize = 1_000;

/// Two angles closer than this (degrees) count as equal when picking the stored planes.
const ANGLE_TOLERANCE_DEG: f64 = 1e-6;

/// The line number (1-based) of field 4, Mc, in the fixed layout.
const MC_LINE: usize = 4;

/// Parses the text of a EULUMDAT file; `path` is only used in error messages.
///
/// EULUMDAT has no signature: the file counts as recognised once fields 3, 4 and 6 (Isym, Mc,
/// Ng) are whole numbers in their ranges. Before that an error says which field is wrong without
/// quoting the line; after it, at most the offending value ([`crate::error::quoted`]).
pub fn parse_ldt(path: &Path, text: &str) -> Result<LidFile> {
    if text.trim().is_empty() {
        return Err(Error::input(path, "line 1", "the file is empty"));
    }
    let mut fields = Fields {
        path,
        lines: text.lines().collect(),
        next: 0,
        recognised: false,
    };
    fields.text("field 1 (company)")?;
    fields.text("field 2 (Ityp)")?;
    let isym = fields.whole("field 3 (Isym)", 0, 4)?;
    let mc = fields.whole("field 4 (Mc)", 1, MAX_ANGLES)?;
    fields.text("field 5 (Dc)")?;
    let ng = fields.whole("field 6 (Ng)", 2, MAX_ANGLES)?;
    fields.recognised = true;
    fields.text("field 7 (Dg)")?;
    fields.text("field 8 (report number)")?;
    let name = fields.text("field 9 (luminaire name)")?.trim();
    let number = fields.text("field 10 (luminaire number)")?.trim();
    let luminaire = if name.is_empty() { number } else { name }.to_string();
    for field in 11..=15 {
        fields.text(&format!("field {field}"))?;
    }
    let mut millimetres = |label: &str| {
        fields.number(label, |v| {
            if v < 0.0 {
                Some("a dimension cannot be negative".into())
            } else {
                (v > MAX_LUMINOUS_SIZE_M * 1e3)
                    .then(|| format!("a luminous dimension above {MAX_LUMINOUS_SIZE_M} m"))
            }
        })
    };
    let luminous_length = millimetres("field 16 (length or diameter of the luminous area, mm)")?;
    let luminous_width = millimetres("field 17 (width of the luminous area, mm)")?;
    let mut heights = [0.0; 4];
    for (k, (height, c)) in heights.iter_mut().zip([0, 90, 180, 270]).enumerate() {
        *height = millimetres(&format!("field {} (luminous height at C{c}, mm)", 18 + k))?;
    }
    let luminous = LuminousShape::from_eulumdat(luminous_length, luminous_width, heights);
    for field in 22..=23 {
        fields.text(&format!("field {field}"))?;
    }
    let conversion = fields.number("field 24 (conversion factor for intensities)", |v| {
        (v <= 0.0).then(|| "must be greater than 0".into())
    })?;
    fields.text("field 25 (tilt during measurement)")?;
    let lamps = read_lamp_sets(&mut fields)?;
    let scale = check_scale(
        path,
        "field 24 (conversion factor for intensities)",
        conversion * lamps.klm_factor(path)?,
        "the conversion factor and the lamp flux",
    )?;
    for k in 1..=10 {
        fields.text(&format!("direct ratio {k}"))?;
    }
    let c_first_line = fields.next + 1;
    let c_deg = fields.list(mc, |k| format!("C-angle {k}"))?;
    check_c_angles(path, &c_deg, |k| {
        format!("line {}, C-angle {}", c_first_line + k, k + 1)
    })?;
    let gamma_first_line = fields.next + 1;
    let gamma_deg = fields.list(ng, |k| format!("γ-angle {k}"))?;
    check_gamma_grid(path, &gamma_deg, |k| {
        format!("line {}, γ-angle {}", gamma_first_line + k, k + 1)
    })?;

    let (stored_c_deg, symmetry) = stored_planes(path, isym, mc, &c_deg)?;
    let mut planes = Vec::with_capacity(stored_c_deg.len());
    for c in stored_c_deg {
        let mut values = Vec::with_capacity(ng);
        for &g in &gamma_deg {
            let value = fields.number(&format!("intensity for C={c}°, γ={g}°"), |v| {
                check_scaled_intensity(v, scale)
            })?;
            values.push(value * scale);
        }
        planes.push((c, values));
    }
    fields.expect_end()?;
    let stored = StoredPlanes {
        gamma_deg,
        planes,
        symmetry,
        luminous,
    };
    stored.into_lid_file(path, LidFormat::Eulumdat, luminaire)
}

/// The lamp sets: whether any marks absolute photometry, and each set's flux (lm) with the
/// line it is on (`None` when the line is blank).
struct LampSets {
    absolute: bool,
    flux: Vec<(Option<f64>, usize)>,
}

fn read_lamp_sets(fields: &mut Fields) -> Result<LampSets> {
    let n_sets = fields.whole("field 26 (number of lamp sets)", 0, MAX_LAMP_SETS)?;
    let mut sets = LampSets {
        absolute: false,
        flux: Vec::with_capacity(n_sets),
    };
    for set in 1..=n_sets {
        let n_lamps = fields.number(&format!("field 26a (number of lamps in set {set})"), |_| None)?;
        sets.absolute |= n_lamps < 0.0;
        fields.text(&format!("field 26b (lamp type of set {set})"))?;
        let label = format!("field 26c (total flux of lamp set {set})");
        let flux_line = fields.next + 1;
        let flux = if fields.peek_blank() {
            fields.text(&label)?;
            None
        } else {
            Some(fields.number(&label, |v| {
                (v < 0.0).then(|| "a lamp flux cannot be negative".into())
            })?)
        };
        sets.flux.push((flux, flux_line));
        fields.text(&format!("field 26d (colour of lamp set {set})"))?;
        fields.text(&format!("field 26e (colour rendering of lamp set {set})"))?;
        fields.text(&format!("field 26f (watts of lamp set {set})"))?;
    }
    Ok(sets)
}

impl LampSets {
    /// The factor from the file's values to candela before the conversion factor: 1 for
    /// absolute photometry, else Σ flux / 1000 (values in cd/klm).
    fn klm_factor(&self, path: &Path) -> Result<f64> {
        if self.absolute {
            return Ok(1.0);
        }
        let missing = |line: usize, message: &str| {
            Error::input(
                path,
                format!("line {line}, field 26c"),
                format!("{message}: relative intensities (cd/klm) need the lamp flux in lm"),
            )
        };
        let mut total_lm = 0.0;
        for &(flux, line) in &self.flux {
            total_lm += flux.ok_or_else(|| missing(line, "the lamp flux is missing"))?;
        }
        if total_lm <= 0.0 {
            let line = self.flux.first().map_or(26, |f| f.1);
            return Err(missing(line, "the total lamp flux is 0"));
        }
        Ok(total_lm / 1000.0)
    }
}

/// The C angles of the planes Isym says the file stores, and the symmetry that generates the
/// others. The listed angles are trusted over Dc; they must contain exactly the stored range.
fn stored_planes(path: &Path, isym: usize, mc: usize, c_deg: &[f64]) -> Result<(Vec<f64>, CSymmetry)> {
    let (low, high, expected, symmetry) = match isym {
        0 => return Ok((c_deg.to_vec(), CSymmetry::None)),
        1 => return Ok((vec![0.0], CSymmetry::None)),
        2 => (0.0, 180.0, mc / 2 + 1, CSymmetry::AboutC0C180),
        3 => (90.0, 270.0, mc / 2 + 1, CSymmetry::AboutC90C270),
        _ => (0.0, 90.0, mc / 4 + 1, CSymmetry::Quadrant),
    };
    let inside: Vec<f64> = c_deg
        .iter()
        .copied()
        .filter(|&c| c > low - ANGLE_TOLERANCE_DEG && c < high + ANGLE_TOLERANCE_DEG)
        .collect();
    let near = |a: Option<&f64>, b: f64| a.is_some_and(|a| (a - b).abs() < ANGLE_TOLERANCE_DEG);
    if inside.len() != expected || !near(inside.first(), low) || !near(inside.last(), high) {
        return Err(Error::input(
            path,
            format!("line {MC_LINE}, field 4 (Mc)"),
            format!(
                "Isym {isym} stores {expected} C-planes from C{low}° to C{high}° (Mc = {mc}), but the \
                 listed C-angles have {} in that range{}",
                inside.len(),
                if inside.is_empty() { "" } else { " or miss an end" }
            ),
        ));
    }
    Ok((inside, symmetry))
}

/// The file's lines, read in order with a label for error messages.
struct Fields<'a> {
    path: &'a Path,
    lines: Vec<&'a str>,
    /// Index (0-based) of the next line.
    next: usize,
    /// Whether the file has shown itself to be EULUMDAT (its counts parsed), so that a bad value
    /// may be quoted in an error.
    recognised: bool,
}

impl<'a> Fields<'a> {
    /// The next line as text; `label` names the field for errors.
    fn text(&mut self, label: &str) -> Result<&'a str> {
        let Some(&line) = self.lines.get(self.next) else {
            return Err(Error::input(
                self.path,
                format!("line {}", self.lines.len() + 1),
                format!("the file ends early: expected {label}"),
            ));
        };
        self.next += 1;
        Ok(line)
    }

    /// Whether the next line exists and is blank.
    fn peek_blank(&self) -> bool {
        self.lines.get(self.next).is_some_and(|l| l.trim().is_empty())
    }

    /// The next line as a finite number (a decimal comma is accepted) that passes `check`,
    /// which returns an error message for a bad value.
    fn number(&mut self, label: &str, check: impl Fn(f64) -> Option<String>) -> Result<f64> {
        let line = self.text(label)?;
        let place = format!("line {}, {label}", self.next);
        let cleaned = line.trim().replace(',', ".");
        let value = match cleaned.parse::<f64>() {
            Ok(v) if v.is_finite() => v,
            parsed => {
                let what = if parsed.is_ok() {
                    "a finite number"
                } else {
                    "a number"
                };
                let message = if self.recognised {
                    format!("{} is not {what}", quoted(line.trim()))
                } else {
                    format!("expected {what}: this is not a EULUMDAT file (or a damaged one)")
                };
                return Err(Error::input(self.path, place, message));
            }
        };
        match check(value) {
            None => Ok(value),
            Some(message) if self.recognised => {
                Err(Error::input(self.path, place, format!("{value}: {message}")))
            }
            Some(message) => Err(Error::input(
                self.path,
                place,
                format!("{message}: this is not a EULUMDAT file (or a damaged one)"),
            )),
        }
    }

    /// The next line as a whole number from `min` to `max`.
    fn whole(&mut self, label: &str, min: usize, max: usize) -> Result<usize> {
        let value = self.number(label, |v| {
            (v.fract() != 0.0 || v < min as f64 || v > max as f64)
                .then(|| format!("must be a whole number from {min} to {max}"))
        })?;
        Ok(value as usize)
    }

    /// The next `n` lines as numbers; `label(k)` names the k-th (1-based).
    fn list(&mut self, n: usize, label: impl Fn(usize) -> String) -> Result<Vec<f64>> {
        (1..=n).map(|k| self.number(&label(k), |_| None)).collect()
    }

    /// Fails if a non-blank line follows the intensities (the counts disagree with the data).
    fn expect_end(&self) -> Result<()> {
        match self.lines[self.next..].iter().position(|l| !l.trim().is_empty()) {
            None => Ok(()),
            Some(offset) => Err(Error::input(
                self.path,
                format!("line {}", self.next + offset + 1),
                "unexpected data after the intensities (do Mc, Ng and Isym match the data?)",
            )),
        }
    }
}
