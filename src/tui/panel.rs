//! The live numbers panel: per calculation surface the maintained Ē, E_min, E_max, U0 and g2
//! with a pass/fail mark against the targets, the worst UGR over the observers, and the
//! illuminance at the point under the cursor. The engine worker computes the numbers after every
//! batch of edits through the session's receiver sets (docs/ARCHITECTURE.md, "Numbers") and
//! sends them as [`PanelNumbers`]; the view draws the latest.

use glam::DVec3;
use ratatui::Frame;
use ratatui::layout::Rect;
use ratatui::style::{Color, Style, Stylize};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Paragraph};

use crate::metrics::{Check, SurfaceCheck, SurfaceStats, UgrStatus};
use crate::session::DesignNumbers;

/// Rows of the panel (borders included) in a terminal lower than [`TALL_TERMINAL_ROWS`].
pub const PANEL_ROWS: u16 = 7;
/// Rows of the panel in a tall terminal.
pub const TALL_PANEL_ROWS: u16 = 12;
/// From this many terminal rows on the panel is [`TALL_PANEL_ROWS`] high.
pub const TALL_TERMINAL_ROWS: u16 = 40;

/// Colour of a met target.
pub const PASS_COLOR: Color = Color::Green;
/// Colour of a missed target.
pub const FAIL_COLOR: Color = Color::LightRed;

/// One calculation surface's numbers.
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceRow {
    /// The surface's name.
    pub name: String,
    /// Maintained statistics (`None` when furniture covers every point).
    pub stats: Option<SurfaceStats>,
    /// The statistics against the targets.
    pub check: Option<SurfaceCheck>,
    /// Every target met (`None` without targets).
    pub pass: Option<bool>,
}

/// One observer's glare rating.
#[derive(Debug, Clone, PartialEq)]
pub struct ObserverRow {
    /// The observer's name.
    pub name: String,
    /// The UGR, when defined.
    pub ugr: Option<f64>,
    /// Why there is or is not a value.
    pub status: UgrStatus,
    /// The limit it is judged by.
    pub limit: Option<f64>,
    /// `ugr ≤ limit`.
    pub pass: Option<bool>,
}

/// What the panel shows, as the engine last computed it.
#[derive(Debug, Clone, PartialEq)]
pub struct PanelNumbers {
    /// The room's maintenance factor.
    pub maintenance_factor: f64,
    /// The calculation surfaces, in file order.
    pub surfaces: Vec<SurfaceRow>,
    /// The glare observers, in file order.
    pub observers: Vec<ObserverRow>,
    /// The point under the cursor (world, m) and its new illuminance (lx), once something was
    /// picked.
    pub cursor: Option<(DVec3, f64)>,
    /// Time the engine took to compute these numbers, ms.
    pub compute_ms: f64,
}

impl PanelNumbers {
    /// The panel's numbers from the session's design numbers.
    pub fn of(
        numbers: &DesignNumbers,
        maintenance_factor: f64,
        cursor: Option<(DVec3, f64)>,
        compute_ms: f64,
    ) -> Self {
        PanelNumbers {
            maintenance_factor,
            surfaces: numbers
                .surfaces
                .iter()
                .map(|s| SurfaceRow {
                    name: s.grid.name.clone(),
                    stats: s.stats,
                    check: s.check,
                    pass: s.check.and_then(|c| c.pass()),
                })
                .collect(),
            observers: numbers
                .observers
                .iter()
                .map(|o| ObserverRow {
                    name: o.name.clone(),
                    ugr: o.ugr,
                    status: o.status,
                    limit: o.limit,
                    pass: o.pass,
                })
                .collect(),
            cursor,
            compute_ms,
        }
    }

    /// The observer with the highest UGR (the first undefined one when none is rated).
    pub fn worst_observer(&self) -> Option<&ObserverRow> {
        self.observers
            .iter()
            .filter(|o| o.ugr.is_some())
            .max_by(|a, b| a.ugr.partial_cmp(&b.ugr).unwrap_or(std::cmp::Ordering::Equal))
            .or_else(|| self.observers.first())
    }
}

/// The panel's height for a terminal of `rows` rows.
pub fn panel_rows(rows: u16) -> u16 {
    if rows >= TALL_TERMINAL_ROWS {
        TALL_PANEL_ROWS
    } else {
        PANEL_ROWS
    }
}

/// The mark after a judged value: `✓`, `✗`, or a space without a target.
fn mark(pass: Option<bool>) -> Span<'static> {
    match pass {
        Some(true) => Span::styled("✓", Style::new().fg(PASS_COLOR)),
        Some(false) => Span::styled("✗", Style::new().fg(FAIL_COLOR).bold()),
        None => Span::from(" "),
    }
}

/// A judged value right-aligned in `width` columns, then its mark.
fn judged(check: &Check, digits: usize, width: usize) -> [Span<'static>; 2] {
    [
        Span::from(format!(" {:>width$.digits$}", check.value)),
        mark(check.pass),
    ]
}

