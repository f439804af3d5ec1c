//! Every key binding and its help text, in one table ([`BINDINGS`]) read by both the key
//! handler ([`lookup`]) and the help overlay and hint bar.

use std::fmt;

use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyModifiers};

/// Which table of bindings applies (one per [`crate::tui::model::Mode`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModeKind {
    /// Editing the curve.
    Normal,
    /// Aiming with the keyboard cursor.
    Aim,
    /// Moving the light.
    Move,
    /// The help overlay.
    Help,
    /// Typing an exact value.
    ValueEntry,
    /// Typing a file path.
    PathEntry,
    /// The prompt about edited file curves before a save.
    ConfirmSave,
    /// The unsaved-changes quit prompt.
    ConfirmQuit,
    /// The room file changed on disk since it was read: overwrite, reload or save as.
    SaveConflict,
    /// Typing the name of the file to save as.
    SaveAs,
}

impl ModeKind {
    /// Every mode, in the order the help overlay lists them.
    pub const ALL: [ModeKind; 10] = [
        ModeKind::Normal,
        ModeKind::Aim,
        ModeKind::Move,
        ModeKind::ValueEntry,
        ModeKind::PathEntry,
        ModeKind::Help,
        ModeKind::ConfirmSave,
        ModeKind::ConfirmQuit,
        ModeKind::SaveConflict,
        ModeKind::SaveAs,
    ];

    /// Heading of the mode's section in the help overlay.
    pub fn title(self) -> &'static str {
        match self {
            ModeKind::Normal => "Editing",
            ModeKind::Aim => "Aim mode (a)",
            ModeKind::Move => "Move mode (m)",
            ModeKind::ValueEntry => "Typing a value (=, %)",
            ModeKind::PathEntry => "Typing a file path (F)",
            ModeKind::ConfirmSave => "Save prompt (edited file curves)",
            ModeKind::Help => "Help",
            ModeKind::ConfirmQuit => "Quit prompt",
            ModeKind::SaveConflict => "File changed on disk",
            ModeKind::SaveAs => "Save as (S)",
        }
    }
}

/// A key (with modifiers) as written in the table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Key {
    /// A printable character (its Shift is part of the character: `K`, `<`).
    Char(char),
    /// A key without modifiers (arrows, Enter, Esc, Tab, PgUp…); BackTab is Shift-Tab.
    Code(KeyCode),
    /// A key with Shift.
    Shift(KeyCode),
    /// A character with Ctrl.
    Ctrl(char),
    /// A key with Ctrl.
    CtrlCode(KeyCode),
    /// Any digit or `.` (typing a number).
    Digit,
    /// Any printable character (typing text).
    AnyChar,
}

impl Key {
    /// True when the event is this key.
    pub fn matches(self, event: &KeyEvent) -> bool {
        let mods = event.modifiers;
        let plain_or_shift = (mods - KeyModifiers::SHIFT).is_empty();
        match self {
            Key::Char(c) => event.code == KeyCode::Char(c) && plain_or_shift,
            Key::Code(KeyCode::BackTab) => event.code == KeyCode::BackTab && plain_or_shift,
            Key::Code(code) => event.code == code && mods.is_empty(),
            Key::Shift(code) => event.code == code && mods == KeyModifiers::SHIFT,
            Key::Ctrl(c) => event.code == KeyCode::Char(c) && mods == KeyModifiers::CONTROL,
            Key::CtrlCode(code) => event.code == code && mods == KeyModifiers::CONTROL,
            Key::Digit => {
                matches!(event.code, KeyCode::Char(c) if c.is_ascii_digit() || c == '.') && plain_or_shift
            }
            Key::AnyChar => matches!(event.code, KeyCode::Char(c) if !c.is_control()) && plain_or_shift,
        }
    }
}

