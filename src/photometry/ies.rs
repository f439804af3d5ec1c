//! IES LM-63 photometric files (1986, 1991, 1995, 2002, 2019): reading and writing.
//!
//! Layout (docs/FORMATS.md): a version line (none in LM-63-1986), keyword or free-text lines, the
//! `TILT=` line, then numbers separated by white space (commas are tolerated) that may wrap
//! across lines, so they are read as one token stream:
//! the optional tilt table; `#lamps lumens/lamp multiplier #vertical #horizontal type units
//! width length height`; `ballast-factor file-generation-type input-watts`; the vertical angles
//! γ (degrees from nadir); the horizontal angles C (degrees); the candela values, all γ for each
//! C in turn.
//!
//! Intensities become absolute candela as `value × candela-multiplier × ballast-factor`, and
//! also × the ballast-lamp photometric factor in LM-63-1986 and -1991 files, where the field
//! after the ballast factor still was that multiplier. With lumens/lamp = −1 the file is absolute
//! photometry; with rated lumens/lamp the values are for the rated lamps, which is what Haiko
//! uses (it has no other lamp flux to scale to). From LM-63-1995 on that field is "future use",
//! and the LM-63-2019 file-generation-type (1.00001, 1.10000, …) is a code, not a factor
//! (docs/FORMATS.md): both are ignored.

use std::path::Path;

use crate::error::{Error, Result, quoted};
use crate::photometry::lidfile::{
    CSymmetry, LidFile, LidFormat, MAX_ANGLES, StoredPlanes, check_c_angles, check_gamma_grid, check_scale,
    check_scaled_intensity,
};
use crate::photometry::luminous::MAX_LUMINOUS_SIZE_M;
use crate::photometry::{Curve, LuminousShape};

/// One foot in metres (IES units type 1).
const FOOT_M: f64 = 0.3048;

/// The version reported for a file without a version line.
const VERSION_1986: &str = "LM-63-1986";

/// Two angles closer than this (degrees) count as equal when classifying the C range.
const ANGLE_TOLERANCE_DEG: f64 = 1e-6;

/// Parses the text of an IES LM-63 file; `path` is only used in error messages. Nothing of the
/// file is quoted in an error before its `TILT=` line has shown it to be an IES file, and after
/// that only the offending token ([`crate::error::quoted`]).
pub fn parse_ies(path: &Path, text: &str) -> Result<LidFile> {
    let lines: Vec<&str> = text.lines().collect();
    if text.trim().is_empty() {
        return Err(Error::input(path, "line 1", "the file is empty"));
    }
    let first = lines[0].trim();
    let upper = first.to_ascii_uppercase();
    let (version, header_start) = if upper.starts_with("IESNA") || upper.starts_with("IES:") {
        (first.to_string(), 1)
    } else {
        (VERSION_1986.to_string(), 0)
    };

    let mut header = Header::default();
    let mut tilt = None;
    for (index, line) in lines.iter().enumerate().skip(header_start) {
        if let Some(value) = tilt_value(line) {
            tilt = Some((index, value));
            break;
        }
        header.read_line(line);
    }
    let Some((tilt_index, tilt_value)) = tilt else {
        return Err(Error::input(
            path,
            format!("line {}", lines.len()),
            "no TILT= line: not an IES LM-63 file (the header must end with TILT=NONE or TILT=INCLUDE)",
        ));
    };
    let tilt_line = tilt_index + 1;
    let tilt_included = if tilt_value.eq_ignore_ascii_case("NONE") {
        false
    } else if tilt_value.eq_ignore_ascii_case("INCLUDE") {
        true
    } else {
        return Err(Error::input(
            path,
            format!("line {tilt_line}"),
            format!(
                "TILT file {} is not supported, use TILT=INCLUDE (copy the tilt table into the IES file)",
                quoted(tilt_value)
            ),
        ));
    };

    let mut numbers = Numbers::new(path, &lines[tilt_index + 1..], tilt_line + 1);
    if tilt_included {
        skip_tilt_table(&mut numbers)?;
    }
    let pre_1995 = version == VERSION_1986 || upper.starts_with("IESNA91");
    let planes = read_photometry(&mut numbers, pre_1995)?;
    numbers.expect_end()?;
    let format = LidFormat::Ies { version };
    planes.into_lid_file(path, format, header.luminaire())
}

/// The value of a `TILT=…` line (trimmed), or `None` for any other line.
fn tilt_value(line: &str) -> Option<&str> {
    let trimmed = line.trim_start();
    let keyword = trimmed.get(..4)?;
    if !keyword.eq_ignore_ascii_case("TILT") {
        return None;
    }
    trimmed[4..].trim_start().strip_prefix('=').map(str::trim)
}

