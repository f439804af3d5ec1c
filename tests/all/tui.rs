//! The editor core without a terminal: `update` for every action, undo/redo, saving the room
//! file, and full-screen snapshots drawn on ratatui's `TestBackend`.

use std::path::PathBuf;

use glam::DVec3;
use haiko::photometry::Curve;
use haiko::scene::design::Design;
use haiko::scene::{AimSpec, Camera, LidSource, Light, PatchMesh, Scene, Settings};
use haiko::session::{Command, Series};
use haiko::tui::keys::{self, BINDINGS, ModeKind};
use haiko::tui::model::{MAX_ORDER, WindowChoice};
use haiko::tui::msg::CurveSave;
use haiko::tui::save::{edit_room_text, round_significant, save_room};
use haiko::tui::view::{cell_to_pixel, preview_rect};
use haiko::tui::{Effect, Mode, Model, Msg, PreviewArea, update, view};
use ratatui::Terminal;
use ratatui::backend::TestBackend;
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyEventKind, KeyModifiers};
use ratatui::layout::{Position, Rect};

const CENTRE_LID: [(f64, f64); 4] = [(0.0, 1000.0), (30.0, 950.0), (60.0, 700.0), (90.0, 0.0)];
const SPOT_LID: [(f64, f64); 3] = [(0.0, 2000.0), (15.0, 1800.0), (25.0, 0.0)];

fn light(name: &str, position: DVec3, aim_spec: AimSpec, lid: &[(f64, f64)], source: LidSource) -> Light {
    let aim = match aim_spec {
        AimSpec::Target(p) => (p - position).normalize(),
        AimSpec::Direction(d) => d.normalize(),
    };
    Light {
        name: name.into(),
        position,
        aim,
        aim_spec,
        curve: Curve::new(lid).unwrap(),
        lid_source: source,
        order: None,
        radius: 0.05,
        dimmer: 1.0,
        color: [1.0; 3],
        luminous: None,
    }
}

/// A 6 × 4 × 2.7 m box room with a downlight ("centre", inline lid, order 5) and a spot
/// ("spot", from a lid_file, aimed by direction): the same lights as [`ROOM_TEXT`].
fn scene() -> Scene {
    let mut centre = light(
        "centre",
        DVec3::new(3.0, 2.0, 2.6),
        AimSpec::Target(DVec3::new(3.0, 2.0, 0.0)),
        &CENTRE_LID,
        LidSource::Inline,
    );
    centre.order = Some(5);
    let spot = light(
        "spot",
        DVec3::new(1.0, 1.0, 2.5),
        AimSpec::Direction(DVec3::new(1.0, 0.0, -1.0).normalize()),
        &SPOT_LID,
        LidSource::File {
            path: PathBuf::from("spot.ies"),
            asymmetry: 0.0,
        },
    );
    Scene {
        path: PathBuf::from("room.toml"),
        name: "Paper example".into(),
        room_size: DVec3::new(6.0, 4.0, 2.7),
        surfaces: Vec::new(),
        fine: PatchMesh::default(),
        coarse: PatchMesh::default(),
        boxes: Vec::new(),
        mesh_bounds: Vec::new(),
        lights: vec![centre, spot],
        camera: Camera {
            eye: DVec3::new(0.5, 0.5, 1.6),
            target: DVec3::new(3.0, 2.0, 0.8),
            fov_deg: 60.0,
        },
        settings: Settings::default(),
        design: Design::default_for(DVec3::new(6.0, 4.0, 2.7)),
        notes: Vec::new(),
    }
}

const ROOM_TEXT: &str = r#"# Test room: comments and odd formatting must survive a save
version   = 1
name = "Paper example"   # the name

[room]
size = [ 6.0,4.0 , 2.7 ]   # odd spacing
[room.reflectance]
floor = 0.2
walls = 0.5
ceiling = 0.7

# The main light
[[light]]
name = "centre"
position = [3.0, 2.0, 2.6]     # hung 10 cm below the ceiling
aim = [3.0, 2.0, 0.0]        # straight down
lid = [[0, 1000], [30, 950], [60, 700], [90, 0]]   # cd
order = 5

[[light]]
name    =    "spot"
position = [1.0, 1.0, 2.5]
aim_dir = [1, 0, -1]
lid_file = "spot.ies"   # from the manufacturer
radius = 0.05

[camera]
eye = [0.5, 0.5, 1.6]
target = [3.0, 2.0, 0.8]
fov_deg = 60
"#;

fn model() -> Model {
    Model::new(&scene(), (120, 40), (8, 16))
}

fn press(code: KeyCode, modifiers: KeyModifiers) -> Msg {
    Msg::Key(KeyEvent::new(code, modifiers))
}
fn key(code: KeyCode) -> Msg {
    press(code, KeyModifiers::NONE)
}
fn ch(c: char) -> Msg {
    key(KeyCode::Char(c))
}
/// Sends `msgs` in order; returns the effects of the last one.
fn send(model: &mut Model, msgs: impl IntoIterator<Item = Msg>) -> Vec<Effect> {
    msgs.into_iter().fold(Vec::new(), |_, msg| update(model, msg))
}
fn type_keys(model: &mut Model, text: &str) -> Vec<Effect> {
    send(model, text.chars().map(ch))
}
fn cd(model: &Model, light: usize, k: usize) -> f64 {
    model.lights[light].curve.intensities_cd()[k]
}
fn gamma(model: &Model, light: usize, k: usize) -> f64 {
    model.lights[light].curve.gammas_deg()[k]
}
fn points(model: &Model, light: usize) -> Vec<(f64, f64)> {
    model.lights[light].curve.points().collect()
}
fn assert_close(actual: f64, expected: f64) {
    assert!(
        (actual - expected).abs() <= 1e-9 * expected.abs().max(1.0),
        "{actual} vs {expected}"
    );
}
/// The one command an edit sends the engine (and nothing else).
fn command(effects: Vec<Effect>) -> Command {
    match effects.as_slice() {
        [Effect::Engine(command)] => command.clone(),
        other => panic!("expected one engine command, got {other:?}"),
    }
}
/// True when `effects` are one command for light 0.
fn edits_light_0(effects: Vec<Effect>) -> bool {
    command(effects).light() == Some(0)
}

// ---------------------------------------------------------------- update: curve edits

#[test]
fn up_and_down_change_the_point_by_five_percent_of_the_peak() {
    let mut m = model();
    assert_eq!(
        command(update(&mut m, key(KeyCode::Up))),
        Command::SetIntensity {
            light: 0,
            point: 0,
            candela: 1050.0
        }
    );
    assert_close(cd(&m, 0, 0), 1050.0); // 1000 + 5 % of 1000
    assert!(m.dirty);
    update(&mut m, ch('k'));
    assert_close(cd(&m, 0, 0), 1102.5); // the peak is now 1050: + 52.5
    update(&mut m, key(KeyCode::Down));
    assert_close(cd(&m, 0, 0), 1102.5 - 0.05 * 1102.5);
    // Lowering a point that is not the peak uses the peak: 950 − 5 % of 1047.375.
    let peak = cd(&m, 0, 0);
    send(&mut m, [ch('l'), ch('j')]);
    assert_close(cd(&m, 0, 1), 950.0 - 0.05 * peak);
}

#[test]
fn lowering_clamps_at_zero_and_a_no_op_is_not_an_edit() {
    let mut m = model();
    send(&mut m, [ch('l'), ch('l'), ch('l')]);
    assert_eq!(m.selected_point, 3);
    assert_eq!(update(&mut m, key(KeyCode::Down)), vec![]); // already 0 cd
    assert_eq!(cd(&m, 0, 3), 0.0);
    assert_eq!(m.history.undo_len(), 0);
    assert!(!m.dirty);
    // 700 cd lowered 15 times by 50 cd (5 % of the 1000 cd peak) stops at 0, not below.
    send(&mut m, [ch('h')]);
    send(&mut m, std::iter::repeat_n(ch('j'), 15));
    assert_eq!(cd(&m, 0, 2), 0.0);
}

