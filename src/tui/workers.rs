//! The editor's background threads and the one channel the app loop blocks on
//! (docs/ARCHITECTURE.md "The editor's threads"). The engine worker owns the [`Session`]: it applies the
//! editor's commands as given (everything queued at once), relights and renders once per batch,
//! answers picks on the frame it just made, and hands moved lights to the bake worker, whose
//! results come back as requests. The encode worker turns frames into the terminal's image
//! protocol. Every worker works on the latest of what is queued.

use std::collections::{BTreeSet, HashSet};
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::{self, Receiver, Sender};
use std::thread;
use std::time::{Duration, Instant};

use ratatui::crossterm::event::Event;
use ratatui::layout::Size;
use tiny_skia::Pixmap;

use glam::DVec3;

use crate::report::{ReportOptions, report_html};
use crate::scene::{Receiver as Point, Scene};
use crate::session::{
    BakeJob, BakeOutcome, Change, Command, FrameSpec, LightStatus, Session, SessionOptions, WatchId,
    group_aims,
};
use crate::transport::bake::Progress;
use crate::tui::frame_budget::FramePlan;
use crate::tui::msg::Msg;
use crate::tui::panel::PanelNumbers;
use crate::tui::preview::{self, FrameImage, ImageSetup};

/// Everything that reaches the app loop.
pub enum AppEvent {
    /// A terminal event from the input reader.
    Input(Event),
    /// The input reader failed (the terminal went away); one line for the user.
    InputFailed(String),
    /// A worker's message for `update` (progress, series, statuses, picks, failures).
    Msg(Msg),
    /// The engine finished a frame.
    Rendered(RenderedFrame),
    /// The encode worker finished (or skipped) a frame.
    Encoded(EncodedFrame),
    /// SIGTSTP arrived from outside: suspend as on Ctrl-Z.
    Suspend,
}

/// A rendered preview and what it cost.
#[derive(Debug, Clone)]
pub struct RenderedFrame {
    /// The image with overlays (shared with the encode worker; the engine reuses the buffer
    /// once the encoder has let go of it).
    pub pixmap: Arc<Pixmap>,
    /// Relight time, ms.
    pub relight_ms: f64,
    /// Render (rasterise + overlays) time, ms.
    pub render_ms: f64,
}

/// A frame ready for the terminal.
pub struct EncodedFrame {
    /// The new image, or `None` when the pixels did not change (nothing to re-send).
    pub image: Option<FrameImage>,
    /// The plan the frame was rendered for.
    pub plan: FramePlan,
    /// Bytes the terminal receives to show the new image ([`preview::frame_bytes`]).
    pub bytes: usize,
    /// The frame's relight and render times, ms.
    pub rendered: (f64, f64),
    /// Hashing + encoding time, ms.
    pub encode_ms: f64,
}

/// A frame for the encode worker, with the cells it must cover (columns, rows).
pub struct EncodeJob {
    /// The rendered frame.
    pub frame: RenderedFrame,
    /// What it was rendered for (full or reduced).
    pub plan: FramePlan,
    /// The preview's size in cells.
    pub cells: Size,
}

/// What the app asks of the engine worker.
#[derive(Debug)]
pub enum EngineRequest {
    /// Apply these commands, in order (the editor's model already has).
    Commands(Vec<Command>),
    /// Show this frame (size, mode, overlays).
    Frame(FrameSpec),
    /// What does preview pixel `pixel` of a `preview_px` preview show? Answered after the
    /// batch's frame is rendered, so an aim or an edit just made is in it.
    Pick {
        /// The preview pixel.
        pixel: (u32, u32),
        /// The preview's size the pixel refers to (scaled if the frame has another size).
        preview_px: (u32, u32),
        /// True when the pick aims the selected light.
        aim: bool,
        /// The lights aim mode would aim at the point (the pick reads the aim cursor's): the
        /// selected light, and its group (the selected light among them). Their aims there
        /// ([`group_aims`]) are solved while the editor is idle ([`Session::prepare`]).
        prepare_aim: Option<(usize, Vec<usize>)>,
    },
    /// A bake the bake worker finished.
    Baked(Box<BakeOutcome>),
    /// Write the report of the current state to this HTML file (answered with
    /// [`Msg::Reported`] or [`Msg::Failed`]).
    Report(std::path::PathBuf),
    /// End the engine (the room was reloaded and a new engine took over).
    Stop,
}

