//! The real `haiko edit` in tmux (3.3 here: no sixel, `allow-passthrough` off): with automatic
//! graphics the preview shows in half-blocks and the status says how to get images; a signal
//! with an unsaved edit gives the terminal back (alternate screen off, cursor on, mouse off,
//! cooked mode) and keeps the edit in the recovery file, which the next `haiko edit` offers.
//! Needs tmux (CI installs it): without it the tests fail.

use std::path::{Path, PathBuf};

use crate::tui_e2e::{TmuxSession, number, shows_saved, status_line, wait_for_file};

/// A copy of the paper room in `dir`.
fn paper_room(dir: &Path) -> (PathBuf, String) {
    let repo = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let original = std::fs::read_to_string(repo.join("rooms/paper.toml")).unwrap();
    let room = dir.join("paper.toml");
    std::fs::write(&room, &original).unwrap();
    (room, original)
}

/// The shell command running `haiko edit ROOM ARGS` with a private bake cache in `dir`.
fn edit_command(dir: &Path, room: &Path, args: &str) -> String {
    format!(
        "HAIKO_CACHE_DIR='{}' '{}' edit '{}' {args}",
        dir.join("cache").display(),
        env!("CARGO_BIN_EXE_haiko"),
        room.display(),
    )
}

/// The centre light's curve in a room text.
fn centre_curve(text: &str) -> Vec<(f64, f64)> {
    let room: toml::Value = toml::from_str(text).unwrap();
    room["light"][0]["lid"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| {
            let p = p.as_array().unwrap();
            (number(&p[0]), number(&p[1]))
        })
        .collect()
}

/// The raised curve: ↑ raises the first point by 5 % of the 1000 cd peak.
const RAISED: [(f64, f64); 4] = [(0.0, 1050.0), (30.0, 950.0), (60.0, 700.0), (90.0, 0.0)];

/// Cells of the preview pane at 160 × 48: 94 columns × 32 rows.
const PREVIEW_CELLS: usize = 94 * 32;

/// Cells drawn as half-blocks (`▀`, `▄`) on the screen.
fn half_block_cells(screen: &str) -> usize {
    screen.chars().filter(|&c| c == '▀' || c == '▄').count()
}

#[test]
fn automatic_graphics_in_tmux_without_sixel_shows_the_preview_in_half_blocks() {
    let dir = tempfile::tempdir().unwrap();
    let (room, _) = paper_room(dir.path());
    let session = TmuxSession::start(&edit_command(dir.path(), &room, "--graphics auto"), 160, 48);
    // Waited for whole: a capture can catch the status line half rewritten by the next frame.
    let screen = session.wait_for("the first preview frame, in half-blocks", |s| {
        let status = status_line(s);
        status.contains("relight") && status.contains("│ half-blocks")
    });
    // The preview (94 × 32 cells at 160 × 48, above the numbers panel) is an image, not a blank
    // pane: many of its cells are half-blocks (a cell whose two halves have the same colour is
    // drawn as a space on that colour, so even areas do not count here).
    assert!(half_block_cells(&screen) > PREVIEW_CELLS / 4, "{screen}");
    // Said once: why half-blocks, and how to get images.
    assert!(
        screen.contains("tmux 3.3") && screen.contains("allow-passthrough"),
        "{screen}"
    );
    // The first key press counts (the terminal query left nothing reading the keyboard).
    session.send("Up");
    let screen = session.wait_for("the raised point", |s| {
        s.contains("1050.0") && s.contains("unsaved")
    });
    assert!(half_block_cells(&screen) > PREVIEW_CELLS / 4, "{screen}");
}

/// `tmux display` of `format` for the session's pane.
fn pane_flags(session: &TmuxSession, format: &str) -> String {
    let output = std::process::Command::new("tmux")
        .args(["display-message", "-p", "-t", session.name(), format])
        .output()
        .unwrap();
    String::from_utf8_lossy(&output.stdout).trim().to_string()
}

