//! End to end: the real `haiko edit` binary in a detached tmux session (160 × 48 cells,
//! half-blocks): raise a control point, aim by keyboard, save, quit; then check the exit
//! status and the saved room file. Needs tmux (CI installs it): without it the test fails.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

/// How long any one step may take (a debug build's first frame included).
pub(crate) const STEP_TIMEOUT: Duration = Duration::from_secs(60);

/// A tmux session that is killed when the test ends, passed or failed.
pub(crate) struct TmuxSession {
    name: String,
}

impl TmuxSession {
    /// Starts `command` in a new detached session of `width × height` cells.
    pub(crate) fn start(command: &str, width: u16, height: u16) -> TmuxSession {
        let nanos = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| d.subsec_nanos());
        let name = format!("haiko-e2e-{}-{nanos}", std::process::id());
        let (w, h) = (width.to_string(), height.to_string());
        tmux(&["new-session", "-d", "-s", &name, "-x", &w, "-y", &h, command]);
        // Keep the pane after the command ends, so a failure can still show the last screen.
        let session = TmuxSession { name };
        tmux(&["set-option", "-t", &session.name, "remain-on-exit", "on"]);
        session
    }

    /// The session's name (a tmux target).
    pub(crate) fn name(&self) -> &str {
        &self.name
    }

    pub(crate) fn capture(&self) -> String {
        tmux(&["capture-pane", "-p", "-t", &self.name])
    }

    pub(crate) fn send(&self, key: &str) {
        tmux(&["send-keys", "-t", &self.name, key]);
    }

    /// Waits until the pane satisfies `done`; panics with the last screen after the timeout.
    pub(crate) fn wait_for(&self, what: &str, done: impl Fn(&str) -> bool) -> String {
        let start = Instant::now();
        loop {
            let screen = self.capture();
            if done(&screen) {
                return screen;
            }
            assert!(
                start.elapsed() < STEP_TIMEOUT,
                "timed out waiting for {what}; the screen was:\n{screen}"
            );
            std::thread::sleep(Duration::from_millis(100));
        }
    }
}

impl Drop for TmuxSession {
    fn drop(&mut self) {
        let _ = Command::new("tmux")
            .args(["kill-session", "-t", &self.name])
            .output();
    }
}

/// Runs tmux with `args` and returns its stdout; fails the test when tmux is missing or fails.
/// A server that is exiting (its last session was just killed by another test) is asked again:
/// the next call starts a new one.
fn tmux(args: &[&str]) -> String {
    let mut tries = 0;
    loop {
        let output = Command::new("tmux").args(args).output().unwrap_or_else(|e| {
            panic!(
                "tmux is required for the end-to-end editor test (CI installs it) but could not be run: {e}"
            )
        });
        let stderr = String::from_utf8_lossy(&output.stderr);
        let server_gone = stderr.contains("server exited") || stderr.contains("no server running");
        if output.status.success() || !server_gone || tries == 5 {
            assert!(output.status.success(), "tmux {args:?} failed: {stderr}");
            return String::from_utf8_lossy(&output.stdout).into_owned();
        }
        tries += 1;
        std::thread::sleep(Duration::from_millis(200));
    }
}

/// The status line (second-to-last row of the screen).
pub(crate) fn status_line(screen: &str) -> &str {
    let lines: Vec<&str> = screen.lines().collect();
    lines.len().checked_sub(2).map_or("", |i| lines[i])
}

/// The aim cursor title of the preview pane, e.g. `aim: cursor at pixel (470, 440)`.
fn aim_title(screen: &str) -> Option<String> {
    let start = screen.find("aim: cursor at pixel")?;
    let end = start + screen[start..].find(')')?;
    Some(screen[start..=end].to_string())
}

/// The light panel's aim line, e.g. `0.70 0.27 -0.66`.
fn light_aim(screen: &str) -> Option<String> {
    let line = screen.lines().find(|l| l.contains("│aim "))?;
    let start = line.find("│aim ")? + "│aim ".len();
    let rest = &line[start..];
    Some(rest[..rest.find('│')?].trim().to_string())
}

/// True once the save has finished: the status reports "saved PATH" and the room is no longer
/// marked "● unsaved" (a plain `contains("saved ")` also matches that marker).
pub(crate) fn shows_saved(screen: &str) -> bool {
    !screen.contains("unsaved")
        && screen
            .match_indices("saved ")
            .any(|(i, _)| !screen[..i].ends_with("un"))
}

