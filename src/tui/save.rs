//! The editor's save: a thin wrapper over [`crate::scene::save`], which takes the lights as
//! scene-level values. The editor reads the file just before saving, so no change on disk is
//! detected here (the session's save will keep the text read at load).

use std::path::Path;

use crate::error::Result;
use crate::scene::save::{self, IfChanged};
use crate::scene::{Light, RoomText};
use crate::tui::model::{LightEdit, Model};

pub use crate::scene::save::{EditedRoom, SIGNIFICANT_DIGITS, number, round_significant};

/// Writes `model`'s changes (against [`Model::saved`]) into the room file at `path`, whose
/// current text is `original_text`; returns the status message for the user.
pub fn save_room(path: &Path, original_text: &str, model: &Model) -> Result<String> {
    let (saved, now) = scene_lights(model);
    let room = RoomText::new(original_text.to_string());
    Ok(save::save_room(path, &room, &saved, &now, IfChanged::Refuse)?.message)
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