/// Columns of the fixed part of a surface row: ` Ē✓ min max U0✓ g2✓`.
const FIXED_COLUMNS: usize = 30;
/// From this inner width on, a row also shows the targets.
const TARGETS_FROM_WIDTH: usize = 52;

fn targets_text(check: &SurfaceCheck) -> String {
    let mut parts = Vec::new();
    if let Some(t) = check.e_avg.target {
        parts.push(format!("≥{t:.0}"));
    }
    if let Some(t) = check.u0.target {
        parts.push(format!("U0≥{t:.2}"));
    }
    if let Some(t) = check.g2.target {
        parts.push(format!("g2≥{t:.2}"));
    }
    parts.join(" ")
}

fn surface_line(row: &SurfaceRow, name_width: usize, with_targets: bool) -> Line<'static> {
    let name: String = row.name.chars().take(name_width).collect();
    let mut spans = vec![Span::from(format!("{name:<name_width$}"))];
    match (row.stats, row.check) {
        (Some(stats), Some(check)) => {
            spans.extend(judged(&check.e_avg, 0, 4));
            spans.push(Span::from(format!(" {:>5.0} {:>5.0}", stats.e_min, stats.e_max)));
            spans.extend(judged(&check.u0, 2, 4));
            spans.extend(judged(&check.g2, 2, 4));
            if with_targets {
                spans.push(Span::from(format!("  {}", targets_text(&check))).dim());
            }
        }
        _ => spans.push(Span::from(" under furniture").dim()),
    }
    Line::from(spans)
}

fn glare_line(numbers: &PanelNumbers) -> Line<'static> {
    let Some(worst) = numbers.worst_observer() else {
        return Line::from("UGR: no observers").dim();
    };
    let value = match (worst.status, worst.ugr) {
        (UgrStatus::Rated, Some(u)) => format!("{u:.1}"),
        (UgrStatus::NoBackground, _) => "undefined (no reflected light)".to_string(),
        _ => "no glare source".to_string(),
    };
    let mut spans = vec![Span::from("UGR max ").dim(), Span::from(value)];
    if let Some(limit) = worst.limit {
        spans.push(Span::from(format!(" ≤{limit:.0}")));
        spans.push(mark(worst.pass));
    }
    spans.push(Span::from(format!("  {}", worst.name)).dim());
    Line::from(spans)
}

fn cursor_line(numbers: &PanelNumbers) -> Line<'static> {
    match numbers.cursor {
        Some((p, lux)) => Line::from(vec![
            Span::from("cursor ").dim(),
            Span::from(format!("{lux:.0} lx")).bold(),
            Span::from(format!(" at {:.2} {:.2} {:.2} m", p.x, p.y, p.z)).dim(),
        ]),
        None => Line::from("cursor: aim mode (a) or a click picks a point").dim(),
    }
}

/// The panel's text lines for an inner area of `width × height` cells.
pub fn panel_lines(numbers: &PanelNumbers, width: u16, height: u16) -> Vec<Line<'static>> {
    let width = usize::from(width);
    let name_width = width.saturating_sub(FIXED_COLUMNS).max(4);
    let with_targets = width >= TARGETS_FROM_WIDTH;
    let name_width = if with_targets {
        name_width.min(16)
    } else {
        name_width
    };
    let mut lines = vec![
        Line::from(format!(
            "{:<name_width$} {:>4}  {:>5} {:>5} {:>4}  {:>4} ",
            "surface", "Ē lx", "min", "max", "U0", "g2"
        ))
        .dim(),
    ];
    // Header, glare and cursor lines take three rows; the surfaces get the rest.
    let room = usize::from(height).saturating_sub(3).max(1);
    let shown = if numbers.surfaces.len() > room {
        room - 1
    } else {
        numbers.surfaces.len()
    };
    lines.extend(
        numbers.surfaces[..shown]
            .iter()
            .map(|row| surface_line(row, name_width, with_targets)),
    );
    if shown < numbers.surfaces.len() {
        let rest = &numbers.surfaces[shown..];
        let failing = rest.iter().filter(|r| r.pass == Some(false)).count();
        lines.push(Line::from(format!("+{} more surfaces, {failing} failing", rest.len())).dim());
    }
    lines.push(glare_line(numbers));
    lines.push(cursor_line(numbers));
    lines
}

/// Draws the panel into `area`: the numbers, or a note while they are being computed.
pub fn draw_panel(numbers: Option<&PanelNumbers>, frame: &mut Frame<'_>, area: Rect) {
    let title = match numbers {
        Some(n) => format!(
            " numbers · maintained (MF {:.2}) · {:.1} ms ",
            n.maintenance_factor, n.compute_ms
        ),
        None => " numbers ".to_string(),
    };
    let block = Block::bordered().title(title);
    let inner = block.inner(area);
    let lines = match numbers {
        Some(n) => panel_lines(n, inner.width, inner.height),
        None => vec![Line::from("computing…").dim()],
    };
    frame.render_widget(Paragraph::new(lines).block(block), area);
}
