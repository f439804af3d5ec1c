//! The crate's error type: every failure names the file and the place, and says whether the
//! user's input was at fault (exit code 2) or the program was (exit code 1).

use std::fmt;
use std::path::Path;

/// A failure with a one-line, user-facing message.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The user's input is wrong (a file, a flag, a value): exit code 2.
    #[error("{0}")]
    Input(InputError),
    /// The program failed on valid input (an I/O error writing output, a broken invariant):
    /// exit code 1.
    #[error("{0}")]
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
        match (self.file.is_empty(), self.place.is_empty()) {
            (false, false) => write!(f, "{}: {}: {}", self.file, self.place, self.message),
            (false, true) => write!(f, "{}: {}", self.file, self.message),
            (true, false) => write!(f, "{}: {}", self.place, self.message),
            (true, true) => write!(f, "{}", self.message),
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
