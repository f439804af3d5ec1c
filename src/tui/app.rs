//! `haiko edit ROOM`: the app loop. Loads the room (before the screen is taken), enters the
//! terminal, starts the workers, then blocks on one channel: each event becomes a [`Msg`] for
//! [`update`], whose [`Effect`]s are carried out here — commands and frame requests collected
//! and sent to the engine once per loop turn (in order), picks asked of the engine, saves
//! written, quitting.

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{self, Receiver, Sender};

use ratatui::Frame;
use ratatui::crossterm::event::{Event, MouseButton, MouseEvent, MouseEventKind};
use ratatui::layout::{Alignment, Constraint, Flex, Layout, Rect, Size};
use ratatui::style::Stylize;
use ratatui::widgets::{Gauge, Paragraph};
use ratatui_image::protocol::Protocol;

use crate::error::{Error, Result};
use crate::photometry::read_lid_file;
use crate::render::DisplayMode;
use crate::scene::save::{IfChanged, SaveError, Saved};
use crate::scene::{self, LidSource, RoomText};
use crate::session::budget::{self, MemoryLimit};
use crate::session::{FrameSpec, SessionOptions, ViewChoice, initial_lights};
use crate::transport::plan::{PlanOptions, plan};
use crate::tui::luminaires::{self, LidInfo};
use crate::tui::msg::{CurveSave, Effect, Msg};
use crate::tui::save::SaveTarget;
use crate::tui::terminal::{Graphics, TerminalSession, spawn_input_reader};
use crate::tui::workers::{
    AppEvent, EncodeJob, EngineRequest, RenderedFrame, spawn_encode_worker, spawn_engine,
};
use crate::tui::{Mode, Model, PreviewArea, preview, save, update, view};

/// Runs the editor on the room file `room` with the `graphics` protocol choice. A bad room
/// fails before the terminal is touched; the terminal is restored however the editor ends.
///
/// Errors: the room file (bad input), the terminal or a worker (internal).
pub fn run(room: &Path, graphics: Graphics, limit: &MemoryLimit) -> Result<()> {
    let loaded = scene::read_room(room)?;
    let scene = scene::load::load_text(room, &loaded.text)?;
    // Before the terminal is taken: a room too large for memory is refused on a sane screen.
    budget::check_scene(&scene, PlanOptions::default(), true, limit)?;
    // Temporaries of a save that was killed midway (docs/DECISIONS.md "Saving").
    let removed = scene::save::remove_stale_temporaries(room).unwrap_or_default();
    let mut session = TerminalSession::enter(graphics)?;
    let mut app = App::start(scene, loaded, room, *limit, &session)?;
    if !removed.is_empty() {
        app.model.message = Some(format!(
            "removed {} temporary file(s) an interrupted save left beside the room file",
            removed.len()
        ));
    }
    app.run(&mut session)
}

/// The editor's model for a freshly loaded scene: the plan's orders, as if the file said them.
fn fresh_model(
    scene: &scene::Scene,
    terminal_size: (u16, u16),
    cell_px: (u16, u16),
    protocol: String,
) -> Model {
    let mut model = Model::new(scene, terminal_size, cell_px);
    model.protocol = protocol;
    let planned = initial_lights(scene, &plan(scene, PlanOptions::default()));
    for (i, light) in planned.iter().enumerate() {
        model.set_planned_order(i, light.order);
    }
    model.lid_files = luminaires::read_lid_infos(&model.lights);
    model
}

/// The running editor: the model and the app's side of the workers.
struct App {
    model: Model,
    /// The room file being edited (changes with "save as").
    room: PathBuf,
    /// Its text as last read or saved: what a save edits and compares the file against.
    loaded: RoomText,
    /// The memory limit (checked again on reload).
    limit: MemoryLimit,
    events: Receiver<AppEvent>,
    /// For the workers of a reloaded room.
    sender: Sender<AppEvent>,
    engine: Sender<EngineRequest>,
    encode_jobs: Sender<EncodeJob>,
    /// Requests for the engine from this loop turn, sent in order at its end.
    outbox: Vec<EngineRequest>,
    /// True when the frame the model shows changed this turn.
    frame_changed: bool,
    /// The latest encoded image on screen.
    image: Option<Protocol>,
    quit: bool,
}

