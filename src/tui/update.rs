//! `update(&mut Model, Msg) -> Vec<Effect>`: the editor's only state transition. Pure: no I/O,
//! no clock; the app carries out the returned effects and reports back with messages.
//!
//! An edit is a [`Command`]: `update` applies it to the model (the same pure function the
//! engine applies to its session), records it with its inverse for undo, and returns it as
//! [`Effect::Engine`] — so each change is made once, as a value, and never detected by
//! comparing states.

use glam::DVec3;
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyEventKind};
use ratatui::layout::{Position, Rect};

use crate::scene::Camera;
use crate::session::{Change as Changed, Command, ExposureChoice, LightStatus};
use crate::tui::camera_nav;
use crate::tui::edits::{self, EditError};
use crate::tui::history::Change;
use crate::tui::keys::{self, Action};
use crate::tui::luminaires::{self, group};
use crate::tui::model::{LightEdit, Mode, Model, Picked, Timings};
use crate::tui::msg::{CurveSave, Effect, Msg, SaveOffer};
use crate::tui::view::{cell_to_pixel, preview_rect};

/// Longest typed value, characters.
const MAX_TYPED_LEN: usize = 16;
/// Longest typed path, characters.
const MAX_TYPED_PATH_LEN: usize = 4096;

/// Longest typed file name, characters.
const MAX_TYPED_NAME_LEN: usize = 1024;

/// Applies one message to the model and returns the work the app must do.
pub fn update(model: &mut Model, msg: Msg) -> Vec<Effect> {
    match msg {
        Msg::Key(event) => on_key(model, &event),
        Msg::Click { column, row } => on_click(model, Position::new(column, row)),
        Msg::Hover { column, row } => on_hover(model, Position::new(column, row)),
        Msg::Resize { width, height } => {
            model.terminal_size = (width, height);
            let before = model.preview_px;
            model.preview_px = model.compute_preview_px();
            if let Mode::Aim { cursor } = &mut model.mode {
                *cursor = clamp_pixel(*cursor, model.preview_px);
            }
            if before == model.preview_px {
                Vec::new()
            } else {
                vec![Effect::Render]
            }
        }
        Msg::BakeProgress { done, total } => {
            model.bake = Some((done, total));
            Vec::new()
        }
        Msg::BakeDone { notices } => {
            model.bake = None;
            // A message already shown (the recovery file restored) matters more.
            if let Some(first) = notices.first().filter(|_| model.message.is_none()) {
                let more = match notices.len() {
                    1 => String::new(),
                    n => format!(" (and {} more)", n - 1),
                };
                model.message = Some(format!("{first}{more}"));
            }
            vec![Effect::Render]
        }
        Msg::LightStatus(status) => {
            model.light_status = status;
            Vec::new()
        }
        Msg::Frame {
            relight_ms,
            render_ms,
            encode_ms,
        } => {
            model.timings = Some(Timings {
                relight_ms,
                render_ms,
                encode_ms,
            });
            Vec::new()
        }
        Msg::Picked { hit, aim, .. } => on_picked(model, hit, aim),
        Msg::Series { light, series } => {
            if let Some(slot) = model.series.get_mut(light) {
                *slot = Some(series);
            }
            Vec::new()
        }
        Msg::Saved { message, sources } => luminaires::on_saved(model, message, sources),
        Msg::LidLoaded { path, result } => luminaires::on_lid_loaded(model, path, result),
        Msg::Numbers(numbers) => {
            if let Some((point, lux)) = numbers.cursor {
                model.picked = Some(Picked { point, lux });
            }
            model.numbers = Some(*numbers);
            Vec::new()
        }
        Msg::Reported { message } => {
            model.message = Some(message);
            Vec::new()
        }
        Msg::Failed { message } => {
            model.message = Some(message);
            Vec::new()
        }
        Msg::SaveRefused { reason, offer } => {
            model.mode = match offer {
                SaveOffer::OverwriteReloadOrSaveAs { curves } => Mode::SaveConflict { reason, curves },
                SaveOffer::SaveAs => Mode::SaveAs {
                    buffer: String::new(),
                    reason: Some(reason),
                },
            };
            Vec::new()
        }
    }
}

fn on_key(model: &mut Model, event: &KeyEvent) -> Vec<Effect> {
    if event.kind == KeyEventKind::Release {
        return Vec::new();
    }
    model.message = None;
    match keys::lookup(model.mode.kind(), event) {
        Some(action) => on_action(model, action, event),
        None => Vec::new(),
    }
}