#[test]
fn shift_gives_the_fine_half_percent_step() {
    let mut m = model();
    send(&mut m, [ch('l')]);
    assert!(edits_light_0(update(
        &mut m,
        press(KeyCode::Up, KeyModifiers::SHIFT)
    )));
    assert_close(cd(&m, 0, 1), 955.0); // + 0.5 % of 1000
    update(&mut m, press(KeyCode::Char('K'), KeyModifiers::SHIFT));
    assert_close(cd(&m, 0, 1), 960.0);
    update(&mut m, press(KeyCode::Down, KeyModifiers::SHIFT));
    update(&mut m, ch('J'));
    assert_close(cd(&m, 0, 1), 950.0);
}

#[test]
fn angle_keys_move_the_point_within_its_neighbours() {
    let mut m = model();
    send(&mut m, [ch('l')]);
    assert!(edits_light_0(update(&mut m, ch('>'))));
    assert_eq!(gamma(&m, 0, 1), 31.0);
    update(&mut m, ch(','));
    assert_eq!(gamma(&m, 0, 1), 26.0);
    update(&mut m, ch('<'));
    assert_eq!(gamma(&m, 0, 1), 25.0);
    // Upwards in 5° steps: 30 … 55, then clamped at the next point (60°) — a step.
    send(&mut m, std::iter::repeat_n(ch('.'), 10));
    assert_eq!(gamma(&m, 0, 1), 60.0);
    assert_eq!(gamma(&m, 0, 2), 60.0);
    // The first point cannot go below 0°: no change, no edit.
    let edits = m.history.undo_len();
    send(&mut m, [ch('h')]);
    assert_eq!(update(&mut m, ch('<')), vec![]);
    assert_eq!(gamma(&m, 0, 0), 0.0);
    assert_eq!(m.history.undo_len(), edits);
}

#[test]
fn insert_splits_a_segment_on_the_curve_and_delete_removes_it() {
    let mut m = model();
    send(&mut m, [ch('l')]);
    assert!(edits_light_0(update(&mut m, ch('+'))));
    // Halfway between 30° (950 cd) and 60° (700 cd): 45°, 825 cd; the new point is selected.
    assert_eq!(points(&m, 0)[2], (45.0, 825.0));
    assert_eq!(m.selected_point, 2);
    assert_eq!(m.lights[0].curve.len(), 5);
    update(&mut m, ch('-'));
    assert_eq!(points(&m, 0), CENTRE_LID.to_vec());
    // Insert at the last point goes between the last two: 75°, 350 cd.
    send(&mut m, [ch('l'), ch('l'), ch('l'), ch('+')]);
    assert_eq!(points(&m, 0)[3], (75.0, 350.0));
}

#[test]
fn delete_refuses_to_leave_fewer_than_two_points() {
    let mut m = model();
    send(&mut m, [ch('-'), ch('-')]);
    assert_eq!(points(&m, 0), vec![(60.0, 700.0), (90.0, 0.0)]);
    assert_eq!(update(&mut m, ch('-')), vec![]);
    assert_eq!(m.lights[0].curve.len(), 2);
    assert!(m.message.as_deref().unwrap().contains("at least two"));
}

#[test]
fn typed_value_sets_the_intensity_exactly() {
    let mut m = model();
    send(&mut m, [ch('l'), ch('=')]);
    assert_eq!(
        m.mode,
        Mode::ValueEntry {
            buffer: String::new()
        }
    );
    type_keys(&mut m, "12345.6");
    update(&mut m, key(KeyCode::Backspace));
    assert_eq!(
        m.mode,
        Mode::ValueEntry {
            buffer: "12345.".into()
        }
    );
    type_keys(&mut m, "25");
    assert!(edits_light_0(update(&mut m, key(KeyCode::Enter))));
    assert_eq!(cd(&m, 0, 1), 12345.25);
    assert_eq!(m.mode, Mode::Normal);
}

#[test]
fn invalid_typed_value_changes_nothing_and_says_why() {
    let mut m = model();
    send(&mut m, [ch('=')]);
    type_keys(&mut m, "1.2.3");
    assert_eq!(update(&mut m, key(KeyCode::Enter)), vec![]);
    assert_eq!(points(&m, 0), CENTRE_LID.to_vec());
    assert_eq!(m.mode, Mode::Normal);
    assert!(m.message.as_deref().unwrap().contains("'1.2.3'"));
    assert_eq!(m.history.undo_len(), 0);
    // Empty input is invalid too; Esc cancels without a message.
    send(&mut m, [ch('='), key(KeyCode::Enter)]);
    assert!(m.message.is_some());
    send(&mut m, [ch('='), ch('5'), key(KeyCode::Esc)]);
    assert_eq!(m.mode, Mode::Normal);
    assert_eq!(cd(&m, 0, 0), 1000.0);
    // Letters are not typed into the value.
    send(&mut m, [ch('='), ch('x'), ch('7')]);
    assert_eq!(m.mode, Mode::ValueEntry { buffer: "7".into() });
}

#[test]
fn order_changes_rebake_and_clamp_and_window_cycles() {
    let mut m = model();
    assert_eq!(m.lights[0].order, 5);
    assert_eq!(
        command(update(&mut m, ch('O'))),
        Command::SetOrder { light: 0, order: 6 }
    );
    assert_eq!(m.lights[0].order, 6);
    send(&mut m, std::iter::repeat_n(ch('o'), 10));
    assert_eq!(m.lights[0].order, 0);
    m.lights[0].order = MAX_ORDER;
    update(&mut m, ch('O'));
    assert_eq!(m.lights[0].order, MAX_ORDER);

    let mut m = model();
    let expected = [
        WindowChoice::None,
        WindowChoice::Hann,
        WindowChoice::Lanczos,
        WindowChoice::Cesaro2,
        WindowChoice::Auto,
    ];
    for window in expected {
        assert_eq!(
            command(update(&mut m, ch('w'))),
            Command::SetWindow { light: 0, window }
        );
        assert_eq!(m.lights[0].window, window);
    }
    // The window is a session choice: not a change to save.
    assert!(!m.dirty);
}

#[test]
fn tab_and_backtab_switch_lights_and_keep_the_point_in_range() {
    let mut m = model();
    send(&mut m, [ch('l'), ch('l'), ch('l')]);
    // The aim line drawn on the preview moves to the new light.
    assert_eq!(update(&mut m, key(KeyCode::Tab)), vec![Effect::Render]);
    assert_eq!(m.selected_light, 1);
    assert_eq!(m.selected_point, 2); // the spot has 3 points
    update(&mut m, key(KeyCode::Tab));
    assert_eq!(m.selected_light, 0);
    update(&mut m, press(KeyCode::BackTab, KeyModifiers::SHIFT));
    assert_eq!(m.selected_light, 1);
    // Edits now go to the spot.
    send(&mut m, [ch('h'), ch('h'), key(KeyCode::Up)]);
    assert_close(cd(&m, 1, 0), 2100.0);
    assert_eq!(points(&m, 0), CENTRE_LID.to_vec());
}

// ---------------------------------------------------------------- update: aim, move, dimmer

