//! Terminal multiplexers and what gets through them (docs/DECISIONS.md "Terminal graphics").
//!
//! tmux and GNU screen sit between the editor and the terminal: an image protocol the terminal
//! speaks may never reach the screen. [`choose`] decides, from the multiplexer ([`detect`]),
//! the terminal's answers to the graphics query ([`Answers`], see `tui::probe`) and the
//! user's `--graphics` choice, which protocol the preview uses and the one-line hint to show
//! when images cannot get through:
//!
//! * tmux 3.4 and newer decode sixel themselves and redraw it on the outer terminal, when built
//!   with sixel and the outer terminal is marked sixel-capable: tmux then lists sixel in its own
//!   answer to the device-attributes query. Sixel wrapped in passthrough bypasses tmux's
//!   decoder and is never used.
//! * kitty graphics with Unicode placeholders pass through tmux when `allow-passthrough` is on
//!   (always before tmux 3.3, which has no such option): the query itself goes through
//!   passthrough, so an answer proves the way is open.
//! * Otherwise, and always in GNU screen, the preview is drawn with half-blocks.
//!
//! A protocol forced with `--graphics` is used as asked, with a hint when it cannot reach the
//! screen.

use std::fmt;
use std::process::{Command, Stdio};

use crate::tui::terminal::Graphics;

/// A tmux version, `major.minor` (a letter suffix such as `3.3a` is dropped).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub struct TmuxVersion {
    /// Major version.
    pub major: u32,
    /// Minor version.
    pub minor: u32,
}

impl TmuxVersion {
    /// The first tmux that decodes sixel itself.
    pub const SIXEL: TmuxVersion = TmuxVersion { major: 3, minor: 4 };
    /// The first tmux with the `allow-passthrough` option (off by default).
    pub const PASSTHROUGH_OPTION: TmuxVersion = TmuxVersion { major: 3, minor: 3 };
}

impl fmt::Display for TmuxVersion {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}.{}", self.major, self.minor)
    }
}

/// tmux's `allow-passthrough` option for the editor's pane.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Passthrough {
    /// `off`: escape sequences wrapped for the outer terminal are dropped.
    Off,
    /// `on` or `all`, or a tmux older than 3.3 (no option: always allowed).
    On,
    /// tmux could not be asked.
    Unknown,
}

/// The multiplexer the editor runs in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Multiplexer {
    /// None: the editor talks to the terminal directly.
    None,
    /// tmux (`$TMUX` set), its version if `tmux -V` answered.
    Tmux {
        /// The server's version.
        version: Option<TmuxVersion>,
        /// `allow-passthrough` for the pane.
        passthrough: Passthrough,
    },
    /// GNU screen (`$STY` set).
    Screen,
}

impl Multiplexer {
    /// True inside tmux with passthrough allowed: escape sequences for the outer terminal
    /// are wrapped in `ESC P tmux; … ESC \`.
    pub fn passes_through(self) -> bool {
        matches!(
            self,
            Multiplexer::Tmux {
                passthrough: Passthrough::On,
                ..
            }
        )
    }
}

/// The environment variable tmux sets in its panes.
pub const TMUX_ENV: &str = "TMUX";
/// The environment variable GNU screen sets in its windows.
pub const SCREEN_ENV: &str = "STY";

/// `tmux -V`'s version: `tmux 3.3a` → 3.3, `tmux next-3.5` → 3.5; `None` for builds without
/// a number (`tmux master`).
pub fn parse_tmux_version(text: &str) -> Option<TmuxVersion> {
    let start = text.find(|c: char| c.is_ascii_digit())?;
    let mut parts = text[start..]
        .split(|c: char| !c.is_ascii_digit())
        .filter(|p| !p.is_empty());
    let major = parts.next()?.parse().ok()?;
    let minor = parts.next().and_then(|p| p.parse().ok()).unwrap_or(0);
    Some(TmuxVersion { major, minor })
}