fn on_action(model: &mut Model, action: Action, event: &KeyEvent) -> Vec<Effect> {
    let k = model.selected_point;
    match action {
        Action::ToggleHelp => {
            model.mode = if model.mode == Mode::Help {
                Mode::Normal
            } else {
                model.help_page = 0;
                Mode::Help
            };
            Vec::new()
        }
        Action::HelpPage(step) => {
            // The view shows the last page for anything past it.
            let pages = crate::tui::view::help_page_count(model.terminal_size);
            model.help_page = model
                .help_page
                .saturating_add_signed(isize::from(step))
                .min(pages.saturating_sub(1));
            Vec::new()
        }
        Action::Quit if model.dirty => {
            model.mode = Mode::ConfirmQuit;
            Vec::new()
        }
        Action::Quit | Action::ConfirmQuit => vec![Effect::Quit],
        Action::Suspend => vec![Effect::Suspend],
        Action::Save => luminaires::save(model),
        Action::SaveCurveFiles => {
            model.mode = Mode::Normal;
            vec![Effect::Save {
                curves: CurveSave::NewFiles,
                overwrite: false,
            }]
        }
        Action::SaveInline => {
            model.mode = Mode::Normal;
            vec![Effect::Save {
                curves: CurveSave::Inline,
                overwrite: false,
            }]
        }
        Action::SaveAs => {
            model.mode = Mode::SaveAs {
                buffer: String::new(),
                reason: None,
            };
            Vec::new()
        }
        Action::Overwrite => match std::mem::replace(&mut model.mode, Mode::Normal) {
            Mode::SaveConflict { curves, .. } => vec![Effect::Save {
                curves,
                overwrite: true,
            }],
            _ => Vec::new(),
        },
        Action::Reload => {
            model.mode = Mode::Normal;
            vec![Effect::Reload]
        }
        Action::DuplicateLight
        | Action::DeleteLight
        | Action::EnterDimmer
        | Action::EnterPath
        | Action::ToggleMark
        | Action::MarkSamePhotometry
        | Action::ClearMarks
        | Action::Report => luminaires::on_action(model, action),
        Action::NextLight => select_light(model, 1),
        Action::PreviousLight => select_light(model, -1),
        Action::NextPoint => select_point(model, 1),
        Action::PreviousPoint => select_point(model, -1),
        Action::Intensity(fraction) => edit(model, |l, i| edits::nudge_intensity(l, i, k, fraction)),
        Action::Angle(delta_deg) => edit(model, |l, i| edits::move_angle(l, i, k, delta_deg)),
        Action::InsertPoint => {
            let mut inserted = k;
            let selected = model.selected_light;
            let effects = edit(model, |l, i| {
                edits::insert_after(l, i, k).map(|(command, index)| {
                    if i == selected {
                        inserted = index;
                    }
                    command
                })
            });
            if !effects.is_empty() {
                model.selected_point = inserted;
            }
            effects
        }
        Action::DeletePoint => {
            let effects = edit(model, |l, i| edits::delete_point(l, i, k));
            clamp_selected_point(model);
            effects
        }
        Action::EnterValue => {
            if model.light().is_some() {
                model.mode = Mode::ValueEntry {
                    buffer: String::new(),
                };
            }
            Vec::new()
        }
        Action::Type => {
            let limit = match model.mode {
                Mode::PathEntry { .. } => MAX_TYPED_PATH_LEN,
                Mode::SaveAs { .. } => MAX_TYPED_NAME_LEN,
                _ => MAX_TYPED_LEN,
            };
            if let (Some(buffer), KeyCode::Char(c)) = (typed_buffer(&mut model.mode), event.code)
                && buffer.chars().count() < limit
            {
                buffer.push(c);
            }
            Vec::new()
        }
        Action::Backspace => {
            if let Some(buffer) = typed_buffer(&mut model.mode) {
                buffer.pop();
            }
            Vec::new()
        }
        Action::Apply => match std::mem::replace(&mut model.mode, Mode::Normal) {
            Mode::ValueEntry { buffer } => apply_typed_value(model, &buffer),
            Mode::DimmerEntry { buffer } => match luminaires::parse_dimmer_percent(&buffer) {
                Ok(dimmer) => edit(model, |_, i| Ok(Command::SetDimmer { light: i, dimmer })),
                Err(reason) => {
                    model.message = Some(reason.to_string());
                    Vec::new()
                }
            },
            Mode::PathEntry { buffer } if !buffer.trim().is_empty() => {
                model.message = Some(format!("reading {}…", buffer.trim()));
                vec![Effect::LoadLid(buffer)]
            }
            Mode::SaveAs { buffer, reason } if buffer.trim().is_empty() => {
                model.message = Some("type a file name to save as (Esc cancels)".into());
                model.mode = Mode::SaveAs { buffer, reason };
                Vec::new()
            }
            Mode::SaveAs { buffer, .. } => vec![Effect::SaveAs(buffer.trim().to_string())],
            _ => Vec::new(),
        },
        Action::Order(delta) => edit(model, |l, i| Ok(edits::change_order(l, i, delta))),
        Action::CycleWindow => edit(model, |l, i| {
            Ok(Command::SetWindow {
                light: i,
                window: l.window.next(),
            })
        }),
        Action::Dimmer(delta) => edit(model, |l, i| Ok(edits::step_dimmer(l, i, delta))),
        Action::ToggleFalseColour => {
            model.false_colour = !model.false_colour;
            vec![Effect::Render]
        }
        Action::Exposure(stops) => {
            let brighter_ev = match model.exposure {
                ExposureChoice::Room { brighter_ev } => brighter_ev,
                ExposureChoice::Ev100(_) | ExposureChoice::Auto => 0.0,
            };
            model.exposure = ExposureChoice::Room {
                brighter_ev: brighter_ev + stops,
            };
            vec![Effect::Render]
        }
        Action::ToggleAutoExposure => {
            model.exposure = match model.exposure {
                ExposureChoice::Auto => ExposureChoice::default(),
                ExposureChoice::Room { .. } | ExposureChoice::Ev100(_) => ExposureChoice::Auto,
            };
            vec![Effect::Render]
        }
        Action::RefitDisplay => {
            model.display_refit = model.display_refit.wrapping_add(1);
            vec![Effect::Render]
        }
        Action::ToggleIsolux => {
            model.isolux = !model.isolux;
            vec![Effect::Render]
        }
        Action::TogglePlanView => {
            model.plan_view = !model.plan_view;
            vec![Effect::Render]
        }
        Action::ToggleWorkPlane => {
            // From the camera view straight to the work plane's plan.
            model.plan_work_plane = !model.plan_view || !model.plan_work_plane;
            model.plan_view = true;
            vec![Effect::Render]
        }
        Action::AimMode => {
            if model.light().is_none() {
                return Vec::new();
            }
            let (w, h) = model.preview_px;
            let cursor = (w / 2, h / 2);
            model.mode = Mode::Aim { cursor };
            vec![
                Effect::Render,
                Effect::Pick {
                    pixel: cursor,
                    aim: false,
                },
            ]
        }
        Action::MoveMode => {
            if let Some(light) = model.light() {
                model.mode = Mode::Move {
                    start: light.position,
                };
            }
            Vec::new()
        }
        Action::Undo => undo_or_redo(model, true),
        Action::Redo => undo_or_redo(model, false),
        Action::Orbit { yaw_deg, pitch_deg } => {
            set_camera(model, camera_nav::orbit(&model.camera, yaw_deg, pitch_deg))
        }
        Action::Pan { right_m, up_m } => set_camera(model, camera_nav::pan(&model.camera, right_m, up_m)),
        Action::Dolly(factor) => set_camera(model, camera_nav::dolly(&model.camera, factor)),
        Action::ResetCamera => set_camera(model, model.home_camera),
        Action::Cursor { dx, dy, big } => move_cursor(model, dx, dy, big),
        Action::AimHere => match model.mode {
            Mode::Aim { cursor } => {
                model.mode = Mode::Normal;
                vec![
                    Effect::Render,
                    Effect::Pick {
                        pixel: cursor,
                        aim: true,
                    },
                ]
            }
            _ => Vec::new(),
        },
        Action::MoveBy(offset) => {
            let i = model.selected_light;
            match model.lights.get(i) {
                Some(light) => {
                    let command = edits::move_by(light, i, DVec3::from_array(offset), model.room_size);
                    // One undo record for the whole move, made when it is finished.
                    run(model, command, false)
                }
                None => Vec::new(),
            }
        }
        Action::Finish => finish_move(model),
        Action::Cancel => cancel(model),
    }
}

