//! The recovery file (docs/DECISIONS.md "Terminal"): when the editor is stopped by a signal with
//! unsaved edits, the room text as it would have been saved goes to `ROOM.recovery` next to the
//! room file (`rooms/office.toml` → `rooms/office.toml.recovery`), and the next `haiko edit` of
//! that room offers to restore it.
//!
//! Format: three comment lines, then the room text, so the file is itself a valid room file:
//!
//! ```text
//! # haiko recovery file: unsaved edits of office.toml, written on SIGHUP.
//! # haiko-recovery v1 reason=SIGHUP time=1764600000 base=fnv1a64:cbf29ce484222325
//! # `haiko edit office.toml` offers to restore them; delete this file to discard them.
//! [room]
//! …
//! ```
//!
//! `time` is the writing time in seconds since the Unix epoch, `base` a 64-bit FNV-1a hash of
//! the room file's text the edits were made on (so the offer can say when the room file changed
//! since). The module takes the text to write and knows nothing of the editor's model.

use std::fs;
use std::io::{self, BufRead, Write};
use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

use crate::error::{Error, Result};
use crate::fsio;

/// Appended to the room file's name.
pub const SUFFIX: &str = ".recovery";
/// The header's machine-readable line starts with this.
const TAG: &str = "# haiko-recovery v1 ";
/// Lines of header before the room text.
const HEADER_LINES: usize = 3;

/// The recovery file of `room`: `ROOM.recovery` next to it.
pub fn path_for(room: &Path) -> PathBuf {
    let mut name = room.as_os_str().to_owned();
    name.push(SUFFIX);
    PathBuf::from(name)
}

/// The 64-bit FNV-1a hash of `text` (the file-content hash of `fsio`).
pub fn fnv1a64(text: &str) -> u64 {
    fsio::content_hash(text.as_bytes())
}

/// A recovery file read back.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Recovery {
    /// Where it is.
    pub path: PathBuf,
    /// Why it was written (e.g. `SIGHUP`).
    pub reason: String,
    /// When, seconds since the Unix epoch.
    pub time: u64,
    /// [`fnv1a64`] of the room text the edits were made on.
    pub base: u64,
    /// The room text with the edits.
    pub text: String,
}

impl Recovery {
    /// True when the room file's text now (`current`) is not the one the edits were made on.
    pub fn room_changed_since(&self, current: &str) -> bool {
        fnv1a64(current) != self.base
    }

    /// One line for the restore offer, e.g. `unsaved edits from 5 min ago (SIGHUP)`, `now`
    /// being the current time in seconds since the Unix epoch.
    pub fn summary(&self, now: u64) -> String {
        let age = now.saturating_sub(self.time);
        let ago = match age {
            0..60 => format!("{age} s ago"),
            60..7200 => format!("{} min ago", age / 60),
            7200..172_800 => format!("{} h ago", age / 3600),
            _ => format!("{} days ago", age / 86_400),
        };
        format!("unsaved edits from {ago} ({})", self.reason)
    }
}

/// Seconds since the Unix epoch now (0 if the clock is before it).
pub fn now() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_secs())
}