fn code_label(code: KeyCode) -> String {
    match code {
        KeyCode::Up => "↑".into(),
        KeyCode::Down => "↓".into(),
        KeyCode::Left => "←".into(),
        KeyCode::Right => "→".into(),
        KeyCode::PageUp => "PgUp".into(),
        KeyCode::PageDown => "PgDn".into(),
        KeyCode::BackTab => "Shift-Tab".into(),
        other => other.to_string(),
    }
}

impl fmt::Display for Key {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Key::Char(' ') => write!(f, "Space"),
            Key::Char(c) => write!(f, "{c}"),
            Key::Code(code) => write!(f, "{}", code_label(code)),
            Key::Shift(code) => write!(f, "Shift-{}", code_label(code)),
            Key::Ctrl(c) => write!(f, "Ctrl-{c}"),
            Key::CtrlCode(code) => write!(f, "Ctrl-{}", code_label(code)),
            Key::Digit => write!(f, "0-9 ."),
            Key::AnyChar => write!(f, "text"),
        }
    }
}

/// What a key does. Steps are in the units named by each variant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Action {
    /// Show or hide the help overlay.
    ToggleHelp,
    /// Turn the help's page by this many (negative: back).
    HelpPage(i8),
    /// Quit (asks first when there are unsaved changes).
    Quit,
    /// Suspend the editor to the shell (Ctrl-Z); it redraws when resumed.
    Suspend,
    /// Save the room file.
    Save,
    /// Save the room as another file (type its name).
    SaveAs,
    /// Save over a room file that changed on disk since it was read.
    Overwrite,
    /// Read the room file again, dropping the edits.
    Reload,
    /// Select the next light.
    NextLight,
    /// Select the previous light.
    PreviousLight,
    /// Select the next control point.
    NextPoint,
    /// Select the previous control point.
    PreviousPoint,
    /// Change the selected point's intensity by this fraction of the curve's peak (clamped at 0).
    Intensity(f64),
    /// Move the selected point's angle by this many degrees (clamped at its neighbours).
    Angle(f64),
    /// Insert a point halfway to the next one, on the curve (the shape is unchanged).
    InsertPoint,
    /// Delete the selected point.
    DeletePoint,
    /// Start typing an exact intensity (cd) for the selected point.
    EnterValue,
    /// Change the SH order by this many.
    Order(i32),
    /// Cycle the ringing window.
    CycleWindow,
    /// Change the dimmer by this amount (0.1 = 10 %), clamped at 0.
    Dimmer(f64),
    /// Toggle the false-colour preview.
    ToggleFalseColour,
    /// Make the photo this many stops brighter (negative: darker); automatic exposure becomes
    /// fixed at the room's exposure first.
    Exposure(f64),
    /// Switch between the fixed and the automatic photo exposure.
    ToggleAutoExposure,
    /// Choose the exposure and the false-colour lux range anew from the current light.
    RefitDisplay,
    /// Show or hide isolux lines.
    ToggleIsolux,
    /// Switch between the camera's view and the plan (top-down) view.
    TogglePlanView,
    /// The plan shows the work plane instead of the floor (and the plan is shown).
    ToggleWorkPlane,
    /// Enter aim mode.
    AimMode,
    /// Enter move mode.
    MoveMode,
    /// Undo the last edit.
    Undo,
    /// Redo the last undone edit.
    Redo,
    /// Orbit the camera around its target: yaw about world z, pitch about the camera's right
    /// axis (degrees).
    Orbit {
        /// Yaw, degrees (positive = counter-clockwise seen from above).
        yaw_deg: f64,
        /// Pitch, degrees (positive = look from higher up).
        pitch_deg: f64,
    },
    /// Pan the camera (eye and target) along its right and up axes, metres.
    Pan {
        /// Along the camera's right axis, m.
        right_m: f64,
        /// Along the camera's up axis, m.
        up_m: f64,
    },
    /// Scale the eye-to-target distance by this factor (< 1 = closer).
    Dolly(f64),
    /// Reset the camera to the room file's.
    ResetCamera,
    /// Move the aim cursor by this many steps of 1/40 (or 1/8 when `big`) of the preview.
    Cursor {
        /// Steps right (negative = left).
        dx: i32,
        /// Steps down (negative = up).
        dy: i32,
        /// 1/8 instead of 1/40 of the preview per step.
        big: bool,
    },
    /// Aim the light at the point under the cursor.
    AimHere,
    /// Move the light by this offset (world, m).
    MoveBy([f64; 3]),
    /// Leave the mode, keeping what was done.
    Finish,
    /// Leave the mode, undoing what it did.
    Cancel,
    /// Type the pressed character (a digit or `.` for a value).
    Type,
    /// Delete the last typed character.
    Backspace,
    /// Apply the typed value (or save under the typed name).
    Apply,
    /// Quit without saving.
    ConfirmQuit,
    /// Insert a copy of the selected light next to it.
    DuplicateLight,
    /// Delete the selected light.
    DeleteLight,
    /// Start typing a dimmer in percent (selected and marked lights).
    EnterDimmer,
    /// Start typing the path of a photometric file (selected and marked lights).
    EnterPath,
    /// Mark or unmark the selected light (edits apply to all marked lights).
    ToggleMark,
    /// Mark every light with the selected light's photometry (same file or equal curve).
    MarkSamePhotometry,
    /// Unmark every light.
    ClearMarks,
    /// Write the report (HTML) next to the room file.
    Report,
    /// Save, writing each edited file curve as a new IES file the light then points at.
    SaveCurveFiles,
    /// Save, writing each edited file curve inline.
    SaveInline,
}