#[test]
fn aim_mode_cursor_steps_are_fractions_of_the_preview() {
    let mut m = model();
    let (w, h) = m.preview_px;
    let inner = preview_rect(Rect::new(0, 0, 120, 40));
    assert_eq!((w, h), (u32::from(inner.width) * 8, u32::from(inner.height) * 16));
    let centre = (w / 2, h / 2);
    assert_eq!(
        update(&mut m, ch('a')),
        vec![
            Effect::Render,
            Effect::Pick {
                pixel: centre,
                aim: false
            }
        ]
    );
    assert_eq!(m.mode, Mode::Aim { cursor: centre });
    update(&mut m, key(KeyCode::Right));
    assert_eq!(
        m.mode,
        Mode::Aim {
            cursor: (centre.0 + w / 40, centre.1)
        }
    );
    let effects = update(&mut m, press(KeyCode::Up, KeyModifiers::SHIFT));
    let cursor = (centre.0 + w / 40, centre.1 - h / 8);
    assert_eq!(
        effects,
        vec![
            Effect::Render,
            Effect::Pick {
                pixel: cursor,
                aim: false
            }
        ]
    );
    // The cursor stops at the preview's edge.
    send(
        &mut m,
        std::iter::repeat_n(press(KeyCode::Left, KeyModifiers::SHIFT), 20),
    );
    send(&mut m, std::iter::repeat_n(key(KeyCode::Down), 100));
    assert_eq!(m.mode, Mode::Aim { cursor: (0, h - 1) });
    // Leaving aim mode takes the cursor off the preview.
    assert_eq!(update(&mut m, key(KeyCode::Esc)), vec![Effect::Render]);
    assert_eq!(m.mode, Mode::Normal);
}

#[test]
fn aiming_via_picked_sets_the_exact_axis_and_a_target() {
    let mut m = model();
    update(&mut m, ch('a'));
    let cursor = match m.mode {
        Mode::Aim { cursor } => cursor,
        _ => panic!("not in aim mode"),
    };
    assert_eq!(
        update(&mut m, key(KeyCode::Enter)),
        vec![
            Effect::Render,
            Effect::Pick {
                pixel: cursor,
                aim: true
            }
        ]
    );
    assert_eq!(m.mode, Mode::Normal);
    let point = DVec3::new(4.0, 2.0, 0.0);
    let effects = update(
        &mut m,
        Msg::Picked {
            pixel: cursor,
            hit: Some((point, 123.0)),
            aim: true,
        },
    );
    assert_eq!(
        command(effects),
        Command::Aim {
            light: 0,
            spec: AimSpec::Target(point)
        }
    );
    // (4, 2, 0) − (3, 2, 2.6) = (1, 0, −2.6), length √7.76.
    let len = 7.76f64.sqrt();
    let aim = m.lights[0].aim;
    assert_close(aim.x, 1.0 / len);
    assert_eq!(aim.y, 0.0);
    assert_close(aim.z, -2.6 / len);
    assert_eq!(m.lights[0].aim_spec, AimSpec::Target(point));
    assert_eq!(m.picked.unwrap().lux, 123.0);
    assert!(m.dirty);
    update(&mut m, ch('u'));
    assert_eq!(m.lights[0].aim, DVec3::new(0.0, 0.0, -1.0));
    assert!(!m.dirty);
}

#[test]
fn picks_without_aim_or_without_a_hit_change_no_light() {
    let mut m = model();
    let hit = Some((DVec3::new(1.0, 1.0, 0.0), 250.0));
    assert_eq!(
        update(
            &mut m,
            Msg::Picked {
                pixel: (5, 5),
                hit,
                aim: false
            }
        ),
        vec![]
    );
    assert_eq!(m.picked.unwrap().point, DVec3::new(1.0, 1.0, 0.0));
    assert_eq!(
        update(
            &mut m,
            Msg::Picked {
                pixel: (5, 5),
                hit: None,
                aim: true
            }
        ),
        vec![]
    );
    assert!(m.message.is_some());
    assert_eq!(m.lights, model().lights);
    // Aiming at the light's own position is refused.
    let own = Some((DVec3::new(3.0, 2.0, 2.6), 0.0));
    assert_eq!(
        update(
            &mut m,
            Msg::Picked {
                pixel: (5, 5),
                hit: own,
                aim: true
            }
        ),
        vec![]
    );
    assert_eq!(m.lights, model().lights);
}

#[test]
fn mouse_click_in_the_preview_picks_its_pixel_and_aims_only_in_aim_mode() {
    let mut m = model();
    let area = preview_rect(Rect::new(0, 0, 120, 40));
    let cell = Position::new(area.x + 3, area.y + 2);
    // Cell (3, 2) of the image: its centre (3.5, 2.5) cells = (28, 40) pixels of 8 × 16.
    assert_eq!(
        cell_to_pixel(cell, area, m.preview_px.0, m.preview_px.1),
        Some((28, 40))
    );
    let effects = update(
        &mut m,
        Msg::Click {
            column: cell.x,
            row: cell.y,
        },
    );
    // Outside aim mode a click reads the point and aims nothing (issue: a stray click re-aimed
    // the light).
    assert_eq!(
        effects,
        vec![Effect::Pick {
            pixel: (28, 40),
            aim: false
        }]
    );
    assert_eq!(m.mode, Mode::Normal);
    // In aim mode it aims, and aim mode ends.
    update(&mut m, ch('a'));
    assert!(matches!(m.mode, Mode::Aim { .. }));
    assert_eq!(
        update(
            &mut m,
            Msg::Click {
                column: cell.x,
                row: cell.y
            }
        ),
        vec![
            Effect::Render,
            Effect::Pick {
                pixel: (28, 40),
                aim: true
            }
        ]
    );
    assert_eq!(m.mode, Mode::Normal);
    // Outside aim mode the mouse moving does nothing; in aim mode the cursor follows it over
    // the preview (read there, as the arrow keys' cursor), and a click where it rests aims there.
    let hover = |m: &mut Model, cell: Position| {
        update(
            m,
            Msg::Hover {
                column: cell.x,
                row: cell.y,
            },
        )
    };
    assert_eq!(hover(&mut m, cell), vec![]);
    update(&mut m, ch('a'));
    let next = Position::new(cell.x + 1, cell.y);
    assert_eq!(
        hover(&mut m, next),
        vec![
            Effect::Render,
            Effect::Pick {
                pixel: (36, 40),
                aim: false
            }
        ]
    );
    assert_eq!(m.mode, Mode::Aim { cursor: (36, 40) });
    assert_eq!(hover(&mut m, next), vec![], "the same pixel: nothing new");
    assert_eq!(hover(&mut m, Position::new(0, 0)), vec![], "outside the preview");
    assert_eq!(m.mode, Mode::Aim { cursor: (36, 40) });
    assert_eq!(
        update(
            &mut m,
            Msg::Click {
                column: next.x,
                row: next.y
            }
        ),
        vec![
            Effect::Render,
            Effect::Pick {
                pixel: (36, 40),
                aim: true
            }
        ]
    );
    // Outside the preview: nothing.
    assert_eq!(update(&mut m, Msg::Click { column: 0, row: 0 }), vec![]);
    // During help: nothing.
    update(&mut m, ch('?'));
    assert_eq!(
        update(
            &mut m,
            Msg::Click {
                column: cell.x,
                row: cell.y
            }
        ),
        vec![]
    );
}

#[test]
fn move_mode_moves_in_tenths_and_rebakes_on_leaving() {
    let mut m = model();
    update(&mut m, ch('m'));
    assert!(matches!(m.mode, Mode::Move { .. }));
    // Each step goes to the engine at once (it re-bakes the moved light in the background).
    assert_eq!(
        command(update(&mut m, key(KeyCode::Right))),
        Command::Move {
            light: 0,
            position: DVec3::new(3.1, 2.0, 2.6)
        }
    );
    send(
        &mut m,
        [key(KeyCode::Right), key(KeyCode::Down), key(KeyCode::PageUp)],
    );
    let p = m.lights[0].position;
    assert_close(p.x, 3.2);
    assert_close(p.y, 1.9);
    assert_close(p.z, 2.69); // 1 cm below the ceiling: a light on it could not be loaded
    update(&mut m, key(KeyCode::PageUp));
    assert_close(m.lights[0].position.z, 2.69); // clamped inside the room
    // Still aimed at its target (3, 2, 0).
    let expected_aim = (DVec3::new(3.0, 2.0, 0.0) - p).normalize();
    assert!((m.lights[0].aim - expected_aim).length() < 1e-12);
    // The engine has every step already: leaving move mode sends nothing.
    assert_eq!(update(&mut m, key(KeyCode::Enter)), vec![]);
    assert_eq!(m.mode, Mode::Normal);
    // The whole move is one undo step.
    assert_eq!(m.history.undo_len(), 1);
    assert_eq!(
        command(update(&mut m, ch('u'))),
        Command::Move {
            light: 0,
            position: DVec3::new(3.0, 2.0, 2.6)
        }
    );
    assert_eq!(m.lights, model().lights);
}

