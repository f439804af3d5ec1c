//! End to end on the office, as the "must show" asks: the real `haiko edit` in tmux
//! shows the work plane's Ē in its numbers panel; a typed dimmer of 24 % on one light sets 0.24
//! and changes Ē; the report key writes the report with that state; after saving,
//! `haiko check --json` on the saved room gives the same Ē within 0.5 % (the panel rounds to
//! whole lux).

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::tui_e2e::{TmuxSession, number, shows_saved, status_line, wait_for_file};

/// The work plane's Ē (maintained, lx) in the numbers panel, if the panel shows it.
fn panel_mean(screen: &str) -> Option<f64> {
    let line = screen.lines().find(|l| l.contains("│work plane"))?;
    let after = &line[line.find("work plane")? + "work plane".len()..];
    after
        .split(|c: char| !c.is_ascii_digit())
        .find(|t| !t.is_empty())?
        .parse()
        .ok()
}

fn haiko(cache: &Path, args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_haiko"))
        .args(args)
        .env("HAIKO_CACHE_DIR", cache)
        .output()
        .expect("the binary runs");
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

#[test]
fn office_panel_follows_a_typed_dimmer_and_matches_check() {
    let dir = tempfile::tempdir().unwrap();
    let repo = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    for file in ["office.toml", "office-downlight.ldt"] {
        std::fs::copy(repo.join("rooms").join(file), dir.path().join(file)).unwrap();
    }
    let room = dir.path().join("office.toml");
    let cache = dir.path().join("cache");
    // Bake once (the editor and `check` then read the cache; a dimmer does not change a bake).
    haiko(&cache, &["bake", room.to_str().unwrap()]);
    let exit_file = dir.path().join("exit-status");
    let command = format!(
        "HAIKO_CACHE_DIR='{}' '{}' edit '{}' --graphics halfblocks; echo EXIT=$? > '{}'",
        cache.display(),
        env!("CARGO_BIN_EXE_haiko"),
        room.display(),
        exit_file.display()
    );
    let session = TmuxSession::start(&command, 120, 40);

    let screen = session.wait_for("the work plane's Ē in the panel", |s| panel_mean(s).is_some());
    let before = panel_mean(&screen).unwrap();
    assert!(screen.contains("d11 (1/6)"), "{screen}");
    assert!(screen.contains("dimmer  35 %"), "{screen}");

    // A typed dimmer of 24 % on d11.
    session.send("%");
    session.wait_for("the dimmer prompt", |s| s.contains("dimmer (%):"));
    session.send("2");
    session.send("4");
    session.send("Enter");
    let screen = session.wait_for("the new dimmer and Ē", |s| {
        s.contains("dimmer  24 %") && panel_mean(s).is_some_and(|e| e != before)
    });
    let after = panel_mean(&screen).unwrap();
    assert!(after < before, "dimming lowers Ē: {before} → {after}");

    // The report key writes the current state next to the room file.
    session.send("R");
    session.wait_for("the report", |s| s.contains("report written to"));
    let report = std::fs::read_to_string(dir.path().join("office-report.html")).unwrap();
    assert_eq!(report.matches("src=\"data:image/png;base64,").count(), 3);
    assert!(
        report.contains("<td class=\"n\">24.0 %</td>"),
        "d11's dimmer in the schedule"
    );
    assert!(
        report.contains(&format!("<td class=\"n\">{after:.0}")),
        "the panel's Ē in the table"
    );

    session.send("s");
    session.wait_for("the save", shows_saved);
    session.send("q");
    assert_eq!(wait_for_file(&exit_file).trim(), "EXIT=0");
    drop(session);

    let saved: toml::Value = toml::from_str(&std::fs::read_to_string(&room).unwrap()).unwrap();
    let lights = saved["light"].as_array().unwrap();
    assert_eq!(number(&lights[0]["dimmer"]), 0.24);
    assert!(lights[1..].iter().all(|l| number(&l["dimmer"]) == 0.35));

    let check: serde_json::Value =
        serde_json::from_str(&haiko(&cache, &["check", room.to_str().unwrap(), "--json"])).unwrap();
    let plane = &check["surfaces"][0];
    assert_eq!(plane["name"], "work plane");
    let e_avg = plane["stats"]["e_avg"].as_f64().unwrap();
    assert!(
        (after - e_avg).abs() <= 0.005 * e_avg,
        "panel {after} lx vs check {e_avg} lx ({status})",
        status = status_line(&screen)
    );
}
