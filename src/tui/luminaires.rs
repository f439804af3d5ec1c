//! Luminaires in the editor: the group an edit applies to (marked lights), duplicates and
//! deletions, the typed dimmer, swapping a light's photometric file, group aim offsets, and what
//! the editor knows of each photometric file (its C-plane average, asymmetry and spread).
//!
//! Everything here is pure: it computes commands (and the paths a save writes) from the model;
//! reading and writing files is the app's (docs/ARCHITECTURE.md, "One key press").

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::DVec3;

use crate::photometry::{ASYMMETRY_WARNING, CSpread, Curve, LidFile, LuminousShape, read_lid_file};
use crate::scene::{AimSpec, LidSource};
use crate::session::{Command, LightEdit, RoomBounds, group_aims};
use crate::tui::edits::{EditError, MOVE_MARGIN_M};
use crate::tui::keys::Action;
use crate::tui::model::{Mode, Model};
use crate::tui::msg::{CurveSave, Effect};
use crate::tui::update::{edit, run, run_group};

/// How far a duplicate is placed from its original (m), along x or y, whichever stays in the
/// room and out of furniture first.
pub const DUPLICATE_OFFSET_M: f64 = 0.5;

/// What the editor keeps of a photometric file.
#[derive(Debug, Clone, PartialEq)]
pub struct LidInfo {
    /// The file's C-plane average (cd).
    pub curve: Curve,
    /// Largest deviation of a C-plane from the average, as a fraction of its peak.
    pub asymmetry: f64,
    /// Distinct C-planes in the file.
    pub n_planes: usize,
    /// The lowest and highest C-plane at each point of `curve`.
    pub spread: CSpread,
    /// The luminous area the file gives.
    pub luminous: Option<LuminousShape>,
}

impl LidInfo {
    /// What the editor keeps of `lid`.
    pub fn of(lid: LidFile) -> Self {
        LidInfo {
            curve: lid.curve,
            asymmetry: lid.asymmetry,
            n_planes: lid.n_planes,
            spread: lid.spread,
            luminous: lid.luminous,
        }
    }

    /// True when the file is asymmetric enough to warn about ([`ASYMMETRY_WARNING`]).
    pub fn warns(&self) -> bool {
        self.asymmetry > ASYMMETRY_WARNING
    }

    /// The spread for the polar diagram: `(γ rad, lowest cd, highest cd)` per curve point.
    pub fn spread_samples(&self) -> Vec<(f64, f64, f64)> {
        self.curve
            .gammas_deg()
            .iter()
            .zip(self.spread.min_cd.iter().zip(&self.spread.max_cd))
            .map(|(g, (&lo, &hi))| (g.to_radians(), lo, hi))
            .collect()
    }
}

/// The photometric files the editor knows, by path.
pub type LidInfos = HashMap<PathBuf, Arc<LidInfo>>;

/// Reads every photometric file `lights` come from (files that cannot be read are left out: the
/// editor then shows no spread for them).
pub fn read_lid_infos(lights: &[LightEdit]) -> LidInfos {
    let mut infos = LidInfos::new();
    for light in lights {
        if let LidSource::File { path, .. } = &light.lid_source
            && !infos.contains_key(path)
            && let Ok(lid) = read_lid_file(path)
        {
            infos.insert(path.clone(), Arc::new(LidInfo::of(lid)));
        }
    }
    infos
}

/// What the editor knows of light `light`'s photometric file, if it comes from one.
pub fn lid_info<'a>(model: &'a Model, light: &LightEdit) -> Option<&'a LidInfo> {
    match &light.lid_source {
        LidSource::File { path, .. } => model.lid_files.get(path).map(Arc::as_ref),
        LidSource::Inline => None,
    }
}

/// The lights an edit applies to, in order: the marked lights and the selected one, or the
/// selected one alone when none is marked.
pub fn group(model: &Model) -> Vec<usize> {
    (0..model.lights.len())
        .filter(|&i| i == model.selected_light || model.marked.contains(&model.lights[i].name))
        .collect()
}