#[test]
fn move_mode_escape_restores_the_position() {
    let mut m = model();
    send(&mut m, [ch('m')]);
    send(&mut m, std::iter::repeat_n(key(KeyCode::Left), 40));
    assert_eq!(m.lights[0].position.x, 0.01); // 1 cm from the wall x = 0
    assert_eq!(
        command(update(&mut m, key(KeyCode::Esc))),
        Command::Move {
            light: 0,
            position: DVec3::new(3.0, 2.0, 2.6)
        }
    );
    assert_eq!(m.lights, model().lights);
    assert_eq!(m.history.undo_len(), 0);
    assert!(!m.dirty);
}

#[test]
fn dimmer_steps_by_tenths_and_clamps_at_zero() {
    let mut m = model();
    assert!(edits_light_0(update(&mut m, ch('d'))));
    assert_eq!(m.lights[0].dimmer, 0.9);
    send(&mut m, std::iter::repeat_n(ch('d'), 8));
    assert_eq!(m.lights[0].dimmer, 0.1);
    update(&mut m, ch('d'));
    assert_eq!(m.lights[0].dimmer, 0.0);
    assert_eq!(update(&mut m, ch('d')), vec![]);
    send(&mut m, [ch('D'), ch('D'), ch('D')]);
    assert_eq!(m.lights[0].dimmer, 0.3); // 3/10, no 0.30000000000000004
    m.lights[0].dimmer = 0.95;
    update(&mut m, ch('D'));
    assert_eq!(m.lights[0].dimmer, 1.0);
}

#[test]
fn camera_keys_orbit_pan_dolly_and_reset() {
    let mut m = model();
    let home = m.camera;
    let offset = home.eye - home.target;
    assert!(matches!(command(update(&mut m, ch(']'))), Command::SetCamera(_)));
    let turned = m.camera.eye - m.camera.target;
    // A 5° yaw about z: same height and horizontal distance, 5° between the horizontal parts.
    assert_close(turned.z, offset.z);
    assert_close(turned.truncate().length(), offset.truncate().length());
    let cos = turned.truncate().dot(offset.truncate()) / offset.truncate().length_squared();
    assert_close(cos, 5f64.to_radians().cos());
    update(&mut m, ch('c'));
    assert_eq!(m.camera, home);
    update(&mut m, key(KeyCode::PageUp));
    assert_close((m.camera.eye - m.camera.target).length(), 0.9 * offset.length());
    update(&mut m, ch('c'));
    update(&mut m, press(KeyCode::Right, KeyModifiers::CONTROL));
    assert!((m.camera.eye - m.camera.target - offset).length() < 1e-12);
    assert_close((m.camera.target - home.target).length(), 0.1);
    assert_close((m.camera.target - home.target).dot(offset), 0.0);
    update(&mut m, ch('f'));
    assert!(m.false_colour);
}

/// The preview keys: exposure steps of ½ stop from the room's exposure, automatic exposure and
/// back, the refit counter, isolux lines and the plan view, all carried by the frame spec; none
/// is an edit of the room.
#[test]
fn preview_keys_step_the_exposure_toggle_isolux_and_the_plan_and_refit() {
    use haiko::render::DisplayMode;
    use haiko::session::{ExposureChoice, ViewChoice};
    use haiko::tui::app::frame_spec;
    let mut m = model();
    m.preview_px = (320, 240);
    let spec = frame_spec(&m).unwrap();
    assert_eq!(spec.exposure, ExposureChoice::Room { brighter_ev: 0.0 });
    assert_eq!(
        (spec.view, spec.isolux, spec.legend, spec.mode),
        (ViewChoice::Camera, false, true, DisplayMode::Photo)
    );
    for (keys, brighter_ev) in [("e", 0.5), ("ee", 1.5), ("E", 1.0), ("EEEE", -1.0)] {
        for c in keys.chars() {
            assert!(
                !update(&mut m, ch(c))
                    .iter()
                    .any(|e| matches!(e, Effect::Engine(_)))
            );
        }
        assert_eq!(
            frame_spec(&m).unwrap().exposure,
            ExposureChoice::Room { brighter_ev }
        );
    }
    update(&mut m, ch('x'));
    assert_eq!(frame_spec(&m).unwrap().exposure, ExposureChoice::Auto);
    // A step from the automatic exposure starts from the room's exposure.
    update(&mut m, ch('e'));
    assert_eq!(
        frame_spec(&m).unwrap().exposure,
        ExposureChoice::Room { brighter_ev: 0.5 }
    );
    update(&mut m, ch('x'));
    update(&mut m, ch('x'));
    assert_eq!(
        frame_spec(&m).unwrap().exposure,
        ExposureChoice::Room { brighter_ev: 0.0 }
    );
    let refit = frame_spec(&m).unwrap().refit;
    update(&mut m, ch('r'));
    assert_eq!(frame_spec(&m).unwrap().refit, refit + 1);
    update(&mut m, ch('i'));
    update(&mut m, ch('p'));
    let spec = frame_spec(&m).unwrap();
    assert!(spec.isolux);
    assert_eq!(spec.view, ViewChoice::Plan);
    update(&mut m, ch('p'));
    assert_eq!(frame_spec(&m).unwrap().view, ViewChoice::Camera);
    // P: from the camera straight to the work plane's plan, then the floor's, and back.
    update(&mut m, ch('P'));
    assert_eq!(frame_spec(&m).unwrap().view, ViewChoice::WorkPlane);
    update(&mut m, ch('P'));
    assert_eq!(frame_spec(&m).unwrap().view, ViewChoice::Plan);
    update(&mut m, ch('P'));
    assert_eq!(frame_spec(&m).unwrap().view, ViewChoice::WorkPlane);
    update(&mut m, ch('p'));
    assert_eq!(frame_spec(&m).unwrap().view, ViewChoice::Camera);
    assert!(!m.dirty, "preview keys do not edit the room");
}

// ---------------------------------------------------------------- update: history, quit, save

/// A session touching every kind of edit on both lights.
fn edit_session(m: &mut Model) {
    send(m, [key(KeyCode::Up), ch('l'), ch('>'), ch('+'), ch('=')]);
    type_keys(m, "512.5");
    send(m, [key(KeyCode::Enter), ch('O'), ch('w'), ch('d')]);
    send(m, [ch('a'), key(KeyCode::Enter)]);
    let hit = Some((DVec3::new(5.0, 3.0, 0.0), 80.0));
    update(
        m,
        Msg::Picked {
            pixel: (0, 0),
            hit,
            aim: true,
        },
    );
    send(m, [ch('m'), key(KeyCode::Up), key(KeyCode::Enter)]);
    send(
        m,
        [
            key(KeyCode::Tab),
            ch('-'),
            press(KeyCode::Down, KeyModifiers::SHIFT),
            ch('D'),
        ],
    );
}

