//! The editor's background threads and the one channel the app loop blocks on (docs/ARCHITECTURE.md: gitui's
//! shape). The render worker owns the [`PreviewRenderer`] (relight + render + overlays); the
//! encode worker turns frames into the terminal's image protocol. Both coalesce their queue:
//! only the latest request is worked on.

use std::sync::Arc;
use std::sync::mpsc::{self, Receiver, Sender};
use std::thread;
use std::time::Instant;

use ratatui::crossterm::event::Event;
use ratatui::layout::Size;
use ratatui_image::picker::Picker;
use ratatui_image::protocol::Protocol;

use crate::error::Result;
use crate::scene::Scene;
use crate::transport::bake::Progress;
use crate::transport::cache;
use crate::tui::msg::Msg;
use crate::tui::preview;
use crate::tui::renderer::{FrameRequest, PreviewFrame, PreviewRenderer};

/// Everything that reaches the app loop.
pub enum AppEvent {
    /// A terminal event from the input reader.
    Input(Event),
    /// The input reader failed (the terminal went away); one line for the user.
    InputFailed(String),
    /// A worker's message for `update` (bake progress, failures).
    Msg(Msg),
    /// The render worker finished a frame.
    Rendered(RenderedFrame),
    /// The encode worker finished (or skipped) a frame.
    Encoded(EncodedFrame),
}

/// A rendered preview and what it cost.
#[derive(Debug, Clone)]
pub struct RenderedFrame {
    /// The frame (shared with the encode worker).
    pub preview: Arc<PreviewFrame>,
    /// True when a light moved and the direct caches were rebuilt for this frame.
    pub rebuilt: bool,
    /// Relight time, ms.
    pub relight_ms: f64,
    /// Render (rasterise + overlays) time, ms.
    pub render_ms: f64,
}

/// A frame ready for the terminal.
pub struct EncodedFrame {
    /// The new image, or `None` when the pixels did not change (nothing to re-send).
    pub protocol: Option<Protocol>,
    /// The frame's relight and render times, ms.
    pub rendered: (f64, f64),
    /// Hashing + encoding time, ms.
    pub encode_ms: f64,
}

/// A frame for the encode worker, with the cells it must cover (columns, rows).
pub struct EncodeJob {
    /// The rendered frame.
    pub frame: RenderedFrame,
    /// The preview's size in cells.
    pub cells: Size,
}

/// Milliseconds since `start`.
fn ms_since(start: Instant) -> f64 {
    start.elapsed().as_secs_f64() * 1e3
}

/// The newest job in `jobs`, waiting for one; `None` once the app is gone.
fn latest<T>(jobs: &Receiver<T>) -> Option<T> {
    let mut job = jobs.recv().ok()?;
    while let Ok(newer) = jobs.try_recv() {
        job = newer;
    }
    Some(job)
}

/// Starts the render worker: it first builds the relighting caches (reporting
/// [`Msg::BakeProgress`] and [`Msg::BakeDone`]), then renders each [`FrameRequest`] it
/// receives (the latest one when several are queued), answering with [`AppEvent::Rendered`]
/// or a [`Msg::Failed`].
pub fn spawn_render_worker(scene: Arc<Scene>, events: Sender<AppEvent>) -> Sender<FrameRequest> {
    let (jobs, queue) = mpsc::channel::<FrameRequest>();
    thread::spawn(move || {
        let _ = events.send(AppEvent::Msg(Msg::BakeProgress { done: 0, total: 1 }));
        let progress_events = events.clone();
        let mut progress = move |p: Progress| {
            let _ = progress_events.send(AppEvent::Msg(Msg::BakeProgress {
                done: p.done,
                total: p.total.max(1),
            }));
        };
        let mut renderer = match PreviewRenderer::new(scene, Some(cache::default_dir()), &mut progress) {
            Ok(renderer) => renderer,
            Err(e) => {
                let _ = events.send(AppEvent::Msg(Msg::Failed {
                    message: format!("bake: {e}"),
                }));
                return;
            }
        };
        if events.send(AppEvent::Msg(Msg::BakeDone)).is_err() {
            return;
        }
        while let Some(request) = latest(&queue) {
            let event = match render_one(&mut renderer, &request) {
                Ok(frame) => AppEvent::Rendered(frame),
                Err(e) => AppEvent::Msg(Msg::Failed {
                    message: format!("preview: {e}"),
                }),
            };
            if events.send(event).is_err() {
                return;
            }
        }
    });
    jobs
}

/// Relights the lights that changed and renders `request`, timing both stages.
///
/// Errors: as [`PreviewRenderer::apply_lights`] and [`PreviewRenderer::render`].
pub fn render_one(renderer: &mut PreviewRenderer, request: &FrameRequest) -> Result<RenderedFrame> {
    let start = Instant::now();
    let applied = renderer.apply_lights(&request.lights)?;
    let relight_ms = ms_since(start);
    let start = Instant::now();
    let preview = renderer.render(request)?;
    Ok(RenderedFrame {
        preview: Arc::new(preview),
        rebuilt: applied.rebuilt,
        relight_ms,
        render_ms: ms_since(start),
    })
}

/// Starts the encode worker: each [`EncodeJob`] (the latest when several are queued) is encoded
/// with `picker`'s protocol unless its pixels and size equal the previous job's; answers with
/// [`AppEvent::Encoded`] or a [`Msg::Failed`].
pub fn spawn_encode_worker(picker: Picker, events: Sender<AppEvent>) -> Sender<EncodeJob> {
    let (jobs, queue) = mpsc::channel::<EncodeJob>();
    thread::spawn(move || {
        let mut previous: Option<(u64, Size)> = None;
        while let Some(job) = latest(&queue) {
            let start = Instant::now();
            let pixmap = &job.frame.preview.frame.pixmap;
            let key = (preview::pixmap_hash(pixmap), job.cells);
            let protocol = if previous == Some(key) {
                None
            } else {
                match preview::encode(&picker, pixmap, job.cells) {
                    Ok(protocol) => Some(protocol),
                    Err(e) => {
                        let failed = Msg::Failed {
                            message: e.to_string(),
                        };
                        if events.send(AppEvent::Msg(failed)).is_err() {
                            return;
                        }
                        continue;
                    }
                }
            };
            previous = Some(key);
            let encoded = EncodedFrame {
                protocol,
                rendered: (job.frame.relight_ms, job.frame.render_ms),
                encode_ms: ms_since(start),
            };
            if events.send(AppEvent::Encoded(encoded)).is_err() {
                return;
            }
        }
    });
    jobs
}
