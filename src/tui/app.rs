//! `haiko edit ROOM`: the app loop. Loads the room (before the screen is taken; a recovery file
//! left by a signal is offered first), enters the terminal, starts the workers and the signal
//! watcher, then blocks on one channel: each event becomes a [`Msg`] for [`update`], whose
//! [`Effect`]s are carried out here — commands and frame requests collected and sent to the
//! engine once per loop turn (in order), picks asked of the engine, saves written, suspending,
//! quitting. While keys repeat the frames are reduced to fit the frame budget; the full frame
//! follows once input has been idle ([`FrameBudget`]).

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender};
use std::time::Instant;

use ratatui::Frame;
use ratatui::crossterm::event::{Event, MouseButton, MouseEvent, MouseEventKind};
use ratatui::layout::{Alignment, Constraint, Flex, Layout, Rect, Size};
use ratatui::style::Stylize;
use ratatui::widgets::{Gauge, Paragraph};

use crate::error::{Error, Result};
use crate::photometry::read_lid_file;
use crate::render::DisplayMode;
use crate::scene::save::{IfChanged, SaveError, Saved};
use crate::scene::{self, LidSource, RoomText};
use crate::session::budget::{self, MemoryLimit};
use crate::session::{FrameSpec, SessionOptions, ViewChoice, initial_lights};
use crate::transport::plan::{PlanOptions, plan};
use crate::tui::frame_budget::{Budget, DIVISORS, FrameBudget, FramePlan, prior_bytes_per_pixel};
use crate::tui::luminaires::{self, LidInfo};
use crate::tui::msg::{CurveSave, Effect, Msg};
use crate::tui::polar::{PolarOptions, PolarScale, PolarStyle};
use crate::tui::preview::FrameImage;
use crate::tui::recovery::{self, Answer};
use crate::tui::save::{SaveTarget, edit_room_text};
use crate::tui::signals::{self, PendingEdits};
use crate::tui::terminal::{Graphics, TerminalSession, spawn_input_reader};
use crate::tui::view::dialog_shown;
use crate::tui::workers::{
    AppEvent, EncodeJob, EncodedFrame, EngineRequest, RenderedFrame, spawn_encode_worker, spawn_engine,
};
use crate::tui::{Mode, Model, PreviewArea, save, update, view};

/// How the editor talks to the terminal (the `haiko edit` flags, README "Terminals").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EditorOptions {
    /// The image protocol asked for.
    pub graphics: Graphics,
    /// The polar diagram's style; `None`: [`PolarStyle::detect`] (`$HAIKO_POLAR`, the terminal).
    pub polar: Option<PolarStyle>,
    /// The byte budget of an interactive frame.
    pub budget: Budget,
}

impl Default for EditorOptions {
    fn default() -> Self {
        EditorOptions {
            graphics: Graphics::Auto,
            polar: None,
            budget: Budget::Auto,
        }
    }
}

/// Runs the editor on the room file `room` with `options`. A recovery file of the room is
/// offered first (on the standard streams, before the terminal is taken); a bad room fails
/// before the terminal is touched; the terminal is restored however the editor ends, also on
/// SIGTERM, SIGHUP, SIGINT and SIGQUIT (`tui::signals`), which keep unsaved edits in the
/// recovery file.
///
/// Errors: the room file or the recovery file (bad input), the terminal or a worker (internal).
pub fn run(room: &Path, options: EditorOptions, limit: &MemoryLimit) -> Result<()> {
    let loaded = scene::read_room(room)?;
    let saved_scene = scene::load::load_text(room, &loaded.text)?;
    // Before the terminal is taken: a room too large for memory is refused on a sane screen.
    budget::check_scene(&saved_scene, PlanOptions::default(), true, limit)?;
    let restored = match recovery::find(room)? {
        Some(found) => {
            let answer = recovery::ask(
                &found,
                &loaded.text,
                &mut std::io::stdin().lock(),
                &mut std::io::stderr(),
            )
            .map_err(|e| Error::internal(format!("asking about the recovery file: {e}")))?;
            match answer {
                Answer::Restore => Some(scene::load(&found.path)?),
                Answer::Discard => {
                    recovery::discard(room)?;
                    None
                }
                Answer::Keep => None,
            }
        }
        None => None,
    };
    // Temporaries of a save that was killed midway (docs/DECISIONS.md "Saving").
    let removed = scene::save::remove_stale_temporaries(room).unwrap_or_default();
    // What loading repaired (OBJ faces left out or turned) shows until the first key, after
    // what the start itself has to say (a restored recovery file, the terminal's hint).
    let mut messages: Vec<String> = loading_notes(&saved_scene).into_iter().collect();
    if !removed.is_empty() {
        messages.push(format!(
            "removed {} temporary file(s) an interrupted save left beside the room file",
            removed.len()
        ));
    }
    let mut session = TerminalSession::enter(options.graphics)?;
    let mut app = App::start(saved_scene, restored, loaded, room, *limit, &session, options)?;
    if !messages.is_empty() {
        messages.splice(0..0, app.model.message.take());
        app.model.message = Some(messages.join("; "));
    }
    app.run(&mut session)
}