#[test]
fn undo_all_restores_and_redo_all_replays_exactly() {
    let mut m = model();
    let initial = m.lights.clone();
    edit_session(&mut m);
    let edited = m.lights.clone();
    let n = m.history.undo_len();
    assert_eq!(n, 12);
    assert!(m.dirty);
    for _ in 0..n {
        assert!(!update(&mut m, ch('u')).is_empty());
    }
    assert_eq!(m.lights, initial);
    assert!(!m.dirty);
    assert_eq!(update(&mut m, ch('u')), vec![]);
    assert_eq!(m.message.as_deref(), Some("nothing to undo"));
    let redo = press(KeyCode::Char('r'), KeyModifiers::CONTROL);
    for _ in 0..n {
        assert!(!update(&mut m, redo.clone()).is_empty());
    }
    assert_eq!(m.lights, edited);
    assert!(m.dirty);
}

#[test]
fn a_new_edit_clears_redo() {
    let mut m = model();
    send(&mut m, [key(KeyCode::Up), key(KeyCode::Up), ch('u')]);
    assert_eq!(m.history.redo_len(), 1);
    update(&mut m, ch('d'));
    assert_eq!(m.history.redo_len(), 0);
    assert_eq!(
        update(&mut m, press(KeyCode::Char('r'), KeyModifiers::CONTROL)),
        vec![]
    );
    assert_close(cd(&m, 0, 0), 1050.0);
    assert_eq!(m.lights[0].dimmer, 0.9);
    // Undo selects the light it changes.
    send(&mut m, [key(KeyCode::Tab)]);
    update(&mut m, ch('u'));
    assert_eq!(m.selected_light, 0);
}

#[test]
fn quit_asks_only_with_unsaved_changes() {
    let mut m = model();
    assert_eq!(update(&mut m, ch('q')), vec![Effect::Quit]);
    update(&mut m, key(KeyCode::Up));
    assert_eq!(update(&mut m, ch('q')), vec![]);
    assert_eq!(m.mode, Mode::ConfirmQuit);
    assert_eq!(update(&mut m, ch('n')), vec![]);
    assert_eq!(m.mode, Mode::Normal);
    send(&mut m, [ch('q'), key(KeyCode::Esc)]);
    assert_eq!(m.mode, Mode::Normal);
    // Other keys do nothing at the prompt.
    update(&mut m, ch('q'));
    assert_eq!(update(&mut m, key(KeyCode::Up)), vec![]);
    assert_close(cd(&m, 0, 0), 1050.0);
    assert_eq!(update(&mut m, ch('y')), vec![Effect::Quit]);
}

#[test]
fn saved_clears_dirty_only_when_the_app_reports_success() {
    let mut m = model();
    send(&mut m, [key(KeyCode::Tab), key(KeyCode::Up)]);
    // The spot's curve came from a file: the save asks how to write it.
    assert_eq!(update(&mut m, ch('s')), vec![]);
    assert_eq!(m.mode, Mode::ConfirmSave);
    assert_eq!(
        update(&mut m, ch('i')),
        vec![Effect::Save {
            curves: CurveSave::Inline,
            overwrite: false
        }]
    );
    assert_eq!(m.mode, Mode::Normal);
    assert!(m.dirty);
    update(
        &mut m,
        Msg::Failed {
            message: "disk full".into(),
        },
    );
    assert!(m.dirty);
    update(
        &mut m,
        Msg::Saved {
            message: "saved room.toml".into(),
            sources: vec![LidSource::Inline, LidSource::Inline],
        },
    );
    assert!(!m.dirty);
    assert_eq!(m.message.as_deref(), Some("saved room.toml"));
    // The edited file-backed curve is now inline, as the app reported; the other kept its source.
    assert_eq!(m.lights[1].lid_source, LidSource::Inline);
    assert_eq!(m.lights[0].lid_source, LidSource::Inline);
    update(&mut m, ch('u'));
    assert!(m.dirty);
    // Quitting after a save does not ask.
    let mut m = model();
    let spot_source = m.lights[1].lid_source.clone();
    send(
        &mut m,
        [
            key(KeyCode::Up),
            Msg::Saved {
                message: String::new(),
                sources: vec![LidSource::Inline, spot_source],
            },
        ],
    );
    assert_eq!(update(&mut m, ch('q')), vec![Effect::Quit]);
}

#[test]
fn help_toggles_and_swallows_editing_keys() {
    let mut m = model();
    update(&mut m, ch('?'));
    assert_eq!(m.mode, Mode::Help);
    assert_eq!(update(&mut m, key(KeyCode::Up)), vec![]);
    assert_eq!(cd(&m, 0, 0), 1000.0);
    update(&mut m, ch('?'));
    assert_eq!(m.mode, Mode::Normal);
    send(&mut m, [ch('?'), key(KeyCode::Esc)]);
    assert_eq!(m.mode, Mode::Normal);
    send(&mut m, [ch('?'), ch('q')]);
    assert_eq!(m.mode, Mode::Normal);
}

#[test]
fn key_releases_are_ignored() {
    let mut m = model();
    let release = KeyEvent::new_with_kind(KeyCode::Up, KeyModifiers::NONE, KeyEventKind::Release);
    assert_eq!(update(&mut m, Msg::Key(release)), vec![]);
    assert_eq!(cd(&m, 0, 0), 1000.0);
}

#[test]
fn worker_messages_fill_the_status() {
    let mut m = model();
    assert_eq!(update(&mut m, Msg::BakeProgress { done: 3, total: 10 }), vec![]);
    assert_eq!(m.bake, Some((3, 10)));
    assert_eq!(
        update(&mut m, Msg::BakeDone { notices: Vec::new() }),
        vec![Effect::Render]
    );
    assert_eq!(m.bake, None);
    assert_eq!(m.message, None, "no notice, no message");
    let notices = vec!["cache /c/1.bake: checksum mismatch (corrupted); rebuilding".to_string(); 2];
    update(&mut m, Msg::BakeDone { notices });
    assert_eq!(
        m.message.as_deref(),
        Some("cache /c/1.bake: checksum mismatch (corrupted); rebuilding (and 1 more)")
    );
    m.message = Some("restored the unsaved edits from the recovery file (s saves them)".into());
    update(
        &mut m,
        Msg::BakeDone {
            notices: vec!["could not write the bake cache in /c: disk full".into()],
        },
    );
    assert!(m.message.as_deref().unwrap().starts_with("restored"));
    m.message = None;
    update(
        &mut m,
        Msg::Frame {
            relight_ms: 0.5,
            render_ms: 4.0,
            encode_ms: 2.5,
        },
    );
    assert_eq!(m.timings.unwrap().render_ms, 4.0);
    let series = Series {
        samples: vec![(0.0, 990.0), (std::f64::consts::PI, 0.0)],
        relative_error: 0.02,
    };
    update(
        &mut m,
        Msg::Series {
            light: 1,
            series: series.clone(),
        },
    );
    assert_eq!(m.series[1].as_ref(), Some(&series));
    // An out-of-range light is ignored, not a panic.
    update(&mut m, Msg::Series { light: 7, series });
}

#[test]
fn resize_recomputes_the_preview_pixels() {
    let mut m = model();
    let before = m.preview_px;
    assert_eq!(
        update(
            &mut m,
            Msg::Resize {
                width: 120,
                height: 40
            }
        ),
        vec![]
    );
    assert_eq!(
        update(
            &mut m,
            Msg::Resize {
                width: 100,
                height: 30
            }
        ),
        vec![Effect::Render]
    );
    let inner = preview_rect(Rect::new(0, 0, 100, 30));
    assert_eq!(
        m.preview_px,
        (u32::from(inner.width) * 8, u32::from(inner.height) * 16)
    );
    assert_ne!(m.preview_px, before);
    update(
        &mut m,
        Msg::Resize {
            width: 50,
            height: 10,
        },
    );
    assert_eq!(m.preview_px, (0, 0));
    assert_eq!(update(&mut m, Msg::Click { column: 30, row: 5 }), vec![]);
}

// ---------------------------------------------------------------- key table