/// Edits the paper room in tmux, sends `signal` to the editor with the edit unsaved, checks the
/// terminal and the recovery file; returns the room, its original text and the temp dir.
fn stop_with_an_unsaved_edit(signal: &str) -> (tempfile::TempDir, PathBuf, String) {
    let dir = tempfile::tempdir().unwrap();
    let (room, original) = paper_room(dir.path());
    let pid_file = dir.path().join("pid");
    let exit_file = dir.path().join("exit-status");
    let stty_file = dir.path().join("stty");
    // The inner shell writes its PID and becomes the editor (exec), in the foreground of the
    // pane; after it the pane's shell reports the exit status and the terminal's modes.
    let command = format!(
        "sh -c 'echo $$ > \"{pid}\"; HAIKO_CACHE_DIR=\"{cache}\" exec \"{haiko}\" edit \"{room}\" --graphics halfblocks'; \
         echo EXIT=$? > '{exit}'; stty -a > '{stty}'; echo STOPPED; sleep 600",
        pid = pid_file.display(),
        cache = dir.path().join("cache").display(),
        haiko = env!("CARGO_BIN_EXE_haiko"),
        room = room.display(),
        exit = exit_file.display(),
        stty = stty_file.display(),
    );
    let session = TmuxSession::start(&command, 160, 48);
    session.wait_for("the first preview frame", |s| status_line(s).contains("relight"));
    assert_eq!(pane_flags(&session, "#{alternate_on}"), "1");
    session.send("Up");
    session.wait_for("the unsaved edit", |s| {
        s.contains("1050.0") && s.contains("unsaved")
    });
    let pid = wait_for_file(&pid_file).trim().to_string();
    let killed = std::process::Command::new("kill")
        .args([&format!("-{signal}"), &pid])
        .status()
        .unwrap();
    assert!(killed.success());
    let number = match signal {
        "TERM" => 15,
        "HUP" => 1,
        "INT" => 2,
        _ => unreachable!(),
    };
    assert_eq!(wait_for_file(&exit_file).trim(), format!("EXIT={}", 128 + number));
    let screen = session.wait_for("the shell after the editor", |s| s.contains("STOPPED"));
    assert!(
        screen.contains(&format!("haiko: stopped by SIG{signal}; unsaved edits kept in")),
        "{screen}"
    );
    // Off the alternate screen, cursor visible, no mouse tracking, cooked mode with echo.
    assert_eq!(
        pane_flags(&session, "#{alternate_on} #{cursor_flag} #{mouse_any_flag}"),
        "0 1 0"
    );
    let stty = wait_for_file(&stty_file);
    let modes: Vec<&str> = stty.split_whitespace().collect();
    assert!(modes.contains(&"icanon") && modes.contains(&"echo"), "{stty}");
    // The recovery file holds the edit; the room file is untouched.
    let recovery = std::fs::read_to_string(dir.path().join("paper.toml.recovery")).unwrap();
    assert!(recovery.starts_with("# haiko recovery file: unsaved edits of paper.toml"));
    assert!(recovery.contains(&format!("reason=SIG{signal} ")), "{recovery}");
    assert_eq!(centre_curve(&recovery), RAISED);
    assert_eq!(std::fs::read_to_string(&room).unwrap(), original);
    (dir, room, original)
}

#[test]
fn sigterm_restores_the_terminal_and_the_next_edit_restores_the_edit() {
    let (dir, room, original) = stop_with_an_unsaved_edit("TERM");
    // The next `haiko edit` offers the recovery file; `y` restores the edit, unsaved.
    let exit_file = dir.path().join("exit-again");
    let command = format!(
        "{}; echo EXIT=$? > '{}'",
        edit_command(dir.path(), &room, "--graphics halfblocks"),
        exit_file.display()
    );
    let session = TmuxSession::start(&command, 160, 48);
    let screen = session.wait_for("the offer", |s| s.contains("Restore them?"));
    assert!(
        screen.contains("unsaved edits from") && screen.contains("(SIGTERM) are kept in"),
        "{screen}"
    );
    session.send("y");
    session.send("Enter");
    let screen = session.wait_for("the restored edit", |s| {
        s.contains("1050.0") && s.contains("unsaved") && status_line(s).contains("relight")
    });
    assert!(screen.contains("restored the unsaved edits"), "{screen}");
    // Saving writes the edit into the room and removes the recovery file.
    session.send("s");
    session.wait_for("the save", shows_saved);
    session.send("q");
    assert_eq!(wait_for_file(&exit_file).trim(), "EXIT=0");
    let saved = std::fs::read_to_string(&room).unwrap();
    assert_eq!(centre_curve(&saved), RAISED);
    assert_ne!(saved, original);
    assert!(!dir.path().join("paper.toml.recovery").exists());
}

