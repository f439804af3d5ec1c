//! Saving the room file (docs/ROOM_FILE.md, docs/DECISIONS.md "Saving"): rewrite only the values
//! the user changed — a light's `lid`, `aim`/`aim_dir`, `position`, `dimmer`, `order` — keeping
//! comments, order and layout of everything else (toml_edit), comments inside an edited `lid`
//! array included, and replace the file atomically ([`crate::fsio::write_atomic`]).
//!
//! The lights are scene-level values ([`Light`]): the state as last read or saved, and the state
//! now, matched by index. Before writing, [`save_room`] refuses with a distinct [`SaveError`]:
//! * a read-only file ([`SaveError::ReadOnly`]: offer "save as");
//! * a file changed on disk since it was read ([`SaveError::ChangedOnDisk`], by content hash:
//!   ask overwrite / reload / save as; overwrite is [`IfChanged::Overwrite`]);
//! * a file with other hard links ([`SaveError::HardLinked`]): replacing it would detach it from
//!   its other names, and writing it in place is not safe against a crash, so Haiko asks for
//!   "save as" instead.
//!
//! A symlink is written through to its target; the file's permissions are kept.

use std::fmt;
use std::fs::{self, OpenOptions};
use std::io;
use std::path::{Path, PathBuf};

use toml_edit::{Array, DocumentMut, Item, Key, Table, Value};

use crate::error::{Error, Result};
use crate::fsio::{self, FileKind};
use crate::photometry::Curve;
use crate::scene::light_tables::align_light_tables;
use crate::scene::load::RoomText;
use crate::scene::model::{AimSpec, Light};

pub use crate::scene::light_tables::{SIGNIFICANT_DIGITS, number, round_significant, vector};

/// Why a save did not happen. Nothing was written in any case.
#[derive(Debug)]
pub enum SaveError {
    /// The room file (or the file its symlink names) is read-only.
    ReadOnly {
        /// The file as named.
        path: PathBuf,
    },
    /// The file's content differs from what was read (or it was removed).
    ChangedOnDisk {
        /// The file as named.
        path: PathBuf,
        /// False when the file no longer exists.
        exists: bool,
    },
    /// The file has `links` hard links in all.
    HardLinked {
        /// The file as named.
        path: PathBuf,
        /// Its number of hard links.
        links: u64,
    },
    /// Anything else: a room text that no longer matches the lights, an I/O failure.
    Failed(Error),
}

impl fmt::Display for SaveError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.as_error())
    }
}

impl SaveError {
    /// The error as the crate's [`Error`] (a refusal is bad input, exit code 2).
    fn as_error(&self) -> Error {
        let refuse = |path: &Path, why: String| Error::input(path, "", format!("cannot save: {why}"));
        match self {
            SaveError::ReadOnly { path } => refuse(path, "the file is read-only (save as another file)".into()),
            SaveError::ChangedOnDisk { path, exists: true } => refuse(
                path,
                "the file was changed on disk since it was read (overwrite, reload or save as)".into(),
            ),
            SaveError::ChangedOnDisk { path, exists: false } => refuse(
                path,
                "the file no longer exists (removed or moved since it was read; save again to write it anew, \
                 or save as)"
                    .into(),
            ),
            SaveError::HardLinked { path, links } => refuse(
                path,
                format!(
                    "the file has {links} hard links, which replacing it would break and writing it in \
                     place is not crash-safe (save as another file)"
                ),
            ),
            SaveError::Failed(e) => match e {
                Error::Input(inner) => Error::Input(inner.clone()),
                Error::Internal(message) => Error::Internal(message.clone()),
            },
        }
    }
}

impl From<SaveError> for Error {
    fn from(e: SaveError) -> Self {
        match e {
            SaveError::Failed(inner) => inner,
            other => other.as_error(),
        }
    }
}

impl From<Error> for SaveError {
    fn from(e: Error) -> Self {
        SaveError::Failed(e)
    }
}

impl std::error::Error for SaveError {}

/// What [`save_room`] does when the file changed on disk since it was read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IfChanged {
    /// Refuse with [`SaveError::ChangedOnDisk`].
    Refuse,
    /// Write the edited room over the other change (the user chose "overwrite").
    Overwrite,
}

/// A successful save.
#[derive(Debug, Clone, PartialEq)]
pub struct Saved {
    /// The status line for the user.
    pub message: String,
    /// Names of the lights whose `lid_file` was replaced by an inline `lid`.
    pub inlined: Vec<String>,
    /// The room as now on disk: the state the next save compares against.
    pub room: RoomText,
}

