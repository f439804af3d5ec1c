//! The crate's error type: every failure names the file and the place, and says whether the
//! user's input was at fault (exit code 2) or the program was (exit code 1).
//!
//! Messages are one line: [`printable`] escapes control characters (and Unicode direction
//! overrides) in every part when an error is displayed, and file content is quoted only through
//! [`quoted`], which keeps at most [`MAX_QUOTED_CHARS`] characters of the offending token
//! (docs/DECISIONS.md, "Bad input").

use std::borrow::Cow;
use std::fmt;
use std::path::Path;
use std::sync::{Mutex, PoisonError};

/// A failure with a one-line, user-facing message.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The user's input is wrong (a file, a flag, a value): exit code 2.
    #[error("{0}")]
    Input(InputError),
    /// The program failed on valid input (an I/O error writing output, a broken invariant):
    /// exit code 1.
    #[error("{}", printable(.0))]
    Internal(String),
}

/// Bad input, located: `file: place: message` (the place may be empty).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct InputError {
    /// The file (or the command-line flag) the bad input came from, as the user wrote it.
    pub file: String,
    /// Where in it: `line 3, column 7`, `field light[1].lid`, `row 12`; may be empty.
    pub place: String,
    /// What is wrong, in words a lighting designer understands.
    pub message: String,
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (file, place, message) = (
            printable(&self.file),
            printable(&self.place),
            printable(&self.message),
        );
        match (file.is_empty(), place.is_empty()) {
            (false, false) => write!(f, "{file}: {place}: {message}"),
            (false, true) => write!(f, "{file}: {message}"),
            (true, false) => write!(f, "{place}: {message}"),
            (true, true) => write!(f, "{message}"),
        }
    }
}

impl Error {
    /// Bad input in `file` at `place` (may be empty).
    pub fn input(file: impl AsRef<Path>, place: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Input(InputError {
            file: file.as_ref().display().to_string(),
            place: place.into(),
            message: message.into(),
        })
    }

    /// An internal failure on valid input.
    pub fn internal(message: impl Into<String>) -> Self {
        Error::Internal(message.into())
    }

    /// A file the user named could not be read (missing, unreadable): bad input, exit code 2.
    pub fn unreadable(file: impl AsRef<Path>, err: &std::io::Error) -> Self {
        Error::input(file, "", format!("cannot read file: {err}"))
    }

    /// The process exit code for this error: 2 for bad input, 1 otherwise.
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::Input(_) => 2,
            Error::Internal(_) => 1,
        }
    }
}

/// The crate's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// The last panic's message and place, kept by [`install_panic_recorder`]'s hook.
static LAST_PANIC: Mutex<Option<String>> = Mutex::new(None);

/// Replaces the default panic report (several lines on standard error) by a record of the
/// message and its place, for [`take_recorded_panic`]: the command boundary
/// (`cli::catch_panics`) and the editor (a worker that stopped) turn it into one line. The
/// binary installs it once at start; hooks installed later (the editor's terminal restore) run
/// before it.
pub fn install_panic_recorder() {
    std::panic::set_hook(Box::new(|info| {
        let place = info
            .location()
            .map(|l| format!(" at {}:{}", l.file(), l.line()))
            .unwrap_or_default();
        let text = format!("{}{place}", panic_text(info.payload()));
        *LAST_PANIC.lock().unwrap_or_else(PoisonError::into_inner) = Some(text);
    }));
}

/// The last recorded panic (message and place), taken; `None` when none was recorded.
pub fn take_recorded_panic() -> Option<String> {
    LAST_PANIC.lock().unwrap_or_else(PoisonError::into_inner).take()
}

/// A panic payload's message (`panic!` gives a `&str` or a `String`).
pub fn panic_text(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| (*s).to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "a panic without a message".to_string())
}

/// Checks that every number of a result about to be printed is finite. The input ranges
/// (docs/ROOM_FILE.md "Limits") rule out a NaN or an infinity, so one here is Haiko's bug: an
/// internal error naming `what` (exit code 1), never a printed `NaN` or `inf`.
pub fn check_finite(what: &str, values: impl IntoIterator<Item = f64>) -> Result<()> {
    match values.into_iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(i) => Err(Error::internal(format!(
            "internal error: {what} (value {}) is not a finite number; nothing was printed \
             (please report this with the input files)",
            i + 1
        ))),
    }
}