#[test]
fn sighup_restores_the_terminal_and_keeps_the_edit() {
    let (dir, room, original) = stop_with_an_unsaved_edit("HUP");
    // `n` at the offer discards the file and opens the room as saved.
    let command = edit_command(dir.path(), &room, "--graphics halfblocks");
    let session = TmuxSession::start(&command, 160, 48);
    session.wait_for("the offer", |s| s.contains("(SIGHUP) are kept in"));
    session.send("n");
    session.send("Enter");
    let screen = session.wait_for("the editor", |s| status_line(s).contains("relight"));
    assert!(
        screen.contains("1000.0") && !screen.contains("unsaved"),
        "{screen}"
    );
    assert!(!dir.path().join("paper.toml.recovery").exists());
    assert_eq!(std::fs::read_to_string(&room).unwrap(), original);
}

#[test]
fn sigint_restores_the_terminal_and_keeps_the_edit() {
    let (dir, room, _) = stop_with_an_unsaved_edit("INT");
    // Enter at the offer keeps the file for later.
    let command = edit_command(dir.path(), &room, "--graphics halfblocks");
    let session = TmuxSession::start(&command, 160, 48);
    session.wait_for("the offer", |s| s.contains("(SIGINT) are kept in"));
    session.send("Enter");
    let screen = session.wait_for("the editor", |s| status_line(s).contains("relight"));
    assert!(
        screen.contains("1000.0") && !screen.contains("unsaved"),
        "{screen}"
    );
    assert!(dir.path().join("paper.toml.recovery").exists());
}

/// Suspends the editor running as a job of the shell in `session` (by `suspend`), checks that
/// the shell has the terminal back in cooked mode, then resumes it with `fg` and checks that the
/// editor draws its whole screen again with the edit still there.
fn suspend_and_resume(session: &TmuxSession, dir: &Path, round: usize, suspend: impl Fn()) {
    suspend();
    session.wait_for("the shell's stopped job", |s| {
        s.matches("Stopped").count() >= round && s.trim_end().ends_with('$')
    });
    assert_eq!(
        pane_flags(session, "#{alternate_on} #{cursor_flag} #{mouse_any_flag}"),
        "0 1 0"
    );
    let stty_file = dir.join(format!("stty-{round}"));
    session.send(&format!("stty -a > '{}'", stty_file.display()));
    session.send("Enter");
    let stty = wait_for_file(&stty_file);
    let modes: Vec<&str> = stty.split_whitespace().collect();
    assert!(modes.contains(&"icanon") && modes.contains(&"echo"), "{stty}");
    session.send("fg");
    session.send("Enter");
    let screen = session.wait_for("the editor drawn again", |s| {
        status_line(s).contains("relight") && s.contains("1050.0") && s.contains("unsaved")
    });
    assert!(half_block_cells(&screen) > PREVIEW_CELLS / 4, "{screen}");
    assert_eq!(pane_flags(session, "#{alternate_on} #{mouse_any_flag}"), "1 1");
}

#[test]
fn ctrl_z_and_sigtstp_suspend_to_the_shell_and_fg_redraws_the_editor() {
    let dir = tempfile::tempdir().unwrap();
    let (room, original) = paper_room(dir.path());
    let pid_file = dir.path().join("pid");
    // An interactive shell with job control; the editor is its foreground job.
    let session = TmuxSession::start("env PS1='$ ' bash --norc --noprofile -i", 160, 48);
    session.wait_for("the shell", |s| s.trim_end().ends_with('$'));
    session.send(&format!(
        "sh -c 'echo $$ > \"{pid}\"; HAIKO_CACHE_DIR=\"{cache}\" exec \"{haiko}\" edit \"{room}\" --graphics halfblocks'",
        pid = pid_file.display(),
        cache = dir.path().join("cache").display(),
        haiko = env!("CARGO_BIN_EXE_haiko"),
        room = room.display(),
    ));
    session.send("Enter");
    session.wait_for("the first preview frame", |s| status_line(s).contains("relight"));
    session.send("Up");
    session.wait_for("the unsaved edit", |s| {
        s.contains("1050.0") && s.contains("unsaved")
    });
    // Ctrl-Z, a key in raw mode.
    suspend_and_resume(&session, dir.path(), 1, || session.send("C-z"));
    // SIGTSTP from outside (`kill -TSTP`, as a job-control stop sends it).
    let pid = wait_for_file(&pid_file).trim().to_string();
    suspend_and_resume(&session, dir.path(), 2, || {
        let sent = std::process::Command::new("kill")
            .args(["-TSTP", &pid])
            .status()
            .unwrap();
        assert!(sent.success());
    });
    // Nothing was written meanwhile: the edit is still only in the editor.
    assert_eq!(std::fs::read_to_string(&room).unwrap(), original);
}
