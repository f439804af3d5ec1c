//! The editor's state (the Elm architecture's `Model`): every light's editable values, the
//! selection, the mode, the camera, and what the workers last reported.
//!
//! Plain data; changed only by [`crate::tui::update::update`] (and by the app for the fields it
//! documents as its own, such as [`Model::protocol`]). World frame: metres, z up (docs/METHOD.md §1).

use std::collections::BTreeSet;

use glam::DVec3;

use crate::scene::{Camera, Scene};
pub use crate::session::light::{DEFAULT_ORDER, LightEdit, MAX_ORDER, WindowChoice};
use crate::session::{ExposureChoice, LightStatus, RoomBounds, Series};
use crate::tui::history::History;
use crate::tui::keys::ModeKind;
use crate::tui::luminaires::LidInfos;
use crate::tui::msg::CurveSave;
use crate::tui::panel::PanelNumbers;
use crate::tui::polar::PolarOptions;
use crate::tui::view::preview_rect;

/// What the editor is doing; decides which key table applies.
#[derive(Debug, Clone, PartialEq)]
pub enum Mode {
    /// Editing the selected light's curve.
    Normal,
    /// Moving a keyboard cursor over the preview to aim the selected light.
    Aim {
        /// Cursor position in preview pixels (0, 0 = top-left).
        cursor: (u32, u32),
    },
    /// Moving the selected light's position with the arrow keys.
    Move {
        /// The light's position when the move started (world, m; for cancel and the undo
        /// record).
        start: DVec3,
    },
    /// The key help overlay.
    Help,
    /// Typing an exact intensity (cd) for the selected control point.
    ValueEntry {
        /// What was typed so far.
        buffer: String,
    },
    /// Typing a dimmer in percent for the selected (or marked) lights.
    DimmerEntry {
        /// What was typed so far.
        buffer: String,
    },
    /// Typing the path of a photometric file for the selected (or marked) lights.
    PathEntry {
        /// What was typed so far.
        buffer: String,
    },
    /// "Edited file curves: write new files or save inline?" prompt before a save.
    ConfirmSave,
    /// "Unsaved changes: quit?" prompt.
    ConfirmQuit,
    /// The room file changed on disk since it was read: overwrite, reload or save as?
    SaveConflict {
        /// What the save found, for the prompt.
        reason: String,
        /// How the refused save wrote edited file curves (an overwrite does the same).
        curves: CurveSave,
    },
    /// Typing the name of a file to save the room as.
    SaveAs {
        /// What was typed so far (relative names are in the room file's folder).
        buffer: String,
        /// Why "save as" is offered (a refused save), if it was.
        reason: Option<String>,
    },
}

impl Mode {
    /// Which key table applies in this mode.
    pub fn kind(&self) -> ModeKind {
        match self {
            Mode::Normal => ModeKind::Normal,
            Mode::Aim { .. } => ModeKind::Aim,
            Mode::Move { .. } => ModeKind::Move,
            Mode::Help => ModeKind::Help,
            Mode::ValueEntry { .. } | Mode::DimmerEntry { .. } => ModeKind::ValueEntry,
            Mode::PathEntry { .. } => ModeKind::PathEntry,
            Mode::ConfirmSave => ModeKind::ConfirmSave,
            Mode::ConfirmQuit => ModeKind::ConfirmQuit,
            Mode::SaveConflict { .. } => ModeKind::SaveConflict,
            Mode::SaveAs { .. } => ModeKind::SaveAs,
        }
    }

    /// The mode's name in the status line.
    pub fn label(&self) -> &'static str {
        match self {
            Mode::Normal => "EDIT",
            Mode::Aim { .. } => "AIM",
            Mode::Move { .. } => "MOVE",
            Mode::Help => "HELP",
            Mode::ValueEntry { .. } => "VALUE",
            Mode::DimmerEntry { .. } => "DIMMER",
            Mode::PathEntry { .. } => "FILE",
            Mode::ConfirmSave => "SAVE?",
            Mode::ConfirmQuit => "QUIT?",
            Mode::SaveConflict { .. } => "CHANGED ON DISK",
            Mode::SaveAs { .. } => "SAVE AS",
        }
    }
}

/// Durations of the last frame's stages, in milliseconds (reported by the app).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Timings {
    /// Relight (blend) time, ms.
    pub relight_ms: f64,
    /// Rasterisation time, ms.
    pub render_ms: f64,
    /// Image-protocol encoding time, ms.
    pub encode_ms: f64,
}

/// The last pick under the cursor (reported by the app).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Picked {
    /// The 3D point hit (world, m).
    pub point: DVec3,
    /// Illuminance at that point, lx.
    pub lux: f64,
}