impl App {
    fn start(
        scene: scene::Scene,
        loaded: RoomText,
        room: &Path,
        limit: MemoryLimit,
        session: &TerminalSession,
    ) -> Result<App> {
        let model = fresh_model(
            &scene,
            session.size()?,
            preview::cell_px(session.picker()),
            preview::protocol_label(session.picker()),
        );
        let (sender, events) = mpsc::channel();
        spawn_input_reader(sender.clone());
        let engine = spawn_engine(scene, SessionOptions::with_user_cache(), sender.clone());
        let encode_jobs = spawn_encode_worker(session.picker().clone(), sender.clone());
        Ok(App {
            model,
            room: room.to_path_buf(),
            loaded,
            limit,
            events,
            sender,
            engine,
            encode_jobs,
            outbox: Vec::new(),
            frame_changed: true,
            image: None,
            quit: false,
        })
    }

    fn run(&mut self, session: &mut TerminalSession) -> Result<()> {
        self.flush()?;
        self.draw(session)?;
        while !self.quit {
            let event = self.events.recv().map_err(|_| worker_stopped())?;
            self.handle(event)?;
            // Handle whatever else is already queued before drawing once.
            while !self.quit
                && let Ok(event) = self.events.try_recv()
            {
                self.handle(event)?;
            }
            if !self.quit {
                self.flush()?;
                self.draw(session)?;
            }
        }
        Ok(())
    }

    fn handle(&mut self, event: AppEvent) -> Result<()> {
        match event {
            AppEvent::Input(event) => match input_msg(event) {
                Some(msg) => self.dispatch(msg),
                None => Ok(()),
            },
            AppEvent::InputFailed(message) => {
                Err(Error::internal(format!("reading the terminal: {message}")))
            }
            AppEvent::Msg(msg) => self.dispatch(msg),
            AppEvent::Rendered(frame) => self.on_rendered(frame),
            AppEvent::Encoded(encoded) => {
                if let Some(image) = encoded.protocol {
                    self.image = Some(image);
                }
                let (relight_ms, render_ms) = encoded.rendered;
                self.dispatch(Msg::Frame {
                    relight_ms,
                    render_ms,
                    encode_ms: encoded.encode_ms,
                })
            }
        }
    }

    fn on_rendered(&mut self, frame: RenderedFrame) -> Result<()> {
        let (cell_w, cell_h) = self.model.cell_px;
        let cells = Size::new(
            u16::try_from(frame.pixmap.width() / u32::from(cell_w)).unwrap_or(u16::MAX),
            u16::try_from(frame.pixmap.height() / u32::from(cell_h)).unwrap_or(u16::MAX),
        );
        self.encode_jobs
            .send(EncodeJob { frame, cells })
            .map_err(|_| worker_stopped())
    }

    /// Applies `msg` and carries out the effects, feeding their answers back to `update`.
    fn dispatch(&mut self, msg: Msg) -> Result<()> {
        let mut queue = VecDeque::from([msg]);
        while let Some(msg) = queue.pop_front() {
            for effect in update(&mut self.model, msg) {
                match effect {
                    Effect::Engine(command) => match self.outbox.last_mut() {
                        Some(EngineRequest::Commands(commands)) => commands.push(command),
                        _ => self.outbox.push(EngineRequest::Commands(vec![command])),
                    },
                    Effect::Render => self.frame_changed = true,
                    Effect::Pick { pixel, aim } => self.outbox.push(EngineRequest::Pick {
                        pixel,
                        preview_px: self.model.preview_px,
                        aim,
                    }),
                    Effect::Save { curves, overwrite } => queue.push_back(self.save(curves, overwrite)),
                    Effect::SaveAs(name) => queue.push_back(self.save_as(&name)),
                    Effect::Reload => self.reload(),
                    Effect::LoadLid(typed) => queue.push_back(self.load_lid(&typed)),
                    Effect::Report => self.outbox.push(EngineRequest::Report(report_path(&self.room))),
                    Effect::Quit => self.quit = true,
                }
            }
        }
        Ok(())
    }