/// One row of the table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Binding {
    /// The mode it applies in.
    pub mode: ModeKind,
    /// The keys (any of them) that trigger it.
    pub keys: &'static [Key],
    /// What it does.
    pub action: Action,
    /// Help text (help overlay).
    pub help: &'static str,
    /// Short text for the hint bar, if it is shown there.
    pub hint: Option<&'static str>,
}

impl Binding {
    /// The keys as shown to the user: `↑/k`.
    pub fn keys_label(&self) -> String {
        let labels: Vec<String> = self.keys.iter().map(Key::to_string).collect();
        labels.join("/")
    }
}

/// Intensity step of ↑/↓ (fraction of the peak).
pub const COARSE_INTENSITY_STEP: f64 = 0.05;
/// Intensity step with Shift (fraction of the peak).
pub const FINE_INTENSITY_STEP: f64 = 0.005;
/// Exposure step of `e`/`E`, stops (EV).
pub const EXPOSURE_STEP_EV: f64 = 0.5;
/// Move-mode step, metres.
pub const MOVE_STEP_M: f64 = 0.1;

const fn bind(
    mode: ModeKind,
    keys: &'static [Key],
    action: Action,
    help: &'static str,
    hint: Option<&'static str>,
) -> Binding {
    Binding {
        mode,
        keys,
        action,
        help,
        hint,
    }
}

use Action as A;
use Key::{Char as C, Code, Ctrl, CtrlCode, Shift};
use ModeKind::{
    Aim, ConfirmQuit, ConfirmSave, Help, Move, Normal, PathEntry, SaveAs, SaveConflict, ValueEntry,
};

