//! The `[[light]]` tables of a room file brought in line with the editor's lights before a save
//! (docs/ROOM_FILE.md, "Saving from the editor"): the tables of removed lights go, added lights
//! get a table at their place in the list, the tables follow the lights' order, and a light
//! whose photometric file changed gets `lid_file` — written only when the file reproduces the
//! light's curve exactly, else the curve is left to be written inline.
//!
//! Lights are matched by name (names are unique within a room). The value-by-value save then
//! runs on the result with one table per light, comparing against the returned `saved` lights.

use std::path::Path;

use toml_edit::{ArrayOfTables, DocumentMut, Item, Table, Value};

use crate::error::{Error, Result};
use crate::photometry::read_lid_file;
use crate::scene::model::{AimSpec, LidSource, Light};

/// The room text with its light tables aligned, and what the value-by-value save compares the
/// lights against (one per light of `now`, in order).
#[derive(Debug, Clone)]
pub(crate) struct AlignedLights {
    /// The new room text.
    pub text: String,
    /// Per light of `now`: its saved state, or (for an added light, or a light whose `lid_file`
    /// was just written) the values already in the text.
    pub saved: Vec<Light>,
}

/// Aligns the `[[light]]` tables of `text` (the room file `file`, whose lights are `saved`,
/// table `i` holding `saved[i]`) with `now`: see the module docs. When the lights are the same
/// names in the same order and no photometric file changed, the text is returned unchanged.
///
/// Errors (bad input naming the file): the text does not parse, or its light tables no longer
/// match `saved` (count or names: the file was changed on disk).
pub(crate) fn align_light_tables(
    file: &Path,
    text: &str,
    saved: &[Light],
    now: &[Light],
) -> Result<AlignedLights> {
    let same_names = saved.len() == now.len() && saved.iter().zip(now).all(|(s, n)| s.name == n.name);
    let sources_changed = now
        .iter()
        .zip(saved)
        .any(|(n, s)| n.lid_source != s.lid_source && matches!(n.lid_source, LidSource::File { .. }));
    if same_names && !sources_changed {
        return Ok(AlignedLights {
            text: text.to_string(),
            saved: saved.to_vec(),
        });
    }
    let mut doc: DocumentMut = text
        .parse()
        .map_err(|e: toml_edit::TomlError| Error::input(file, "", e.message()))?;
    let room_dir = file.parent().unwrap_or(Path::new(""));
    let old_tables: Vec<Table> = match doc.get("light").and_then(Item::as_array_of_tables) {
        Some(tables) => tables.iter().cloned().collect(),
        None => Vec::new(),
    };
    check_tables(file, &old_tables, saved)?;
    let positions: Vec<isize> = old_tables.iter().filter_map(Table::position).collect();
    let mut tables: Vec<Table> = Vec::with_capacity(now.len());
    let mut aligned: Vec<Light> = Vec::with_capacity(now.len());
    for light in now {
        match saved.iter().position(|s| s.name == light.name) {
            Some(k) => {
                let mut table = old_tables[k].clone();
                let mut base = saved[k].clone();
                if light.lid_source != base.lid_source && write_lid_file(&mut table, light, room_dir) {
                    base.curve = light.curve.clone();
                    base.lid_source = light.lid_source.clone();
                }
                tables.push(table);
                aligned.push(base);
            }
            None => {
                let template = saved
                    .iter()
                    .zip(&old_tables)
                    .chain(aligned.iter().zip(&tables))
                    .find(|(s, _)| same_kind(s, light))
                    .map(|(_, t)| t.clone());
                tables.push(new_table(template, light, room_dir));
                aligned.push(light.clone());
            }
        }
    }
    // Document positions decide the order tables are written in: the tables take the light
    // tables' old positions in their new order; a new table shares its predecessor's.
    let mut last = positions.first().copied();
    for (k, table) in tables.iter_mut().enumerate() {
        let position = positions.get(k).copied().or(last);
        table.set_position(position);
        last = position;
    }
    if tables.is_empty() {
        doc.remove("light");
    } else {
        doc.insert("light", Item::ArrayOfTables(ArrayOfTables::from_iter(tables)));
    }
    Ok(AlignedLights {
        text: doc.to_string(),
        saved: aligned,
    })
}

/// Refuses when table `i` is not light `saved[i]` (count or name): the file changed on disk.
fn check_tables(file: &Path, tables: &[Table], saved: &[Light]) -> Result<()> {
    if tables.len() != saved.len() {
        return Err(Error::input(
            file,
            "[[light]]",
            format!(
                "the file has {} lights but {} were loaded (was it changed on disk?)",
                tables.len(),
                saved.len()
            ),
        ));
    }
    for (i, (table, light)) in tables.iter().zip(saved).enumerate() {
        if table.get("name").and_then(Item::as_str) != Some(light.name.as_str()) {
            return Err(Error::input(
                file,
                format!("light[{i}].name"),
                format!("expected \"{}\" (was the file changed on disk?)", light.name),
            ));
        }
    }
    Ok(())
}

/// True when `a` and `b` are the same kind of luminaire (photometry, luminous area, radius,
/// colour): a duplicate's table is made from its original's.
fn same_kind(a: &Light, b: &Light) -> bool {
    a.lid_source == b.lid_source && a.luminous == b.luminous && a.radius == b.radius && a.color == b.color
}