    /// Saves into the room file; a refusal becomes the prompt that asks what to do.
    fn save(&mut self, curves: CurveSave, overwrite: bool) -> Msg {
        let if_changed = if overwrite {
            IfChanged::Overwrite
        } else {
            IfChanged::Refuse
        };
        let target = SaveTarget::Room(if_changed);
        let result = save::save_curves_to(&self.room, &self.loaded, &self.model, curves, target);
        self.saved(result, curves, None)
    }

    /// Saves as `name` (relative to the room file's folder; edited file curves inline); the
    /// editor then edits that file.
    fn save_as(&mut self, name: &str) -> Msg {
        let folder = self.room.parent().unwrap_or(Path::new("."));
        let path = folder.join(name);
        let (curves, target) = (CurveSave::Inline, SaveTarget::As(&path));
        let result = save::save_curves_to(&self.room, &self.loaded, &self.model, curves, target);
        self.saved(result, curves, Some(path.clone()))
    }

    /// The message for a save's `result`; on success the room as written is what the next save
    /// compares against, and `new_room` (a "save as") becomes the file edited.
    fn saved(
        &mut self,
        result: std::result::Result<(Saved, Vec<LidSource>), SaveError>,
        curves: CurveSave,
        new_room: Option<PathBuf>,
    ) -> Msg {
        match result {
            Ok((saved, sources)) => {
                self.loaded = saved.room;
                if let Some(path) = new_room {
                    self.room = path;
                }
                Msg::Saved {
                    message: saved.message,
                    sources,
                }
            }
            Err(e) => save::refusal(e, curves),
        }
    }

    /// Reads the room file again and starts over on it (the user chose "reload"): a new model,
    /// a new engine (the old one is stopped). A room that no longer loads keeps the session.
    fn reload(&mut self) {
        let read = scene::read_room(&self.room).and_then(|loaded| {
            let scene = scene::load::load_text(&self.room, &loaded.text)?;
            budget::check_scene(&scene, PlanOptions::default(), true, &self.limit)?;
            Ok((loaded, scene))
        });
        let (loaded, scene) = match read {
            Ok(read) => read,
            Err(e) => {
                self.model.message = Some(format!("cannot reload: {e}"));
                return;
            }
        };
        let _ = self.engine.send(EngineRequest::Stop);
        self.outbox.clear();
        let model = &self.model;
        let mut fresh = fresh_model(&scene, model.terminal_size, model.cell_px, model.protocol.clone());
        fresh.false_colour = model.false_colour;
        fresh.message = Some(format!(
            "reloaded {} (the edits were dropped)",
            self.room.display()
        ));
        self.model = fresh;
        self.loaded = loaded;
        self.engine = spawn_engine(scene, SessionOptions::with_user_cache(), self.sender.clone());
        self.frame_changed = true;
    }

    /// Reads the photometric file the user typed.
    fn load_lid(&self, typed: &str) -> Msg {
        let home = std::env::var_os("HOME").map(PathBuf::from);
        let path = luminaires::resolve_typed_path(&self.room, typed, home.as_deref());
        Msg::LidLoaded {
            result: read_lid_file(&path)
                .map(|lid| std::sync::Arc::new(LidInfo::of(lid)))
                .map_err(|e| e.to_string()),
            path,
        }
    }

    /// Sends the engine this turn's requests, in order, with the frame the model now shows
    /// when it changed.
    fn flush(&mut self) -> Result<()> {
        if self.frame_changed {
            self.frame_changed = false;
            if let Some(spec) = frame_spec(&self.model) {
                // Before picks of this turn, so they see the new frame.
                self.outbox.insert(0, EngineRequest::Frame(spec));
            }
        }
        for request in self.outbox.drain(..) {
            self.engine.send(request).map_err(|_| worker_stopped())?;
        }
        Ok(())
    }

    fn draw(&self, session: &mut TerminalSession) -> Result<()> {
        let (model, image) = (&self.model, self.image.as_ref());
        session.draw(|frame| {
            let mut preview = |f: &mut Frame<'_>, area: Rect| draw_preview(model, image, f, area);
            view(model, frame, PreviewArea::Draw(&mut preview));
        })
    }
}

