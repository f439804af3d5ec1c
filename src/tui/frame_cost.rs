//! What the editor's preview frames cost on the wire, without a terminal (`haiko render
//! --terminal`, docs/DECISIONS.md "Terminal graphics"): the room rendered for the preview of a
//! terminal of given cells and font, one full frame and one interactive frame encoded as the
//! editor would send them, with their bytes and encode times.
//!
//! The frames follow the editor's [`FrameBudget`]: the interactive frame is the finest
//! reduction that fits the budget, learned from the frames encoded before it exactly as the
//! editor learns from the frames it sends; the full frame is the one the editor settles on once
//! idle (sixel dithered when that fits [`crate::tui::frame_budget::FULL_TARGET`], else flat).

use std::time::Instant;

use ratatui::layout::{Rect, Size};

use crate::error::{Error, Result};
use crate::scene::Scene;
use crate::session::Session;
use crate::tui::Model;
use crate::tui::app::frame_spec;
use crate::tui::frame_budget::{Budget, FrameBudget, FramePlan, prior_bytes_per_pixel};
use crate::tui::multiplexer::Protocol;
use crate::tui::preview::{self, HALFBLOCK_CELL_PX, ImageSetup};

/// Input idle while keys repeat: what the editor sees between two key repeats.
const TYPING: std::time::Duration = std::time::Duration::from_millis(30);

/// One encoded frame.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameCost {
    /// What it was rendered for.
    pub plan: FramePlan,
    /// The rendered size, px (width, height).
    pub size_px: (u32, u32),
    /// The bytes the terminal receives ([`preview::frame_sequence`]).
    pub bytes: Vec<u8>,
    /// Encoding time (protocol only, not rendering), ms.
    pub encode_ms: f64,
}

/// The preview's frames for one terminal.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameCosts {
    /// The preview pane's inside, cells.
    pub preview_cells: Size,
    /// The full frame's size, px.
    pub full_px: (u32, u32),
    /// The interactive frame's byte budget.
    pub budget: usize,
    /// The full frame sent once input is idle.
    pub full: FrameCost,
    /// The frame sent while keys repeat.
    pub interactive: FrameCost,
}

/// The preview pane's inside (cells) in a terminal of `cells` (columns, rows).
///
/// Errors (bad input, naming `--cells`): the terminal is below the editor's minimum.
pub fn preview_cells(cells: (u16, u16)) -> Result<Size> {
    let area = crate::tui::view::preview_rect(Rect::new(0, 0, cells.0, cells.1));
    if area.is_empty() {
        let (w, h) = crate::tui::view::MIN_SIZE;
        return Err(Error::input(
            "--cells",
            "",
            format!(
                "{}x{} cells leave no room for the preview: the editor needs at least {w}x{h}",
                cells.0, cells.1
            ),
        ));
    }
    Ok(Size::new(area.width, area.height))
}

/// The frames of `scene`'s preview (the session already baked and relit) in a terminal of
/// `cells` (columns, rows) with a `font` (width, height px) cell, for `protocol` and an
/// interactive budget of `budget` bytes.
///
/// Errors: the terminal is below the editor's minimum (bad input, naming `--cells`), rendering
/// or encoding failed (internal).
pub fn measure(
    session: &mut Session,
    scene: &Scene,
    protocol: Protocol,
    cells: (u16, u16),
    font: (u16, u16),
    budget: usize,
) -> Result<FrameCosts> {
    let setup = ImageSetup {
        protocol,
        passthrough: false,
        cell_px: if protocol == Protocol::Halfblocks {
            HALFBLOCK_CELL_PX
        } else {
            font
        },
        hint: None,
    };
    let preview_cells = preview_cells(cells)?;
    let area = Rect::new(0, 0, preview_cells.width, preview_cells.height);
    let model = Model::new(scene, cells, setup.cell_px);
    let full_spec = frame_spec(&model).ok_or_else(|| Error::internal("the preview has no pixels"))?;
    let full_px = full_spec.size_px;
    let mut encode = |plan: FramePlan| -> Result<FrameCost> {
        let spec = crate::session::FrameSpec {
            size_px: plan.size(full_px),
            ..full_spec
        };
        let frame = session.render(&spec)?;
        let start = Instant::now();
        let image = preview::encode_frame(&setup, frame.pixmap.data(), spec.size_px, plan, preview_cells)?;
        let encode_ms = start.elapsed().as_secs_f64() * 1e3;
        let bytes = preview::frame_sequence(&image, Rect::new(0, 0, area.width, area.height))?;
        Ok(FrameCost {
            plan,
            size_px: spec.size_px,
            bytes,
            encode_ms,
        })
    };
    let mut policy = FrameBudget::new(Budget::Bytes(budget), prior_bytes_per_pixel(true));
    let record = |policy: &mut FrameBudget, frame: &FrameCost| {
        policy.record(frame.plan, full_px, frame.bytes.len(), std::time::Duration::ZERO);
    };
    // The first full frame (dithered), then the one the editor settles on: flat when the
    // dithered one is over the target.
    let idle = std::time::Duration::from_secs(1);
    let mut full = encode(policy.plan(idle, full_px))?;
    record(&mut policy, &full);
    if policy.plan(idle, full_px) != full.plan {
        full = encode(policy.plan(idle, full_px))?;
        record(&mut policy, &full);
    }
    // Interactive frames until the plan settles (at most one try per divisor).
    let mut interactive = encode(policy.plan(TYPING, full_px))?;
    for _ in 0..crate::tui::frame_budget::DIVISORS.len() {
        record(&mut policy, &interactive);
        let next = policy.plan(TYPING, full_px);
        if next == interactive.plan {
            break;
        }
        interactive = encode(next)?;
    }
    Ok(FrameCosts {
        preview_cells,
        full_px,
        budget,
        full,
        interactive,
    })
}
