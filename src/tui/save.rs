//! Saving the room file (docs/ROOM_FILE.md): rewrite only the values the user changed — a light's
//! `lid`, `aim`/`aim_dir`, `position`, `dimmer`, `order` — keeping comments, order and layout of
//! everything else (toml_edit), and replace the file atomically.

use std::fs::{self, File};
use std::io::{self, Write};
use std::path::{Path, PathBuf};

use toml_edit::{Array, DocumentMut, Item, Key, Table, Value};

use crate::error::{Error, Result};
use crate::photometry::write_ies_with_area;
use crate::scene::light_tables::align_light_tables;
use crate::scene::{AimSpec, LidSource};
use crate::tui::luminaires;
use crate::tui::model::{LightEdit, Model};
use crate::tui::msg::CurveSave;

pub use crate::scene::light_tables::{SIGNIFICANT_DIGITS, number, round_significant, vector};

/// The room text after a save, and what it changed.
#[derive(Debug, Clone, PartialEq)]
pub struct EditedRoom {
    /// The new file text.
    pub text: String,
    /// Names of the lights whose `lid_file` was replaced by an inline `lid`.
    pub inlined: Vec<String>,
}

/// Saves `model` into the room file `room` (read from disk now): each light whose curve came
/// from a photometric file and was edited ([`luminaires::edited_file_curves`]) is first written
/// as a new IES file next to the room (with its luminous area) and pointed at, or made inline,
/// as `curves` says. Returns the status message and every light's photometric source as
/// written. On failure nothing is left behind: new IES files are removed again.
///
/// Errors: the room file unreadable or refused by the save (bad input), a file not writable.
pub fn save_with_curves(room: &Path, model: &Model, curves: CurveSave) -> Result<(String, Vec<LidSource>)> {
    let mut model = model.clone();
    let mut written: Vec<PathBuf> = Vec::new();
    let mut save = || -> Result<String> {
        for i in luminaires::edited_file_curves(&model) {
            let light = &mut model.lights[i];
            light.lid_source = match curves {
                CurveSave::NewFiles => {
                    let path = luminaires::edited_curve_path(room, &light.name, |p| {
                        p.exists() || written.iter().any(|w| w == p)
                    });
                    let text = write_ies_with_area(&light.curve, &light.name, light.luminous.as_ref());
                    write_atomically(&path, &text)?;
                    written.push(path.clone());
                    LidSource::File { path, asymmetry: 0.0 }
                }
                CurveSave::Inline => LidSource::Inline,
            };
        }
        let text = fs::read_to_string(room).map_err(|e| Error::unreadable(room, &e))?;
        save_room(room, &text, &model)
    };
    match save() {
        Ok(mut message) => {
            if !written.is_empty() {
                let names: Vec<String> = written.iter().map(|p| p.display().to_string()).collect();
                message.push_str(&format!("; edited curves written to {}", names.join(", ")));
            }
            Ok((
                message,
                model.lights.iter().map(|l| l.lid_source.clone()).collect(),
            ))
        }
        Err(e) => {
            // The room file was not changed: the new curve files would name nothing.
            for path in &written {
                fs::remove_file(path).ok();
            }
            Err(e)
        }
    }
}

/// Writes `model`'s changes (against [`Model::saved`]) into the room file at `path`, whose
/// current text is `original_text`; returns the status message for the user.
pub fn save_room(path: &Path, original_text: &str, model: &Model) -> Result<String> {
    let edited = edit_room_text(path, original_text, model)?;
    write_atomically(path, &edited.text)?;
    let mut message = format!("saved {}", path.display());
    if !edited.inlined.is_empty() {
        message.push_str(&format!(
            "; edited curve of {} now inline (lid = …), lid_file removed",
            edited.inlined.join(", ")
        ));
    }
    Ok(message)
}

/// The room text with `model`'s changed values written in; `file` names the file in errors.
/// Added and removed lights and changed photometric files are handled first
/// ([`align_light_tables`]), then each light's changed values.
pub fn edit_room_text(file: &Path, original_text: &str, model: &Model) -> Result<EditedRoom> {
    let scene_lights = |lights: &[LightEdit]| lights.iter().map(LightEdit::to_light).collect::<Vec<_>>();
    let aligned = align_light_tables(
        file,
        original_text,
        &scene_lights(&model.saved),
        &scene_lights(&model.lights),
    )?;
    let saved: Vec<LightEdit> = aligned.saved.iter().map(LightEdit::from_light).collect();
    let text = aligned.text.as_str();
    let mut doc: DocumentMut = text
        .parse()
        .map_err(|e: toml_edit::TomlError| Error::input(file, place_of(&e, text), e.message()))?;
    let mut inlined = Vec::new();
    let changed = model
        .lights
        .iter()
        .zip(&saved)
        .any(|(now, saved)| !now.same_saved_values(saved));
    if !changed {
        return Ok(EditedRoom {
            text: aligned.text,
            inlined,
        });
    }
    let tables = doc
        .get_mut("light")
        .and_then(Item::as_array_of_tables_mut)
        .ok_or_else(|| Error::input(file, "[[light]]", "the file has no [[light]] tables any more"))?;
    if tables.len() != model.lights.len() {
        return Err(Error::input(
            file,
            "[[light]]",
            format!(
                "the file has {} lights but the editor {} (was it changed on disk?)",
                tables.len(),
                model.lights.len()
            ),
        ));
    }
    for (i, (table, (now, saved))) in tables.iter_mut().zip(model.lights.iter().zip(&saved)).enumerate() {
        let name = table.get("name").and_then(Item::as_str);
        if name != Some(now.name.as_str()) {
            return Err(Error::input(
                file,
                format!("light[{i}].name"),
                format!("expected \"{}\" (was the file changed on disk?)", now.name),
            ));
        }
        if write_light(table, now, saved) {
            inlined.push(now.name.clone());
        }
    }
    Ok(EditedRoom {
        text: doc.to_string(),
        inlined,
    })
}