/// The recovery file's contents for `edited` (the room text with the edits), made on the room
/// text whose hash is `base`, written at `time` for `reason`.
pub fn contents(room: &Path, edited: &str, base: u64, reason: &str, time: u64) -> String {
    let name = room.file_name().map_or_else(
        || room.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    format!(
        "# haiko recovery file: unsaved edits of {name}, written on {reason}.\n\
         {TAG}reason={reason} time={time} base=fnv1a64:{base:016x}\n\
         # `haiko edit {name}` offers to restore them; delete this file to discard them.\n\
         {edited}"
    )
}

/// Writes the recovery file of `room` (atomically) and returns its path.
///
/// Errors (internal): the file cannot be written (named in the message).
pub fn write(room: &Path, edited: &str, base: u64, reason: &str) -> Result<PathBuf> {
    let path = path_for(room);
    fsio::write_atomic(&path, contents(room, edited, base, reason, now()).as_bytes())?;
    Ok(path)
}

/// Parses a recovery file's text read from `path`.
///
/// Errors (bad input): the header is missing or broken (the file and line are named).
pub fn parse(path: &Path, text: &str) -> Result<Recovery> {
    let broken = |message: &str| Error::input(path, "line 2", message.to_string());
    let mut lines = text.splitn(HEADER_LINES + 1, '\n');
    let _title = lines.next();
    let tag = lines
        .next()
        .and_then(|l| l.strip_prefix(TAG))
        .ok_or_else(|| broken("not a haiko recovery file (no `# haiko-recovery v1` line)"))?;
    let _note = lines.next();
    let body = lines.next().unwrap_or("");
    let field = |key: &str| {
        tag.split_whitespace()
            .find_map(|kv| kv.strip_prefix(key)?.strip_prefix('='))
            .ok_or_else(|| broken(&format!("the header has no `{key}=`")))
    };
    let time = field("time")?
        .parse()
        .map_err(|_| broken("`time=` is not a number of seconds"))?;
    let base = field("base")?
        .strip_prefix("fnv1a64:")
        .and_then(|h| u64::from_str_radix(h, 16).ok())
        .ok_or_else(|| broken("`base=` is not `fnv1a64:` and 16 hex digits"))?;
    Ok(Recovery {
        path: path.to_path_buf(),
        reason: field("reason")?.to_string(),
        time,
        base,
        text: body.to_string(),
    })
}

/// The recovery file of `room`, if there is one.
///
/// Errors (bad input): it exists but cannot be read or parsed.
pub fn find(room: &Path) -> Result<Option<Recovery>> {
    let path = path_for(room);
    match fs::read_to_string(&path) {
        Ok(text) => parse(&path, &text).map(Some),
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(Error::unreadable(&path, &e)),
    }
}

/// What the user chose when offered a recovery file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Answer {
    /// Open the room with the recovered edits (unsaved until `s`).
    Restore,
    /// Delete the recovery file and open the room as saved.
    Discard,
    /// Keep the file for later and open the room as saved.
    Keep,
}

/// Offers `found` (the room file's text now being `room_text`) on `output` and reads the
/// answer, one line, from `input`: `y` restores, `n` discards, anything else (Enter, end of
/// input) keeps the file.
///
/// Errors: reading or writing failed.
pub fn ask(
    found: &Recovery,
    room_text: &str,
    input: &mut impl BufRead,
    output: &mut impl Write,
) -> io::Result<Answer> {
    let changed = if found.room_changed_since(room_text) {
        "; the room file changed since, restoring replaces those changes"
    } else {
        ""
    };
    write!(
        output,
        "haiko: {} are kept in {}{changed}.\nRestore them? [y] restore  [n] discard  [Enter] keep the file, open the room as saved: ",
        found.summary(now()),
        found.path.display()
    )?;
    output.flush()?;
    let mut line = String::new();
    input.read_line(&mut line)?;
    Ok(match line.trim().to_ascii_lowercase().as_str() {
        "y" | "yes" => Answer::Restore,
        "n" | "no" => Answer::Discard,
        _ => Answer::Keep,
    })
}