/// The text being typed in an entry mode.
fn typed_buffer(mode: &mut Mode) -> Option<&mut String> {
    match mode {
        Mode::ValueEntry { buffer }
        | Mode::DimmerEntry { buffer }
        | Mode::PathEntry { buffer }
        | Mode::SaveAs { buffer, .. } => Some(buffer),
        _ => None,
    }
}

/// Builds a command with `build` (given a light and its index) for each light of the group —
/// the selected light, and the marked ones ([`group`]) — and runs them as one undo step. When
/// the selected light's command cannot be built nothing is done and the reason shown; other
/// lights whose command cannot be built are skipped and named.
pub(crate) fn edit(
    model: &mut Model,
    mut build: impl FnMut(&LightEdit, usize) -> Result<Command, EditError>,
) -> Vec<Effect> {
    let selected = model.selected_light;
    let mut commands = Vec::new();
    let mut skipped = Vec::new();
    for i in group(model) {
        match build(&model.lights[i], i) {
            Ok(command) => commands.push(command),
            Err(reason) if i == selected => {
                model.message = Some(reason.to_string());
                return Vec::new();
            }
            Err(reason) => skipped.push(format!("{}: {reason}", model.lights[i].name)),
        }
    }
    let effects = run_group(model, commands);
    if !skipped.is_empty() {
        model.message = Some(format!("skipped {}", skipped.join("; ")));
    }
    effects
}