/// Writes the values of `now` that differ from `saved` into the light's table; returns true
/// when an edited curve replaced a `lid_file`.
fn write_light(table: &mut Table, now: &LightEdit, saved: &LightEdit) -> bool {
    let mut inlined = false;
    if now.curve != saved.curve {
        let lid = Array::from_iter(now.curve.points().map(|(gamma_deg, cd)| {
            let mut pair = Array::from_iter([number(gamma_deg, true), number(cd, true)]);
            pair.fmt();
            Value::Array(pair)
        }));
        inlined = table.contains_key("lid_file");
        set_replacing(table, "lid", "lid_file", Value::Array(formatted(lid)));
    }
    if now.aim_spec != saved.aim_spec {
        match now.aim_spec {
            AimSpec::Target(point) => set_replacing(table, "aim", "aim_dir", vector(point.to_array())),
            AimSpec::Direction(dir) => set_replacing(table, "aim_dir", "aim", vector(dir.to_array())),
        }
    }
    if now.position != saved.position {
        set_replacing(table, "position", "position", vector(now.position.to_array()));
    }
    if now.dimmer != saved.dimmer {
        set_replacing(table, "dimmer", "dimmer", number(now.dimmer, false));
    }
    if now.order != saved.order {
        let order = i64::try_from(now.order).unwrap_or(i64::MAX);
        set_replacing(table, "order", "order", Value::from(order));
    }
    inlined
}

/// Sets `key = value`, keeping the formatting (comments, spacing) and position of `key`, or of
/// `replaced` which it takes the place of (removed); appended when neither exists.
fn set_replacing(table: &mut Table, key: &str, replaced: &str, mut value: Value) {
    if key != replaced && table.contains_key(key) {
        table.remove(replaced);
    }
    let Some(old_key) = [key, replaced].into_iter().find(|k| table.contains_key(k)) else {
        table.insert(key, Item::Value(value));
        return;
    };
    let keys: Vec<String> = table.iter().map(|(k, _)| k.to_string()).collect();
    let position = keys.iter().position(|k| k == old_key).unwrap_or(keys.len());
    let tail: Vec<(Key, Item)> = keys[position..]
        .iter()
        .filter_map(|k| table.remove_entry(k))
        .collect();
    let mut tail = tail.into_iter();
    if let Some((old, old_item)) = tail.next() {
        if let Some(old_value) = old_item.as_value() {
            *value.decor_mut() = old_value.decor().clone();
        }
        let new_key = Key::new(key).with_leaf_decor(old.leaf_decor().clone());
        table.insert_formatted(&new_key, Item::Value(value));
    }
    for (k, item) in tail {
        table.insert_formatted(&k, item);
    }
}

fn formatted(mut array: Array) -> Array {
    array.fmt();
    array
}

/// `line L, column C` of a parse error, when it has a span.
fn place_of(error: &toml_edit::TomlError, text: &str) -> String {
    let Some(span) = error.span() else {
        return String::new();
    };
    let before = text.get(..span.start).unwrap_or(text);
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    format!("line {line}, column {column}")
}

/// Replaces `path` by `text` atomically: a temporary file in the same directory, written and
/// flushed to disk (fsync), then renamed over `path`. On failure the temporary file is removed
/// and `path` is untouched.
pub fn write_atomically(path: &Path, text: &str) -> Result<()> {
    let name = path
        .file_name()
        .ok_or_else(|| Error::input(path, "", "cannot save: not a file name"))?;
    let dir = match path.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => parent,
        _ => Path::new("."),
    };
    let temp = dir.join(format!(
        ".{}.haiko-save-{}",
        name.to_string_lossy(),
        std::process::id()
    ));
    let write = || -> io::Result<()> {
        let mut file = File::create(&temp)?;
        file.write_all(text.as_bytes())?;
        file.sync_all()?;
        if let Ok(metadata) = fs::metadata(path) {
            fs::set_permissions(&temp, metadata.permissions())?;
        }
        fs::rename(&temp, path)?;
        // Persist the rename itself; not every platform can open a directory, so best effort.
        if let Ok(directory) = File::open(dir) {
            directory.sync_all().ok();
        }
        Ok(())
    };
    write().map_err(|e| {
        fs::remove_file(&temp).ok();
        Error::input(path, "", format!("cannot save: {e}"))
    })
}