#[test]
fn no_key_is_bound_twice_in_one_mode_and_every_binding_is_reachable() {
    let events: Vec<KeyEvent> = BINDINGS
        .iter()
        .flat_map(|b| b.keys.iter())
        .flat_map(|k| example_events(*k))
        .collect();
    for mode in ModeKind::ALL {
        for event in &events {
            let hits = keys::bindings_of(mode)
                .filter(|b| b.keys.iter().any(|k| k.matches(event)))
                .count();
            assert!(hits <= 1, "{event:?} bound {hits} times in {mode:?}");
        }
    }
    for binding in BINDINGS {
        for &k in binding.keys {
            for event in example_events(k) {
                assert_eq!(keys::lookup(binding.mode, &event), Some(binding.action), "{k}");
            }
        }
        assert!(!binding.help.is_empty());
    }
}

fn example_events(k: keys::Key) -> Vec<KeyEvent> {
    use keys::Key;
    match k {
        Key::Char(c) => vec![KeyEvent::new(KeyCode::Char(c), KeyModifiers::NONE)],
        Key::Code(code) => vec![KeyEvent::new(code, KeyModifiers::NONE)],
        Key::Shift(code) => vec![KeyEvent::new(code, KeyModifiers::SHIFT)],
        Key::Ctrl(c) => vec![KeyEvent::new(KeyCode::Char(c), KeyModifiers::CONTROL)],
        Key::CtrlCode(code) => vec![KeyEvent::new(code, KeyModifiers::CONTROL)],
        Key::Digit => "0123456789."
            .chars()
            .map(|c| KeyEvent::new(KeyCode::Char(c), KeyModifiers::NONE))
            .collect(),
        Key::AnyChar => "a/Z.~ 9"
            .chars()
            .map(|c| KeyEvent::new(KeyCode::Char(c), KeyModifiers::NONE))
            .collect(),
    }
}

// ---------------------------------------------------------------- save

fn lines_differing(a: &str, b: &str) -> Vec<usize> {
    assert_eq!(a.lines().count(), b.lines().count(), "line count changed:\n{b}");
    a.lines()
        .zip(b.lines())
        .enumerate()
        .filter(|(_, (x, y))| x != y)
        .map(|(i, _)| i)
        .collect()
}

fn line_of(text: &str, start: &str) -> usize {
    text.lines().position(|l| l.starts_with(start)).unwrap()
}

#[test]
fn save_changes_only_the_edited_lines_and_keeps_comments() {
    let mut m = model();
    update(&mut m, key(KeyCode::Up));
    let hit = Some((DVec3::new(4.0, 2.0, 0.0), 0.0));
    update(
        &mut m,
        Msg::Picked {
            pixel: (0, 0),
            hit,
            aim: true,
        },
    );
    let edited = edit_room_text("room.toml".as_ref(), ROOM_TEXT, &m).unwrap();
    assert!(edited.inlined.is_empty());
    let text = edited.text;
    let lid_line = line_of(ROOM_TEXT, "lid =");
    let aim_line = line_of(ROOM_TEXT, "aim =");
    assert_eq!(lines_differing(ROOM_TEXT, &text), vec![aim_line, lid_line]);
    let new_lines: Vec<&str> = text.lines().collect();
    assert_eq!(
        new_lines[lid_line],
        "lid = [[0, 1050], [30, 950], [60, 700], [90, 0]]   # cd"
    );
    assert_eq!(
        new_lines[aim_line],
        "aim = [4.0, 2.0, 0.0]        # straight down"
    );
    let parsed: toml::Table = text.parse().unwrap();
    let centre = &parsed["light"].as_array().unwrap()[0];
    assert_eq!(
        centre["lid"].as_array().unwrap()[0].as_array().unwrap()[1].as_integer(),
        Some(1050)
    );
    assert_eq!(centre["aim"].as_array().unwrap()[0].as_float(), Some(4.0));
}

#[test]
fn save_writes_position_dimmer_order_without_float_noise() {
    let mut m = model();
    send(
        &mut m,
        [
            ch('m'),
            key(KeyCode::Right),
            key(KeyCode::Enter),
            ch('d'),
            ch('O'),
        ],
    );
    send(&mut m, [key(KeyCode::Tab), ch('=')]);
    type_keys(&mut m, "1234.5678901");
    send(&mut m, [key(KeyCode::Enter), ch('o')]);
    let text = edit_room_text("room.toml".as_ref(), ROOM_TEXT, &m).unwrap().text;
    assert!(
        text.contains("position = [3.1, 2.0, 2.6]     # hung 10 cm below the ceiling"),
        "{text}"
    );
    assert!(text.contains("order = 6\n"), "{text}");
    let parsed: toml::Table = text.parse().unwrap();
    let lights = parsed["light"].as_array().unwrap();
    assert_eq!(lights[0]["dimmer"].as_float(), Some(0.9));
    assert_eq!(lights[0]["position"].as_array().unwrap()[0].as_float(), Some(3.1));
    // The spot: order added (16 → 15), the typed value rounded to 6 significant digits.
    assert_eq!(lights[1]["order"].as_integer(), Some(15));
    let lid = lights[1]["lid"].as_array().unwrap();
    assert_eq!(lid[0].as_array().unwrap()[1].as_float(), Some(1234.57));
    assert_eq!(round_significant(0.1 + 0.2), 0.3);
    assert_eq!(round_significant(1.0000000000000002), 1.0);
    assert_eq!(round_significant(-0.0).to_string(), "0");
}

#[test]
fn save_converts_an_edited_lid_file_light_to_inline_and_writes_atomically() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("room.toml");
    std::fs::write(&path, ROOM_TEXT).unwrap();
    let mut m = model();
    send(&mut m, [key(KeyCode::Tab), ch('l'), key(KeyCode::Down)]);
    let message = save_room(&path, ROOM_TEXT, &m).unwrap();
    assert!(
        message.contains("spot") && message.contains("lid_file removed"),
        "{message}"
    );
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names, vec!["room.toml".to_string()]);
    let text = std::fs::read_to_string(&path).unwrap();
    // The lid takes lid_file's line, with its comment; nothing else changes.
    let line = line_of(ROOM_TEXT, "lid_file");
    assert_eq!(lines_differing(ROOM_TEXT, &text), vec![line]);
    assert_eq!(
        text.lines().nth(line).unwrap(),
        "lid = [[0, 2000], [15, 1700], [25, 0]]   # from the manufacturer"
    );
    let parsed: toml::Table = text.parse().unwrap();
    let spot = &parsed["light"].as_array().unwrap()[1];
    assert!(spot.get("lid_file").is_none());
    assert_eq!(spot["lid"].as_array().unwrap().len(), 3);
    // After the app reports the save, nothing is left to write.
    let sources = vec![LidSource::Inline, LidSource::Inline];
    update(&mut m, Msg::Saved { message, sources });
    assert_eq!(edit_room_text(&path, &text, &m).unwrap().text, text);
}

#[test]
fn save_refuses_a_file_that_no_longer_matches() {
    let mut m = model();
    update(&mut m, key(KeyCode::Up));
    let renamed = ROOM_TEXT.replace("name = \"centre\"", "name = \"other\"");
    let err = edit_room_text("room.toml".as_ref(), &renamed, &m).unwrap_err();
    assert!(err.to_string().starts_with("room.toml: light[0].name:"), "{err}");
    let broken = ROOM_TEXT.replace("fov_deg = 60", "fov_deg = ");
    let err = edit_room_text("room.toml".as_ref(), &broken, &m).unwrap_err();
    assert!(err.to_string().starts_with("room.toml: line 30"), "{err}");
    // A directory that does not exist: an error, no panic, no stray file.
    let err = save_room("/nonexistent-dir/room.toml".as_ref(), ROOM_TEXT, &m).unwrap_err();
    assert!(err.to_string().contains("cannot save"), "{err}");
}

// ---------------------------------------------------------------- snapshots

fn draw(model: &Model, width: u16, height: u16) -> Terminal<TestBackend> {
    let mut terminal = Terminal::new(TestBackend::new(width, height)).unwrap();
    terminal
        .draw(|frame| view(model, frame, PreviewArea::Placeholder))
        .unwrap();
    terminal
}