/// True when `a` and `b` have the same photometry: the same file, or equal inline curves.
pub fn same_photometry(a: &LightEdit, b: &LightEdit) -> bool {
    match (&a.lid_source, &b.lid_source) {
        (LidSource::File { path: pa, .. }, LidSource::File { path: pb, .. }) => pa == pb,
        (LidSource::Inline, LidSource::Inline) => a.curve == b.curve,
        _ => false,
    }
}

/// A name for a copy of `name` that no light in `lights` has: `NAME copy`, `NAME copy 2`, …
pub fn copy_name(lights: &[LightEdit], name: &str) -> String {
    let taken = |n: &str| lights.iter().any(|l| l.name == n);
    let first = format!("{name} copy");
    if !taken(&first) {
        return first;
    }
    (2..)
        .map(|k| format!("{name} copy {k}"))
        .find(|n| !taken(n))
        .unwrap_or(first)
}

/// Inserts a copy of light `i` after it, [`DUPLICATE_OFFSET_M`] away along +x, −x, +y or −y
/// (the first place inside the room, off the walls by [`MOVE_MARGIN_M`] and out of furniture;
/// on the original's place when none is). A copy aimed at a target aims at the same target.
pub fn duplicate(lights: &[LightEdit], i: usize, bounds: &RoomBounds) -> Option<Command> {
    let original = lights.get(i)?;
    let margin = DVec3::splat(MOVE_MARGIN_M);
    let inside = |p: DVec3| bounds.admits(p) && p.cmpge(margin).all() && p.cmple(bounds.size - margin).all();
    let position = [DVec3::X, DVec3::NEG_X, DVec3::Y, DVec3::NEG_Y]
        .into_iter()
        .map(|d| original.position + d * DUPLICATE_OFFSET_M)
        .find(|&p| inside(p))
        .unwrap_or(original.position);
    let aim = match original.aim_spec {
        AimSpec::Target(t) => (t - position).try_normalize().unwrap_or(original.aim),
        AimSpec::Direction(_) => original.aim,
    };
    let copy = LightEdit {
        name: copy_name(lights, &original.name),
        position,
        aim,
        ..original.clone()
    };
    Some(Command::Insert {
        at: i + 1,
        light: Box::new(copy),
    })
}

/// Parses a typed dimmer in percent (`24` or `24 %` is 0.24): a finite number ≥ 0.
pub fn parse_dimmer_percent(text: &str) -> Result<f64, EditError> {
    let number = text.trim().trim_end_matches('%').trim();
    match number.parse::<f64>() {
        Ok(percent) if percent.is_finite() && percent >= 0.0 => Ok(percent / 100.0),
        _ => Err(EditError::NotADimmer(text.to_string())),
    }
}

/// The lights whose curve came from a photometric file and was edited since: a save offers to
/// write each as a new file.
pub fn edited_file_curves(model: &Model) -> Vec<usize> {
    (0..model.lights.len())
        .filter(|&i| {
            let light = &model.lights[i];
            let LidSource::File { path, .. } = &light.lid_source else {
                return false;
            };
            let original = match model.lid_files.get(path) {
                Some(info) => Some(&info.curve),
                None => model
                    .saved
                    .iter()
                    .find(|s| s.name == light.name && s.lid_source == light.lid_source)
                    .map(|s| &s.curve),
            };
            original.is_some_and(|c| *c != light.curve)
        })
        .collect()
}