pub(crate) fn wait_for_file(path: &Path) -> String {
    let start = Instant::now();
    while start.elapsed() < STEP_TIMEOUT {
        if let Ok(text) = std::fs::read_to_string(path)
            && text.ends_with('\n')
        {
            return text;
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    panic!("{} was not written: the editor did not exit", path.display());
}

pub(crate) fn number(value: &toml::Value) -> f64 {
    value
        .as_float()
        .or_else(|| value.as_integer().map(|i| i as f64))
        .expect("a number")
}

/// The editor on a copy of the paper room in `dir`, with a private bake cache in `dir/cache`;
/// its exit status goes to the returned file.
fn start_editor(dir: &Path) -> (TmuxSession, PathBuf, PathBuf, String) {
    let original = paper_room();
    let room = dir.join("paper.toml");
    std::fs::write(&room, &original).unwrap();
    let (session, exit_file) = start_editor_on(dir, &room);
    (session, room, exit_file, original)
}

/// The text of `rooms/paper.toml`.
fn paper_room() -> String {
    let repo = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    std::fs::read_to_string(repo.join("rooms/paper.toml")).unwrap()
}

/// The editor on the room file `room` (as named: a link stays a link), with a private bake
/// cache in `dir/cache`; its exit status goes to the returned file.
fn start_editor_on(dir: &Path, room: &Path) -> (TmuxSession, PathBuf) {
    let exit_file = dir.join("exit-status");
    // A private bake cache: the editor bakes on start (the preview appears when it is done).
    let command = format!(
        "HAIKO_CACHE_DIR='{}' '{}' edit '{}' --graphics halfblocks; echo EXIT=$? > '{}'",
        dir.join("cache").display(),
        env!("CARGO_BIN_EXE_haiko"),
        room.display(),
        exit_file.display()
    );
    (TmuxSession::start(&command, 160, 48), exit_file)
}

#[test]
fn edit_aim_save_and_quit_in_tmux() {
    let dir = tempfile::tempdir().unwrap();
    let (session, room, exit_file, original) = start_editor(dir.path());

    // The first frame: the status line reports the stage timings of a rendered preview.
    // Waited for whole: a capture can catch the status line half rewritten by the next frame.
    let screen = session.wait_for("the first preview frame, in half-blocks", |s| {
        let status = status_line(s);
        status.contains("relight") && status.contains("│ half-blocks")
    });
    assert!(screen.contains("centre"), "the first light is selected: {screen}");
    assert!(
        screen.contains("1000.0"),
        "the first point of centre's curve is 1000 cd: {screen}"
    );

    // ↑ raises the first control point by 5 % of the 1000 cd peak: 1050 cd.
    session.send("Up");
    session.wait_for("the raised point", |s| {
        s.contains("1050.0") && s.contains("unsaved")
    });

    // Aim mode; two steps to the right; Enter aims the light at the point under the cursor.
    session.send("a");
    let screen = session.wait_for("aim mode", |s| aim_title(s).is_some());
    let centred = aim_title(&screen).unwrap();
    session.send("Right");
    session.send("Right");
    session.wait_for("the cursor to move", |s| {
        aim_title(s).is_some_and(|t| t != centred)
    });
    let before = light_aim(&screen).expect("the light panel's aim");
    session.send("Enter");
    // The aim applies when the engine's pick comes back: the light panel then shows the new aim
    // (a save before that would miss it; the status line's lux alone also shows the cursor's
    // before the pick is back, which a loaded machine let a save slip in front of).
    session.wait_for("the aim to apply", |s| {
        aim_title(s).is_none()
            && status_line(s).contains("EDIT")
            && light_aim(s).is_some_and(|aim| aim != before)
    });

    session.send("s");
    session.wait_for("the save", shows_saved);
    session.send("q");
    assert_eq!(wait_for_file(&exit_file).trim(), "EXIT=0");

    let saved_text = std::fs::read_to_string(&room).unwrap();
    let saved: toml::Value = toml::from_str(&saved_text).unwrap();
    let centre = &saved["light"][0];
    let lid = centre["lid"].as_array().unwrap();
    let first = lid[0].as_array().unwrap();
    assert_eq!(
        (number(&first[0]), number(&first[1])),
        (0.0, 1050.0),
        "{saved_text}"
    );
    let rest: Vec<(f64, f64)> = lid[1..]
        .iter()
        .map(|p| {
            let p = p.as_array().unwrap();
            (number(&p[0]), number(&p[1]))
        })
        .collect();
    assert_eq!(rest, [(30.0, 950.0), (60.0, 700.0), (90.0, 0.0)]);

    // The new aim is a point on a room surface (6 × 4 × 2.7 m), not the old (3, 2, 0).
    let aim: Vec<f64> = centre["aim"].as_array().unwrap().iter().map(number).collect();
    assert_ne!(aim, [3.0, 2.0, 0.0]);
    let size = [6.0, 4.0, 2.7];
    let on_surface = (0..3).any(|a| aim[a].abs() < 1e-3 || (aim[a] - size[a]).abs() < 1e-3);
    let inside = (0..3).all(|a| aim[a] > -1e-3 && aim[a] < size[a] + 1e-3);
    assert!(on_surface && inside, "aim {aim:?} is not on the room's surface");

    // Every comment of the original is still there, and the other light is untouched.
    for line in original.lines().filter(|l| l.contains('#')) {
        let comment = &line[line.find('#').unwrap()..];
        assert!(
            saved_text.contains(comment),
            "lost comment {comment:?}:\n{saved_text}"
        );
    }
    let accent_lines = |text: &str| -> Vec<String> {
        let start = text.find("name = \"accent\"").unwrap();
        let end = start + text[start..].find("[settings]").unwrap();
        text[start..end].lines().map(str::to_string).collect()
    };
    assert_eq!(accent_lines(&saved_text), accent_lines(&original));
    drop(session);
}

/// `m`, `↑`, `Enter`: the light moves 0.1 m, its new bake runs in the background and the status
/// line is back to normal (no "updating", no "baking") within 10 s; the save writes the new
/// position and the bake cache keeps one entry per light.
#[test]
fn a_move_in_tmux_finishes_its_bake_and_keeps_one_cache_entry_per_light() {
    let dir = tempfile::tempdir().unwrap();
    // The SH basis engine: the one that bakes moved lights in the background and caches them.
    let room = dir.path().join("paper.toml");
    std::fs::write(
        &room,
        paper_room().replacen("[settings]\n", "[settings]\nindirect = \"basis\"\n", 1),
    )
    .unwrap();
    let (session, exit_file) = start_editor_on(dir.path(), &room);
    session.wait_for("the first preview frame", |s| status_line(s).contains("relight"));
    session.send("m");
    session.wait_for("move mode", |s| status_line(s).contains("MOVE"));
    session.send("Up");
    session.wait_for("the moved light", |s| s.contains("3.00 2.10 2.60"));
    session.send("Enter");
    let entered = Instant::now();
    let screen = session.wait_for("the moved light's bake", |s| {
        let status = status_line(s);
        status.contains("EDIT") && !status.contains("updating") && !status.contains("baking")
    });
    assert!(
        entered.elapsed() < Duration::from_secs(10),
        "the move took {:?} to settle:\n{screen}",
        entered.elapsed()
    );
    session.send("s");
    session.wait_for("the save", shows_saved);
    session.send("q");
    assert_eq!(wait_for_file(&exit_file).trim(), "EXIT=0");
    let saved: toml::Value = toml::from_str(&std::fs::read_to_string(&room).unwrap()).unwrap();
    let position: Vec<f64> = saved["light"][0]["position"]
        .as_array()
        .unwrap()
        .iter()
        .map(number)
        .collect();
    assert_eq!(position, [3.0, 2.1, 2.6]);
    let entries = std::fs::read_dir(dir.path().join("cache"))
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .path()
                .extension()
                .is_some_and(|x| x == "bake")
        })
        .count();
    assert_eq!(entries, 2, "one cache entry per light");
    drop(session);
}