/// Milliseconds since `start`.
fn ms_since(start: Instant) -> f64 {
    start.elapsed().as_secs_f64() * 1e3
}

/// The newest job in `jobs`, waiting for one; `None` once the sender is gone.
fn latest<T>(jobs: &Receiver<T>) -> Option<T> {
    let mut job = jobs.recv().ok()?;
    while let Ok(newer) = jobs.try_recv() {
        job = newer;
    }
    Some(job)
}

/// Starts the engine worker on `scene`: it bakes (reporting [`Msg::BakeProgress`], then
/// [`Msg::BakeDone`] with every light's series), then serves [`EngineRequest`]s until the app
/// hangs up.
pub fn spawn_engine(
    scene: Scene,
    options: SessionOptions,
    events: Sender<AppEvent>,
) -> Sender<EngineRequest> {
    let (requests, queue) = mpsc::channel::<EngineRequest>();
    let bakes = spawn_bake_worker(requests.clone());
    thread::spawn(move || {
        let progress_events = events.clone();
        let mut progress = move |p: Progress| {
            let _ = progress_events.send(AppEvent::Msg(Msg::BakeProgress {
                done: p.done,
                total: p.total.max(1),
            }));
        };
        let _ = events.send(AppEvent::Msg(Msg::BakeProgress { done: 0, total: 1 }));
        let session = match Session::new(scene, options, &mut progress) {
            Ok(session) => session,
            Err(e) => {
                let _ = events.send(AppEvent::Msg(Msg::Failed {
                    message: format!("bake: {e}"),
                }));
                return;
            }
        };
        let mut engine = Engine {
            session,
            spec: None,
            pixmap: None,
            events,
            bakes,
            cursor: None,
            aim_read: None,
        };
        if engine.start().is_some() {
            while let Ok(first) = queue.recv() {
                let mut batch = vec![first];
                batch.extend(queue.try_iter());
                if engine.serve(batch).is_none() {
                    return;
                }
            }
        }
    });
    requests
}

/// The engine worker's state.
struct Engine {
    session: Session,
    spec: Option<FrameSpec>,
    /// The last frame's pixels, reused when the encoder has let go of them.
    pixmap: Option<Arc<Pixmap>>,
    events: Sender<AppEvent>,
    bakes: Sender<BakeJob>,
    /// The point under the cursor, kept lit for the numbers panel.
    cursor: Option<(WatchId, DVec3)>,
    /// The aim cursor's last read (the point whose aim was prepared): an aim at that pixel
    /// lands on that point, whatever frame size was drawn since; forgotten at any command or
    /// change of view.
    aim_read: Option<AimRead>,
}

/// The point the aim cursor read at a preview pixel.
#[derive(Debug, Clone, Copy)]
struct AimRead {
    /// The preview pixel, and the preview's size it refers to.
    pixel: (u32, u32),
    preview_px: (u32, u32),
    point: Point,
}

impl Engine {
    /// Sends `msg` to the app; `None` once the app is gone.
    fn send(&self, msg: Msg) -> Option<()> {
        self.events.send(AppEvent::Msg(msg)).ok()
    }

    /// After the bake: every light's series and status, then "done".
    fn start(&mut self) -> Option<()> {
        for light in 0..self.session.lights().len() {
            self.send(Msg::Series {
                light,
                series: self.session.series(light),
            })?;
        }
        self.send(Msg::LightStatus(self.statuses()))?;
        let notices = self.session.bake().map_or_else(Vec::new, |b| b.notices.clone());
        self.send(Msg::BakeDone { notices })?;
        self.send_numbers()
    }

    /// Computes the design numbers and the cursor's illuminance for the current lights (only
    /// the lights changed since the last time are recomputed) and sends them.
    fn send_numbers(&mut self) -> Option<()> {
        let start = Instant::now();
        let numbers = self.session.design_numbers();
        let cursor = self.cursor_lux();
        let maintenance_factor = self.session.scene().design.maintenance_factor;
        let panel = PanelNumbers::of(&numbers, maintenance_factor, cursor, ms_since(start));
        self.send(Msg::Numbers(Box::new(panel)))
    }