/// What loading `scene` repaired ([`scene::Scene::notes`]), for the one-line message: the note
/// itself, or when there are several, how many (`haiko plan` prints them all) and the first.
fn loading_notes(scene: &scene::Scene) -> Option<String> {
    match scene.notes.as_slice() {
        [] => None,
        [one] => Some(one.clone()),
        [first, ..] => Some(format!(
            "{} notes on loading (`haiko plan` lists them): {first}",
            scene.notes.len()
        )),
    }
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
    image: Option<FrameImage>,
    /// A new image's plan and bytes, recorded once it is written.
    unrecorded: Option<(FramePlan, usize)>,
    /// The budget of interactive frames.
    budget: FrameBudget,
    /// The plan of the last frame asked of the engine.
    requested: Option<FramePlan>,
    /// When the last key or click came.
    last_input: Instant,
    /// The edits to keep on a signal (made on `loaded`).
    pending: PendingEdits,
    /// True when the edits changed this turn (the recovery text is made again).
    edits_changed: bool,
    suspend: bool,
    /// True when the last frame drawn showed a dialog ([`dialog_shown`]).
    dialog_shown: bool,
    quit: bool,
}

impl App {
    /// The editor on `saved` (the room as saved, its text `loaded`), showing `restored` (the
    /// room with recovered edits) when given.
    fn start(
        saved: scene::Scene,
        restored: Option<scene::Scene>,
        loaded: RoomText,
        room: &Path,
        limit: MemoryLimit,
        session: &TerminalSession,
        options: EditorOptions,
    ) -> Result<App> {
        let setup = session.setup().clone();
        // The saved state, with the orders the plan chooses for the room as saved.
        let saved_lights = fresh_model(&saved, (1, 1), (1, 1), String::new()).saved;
        let edited = restored.is_some();
        let scene = restored.unwrap_or(saved);
        let mut model = fresh_model(&scene, session.size()?, setup.cell_px, setup.label());
        model.message = setup.hint.clone();
        model.polar = PolarOptions {
            style: options
                .polar
                .unwrap_or_else(|| PolarStyle::detect(|name| std::env::var(name).ok())),
            scale: None,
        };
        if edited {
            model.saved = saved_lights;
            model.refresh_dirty();
            model.message = Some("restored the unsaved edits from the recovery file (s saves them)".into());
        }
        let (sender, events) = mpsc::channel();
        spawn_input_reader(sender.clone());
        let engine_options = SessionOptions {
            memory_limit: Some(limit),
            ..SessionOptions::with_user_cache().interactive()
        };
        let engine = spawn_engine(scene, engine_options, sender.clone());
        let encode_jobs = spawn_encode_worker(setup, sender.clone());
        let pending = PendingEdits::default();
        signals::watch(room.to_path_buf(), pending.clone())
            .map_err(|e| Error::internal(format!("cannot watch for signals: {e}")))?;
        let suspend = sender.clone();
        signals::watch_suspend(move || {
            // The app gone means the editor is ending anyway.
            let _ = suspend.send(AppEvent::Suspend);
        })
        .map_err(|e| Error::internal(format!("cannot watch for signals: {e}")))?;
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
            unrecorded: None,
            // Every protocol sent is compressed (sixel runs, PNG); half-blocks do not shrink.
            budget: FrameBudget::new(options.budget, prior_bytes_per_pixel(true)),
            requested: None,
            last_input: Instant::now(),
            pending,
            edits_changed: edited,
            suspend: false,
            dialog_shown: false,
            quit: false,
        })
    }

    fn run(&mut self, session: &mut TerminalSession) -> Result<()> {
        self.flush()?;
        self.draw(session)?;
        while !self.quit {
            match self.next_event()? {
                Some(event) => self.handle(event)?,
                // Input went idle after reduced frames: the full frame is due.
                None => self.frame_changed = true,
            }
            // Handle whatever else is already queued before drawing once.
            while !self.quit
                && let Ok(event) = self.events.try_recv()
            {
                self.handle(event)?;
            }
            if self.suspend {
                self.suspend = false;
                session.suspend()?;
                self.frame_changed = true;
            }
            if !self.quit {
                self.keep_edits();
                self.follow_polar_scale();
                self.flush()?;
                self.draw(session)?;
            }
        }
        Ok(())
    }

    /// The next event; `None` when the full frame is due first (the last frame asked for was
    /// reduced and input has since been idle, [`FrameBudget::full_frame_in`]).
    fn next_event(&self) -> Result<Option<AppEvent>> {
        let reduced = self
            .requested
            .is_some_and(|p| !matches!(p, FramePlan::Full { .. }));
        if !reduced {
            return self.events.recv().map(Some).map_err(|_| worker_stopped());
        }
        match self
            .events
            .recv_timeout(self.budget.full_frame_in(self.last_input.elapsed()))
        {
            Ok(event) => Ok(Some(event)),
            Err(RecvTimeoutError::Timeout) => Ok(None),
            Err(RecvTimeoutError::Disconnected) => Err(worker_stopped()),
        }
    }

    /// Keeps the room text with the unsaved edits ready for the signal watcher.
    fn keep_edits(&mut self) {
        if !std::mem::take(&mut self.edits_changed) {
            return;
        }
        if !self.model.dirty {
            self.pending.clear();
        } else if let Ok(edited) = edit_room_text(&self.room, &self.loaded.text, &self.model) {
            self.pending
                .set(edited.text, recovery::fnv1a64(&self.loaded.text));
        }
    }

    /// The polar diagram's scale after this turn's edits (it changes in round steps).
    fn follow_polar_scale(&mut self) {
        if let Some(peak) = crate::tui::view::polar_peak(&self.model) {
            let scale = self.model.polar.scale;
            self.model.polar.scale =
                Some(scale.map_or_else(|| PolarScale::fitting(peak), |s| s.follow(peak)));
        }
    }

    fn handle(&mut self, event: AppEvent) -> Result<()> {
        match event {
            AppEvent::Input(event) => match input_msg(event) {
                Some(msg) => {
                    let aiming = matches!(self.model.mode, Mode::Aim { .. });
                    if matches!(msg, Msg::Key(_) | Msg::Click { .. })
                        || (aiming && matches!(msg, Msg::Hover { .. }))
                    {
                        self.last_input = Instant::now();
                    }
                    self.dispatch(msg)
                }
                None => Ok(()),
            },
            AppEvent::InputFailed(message) => {
                Err(Error::internal(format!("reading the terminal: {message}")))
            }
            AppEvent::Msg(msg) => self.dispatch(msg),
            AppEvent::Suspend => {
                self.suspend = true;
                Ok(())
            }
            AppEvent::Rendered(frame) => self.on_rendered(frame),
            AppEvent::Encoded(encoded) => {
                let EncodedFrame {
                    image,
                    plan,
                    bytes,
                    rendered,
                    encode_ms,
                } = encoded;
                if let Some(image) = image {
                    self.image = Some(image);
                    self.unrecorded = Some((plan, bytes));
                }
                let (relight_ms, render_ms) = rendered;
                self.dispatch(Msg::Frame {
                    relight_ms,
                    render_ms,
                    encode_ms,
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
        let full = self.model.preview_px;
        let size = (frame.pixmap.width(), frame.pixmap.height());
        let plan = self
            .requested
            .filter(|p| p.size(full) == size)
            .or_else(|| {
                DIVISORS
                    .iter()
                    .map(|&divisor| FramePlan::Interactive { divisor })
                    .find(|p| p.size(full) == size)
            })
            .unwrap_or(FramePlan::Full { dither: false });
        self.encode_jobs
            .send(EncodeJob { frame, plan, cells })
            .map_err(|_| worker_stopped())
    }

    /// Applies `msg` and carries out the effects, feeding their answers back to `update`.
    fn dispatch(&mut self, msg: Msg) -> Result<()> {
        let mut queue = VecDeque::from([msg]);
        while let Some(msg) = queue.pop_front() {
            for effect in update(&mut self.model, msg) {
                match effect {
                    Effect::Engine(command) => {
                        self.edits_changed = true;
                        match self.outbox.last_mut() {
                            Some(EngineRequest::Commands(commands)) => commands.push(command),
                            _ => self.outbox.push(EngineRequest::Commands(vec![command])),
                        }
                    }
                    Effect::Render => self.frame_changed = true,
                    Effect::Pick { pixel, aim } => self.outbox.push(EngineRequest::Pick {
                        pixel,
                        preview_px: self.model.preview_px,
                        aim,
                        // The aim cursor read: an Enter would aim the selected light there.
                        prepare_aim: (!aim && matches!(self.model.mode, Mode::Aim { .. }))
                            .then(|| (self.model.selected_light, luminaires::group(&self.model))),
                    }),
                    Effect::Save { curves, overwrite } => queue.push_back(self.save(curves, overwrite)),
                    Effect::SaveAs(name) => queue.push_back(self.save_as(&name)),
                    Effect::Reload => self.reload(),
                    Effect::LoadLid(typed) => queue.push_back(self.load_lid(&typed)),
                    Effect::Report => self.outbox.push(EngineRequest::Report(report_path(&self.room))),
                    Effect::Suspend => self.suspend = true,
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
                // The edits are in a file now: the recovery file is stale.
                let _ = recovery::discard(&self.room);
                self.edits_changed = true;
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
        fresh.polar = PolarOptions {
            scale: None,
            ..model.polar
        };
        fresh.message = Some(format!(
            "reloaded {} (the edits were dropped){}",
            self.room.display(),
            loading_notes(&scene).map_or(String::new(), |n| format!("; {n}"))
        ));
        self.model = fresh;
        self.loaded = loaded;
        self.edits_changed = true;
        let engine_options = SessionOptions {
            memory_limit: Some(self.limit),
            ..SessionOptions::with_user_cache().interactive()
        };
        self.engine = spawn_engine(scene, engine_options, self.sender.clone());
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
            if let Some(full) = frame_spec(&self.model) {
                let plan = self.budget.plan(self.last_input.elapsed(), full.size_px);
                self.requested = Some(plan);
                // Before picks of this turn, so they see the new frame.
                self.outbox.insert(0, EngineRequest::Frame(reduced(full, plan)));
            }
        }
        for request in self.outbox.drain(..) {
            self.engine.send(request).map_err(|_| worker_stopped())?;
        }
        Ok(())
    }

    /// Draws the screen; a new image's bytes and write time go to the frame budget.
    fn draw(&mut self, session: &mut TerminalSession) -> Result<()> {
        let (model, image) = (&self.model, self.image.as_ref());
        // A dialog closed: the normal draw puts the text cells right, then everything is drawn
        // again so the preview image covers what the dialog left on it.
        let dialog_closed =
            std::mem::replace(&mut self.dialog_shown, dialog_shown(model)) && !self.dialog_shown;
        let start = Instant::now();
        for pass in 0..1 + usize::from(dialog_closed) {
            if pass > 0 {
                session.forget_screen();
            }
            session.draw(|frame| {
                let mut preview = |f: &mut Frame<'_>, area: Rect| draw_preview(model, image, f, area);
                view(model, frame, PreviewArea::Draw(&mut preview));
            })?;
        }
        if let Some((plan, bytes)) = self.unrecorded.take() {
            self.budget
                .record(plan, self.model.preview_px, bytes, start.elapsed());
        }
        Ok(())
    }
}

/// `full` rendered for `plan`: its size reduced, the aim cursor scaled with it.
fn reduced(full: FrameSpec, plan: FramePlan) -> FrameSpec {
    let d = plan.divisor().max(1);
    FrameSpec {
        size_px: plan.size(full.size_px),
        cursor: full.cursor.map(|(x, y)| (x / d, y / d)),
        ..full
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
        view: match (model.plan_view, model.plan_work_plane) {
            (false, _) => ViewChoice::Camera,
            (true, false) => ViewChoice::Plan,
            (true, true) => ViewChoice::WorkPlane,
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
        Event::Mouse(MouseEvent {
            kind: MouseEventKind::Moved,
            column,
            row,
            ..
        }) => Some(Msg::Hover { column, row }),
        Event::Resize(width, height) => Some(Msg::Resize { width, height }),
        _ => None,
    }
}

/// The preview pane's inside: the image when one fits, else the bake gauge or a note.
fn draw_preview(model: &Model, image: Option<&FrameImage>, frame: &mut Frame<'_>, area: Rect) {
    if let Some(image) = image
        && image.size().width <= area.width
        && image.size().height <= area.height
    {
        image.draw(area, frame.buffer_mut());
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
    fn loading_notes_fit_the_message_line() {
        let mut scene = crate::scene::load::test_room(
            "version = 1\n[room]\nsize = [3.0, 3.0, 2.5]\n[room.reflectance]\nfloor = 0.2\nwalls = 0.5\nceiling = 0.7\n",
        );
        assert_eq!(loading_notes(&scene), None);
        scene.notes = vec!["mesh[0]: one".into()];
        assert_eq!(loading_notes(&scene).as_deref(), Some("mesh[0]: one"));
        scene.notes.push("mesh[1]: two".into());
        assert_eq!(
            loading_notes(&scene).as_deref(),
            Some("2 notes on loading (`haiko plan` lists them): mesh[0]: one")
        );
    }

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
        assert_eq!(
            input_msg(mouse(MouseEventKind::Moved)),
            Some(Msg::Hover { column: 7, row: 3 })
        );
        assert_eq!(input_msg(mouse(MouseEventKind::Drag(MouseButton::Left))), None);
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