/// Deletes the recovery file of `room` (nothing if there is none).
///
/// Errors (bad input): it exists and cannot be deleted.
pub fn discard(room: &Path) -> Result<()> {
    let path = path_for(room);
    match fs::remove_file(&path) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(Error::input(&path, "", format!("cannot delete: {e}"))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ROOM: &str = "# my office\n[room]\nsize = [6.0, 4.0, 2.7]\n";
    const EDITED: &str = "# my office\n[room]\nsize = [6.0, 4.0, 2.7]\n\n[[light]]\ndimmer = 0.5\n";

    #[test]
    fn the_recovery_file_sits_next_to_the_room() {
        assert_eq!(
            path_for(Path::new("rooms/office.toml")),
            Path::new("rooms/office.toml.recovery")
        );
        assert_eq!(
            path_for(Path::new("office.toml")),
            Path::new("office.toml.recovery")
        );
    }

    #[test]
    fn fnv1a64_matches_the_reference_values() {
        // The FNV-1a test vectors: "" → offset basis, "a" → 0xaf63dc4c8601ec8c.
        assert_eq!(fnv1a64(""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a64("a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a64("foobar"), 0x8594_4171_f739_67e8);
    }

    #[test]
    fn contents_round_trip_and_keep_the_room_text_byte_for_byte() {
        let base = fnv1a64(ROOM);
        let text = contents(
            Path::new("rooms/office.toml"),
            EDITED,
            base,
            "SIGHUP",
            1_764_600_000,
        );
        assert!(
            text.starts_with("# haiko recovery file: unsaved edits of office.toml, written on SIGHUP.\n")
        );
        assert!(text.ends_with(EDITED));
        // The header is comments: the file parses as the same TOML as the edited room.
        let as_toml: toml::Table = text.parse().unwrap();
        assert_eq!(as_toml, EDITED.parse::<toml::Table>().unwrap());
        let recovery = parse(Path::new("x.recovery"), &text).unwrap();
        assert_eq!(
            recovery,
            Recovery {
                path: PathBuf::from("x.recovery"),
                reason: "SIGHUP".into(),
                time: 1_764_600_000,
                base,
                text: EDITED.into(),
            }
        );
        assert!(!recovery.room_changed_since(ROOM));
        assert!(recovery.room_changed_since(EDITED));
    }

    #[test]
    fn the_summary_says_how_old_and_why() {
        let recovery = parse(
            Path::new("r"),
            &contents(Path::new("a.toml"), EDITED, 1, "SIGTERM", 1000),
        )
        .unwrap();
        assert_eq!(recovery.summary(1042), "unsaved edits from 42 s ago (SIGTERM)");
        assert_eq!(
            recovery.summary(1000 + 300),
            "unsaved edits from 5 min ago (SIGTERM)"
        );
        assert_eq!(
            recovery.summary(1000 + 3 * 3600),
            "unsaved edits from 3 h ago (SIGTERM)"
        );
        assert_eq!(
            recovery.summary(1000 + 3 * 86_400),
            "unsaved edits from 3 days ago (SIGTERM)"
        );
    }

    #[test]
    fn a_broken_header_is_bad_input_naming_the_file() {
        let e = parse(Path::new("rooms/a.toml.recovery"), "[room]\n").unwrap_err();
        assert_eq!(e.exit_code(), 2);
        assert!(
            e.to_string()
                .starts_with("rooms/a.toml.recovery: line 2: not a haiko recovery file"),
            "{e}"
        );
        let e = parse(
            Path::new("r"),
            "# t\n# haiko-recovery v1 reason=X time=soon base=fnv1a64:00\n# n\n",
        )
        .unwrap_err();
        assert!(e.to_string().contains("`time=`"), "{e}");
    }

    #[test]
    fn write_find_and_discard_on_disk() {
        let dir = tempfile::tempdir().unwrap();
        let room = dir.path().join("office.toml");
        fs::write(&room, ROOM).unwrap();
        assert_eq!(find(&room).unwrap(), None);
        let written = write(&room, EDITED, fnv1a64(ROOM), "SIGTERM").unwrap();
        assert_eq!(written, dir.path().join("office.toml.recovery"));
        let found = find(&room).unwrap().expect("the file is found");
        assert_eq!((found.text.as_str(), found.reason.as_str()), (EDITED, "SIGTERM"));
        assert!(now().abs_diff(found.time) < 60);
        // The room file itself is untouched.
        assert_eq!(fs::read_to_string(&room).unwrap(), ROOM);
        discard(&room).unwrap();
        assert_eq!(find(&room).unwrap(), None);
        discard(&room).unwrap();
    }

    #[test]
    fn the_offer_names_the_file_and_reads_one_answer() {
        let found = Recovery {
            path: PathBuf::from("rooms/office.toml.recovery"),
            reason: "SIGHUP".into(),
            time: now(),
            base: fnv1a64("[room]\n"),
            text: "[room]\n# edited\n".into(),
        };
        for (typed, answer) in [
            ("y\n", Answer::Restore),
            ("Yes\n", Answer::Restore),
            ("n\n", Answer::Discard),
            ("\n", Answer::Keep),
            ("", Answer::Keep),
            ("maybe\n", Answer::Keep),
        ] {
            let mut shown = Vec::new();
            assert_eq!(
                ask(&found, "[room]\n", &mut typed.as_bytes(), &mut shown).unwrap(),
                answer,
                "{typed:?}"
            );
            let shown = String::from_utf8(shown).unwrap();
            assert!(shown.starts_with("haiko: unsaved edits from "), "{shown}");
            assert!(
                shown.contains(" s ago (SIGHUP) are kept in rooms/office.toml.recovery.\nRestore them?"),
                "{shown}"
            );
        }
        let mut shown = Vec::new();
        ask(
            &found,
            "[room]\n# changed by hand\n",
            &mut "\n".as_bytes(),
            &mut shown,
        )
        .unwrap();
        assert!(
            String::from_utf8(shown)
                .unwrap()
                .contains("the room file changed since")
        );
    }
}