    /// The cursor point and its illuminance now, lx.
    fn cursor_lux(&mut self) -> Option<(DVec3, f64)> {
        let (id, point) = self.cursor?;
        let lux = self.session.watched(id)?.lux().first().copied()?;
        Some((point, lux))
    }

    /// Makes `receiver` the cursor point the numbers follow; returns its illuminance, lx.
    fn set_cursor(&mut self, receiver: Point) -> Option<f64> {
        if let Some((old, _)) = self.cursor.take() {
            self.session.unwatch(old);
        }
        let id = self.session.watch(vec![receiver]);
        self.cursor = Some((id, receiver.point));
        self.cursor_lux().map(|(_, lux)| lux)
    }

    /// Writes the report of the current state to `path`.
    fn report(&mut self, path: &std::path::Path) -> Msg {
        let room = self.session.scene().path.display().to_string();
        let written = report_html(&mut self.session, &room, &ReportOptions::default())
            .and_then(|html| crate::fsio::write_atomic(path, html.as_bytes()));
        match written {
            Ok(()) => Msg::Reported {
                message: format!("report written to {}", path.display()),
            },
            Err(e) => Msg::Failed {
                message: format!("report: {e}"),
            },
        }
    }

    fn statuses(&self) -> Vec<LightStatus> {
        (0..self.session.lights().len())
            .map(|i| self.session.light_status(i))
            .collect()
    }

    /// Handles one batch of requests: commands and finished bakes in order, then one relight and
    /// render, then the picks. `None` once the app is gone.
    fn serve(&mut self, batch: Vec<EngineRequest>) -> Option<()> {
        let mut redraw = false;
        let mut relit = false;
        let mut status_changed = false;
        let mut series: BTreeSet<usize> = BTreeSet::new();
        let mut picks = Vec::new();
        let mut reports = Vec::new();
        for request in batch {
            match request {
                EngineRequest::Stop => return None,
                EngineRequest::Commands(commands) => {
                    self.aim_read = None;
                    for command in commands {
                        match self.session.apply(command) {
                            Ok(applied) => {
                                redraw = true;
                                relit |= applied.change != Change::Camera;
                                match applied.change {
                                    Change::Point { light, .. }
                                    | Change::Curve { light }
                                    | Change::Window { light } => {
                                        series.insert(light);
                                    }
                                    Change::Order { light } | Change::Moved { light } => {
                                        series.insert(light);
                                        status_changed = true;
                                    }
                                    Change::Inserted { .. } | Change::Removed { .. } => {
                                        series.extend(0..self.session.lights().len());
                                        status_changed = true;
                                    }
                                    Change::Aim { .. } | Change::Dimmer { .. } | Change::Camera => {}
                                }
                            }
                            Err(e) => self.send(Msg::Failed {
                                message: format!("engine: {e}"),
                            })?,
                        }
                    }
                }
                EngineRequest::Frame(spec) => {
                    if self.spec.is_some_and(|old| old.view != spec.view) {
                        self.aim_read = None;
                    }
                    redraw |= self.spec != Some(spec);
                    self.spec = Some(spec);
                }
                EngineRequest::Pick {
                    pixel,
                    preview_px,
                    aim,
                    prepare_aim,
                } => picks.push((pixel, preview_px, aim, prepare_aim)),
                EngineRequest::Report(path) => reports.push(path),
                EngineRequest::Baked(outcome) => {
                    status_changed = true;
                    match self.session.finish_bake(*outcome) {
                        Ok(installed) => {
                            redraw |= installed.is_some();
                            relit |= installed.is_some();
                        }
                        Err(e) => self.send(Msg::Failed {
                            message: format!("bake: {e}"),
                        })?,
                    }
                }
            }
        }
        for path in &reports {
            let answer = self.report(path);
            self.send(answer)?;
            // The report drew its own views: the preview must be drawn again.
            redraw = true;
        }
        if redraw && let Some(spec) = self.spec {
            self.render(&spec)?;
        }
        for light in series {
            self.send(Msg::Series {
                light,
                series: self.session.series(light),
            })?;
        }
        let picked = !picks.is_empty();
        for (pixel, preview_px, aim, prepare_aim) in picks {
            let read = self
                .aim_read
                .filter(|r| aim && (r.pixel, r.preview_px) == (pixel, preview_px))
                .map(|r| r.point);
            let hit = match read {
                Some(point) => self.set_cursor(point).map(|lux| (point, lux)),
                None => self.pick(pixel, preview_px),
            };
            if let (Some((selected, group)), Some((point, _))) = (prepare_aim, hit) {
                self.aim_read = Some(AimRead {
                    pixel,
                    preview_px,
                    point,
                });
                // The selected light first: its aim is the one most surely asked for.
                let mut aims = group_aims(self.session.lights(), selected, &group, point.point);
                aims.sort_by_key(|(i, _)| *i != selected);
                let commands: Vec<Command> = aims.into_iter().filter_map(|(_, c)| c).collect();
                self.session.prepare(&commands);
            }
            let hit = hit.map(|(point, lux)| (point.point, lux));
            self.send(Msg::Picked { pixel, hit, aim })?;
        }
        if relit || picked {
            self.send_numbers()?;
        }
        // Commands queue re-bakes; the relight and the numbers queue the hierarchical engine's
        // solves (docs/ARCHITECTURE.md "The editor's threads").
        // Idle: the selected light's curve response (else an edited one's) grown a step
        // (docs/DECISIONS.md "Interreflection", "Responses completed while the editor is idle").
        self.session
            .queue_idle_work(self.spec.and_then(|s| s.selected_light));
        for job in self.session.take_bake_jobs() {
            status_changed = true;
            // The bake worker outlives the engine's use of it; a closed queue means shutdown.
            let _ = self.bakes.send(job);
        }
        if status_changed {
            self.send(Msg::LightStatus(self.statuses()))?;
        }
        Some(())
    }