/// Where the edited curve of light `name` is written: `ROOM-NAME.ies` next to the room file
/// (characters other than letters, digits, `-` and `_` become `-`), with `-2`, `-3`, … when that
/// name is taken (`taken` says whether a path exists).
pub fn edited_curve_path(room: &Path, name: &str, taken: impl Fn(&Path) -> bool) -> PathBuf {
    let clean = |s: &str| -> String {
        s.chars()
            .map(|c| {
                if c.is_alphanumeric() || c == '-' || c == '_' {
                    c
                } else {
                    '-'
                }
            })
            .collect()
    };
    let stem = room
        .file_stem()
        .map(|s| clean(&s.to_string_lossy()))
        .unwrap_or_default();
    let dir = room.parent().unwrap_or(Path::new(""));
    let base = format!("{stem}-{}", clean(name));
    std::iter::once(dir.join(format!("{base}.ies")))
        .chain((2..).map(|k| dir.join(format!("{base}-{k}.ies"))))
        .find(|p| !taken(p))
        .unwrap_or_else(|| dir.join(format!("{base}.ies")))
}

/// The path a typed photometric file names: relative to the room file's directory unless
/// absolute (a leading `~/` is the home directory).
pub fn resolve_typed_path(room: &Path, typed: &str, home: Option<&Path>) -> PathBuf {
    let typed = typed.trim();
    if let (Some(rest), Some(home)) = (typed.strip_prefix("~/"), home) {
        return home.join(rest);
    }
    let path = Path::new(typed);
    if path.is_absolute() {
        path.to_path_buf()
    } else {
        room.parent().unwrap_or(Path::new("")).join(path)
    }
}

/// The command giving light `i` the photometry of the file at `path`.
pub fn photometry_command(i: usize, path: &Path, info: &LidInfo) -> Command {
    Command::SetPhotometry {
        light: i,
        curve: info.curve.clone(),
        source: LidSource::File {
            path: path.to_path_buf(),
            asymmetry: info.asymmetry,
        },
        luminous: info.luminous,
    }
}

/// The message after loading a photometric file: its flux and asymmetry, with the warning when
/// the C-plane average hides an asymmetric distribution.
pub fn loaded_message(names: &[&str], path: &Path, info: &LidInfo) -> String {
    let file = path.file_name().map_or_else(
        || path.display().to_string(),
        |f| f.to_string_lossy().into_owned(),
    );
    let mut message = format!(
        "{} ← {file}: {:.0} lm, {} C-plane(s), asymmetry {:.2}",
        names.join(", "),
        info.curve.flux_lm(),
        info.n_planes,
        info.asymmetry
    );
    if info.warns() {
        message.push_str(&format!(
            " — above {ASYMMETRY_WARNING}: the axial average hides the C-plane differences"
        ));
    }
    message
}

/// The luminaire keys: duplicate, delete, typed dimmer and file, marks, report.
pub(crate) fn on_action(model: &mut Model, action: Action) -> Vec<Effect> {
    let i = model.selected_light;
    let Some(light) = model.lights.get(i) else {
        return Vec::new();
    };
    match action {
        Action::DuplicateLight => {
            let Some(command) = duplicate(&model.lights, i, &model.bounds) else {
                return Vec::new();
            };
            let mut effects = run(model, command, true);
            if !effects.is_empty() {
                model.selected_light = i + 1;
                let copy = &model.lights[i + 1];
                model.message = Some(format!(
                    "{} added at {:.2} {:.2} {:.2} m (m moves it)",
                    copy.name, copy.position.x, copy.position.y, copy.position.z
                ));
                effects.push(Effect::Render);
            }
            effects
        }
        Action::DeleteLight => {
            let name = light.name.clone();
            let mut effects = run(model, Command::Remove { light: i }, true);
            if !effects.is_empty() {
                model.marked.remove(&name);
                model.selected_light = i.min(model.lights.len().saturating_sub(1));
                model.selected_point = 0;
                model.message = Some(format!("{name} deleted (u brings it back)"));
                effects.push(Effect::Render);
            }
            effects
        }
        Action::EnterDimmer => {
            model.mode = Mode::DimmerEntry {
                buffer: String::new(),
            };
            Vec::new()
        }
        Action::EnterPath => {
            model.mode = Mode::PathEntry {
                buffer: String::new(),
            };
            Vec::new()
        }
        Action::ToggleMark => {
            let name = light.name.clone();
            if !model.marked.remove(&name) {
                model.marked.insert(name);
            }
            Vec::new()
        }
        Action::MarkSamePhotometry => {
            let names: Vec<String> = model
                .lights
                .iter()
                .filter(|l| same_photometry(l, light))
                .map(|l| l.name.clone())
                .collect();
            model.message = Some(format!("marked {}: {}", names.len(), names.join(", ")));
            model.marked = names.into_iter().collect();
            Vec::new()
        }
        Action::ClearMarks => {
            model.marked.clear();
            Vec::new()
        }
        Action::Report => {
            model.message = Some("writing the report…".into());
            vec![Effect::Report]
        }
        _ => Vec::new(),
    }
}