/// The room text after an edit, and what it changed.
#[derive(Debug, Clone, PartialEq)]
pub struct EditedRoom {
    /// The new file text.
    pub text: String,
    /// Names of the lights whose `lid_file` was replaced by an inline `lid`.
    pub inlined: Vec<String>,
}

/// Writes the changes of `now` (against `saved`, the state of `loaded`) into the room file at
/// `path`, which was read as `loaded`. See the module docs for the refusals.
pub fn save_room(
    path: &Path,
    loaded: &RoomText,
    saved: &[Light],
    now: &[Light],
    if_changed: IfChanged,
) -> Result<Saved, SaveError> {
    let target = fsio::resolve_symlinks(path).map_err(|e| write_failed(path, &e))?;
    let exists = check_writable(path, &target)?;
    let changed = !exists || fsio::content_hash(&fsio::read(&target, FileKind::Room)?) != loaded.hash;
    if changed && if_changed == IfChanged::Refuse {
        return Err(SaveError::ChangedOnDisk {
            path: path.to_path_buf(),
            exists,
        });
    }
    write_edited(path, &loaded.text, saved, now)
}

/// Writes the edited room to `path`, a new file or one the user chose to replace (the editor
/// asks first). Relative `file` / `lid_file` paths become absolute when the new file is in
/// another directory, so they still name the same files.
pub fn save_room_as(
    path: &Path,
    from: &Path,
    loaded: &RoomText,
    saved: &[Light],
    now: &[Light],
) -> Result<Saved, SaveError> {
    let target = fsio::resolve_symlinks(path).map_err(|e| write_failed(path, &e))?;
    check_writable(path, &target)?;
    let rebased = rebase_paths(from, path, &loaded.text)?;
    write_edited(path, &rebased, saved, now)
}

/// Removes temporary files a killed save left beside the room file at `path` (for the editor to
/// call on open); returns those removed.
pub fn remove_stale_temporaries(path: &Path) -> io::Result<Vec<PathBuf>> {
    fsio::remove_stale_temporaries(path)
}

/// Edits `text` and writes it atomically to `path`.
fn write_edited(path: &Path, text: &str, saved: &[Light], now: &[Light]) -> Result<Saved, SaveError> {
    let edited = edit_room_text(path, text, saved, now)?;
    fsio::write_atomic(path, edited.text.as_bytes())?;
    let mut message = format!("saved {}", path.display());
    if !edited.inlined.is_empty() {
        message.push_str(&format!(
            "; edited curve of {} now inline (lid = …), lid_file removed",
            edited.inlined.join(", ")
        ));
    }
    Ok(Saved {
        message,
        inlined: edited.inlined,
        room: RoomText::new(edited.text),
    })
}

/// An I/O failure while saving `path` (exit code 1).
fn write_failed(path: &Path, e: &io::Error) -> SaveError {
    SaveError::Failed(Error::internal(format!("cannot save {}: {e}", path.display())))
}

/// Checks the file a save would replace (`target`, which `path` names): whether it exists, and
/// refuses a read-only, hard-linked or non-regular file.
fn check_writable(path: &Path, target: &Path) -> Result<bool, SaveError> {
    let metadata = match fs::metadata(target) {
        Ok(m) => m,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(false),
        Err(e) => return Err(write_failed(path, &e)),
    };
    if !metadata.is_file() {
        return Err(SaveError::Failed(Error::input(
            path,
            "",
            "cannot save: not a regular file",
        )));
    }
    // The mode bits decide even for a user who may write anyway (root); opening for writing
    // (without truncating) catches a file owned by someone else.
    let denied = metadata.permissions().readonly()
        || matches!(
            OpenOptions::new().write(true).open(target),
            Err(e) if e.kind() == io::ErrorKind::PermissionDenied
        );
    if denied {
        return Err(SaveError::ReadOnly {
            path: path.to_path_buf(),
        });
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if metadata.nlink() > 1 {
            return Err(SaveError::HardLinked {
                path: path.to_path_buf(),
                links: metadata.nlink(),
            });
        }
    }
    Ok(true)
}