/// `path` as written in the room file: relative to the room's directory when inside it.
fn written_path(path: &Path, room_dir: &Path) -> String {
    path.strip_prefix(room_dir).unwrap_or(path).display().to_string()
}

/// True when the photometric file of `light` (its `lid_file`) gives exactly its curve.
fn file_gives_curve(light: &Light) -> bool {
    match &light.lid_source {
        LidSource::File { path, .. } => read_lid_file(path).is_ok_and(|lid| lid.curve == light.curve),
        LidSource::Inline => false,
    }
}

/// Writes `lid_file` for `light` into `table` (in place of `lid`), when its file reproduces its
/// curve; returns whether it did.
fn write_lid_file(table: &mut Table, light: &Light, room_dir: &Path) -> bool {
    let LidSource::File { path, .. } = &light.lid_source else {
        return false;
    };
    if !file_gives_curve(light) {
        return false;
    }
    let value = Value::from(written_path(path, room_dir));
    match ["lid_file", "lid"].into_iter().find(|k| table.contains_key(k)) {
        Some(old) => {
            let decor = table.get(old).and_then(Item::as_value).map(|v| v.decor().clone());
            let mut value = value;
            if let Some(decor) = decor {
                *value.decor_mut() = decor;
            }
            if old == "lid" {
                // Keep the key's place: rename by rebuilding the table in order.
                let entries: Vec<(String, Item)> = table
                    .iter()
                    .map(|(k, item)| {
                        if k == "lid" {
                            ("lid_file".to_string(), Item::Value(value.clone()))
                        } else {
                            (k.to_string(), item.clone())
                        }
                    })
                    .collect();
                table.clear();
                for (k, item) in entries {
                    table.insert(&k, item);
                }
            } else {
                table.insert("lid_file", Item::Value(value));
            }
        }
        None => {
            table.insert("lid_file", Item::Value(value));
        }
    }
    true
}

/// A table for the added light `light`: a copy of `template` (a table of the same kind of
/// luminaire: keeps its luminous size, radius, colour, order and comments inside) or a new
/// table, with the light's name, position, aim, dimmer and photometry.
fn new_table(template: Option<Table>, light: &Light, room_dir: &Path) -> Table {
    let mut table = template.unwrap_or_default();
    table.decor_mut().clear();
    for key in ["name", "position", "aim", "aim_dir", "dimmer"] {
        table.remove(key);
    }
    let mut entries: Vec<(String, Item)> = vec![
        ("name".into(), Item::Value(Value::from(light.name.as_str()))),
        ("position".into(), Item::Value(vector(light.position.to_array()))),
    ];
    match light.aim_spec {
        AimSpec::Target(p) => entries.push(("aim".into(), Item::Value(vector(p.to_array())))),
        AimSpec::Direction(d) => entries.push(("aim_dir".into(), Item::Value(vector(d.to_array())))),
    }
    let rest: Vec<(String, Item)> = table.iter().map(|(k, v)| (k.to_string(), v.clone())).collect();
    table.clear();
    for (k, v) in entries.into_iter().chain(rest) {
        table.insert(&k, v);
    }
    if !write_lid_file(&mut table, light, room_dir) {
        table.remove("lid_file");
        let lid = toml_edit::Array::from_iter(light.curve.points().map(|(gamma_deg, cd)| {
            let mut pair = toml_edit::Array::from_iter([number(gamma_deg, true), number(cd, true)]);
            pair.fmt();
            Value::Array(pair)
        }));
        table.insert("lid", Item::Value(Value::Array(lid)));
    }
    if light.dimmer != 1.0 {
        table.insert("dimmer", Item::Value(number(light.dimmer, false)));
    }
    if light.radius != 0.0 && !table.contains_key("radius") {
        table.insert("radius", Item::Value(number(light.radius, false)));
    }
    if light.color != [1.0; 3] && !table.contains_key("color") {
        table.insert("color", Item::Value(vector(light.color)));
    }
    table
}

/// Significant digits of the numbers a save writes (no `1.0000000000000002` noise).
pub const SIGNIFICANT_DIGITS: usize = 6;

/// `[x, y, z]` with [`SIGNIFICANT_DIGITS`].
pub fn vector(v: [f64; 3]) -> Value {
    let mut array = toml_edit::Array::from_iter(v.map(|x| number(x, false)));
    array.fmt();
    Value::Array(array)
}

/// `x` rounded to [`SIGNIFICANT_DIGITS`]; written as an integer when `integral_as_int` and it is
/// one (as in `lid = [[0, 1000], …]`), else as a float.
pub fn number(x: f64, integral_as_int: bool) -> Value {
    let rounded = round_significant(x);
    if integral_as_int && rounded.fract() == 0.0 && rounded.abs() < 1e15 {
        Value::from(rounded as i64)
    } else {
        Value::from(rounded)
    }
}

/// `x` rounded to [`SIGNIFICANT_DIGITS`] significant digits (−0 becomes 0).
pub fn round_significant(x: f64) -> f64 {
    if !x.is_finite() || x == 0.0 {
        return if x == 0.0 { 0.0 } else { x };
    }
    let text = format!("{:.*e}", SIGNIFICANT_DIGITS - 1, x);
    text.parse().unwrap_or(x)
}
