//! What reaches the editor (`Msg`: input events and engine results) and what it asks the app to
//! do (`Effect`).

use std::path::PathBuf;
use std::sync::Arc;

use glam::DVec3;
use ratatui::crossterm::event::KeyEvent;

use crate::scene::LidSource;
use crate::session::{Command, LightStatus, Series};
use crate::tui::luminaires::LidInfo;
use crate::tui::panel::PanelNumbers;

/// An input event or an engine's result.
#[derive(Debug, Clone, PartialEq)]
pub enum Msg {
    /// A key press (or repeat; releases are ignored).
    Key(KeyEvent),
    /// A left mouse click at a terminal cell (column, row; 0-based from the top-left).
    Click {
        /// Column of the cell.
        column: u16,
        /// Row of the cell.
        row: u16,
    },
    /// The mouse moved over a terminal cell (column, row; 0-based from the top-left) with no
    /// button held: in aim mode the aim cursor follows it.
    Hover {
        /// Column of the cell.
        column: u16,
        /// Row of the cell.
        row: u16,
    },
    /// The terminal was resized to `width × height` cells.
    Resize {
        /// Columns.
        width: u16,
        /// Rows.
        height: u16,
    },
    /// The start-up bake's progress: `done` of `total` units of its current stage.
    BakeProgress {
        /// Units done.
        done: usize,
        /// Units in the stage.
        total: usize,
    },
    /// The start-up bake finished; the engine is ready. With the bake's notices (a damaged
    /// cache entry rebuilt, a cache that could not be written), shown in the status line.
    BakeDone {
        /// One line each.
        notices: Vec<String>,
    },
    /// Every light's status (a moved light is `Updating` until its new bake is installed).
    LightStatus(Vec<LightStatus>),
    /// A new preview frame is on screen; its stage timings in milliseconds.
    Frame {
        /// Relight time, ms.
        relight_ms: f64,
        /// Render time, ms.
        render_ms: f64,
        /// Encode time, ms.
        encode_ms: f64,
    },
    /// The answer to [`Effect::Pick`]: the 3D point under `pixel` and its illuminance, or None
    /// when the pixel shows no surface.
    Picked {
        /// The picked preview pixel.
        pixel: (u32, u32),
        /// The hit point (world, m) and its illuminance (lx).
        hit: Option<(DVec3, f64)>,
        /// True when the pick was asked for to aim the selected light.
        aim: bool,
    },
    /// The engine recomputed light `light`'s truncated series (for the polar diagram).
    Series {
        /// Index of the light.
        light: usize,
        /// The series.
        series: Series,
    },
    /// The app saved the room file; `message` says what was written.
    Saved {
        /// Status message from [`crate::tui::save::save_room`].
        message: String,
        /// Every light's photometric source as now written (a light whose edited curve went
        /// to a new file points at it; one written inline is inline).
        sources: Vec<LidSource>,
    },
    /// The answer to [`Effect::LoadLid`]: the file at `path`, or why it could not be read.
    LidLoaded {
        /// The file, as resolved.
        path: PathBuf,
        /// What the editor keeps of it, or the error in one line.
        result: Result<Arc<LidInfo>, String>,
    },
    /// The engine's numbers after its latest batch of edits.
    Numbers(Box<PanelNumbers>),
    /// The report was written; `message` says where.
    Reported {
        /// Status message.
        message: String,
    },
    /// The engine or the save failed; `message` is one line for the user.
    Failed {
        /// What went wrong.
        message: String,
    },
    /// The save was refused and wrote nothing; the editor offers `offer`.
    SaveRefused {
        /// Why, one line.
        reason: String,
        /// What the user may do instead.
        offer: SaveOffer,
    },
}

/// What the editor offers after a refused save (docs/DECISIONS.md "Saving").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SaveOffer {
    /// The file changed on disk since it was read: overwrite (writing edited file curves as
    /// `curves` says), reload or save as.
    OverwriteReloadOrSaveAs {
        /// How the refused save wrote edited file curves.
        curves: CurveSave,
    },
    /// The file cannot be replaced (read-only, hard-linked): save as another file.
    SaveAs,
}

/// Work the app carries out for the editor; its results come back as [`Msg`]s.
#[derive(Debug, Clone, PartialEq)]
pub enum Effect {
    /// The engine applies this command (the model already has): it relights what the command
    /// changed and renders a new frame.
    Engine(Command),
    /// The frame the model shows changed (size, display mode, selection, aim cursor): render it.
    Render,
    /// Find the 3D point under preview `pixel`; answer with [`Msg::Picked`].
    Pick {
        /// Preview pixel (0, 0 = top-left).
        pixel: (u32, u32),
        /// True to aim the selected light at it.
        aim: bool,
    },
    /// Save the room file ([`crate::tui::save::save_curves_to`]), edited file curves as
    /// `curves` says; `overwrite` writes over a change made on disk since it was read. Answered
    /// with [`Msg::Saved`], [`Msg::SaveRefused`] or [`Msg::Failed`].
    Save {
        /// How edited file curves are written.
        curves: CurveSave,
        /// True when the user chose to overwrite a change on disk.
        overwrite: bool,
    },
    /// Save the room as the file typed (relative to the room file's folder; edited file curves
    /// inline); the editor then edits that file. Answered as [`Effect::Save`].
    SaveAs(String),
    /// Read the room file again, dropping the edits (the user chose "reload").
    Reload,
    /// Read the photometric file the user typed (relative to the room file); answer with
    /// [`Msg::LidLoaded`].
    LoadLid(String),
    /// Write the report next to the room file; answer with [`Msg::Reported`] or [`Msg::Failed`].
    Report,
    /// Leave the editor.
    /// Give the terminal back and stop the process until the shell continues it.
    Suspend,
    Quit,
}

/// How a save writes a curve that came from a photometric file and was edited.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CurveSave {
    /// As a new IES file next to the room file, which the light's `lid_file` then names.
    NewFiles,
    /// Inline (`lid = […]` in place of `lid_file`).
    Inline,
}
