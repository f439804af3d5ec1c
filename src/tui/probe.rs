//! Asking the terminal what it can show (docs/DECISIONS.md "Terminal graphics"): one burst of
//! queries, read back with a deadline, so no thread is left behind reading the keyboard (the
//! first key press is never swallowed, even when nothing answers, e.g. in a detached tmux).
//!
//! The queries: the kitty graphics query (plain and zlib-compressed), XTVERSION (the terminal's
//! name), the device attributes (sixel is attribute 4), the cell size in pixels (`CSI 16 t`),
//! and a device status report last, which every terminal answers, as the end marker. Inside
//! tmux with passthrough the kitty queries, XTVERSION and a second status report go to the
//! outer terminal wrapped in `ESC P tmux; … ESC \`, while the device attributes and the cell
//! size are asked of tmux itself (tmux 3.4+ answers for its own sixel support).

use std::io::{self, Write};
use std::time::{Duration, Instant};

use rustix::event::{PollFd, PollFlags, Timespec, poll};

use crate::tui::multiplexer::{Answers, Multiplexer};

/// How long to wait for the first end marker.
pub const TIMEOUT: Duration = Duration::from_millis(1000);
/// How long to wait for the outer terminal's end marker once tmux has answered.
pub const OUTER_TIMEOUT: Duration = Duration::from_millis(300);

/// The kitty graphics query: a 1 × 1 RGB image, query only (`a=q`), id 31.
const KITTY_QUERY: &str = "\x1b_Gi=31,s=1,v=1,a=q,t=d,f=24;AAAA\x1b\\";
/// The same with the payload zlib-compressed (`o=z`), id 32.
const KITTY_ZLIB_QUERY: &str = "\x1b_Gi=32,s=1,v=1,a=q,t=d,f=24,o=z;eJxjYGAAAAADAAE=\x1b\\";
/// XTVERSION.
const VERSION_QUERY: &str = "\x1b[>0q";
/// Primary device attributes.
const ATTRIBUTES_QUERY: &str = "\x1b[c";
/// The cell size in pixels.
const CELL_SIZE_QUERY: &str = "\x1b[16t";
/// Device status report: answered `ESC [ 0 n` by every terminal.
const STATUS_QUERY: &str = "\x1b[5n";

/// `sequence` wrapped for tmux passthrough: `ESC P tmux;`, every ESC doubled, `ESC \`.
pub fn wrap_for_tmux(sequence: &str) -> String {
    format!("\x1bPtmux;{}\x1b\\", sequence.replace('\x1b', "\x1b\x1b"))
}

/// The queries to write for `mux`, and how many end markers (status reports) to expect.
pub fn queries(mux: Multiplexer) -> (String, usize) {
    let outer = [KITTY_QUERY, KITTY_ZLIB_QUERY, VERSION_QUERY].concat();
    let own = [ATTRIBUTES_QUERY, CELL_SIZE_QUERY, STATUS_QUERY].concat();
    match mux {
        Multiplexer::Tmux { .. } if mux.passes_through() => {
            let wrapped = wrap_for_tmux(&[outer.as_str(), CELL_SIZE_QUERY, STATUS_QUERY].concat());
            (format!("{own}{wrapped}"), 2)
        }
        // tmux without passthrough: only tmux itself can answer.
        Multiplexer::Tmux { .. } => (own, 1),
        Multiplexer::None | Multiplexer::Screen => (format!("{outer}{own}"), 1),
    }
}

/// The answers found in `replies` and the number of end markers among them. Unknown
/// sequences and other bytes (keys typed meanwhile) are skipped.
pub fn parse(replies: &[u8]) -> (Answers, usize) {
    let mut answers = Answers::default();
    let mut markers = 0;
    let mut at = 0;
    while at < replies.len() {
        if replies[at] != 0x1b || at + 1 >= replies.len() {
            at += 1;
            continue;
        }
        let kind = replies[at + 1];
        let body_start = at + 2;
        match kind {
            b'[' => {
                // CSI: parameters up to a final byte in 0x40..=0x7e.
                let Some(len) = replies[body_start..]
                    .iter()
                    .position(|b| (0x40..=0x7e).contains(b))
                else {
                    break;
                };
                let params = &replies[body_start..body_start + len];
                let fin = replies[body_start + len];
                read_csi(params, fin, &mut answers, &mut markers);
                at = body_start + len + 1;
            }
            b'_' | b'P' => {
                // APC or DCS, up to the string terminator ESC \.
                let Some(len) = replies[body_start..].windows(2).position(|w| w == b"\x1b\\") else {
                    break;
                };
                let body = &replies[body_start..body_start + len];
                read_string(kind, body, &mut answers);
                at = body_start + len + 2;
            }
            _ => at += 2,
        }
    }
    (answers, markers)
}

fn read_csi(params: &[u8], fin: u8, answers: &mut Answers, markers: &mut usize) {
    let text = String::from_utf8_lossy(params);
    match fin {
        b'c' if text.starts_with('?') => {
            answers.sixel |= text[1..].split(';').any(|p| p == "4");
        }
        b't' => {
            let numbers: Vec<u16> = text.split(';').filter_map(|p| p.parse().ok()).collect();
            if let [6, height, width] = numbers[..]
                && width > 0
                && height > 0
            {
                answers.cell_px = Some((width, height));
            }
        }
        b'n' if text == "0" => *markers += 1,
        _ => {}
    }
}