    /// Relights, renders `spec` into the session's buffers and hands the pixels to the app.
    fn render(&mut self, spec: &FrameSpec) -> Option<()> {
        let start = Instant::now();
        self.session.relight();
        let relight_ms = ms_since(start);
        let start = Instant::now();
        let frame = match self.session.render(spec) {
            Ok(frame) => frame,
            Err(e) => {
                return self.send(Msg::Failed {
                    message: format!("preview: {e}"),
                });
            }
        };
        let pixels = &frame.pixmap;
        let reused = self
            .pixmap
            .as_mut()
            .and_then(Arc::get_mut)
            .filter(|p| (p.width(), p.height()) == (pixels.width(), pixels.height()));
        match reused {
            Some(buffer) => buffer.data_mut().copy_from_slice(pixels.data()),
            None => self.pixmap = Some(Arc::new(pixels.clone())),
        }
        let pixmap = Arc::clone(self.pixmap.as_ref()?);
        let rendered = RenderedFrame {
            pixmap,
            relight_ms,
            render_ms: ms_since(start),
        };
        self.events.send(AppEvent::Rendered(rendered)).ok()
    }

    /// The point under preview `pixel` (scaled from `preview_px` to the latest frame's size)
    /// and its illuminance as `haiko probe` gives it; the point becomes the cursor the numbers
    /// follow.
    fn pick(&mut self, pixel: (u32, u32), (w, h): (u32, u32)) -> Option<(Point, f64)> {
        let (frame, _) = self.session.latest_frame()?;
        let scale = |p: u32, from: u32, to: u32| {
            u32::try_from(u64::from(p) * u64::from(to) / u64::from(from.max(1))).unwrap_or(u32::MAX)
        };
        let at = (
            scale(pixel.0, w, frame.pixmap.width()),
            scale(pixel.1, h, frame.pixmap.height()),
        );
        let hit = self.session.pick(at)?;
        let point = Point {
            point: hit.point,
            normal: hit.normal,
        };
        Some((point, self.set_cursor(point)?))
    }
}

