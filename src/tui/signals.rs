//! Stopping on a signal without losing the terminal or an edit (docs/DECISIONS.md "Terminal").
//!
//! SIGTERM, SIGHUP (the SSH session or the pane closed), SIGINT (sent by `kill`: in raw mode
//! Ctrl-C is a key) and SIGQUIT reach a watcher thread (signal-hook's iterator, no async
//! runtime). It writes the unsaved edits the app last left in [`PendingEdits`] to the recovery
//! file (`tui::recovery`), then takes the terminal back: the standard output lock is taken
//! from the app (waiting at most [`STDOUT_WAIT`] for a write in progress) so no further frame
//! follows, [`RESTORE`] is written, cooked mode is restored, and the process exits with
//! 128 + the signal's number. SIGTSTP from outside suspends the editor as Ctrl-Z does
//! ([`watch_suspend`]).

use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::sync::{Arc, Mutex, PoisonError};
use std::thread;
use std::time::Duration;

use ratatui::crossterm::terminal::disable_raw_mode;
use signal_hook::consts::signal::{SIGHUP, SIGINT, SIGQUIT, SIGSTOP, SIGTERM, SIGTSTP};
use signal_hook::iterator::Signals;

use crate::tui::recovery;

/// The signals that stop the editor.
pub const STOP_SIGNALS: [i32; 4] = [SIGTERM, SIGHUP, SIGINT, SIGQUIT];

/// How long the watcher waits for the app to finish a write to the terminal.
pub const STDOUT_WAIT: Duration = Duration::from_millis(500);

/// What puts the terminal back, whatever state a cut-off frame left it in: CAN ends any escape
/// sequence in progress (a sixel or kitty image cut short), ST ends a string; then the
/// synchronized update ends, the mouse modes crossterm enables are reset, the alternate screen
/// is left, attributes reset and the cursor shown.
pub const RESTORE: &str = concat!(
    "\x18\x1b\\",
    "\x1b[?2026l",
    "\x1b[?1006l\x1b[?1015l\x1b[?1003l\x1b[?1002l\x1b[?1000l",
    "\x1b[?1049l",
    "\x1b[0m\x1b[?25h",
);

/// The signal's name (`SIGTERM`); `signal N` for others.
pub fn name(signal: i32) -> String {
    match signal {
        SIGTERM => "SIGTERM".into(),
        SIGHUP => "SIGHUP".into(),
        SIGINT => "SIGINT".into(),
        SIGQUIT => "SIGQUIT".into(),
        other => format!("signal {other}"),
    }
}

/// The unsaved edits at this moment, shared between the app (which sets them after every
/// change and clears them on save) and the watcher.
#[derive(Debug, Clone, Default)]
pub struct PendingEdits {
    slot: Arc<Mutex<Option<Pending>>>,
}

/// Unsaved edits: the room text as it would be saved, and the hash of the text they were made on.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Pending {
    text: String,
    base: u64,
}

impl PendingEdits {
    /// Records the room text with the unsaved edits, made on the room text hashing to `base`
    /// ([`recovery::fnv1a64`]).
    pub fn set(&self, text: String, base: u64) {
        *self.slot.lock().unwrap_or_else(PoisonError::into_inner) = Some(Pending { text, base });
    }

    /// No unsaved edits (after a save).
    pub fn clear(&self) {
        *self.slot.lock().unwrap_or_else(PoisonError::into_inner) = None;
    }

    fn take(&self) -> Option<Pending> {
        self.slot.lock().unwrap_or_else(PoisonError::into_inner).take()
    }
}

/// What the watcher does on `signal`, short of exiting: the recovery file of `room` when there
/// are unsaved edits, then [`RESTORE`] to `terminal`. Returns the recovery file's path, if one
/// was written, and the message for the user (printed after the terminal is back).
pub fn stop(
    signal: i32,
    room: &Path,
    pending: &PendingEdits,
    terminal: &mut impl Write,
) -> (Option<PathBuf>, String) {
    let reason = name(signal);
    let (written, message) = match pending.take() {
        Some(edits) => match recovery::write(room, &edits.text, edits.base, &reason) {
            Ok(path) => (
                Some(path.clone()),
                format!(
                    "haiko: stopped by {reason}; unsaved edits kept in {}",
                    path.display()
                ),
            ),
            Err(e) => (
                None,
                format!("haiko: stopped by {reason}; the unsaved edits could not be kept: {e}"),
            ),
        },
        None => (None, format!("haiko: stopped by {reason}")),
    };
    terminal.write_all(RESTORE.as_bytes()).ok();
    terminal.flush().ok();
    (written, message)
}