/// The editor's whole state.
#[derive(Debug, Clone)]
pub struct Model {
    /// Room name (from the room file).
    pub room_name: String,
    /// Room interior extent (m): positions are kept within (0, 0, 0)..room_size.
    pub room_size: DVec3,
    /// Where lights may stand (the room and its furniture), for commands.
    pub bounds: RoomBounds,
    /// Every light's current editable state, in file order.
    pub lights: Vec<LightEdit>,
    /// The state as last loaded or saved: a save writes what differs from it.
    pub saved: Vec<LightEdit>,
    /// Index of the selected light.
    pub selected_light: usize,
    /// Index of the selected control point of the selected light's curve.
    pub selected_point: usize,
    /// Current mode.
    pub mode: Mode,
    /// The preview camera.
    pub camera: Camera,
    /// The room file's camera (`c` resets to it).
    pub home_camera: Camera,
    /// False-colour (illuminance scale) preview instead of the photographic one.
    pub false_colour: bool,
    /// The plan (top-down) preview instead of the camera's.
    pub plan_view: bool,
    /// The plan shows the design's work plane instead of the floor.
    pub plan_work_plane: bool,
    /// Isolux lines over the preview.
    pub isolux: bool,
    /// The photo exposure: the room's, moved in stops, or automatic.
    pub exposure: ExposureChoice,
    /// Bumped by the reset key: the engine chooses the exposure and the lux range anew.
    pub display_refit: u32,
    /// Terminal size in cells (columns, rows).
    pub terminal_size: (u16, u16),
    /// One cell's size in pixels (width, height), from the terminal.
    pub cell_px: (u16, u16),
    /// The preview's size in pixels (width, height): the preview cells times `cell_px`.
    pub preview_px: (u32, u32),
    /// The latest pick under the cursor.
    pub picked: Option<Picked>,
    /// Stage timings of the latest frame.
    pub timings: Option<Timings>,
    /// Name of the image protocol in use (set by the app).
    pub protocol: String,
    /// Progress `(done, total)` of the start-up bake while it runs.
    pub bake: Option<(usize, usize)>,
    /// Per light, whether its result is final or a re-bake (after a move) is pending.
    pub light_status: Vec<LightStatus>,
    /// True when some saved value differs from the file on disk.
    pub dirty: bool,
    /// A message for the user (an error or a confirmation), shown until the next key.
    pub message: Option<String>,
    /// Per light, the truncated series the engine last computed (None until then).
    pub series: Vec<Option<Series>>,
    /// Undo and redo stacks.
    pub history: History,
    /// Names of the marked lights: edits apply to them and the selected light together.
    pub marked: BTreeSet<String>,
    /// The photometric files the lights come from (set by the app, which reads them).
    pub lid_files: LidInfos,
    /// The latest numbers from the engine (None until the first are computed).
    pub numbers: Option<PanelNumbers>,
    /// How the polar diagram is drawn and its scale (kept across edits: it changes in round
    /// steps, [`crate::tui::polar::PolarScale::follow`]).
    pub polar: PolarOptions,
    /// The help overlay's page (0 first; the view clamps it to the pages there are).
    pub help_page: usize,
}

impl Model {
    /// The editor state for a loaded scene, in a terminal of `terminal_size` cells of
    /// `cell_px` pixels each.
    pub fn new(scene: &Scene, terminal_size: (u16, u16), cell_px: (u16, u16)) -> Self {
        let lights: Vec<LightEdit> = scene.lights.iter().map(LightEdit::from_light).collect();
        let mut model = Model {
            room_name: scene.name.clone(),
            room_size: scene.room_size,
            bounds: RoomBounds::of(scene),
            saved: lights.clone(),
            light_status: vec![LightStatus::Ready; lights.len()],
            series: vec![None; lights.len()],
            lights,
            selected_light: 0,
            selected_point: 0,
            mode: Mode::Normal,
            camera: scene.camera,
            home_camera: scene.camera,
            false_colour: false,
            plan_view: false,
            plan_work_plane: false,
            isolux: false,
            exposure: ExposureChoice::default(),
            display_refit: 0,
            terminal_size,
            cell_px,
            preview_px: (0, 0),
            picked: None,
            timings: None,
            protocol: String::new(),
            bake: None,
            dirty: false,
            message: None,
            history: History::default(),
            marked: BTreeSet::new(),
            lid_files: LidInfos::new(),
            numbers: None,
            polar: PolarOptions::default(),
            help_page: 0,
        };
        model.preview_px = model.compute_preview_px();
        model
    }

    /// Replaces light `i`'s order by the plan's choice, as if the file had said so (not an
    /// edit: nothing to undo or save). Out-of-range `i` is ignored.
    pub fn set_planned_order(&mut self, i: usize, order: usize) {
        if let (Some(light), Some(saved)) = (self.lights.get_mut(i), self.saved.get_mut(i)) {
            light.order = order.min(MAX_ORDER);
            saved.order = light.order;
        }
    }

    /// The selected light's state, or None in a room without lights.
    pub fn light(&self) -> Option<&LightEdit> {
        self.lights.get(self.selected_light)
    }

    /// The preview's pixel size for the current terminal: preview cells × cell pixels.
    pub fn compute_preview_px(&self) -> (u32, u32) {
        let (w, h) = self.terminal_size;
        let rect = preview_rect(ratatui::layout::Rect::new(0, 0, w, h));
        (
            u32::from(rect.width) * u32::from(self.cell_px.0),
            u32::from(rect.height) * u32::from(self.cell_px.1),
        )
    }

    /// Recomputes [`Model::dirty`]: whether a light was added or removed, or any light's saved
    /// values or photometric file differ from the file's.
    pub fn refresh_dirty(&mut self) {
        self.dirty = self.lights.len() != self.saved.len()
            || self.lights.iter().zip(&self.saved).any(|(now, saved)| {
                now.name != saved.name || now.lid_source != saved.lid_source || !now.same_saved_values(saved)
            });
    }
}