// ---------------------------------------------------------------- saving (docs/DECISIONS.md "Saving")

/// The centre light's first `lid` point as written in `text`.
fn first_point(text: &str) -> (f64, f64) {
    let room: toml::Value = toml::from_str(text).unwrap_or_else(|e| panic!("{e}:\n{text}"));
    let first = room["light"][0]["lid"][0].as_array().unwrap().clone();
    (number(&first[0]), number(&first[1]))
}

/// Waits for the first frame, then raises centre's first point to 1050 cd (unsaved).
fn raise_first_point(session: &TmuxSession) {
    session.wait_for("the first preview frame", |s| status_line(s).contains("relight"));
    session.send("Up");
    session.wait_for("the raised point", |s| {
        s.contains("1050.0") && s.contains("unsaved")
    });
}

/// `q` on a saved room, or `q` `y` on an unsaved one: the editor exits 0.
fn quit(session: &TmuxSession, exit_file: &Path, unsaved: bool) {
    session.send("q");
    if unsaved {
        session.wait_for("the quit prompt", |s| status_line(s).contains("QUIT?"));
        session.send("y");
    }
    assert_eq!(wait_for_file(exit_file).trim(), "EXIT=0");
}

#[test]
fn a_read_only_room_is_refused_and_saved_as_another_file_in_tmux() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let (session, room, exit_file, original) = start_editor(dir.path());
    std::fs::set_permissions(&room, std::fs::Permissions::from_mode(0o444)).unwrap();
    raise_first_point(&session);
    session.send("s");
    let screen = session.wait_for("the save-as prompt", |s| status_line(s).contains("SAVE AS"));
    assert!(
        screen.contains("cannot save: the file is read-only") && screen.contains("save as (file name):"),
        "{screen}"
    );
    session.send("copy.toml");
    session.wait_for("the typed name", |s| s.contains("copy.toml▏"));
    session.send("Enter");
    let screen = session.wait_for("the save as", shows_saved);
    assert!(screen.contains("copy.toml"), "{screen}");
    quit(&session, &exit_file, false);
    assert_eq!(
        std::fs::read_to_string(&room).unwrap(),
        original,
        "the read-only file is untouched"
    );
    let mode = std::fs::metadata(&room).unwrap().permissions().mode();
    assert_eq!(mode & 0o777, 0o444);
    let copy = std::fs::read_to_string(dir.path().join("copy.toml")).unwrap();
    assert_eq!(first_point(&copy), (0.0, 1050.0));
}