/// Starts the bake workers: each [`BakeJob`] (the latest per light when several are queued) is
/// run and its outcome sent back to the engine as [`EngineRequest::Baked`]. Regrades (a grading
/// check, or a whole engine rebuilt: about a minute on a large floor) run on a thread of their
/// own with a rayon pool of their own, so that the lights' solves queued while one runs neither
/// wait behind it nor queue behind its parallel tasks in the shared pool (the two share the
/// cores through the system's scheduler); a regrade starts once the lights' solves queued before
/// it have run — the moved light's own solve on the current engine first, at full speed
/// (docs/ARCHITECTURE.md "The editor's threads").
fn spawn_bake_worker(engine: Sender<EngineRequest>) -> Sender<BakeJob> {
    let (jobs, queue) = mpsc::channel::<BakeJob>();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(rayon::current_num_threads())
        .thread_name(|i| format!("haiko-regrade-{i}"))
        .build()
        .ok();
    // Light jobs sent to their runner and not yet run (or superseded).
    let queued = Arc::new(AtomicUsize::new(0));
    let regrades = spawn_job_runner(engine.clone(), pool, None);
    let lights = spawn_job_runner(engine, None, Some(Arc::clone(&queued)));
    thread::spawn(move || {
        for job in queue {
            let sent = if job.light().is_none() {
                while queued.load(Ordering::Acquire) > 0 {
                    thread::sleep(Duration::from_millis(5));
                }
                regrades.send(job)
            } else {
                queued.fetch_add(1, Ordering::AcqRel);
                lights.send(job)
            };
            if sent.is_err() {
                return;
            }
        }
    });
    jobs
}

/// A thread that runs the [`BakeJob`]s sent to it in order — in `pool` when given, else in the
/// global rayon pool — the latest per light when several are queued, and sends each outcome to
/// the engine; `queued`, when given, is decreased for each job run or superseded.
fn spawn_job_runner(
    engine: Sender<EngineRequest>,
    pool: Option<rayon::ThreadPool>,
    queued: Option<Arc<AtomicUsize>>,
) -> Sender<BakeJob> {
    let (jobs, queue) = mpsc::channel::<BakeJob>();
    thread::spawn(move || {
        let done = |n: usize| {
            if let Some(queued) = &queued {
                queued.fetch_sub(n, Ordering::AcqRel);
            }
        };
        while let Ok(first) = queue.recv() {
            let mut pending = vec![first];
            pending.extend(queue.try_iter());
            let received = pending.len();
            // A newer job for the same light supersedes an older one.
            let mut seen = HashSet::new();
            let mut latest_first: Vec<BakeJob> = pending
                .into_iter()
                .rev()
                .filter(|job| seen.insert(job.light()))
                .collect();
            latest_first.reverse();
            done(received - latest_first.len());
            for job in latest_first {
                let outcome = match &pool {
                    Some(pool) => pool.install(|| job.run(&mut |_| {})),
                    None => job.run(&mut |_| {}),
                };
                done(1);
                if engine.send(EngineRequest::Baked(Box::new(outcome))).is_err() {
                    return;
                }
            }
        }
    });
    jobs
}

/// Starts the encode worker: each [`EncodeJob`] (the latest when several are queued) is encoded
/// for `setup` ([`preview::encode_frame`]) unless its pixels, size and plan equal the previous
/// job's; answers with [`AppEvent::Encoded`] or a [`Msg::Failed`].
pub fn spawn_encode_worker(setup: ImageSetup, events: Sender<AppEvent>) -> Sender<EncodeJob> {
    let (jobs, queue) = mpsc::channel::<EncodeJob>();
    thread::spawn(move || {
        let mut previous: Option<(u64, Size, FramePlan)> = None;
        while let Some(job) = latest(&queue) {
            let start = Instant::now();
            let pixmap = &job.frame.pixmap;
            let key = (preview::pixmap_hash(pixmap), job.cells, job.plan);
            let encoded = if previous == Some(key) {
                Ok(None)
            } else {
                let size = (pixmap.width(), pixmap.height());
                preview::encode_frame(&setup, pixmap.data(), size, job.plan, job.cells).and_then(|image| {
                    let area = ratatui::layout::Rect::new(0, 0, job.cells.width, job.cells.height);
                    Ok(Some((preview::frame_bytes(&image, area)?, image)))
                })
            };
            let (bytes, image) = match encoded {
                Ok(Some((bytes, image))) => (bytes, Some(image)),
                Ok(None) => (0, None),
                Err(e) => {
                    let failed = Msg::Failed {
                        message: e.to_string(),
                    };
                    if events.send(AppEvent::Msg(failed)).is_err() {
                        return;
                    }
                    continue;
                }
            };
            previous = Some(key);
            let encoded = EncodedFrame {
                image,
                plan: job.plan,
                bytes,
                rendered: (job.frame.relight_ms, job.frame.render_ms),
                encode_ms: ms_since(start),
            };
            drop(job);
            if events.send(AppEvent::Encoded(encoded)).is_err() {
                return;
            }
        }
    });
    jobs
}