/// The keyword lines Haiko keeps: the luminaire's name and catalogue number.
#[derive(Debug, Default)]
struct Header {
    luminaire: Option<String>,
    catalogue: Option<String>,
    first_text: Option<String>,
}

impl Header {
    fn read_line(&mut self, line: &str) {
        let line = line.trim();
        if let Some(rest) = line.strip_prefix('[') {
            if let Some((key, value)) = rest.split_once(']') {
                let slot = match key.trim().to_ascii_uppercase().as_str() {
                    "LUMINAIRE" => &mut self.luminaire,
                    "LUMCAT" => &mut self.catalogue,
                    _ => return,
                };
                slot.get_or_insert_with(|| value.trim().to_string());
            }
        } else if !line.is_empty() && self.first_text.is_none() {
            self.first_text = Some(line.to_string());
        }
    }

    /// `[LUMINAIRE]`, else `[LUMCAT]`, else the first free-text line (LM-63-1986 files).
    fn luminaire(self) -> String {
        self.luminaire
            .or(self.catalogue)
            .or(self.first_text)
            .unwrap_or_default()
    }
}

/// Reads the tilt table after `TILT=INCLUDE` and discards it: the lamp-to-luminaire geometry,
/// the count n, n angles and n multiplying factors. The factors describe how the lamp's output
/// changes when the luminaire is tilted; they do not change the axial intensity curve Haiko uses.
fn skip_tilt_table(numbers: &mut Numbers) -> Result<()> {
    numbers.number(&|| "TILT lamp-to-luminaire geometry".into(), |v| {
        (![1.0, 2.0, 3.0].contains(&v)).then(|| "the lamp-to-luminaire geometry must be 1, 2 or 3".into())
    })?;
    let n = numbers.count(&|| "number of TILT angles".into(), 1)?;
    for k in 1..=n {
        numbers.number(&|| format!("TILT angle {k}"), |_| None)?;
    }
    for k in 1..=n {
        numbers.number(&|| format!("TILT multiplying factor {k}"), |v| {
            (v < 0.0).then(|| "a tilt factor cannot be negative".into())
        })?;
    }
    Ok(())
}

/// Reads everything after the tilt data: the two header lines, the angles and the candela table.
/// `pre_1995` is true for LM-63-1986 and -1991 files.
fn read_photometry(numbers: &mut Numbers, pre_1995: bool) -> Result<StoredPlanes> {
    numbers.number(&|| "number of lamps".into(), |_| None)?;
    numbers.number(&|| "lumens per lamp".into(), |v| {
        (v != -1.0 && v <= 0.0)
            .then(|| "lumens per lamp must be positive, or −1 for absolute photometry".into())
    })?;
    let multiplier = numbers.number(&|| "candela multiplier".into(), positive)?;
    let n_vertical = numbers.count(&|| "number of vertical angles".into(), 2)?;
    let n_horizontal = numbers.count(&|| "number of horizontal angles".into(), 1)?;
    numbers.number(&|| "photometric type".into(), |v| match v {
        1.0 => None,
        2.0 => Some("Type B photometry is not supported (Haiko reads Type C files only)".into()),
        3.0 => Some("Type A photometry is not supported (Haiko reads Type C files only)".into()),
        _ => Some("the photometric type must be 1 (C), 2 (B) or 3 (A)".into()),
    })?;
    let units = numbers.number(&|| "units type".into(), |v| {
        (v != 1.0 && v != 2.0).then(|| "the units type must be 1 (feet) or 2 (metres)".into())
    })?;
    let to_m = if units == 1.0 { FOOT_M } else { 1.0 };
    let mut dimension = |what: &'static str| {
        numbers.number(&|| what.into(), |v| {
            (v.abs() * to_m > MAX_LUMINOUS_SIZE_M)
                .then(|| format!("a luminous dimension above {MAX_LUMINOUS_SIZE_M} m"))
        })
    };
    let (width, length, height) = (
        dimension("luminous width")?,
        dimension("luminous length")?,
        dimension("luminous height")?,
    );
    // A sign pattern outside LM-63-2019 Table 1 leaves the luminaire without a luminous area
    // (glare ratings then say so) rather than refusing an otherwise usable file.
    let luminous = LuminousShape::from_ies(width, length, height, to_m).unwrap_or(None);
    let ballast_factor = numbers.number(&|| "ballast factor".into(), positive)?;
    // Before LM-63-1995 this field was the ballast-lamp photometric factor, a multiplier; since
    // then it is "future use" or (2019) the file-generation-type code, which must not scale.
    let ballast_lamp_factor = if pre_1995 {
        numbers.number(&|| "ballast-lamp photometric factor".into(), positive)?
    } else {
        numbers.number(&|| "file generation type".into(), |_| None)?;
        1.0
    };
    numbers.number(&|| "input watts".into(), |_| None)?;
    let scale = check_scale(
        numbers.path,
        &format!("line {}", numbers.tokens[numbers.count_read - 1].line),
        multiplier * ballast_factor * ballast_lamp_factor,
        "the candela multiplier and the ballast factors",
    )?;

    let (gamma_deg, gamma_lines) = numbers.list(n_vertical, |k| format!("vertical angle {k}"))?;
    check_gamma_grid(numbers.path, &gamma_deg, |k| {
        format!("line {}, vertical angle {}", gamma_lines[k], k + 1)
    })?;
    let (c_deg, c_lines) = numbers.list(n_horizontal, |k| format!("horizontal angle {k}"))?;
    let c_place = |k: usize| format!("line {}, horizontal angle {}", c_lines[k], k + 1);
    check_c_angles(numbers.path, &c_deg, c_place)?;
    let symmetry = classify_c_range(numbers.path, &c_deg, c_place)?;

    let candela_start = numbers.count_read;
    let mut planes = Vec::with_capacity(n_horizontal);
    for &c in &c_deg {
        let mut values = Vec::with_capacity(n_vertical);
        for &g in &gamma_deg {
            let index = numbers.count_read - candela_start + 1;
            let value = numbers.number(
                &|| format!("value {index} (candela for C={c}°, γ={g}°)"),
                |v| check_scaled_intensity(v, scale),
            )?;
            values.push(value * scale);
        }
        planes.push((c, values));
    }
    Ok(StoredPlanes {
        gamma_deg,
        planes,
        symmetry,
        luminous,
    })
}

