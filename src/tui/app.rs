//! `haiko edit ROOM`: the app loop. Loads the room (before the screen is taken), enters the
//! terminal, starts the workers, then blocks on one channel: each event becomes a [`Msg`] for
//! [`update`], whose [`Effect`]s are carried out here (picks, saves, quitting) or by the
//! workers (a new frame is requested whenever the model asks for a different one).

use std::collections::VecDeque;
use std::fs;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::mpsc::{self, Receiver, Sender};

use ratatui::Frame;
use ratatui::crossterm::event::{Event, MouseButton, MouseEvent, MouseEventKind};
use ratatui::layout::{Alignment, Constraint, Flex, Layout, Rect, Size};
use ratatui::style::Stylize;
use ratatui::widgets::{Gauge, Paragraph};
use ratatui_image::protocol::Protocol;

use crate::error::{Error, Result};
use crate::scene::{self, Scene};
use crate::transport::plan::{PlanOptions, plan};
use crate::tui::msg::{Effect, Msg};
use crate::tui::renderer::{FrameRequest, PreviewFrame};
use crate::tui::series::series_msg;
use crate::tui::terminal::Graphics;
use crate::tui::terminal::{TerminalSession, spawn_input_reader};
use crate::tui::workers::{AppEvent, EncodeJob, RenderedFrame, spawn_encode_worker, spawn_render_worker};
use crate::tui::{Model, PreviewArea, preview, save_room, update, view};

/// Runs the editor on the room file `room` with the `graphics` protocol choice. A bad room
/// fails before the terminal is touched; the terminal is restored however the editor ends.
///
/// Errors: the room file (bad input), the terminal or a worker (internal).
pub fn run(room: &Path, graphics: Graphics) -> Result<()> {
    let scene = Arc::new(scene::load(room)?);
    let mut session = TerminalSession::enter(graphics)?;
    let mut app = App::start(scene, room, &session)?;
    app.run(&mut session)
}

/// The running editor: the model and the app's side of the workers.
struct App {
    model: Model,
    scene: Arc<Scene>,
    room: PathBuf,
    events: Receiver<AppEvent>,
    render_jobs: Sender<crate::tui::renderer::FrameRequest>,
    encode_jobs: Sender<EncodeJob>,
    /// The latest rendered frame (for picks).
    latest: Option<Arc<PreviewFrame>>,
    /// The latest encoded image on screen.
    image: Option<Protocol>,
    /// The last frame asked of the render worker.
    requested: Option<FrameRequest>,
    quit: bool,
}

impl App {
    fn start(scene: Arc<Scene>, room: &Path, session: &TerminalSession) -> Result<App> {
        let mut model = Model::new(&scene, session.size()?, preview::cell_px(session.picker()));
        model.protocol = preview::protocol_label(session.picker());
        let planned = plan(&scene, PlanOptions::default());
        for (i, (light, choice)) in scene.lights.iter().zip(&planned.lights).enumerate() {
            if light.order.is_none() {
                model.set_planned_order(i, choice.order);
            }
        }
        let (sender, events) = mpsc::channel();
        spawn_input_reader(sender.clone());
        let render_jobs = spawn_render_worker(Arc::clone(&scene), sender.clone());
        let encode_jobs = spawn_encode_worker(session.picker().clone(), sender);
        let mut app = App {
            model,
            scene,
            room: room.to_path_buf(),
            events,
            render_jobs,
            encode_jobs,
            latest: None,
            image: None,
            requested: None,
            quit: false,
        };
        for i in 0..app.model.lights.len() {
            app.dispatch(series_msg(i, &app.model.lights[i]))?;
        }
        Ok(app)
    }

    fn run(&mut self, session: &mut TerminalSession) -> Result<()> {
        self.request_frame()?;
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
                self.request_frame()?;
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
        self.latest = Some(Arc::clone(&frame.preview));
        if frame.rebuilt {
            self.dispatch(Msg::BakeDone)?;
        }
        let (cell_w, cell_h) = self.model.cell_px;
        let view = &frame.preview.view;
        let cells = Size::new(
            u16::try_from(view.width() / u32::from(cell_w)).unwrap_or(u16::MAX),
            u16::try_from(view.height() / u32::from(cell_h)).unwrap_or(u16::MAX),
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
                    Effect::Relight { light } => {
                        queue.push_back(series_msg(light, &self.model.lights[light]))
                    }
                    Effect::Rebake { light } => {
                        queue.push_back(series_msg(light, &self.model.lights[light]));
                        queue.push_back(Msg::BakeProgress { done: 0, total: 1 });
                    }
                    // The next frame request follows from the model (request_frame).
                    Effect::Render => {}
                    Effect::Pick { pixel, aim } => queue.push_back(Msg::Picked {
                        pixel,
                        hit: self.pick(pixel),
                        aim,
                    }),
                    Effect::Save => queue.push_back(self.save()),
                    Effect::Quit => self.quit = true,
                }
            }
        }
        Ok(())
    }

    /// The point and illuminance under preview `pixel` of the latest frame (scaled when that
    /// frame was rendered at another size).
    fn pick(&self, pixel: (u32, u32)) -> Option<(glam::DVec3, f64)> {
        let frame = self.latest.as_ref()?;
        let (w, h) = self.model.preview_px;
        let scale = |p: u32, from: u32, to: u32| {
            u32::try_from(u64::from(p) * u64::from(to) / u64::from(from.max(1))).unwrap_or(u32::MAX)
        };
        let at = (
            scale(pixel.0, w, frame.view.width()),
            scale(pixel.1, h, frame.view.height()),
        );
        frame.pick(&self.scene.fine, at)
    }

    fn save(&self) -> Msg {
        let saved = fs::read_to_string(&self.room)
            .map_err(|e| Error::unreadable(&self.room, &e))
            .and_then(|text| save_room(&self.room, &text, &self.model));
        match saved {
            Ok(message) => Msg::Saved { message },
            Err(e) => Msg::Failed {
                message: e.to_string(),
            },
        }
    }

    /// Sends the render worker the frame the model now shows, unless it was already asked for.
    fn request_frame(&mut self) -> Result<()> {
        let request = FrameRequest::from_model(&self.model);
        if request.is_some() && request != self.requested {
            if let Some(r) = &request {
                self.render_jobs.send(r.clone()).map_err(|_| worker_stopped())?;
            }
            self.requested = request;
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

fn worker_stopped() -> Error {
    Error::internal("a background worker of the editor stopped")
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
