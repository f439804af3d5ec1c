//! The report made from a session (`haiko report`, and the editor's report key): the views
//! rendered through the session, its design numbers, the luminaire schedule of the current
//! lights and the accuracy settings of its bake, put into [`crate::report::html`].
//!
//! Views, in order: the plan (the session's orthographic plan view in false colour, with isolux
//! lines, luminaire symbols and the legend: [`plan_image`]), the room's camera in photo mode and
//! in false colour (with the legend of the false-colour scale).

use std::fmt::Write as _;

use crate::error::{Error, Result};
use crate::metrics::{SourceStatus, luminaire_schedule};
use crate::render::{DisplayMode, DisplayShader};
use crate::report::html::{ReportImage, ReportInput, html};
use crate::scene::{Camera, DirectMode};
use crate::session::{Command, DesignNumbers, FrameSpec, LightStatus, Session, ViewChoice};

/// Size of the report's views, pixels: wide enough for print at 180 mm, small enough that the
/// file stays a few hundred kilobytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReportOptions {
    /// Width of each view, pixels.
    pub width_px: u32,
    /// Height of each view, pixels.
    pub height_px: u32,
}

impl Default for ReportOptions {
    fn default() -> Self {
        ReportOptions {
            width_px: 1200,
            height_px: 800,
        }
    }
}

/// Renders one view of the session through `camera` in `mode` as PNG bytes.
fn view_png(
    session: &mut Session,
    camera: Camera,
    mode: DisplayMode,
    options: &ReportOptions,
) -> Result<Vec<u8>> {
    session
        .apply(Command::SetCamera(camera))
        .map_err(|e| Error::internal(format!("report: {e}")))?;
    png(
        session,
        &FrameSpec::new((options.width_px, options.height_px), mode),
    )
}

/// The plan view as PNG bytes: straight down onto the floor with a parallel projection, in false
/// colour on the scale of the perspective rendered before it, with isolux lines at round values,
/// the luminaire symbols and their aim, and the legend.
pub(crate) fn plan_image(session: &mut Session, options: &ReportOptions) -> Result<Vec<u8>> {
    let spec = FrameSpec {
        view: ViewChoice::Plan,
        isolux: true,
        ..FrameSpec::new((options.width_px, options.height_px), DisplayMode::FalseColor)
    };
    png(session, &spec)
}

/// The frame `spec` of the session as PNG bytes.
fn png(session: &mut Session, spec: &FrameSpec) -> Result<Vec<u8>> {
    session
        .render(spec)?
        .pixmap
        .encode_png()
        .map_err(|e| Error::internal(format!("report: PNG encoding failed: {e}")))
}

/// The accuracy settings of the session as (setting, value) rows.
pub(crate) fn accuracy_rows(session: &Session) -> Vec<(String, String)> {
    let scene = session.scene();
    let settings = &scene.settings;
    let mut rows = vec![
        (
            "Direct light".to_string(),
            match settings.direct {
                DirectMode::Exact => {
                    "exact at every point from each curve, with shadows of furniture".to_string()
                }
                DirectMode::Basis => {
                    "the numbers: exact at every point; the preview: from each light's SH series (paper mode)"
                        .to_string()
                }
            },
        ),
        (
            "Display patches".to_string(),
            format!("{} m ({} vertices)", settings.patch_size, scene.fine.n_vertices()),
        ),
    ];
    match (session.bake(), session.hierarchical()) {
        (Some(bake), Some(h)) => {
            let stats = h.stats().engine;
            rows.push((
                "Interreflection".to_string(),
                format!(
                    "hierarchical engine: {} leaves graded from {} patches of {} m, {} links, {} channel(s), solved to a certified relative error of {:.0e}",
                    stats.leaves,
                    stats.coarse_patches,
                    settings.solver_patch_size,
                    stats.links,
                    bake.plan.channels,
                    settings.tolerance
                ),
            ));
            let refinement = if bake.plan.refinement.is_empty() {
                "none: no lamp near a surface, no box contact".to_string()
            } else {
                bake.plan.refinement.join("; ")
            };
            rows.push(("Indirect engine refinement".to_string(), refinement));
            rows.push((
                "Indirect light at the grid points".to_string(),
                "gathered from the leaves' radiosity (clustered, with visibility)".to_string(),
            ));
        }
        (Some(bake), None) if bake.lights.iter().any(|l| l.has_indirect()) => {
            rows.push((
                "Interreflection".to_string(),
                format!(
                    "radiosity on {} patches of {} m, {} channel(s), certified relative error ≤ {:.1e} (asked {:.0e})",
                    scene.coarse.patches.len(),
                    settings.solver_patch_size,
                    bake.plan.channels,
                    bake.lights.iter().map(|l| l.certified_error).fold(0.0, f64::max),
                    settings.tolerance
                ),
            ));
            let orders: Vec<String> = session
                .lights()
                .iter()
                .zip(&bake.lights)
                .map(|(l, b)| format!("{} {}", l.name, b.plan.order))
                .collect();
            rows.push(("SH order per light".to_string(), orders.join(", ")));
            rows.push((
                "Indirect light at the grid points".to_string(),
                "gathered from the patches' radiosity (form factors with visibility)".to_string(),
            ));
        }
        (Some(_), None) => rows.push((
            "Interreflection".to_string(),
            "none: the plan found no surface that reflects".to_string(),
        )),
        (None, _) => rows.push((
            "Interreflection".to_string(),
            "not computed (direct light only)".to_string(),
        )),
    }
    rows.push((
        "Calculation grids".to_string(),
        "EN 12464-1: cell p = 0.2 × 5^log10(d), one point at the centre of each cell".to_string(),
    ));
    rows
}