/// An error message unless `v > 0`.
fn positive(v: f64) -> Option<String> {
    (v <= 0.0).then(|| "must be greater than 0".into())
}

/// The symmetry the last horizontal angle encodes: 0° axial, 90° quadrant, 180° bilateral
/// (about C0–C180), 360° none; a list ending between 180° and 360° is a full circle without the
/// duplicated 360° plane if the gap back to 360° is no wider than its own spacing.
fn classify_c_range(path: &Path, c_deg: &[f64], place: impl Fn(usize) -> String) -> Result<CSymmetry> {
    let last_index = c_deg.len() - 1;
    let last = c_deg[last_index];
    let near = |target: f64| (last - target).abs() < ANGLE_TOLERANCE_DEG;
    let widest_gap = c_deg.windows(2).map(|w| w[1] - w[0]).fold(0.0, f64::max);
    if last_index == 0 || near(360.0) {
        Ok(CSymmetry::None)
    } else if near(90.0) {
        Ok(CSymmetry::Quadrant)
    } else if near(180.0) {
        Ok(CSymmetry::AboutC0C180)
    } else if last > 180.0 && 360.0 - last <= widest_gap + ANGLE_TOLERANCE_DEG {
        Ok(CSymmetry::None)
    } else {
        Err(Error::input(
            path,
            place(last_index),
            format!(
                "the horizontal angles end at {last}°: they must end at 0° (axial), 90° (quadrant), \
                 180° (bilateral) or 360° (full)"
            ),
        ))
    }
}

/// A number token and the (1-based) line it is on.
#[derive(Debug, Clone, Copy)]
struct Token<'a> {
    text: &'a str,
    line: usize,
}

/// The numbers after the `TILT=` line, read one at a time with a description for errors.
struct Numbers<'a> {
    path: &'a Path,
    tokens: Vec<Token<'a>>,
    count_read: usize,
    last_line: usize,
}