fn with_series(mut m: Model) -> Model {
    // A smooth stand-in for the app's truncated series: 1000 cos γ on the lower hemisphere.
    let samples = (0..=180)
        .map(|d| {
            let g = f64::from(d).to_radians();
            (g, 1000.0 * g.cos().max(0.0))
        })
        .collect();
    update(
        &mut m,
        Msg::Series {
            light: 0,
            series: Series {
                samples,
                relative_error: 0.0412,
            },
        },
    );
    update(
        &mut m,
        Msg::Frame {
            relight_ms: 0.4,
            render_ms: 3.1,
            encode_ms: 2.0,
        },
    );
    m.protocol = "halfblocks".into();
    m
}

#[test]
fn snapshot_initial_view() {
    insta::assert_snapshot!(draw(&with_series(model()), 120, 40).backend());
}

#[test]
fn snapshot_after_editing_a_point() {
    let mut m = with_series(model());
    send(&mut m, [ch('l'), key(KeyCode::Up), key(KeyCode::Up), ch('>')]);
    insta::assert_snapshot!(draw(&m, 120, 40).backend());
}

#[test]
fn snapshot_help_overlay() {
    let mut m = model();
    update(&mut m, ch('?'));
    insta::assert_snapshot!(draw(&m, 120, 40).backend());
}

#[test]
fn snapshot_aim_mode() {
    let mut m = with_series(model());
    send(
        &mut m,
        [
            ch('a'),
            key(KeyCode::Right),
            press(KeyCode::Down, KeyModifiers::SHIFT),
        ],
    );
    let hit = Some((DVec3::new(3.5, 2.0, 0.0), 187.0));
    update(
        &mut m,
        Msg::Picked {
            pixel: (0, 0),
            hit,
            aim: false,
        },
    );
    insta::assert_snapshot!(draw(&m, 120, 40).backend());
}

#[test]
fn snapshot_quit_prompt() {
    let mut m = model();
    send(&mut m, [key(KeyCode::Up), ch('q')]);
    insta::assert_snapshot!(draw(&m, 120, 40).backend());
}

#[test]
fn snapshot_too_small_terminal() {
    insta::assert_snapshot!(draw(&model(), 60, 20).backend());
}

// ---------------------------------------------------------------- polar diagram, camera, robustness

#[test]
fn ring_spacing_is_one_two_five() {
    use haiko::tui::polar::ring_step_cd;
    assert_eq!(ring_step_cd(1000.0), 500.0); // a third is 333 → 500
    assert_eq!(ring_step_cd(90.0), 50.0); // 30 → 50
    assert_eq!(ring_step_cd(2400.0), 1000.0); // 800 → 1000
    assert_eq!(ring_step_cd(0.6), 0.2);
    assert_eq!(ring_step_cd(0.0), 1.0);
}

#[test]
fn polar_points_put_the_nadir_down_and_mirror_the_sides() {
    use haiko::tui::polar::polar_xy;
    assert_eq!(polar_xy(0.0, 100.0, false), (0.0, -100.0));
    let (x, y) = polar_xy(std::f64::consts::FRAC_PI_2, 100.0, false);
    assert_close(x, 100.0);
    assert!(y.abs() < 1e-12);
    let (xl, yl) = polar_xy(0.5, 80.0, true);
    let (xr, yr) = polar_xy(0.5, 80.0, false);
    assert_eq!((xl, yl), (-xr, yr));
    let (_, y_up) = polar_xy(std::f64::consts::PI, 50.0, false);
    assert_close(y_up, 50.0); // γ = 180° points up
}

#[test]
fn curve_samples_follow_the_curve_in_one_degree_steps() {
    use haiko::tui::polar::curve_samples;
    let curve = Curve::new(&[(10.0, 500.0), (40.0, 200.0), (40.0, 100.0), (70.0, 100.0)]).unwrap();
    let samples = curve_samples(&curve);
    // Closed to the centre before 10° and after 70°.
    assert_eq!(samples[0], (10f64.to_radians(), 0.0));
    assert_eq!(samples[samples.len() - 1], (70f64.to_radians(), 0.0));
    let inner = &samples[1..samples.len() - 1];
    for pair in inner.windows(2) {
        assert!(pair[1].0 - pair[0].0 <= 1f64.to_radians() + 1e-12);
    }
    // Both values of the step at 40° are drawn.
    let at_40: Vec<f64> = inner
        .iter()
        .filter(|s| (s.0 - 40f64.to_radians()).abs() < 1e-12)
        .map(|s| s.1)
        .collect();
    assert_eq!(at_40, vec![200.0, 100.0]);
    // Off the step, every sample lies on the curve (linear in γ between points).
    for &(g, i) in inner.iter().filter(|s| (s.0 - 40f64.to_radians()).abs() > 1e-9) {
        assert_close(i, curve.eval_rad(g));
    }
}

#[test]
fn polar_diagram_marks_the_selected_point_once_and_labels_rings() {
    use haiko::tui::polar::PolarDiagram;
    use ratatui::buffer::Buffer;
    use ratatui::widgets::{Block, Widget};
    let curve = Curve::new(&CENTRE_LID).unwrap();
    let area = Rect::new(0, 0, 46, 24);
    let mut buf = Buffer::empty(area);
    PolarDiagram {
        curve: &curve,
        series: None,
        spread: None,
        selected: 1,
        block: Block::bordered(),
    }
    .render(area, &mut buf);
    let text: String = buf.content().iter().map(|c| c.symbol()).collect();
    assert_eq!(text.matches('◆').count(), 1);
    assert_eq!(text.matches('•').count(), 3);
    assert!(text.contains("500") && text.contains("1000"));
    // The 0° point (1000 cd) is straight below the centre: in the lower half.
    let row_of =
        |symbol: &str| (0..area.height).find(|&y| (0..area.width).any(|x| buf[(x, y)].symbol() == symbol));
    let mut selected_first = buf.clone();
    PolarDiagram {
        curve: &curve,
        series: None,
        spread: None,
        selected: 0,
        block: Block::bordered(),
    }
    .render(area, &mut selected_first);
    let nadir_row = (0..area.height)
        .find(|&y| (0..area.width).any(|x| selected_first[(x, y)].symbol() == "◆"))
        .unwrap();
    assert!(nadir_row > area.height / 2 + 6, "{nadir_row}");
    assert!(row_of("◆").unwrap() < nadir_row);
}

#[test]
fn orbit_up_stops_short_of_the_pole_and_keeps_the_distance() {
    let mut m = model();
    let distance = (m.camera.eye - m.camera.target).length();
    send(&mut m, std::iter::repeat_n(ch('}'), 40));
    let offset = m.camera.eye - m.camera.target;
    assert_close(offset.length(), distance);
    let elevation = offset.z.atan2(offset.truncate().length()).to_degrees();
    assert_close(elevation, 85.0);
}

#[test]
fn every_key_in_every_mode_is_safe_in_a_room_without_lights() {
    let mut empty = scene();
    empty.lights.clear();
    let events: Vec<KeyEvent> = BINDINGS
        .iter()
        .flat_map(|b| b.keys.iter())
        .flat_map(|k| example_events(*k))
        .collect();
    for mode in [
        Mode::Normal,
        Mode::Help,
        Mode::ConfirmQuit,
        Mode::ValueEntry { buffer: "1".into() },
    ] {
        for event in &events {
            let mut m = Model::new(&empty, (120, 40), (8, 16));
            m.mode = mode.clone();
            update(&mut m, Msg::Key(*event));
            update(
                &mut m,
                Msg::Picked {
                    pixel: (1, 1),
                    hit: Some((DVec3::ONE, 1.0)),
                    aim: true,
                },
            );
            update(&mut m, Msg::Click { column: 80, row: 10 });
            assert!(m.lights.is_empty());
            let terminal = draw(&m, 120, 40);
            let screen = format!("{}", terminal.backend());
            // The help overlay covers the panes; otherwise the editor says why it is empty.
            assert!(m.mode == Mode::Help || screen.contains("no lights"), "{screen}");
        }
    }
}

