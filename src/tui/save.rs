//! The editor's save: a thin wrapper over [`crate::scene::save`], which takes the lights as
//! scene-level values and the room text as read, and refuses what must be asked first
//! (docs/DECISIONS.md "Saving"); [`refusal`] turns a refusal into the prompt's message.

use std::path::Path;

use crate::error::{Error, Result};
use crate::scene::save::{self, IfChanged, SaveError, Saved};
use crate::scene::{Light, RoomText};
use crate::tui::model::{LightEdit, Model};
use crate::tui::msg::{Msg, SaveOffer};

pub use crate::scene::save::{EditedRoom, SIGNIFICANT_DIGITS, number, round_significant};

/// Writes `model`'s changes (against [`Model::saved`]) into the room file at `path`, whose
/// current text is `original_text`; returns the status message for the user.
pub fn save_room(path: &Path, original_text: &str, model: &Model) -> Result<String> {
    let (saved, now) = scene_lights(model);
    let room = RoomText::new(original_text.to_string());
    Ok(save::save_room(path, &room, &saved, &now, IfChanged::Refuse)?.message)
}

/// Saves `model`'s changes into the room file at `path`, read as `loaded`: refused (nothing
/// written) when it is read-only, hard-linked, or changed on disk since — unless `if_changed`
/// says to overwrite such a change.
pub fn save_loaded(
    path: &Path,
    loaded: &RoomText,
    model: &Model,
    if_changed: IfChanged,
) -> Result<Saved, SaveError> {
    let (saved, now) = scene_lights(model);
    save::save_room(path, loaded, &saved, &now, if_changed)
}

/// Saves `model`'s changes to the room read from `from` as `loaded` into the new file `path`
/// (relative `file` / `lid_file` paths rebased). An existing `path` is refused: the editor
/// never replaces another file without asking.
pub fn save_as(path: &Path, from: &Path, loaded: &RoomText, model: &Model) -> Result<Saved, SaveError> {
    if std::fs::symlink_metadata(path).is_ok() {
        return Err(SaveError::Failed(Error::input(
            path,
            "",
            "cannot save as: the file exists; choose a new name",
        )));
    }
    let (saved, now) = scene_lights(model);
    save::save_room_as(path, from, loaded, &saved, &now)
}

/// The editor's message for a save that did not happen: a change on disk asks overwrite /
/// reload / save as; a read-only or hard-linked file offers save as; anything else is shown.
pub fn refusal(e: SaveError) -> Msg {
    let offer = match &e {
        SaveError::ChangedOnDisk { .. } => Some(SaveOffer::OverwriteReloadOrSaveAs),
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
pub fn edit_room_text(file: &Path, original_text: &str, model: &Model) -> Result<EditedRoom> {
    let (saved, now) = scene_lights(model);
    save::edit_room_text(file, original_text, &saved, &now)
}

/// The model's saved and current lights as scene lights (the values a save compares).
fn scene_lights(model: &Model) -> (Vec<Light>, Vec<Light>) {
    let convert = |lights: &[LightEdit]| lights.iter().map(LightEdit::to_light).collect();
    (convert(&model.saved), convert(&model.lights))
}