#[test]
fn a_symlinked_room_is_saved_through_to_its_target_in_tmux() {
    let dir = tempfile::tempdir().unwrap();
    let real_dir = dir.path().join("real");
    std::fs::create_dir(&real_dir).unwrap();
    let target = real_dir.join("paper.toml");
    std::fs::write(&target, paper_room()).unwrap();
    let link = dir.path().join("link.toml");
    std::os::unix::fs::symlink("real/paper.toml", &link).unwrap();
    let (session, exit_file) = start_editor_on(dir.path(), &link);
    raise_first_point(&session);
    session.send("s");
    session.wait_for("the save", shows_saved);
    quit(&session, &exit_file, false);
    assert!(
        std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink(),
        "the link stays"
    );
    assert_eq!(std::fs::read_link(&link).unwrap(), Path::new("real/paper.toml"));
    assert_eq!(
        first_point(&std::fs::read_to_string(&target).unwrap()),
        (0.0, 1050.0)
    );
}

#[test]
fn a_hard_linked_room_is_refused_with_save_as_offered_in_tmux() {
    let dir = tempfile::tempdir().unwrap();
    let (session, room, exit_file, original) = start_editor(dir.path());
    let other = dir.path().join("other-name.toml");
    std::fs::hard_link(&room, &other).unwrap();
    raise_first_point(&session);
    session.send("s");
    let screen = session.wait_for("the save-as prompt", |s| status_line(s).contains("SAVE AS"));
    assert!(screen.contains("has 2 hard links"), "{screen}");
    session.send("Escape");
    session.wait_for("editing again", |s| status_line(s).contains("EDIT"));
    quit(&session, &exit_file, true);
    assert_eq!(std::fs::read_to_string(&room).unwrap(), original);
    assert_eq!(std::fs::read_to_string(&other).unwrap(), original);
    use std::os::unix::fs::MetadataExt;
    assert_eq!(
        std::fs::metadata(&room).unwrap().nlink(),
        2,
        "the link is not broken"
    );
}

/// The room changed on disk after the editor read it: another program set the accent light's
/// dimmer. Returns the changed text.
fn change_on_disk(room: &Path) -> String {
    let text = std::fs::read_to_string(room).unwrap();
    let changed = text.replacen("radius = 0.03", "radius = 0.03\ndimmer = 0.5", 1);
    assert_ne!(changed, text);
    std::fs::write(room, &changed).unwrap();
    changed
}