/// `tmux show -Apv allow-passthrough`'s answer (`on`, `all`, `off`); `None` when the option is
/// unknown to this tmux (older than 3.3) or the answer is not one of those.
pub fn parse_passthrough(text: &str) -> Option<bool> {
    match text.trim() {
        "on" | "all" => Some(true),
        "off" => Some(false),
        _ => None,
    }
}

/// The multiplexer from the environment (`env` reads a variable) and, inside tmux, the answers
/// of `tmux` commands (`tmux` runs one with the given arguments and returns its standard
/// output, `None` when it failed).
pub fn detect(env: impl Fn(&str) -> Option<String>, tmux: impl Fn(&[&str]) -> Option<String>) -> Multiplexer {
    let set = |name: &str| env(name).is_some_and(|v| !v.is_empty());
    if set(TMUX_ENV) {
        let version = tmux(&["-V"]).as_deref().and_then(parse_tmux_version);
        let answer = tmux(&["show", "-Apv", "allow-passthrough"]);
        let passthrough = match answer.as_deref().and_then(parse_passthrough) {
            Some(true) => Passthrough::On,
            Some(false) => Passthrough::Off,
            None if version.is_some_and(|v| v < TmuxVersion::PASSTHROUGH_OPTION) => Passthrough::On,
            None => Passthrough::Unknown,
        };
        return Multiplexer::Tmux { version, passthrough };
    }
    if set(SCREEN_ENV) {
        return Multiplexer::Screen;
    }
    Multiplexer::None
}

/// [`detect`] on this process's environment, running the real `tmux`.
pub fn detect_here() -> Multiplexer {
    detect(
        |name| std::env::var(name).ok(),
        |args| {
            let output = Command::new("tmux")
                .args(args)
                .stdin(Stdio::null())
                .stderr(Stdio::null())
                .output()
                .ok()?;
            output
                .status
                .success()
                .then(|| String::from_utf8_lossy(&output.stdout).into_owned())
        },
    )
}

/// What the terminal (and the multiplexer) answered to the graphics query.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Answers {
    /// The device attributes list sixel (4). Inside tmux this is tmux's own answer.
    pub sixel: bool,
    /// The kitty graphics query was answered `OK` (inside tmux: through passthrough).
    pub kitty: bool,
    /// The zlib-compressed kitty query was answered `OK`.
    pub kitty_compression: bool,
    /// The terminal's name and version (XTVERSION, e.g. `kitty(0.26.5)`); inside tmux the
    /// outer terminal's, asked through passthrough.
    pub version: Option<String>,
    /// A cell's size in pixels (width, height).
    pub cell_px: Option<(u16, u16)>,
}

/// Hints from the environment about the terminal.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TerminalHints {
    /// A terminal known to show iTerm2 inline images (`TERM_PROGRAM` or `LC_TERMINAL` names
    /// iTerm2, WezTerm, mintty, VS Code, Tabby, Hyper or Rio).
    pub iterm2: bool,
    /// WezTerm or Konsole: their sixel and kitty support is incomplete (ratatui-image's list).
    pub broken_sixel_and_kitty: bool,
}

impl TerminalHints {
    /// The hints from the environment (`env` reads a variable).
    pub fn from_env(env: impl Fn(&str) -> Option<String>) -> TerminalHints {
        let set = |name: &str| env(name).is_some_and(|v| !v.is_empty());
        let program = [env("TERM_PROGRAM"), env("LC_TERMINAL")];
        let iterm2 = program.iter().flatten().any(|p| {
            ["iTerm", "WezTerm", "mintty", "vscode", "Tabby", "Hyper", "rio"]
                .iter()
                .any(|name| p.contains(name))
        });
        TerminalHints {
            iterm2,
            broken_sixel_and_kitty: set("WEZTERM_EXECUTABLE") || set("KONSOLE_VERSION"),
        }
    }
}

