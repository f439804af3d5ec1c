//! The editor's design features through `update` and `view` (no terminal): the typed dimmer,
//! marks and group edits as one undo step, group aim offsets, duplicating and deleting lights,
//! swapping a photometric file (with its asymmetry), the numbers panel, and saving — a
//! duplicated, moved light round-trips through the room file; an edited `lid_file` curve goes to
//! a new IES file that reads back with the edited values.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::DVec3;
use haiko::metrics::{Check, SurfaceCheck, SurfaceStats, UgrStatus};
use haiko::photometry::read_lid_file;
use haiko::scene::{self, AimSpec, LidSource};
use haiko::session::Command;
use haiko::tui::luminaires::{LidInfo, read_lid_infos};
use haiko::tui::msg::CurveSave;
use haiko::tui::panel::{ObserverRow, PanelNumbers, SurfaceRow};
use haiko::tui::save::{save_room, save_with_curves};
use haiko::tui::{Effect, Mode, Model, Msg, PreviewArea, update, view};
use ratatui::Terminal;
use ratatui::backend::TestBackend;
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyModifiers};

fn repo(relative: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(relative)
}

/// Three lights in a 6 × 4 × 2.8 m room: two downlights from one EULUMDAT file, an inline
/// spot aimed at a target; a desk.
const ROOM: &str = r#"version = 1
name = "Editor design"
[room]
size = [6.0, 4.0, 2.8]
[room.reflectance]
floor = 0.2
walls = 0.5
ceiling = 0.7

[[box]]
min = [4.5, 0.5, 0.0]
max = [5.5, 1.5, 0.75]
reflectance = 0.4

# the downlights
[[light]]
name = "a"
position = [1.5, 2.0, 2.6]
lid_file = "down.ldt"
dimmer = 0.5

[[light]]
name = "b"
position = [3.0, 2.0, 2.6]
lid_file = "down.ldt"
dimmer = 0.5

[[light]]
name = "spot"
position = [5.0, 3.5, 2.6]
aim = [5.0, 1.0, 0.75]
lid = [[0, 2000], [15, 1800], [25, 0]]

[settings]
patch_size = 0.5
solver_patch_size = 1.0
"#;

/// The room written into `dir` (with its photometric file), and the editor's model of it.
fn room_and_model(dir: &Path) -> (PathBuf, Model) {
    std::fs::copy(repo("tests/data/ldt/sample_09.ldt"), dir.join("down.ldt")).unwrap();
    let path = dir.join("room.toml");
    std::fs::write(&path, ROOM).unwrap();
    let scene = scene::load(&path).unwrap();
    let mut model = Model::new(&scene, (120, 40), (10, 20));
    model.lid_files = read_lid_infos(&model.lights);
    (path, model)
}

fn key(code: KeyCode) -> Msg {
    Msg::Key(KeyEvent::new(code, KeyModifiers::NONE))
}

fn ch(c: char) -> Msg {
    key(KeyCode::Char(c))
}

/// Sends `msgs` in order; returns every effect.
fn send(model: &mut Model, msgs: impl IntoIterator<Item = Msg>) -> Vec<Effect> {
    msgs.into_iter().flat_map(|msg| update(model, msg)).collect()
}

fn engine_commands(effects: &[Effect]) -> Vec<Command> {
    effects
        .iter()
        .filter_map(|e| match e {
            Effect::Engine(c) => Some(c.clone()),
            _ => None,
        })
        .collect()
}

