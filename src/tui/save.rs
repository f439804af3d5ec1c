//! The editor's save: a thin wrapper over [`crate::scene::save`], which takes the lights as
//! scene-level values. Edited file curves are first written as new IES files or made inline
//! (docs/DECISIONS.md, "Editor"). The editor reads the file just before saving, so no change on
//! disk is detected here (the session's save will keep the text read at load).

use std::fs;
use std::path::{Path, PathBuf};

use crate::error::Result;
use crate::fsio::{self, FileKind};
use crate::photometry::write_ies_with_area;
use crate::scene::save::{self, IfChanged};
use crate::scene::{LidSource, Light, RoomText};
use crate::tui::luminaires;
use crate::tui::model::{LightEdit, Model};
use crate::tui::msg::CurveSave;

pub use crate::scene::save::{EditedRoom, SIGNIFICANT_DIGITS, number, round_significant};

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
                    fsio::write_atomic(&path, text.as_bytes())?;
                    written.push(path.clone());
                    LidSource::File { path, asymmetry: 0.0 }
                }
                CurveSave::Inline => LidSource::Inline,
            };
        }
        let text = fsio::read_text(room, FileKind::Room)?;
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
    let (saved, now) = scene_lights(model);
    let room = RoomText::new(original_text.to_string());
    Ok(save::save_room(path, &room, &saved, &now, IfChanged::Refuse)?.message)
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