/// The image protocol the preview uses (after detection; never "auto").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Protocol {
    /// DEC sixel, written unwrapped (tmux ≥ 3.4 decodes it).
    Sixel,
    /// kitty graphics with Unicode placeholders.
    Kitty,
    /// iTerm2 inline images.
    Iterm2,
    /// Unicode half-blocks, text only.
    Halfblocks,
}

impl Protocol {
    /// The protocol's name for the status line.
    pub fn label(self) -> &'static str {
        match self {
            Protocol::Sixel => "sixel",
            Protocol::Kitty => "kitty",
            Protocol::Iterm2 => "iTerm2",
            Protocol::Halfblocks => "half-blocks",
        }
    }
}

/// The decision: the protocol, whether its sequences are wrapped for tmux passthrough, and the
/// hint to show once.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Choice {
    /// The protocol.
    pub protocol: Protocol,
    /// Wrap image sequences in `ESC P tmux; … ESC \` (kitty and iTerm2 inside tmux).
    pub passthrough: bool,
    /// One line for the user when images cannot reach the screen, or a forced protocol may not.
    pub hint: Option<String>,
}

/// The first kitty release with Unicode placeholders, which the kitty protocol here needs.
const KITTY_PLACEHOLDERS: (u32, u32) = (0, 28);

/// True unless the terminal calls itself kitty older than 0.28 (no Unicode placeholders).
fn kitty_has_placeholders(version: Option<&str>) -> bool {
    let Some(rest) = version.and_then(|v| v.strip_prefix("kitty(")) else {
        return true;
    };
    let mut numbers = rest
        .split(|c: char| !c.is_ascii_digit())
        .filter_map(|p| p.parse::<u32>().ok());
    match (numbers.next(), numbers.next()) {
        (Some(major), Some(minor)) => (major, minor) >= KITTY_PLACEHOLDERS,
        _ => true,
    }
}

/// Which protocol reaches the screen for `requested` (see the module docs).
pub fn choose(requested: Graphics, mux: Multiplexer, answers: &Answers, hints: TerminalHints) -> Choice {
    let kitty =
        answers.kitty && !hints.broken_sixel_and_kitty && kitty_has_placeholders(answers.version.as_deref());
    let sixel = answers.sixel && !hints.broken_sixel_and_kitty;
    let wrap = mux.passes_through();
    let choice = |protocol: Protocol, hint: Option<String>| Choice {
        protocol,
        passthrough: wrap && matches!(protocol, Protocol::Kitty | Protocol::Iterm2),
        hint,
    };
    let forced = match requested {
        Graphics::Auto => None,
        Graphics::Sixel => Some(Protocol::Sixel),
        Graphics::Kitty => Some(Protocol::Kitty),
        Graphics::Iterm2 => Some(Protocol::Iterm2),
        Graphics::Halfblocks => Some(Protocol::Halfblocks),
    };
    match mux {
        Multiplexer::None => match forced {
            Some(protocol) => choice(protocol, None),
            None if kitty => choice(Protocol::Kitty, None),
            None if hints.iterm2 => choice(Protocol::Iterm2, None),
            None if sixel => choice(Protocol::Sixel, None),
            None => choice(Protocol::Halfblocks, None),
        },
        Multiplexer::Screen => match forced {
            Some(Protocol::Halfblocks) => choice(Protocol::Halfblocks, None),
            Some(protocol) => choice(
                protocol,
                Some(format!(
                    "{} images may not get through GNU screen; without screen, or in tmux 3.4+, they do",
                    protocol.label()
                )),
            ),
            None => choice(
                Protocol::Halfblocks,
                Some(
                    "GNU screen passes no images: half-blocks; without screen, or in tmux 3.4+, images show"
                        .into(),
                ),
            ),
        },
        Multiplexer::Tmux { version, passthrough } => {
            let native_sixel = sixel && version.is_none_or(|v| v >= TmuxVersion::SIXEL);
            match forced {
                Some(Protocol::Halfblocks) => choice(Protocol::Halfblocks, None),
                Some(Protocol::Sixel) if !native_sixel => choice(
                    Protocol::Sixel,
                    Some(format!(
                        "tmux {} does not show sixel here: the preview may stay blank (--graphics auto)",
                        version_label(version)
                    )),
                ),
                Some(protocol @ (Protocol::Kitty | Protocol::Iterm2)) if passthrough != Passthrough::On => {
                    choice(
                        protocol,
                        Some(format!(
                            "{} images need `set -g allow-passthrough on` in tmux: the preview may stay blank",
                            protocol.label()
                        )),
                    )
                }
                Some(protocol) => choice(protocol, None),
                None if kitty && passthrough == Passthrough::On => choice(Protocol::Kitty, None),
                None if native_sixel => choice(Protocol::Sixel, None),
                None => choice(Protocol::Halfblocks, Some(tmux_hint(version, passthrough))),
            }
        }
    }
}