/// The save key: asks how to write edited file curves when there are any, else saves.
pub(crate) fn save(model: &mut Model) -> Vec<Effect> {
    let edited = edited_file_curves(model);
    if edited.is_empty() {
        return vec![Effect::Save {
            curves: CurveSave::Inline,
            overwrite: false,
        }];
    }
    model.mode = Mode::ConfirmSave;
    Vec::new()
}

/// The names of the lights whose edited file curves the save prompt is about.
pub fn edited_names(model: &Model) -> Vec<&str> {
    edited_file_curves(model)
        .into_iter()
        .map(|i| model.lights[i].name.as_str())
        .collect()
}

/// After a save: every light's photometric source as written, and the state on disk. A light
/// whose edited curve now comes from a new file is told to the engine (same curve, new source)
/// so its reports name the file.
pub(crate) fn on_saved(model: &mut Model, message: String, sources: Vec<LidSource>) -> Vec<Effect> {
    let mut effects = Vec::new();
    if sources.len() == model.lights.len() {
        for (i, (light, source)) in model.lights.iter_mut().zip(sources).enumerate() {
            if light.lid_source != source {
                light.lid_source = source.clone();
                if matches!(source, LidSource::File { .. }) {
                    effects.push(Effect::Engine(Command::SetPhotometry {
                        light: i,
                        curve: light.curve.clone(),
                        source,
                        luminous: light.luminous,
                    }));
                }
            }
        }
    }
    model.saved = model.lights.clone();
    model.refresh_dirty();
    model.message = Some(message);
    effects
}

/// A photometric file was read (or not) for the selected and marked lights.
pub(crate) fn on_lid_loaded(
    model: &mut Model,
    path: PathBuf,
    result: Result<Arc<LidInfo>, String>,
) -> Vec<Effect> {
    let info = match result {
        Ok(info) => info,
        Err(message) => {
            model.message = Some(message);
            return Vec::new();
        }
    };
    model.lid_files.insert(path.clone(), Arc::clone(&info));
    let lights = group(model);
    let commands: Vec<Command> = lights
        .iter()
        .map(|&i| photometry_command(i, &path, &info))
        .collect();
    let effects = run_group(model, commands);
    let names: Vec<&str> = lights.iter().map(|&i| model.lights[i].name.as_str()).collect();
    model.message = Some(loaded_message(&names, &path, &info));
    clamp_point(model);
    effects
}

/// Aims the selected light at `point` (world, m) and turns the other lights of the group by
/// the same rotation ([`group_aims`]; one undo step).
pub(crate) fn aim_group_at(model: &mut Model, point: DVec3) -> Vec<Effect> {
    let aims = group_aims(&model.lights, model.selected_light, &group(model), point);
    edit(model, |l, i| {
        aims.iter()
            .find(|(j, _)| *j == i)
            .and_then(|(_, command)| command.clone())
            .ok_or_else(|| EditError::AimAtItself(l.name.clone()))
    })
}

/// Keeps the selected control point inside the selected light's curve.
fn clamp_point(model: &mut Model) {
    if let Some(light) = model.light() {
        model.selected_point = model.selected_point.min(light.curve.len() - 1);
    }
}