/// The frame `model` shows; `None` while the preview has no pixels (terminal too small).
pub fn frame_spec(model: &Model) -> Option<FrameSpec> {
    let (width, height) = model.preview_px;
    (width > 0 && height > 0).then(|| FrameSpec {
        size_px: model.preview_px,
        mode: if model.false_colour {
            DisplayMode::FalseColor
        } else {
            DisplayMode::Photo
        },
        view: if model.plan_view {
            ViewChoice::Plan
        } else {
            ViewChoice::Camera
        },
        exposure: model.exposure,
        isolux: model.isolux,
        legend: true,
        refit: model.display_refit,
        selected_light: model.light().map(|_| model.selected_light),
        cursor: match model.mode {
            Mode::Aim { cursor } => Some(cursor),
            _ => None,
        },
    })
}

/// Where the editor writes the report: `ROOM-report.html` next to the room file.
pub fn report_path(room: &Path) -> PathBuf {
    let stem = room
        .file_stem()
        .map_or_else(|| "room".into(), |s| s.to_string_lossy().into_owned());
    room.with_file_name(format!("{stem}-report.html"))
}

/// A worker's channel closed: it ended, most likely by a panic, whose recorded message is given.
fn worker_stopped() -> Error {
    match crate::error::take_recorded_panic() {
        Some(panic) => Error::internal(format!(
            "internal error: a background worker of the editor panicked: {panic}"
        )),
        None => Error::internal("a background worker of the editor stopped"),
    }
}

/// The message for a terminal event the editor reacts to.
fn input_msg(event: Event) -> Option<Msg> {
    match event {
        Event::Key(key) => Some(Msg::Key(key)),
        Event::Mouse(MouseEvent {
            kind: MouseEventKind::Down(MouseButton::Left),
            column,
            row,
            ..
        }) => Some(Msg::Click { column, row }),
        Event::Resize(width, height) => Some(Msg::Resize { width, height }),
        _ => None,
    }
}

/// The preview pane's inside: the image when one fits, else the bake gauge or a note.
fn draw_preview(model: &Model, image: Option<&Protocol>, frame: &mut Frame<'_>, area: Rect) {
    if let Some(image) = image
        && preview::fits(image, area)
    {
        preview::draw(image, area, frame.buffer_mut());
        return;
    }
    let [middle] = Layout::vertical([Constraint::Length(1)])
        .flex(Flex::Center)
        .areas(area);
    match model.bake {
        Some((done, total)) => {
            let ratio = if total > 0 {
                done as f64 / total as f64
            } else {
                0.0
            };
            let [bar] = Layout::horizontal([Constraint::Percentage(60)])
                .flex(Flex::Center)
                .areas(middle);
            let gauge = Gauge::default()
                .ratio(ratio.clamp(0.0, 1.0))
                .label(format!("computing the light in the room… {done}/{total}"));
            frame.render_widget(gauge, bar);
        }
        None => frame.render_widget(
            Paragraph::new("rendering…").alignment(Alignment::Center).dim(),
            middle,
        ),
    }
}

#[cfg(test)]
mod tests {
    use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyModifiers};

    use super::*;

    #[test]
    fn terminal_events_become_messages() {
        let key = KeyEvent::new(KeyCode::Char('a'), KeyModifiers::NONE);
        assert_eq!(input_msg(Event::Key(key)), Some(Msg::Key(key)));
        let mouse = |kind| {
            Event::Mouse(MouseEvent {
                kind,
                column: 7,
                row: 3,
                modifiers: KeyModifiers::NONE,
            })
        };
        assert_eq!(
            input_msg(mouse(MouseEventKind::Down(MouseButton::Left))),
            Some(Msg::Click { column: 7, row: 3 })
        );
        assert_eq!(input_msg(mouse(MouseEventKind::Down(MouseButton::Right))), None);
        assert_eq!(input_msg(mouse(MouseEventKind::Moved)), None);
        assert_eq!(
            input_msg(Event::Resize(120, 40)),
            Some(Msg::Resize {
                width: 120,
                height: 40
            })
        );
        assert_eq!(input_msg(Event::FocusGained), None);
    }
}