fn version_label(version: Option<TmuxVersion>) -> String {
    version.map_or_else(|| "(unknown version)".into(), |v| v.to_string())
}

/// How to get images in this tmux.
fn tmux_hint(version: Option<TmuxVersion>, passthrough: Passthrough) -> String {
    let old = version.is_some_and(|v| v < TmuxVersion::SIXEL);
    match (old, passthrough) {
        (true, Passthrough::On) => format!(
            "half-blocks: tmux {} cannot pass sixel; tmux 3.4+ (with sixel) or a kitty-graphics terminal shows images",
            version_label(version)
        ),
        (true, _) => format!(
            "half-blocks: tmux {} cannot pass sixel; use tmux 3.4+, or `set -g allow-passthrough on` with a kitty-graphics terminal",
            version_label(version)
        ),
        (false, Passthrough::On) => {
            "half-blocks: this tmux shows no sixel (built without it, or the terminal is not marked with `terminal-features`)".into()
        }
        (false, _) => {
            "half-blocks: for images in tmux, mark the terminal sixel-capable (`terminal-features`) or `set -g allow-passthrough on` (kitty)".into()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmux(major: u32, minor: u32, passthrough: Passthrough) -> Multiplexer {
        Multiplexer::Tmux {
            version: Some(TmuxVersion { major, minor }),
            passthrough,
        }
    }

    fn answers(sixel: bool, kitty: bool) -> Answers {
        Answers {
            sixel,
            kitty,
            cell_px: Some((9, 18)),
            ..Answers::default()
        }
    }

    const NO_HINTS: TerminalHints = TerminalHints {
        iterm2: false,
        broken_sixel_and_kitty: false,
    };

    #[test]
    fn tmux_versions_parse() {
        let v = |major, minor| Some(TmuxVersion { major, minor });
        assert_eq!(parse_tmux_version("tmux 3.3a\n"), v(3, 3));
        assert_eq!(parse_tmux_version("tmux 3.4"), v(3, 4));
        assert_eq!(parse_tmux_version("tmux next-3.6"), v(3, 6));
        assert_eq!(parse_tmux_version("tmux 2.9"), v(2, 9));
        assert_eq!(parse_tmux_version("tmux master"), None);
        assert!(v(3, 3) < v(3, 4) && v(2, 9) < v(3, 0) && v(3, 10) > v(3, 4));
    }

    #[test]
    fn the_environment_names_the_multiplexer() {
        let env = |pairs: &'static [(&'static str, &'static str)]| {
            move |name: &str| pairs.iter().find(|p| p.0 == name).map(|p| p.1.to_string())
        };
        let no_tmux = |_: &[&str]| None;
        assert_eq!(detect(env(&[]), no_tmux), Multiplexer::None);
        assert_eq!(
            detect(env(&[("STY", "123.pts-0.host")]), no_tmux),
            Multiplexer::Screen
        );
        assert_eq!(detect(env(&[("TMUX", "")]), no_tmux), Multiplexer::None);
        let answering = |version: &'static str, passthrough: Option<&'static str>| {
            move |args: &[&str]| match args {
                ["-V"] => Some(version.to_string()),
                ["show", "-Apv", "allow-passthrough"] => passthrough.map(str::to_string),
                _ => None,
            }
        };
        let inside = env(&[("TMUX", "/tmp/tmux-0/default,123,0"), ("STY", "x")]);
        assert_eq!(
            detect(inside, answering("tmux 3.3a", Some("off\n"))),
            tmux(3, 3, Passthrough::Off)
        );
        assert_eq!(
            detect(inside, answering("tmux 3.5a", Some("on\n"))),
            tmux(3, 5, Passthrough::On)
        );
        assert_eq!(
            detect(inside, answering("tmux 3.4", Some("all\n"))),
            tmux(3, 4, Passthrough::On)
        );
        // Before 3.3 there is no option, and passthrough is always allowed.
        assert_eq!(
            detect(inside, answering("tmux 3.2a", None)),
            tmux(3, 2, Passthrough::On)
        );
        assert_eq!(
            detect(inside, no_tmux),
            Multiplexer::Tmux {
                version: None,
                passthrough: Passthrough::Unknown
            }
        );
    }

    #[test]
    fn without_a_multiplexer_the_terminal_decides() {
        let auto = |a: &Answers, h| choose(Graphics::Auto, Multiplexer::None, a, h).protocol;
        assert_eq!(auto(&answers(true, false), NO_HINTS), Protocol::Sixel);
        assert_eq!(auto(&answers(true, true), NO_HINTS), Protocol::Kitty);
        assert_eq!(auto(&answers(false, false), NO_HINTS), Protocol::Halfblocks);
        let iterm = TerminalHints {
            iterm2: true,
            broken_sixel_and_kitty: false,
        };
        assert_eq!(auto(&answers(false, false), iterm), Protocol::Iterm2);
        let wezterm = TerminalHints {
            iterm2: true,
            broken_sixel_and_kitty: true,
        };
        assert_eq!(auto(&answers(true, true), wezterm), Protocol::Iterm2);
        let konsole = TerminalHints {
            iterm2: false,
            broken_sixel_and_kitty: true,
        };
        assert_eq!(auto(&answers(true, true), konsole), Protocol::Halfblocks);
        let choice = choose(Graphics::Auto, Multiplexer::None, &answers(true, false), NO_HINTS);
        assert_eq!((choice.passthrough, choice.hint), (false, None));
    }

    #[test]
    fn kitty_without_placeholders_is_not_used() {
        let mut old = answers(false, true);
        old.version = Some("kitty(0.26.5)".into());
        assert_eq!(
            choose(Graphics::Auto, Multiplexer::None, &old, NO_HINTS).protocol,
            Protocol::Halfblocks
        );
        old.version = Some("kitty(0.32.2)".into());
        assert_eq!(
            choose(Graphics::Auto, Multiplexer::None, &old, NO_HINTS).protocol,
            Protocol::Kitty
        );
    }

    #[test]
    fn tmux_3_3_without_passthrough_falls_back_to_half_blocks_with_a_hint() {
        // tmux 3.3 answers the device attributes itself, without sixel; the kitty query
        // (wrapped) is dropped.
        let choice = choose(
            Graphics::Auto,
            tmux(3, 3, Passthrough::Off),
            &answers(false, false),
            NO_HINTS,
        );
        assert_eq!(choice.protocol, Protocol::Halfblocks);
        let hint = choice.hint.expect("a hint");
        assert!(
            hint.contains("tmux 3.3") && hint.contains("allow-passthrough on"),
            "{hint}"
        );
    }

    #[test]
    fn tmux_3_3_never_claims_sixel() {
        // Even if something answered sixel (the outer terminal through passthrough), tmux 3.3
        // cannot draw it.
        let choice = choose(
            Graphics::Auto,
            tmux(3, 3, Passthrough::On),
            &answers(true, false),
            NO_HINTS,
        );
        assert_eq!(choice.protocol, Protocol::Halfblocks);
        assert!(choice.hint.expect("a hint").contains("tmux 3.4+"));
    }

    #[test]
    fn tmux_with_passthrough_and_a_kitty_terminal_uses_wrapped_kitty() {
        let choice = choose(
            Graphics::Auto,
            tmux(3, 3, Passthrough::On),
            &answers(false, true),
            NO_HINTS,
        );
        assert_eq!(
            choice,
            Choice {
                protocol: Protocol::Kitty,
                passthrough: true,
                hint: None
            }
        );
    }

    #[test]
    fn tmux_3_4_with_sixel_uses_unwrapped_sixel() {
        let choice = choose(
            Graphics::Auto,
            tmux(3, 5, Passthrough::Off),
            &answers(true, false),
            NO_HINTS,
        );
        assert_eq!(
            choice,
            Choice {
                protocol: Protocol::Sixel,
                passthrough: false,
                hint: None
            }
        );
        // tmux 3.4+ built without sixel (no 4 in its answer): half-blocks and a hint.
        let choice = choose(
            Graphics::Auto,
            tmux(3, 4, Passthrough::On),
            &answers(false, false),
            NO_HINTS,
        );
        assert_eq!(choice.protocol, Protocol::Halfblocks);
        assert!(choice.hint.expect("a hint").contains("terminal-features"));
    }

    #[test]
    fn screen_shows_half_blocks_with_a_hint() {
        let choice = choose(
            Graphics::Auto,
            Multiplexer::Screen,
            &answers(true, true),
            NO_HINTS,
        );
        assert_eq!(choice.protocol, Protocol::Halfblocks);
        assert!(choice.hint.expect("a hint").contains("GNU screen"));
    }

    #[test]
    fn a_forced_protocol_is_used_with_a_warning_where_it_cannot_reach() {
        let forced = choose(
            Graphics::Sixel,
            tmux(3, 3, Passthrough::On),
            &answers(false, false),
            NO_HINTS,
        );
        assert_eq!((forced.protocol, forced.passthrough), (Protocol::Sixel, false));
        assert!(forced.hint.expect("a warning").contains("may stay blank"));
        let forced = choose(
            Graphics::Kitty,
            tmux(3, 5, Passthrough::Off),
            &answers(true, false),
            NO_HINTS,
        );
        assert_eq!(forced.protocol, Protocol::Kitty);
        assert!(forced.hint.expect("a warning").contains("allow-passthrough"));
        let forced = choose(
            Graphics::Kitty,
            tmux(3, 5, Passthrough::On),
            &answers(true, false),
            NO_HINTS,
        );
        assert_eq!((forced.passthrough, forced.hint), (true, None));
        let forced = choose(
            Graphics::Halfblocks,
            Multiplexer::Screen,
            &answers(true, true),
            NO_HINTS,
        );
        assert_eq!((forced.protocol, forced.hint), (Protocol::Halfblocks, None));
        let forced = choose(
            Graphics::Sixel,
            Multiplexer::None,
            &answers(false, false),
            NO_HINTS,
        );
        assert_eq!((forced.protocol, forced.hint), (Protocol::Sixel, None));
    }

    #[test]
    fn terminal_hints_come_from_the_environment() {
        let env = |pairs: &'static [(&'static str, &'static str)]| {
            move |name: &str| pairs.iter().find(|p| p.0 == name).map(|p| p.1.to_string())
        };
        assert_eq!(TerminalHints::from_env(env(&[])), NO_HINTS);
        assert!(TerminalHints::from_env(env(&[("TERM_PROGRAM", "iTerm.app")])).iterm2);
        assert!(TerminalHints::from_env(env(&[("LC_TERMINAL", "iTerm2")])).iterm2);
        assert!(TerminalHints::from_env(env(&[("KONSOLE_VERSION", "221203")])).broken_sixel_and_kitty);
    }
}