/// The screen's rows as text.
fn rows(terminal: &Terminal<TestBackend>) -> Vec<String> {
    let buffer = terminal.backend().buffer();
    (0..buffer.area.height)
        .map(|y| {
            (0..buffer.area.width)
                .map(|x| buffer[(x, y)].symbol().to_string())
                .collect()
        })
        .collect()
}

/// The editor at 80 × 24 after an edit, with a picked point and frame timings.
fn small_and_edited() -> Model {
    let mut m = with_series(model());
    update(
        &mut m,
        Msg::Resize {
            width: 80,
            height: 24,
        },
    );
    send(&mut m, [key(KeyCode::Up)]);
    update(
        &mut m,
        Msg::Picked {
            pixel: (10, 10),
            hit: Some((DVec3::new(3.0, 2.0, 0.0), 123.4)),
            aim: false,
        },
    );
    m.protocol = "sixel 9×18 px".into();
    m
}

#[test]
fn at_80x24_the_status_keeps_mode_lux_and_the_unsaved_mark_and_drops_timings_first() {
    let m = small_and_edited();
    let screen = rows(&draw(&m, 80, 24));
    let status = &screen[22];
    for kept in ["centre (1/2)", "EDIT", "E 123 lx", "● unsaved"] {
        assert!(status.contains(kept), "{kept} missing: {status}");
    }
    assert!(!status.contains("relight"), "{status}");
    // Wide enough for everything, nothing is dropped.
    let wide = rows(&draw(&m, 160, 48));
    assert!(
        wide[46].contains("relight 0.4 · render 3.1 · encode 2.0 ms") && wide[46].contains("sixel 9×18 px"),
        "{}",
        wide[46]
    );
}

#[test]
fn at_80x24_the_light_panel_shows_position_and_aim() {
    let screen = rows(&draw(&small_and_edited(), 80, 24)).join("\n");
    // To one decimal: two do not fit 80 columns.
    assert!(screen.contains("pos m   3.0 2.0 2.6"), "{screen}");
    assert!(screen.contains("aim     0.0 0.0 -1.0"), "{screen}");
    // The polar diagram keeps its angle labels.
    assert!(screen.contains("90°") && screen.contains("0°"), "{screen}");
}

#[test]
fn at_80x24_the_help_pages_show_every_binding_in_full() {
    let mut m = small_and_edited();
    update(&mut m, ch('?'));
    assert_eq!(m.mode, Mode::Help);
    let pages = haiko::tui::view::help_page_count((80, 24));
    assert!(pages > 1, "{pages}");
    let mut seen = String::new();
    for page in 0..pages {
        let screen = rows(&draw(&m, 80, 24)).join("\n");
        assert!(screen.contains(&format!("page {}/{pages}", page + 1)), "{screen}");
        seen.push_str(&screen);
        update(&mut m, key(KeyCode::PageDown));
    }
    // Past the last page it stays there; PgUp goes back.
    assert_eq!(m.help_page, pages - 1);
    update(&mut m, key(KeyCode::PageUp));
    assert_eq!(m.help_page, pages - 2);
    for binding in BINDINGS {
        assert!(
            seen.contains(binding.help),
            "{:?} not shown in full",
            binding.help
        );
    }
    // Closing and opening again starts at the first page.
    update(&mut m, key(KeyCode::Esc));
    update(&mut m, ch('?'));
    assert_eq!(m.help_page, 0);
    // At 160 × 48 the help is one page.
    assert_eq!(haiko::tui::view::help_page_count((160, 48)), 1);
}

#[test]
fn snapshot_80x24() {
    insta::assert_snapshot!(draw(&small_and_edited(), 80, 24).backend());
}

#[test]
fn snapshot_80x24_help() {
    let mut m = small_and_edited();
    update(&mut m, ch('?'));
    insta::assert_snapshot!(draw(&m, 80, 24).backend());
}

#[test]
fn light_names_are_escaped_in_the_panels() {
    let mut s = scene();
    s.lights[0].name = "red\u{1b}[31m\nx\u{202e}".into();
    let m = Model::new(&s, (120, 40), (8, 16));
    let terminal = draw(&m, 120, 40);
    let text: String = terminal
        .backend()
        .buffer()
        .content()
        .iter()
        .map(|c| c.symbol())
        .collect();
    // The curve panel's title and the status line both show the escaped name.
    assert_eq!(text.matches("red\\u{1b}[31m\\nx\\u{202e}").count(), 2, "{text}");
    assert!(!text.contains('\u{1b}') && !text.contains('\u{202e}'));
}

#[test]
fn refused_saves_ask_what_to_do() {
    use haiko::tui::msg::SaveOffer;
    let mut m = model();
    send(&mut m, [key(KeyCode::Up)]);
    // The centre light's curve is inline: no question about file curves.
    let save = |curves, overwrite| Effect::Save { curves, overwrite };
    assert_eq!(update(&mut m, ch('s')), vec![save(CurveSave::Inline, false)]);
    // Changed on disk: overwrite, reload or save as.
    let conflict = || Msg::SaveRefused {
        reason: "room.toml: cannot save: the file was changed on disk".into(),
        offer: SaveOffer::OverwriteReloadOrSaveAs {
            curves: CurveSave::NewFiles,
        },
    };
    update(&mut m, conflict());
    assert_eq!(m.mode.kind(), ModeKind::SaveConflict);
    // Overwrite writes the file curves as the refused save did.
    assert_eq!(update(&mut m, ch('o')), vec![save(CurveSave::NewFiles, true)]);
    assert_eq!(m.mode, Mode::Normal);
    update(&mut m, conflict());
    assert_eq!(update(&mut m, ch('r')), vec![Effect::Reload]);
    assert_eq!(m.mode, Mode::Normal);
    update(&mut m, conflict());
    assert_eq!(update(&mut m, key(KeyCode::Esc)), vec![]);
    assert_eq!(m.mode, Mode::Normal);
    assert!(m.dirty, "a cancelled save keeps the edits");
    update(&mut m, conflict());
    assert!(update(&mut m, ch('a')).is_empty());
    assert_eq!(
        m.mode,
        Mode::SaveAs {
            buffer: String::new(),
            reason: None
        }
    );
    // Read-only or hard-linked: save as, with the reason shown.
    update(
        &mut m,
        Msg::SaveRefused {
            reason: "room.toml: cannot save: the file is read-only".into(),
            offer: SaveOffer::SaveAs,
        },
    );
    let reason = Some("room.toml: cannot save: the file is read-only".to_string());
    assert_eq!(
        m.mode,
        Mode::SaveAs {
            buffer: String::new(),
            reason: reason.clone()
        }
    );
    assert!(update(&mut m, key(KeyCode::Enter)).is_empty(), "no name, no save");
    type_keys(&mut m, "sub/Copy 2.tomlx");
    update(&mut m, key(KeyCode::Backspace));
    let screen = draw(&m, 120, 40);
    let text: String = screen
        .backend()
        .buffer()
        .content()
        .iter()
        .map(|c| c.symbol())
        .collect();
    assert!(text.contains("save as (file name): sub/Copy 2.toml▏"), "{text}");
    assert!(text.contains("cannot save: the file is read-only"), "{text}");
    assert_eq!(
        update(&mut m, key(KeyCode::Enter)),
        vec![Effect::SaveAs("sub/Copy 2.toml".into())]
    );
    assert_eq!(m.mode, Mode::Normal);
    // `S` offers save as at any time.
    update(&mut m, ch('S'));
    assert_eq!(m.mode.kind(), ModeKind::SaveAs);
}