#[test]
fn a_room_changed_on_disk_asks_and_overwrite_writes_ours_in_tmux() {
    let dir = tempfile::tempdir().unwrap();
    let (session, room, exit_file, _) = start_editor(dir.path());
    raise_first_point(&session);
    change_on_disk(&room);
    session.send("s");
    let screen = session.wait_for("the conflict prompt", |s| {
        status_line(s).contains("CHANGED ON DISK")
    });
    assert!(
        screen.contains("changed on disk since it was read") && screen.contains("o overwrite"),
        "{screen}"
    );
    session.send("o");
    session.wait_for("the save", shows_saved);
    quit(&session, &exit_file, false);
    let saved = std::fs::read_to_string(&room).unwrap();
    assert_eq!(first_point(&saved), (0.0, 1050.0));
    assert!(
        !saved.contains("dimmer = 0.5"),
        "overwrite replaces the other change:\n{saved}"
    );
}

#[test]
fn a_room_changed_on_disk_asks_and_reload_takes_theirs_in_tmux() {
    let dir = tempfile::tempdir().unwrap();
    let (session, room, exit_file, _) = start_editor(dir.path());
    raise_first_point(&session);
    let changed = change_on_disk(&room);
    session.send("s");
    session.wait_for("the conflict prompt", |s| {
        status_line(s).contains("CHANGED ON DISK")
    });
    session.send("r");
    let screen = session.wait_for("the reload", |s| s.contains("reloaded") && !s.contains("unsaved"));
    assert!(
        screen.contains("1000.0") && !screen.contains("1050.0"),
        "{screen}"
    );
    // The reloaded room is edited and saved as usual.
    session.wait_for("a frame of the reloaded room", |s| {
        status_line(s).contains("relight")
    });
    session.send("Down");
    session.wait_for("the lowered point", |s| {
        s.contains("950.0") && s.contains("unsaved")
    });
    session.send("s");
    session.wait_for("the save", shows_saved);
    quit(&session, &exit_file, false);
    let saved = std::fs::read_to_string(&room).unwrap();
    assert!(saved.contains("dimmer = 0.5"), "their change is kept:\n{saved}");
    assert_eq!(first_point(&saved), (0.0, 950.0));
    assert_eq!(saved.lines().count(), changed.lines().count());
}

#[test]
fn comments_inside_an_edited_lid_array_are_kept_in_tmux() {
    let dir = tempfile::tempdir().unwrap();
    let room = dir.path().join("paper.toml");
    let text = paper_room().replacen(
        "lid = [[0, 1000], [30, 950], [60, 700], [90, 0]]",
        "lid = [\n    # straight down\n    [0, 1000],\n    [30, 950], # shoulder\n    # the cut-off\n    [60, 700],\n    [90, 0],\n]",
        1,
    );
    std::fs::write(&room, &text).unwrap();
    let (session, exit_file) = start_editor_on(dir.path(), &room);
    raise_first_point(&session);
    session.send("s");
    session.wait_for("the save", shows_saved);
    quit(&session, &exit_file, false);
    let saved = std::fs::read_to_string(&room).unwrap();
    assert_eq!(first_point(&saved), (0.0, 1050.0));
    assert!(
        saved.contains("lid = [\n    # straight down\n    [0, 1050],\n    [30, 950], # shoulder\n    # the cut-off\n    [60, 700],\n    [90, 0],\n]"),
        "{saved}"
    );
}

#[test]
fn a_stale_temporary_of_a_killed_save_is_removed_on_open_in_tmux() {
    let dir = tempfile::tempdir().unwrap();
    let room = dir.path().join("paper.toml");
    std::fs::write(&room, paper_room()).unwrap();
    // Left by a save whose process is gone (ids above the kernel's 2^22 maximum never live),
    // and one of another file, which stays.
    let stale = dir.path().join(".paper.toml.haiko-tmp-99999999-0");
    let other = dir.path().join(".other.toml.haiko-tmp-99999999-0");
    std::fs::write(&stale, "partial room").unwrap();
    std::fs::write(&other, "partial").unwrap();
    let (session, exit_file) = start_editor_on(dir.path(), &room);
    let screen = session.wait_for("the notice", |s| s.contains("removed 1 temporary file(s)"));
    assert!(!stale.exists(), "{screen}");
    assert!(other.exists());
    session.wait_for("the first preview frame", |s| status_line(s).contains("relight"));
    quit(&session, &exit_file, false);
}