fn read_string(kind: u8, body: &[u8], answers: &mut Answers) {
    let text = String::from_utf8_lossy(body);
    match kind {
        b'_' => {
            if let Some(rest) = text.strip_prefix('G') {
                let (keys, message) = rest.split_once(';').unwrap_or((rest, ""));
                let ok = message == "OK";
                for key in keys.split(',') {
                    match key {
                        "i=31" => answers.kitty |= ok,
                        "i=32" => answers.kitty_compression |= ok,
                        _ => {}
                    }
                }
            }
        }
        _ => {
            if let Some(version) = text.strip_prefix(">|") {
                answers.version = Some(version.to_string());
            }
        }
    }
}

/// Asks the terminal (in raw mode, before anything else reads the keyboard) and waits for the
/// answers: until every expected end marker arrived, [`TIMEOUT`] passed without one, or
/// [`OUTER_TIMEOUT`] passed after the first. Whatever arrived by then counts.
///
/// Errors: writing the queries or polling the keyboard failed.
pub fn ask(mux: Multiplexer) -> io::Result<Answers> {
    let (query, expected) = queries(mux);
    let mut stdout = io::stdout().lock();
    stdout.write_all(query.as_bytes())?;
    stdout.flush()?;
    drop(stdout);
    let stdin = io::stdin();
    let start = Instant::now();
    let mut deadline = start + TIMEOUT;
    let mut replies = Vec::new();
    let mut buffer = [0u8; 512];
    loop {
        let (answers, markers) = parse(&replies);
        if markers >= expected {
            return Ok(answers);
        }
        if markers > 0 {
            deadline = deadline.min(Instant::now() + OUTER_TIMEOUT);
        }
        let Some(left) = deadline.checked_duration_since(Instant::now()) else {
            return Ok(answers);
        };
        let timeout = Timespec {
            tv_sec: left.as_secs() as i64,
            tv_nsec: i64::from(left.subsec_nanos()),
        };
        let mut fds = [PollFd::new(&stdin, PollFlags::IN)];
        if poll(&mut fds, Some(&timeout))? == 0 {
            return Ok(answers);
        }
        let read = rustix::io::read(&stdin, &mut buffer)?;
        if read == 0 {
            return Ok(parse(&replies).0);
        }
        replies.extend_from_slice(&buffer[..read]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tui::multiplexer::{Passthrough, TmuxVersion};

    const TMUX_33: TmuxVersion = TmuxVersion { major: 3, minor: 3 };

    #[test]
    fn a_terminal_is_asked_everything_directly() {
        let (query, markers) = queries(Multiplexer::None);
        assert_eq!(markers, 1);
        assert!(query.starts_with(KITTY_QUERY));
        assert!(query.ends_with("\x1b[c\x1b[16t\x1b[5n"));
        assert!(!query.contains("tmux"));
    }

    #[test]
    fn tmux_with_passthrough_asks_the_outer_terminal_wrapped() {
        let mux = Multiplexer::Tmux {
            version: Some(TMUX_33),
            passthrough: Passthrough::On,
        };
        let (query, markers) = queries(mux);
        assert_eq!(markers, 2);
        // tmux's own questions first, unwrapped, then the wrapped ones with doubled escapes.
        assert!(
            query.starts_with("\x1b[c\x1b[16t\x1b[5n\x1bPtmux;\x1b\x1b_Gi=31,"),
            "{query:?}"
        );
        assert!(query.ends_with("\x1b\x1b[16t\x1b\x1b[5n\x1b\\"), "{query:?}");
        // Without passthrough only tmux is asked.
        let (query, markers) = queries(Multiplexer::Tmux {
            version: Some(TMUX_33),
            passthrough: Passthrough::Off,
        });
        assert_eq!((query.as_str(), markers), ("\x1b[c\x1b[16t\x1b[5n", 1));
    }

    #[test]
    fn xterm_answers_sixel_and_its_cell_size() {
        let (answers, markers) =
            parse(b"\x1b[>0|XTerm(379)\x1b\\\x1b[?63;1;2;4;6;9;15;16;22;28c\x1b[6;18;9t\x1b[0n");
        assert_eq!(markers, 1);
        assert!(answers.sixel && !answers.kitty);
        assert_eq!(answers.cell_px, Some((9, 18)));
    }

    #[test]
    fn kitty_answers_its_graphics_queries_and_version() {
        let replies =
            b"\x1b_Gi=31;OK\x1b\\\x1b_Gi=32;OK\x1b\\\x1bP>|kitty(0.32.2)\x1b\\\x1b[?62;c\x1b[6;20;10t\x1b[0n";
        let (answers, markers) = parse(replies);
        assert_eq!(markers, 1);
        assert!(answers.kitty && answers.kitty_compression && !answers.sixel);
        assert_eq!(answers.version.as_deref(), Some("kitty(0.32.2)"));
        assert_eq!(answers.cell_px, Some((10, 20)));
    }

    #[test]
    fn errors_and_other_bytes_are_not_answers() {
        let replies = b"j\x1b_Gi=31;ENOTSUPPORTED:no\x1b\\k\x1b[?1;2c\x1b[12;5R\x1b[0n\x1b[0n";
        let (answers, markers) = parse(replies);
        assert_eq!(markers, 2);
        assert_eq!(answers, Answers::default());
        // tmux 3.3 lists no 4; `?1;2;4c` from tmux 3.5 does.
        assert!(parse(b"\x1b[?1;2;4c").0.sixel);
        assert!(!parse(b"\x1b[?1;2;14c").0.sixel);
        // A cut-off sequence is not read.
        assert_eq!(parse(b"\x1b[6;18;9"), (Answers::default(), 0));
        assert_eq!(parse(b"\x1b_Gi=31;OK"), (Answers::default(), 0));
    }
}