/// Applies `command` to the model; returns its inverse when it changed something. A refused
/// command changes nothing and says why.
fn apply_command(model: &mut Model, command: &Command) -> Option<Command> {
    match command.apply(&mut model.lights, &mut model.camera, &model.bounds) {
        Ok(applied) if applied.inverse == *command => None,
        Ok(applied) => {
            match applied.change {
                Changed::Inserted { at } => {
                    model.series.insert(at, None);
                    model.light_status.insert(at, LightStatus::Updating);
                }
                Changed::Removed { at } => {
                    model.series.remove(at);
                    model.light_status.remove(at);
                }
                _ => {}
            }
            Some(applied.inverse)
        }
        Err(reason) => {
            model.message = Some(reason.to_string());
            None
        }
    }
}

/// Applies `command` to the model and, when it changed something, returns it for the engine;
/// with `record`, also pushes it and its inverse on the undo stack.
pub(crate) fn run(model: &mut Model, command: Command, record: bool) -> Vec<Effect> {
    if record {
        return run_group(model, vec![command]);
    }
    let changed = apply_command(model, &command).is_some();
    model.refresh_dirty();
    if changed {
        vec![Effect::Engine(command)]
    } else {
        Vec::new()
    }
}

/// Applies `commands` in order and records those that changed something as one undo step (for
/// the selected light); returns them for the engine.
pub(crate) fn run_group(model: &mut Model, commands: Vec<Command>) -> Vec<Effect> {
    let mut forward = Vec::new();
    let mut inverse = Vec::new();
    for command in commands {
        if let Some(undo) = apply_command(model, &command) {
            inverse.push(undo);
            forward.push(command);
        }
    }
    if forward.is_empty() {
        return Vec::new();
    }
    inverse.reverse();
    let effects = forward.iter().cloned().map(Effect::Engine).collect();
    model.history.record(Change {
        light: model.selected_light,
        forward,
        inverse,
    });
    model.refresh_dirty();
    effects
}

fn undo_or_redo(model: &mut Model, undo: bool) -> Vec<Effect> {
    let change = if undo {
        model.history.undo()
    } else {
        model.history.redo()
    };
    let Some(change) = change else {
        model.message = Some(
            if undo {
                "nothing to undo"
            } else {
                "nothing to redo"
            }
            .into(),
        );
        return Vec::new();
    };
    let (light, commands) = (
        change.light,
        if undo {
            change.inverse.clone()
        } else {
            change.forward.clone()
        },
    );
    let mut effects: Vec<Effect> = commands
        .into_iter()
        .flat_map(|command| run(model, command, false))
        .collect();
    let selected = light.min(model.lights.len().saturating_sub(1));
    if selected != model.selected_light {
        model.selected_light = selected;
        effects.push(Effect::Render);
    }
    clamp_selected_point(model);
    effects
}

fn select_light(model: &mut Model, step: isize) -> Vec<Effect> {
    let n = model.lights.len();
    if n < 2 {
        return Vec::new();
    }
    model.selected_light = (model.selected_light as isize + step).rem_euclid(n as isize) as usize;
    clamp_selected_point(model);
    // The selected light's aim line moves to the new one.
    vec![Effect::Render]
}

fn select_point(model: &mut Model, step: isize) -> Vec<Effect> {
    if let Some(light) = model.light() {
        let last = light.curve.len() - 1;
        model.selected_point = model.selected_point.saturating_add_signed(step).min(last);
    }
    Vec::new()
}

fn clamp_selected_point(model: &mut Model) {
    if let Some(light) = model.light() {
        model.selected_point = model.selected_point.min(light.curve.len() - 1);
    }
}

fn apply_typed_value(model: &mut Model, buffer: &str) -> Vec<Effect> {
    let k = model.selected_point;
    edit(model, |l, i| {
        let candela = edits::parse_intensity(buffer)?;
        edits::set_intensity(l, i, k, candela)
    })
}