/// `text` with relative `[[mesh]] file` and `[[light]] lid_file` paths made absolute when the
/// room moves from `from` to another directory (`to`).
fn rebase_paths(from: &Path, to: &Path, text: &str) -> Result<String> {
    let directory = |p: &Path| {
        let parent = p
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        fs::canonicalize(parent).unwrap_or_else(|_| parent.to_path_buf())
    };
    let (old_dir, new_dir) = (directory(from), directory(to));
    if old_dir == new_dir {
        return Ok(text.to_string());
    }
    let mut doc = parse(from, text)?;
    for (tables, key) in [("mesh", "file"), ("light", "lid_file")] {
        let Some(tables) = doc.get_mut(tables).and_then(Item::as_array_of_tables_mut) else {
            continue;
        };
        for table in tables.iter_mut() {
            let Some(value) = table.get_mut(key).and_then(Item::as_value_mut) else {
                continue;
            };
            let Some(written) = value.as_str().filter(|w| Path::new(w).is_relative()) else {
                continue;
            };
            let absolute = old_dir.join(written).to_string_lossy().into_owned();
            let decor = value.decor().clone();
            *value = Value::from(absolute);
            *value.decor_mut() = decor;
        }
    }
    Ok(doc.to_string())
}

/// The room text with the changed values of `now` (against `saved`) written in; `file` names
/// the file in errors. Added and removed lights and changed photometric files are handled first
/// ([`align_light_tables`]), then each light's changed values.
pub fn edit_room_text(
    file: &Path,
    original_text: &str,
    saved: &[Light],
    now: &[Light],
) -> Result<EditedRoom> {
    let aligned = align_light_tables(file, original_text, saved, now)?;
    let (original_text, saved) = (aligned.text.as_str(), aligned.saved.as_slice());
    let mut doc = parse(file, original_text)?;
    let mut inlined = Vec::new();
    let changed = now.len() != saved.len() || now.iter().zip(saved).any(|(n, s)| !same_saved_values(n, s));
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
    if tables.len() != now.len() || saved.len() != now.len() {
        return Err(Error::input(
            file,
            "[[light]]",
            format!(
                "the file has {} lights but the editor {} (was it changed on disk?)",
                tables.len(),
                now.len()
            ),
        ));
    }
    for (i, (table, (now, saved))) in tables.iter_mut().zip(now.iter().zip(saved)).enumerate() {
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

/// Parses room text for editing; `file` names it in errors.
fn parse(file: &Path, text: &str) -> Result<DocumentMut> {
    text.parse()
        .map_err(|e: toml_edit::TomlError| Error::input(file, place_of(&e, text), e.message()))
}

/// True when the values a save writes (curve, aim, position, dimmer, order) are equal.
pub(crate) fn same_saved_values(a: &Light, b: &Light) -> bool {
    a.curve == b.curve
        && a.aim_spec == b.aim_spec
        && a.position == b.position
        && a.dimmer == b.dimmer
        && a.order == b.order
}

/// Writes the values of `now` that differ from `saved` into the light's table; returns true
/// when an edited curve replaced a `lid_file`.
fn write_light(table: &mut Table, now: &Light, saved: &Light) -> bool {
    let mut inlined = false;
    if now.curve != saved.curve {
        let old = table.get("lid").and_then(Item::as_array);
        let lid = edited_lid(old, &saved.curve, &now.curve);
        inlined = table.contains_key("lid_file");
        set_replacing(table, "lid", "lid_file", Value::Array(lid));
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
        match now.order {
            Some(order) => {
                let order = i64::try_from(order).unwrap_or(i64::MAX);
                set_replacing(table, "order", "order", Value::from(order));
            }
            None => {
                table.remove("order");
            }
        }
    }
    inlined
}

/// The new `lid` array for `new`, keeping the layout and comments of the `old` array (which
/// held `saved`): a point keeps the formatting and the comments before it of the old point it
/// corresponds to (by index when the number of points is unchanged, else by angle), an unchanged
/// number keeps its text, and the comments of a removed point move to the point after it. Without
/// an old array (a `lid_file` light) the array is written on one line.
fn edited_lid(old: Option<&Array>, saved: &Curve, new: &Curve) -> Array {
    let pairs = new.points().map(|(gamma_deg, cd)| {
        let mut pair = Array::from_iter([number(gamma_deg, true), number(cd, true)]);
        pair.fmt();
        Value::Array(pair)
    });
    let Some(old) = old.filter(|o| o.len() == saved.len()) else {
        return formatted(Array::from_iter(pairs));
    };
    let old_gammas = saved.gammas_deg();
    let new_gammas = new.gammas_deg();
    // For each new point, the index of its old point (if any); old points left unmatched were
    // removed.
    let mut matched: Vec<Option<usize>> = vec![None; new.len()];
    if old.len() == new.len() {
        matched.iter_mut().enumerate().for_each(|(j, m)| *m = Some(j));
    } else {
        let (mut i, mut j) = (0, 0);
        while i < old_gammas.len() && j < new_gammas.len() {
            if old_gammas[i] == new_gammas[j] {
                matched[j] = Some(i);
                i += 1;
                j += 1;
            } else if new_gammas.len() > old_gammas.len() {
                j += 1;
            } else {
                i += 1;
            }
        }
    }
    let mut out = Array::new();
    let mut next_old = 0;
    let mut carried = String::new();
    for (j, mut value) in pairs.enumerate() {
        let mut prefix = None;
        let mut suffix = None;
        if let Some(i) = matched[j] {
            // Comments of old points skipped over (removed) move here.
            for removed in next_old..i {
                carried.push_str(&comment_lines(old.get(removed).and_then(|v| v.decor().prefix())));
            }
            next_old = i + 1;
            let old_value = old.get(i).expect("matched index");
            keep_number_texts(&mut value, old_value);
            prefix = old_value
                .decor()
                .prefix()
                .and_then(|p| p.as_str())
                .map(str::to_string);
            suffix = old_value
                .decor()
                .suffix()
                .and_then(|s| s.as_str())
                .map(str::to_string);
        }
        let prefix = prefix.unwrap_or_else(|| plain_prefix(out.len(), old));
        value.decor_mut().set_prefix(join_comments(&carried, &prefix));
        carried.clear();
        if let Some(suffix) = suffix {
            value.decor_mut().set_suffix(suffix);
        }
        out.push_formatted(value);
    }
    for removed in next_old..old.len() {
        carried.push_str(&comment_lines(old.get(removed).and_then(|v| v.decor().prefix())));
    }
    out.set_trailing(join_comments(&carried, old.trailing().as_str().unwrap_or("")));
    out.set_trailing_comma(old.trailing_comma());
    *out.decor_mut() = old.decor().clone();
    out
}

/// The comment lines of an element's prefix (up to and including its last newline, when it has
/// a comment), else nothing.
fn comment_lines(prefix: Option<&toml_edit::RawString>) -> String {
    let prefix = prefix.and_then(|p| p.as_str()).unwrap_or("");
    match prefix.rfind('\n') {
        Some(end) if prefix.contains('#') => prefix[..=end].to_string(),
        _ => String::new(),
    }
}

/// `carried` comment lines put before an element whose own prefix is `prefix`: the carried lines
/// replace the prefix's first line break (so no blank line appears).
fn join_comments(carried: &str, prefix: &str) -> String {
    if carried.is_empty() {
        return prefix.to_string();
    }
    let rest = prefix.split_once('\n').map_or(prefix, |(_, after)| after);
    format!("{carried}{rest}")
}

/// The whitespace that goes before a new element at position `k` without an old counterpart:
/// the line break and indentation of the old array's elements (no comment), else a space.
fn plain_prefix(k: usize, old: &Array) -> String {
    let sample = old
        .iter()
        .nth(1.min(old.len().saturating_sub(1)))
        .and_then(|v| v.decor().prefix())
        .and_then(|p| p.as_str())
        .unwrap_or("");
    match sample.rfind('\n') {
        Some(at) => format!("\n{}", &sample[at + 1..]),
        None if k == 0 => String::new(),
        None => " ".to_string(),
    }
}

/// Keeps the text of each number of the `[γ, cd]` pair `old` that equals the new value (so
/// `1000.0` stays `1000.0`), and the spacing inside the pair.
fn keep_number_texts(new: &mut Value, old: &Value) {
    let (Some(new), Some(old)) = (new.as_array_mut(), old.as_array()) else {
        return;
    };
    if new.len() != old.len() {
        return;
    }
    for k in 0..new.len() {
        let (Some(n), Some(o)) = (new.get(k), old.get(k)) else {
            continue;
        };
        let same = as_number(n).is_some() && as_number(n) == as_number(o);
        let replacement = if same {
            o.clone()
        } else {
            let mut n = n.clone();
            *n.decor_mut() = o.decor().clone();
            n
        };
        new.replace_formatted(k, replacement);
    }
    new.set_trailing(old.trailing().as_str().unwrap_or(""));
    new.set_trailing_comma(old.trailing_comma());
}

/// A TOML number as f64.
fn as_number(v: &Value) -> Option<f64> {
    v.as_float().or_else(|| v.as_integer().map(|i| i as f64))
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
    crate::scene::room_file::line_column(text, span.start)
}