/// Every key binding of the editor.
#[rustfmt::skip]
pub const BINDINGS: &[Binding] = &[
    bind(Normal, &[C('?')], A::ToggleHelp, "show this help", Some("help")),
    bind(Normal, &[C('q'), Ctrl('c')], A::Quit, "quit (asks if unsaved)", Some("quit")),
    bind(Normal, &[Ctrl('z')], A::Suspend, "suspend (fg resumes)", None),
    bind(Normal, &[C('s')], A::Save, "save the room file", Some("save")),
    bind(Normal, &[C('S')], A::SaveAs, "save as another file", None),
    bind(Normal, &[Code(KeyCode::Tab)], A::NextLight, "next light", Some("light")),
    bind(Normal, &[Code(KeyCode::BackTab)], A::PreviousLight, "previous light", None),
    bind(Normal, &[Code(KeyCode::Left), C('h')], A::PreviousPoint, "previous control point", None),
    bind(Normal, &[Code(KeyCode::Right), C('l')], A::NextPoint, "next control point", Some("point")),
    bind(Normal, &[Code(KeyCode::Up), C('k')], A::Intensity(COARSE_INTENSITY_STEP), "raise point 5 % of peak", Some("raise")),
    bind(Normal, &[Code(KeyCode::Down), C('j')], A::Intensity(-COARSE_INTENSITY_STEP), "lower point 5 % of peak", Some("lower")),
    bind(Normal, &[Shift(KeyCode::Up), C('K')], A::Intensity(FINE_INTENSITY_STEP), "raise point 0.5 % of peak", None),
    bind(Normal, &[Shift(KeyCode::Down), C('J')], A::Intensity(-FINE_INTENSITY_STEP), "lower point 0.5 % of peak", None),
    bind(Normal, &[C('<')], A::Angle(-1.0), "point angle −1°", None),
    bind(Normal, &[C('>')], A::Angle(1.0), "point angle +1°", None),
    bind(Normal, &[C(',')], A::Angle(-5.0), "point angle −5°", None),
    bind(Normal, &[C('.')], A::Angle(5.0), "point angle +5°", None),
    bind(Normal, &[C('+')], A::InsertPoint, "insert a point after it", None),
    bind(Normal, &[C('-')], A::DeletePoint, "delete the point", None),
    bind(Normal, &[C('=')], A::EnterValue, "type an exact value (cd)", Some("value")),
    bind(Normal, &[C('o')], A::Order(-1), "SH order −1", None),
    bind(Normal, &[C('O')], A::Order(1), "SH order +1", None),
    bind(Normal, &[C('w')], A::CycleWindow, "cycle ringing window", None),
    bind(Normal, &[C('d')], A::Dimmer(-0.1), "dimmer −10 %", None),
    bind(Normal, &[C('D')], A::Dimmer(0.1), "dimmer +10 %", None),
    bind(Normal, &[C('a')], A::AimMode, "aim with a cursor", Some("aim")),
    bind(Normal, &[C('m')], A::MoveMode, "move the light", Some("move")),
    bind(Normal, &[C('u')], A::Undo, "undo", Some("undo")),
    bind(Normal, &[Ctrl('r')], A::Redo, "redo", None),
    bind(Normal, &[C('f')], A::ToggleFalseColour, "photo / false colour", None),
    bind(Normal, &[C('e')], A::Exposure(EXPOSURE_STEP_EV), "photo ½ stop brighter", None),
    bind(Normal, &[C('E')], A::Exposure(-EXPOSURE_STEP_EV), "photo ½ stop darker", None),
    bind(Normal, &[C('x')], A::ToggleAutoExposure, "fixed / automatic exposure", None),
    bind(Normal, &[C('r')], A::RefitDisplay, "refit exposure and scale", None),
    bind(Normal, &[C('i')], A::ToggleIsolux, "isolux lines on / off", None),
    bind(Normal, &[C('p')], A::TogglePlanView, "plan view / camera view", None),
    bind(Normal, &[C('P')], A::ToggleWorkPlane, "plan of the floor / of the work plane", None),
    bind(Normal, &[C('[')], A::Orbit { yaw_deg: -5.0, pitch_deg: 0.0 }, "camera orbit left 5°", None),
    bind(Normal, &[C(']')], A::Orbit { yaw_deg: 5.0, pitch_deg: 0.0 }, "camera orbit right 5°", None),
    bind(Normal, &[C('{')], A::Orbit { yaw_deg: 0.0, pitch_deg: -5.0 }, "camera orbit down 5°", None),
    bind(Normal, &[C('}')], A::Orbit { yaw_deg: 0.0, pitch_deg: 5.0 }, "camera orbit up 5°", None),
    bind(Normal, &[CtrlCode(KeyCode::Left)], A::Pan { right_m: -0.1, up_m: 0.0 }, "camera pan left 0.1 m", None),
    bind(Normal, &[CtrlCode(KeyCode::Right)], A::Pan { right_m: 0.1, up_m: 0.0 }, "camera pan right 0.1 m", None),
    bind(Normal, &[CtrlCode(KeyCode::Up)], A::Pan { right_m: 0.0, up_m: 0.1 }, "camera pan up 0.1 m", None),
    bind(Normal, &[CtrlCode(KeyCode::Down)], A::Pan { right_m: 0.0, up_m: -0.1 }, "camera pan down 0.1 m", None),
    bind(Normal, &[Code(KeyCode::PageUp)], A::Dolly(0.9), "camera closer 10 %", None),
    bind(Normal, &[Code(KeyCode::PageDown)], A::Dolly(1.0 / 0.9), "camera farther 10 %", None),
    bind(Normal, &[C('c')], A::ResetCamera, "reset the camera", None),
    bind(Normal, &[C('%')], A::EnterDimmer, "type the dimmer (%)", Some("dimmer")),
    bind(Normal, &[C('y')], A::DuplicateLight, "duplicate the light", None),
    bind(Normal, &[C('X')], A::DeleteLight, "delete the light", None),
    bind(Normal, &[C('F')], A::EnterPath, "load an IES/LDT file", None),
    bind(Normal, &[C(' ')], A::ToggleMark, "mark for group edits", None),
    bind(Normal, &[C('*')], A::MarkSamePhotometry, "mark same-file lights", None),
    bind(Normal, &[Code(KeyCode::Esc)], A::ClearMarks, "unmark all lights", None),
    bind(Normal, &[C('R')], A::Report, "write the report (HTML)", None),
    bind(Aim, &[Code(KeyCode::Left)], A::Cursor { dx: -1, dy: 0, big: false }, "cursor left 1/40", None),
    bind(Aim, &[Code(KeyCode::Right)], A::Cursor { dx: 1, dy: 0, big: false }, "cursor right 1/40", None),
    bind(Aim, &[Code(KeyCode::Up)], A::Cursor { dx: 0, dy: -1, big: false }, "cursor up 1/40", None),
    bind(Aim, &[Code(KeyCode::Down)], A::Cursor { dx: 0, dy: 1, big: false }, "cursor down 1/40", None),
    bind(Aim, &[Shift(KeyCode::Left)], A::Cursor { dx: -1, dy: 0, big: true }, "cursor left 1/8", None),
    bind(Aim, &[Shift(KeyCode::Right)], A::Cursor { dx: 1, dy: 0, big: true }, "cursor right 1/8", None),
    bind(Aim, &[Shift(KeyCode::Up)], A::Cursor { dx: 0, dy: -1, big: true }, "cursor up 1/8", None),
    bind(Aim, &[Shift(KeyCode::Down)], A::Cursor { dx: 0, dy: 1, big: true }, "cursor down 1/8", None),
    bind(Aim, &[Code(KeyCode::Enter)], A::AimHere, "aim at the cursor", Some("aim here")),
    bind(Aim, &[Code(KeyCode::Esc)], A::Cancel, "cancel", Some("cancel")),
    bind(Move, &[Code(KeyCode::Left)], A::MoveBy([-MOVE_STEP_M, 0.0, 0.0]), "x −0.1 m", None),
    bind(Move, &[Code(KeyCode::Right)], A::MoveBy([MOVE_STEP_M, 0.0, 0.0]), "x +0.1 m", None),
    bind(Move, &[Code(KeyCode::Down)], A::MoveBy([0.0, -MOVE_STEP_M, 0.0]), "y −0.1 m", None),
    bind(Move, &[Code(KeyCode::Up)], A::MoveBy([0.0, MOVE_STEP_M, 0.0]), "y +0.1 m", None),
    bind(Move, &[Code(KeyCode::PageDown)], A::MoveBy([0.0, 0.0, -MOVE_STEP_M]), "z −0.1 m", None),
    bind(Move, &[Code(KeyCode::PageUp)], A::MoveBy([0.0, 0.0, MOVE_STEP_M]), "z +0.1 m", None),
    bind(Move, &[Code(KeyCode::Enter), C('m')], A::Finish, "done (re-bakes the light)", Some("done")),
    bind(Move, &[Code(KeyCode::Esc)], A::Cancel, "cancel", Some("cancel")),
    bind(ValueEntry, &[Key::Digit, C('%')], A::Type, "type the number", None),
    bind(ValueEntry, &[Code(KeyCode::Backspace)], A::Backspace, "delete a character", None),
    bind(ValueEntry, &[Code(KeyCode::Enter)], A::Apply, "apply", Some("apply")),
    bind(ValueEntry, &[Code(KeyCode::Esc)], A::Cancel, "cancel", Some("cancel")),
    bind(PathEntry, &[Key::AnyChar], A::Type, "type the path", None),
    bind(PathEntry, &[Code(KeyCode::Backspace)], A::Backspace, "delete a character", None),
    bind(PathEntry, &[Code(KeyCode::Enter)], A::Apply, "load the file", Some("load")),
    bind(PathEntry, &[Code(KeyCode::Esc)], A::Cancel, "cancel", Some("cancel")),
    bind(ConfirmSave, &[Code(KeyCode::Enter), C('w')], A::SaveCurveFiles, "new IES files (default)", Some("new files")),
    bind(ConfirmSave, &[C('i')], A::SaveInline, "inline curves", Some("inline")),
    bind(ConfirmSave, &[Code(KeyCode::Esc)], A::Cancel, "do not save", Some("cancel")),
    bind(Help, &[C('?'), Code(KeyCode::Esc), C('q')], A::ToggleHelp, "close the help", Some("close")),
    bind(Help, &[Code(KeyCode::PageDown), C(' '), Code(KeyCode::Down), C('j')], A::HelpPage(1), "next page", Some("next page")),
    bind(Help, &[Code(KeyCode::PageUp), Code(KeyCode::Up), C('k')], A::HelpPage(-1), "previous page", Some("previous")),
    bind(ConfirmQuit, &[C('y')], A::ConfirmQuit, "quit without saving", Some("quit")),
    bind(ConfirmQuit, &[C('n'), Code(KeyCode::Esc)], A::Cancel, "keep editing", Some("cancel")),
    bind(SaveConflict, &[C('o')], A::Overwrite, "overwrite with yours", Some("overwrite")),
    bind(SaveConflict, &[C('r')], A::Reload, "reload (drops the edits)", Some("reload")),
    bind(SaveConflict, &[C('a')], A::SaveAs, "save as another file", Some("save as")),
    bind(SaveConflict, &[Code(KeyCode::Esc)], A::Cancel, "keep editing", Some("cancel")),
    bind(SaveAs, &[Key::AnyChar], A::Type, "type the file name", None),
    bind(SaveAs, &[Code(KeyCode::Backspace)], A::Backspace, "delete a character", None),
    bind(SaveAs, &[Code(KeyCode::Enter)], A::Apply, "save under that name", Some("save")),
    bind(SaveAs, &[Code(KeyCode::Esc)], A::Cancel, "cancel", Some("cancel")),
];

/// The action bound to `event` in `mode`, if any.
pub fn lookup(mode: ModeKind, event: &KeyEvent) -> Option<Action> {
    BINDINGS
        .iter()
        .find(|b| b.mode == mode && b.keys.iter().any(|k| k.matches(event)))
        .map(|b| b.action)
}

/// The bindings of one mode, in table order.
pub fn bindings_of(mode: ModeKind) -> impl Iterator<Item = &'static Binding> {
    BINDINGS.iter().filter(move |b| b.mode == mode)
}

/// The hint bar text for a mode: `↑/k raise · ↓/j lower · …`.
pub fn hint_line(mode: ModeKind) -> String {
    let parts: Vec<String> = bindings_of(mode)
        .filter_map(|b| b.hint.map(|h| format!("{} {h}", b.keys_label())))
        .collect();
    parts.join(" · ")
}