/// Points the camera elsewhere (not an undoable edit).
fn set_camera(model: &mut Model, camera: Camera) -> Vec<Effect> {
    run(model, Command::SetCamera(camera), false)
}

fn clamp_pixel((x, y): (u32, u32), (w, h): (u32, u32)) -> (u32, u32) {
    (x.min(w.saturating_sub(1)), y.min(h.saturating_sub(1)))
}

/// Moves the aim cursor by `dx, dy` steps of 1/40 (1/8 when `big`) of the preview size.
fn move_cursor(model: &mut Model, dx: i32, dy: i32, big: bool) -> Vec<Effect> {
    let Mode::Aim { cursor } = &mut model.mode else {
        return Vec::new();
    };
    let (w, h) = model.preview_px;
    let divisions = if big { 8 } else { 40 };
    let step = |size: u32| i64::from((size / divisions).max(1));
    let shift = |at: u32, by: i32, size: u32| {
        let moved = i64::from(at) + i64::from(by) * step(size);
        u32::try_from(moved.clamp(0, i64::from(size.saturating_sub(1)))).unwrap_or(0)
    };
    *cursor = (shift(cursor.0, dx, w), shift(cursor.1, dy, h));
    vec![
        Effect::Render,
        Effect::Pick {
            pixel: *cursor,
            aim: false,
        },
    ]
}

fn on_click(model: &mut Model, cell: Position) -> Vec<Effect> {
    if !matches!(model.mode, Mode::Normal | Mode::Aim { .. }) || model.light().is_none() {
        return Vec::new();
    }
    let (w, h) = model.terminal_size;
    let area = preview_rect(Rect::new(0, 0, w, h));
    let (pw, ph) = model.preview_px;
    match cell_to_pixel(cell, area, pw, ph) {
        // Only aim mode aims; otherwise a click reads the point (lux, numbers cursor).
        Some(pixel) if matches!(model.mode, Mode::Aim { .. }) => {
            model.mode = Mode::Normal;
            vec![Effect::Render, Effect::Pick { pixel, aim: true }]
        }
        Some(pixel) => vec![Effect::Pick { pixel, aim: false }],
        None => Vec::new(),
    }
}

/// In aim mode the aim cursor follows the mouse over the preview, read as the arrow keys'
/// cursor is (so that a click where it rests aims at the point read, its aim prepared: docs/
/// DECISIONS.md "Re-aims prepared where the aim cursor rests").
fn on_hover(model: &mut Model, cell: Position) -> Vec<Effect> {
    let Mode::Aim { cursor } = &mut model.mode else {
        return Vec::new();
    };
    let (w, h) = model.terminal_size;
    let area = preview_rect(Rect::new(0, 0, w, h));
    let (pw, ph) = model.preview_px;
    match cell_to_pixel(cell, area, pw, ph) {
        Some(pixel) if pixel != *cursor => {
            *cursor = pixel;
            vec![Effect::Render, Effect::Pick { pixel, aim: false }]
        }
        _ => Vec::new(),
    }
}

fn on_picked(model: &mut Model, hit: Option<(DVec3, f64)>, aim: bool) -> Vec<Effect> {
    model.picked = hit.map(|(point, lux)| Picked { point, lux });
    if !aim {
        return Vec::new();
    }
    match hit {
        Some((point, _)) => luminaires::aim_group_at(model, point),
        None => {
            model.message = Some("nothing under the cursor to aim at".into());
            Vec::new()
        }
    }
}

/// Ends move mode: the whole move becomes one undo record (the engine already has it).
fn finish_move(model: &mut Model) -> Vec<Effect> {
    let Mode::Move { start } = std::mem::replace(&mut model.mode, Mode::Normal) else {
        return Vec::new();
    };
    let i = model.selected_light;
    if let Some(light) = model.lights.get(i)
        && light.position != start
    {
        model.history.record(Change::single(
            i,
            Command::Move {
                light: i,
                position: light.position,
            },
            Command::Move {
                light: i,
                position: start,
            },
        ));
    }
    Vec::new()
}

fn cancel(model: &mut Model) -> Vec<Effect> {
    match std::mem::replace(&mut model.mode, Mode::Normal) {
        Mode::Move { start } => {
            let light = model.selected_light;
            run(
                model,
                Command::Move {
                    light,
                    position: start,
                },
                false,
            )
        }
        // The aim cursor leaves the preview.
        Mode::Aim { .. } => vec![Effect::Render],
        _ => Vec::new(),
    }
}