/// The most characters of a file's content an error message quotes ([`quoted`]).
pub const MAX_QUOTED_CHARS: usize = 24;

/// `text` with every character that could break a one-line message or drive the terminal
/// escaped: C0/C1 control characters (newline as `\n`, tab as `\t`, carriage return as `\r`,
/// the others — ESC included — as `\u{1b}`) and the invisible Unicode format characters that
/// reorder or hide text (direction marks, embeddings, overrides and isolates, zero-width
/// characters, the byte-order mark), as `\u{202e}`. Everything else, backslashes included, is
/// kept, so escaping twice changes nothing. Names (lights, surfaces, files) go through this
/// wherever they are printed.
pub fn printable(text: &str) -> Cow<'_, str> {
    if !text.chars().any(needs_escape) {
        return Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 8);
    for c in text.chars() {
        match c {
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            c if needs_escape(c) => out.push_str(&format!("\\u{{{:x}}}", u32::from(c))),
            c => out.push(c),
        }
    }
    Cow::Owned(out)
}

/// Whether [`printable`] escapes `c`.
fn needs_escape(c: char) -> bool {
    c.is_control()
        || matches!(
            c,
            '\u{061c}' | '\u{200b}'..='\u{200f}' | '\u{2028}'..='\u{202e}' | '\u{2060}'..='\u{2069}' | '\u{feff}'
        )
}

/// A token from a file, for an error message: at most [`MAX_QUOTED_CHARS`] characters (an
/// ellipsis marks a cut), escaped with [`printable`], between backticks. Only for files already
/// recognised as the expected format: Haiko never quotes an arbitrary file.
pub fn quoted(token: &str) -> String {
    let mut chars = token.chars();
    let head: String = chars.by_ref().take(MAX_QUOTED_CHARS).collect();
    let cut = if chars.next().is_some() { "…" } else { "" };
    format!("`{}{cut}`", printable(&head))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn printable_escapes_controls_and_direction_overrides_only() {
        assert_eq!(printable("desk lamp"), "desk lamp");
        assert!(matches!(printable("plain"), Cow::Borrowed(_)));
        assert_eq!(printable("a\nb\tc\rd"), "a\\nb\\tc\\rd");
        assert_eq!(printable("\u{1b}[31mred"), "\\u{1b}[31mred");
        assert_eq!(printable("x\u{202e}y\u{9b}z"), "x\\u{202e}y\\u{9b}z");
        assert_eq!(printable("γ ≤ 90° C:\\path"), "γ ≤ 90° C:\\path");
        let once = printable("a\n\u{7}b").into_owned();
        assert_eq!(printable(&once), once, "idempotent");
    }

    #[test]
    fn quoted_keeps_a_short_escaped_token() {
        assert_eq!(quoted("12x"), "`12x`");
        assert_eq!(
            quoted("root:x:0:0:root:/root:/bin/bash"),
            "`root:x:0:0:root:/root:/b…`"
        );
        assert_eq!(quoted("a\u{1b}b"), "`a\\u{1b}b`");
    }

    #[test]
    fn non_finite_results_are_internal_errors() {
        assert!(check_finite("lux", [0.0, 1e300, -5.0]).is_ok());
        let e = check_finite("lux", [1.0, f64::NAN]).unwrap_err();
        assert_eq!(e.exit_code(), 1);
        assert_eq!(
            e.to_string(),
            "internal error: lux (value 2) is not a finite number; nothing was printed \
             (please report this with the input files)"
        );
        assert!(check_finite("E_max", [f64::INFINITY]).is_err());
    }

    #[test]
    fn displayed_errors_are_one_line() {
        let e = Error::input("room\n.toml", "line 2", "name `a\nb` is used twice");
        assert_eq!(e.to_string(), "room\\n.toml: line 2: name `a\\nb` is used twice");
        assert_eq!(Error::internal("x\ny").to_string(), "x\\ny");
    }
}