impl<'a> Numbers<'a> {
    /// Tokenises `lines`, the first of which is line `first_line` of the file.
    fn new(path: &'a Path, lines: &[&'a str], first_line: usize) -> Self {
        let tokens = lines
            .iter()
            .enumerate()
            .flat_map(|(k, line)| {
                line.split(|c: char| c.is_whitespace() || c == ',')
                    .filter(|t| !t.is_empty())
                    .map(move |text| Token {
                        text,
                        line: first_line + k,
                    })
            })
            .collect();
        Numbers {
            path,
            tokens,
            count_read: 0,
            last_line: first_line + lines.len().saturating_sub(1),
        }
    }

    /// The next number, which must be finite and pass `check` (which returns an error message
    /// for a bad value). `what` describes it for error messages.
    fn number(&mut self, what: &dyn Fn() -> String, check: impl Fn(f64) -> Option<String>) -> Result<f64> {
        let Some(&token) = self.tokens.get(self.count_read) else {
            return Err(Error::input(
                self.path,
                format!("line {}", self.last_line),
                format!("the file ends early: expected the {}", what()),
            ));
        };
        self.count_read += 1;
        let place = || format!("line {}, {}", token.line, what());
        let value = match token.text.parse::<f64>() {
            Ok(v) if v.is_finite() => v,
            Ok(_) => {
                let message = format!("{} is not a finite number", quoted(token.text));
                return Err(Error::input(self.path, place(), message));
            }
            Err(_) => {
                let message = format!("{} is not a number", quoted(token.text));
                return Err(Error::input(self.path, place(), message));
            }
        };
        match check(value) {
            None => Ok(value),
            Some(message) => Err(Error::input(self.path, place(), format!("{value}: {message}"))),
        }
    }

    /// The next number as a count: a whole number from `min` to [`MAX_ANGLES`].
    fn count(&mut self, what: &dyn Fn() -> String, min: usize) -> Result<usize> {
        let value = self.number(what, |v| {
            (v.fract() != 0.0 || v < min as f64 || v > MAX_ANGLES as f64)
                .then(|| format!("must be a whole number from {min} to {MAX_ANGLES}"))
        })?;
        Ok(value as usize)
    }

    /// The next `n` numbers and their lines; `what(k)` describes the k-th (1-based).
    fn list(&mut self, n: usize, what: impl Fn(usize) -> String) -> Result<(Vec<f64>, Vec<usize>)> {
        let mut values = Vec::with_capacity(n);
        let mut lines = Vec::with_capacity(n);
        for k in 1..=n {
            values.push(self.number(&|| what(k), |_| None)?);
            lines.push(self.tokens[self.count_read - 1].line);
        }
        Ok((values, lines))
    }

    /// Fails if any token is left after the candela table (the counts disagree with the data).
    fn expect_end(&self) -> Result<()> {
        match self.tokens.get(self.count_read) {
            None => Ok(()),
            Some(token) => Err(Error::input(
                self.path,
                format!("line {}", token.line),
                format!(
                    "{} unexpected value(s) after the candela table, starting with {} (do the \
                     numbers of vertical and horizontal angles match the data?)",
                    self.tokens.len() - self.count_read,
                    quoted(token.text)
                ),
            )),
        }
    }
}

/// Writes `curve` as an IES LM-63-2002 file: `TILT=NONE`, absolute photometry (lumens/lamp −1,
/// multiplier 1, ballast factor 1), one horizontal angle (0°, axially symmetric), Type C, units
/// metres, zero luminous dimensions (a point source), and the curve's own γ grid in degrees with
/// its candela values. A step (two points at one angle) is written as two equal angles.
/// Numbers are printed in Rust's shortest round-trip form, so reading the file back gives the
/// same curve exactly. Control characters in `luminaire` become spaces.
pub fn write_ies(curve: &Curve, luminaire: &str) -> String {
    write_ies_with_area(curve, luminaire, None)
}

/// As [`write_ies`], with the luminous dimensions of `luminous` (LM-63 Table 1 signs,
/// [`LuminousShape::to_ies`]) so that the file gives the same luminous area back; zero (a point
/// source) when there is none or LM-63 cannot describe it.
pub fn write_ies_with_area(curve: &Curve, luminaire: &str, luminous: Option<&LuminousShape>) -> String {
    let [width, length, height] = luminous.and_then(LuminousShape::to_ies).unwrap_or([0.0; 3]);
    let name: String = luminaire
        .chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .collect();
    let mut lines = vec![
        "IESNA:LM-63-2002".to_string(),
        "[TEST] none: written by Haiko from an axially symmetric intensity curve".to_string(),
        format!("[LUMINAIRE] {}", name.trim()),
        "[MORE] absolute photometry, candela; gamma in degrees from nadir".to_string(),
        "TILT=NONE".to_string(),
        format!("1 -1 1 {} 1 1 2 {width} {length} {height}", curve.len()),
        "1 1 0".to_string(),
    ];
    lines.extend(wrapped(curve.gammas_deg()));
    lines.push("0".to_string());
    lines.extend(wrapped(curve.intensities_cd()));
    let mut text = lines.join("\r\n");
    text.push_str("\r\n");
    text
}

/// `values` in shortest round-trip form, eight to a line (LM-63 lines stay short).
fn wrapped(values: &[f64]) -> Vec<String> {
    values
        .chunks(8)
        .map(|chunk| chunk.iter().map(|v| format!("{v}")).collect::<Vec<_>>().join(" "))
        .collect()
}