/// Remarks for the end of the report: lights whose bake is pending, luminaires left out of the
/// glare rating for want of a luminous area.
fn notes(session: &Session, numbers: &DesignNumbers) -> Vec<String> {
    let mut notes = Vec::new();
    let pending: Vec<&str> = session
        .lights()
        .iter()
        .enumerate()
        .filter(|&(i, _)| session.light_status(i) == LightStatus::Updating)
        .map(|(_, l)| l.name.as_str())
        .collect();
    if !pending.is_empty() {
        notes.push(format!(
            "The indirect light of {} is that of its previous position: its new bake was still running.",
            pending.join(", ")
        ));
    }
    let mut unknown: Vec<&str> = numbers
        .observers
        .iter()
        .flat_map(|o| &o.sources)
        .filter(|s| s.status == SourceStatus::NoLuminousArea)
        .map(|s| s.name.as_str())
        .collect();
    unknown.sort_unstable();
    unknown.dedup();
    if !unknown.is_empty() {
        notes.push(format!(
            "{} left out of the glare rating: neither the photometric file nor luminous_size gives a luminous area.",
            unknown.join(", ")
        ));
    }
    notes
}

/// The report of the session's current state as one self-contained HTML document; `room_file`
/// is how the room file is named in it. The session's camera is restored afterwards.
///
/// Errors: an image size the renderer refuses (bad input), a render or encoding failure
/// (internal).
pub fn report_html(session: &mut Session, room_file: &str, options: &ReportOptions) -> Result<String> {
    let home = session.camera();
    let images = render_views(session, home, options);
    session
        .apply(Command::SetCamera(home))
        .map_err(|e| Error::internal(format!("report: {e}")))?;
    let [plan, photo, false_colour] = images?;
    let numbers = session.design_numbers();
    let legend = match session.fitted_shader(DisplayMode::FalseColor) {
        Some(DisplayShader::FalseColor(scale)) => Some(scale),
        _ => None,
    };
    let scene = session.current_scene();
    let title = scene.name.clone();
    let maintenance_factor = scene.design.maintenance_factor;
    let schedule = luminaire_schedule(scene);
    let accuracy = accuracy_rows(session);
    let mut notes = notes(session, &numbers);
    notes.push(grid_note(&numbers));
    let images = [
        ReportImage {
            caption: "Plan: new illuminance in false colour, seen from above",
            png: &plan,
        },
        ReportImage {
            caption: "Perspective: the room as lit (photographic exposure)",
            png: &photo,
        },
        ReportImage {
            caption: "Perspective: new illuminance in false colour",
            png: &false_colour,
        },
    ];
    Ok(html(&ReportInput {
        title: &title,
        room_file,
        images: &images,
        legend,
        surfaces: &numbers.surfaces,
        observers: &numbers.observers,
        schedule: &schedule,
        maintenance_factor,
        accuracy: &accuracy,
        notes: &notes,
    }))
}

/// The three views: the plan, and the perspective through `home`.
fn render_views(session: &mut Session, home: Camera, options: &ReportOptions) -> Result<[Vec<u8>; 3]> {
    // The false-colour scale is fitted at the first false-colour frame: the room's camera first,
    // so the plan and the perspective share the scale of the view the user knows.
    let false_colour = view_png(session, home, DisplayMode::FalseColor, options)?;
    let photo = view_png(session, home, DisplayMode::Photo, options)?;
    let plan = plan_image(session, options)?;
    Ok([plan, photo, false_colour])
}

/// What the grid points stand for, with each surface's point count.
fn grid_note(numbers: &DesignNumbers) -> String {
    let mut note = "Illuminance values are computed at the centres of the grid cells: ".to_string();
    let parts: Vec<String> = numbers
        .surfaces
        .iter()
        .map(|s| format!("{} {} points", s.grid.name, s.grid.receivers.len()))
        .collect();
    let _ = write!(note, "{}.", parts.join(", "));
    note
}
