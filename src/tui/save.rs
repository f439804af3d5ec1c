//! The editor's save: a thin wrapper over [`crate::scene::save`], which takes the lights as
//! scene-level values and the room text as read, and refuses what must be asked first
//! (docs/DECISIONS.md "Saving"); [`refusal`] turns a refusal into the prompt's message. Edited
//! file curves are first written as new IES files or made inline (docs/DECISIONS.md, "Editor").

use std::fs;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::fsio::{self, FileKind};
use crate::photometry::write_ies_with_area;
use crate::scene::save::{self, IfChanged, SaveError, Saved};
use crate::scene::{LidSource, Light, RoomText};
use crate::tui::luminaires;
use crate::tui::model::{LightEdit, Model};
use crate::tui::msg::{CurveSave, Msg, SaveOffer};

pub use crate::scene::save::{EditedRoom, SIGNIFICANT_DIGITS, number, round_significant};

/// Where a save writes the room.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SaveTarget<'a> {
    /// The room file itself; `IfChanged` says what to do when it changed on disk since read.
    Room(IfChanged),
    /// A new file (save as): refused when it exists, relative paths rebased.
    As(&'a Path),
}

/// Saves `model` into the room file `room`, read as `loaded`, or as another file (`target`):
/// each light whose curve came from a photometric file and was edited
/// ([`luminaires::edited_file_curves`]) is first written as a new IES file next to the room
/// written (with its luminous area) and pointed at, or made inline, as `curves` says. Returns
/// the save and every light's photometric source as written. On failure nothing is left behind:
/// new IES files are removed again.
///
/// Errors: the refusals of [`save::save_room`] (read-only, hard-linked, changed on disk), an
/// existing save-as file, a file not writable.
pub fn save_curves_to(
    room: &Path,
    loaded: &RoomText,
    model: &Model,
    curves: CurveSave,
    target: SaveTarget<'_>,
) -> Result<(Saved, Vec<LidSource>), SaveError> {
    let destination = match target {
        SaveTarget::Room(_) => room,
        SaveTarget::As(path) => {
            if fs::symlink_metadata(path).is_ok() {
                return Err(SaveError::Failed(Error::input(
                    path,
                    "",
                    "cannot save as: the file exists; choose a new name",
                )));
            }
            path
        }
    };
    let mut model = model.clone();
    let mut written: Vec<PathBuf> = Vec::new();
    let mut save = || -> Result<Saved, SaveError> {
        for i in luminaires::edited_file_curves(&model) {
            let light = &mut model.lights[i];
            light.lid_source = match curves {
                CurveSave::NewFiles => {
                    let path = luminaires::edited_curve_path(destination, &light.name, |p| {
                        p.exists() || written.iter().any(|w| w == p)
                    });
                    let text = write_ies_with_area(&light.curve, &light.name, light.luminous.as_ref());
                    fsio::write_atomic(&path, text.as_bytes())?;
                    written.push(path.clone());
                    LidSource::File { path, asymmetry: 0.0 }
                }
                CurveSave::Inline => LidSource::Inline,
            };
        }
        let (saved, now) = scene_lights(&model);
        match target {
            SaveTarget::Room(if_changed) => save::save_room(room, loaded, &saved, &now, if_changed),
            SaveTarget::As(path) => save::save_room_as(path, room, loaded, &saved, &now),
        }
    };
    match save() {
        Ok(mut saved) => {
            if !written.is_empty() {
                let names: Vec<String> = written.iter().map(|p| p.display().to_string()).collect();
                saved
                    .message
                    .push_str(&format!("; edited curves written to {}", names.join(", ")));
            }
            let sources = model.lights.iter().map(|l| l.lid_source.clone()).collect();
            Ok((saved, sources))
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

/// [`save_curves_to`] the room file `room` as it is on disk now (no change since reading can be
/// detected this way; the editor keeps the text it read and calls [`save_curves_to`]). Returns
/// the status message and every light's photometric source as written.
///
/// Errors: the room file unreadable or refused by the save (bad input), a file not writable.
pub fn save_with_curves(room: &Path, model: &Model, curves: CurveSave) -> Result<(String, Vec<LidSource>)> {
    let loaded = RoomText::new(fsio::read_text(room, FileKind::Room)?);
    let (saved, sources) = save_curves_to(room, &loaded, model, curves, SaveTarget::Room(IfChanged::Refuse))?;
    Ok((saved.message, sources))
}

/// Writes `model`'s changes (against [`Model::saved`]) into the room file at `path`, whose
/// current text is `original_text`; returns the status message for the user.
pub fn save_room(path: &Path, original_text: &str, model: &Model) -> Result<String> {
    let (saved, now) = scene_lights(model);
    let room = RoomText::new(original_text.to_string());
    Ok(save::save_room(path, &room, &saved, &now, IfChanged::Refuse)?.message)
}

/// The editor's message for a save that did not happen: a change on disk asks overwrite /
/// reload / save as (an overwrite then writes the file curves as `curves` said); a read-only or
/// hard-linked file offers save as; anything else is shown.
pub fn refusal(e: SaveError, curves: CurveSave) -> Msg {
    let offer = match &e {
        SaveError::ChangedOnDisk { .. } => Some(SaveOffer::OverwriteReloadOrSaveAs { curves }),
        SaveError::ReadOnly { .. } | SaveError::HardLinked { .. } => Some(SaveOffer::SaveAs),
        SaveError::Failed(_) => None,
    };
    let reason = e.to_string();
    match offer {
        Some(offer) => Msg::SaveRefused { reason, offer },
        None => Msg::Failed { message: reason },
    }
}

/// The room text with `model`'s changed values written in; `file` names the file in errors.
/// Added and removed lights and changed photometric files are handled first, then each light's
/// changed values ([`save::edit_room_text`]).
pub fn edit_room_text(file: &Path, original_text: &str, model: &Model) -> Result<EditedRoom> {
    let (saved, now) = scene_lights(model);
    save::edit_room_text(file, original_text, &saved, &now)
}

/// The model's saved and current lights as scene lights (the values a save compares).
fn scene_lights(model: &Model) -> (Vec<Light>, Vec<Light>) {
    let convert = |lights: &[LightEdit]| lights.iter().map(LightEdit::to_light).collect();
    (convert(&model.saved), convert(&model.lights))
}