fn screen(model: &Model, width: u16, height: u16) -> String {
    let mut terminal = Terminal::new(TestBackend::new(width, height)).unwrap();
    terminal
        .draw(|frame| view(model, frame, PreviewArea::Placeholder))
        .unwrap();
    let buffer = terminal.backend().buffer();
    (0..height)
        .map(|y| (0..width).map(|x| buffer[(x, y)].symbol()).collect::<String>())
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn a_typed_dimmer_of_24_percent_sets_0_24() {
    let dir = tempfile::tempdir().unwrap();
    let (_, mut m) = room_and_model(dir.path());
    assert_eq!(update(&mut m, ch('%')), vec![]);
    assert_eq!(
        m.mode,
        Mode::DimmerEntry {
            buffer: String::new()
        }
    );
    assert!(screen(&m, 120, 40).contains("dimmer (%): ▏"));
    let effects = send(&mut m, [ch('2'), ch('4'), key(KeyCode::Enter)]);
    assert_eq!(
        engine_commands(&effects),
        vec![Command::SetDimmer {
            light: 0,
            dimmer: 0.24
        }]
    );
    assert_eq!(m.lights[0].dimmer, 0.24);
    assert_eq!(m.mode, Mode::Normal);
    assert!(screen(&m, 120, 40).contains("dimmer  24 %"));
    // "24%" works too; a dimmer that is not a number changes nothing and says why.
    send(
        &mut m,
        [
            ch('%'),
            ch('1'),
            ch('2'),
            ch('.'),
            ch('5'),
            ch('%'),
            key(KeyCode::Enter),
        ],
    );
    assert_eq!(m.lights[0].dimmer, 0.125);
    assert!(screen(&m, 120, 40).contains("dimmer  12.5 %"));
    let effects = send(&mut m, [ch('%'), ch('.'), key(KeyCode::Enter)]);
    assert!(effects.is_empty());
    assert_eq!(m.lights[0].dimmer, 0.125);
    assert!(
        m.message.as_deref().unwrap().contains("not a dimmer"),
        "{:?}",
        m.message
    );
    // Undo goes back one typed value at a time.
    send(&mut m, [ch('u')]);
    assert_eq!(m.lights[0].dimmer, 0.24);
    send(&mut m, [ch('u')]);
    assert_eq!(m.lights[0].dimmer, 0.5);
}

#[test]
fn marked_lights_are_edited_together_as_one_undo_step() {
    let dir = tempfile::tempdir().unwrap();
    let (_, mut m) = room_and_model(dir.path());
    // `*` marks every light from a's file: a and b, not the inline spot.
    send(&mut m, [ch('*')]);
    assert_eq!(m.marked.iter().cloned().collect::<Vec<_>>(), ["a", "b"]);
    let before = m.history.undo_len();
    let effects = send(&mut m, [ch('D')]);
    assert_eq!(
        engine_commands(&effects),
        vec![
            Command::SetDimmer {
                light: 0,
                dimmer: 0.6
            },
            Command::SetDimmer {
                light: 1,
                dimmer: 0.6
            }
        ]
    );
    assert_eq!(m.history.undo_len(), before + 1, "one undo step");
    // A curve edit: ↑ raises point 0 of each by 5 % of its own peak (the same file: equal).
    let peak = m.lights[0].curve.peak_cd();
    let first = m.lights[0].curve.intensities_cd()[0];
    send(&mut m, [key(KeyCode::Up)]);
    for i in 0..2 {
        assert_eq!(m.lights[i].curve.intensities_cd()[0], first + 0.05 * peak);
    }
    assert_eq!(
        m.lights[2].curve.intensities_cd()[0],
        2000.0,
        "the spot is not marked"
    );
    assert!(screen(&m, 120, 40).contains("group of 2 lights"));
    assert!(screen(&m, 120, 40).contains("2 marked"));
    // Undo restores both lights at once, bit for bit.
    send(&mut m, [ch('u')]);
    for i in 0..2 {
        assert_eq!(m.lights[i].curve.intensities_cd()[0], first);
        assert_eq!(m.lights[i].dimmer, 0.6);
    }
    send(&mut m, [ch('u')]);
    assert!(m.lights[..2].iter().all(|l| l.dimmer == 0.5));
    // Space toggles one mark; Esc clears them.
    send(&mut m, [key(KeyCode::Tab), ch(' ')]);
    assert_eq!(m.marked.iter().cloned().collect::<Vec<_>>(), ["a"]);
    send(&mut m, [key(KeyCode::Esc)]);
    assert!(m.marked.is_empty());
}

/// Aiming the selected light at a point turns every marked light by the same rotation: a
/// target stays a target at the same distance, turned about its own light.
#[test]
fn a_group_aim_turns_the_other_lights_by_the_same_rotation() {
    let dir = tempfile::tempdir().unwrap();
    let (_, mut m) = room_and_model(dir.path());
    // Mark a, select the spot.
    send(&mut m, [ch(' '), key(KeyCode::BackTab)]);
    assert_eq!(m.selected_light, 2);
    assert_eq!(m.marked.iter().cloned().collect::<Vec<_>>(), ["a"]);
    // The spot aims from (5, 3.5, 2.6) at (5, 1, 0.75); aim it at (3, 1, 0.75) instead.
    let old_spot = m.lights[2].aim;
    let target = DVec3::new(3.0, 1.0, 0.75);
    let effects = update(
        &mut m,
        Msg::Picked {
            pixel: (0, 0),
            hit: Some((target, 100.0)),
            aim: true,
        },
    );
    assert_eq!(engine_commands(&effects).len(), 2);
    let new_spot = m.lights[2].aim;
    assert!((new_spot - (target - m.lights[2].position).normalize()).length() < 1e-15);
    // a pointed straight down (no aim key): its direction turns by the spot's rotation.
    let turned = glam::DQuat::from_rotation_arc(old_spot, new_spot) * DVec3::NEG_Z;
    assert!((m.lights[0].aim - turned).length() < 1e-12, "{}", m.lights[0].aim);
    assert!(matches!(m.lights[0].aim_spec, AimSpec::Direction(_)));
    // The angle between the two lights' axes is kept.
    let angle = |a: DVec3, b: DVec3| a.dot(b).clamp(-1.0, 1.0).acos();
    assert!((angle(m.lights[0].aim, new_spot) - angle(DVec3::NEG_Z, old_spot)).abs() < 1e-12);
    // One undo brings both back.
    send(&mut m, [ch('u')]);
    assert_eq!(m.lights[2].aim, old_spot);
    assert_eq!(m.lights[0].aim, DVec3::NEG_Z);
}

#[test]
fn duplicate_and_delete_go_through_insert_and_remove_and_undo() {
    let dir = tempfile::tempdir().unwrap();
    let (_, mut m) = room_and_model(dir.path());
    let effects = send(&mut m, [ch('y')]);
    let commands = engine_commands(&effects);
    let [Command::Insert { at: 1, light }] = commands.as_slice() else {
        panic!("{commands:?}");
    };
    // Next to a, 0.5 m along +x, with a's photometry and dimmer.
    assert_eq!(light.name, "a copy");
    assert_eq!(light.position, DVec3::new(2.0, 2.0, 2.6));
    assert_eq!((&light.curve, light.dimmer), (&m.lights[0].curve, 0.5));
    assert_eq!(m.lights.len(), 4);
    assert_eq!(m.selected_light, 1, "the copy is selected");
    assert_eq!((m.series.len(), m.light_status.len()), (4, 4));
    assert!(m.dirty);
    // A second copy gets the next free name.
    send(&mut m, [key(KeyCode::BackTab), ch('y')]);
    assert_eq!(m.lights[1].name, "a copy 2");
    // Delete the selected copy; undo brings it back at its place; redo removes it again.
    let effects = send(&mut m, [ch('X')]);
    assert_eq!(engine_commands(&effects), vec![Command::Remove { light: 1 }]);
    assert_eq!(
        m.lights.iter().map(|l| l.name.as_str()).collect::<Vec<_>>(),
        ["a", "a copy", "b", "spot"]
    );
    send(&mut m, [ch('u')]);
    assert_eq!(m.lights[1].name, "a copy 2");
    send(
        &mut m,
        [KeyEvent::new(KeyCode::Char('r'), KeyModifiers::CONTROL)].map(Msg::Key),
    );
    assert_eq!(m.lights.len(), 4);
    // Deleting every light leaves an empty room that still draws.
    for _ in 0..4 {
        send(&mut m, [ch('X')]);
    }
    assert!(m.lights.is_empty());
    assert!(screen(&m, 120, 40).contains("no lights"));
}

/// A photometric file typed in: the app reads it and the light (and the marked ones) take its
/// curve, source and luminous area in one undo step; an asymmetric file is warned about in the
/// message, the light panel and the polar diagram, which draws the C-plane spread.
#[test]
fn a_typed_photometric_file_replaces_the_curve_and_warns_of_asymmetry() {
    let dir = tempfile::tempdir().unwrap();
    let (_, mut m) = room_and_model(dir.path());
    send(&mut m, [ch('F')]);
    assert_eq!(
        m.mode,
        Mode::PathEntry {
            buffer: String::new()
        }
    );
    let effects = send(&mut m, "../wall.ldt".chars().map(ch).chain([key(KeyCode::Enter)]));
    assert_eq!(effects, vec![Effect::LoadLid("../wall.ldt".into())]);
    // The app answers with the file it read.
    let path = repo("tests/data/ldt/sample_06.ldt");
    let lid = read_lid_file(&path).unwrap();
    let info = Arc::new(LidInfo::of(lid.clone()));
    let effects = update(
        &mut m,
        Msg::LidLoaded {
            path: path.clone(),
            result: Ok(Arc::clone(&info)),
        },
    );
    assert_eq!(
        engine_commands(&effects),
        vec![Command::SetPhotometry {
            light: 0,
            curve: lid.curve.clone(),
            source: LidSource::File {
                path: path.clone(),
                asymmetry: lid.asymmetry,
            },
            luminous: lid.luminous,
        }]
    );
    assert_eq!(m.lights[0].curve, lid.curve);
    let message = m.message.clone().unwrap();
    assert!(
        message.contains("asymmetry 0.44") && message.contains("above 0.1"),
        "{message}"
    );
    let text = screen(&m, 120, 40);
    assert!(text.contains("⚠ asymmetry 0.44 > 0.1"), "{text}");
    assert!(text.contains("C-plane average, asym 0.44"), "{text}");
    assert!(text.contains("━ C-planes"), "{text}");
    // The spread is drawn in its colour; the symmetric file of b has none.
    let mut terminal = Terminal::new(TestBackend::new(120, 40)).unwrap();
    terminal.draw(|f| view(&m, f, PreviewArea::Placeholder)).unwrap();
    let spread_cells = terminal
        .backend()
        .buffer()
        .content()
        .iter()
        .filter(|c| c.fg == haiko::tui::polar::SPREAD_COLOR && c.symbol() != " ")
        .count();
    assert!(spread_cells > 20, "{spread_cells}");
    send(&mut m, [key(KeyCode::Tab)]);
    assert!(!screen(&m, 120, 40).contains("C-planes"));
    // A file that cannot be read changes nothing.
    let effects = update(
        &mut m,
        Msg::LidLoaded {
            path: dir.path().join("missing.ies"),
            result: Err("missing.ies: not found".into()),
        },
    );
    assert!(effects.is_empty());
    assert_eq!(m.message.as_deref(), Some("missing.ies: not found"));
    // Undo gives a its own file back.
    send(&mut m, [key(KeyCode::BackTab), ch('u')]);
    assert_eq!(m.lights[0].lid_source, m.saved[0].lid_source);
}

fn stats(e_avg: f64, e_min: f64, e_max: f64) -> SurfaceStats {
    SurfaceStats {
        points: 54,
        maintenance_factor: 0.8,
        e_avg,
        e_min,
        e_max,
        u0: e_min / e_avg,
        g2: e_min / e_max,
    }
}

#[test]
fn the_numbers_panel_shows_each_surface_against_its_targets() {
    let dir = tempfile::tempdir().unwrap();
    let (_, mut m) = room_and_model(dir.path());
    let text = screen(&m, 120, 40);
    assert!(text.contains("numbers") && text.contains("computing…"), "{text}");
    let desk = stats(512.0, 320.0, 650.0);
    let plane = stats(467.0, 259.0, 657.0);
    let numbers = PanelNumbers {
        maintenance_factor: 0.8,
        surfaces: vec![
            SurfaceRow {
                name: "desk 1".into(),
                stats: Some(desk),
                check: Some(SurfaceCheck {
                    e_avg: Check::at_least(512.0, Some(500.0)),
                    u0: Check::at_least(desk.u0, Some(0.6)),
                    g2: Check::at_least(desk.g2, None),
                }),
                pass: Some(true),
            },
            SurfaceRow {
                name: "work plane".into(),
                stats: Some(plane),
                check: Some(SurfaceCheck {
                    e_avg: Check::at_least(467.0, Some(500.0)),
                    u0: Check::at_least(plane.u0, Some(0.6)),
                    g2: Check::at_least(plane.g2, None),
                }),
                pass: Some(false),
            },
        ],
        observers: vec![ObserverRow {
            name: "wall-y0 middle".into(),
            ugr: Some(18.4),
            status: UgrStatus::Rated,
            limit: Some(19.0),
            pass: Some(true),
        }],
        cursor: Some((DVec3::new(2.5, 1.6, 0.75), 612.4)),
        compute_ms: 1.25,
    };
    update(&mut m, Msg::Numbers(Box::new(numbers)));
    let text = screen(&m, 120, 40);
    let lines: Vec<&str> = text.lines().collect();
    let row = |needle: &str| {
        *lines
            .iter()
            .find(|l| l.contains(needle))
            .unwrap_or_else(|| panic!("{needle}:\n{text}"))
    };
    assert!(row("numbers · maintained (MF 0.80) · 1.2 ms").contains("numbers"));
    // U0 = 320/512 = 0.625 ≥ 0.6; g2 = 320/650 = 0.49 has no target.
    assert!(
        row("desk 1").contains("desk 1            512✓   320   650 0.62✓ 0.49   ≥500 U0≥0.60"),
        "{}",
        row("desk 1")
    );
    assert!(
        row("work plane").contains("467✗   259   657 0.55✗ 0.39"),
        "{}",
        row("work plane")
    );
    assert!(
        row("UGR max").contains("UGR max 18.4 ≤19✓  wall-y0 middle"),
        "{}",
        row("UGR max")
    );
    assert!(
        row("cursor").contains("cursor 612 lx at 2.50 1.60 0.75 m"),
        "{}",
        row("cursor")
    );
    assert!(text.contains("E 612 lx"), "the status line follows the cursor");
    // At 80 × 24 the panel has room for two surface rows: with three, it shows the first and
    // says what it left out.
    let mut numbers = m.numbers.clone().unwrap();
    let mut third = numbers.surfaces[0].clone();
    third.name = "desk 2".into();
    numbers.surfaces.push(third);
    update(&mut m, Msg::Numbers(Box::new(numbers)));
    let text = screen(&m, 80, 24);
    assert!(text.contains("desk 1    512✓   320   650 0.62✓ 0.49"), "{text}");
    assert!(text.contains("+2 more surfaces, 1 failing"), "{text}");
}

#[test]
fn saving_asks_how_to_write_an_edited_file_curve() {
    let dir = tempfile::tempdir().unwrap();
    let (_, mut m) = room_and_model(dir.path());
    // Unedited: no question.
    send(&mut m, [ch('D')]);
    assert_eq!(
        send(&mut m, [ch('s')]),
        vec![Effect::Save {
            curves: CurveSave::Inline,
            overwrite: false
        }]
    );
    // An edited point of a's file curve: the prompt, Enter writes new files (the default).
    send(&mut m, [key(KeyCode::Up), ch('s')]);
    assert_eq!(m.mode, Mode::ConfirmSave);
    let text = screen(&m, 120, 40);
    assert!(text.contains("Edited curves from photometric files: a"), "{text}");
    assert_eq!(
        send(&mut m, [key(KeyCode::Enter)]),
        vec![Effect::Save {
            curves: CurveSave::NewFiles,
            overwrite: false
        }]
    );
    send(&mut m, [ch('s')]);
    assert_eq!(send(&mut m, [key(KeyCode::Esc)]), vec![]);
    assert_eq!(m.mode, Mode::Normal);
}

/// A duplicated and moved light, a removed light and an edited file curve saved as a new IES
/// file: the room file loads back with exactly the editor's lights, the new IES file gives the
/// edited curve and the luminous area, and the untouched light keeps its `lid_file`.
#[test]
fn duplicated_moved_and_edited_lights_round_trip_through_the_room_file() {
    let dir = tempfile::tempdir().unwrap();
    let (path, mut m) = room_and_model(dir.path());
    // Duplicate b, move the copy 0.3 m along y, delete the spot; raise a's first point.
    send(&mut m, [key(KeyCode::Tab), ch('y'), ch('m')]);
    send(
        &mut m,
        [
            key(KeyCode::Up),
            key(KeyCode::Up),
            key(KeyCode::Up),
            key(KeyCode::Enter),
        ],
    );
    send(&mut m, [key(KeyCode::Tab), ch('X')]);
    send(
        &mut m,
        [
            key(KeyCode::Tab),
            key(KeyCode::Up),
            ch('%'),
            ch('3'),
            ch('0'),
            key(KeyCode::Enter),
        ],
    );
    let names: Vec<&str> = m.lights.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["a", "b", "b copy"]);
    let (message, sources) = save_with_curves(&path, &m, CurveSave::NewFiles).unwrap();
    assert!(message.contains("room-a.ies"), "{message}");
    update(&mut m, Msg::Saved { message, sources });
    assert!(!m.dirty);
    let new_file = dir.path().join("room-a.ies");
    assert_eq!(
        m.lights[0].lid_source,
        LidSource::File {
            path: new_file.clone(),
            asymmetry: 0.0
        }
    );
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.contains("# the downlights"), "comments kept:\n{text}");
    assert!(text.contains("lid_file = \"room-a.ies\""), "{text}");
    assert_eq!(text.matches("lid_file = \"down.ldt\"").count(), 2, "{text}");
    assert!(!text.contains("spot"), "{text}");
    // Loading the saved file gives the editor's lights.
    let scene = scene::load(&path).unwrap();
    assert_eq!(scene.lights.len(), 3);
    for (loaded, edited) in scene.lights.iter().zip(&m.lights) {
        assert_eq!(loaded.name, edited.name);
        // Positions are written to six significant digits (2.3000000000000003 → 2.3).
        assert!(
            (loaded.position - edited.position).length() < 1e-12,
            "{}",
            edited.name
        );
        assert_eq!(loaded.curve, edited.curve, "{}", edited.name);
        assert_eq!(loaded.dimmer, edited.dimmer, "{}", edited.name);
        assert!((loaded.aim - edited.aim).length() < 1e-15, "{}", edited.name);
        assert_eq!(loaded.luminous, edited.luminous, "{}", edited.name);
    }
    assert_eq!(scene.lights[2].position, DVec3::new(3.5, 2.3, 2.6));
    assert_eq!(scene.lights[0].dimmer, 0.3);
    // The new IES file reads back with the edited values and the file's luminous disc.
    let lid = read_lid_file(&new_file).unwrap();
    let original = read_lid_file(&dir.path().join("down.ldt")).unwrap();
    let raised = original.curve.intensities_cd()[0] + 0.05 * original.curve.peak_cd();
    assert_eq!(lid.curve.intensities_cd()[0], raised);
    assert_eq!(
        lid.curve.intensities_cd()[1..],
        original.curve.intensities_cd()[1..]
    );
    assert_eq!(lid.luminous, original.luminous);
    // Nothing is left to write.
    let again = save_room(&path, &text, &m).unwrap();
    assert!(again.starts_with("saved"));
    assert_eq!(std::fs::read_to_string(&path).unwrap(), text);
}

/// Saving inline: the edited file curve replaces `lid_file` by `lid` (the old behaviour, now a
/// choice), and a failed save leaves no new IES file behind.
#[test]
fn an_inline_save_writes_the_curve_and_a_failed_save_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let (path, mut m) = room_and_model(dir.path());
    send(&mut m, [key(KeyCode::Up)]);
    let (_, sources) = save_with_curves(&path, &m, CurveSave::Inline).unwrap();
    assert_eq!(sources[0], LidSource::Inline);
    let text = std::fs::read_to_string(&path).unwrap();
    assert_eq!(text.matches("lid_file").count(), 1, "{text}");
    // A room file changed on disk (a light renamed) refuses the save: no IES file remains.
    let (path, mut m) = room_and_model(dir.path());
    send(&mut m, [key(KeyCode::Up)]);
    std::fs::write(&path, ROOM.replace("name = \"b\"", "name = \"other\"")).unwrap();
    let err = save_with_curves(&path, &m, CurveSave::NewFiles).unwrap_err();
    assert!(err.to_string().contains("light[1].name"), "{err}");
    assert!(!dir.path().join("room-a.ies").exists());
}