/// Keeps the app from writing to the terminal again: a thread takes the standard output lock
/// and holds it until the process ends. False when a write held it longer than `wait`.
fn hold_stdout(wait: Duration) -> bool {
    let (taken, is_taken) = mpsc::channel();
    thread::spawn(move || {
        let _lock = io::stdout().lock();
        if taken.send(()).is_ok() {
            loop {
                thread::park();
            }
        }
    });
    is_taken.recv_timeout(wait).is_ok()
}

/// Starts the watcher thread for `room`.
///
/// Errors: the signal handlers could not be installed.
pub fn watch(room: PathBuf, pending: PendingEdits) -> io::Result<()> {
    let mut signals = Signals::new(STOP_SIGNALS)?;
    thread::spawn(move || {
        if let Some(signal) = signals.forever().next() {
            hold_stdout(STDOUT_WAIT);
            // Bypass std's buffered stdout (held above): straight to the terminal.
            let mut terminal = RawStdout;
            let (_, message) = stop(signal, &room, &pending, &mut terminal);
            disable_raw_mode().ok();
            let _ = writeln!(terminal, "{message}");
            std::process::exit(128 + signal);
        }
    });
    Ok(())
}

/// Starts a thread that turns SIGTSTP sent from outside (`kill -TSTP`; in raw mode Ctrl-Z is a
/// key) into a call of `suspend`, after which the app suspends as on Ctrl-Z: the terminal given
/// back, the process stopped, the screen drawn anew when the shell continues it. Without it the
/// default action would stop the process with the terminal still raw, on the alternate screen.
///
/// Errors: the signal handler could not be installed.
pub fn watch_suspend(suspend: impl Fn() + Send + 'static) -> io::Result<()> {
    let mut signals = Signals::new([SIGTSTP])?;
    thread::spawn(move || {
        for _ in signals.forever() {
            suspend();
        }
    });
    Ok(())
}

/// Stops the process as Ctrl-Z does outside raw mode; returns once the shell continues it.
/// SIGSTOP, since SIGTSTP is caught ([`watch_suspend`]).
///
/// Errors: the signal could not be raised.
pub fn stop_self() -> io::Result<()> {
    signal_hook::low_level::raise(SIGSTOP)
}

/// File descriptor 1, unbuffered and without std's lock.
struct RawStdout;

impl Write for RawStdout {
    fn write(&mut self, bytes: &[u8]) -> io::Result<usize> {
        rustix::io::write(io::stdout(), bytes).map_err(io::Error::from)
    }

    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use std::fs;

    use super::*;

    #[test]
    fn the_restore_sequence_leaves_every_mode_the_editor_enters() {
        // Cancel first, so the rest is read as commands even after a cut-off image.
        assert!(RESTORE.starts_with('\x18'));
        for mode in ["?1049l", "?25h", "?1000l", "?1002l", "?1003l", "?1006l", "?2026l"] {
            assert!(RESTORE.contains(&format!("\x1b[{mode}")), "{mode}");
        }
    }

    #[test]
    fn stopping_with_unsaved_edits_writes_the_recovery_file_then_restores() {
        let dir = tempfile::tempdir().unwrap();
        let room = dir.path().join("office.toml");
        fs::write(&room, "[room]\n").unwrap();
        let pending = PendingEdits::default();
        pending.set("[room]\n# edited\n".into(), recovery::fnv1a64("[room]\n"));
        let mut terminal = Vec::new();
        let (written, message) = stop(SIGHUP, &room, &pending, &mut terminal);
        assert_eq!(terminal, RESTORE.as_bytes());
        let path = written.expect("a recovery file");
        assert_eq!(path, dir.path().join("office.toml.recovery"));
        assert!(
            message.contains("SIGHUP") && message.contains("office.toml.recovery"),
            "{message}"
        );
        let found = recovery::find(&room).unwrap().unwrap();
        assert_eq!(
            (found.text.as_str(), found.reason.as_str()),
            ("[room]\n# edited\n", "SIGHUP")
        );
        assert!(!found.room_changed_since("[room]\n"));
    }

    #[test]
    fn stopping_without_edits_writes_no_file() {
        let dir = tempfile::tempdir().unwrap();
        let room = dir.path().join("office.toml");
        let pending = PendingEdits::default();
        pending.set("x".into(), 0);
        pending.clear();
        let mut terminal = Vec::new();
        let (written, message) = stop(SIGTERM, &room, &pending, &mut terminal);
        assert_eq!((written, message.as_str()), (None, "haiko: stopped by SIGTERM"));
        assert_eq!(terminal, RESTORE.as_bytes());
        assert!(!recovery::path_for(&room).exists());
    }

    #[test]
    fn signal_names() {
        assert_eq!(STOP_SIGNALS.map(name), ["SIGTERM", "SIGHUP", "SIGINT", "SIGQUIT"]);
        assert_eq!(name(SIGTERM), "SIGTERM");
        assert_eq!(SIGTERM + 128, 143);
    }
}
