//! The photometric polar diagram of one light: the C0–C180 plane with γ = 0° pointing down
//! (the nadir of a downlight), γ drawn on both sides mirrored, intensity (cd) as the radius.
//! A ratatui `Canvas`: rings labelled in cd, spokes every 30° labelled with their angle, the
//! control-point curve, the truncated series the light really emits, the control points (the
//! selected one marked) and the current peak.
//!
//! The scale is a round number of candela ([`PolarScale`]) that grows as soon as the peak
//! passes it and shrinks only when the peak falls below [`SHRINK_BELOW`] of it, so editing a
//! curve does not make the drawing jump. Circles stay round whatever the style: a terminal cell
//! is taken as twice as tall as wide.
//!
//! Three drawing styles ([`PolarStyle`], docs/DECISIONS.md "Terminal"): Braille dots (2 × 4 per
//! cell, the finest), blocks (quadrant block elements, 2 × 2 per cell, for fonts without
//! Braille) and ASCII (`'`, `.` and `:`, 1 × 2 per cell, for any font).

use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::{Color, Style};
use ratatui::symbols::Marker;
use ratatui::text::{Line as TextLine, Span};
use ratatui::widgets::canvas::{Canvas, Circle, Context, Line};
use ratatui::widgets::{Block, Widget};

use crate::photometry::Curve;

/// Colour of the control-point curve.
pub const CURVE_COLOR: Color = Color::Cyan;
/// Colour of the truncated-series curve.
pub const SERIES_COLOR: Color = Color::Yellow;
/// Colour of the rings and axes.
pub const GRID_COLOR: Color = Color::DarkGray;
/// Colour of the selected control point.
pub const SELECTED_COLOR: Color = Color::LightRed;
/// Colour of the ring and angle labels.
pub const LABEL_COLOR: Color = Color::Gray;
/// Colour of the C-plane spread (lowest and highest plane) of an asymmetric file.
pub const SPREAD_COLOR: Color = Color::Magenta;

/// Largest γ step (degrees) between two drawn samples of the control-point curve.
const SAMPLE_STEP_DEG: f64 = 1.0;
/// Angle between two labelled spokes, degrees.
pub const SPOKE_STEP_DEG: u32 = 30;
/// The scale shrinks only once the peak is below this fraction of it.
pub const SHRINK_BELOW: f64 = 0.45;
/// The round full-scale values within a decade (× 10ⁿ cd).
const ROUND_SCALES: [f64; 9] = [1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0];
/// The environment variable choosing the polar diagram's style.
pub const STYLE_ENV: &str = "HAIKO_POLAR";

/// How the diagram's lines are drawn.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum PolarStyle {
    /// Braille dots, 2 × 4 per cell.
    #[default]
    Braille,
    /// Quadrant block elements, 2 × 2 per cell.
    Blocks,
    /// ASCII `'`, `.`, `:`, 1 × 2 per cell.
    Ascii,
}

impl PolarStyle {
    /// The style named `name` (`braille`, `blocks`, `ascii`).
    pub fn from_name(name: &str) -> Option<PolarStyle> {
        match name.trim().to_ascii_lowercase().as_str() {
            "braille" => Some(PolarStyle::Braille),
            "blocks" | "block" => Some(PolarStyle::Blocks),
            "ascii" => Some(PolarStyle::Ascii),
            _ => None,
        }
    }

    /// The style for this terminal (`env` reads a variable): [`STYLE_ENV`] when it names one;
    /// otherwise ASCII on the Linux console (`TERM=linux`: its fonts have neither Braille nor
    /// quadrants), blocks in mlterm (`MLTERM` set or `TERM=mlterm*`: it draws no Braille unless
    /// its own font has them, and does not fall back to another font), Braille elsewhere.
    pub fn detect(env: impl Fn(&str) -> Option<String>) -> PolarStyle {
        if let Some(style) = env(STYLE_ENV).as_deref().and_then(PolarStyle::from_name) {
            return style;
        }
        let term = env("TERM").unwrap_or_default();
        if term == "linux" {
            PolarStyle::Ascii
        } else if term.starts_with("mlterm") || env("MLTERM").is_some_and(|v| !v.is_empty()) {
            PolarStyle::Blocks
        } else {
            PolarStyle::Braille
        }
    }

    fn marker(self) -> Marker {
        match self {
            PolarStyle::Braille => Marker::Braille,
            PolarStyle::Blocks => Marker::Quadrant,
            PolarStyle::Ascii => Marker::HalfBlock,
        }
    }

    /// The control point marks: (selected, other).
    fn point_marks(self) -> (&'static str, &'static str) {
        match self {
            PolarStyle::Ascii => ("@", "o"),
            PolarStyle::Braille | PolarStyle::Blocks => ("◆", "•"),
        }
    }
}

/// The diagram's full scale: the outer ring, a round number of candela.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PolarScale {
    /// The outer ring's intensity, cd.
    pub full_cd: f64,
}

impl PolarScale {
    /// The smallest round scale (1, 1.5, 2, 2.5, 3, 4, 5, 6 or 8 × 10ⁿ cd) at or above
    /// `peak_cd`; 1 cd for no light.
    pub fn fitting(peak_cd: f64) -> PolarScale {
        if !peak_cd.is_finite() || peak_cd <= 0.0 {
            return PolarScale { full_cd: 1.0 };
        }
        let decade = 10f64.powf(peak_cd.log10().floor());
        let full_cd = ROUND_SCALES
            .iter()
            .chain(&[10.0])
            .map(|m| m * decade)
            .find(|&s| s >= peak_cd * (1.0 - 1e-12))
            .unwrap_or(10.0 * decade);
        PolarScale { full_cd }
    }

    /// The scale after the peak became `peak_cd`: unchanged while the peak fits and is at
    /// least [`SHRINK_BELOW`] of it, else the fitting one.
    pub fn follow(self, peak_cd: f64) -> PolarScale {
        if peak_cd > self.full_cd || peak_cd < SHRINK_BELOW * self.full_cd {
            PolarScale::fitting(peak_cd)
        } else {
            self
        }
    }

    /// The rings, cd: every multiple of [`ring_step_cd`] below the full scale, then the full
    /// scale itself.
    pub fn rings(self) -> Vec<f64> {
        let step = ring_step_cd(self.full_cd);
        let mut rings: Vec<f64> = (1..)
            .map(|k| f64::from(k) * step)
            .take_while(|&r| r < self.full_cd * (1.0 - 1e-9))
            .collect();
        rings.push(self.full_cd);
        rings
    }
}

/// Drawing options of [`PolarDiagram::render_with`].
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PolarOptions {
    /// How lines are drawn.
    pub style: PolarStyle,
    /// The scale; `None`: the one fitting the peak.
    pub scale: Option<PolarScale>,
}

/// The polar diagram widget.
#[derive(Debug, Clone)]
pub struct PolarDiagram<'a> {
    /// The control-point curve (cd over γ in degrees).
    pub curve: &'a Curve,
    /// The truncated series as samples `(γ rad, cd)` over 0..=π, if known.
    pub series: Option<&'a [(f64, f64)]>,
    /// The spread of an asymmetric file's C-planes around their average, as
    /// `(γ rad, lowest cd, highest cd)`: drawn as two thin curves.
    pub spread: Option<&'a [(f64, f64, f64)]>,
    /// Index of the selected control point.
    pub selected: usize,
    /// The surrounding block.
    pub block: Block<'a>,
}

/// A 1-2-5 ring spacing (cd) giving two to five rings up to `max_cd`.
pub fn ring_step_cd(max_cd: f64) -> f64 {
    if max_cd.is_nan() || max_cd <= 0.0 {
        return 1.0;
    }
    let rough = max_cd / 3.0;
    let decade = 10f64.powf(rough.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * decade)
        .find(|&step| step >= rough)
        .unwrap_or(10.0 * decade)
}

/// A point of the diagram for intensity `cd` at `gamma_rad` on the right (C0) side, or the
/// mirrored left (C180) side: γ = 0 points down, so `(± I sin γ, −I cos γ)`.
pub fn polar_xy(gamma_rad: f64, cd: f64, left: bool) -> (f64, f64) {
    let x = cd * gamma_rad.sin();
    (if left { -x } else { x }, -cd * gamma_rad.cos())
}

/// The control-point curve as `(γ rad, cd)` samples: every point (both of a step) plus samples
/// at most [`SAMPLE_STEP_DEG`] apart, closed to 0 cd where the curve ends inside 0°..180°.
pub fn curve_samples(curve: &Curve) -> Vec<(f64, f64)> {
    let points: Vec<(f64, f64)> = curve.points().collect();
    let mut samples = Vec::new();
    if points[0].0 > 0.0 {
        samples.push((points[0].0.to_radians(), 0.0));
    }
    for pair in points.windows(2) {
        let ((g0, i0), (g1, i1)) = (pair[0], pair[1]);
        let steps = ((g1 - g0) / SAMPLE_STEP_DEG).ceil().max(1.0) as usize;
        for s in 0..steps {
            let t = s as f64 / steps as f64;
            samples.push(((g0 + t * (g1 - g0)).to_radians(), i0 + t * (i1 - i0)));
        }
    }
    let (g_last, i_last) = points[points.len() - 1];
    samples.push((g_last.to_radians(), i_last));
    if g_last < 180.0 {
        samples.push((g_last.to_radians(), 0.0));
    }
    samples
}

/// A number of candela as a label: whole numbers without decimals (`1500`), others with the
/// fewest that show them (`0.5`, `2.5`).
pub fn cd_label(cd: f64) -> String {
    if (cd - cd.round()).abs() < 1e-9 {
        format!("{}", cd.round())
    } else {
        let text = format!("{cd:.3}");
        text.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

fn draw_polyline(ctx: &mut Context<'_>, samples: &[(f64, f64)], color: Color) {
    for left in [false, true] {
        for pair in samples.windows(2) {
            let (x1, y1) = polar_xy(pair[0].0, pair[0].1.max(0.0), left);
            let (x2, y2) = polar_xy(pair[1].0, pair[1].1.max(0.0), left);
            if [x1, y1, x2, y2].iter().all(|v| v.is_finite()) {
                ctx.draw(&Line::new(x1, y1, x2, y2, color));
            }
        }
    }
}

/// The canvas's mapping between its coordinates (cd) and the cells of its area, as ratatui
/// places labels: column `⌊(x − left) · (columns − 1) / width⌋`.
#[derive(Debug, Clone, Copy)]
struct Cells {
    half_x: f64,
    half_y: f64,
    columns: u16,
    rows: u16,
}

impl Cells {
    /// The cell (column, row) of canvas point `(x, y)`.
    fn of(self, x: f64, y: f64) -> (i32, i32) {
        let column = (x + self.half_x) * f64::from(self.columns.saturating_sub(1)) / (2.0 * self.half_x);
        let row = (self.half_y - y) * f64::from(self.rows.saturating_sub(1)) / (2.0 * self.half_y);
        (column.floor() as i32, row.floor() as i32)
    }

    /// A canvas point inside cell (column, row).
    fn point(self, column: i32, row: i32) -> (f64, f64) {
        let x =
            (f64::from(column) + 0.5) * 2.0 * self.half_x / f64::from(self.columns.saturating_sub(1).max(1));
        let y = (f64::from(row) + 0.5) * 2.0 * self.half_y / f64::from(self.rows.saturating_sub(1).max(1));
        (x - self.half_x, self.half_y - y)
    }
}

/// Labels placed without overlapping: each keeps its cells and one free column either side,
/// and a label that would touch an earlier one, or leave the area, is dropped.
struct Labels {
    cells: Cells,
    placed: Vec<(i32, i32, i32)>,
    lines: Vec<(f64, f64, Span<'static>)>,
}

impl Labels {
    fn new(cells: Cells) -> Labels {
        Labels {
            cells,
            placed: Vec::new(),
            lines: Vec::new(),
        }
    }

    /// Places `text` at the cell of `(x, y)` with its start (`align` 0), middle (½) or end (1)
    /// there.
    fn add(&mut self, (x, y): (f64, f64), align: f64, text: String, style: Style) {
        let (column, row) = self.cells.of(x, y);
        let width = text.chars().count() as i32;
        let start = column - (align * f64::from(width - 1)).round() as i32;
        let end = start + width;
        let outside =
            start < 0 || end > i32::from(self.cells.columns) || row < 0 || row >= i32::from(self.cells.rows);
        let touches = self
            .placed
            .iter()
            .any(|&(r, s, e)| r == row && start <= e && s <= end);
        if outside || touches {
            return;
        }
        self.placed.push((row, start, end));
        let (px, py) = self.cells.point(start, row);
        self.lines.push((px, py, Span::styled(text, style)));
    }

    fn print(self, ctx: &mut Context<'_>) {
        for (x, y, span) in self.lines {
            ctx.print(x, y, span);
        }
    }
}

impl PolarDiagram<'_> {
    /// Largest radius to show (cd): the curve's or the series' peak.
    pub fn peak_cd(&self) -> f64 {
        let series_max = self
            .series
            .map(|s| {
                s.iter()
                    .map(|p| p.1)
                    .filter(|cd| cd.is_finite())
                    .fold(0.0, f64::max)
            })
            .unwrap_or(0.0);
        let spread_max = self
            .spread
            .map(|s| {
                s.iter()
                    .map(|p| p.2)
                    .filter(|cd| cd.is_finite())
                    .fold(0.0, f64::max)
            })
            .unwrap_or(0.0);
        self.curve.peak_cd().max(series_max).max(spread_max)
    }

    /// Draws the diagram in `area` with `options`.
    pub fn render_with(self, options: PolarOptions, area: Rect, buf: &mut Buffer) {
        let inner = self.block.inner(area);
        let peak = self.peak_cd();
        let scale = options.scale.unwrap_or_else(|| PolarScale::fitting(peak));
        let full = scale.full_cd;
        // Room for the angle labels: four columns each side, a row above and below.
        let labelled = inner.width >= 24 && inner.height >= 10;
        let (margin_x, margin_y) = if labelled { (4.0, 1.0) } else { (0.0, 0.0) };
        let (columns, rows) = (f64::from(inner.width.max(1)), f64::from(inner.height.max(1)));
        // A cell is twice as tall as wide: cd per column, and twice that per row.
        let cd_per_column =
            (2.0 * full / (columns - 2.0 * margin_x).max(1.0)).max(full / (rows - 2.0 * margin_y).max(1.0));
        let cells = Cells {
            half_x: cd_per_column * columns / 2.0,
            half_y: cd_per_column * rows,
            columns: inner.width,
            rows: inner.height,
        };
        let curve_samples = curve_samples(self.curve);
        let points: Vec<(f64, f64)> = self.curve.points().collect();
        let rings = scale.rings();
        let (selected_mark, point_mark) = options.style.point_marks();
        let label_style = Style::new().fg(LABEL_COLOR);
        Canvas::default()
            .block(self.block)
            .marker(options.style.marker())
            .x_bounds([-cells.half_x, cells.half_x])
            .y_bounds([-cells.half_y, cells.half_y])
            .paint(|ctx| {
                for &r in &rings {
                    ctx.draw(&Circle::new(0.0, 0.0, r, GRID_COLOR));
                }
                for k in 0..=180 / SPOKE_STEP_DEG {
                    let gamma = f64::from(k * SPOKE_STEP_DEG).to_radians();
                    for left in [false, true] {
                        let (x, y) = polar_xy(gamma, full, left);
                        ctx.draw(&Line::new(0.0, 0.0, x, y, GRID_COLOR));
                    }
                }
                ctx.layer();
                if let Some(spread) = self.spread {
                    for bound in [spread_bound(spread, false), spread_bound(spread, true)] {
                        draw_polyline(ctx, &bound, SPREAD_COLOR);
                    }
                    ctx.layer();
                }
                if let Some(series) = self.series {
                    draw_polyline(ctx, series, SERIES_COLOR);
                    ctx.layer();
                }
                draw_polyline(ctx, &curve_samples, CURVE_COLOR);
                ctx.layer();
                let mut labels = Labels::new(cells);
                let corner = cells.point(0, 0);
                labels.add(
                    corner,
                    0.0,
                    format!("peak {} cd", cd_label(peak.round())),
                    Style::new().fg(CURVE_COLOR),
                );
                for &r in rings.iter().rev() {
                    labels.add((0.0, r), 0.0, cd_label(r), label_style);
                }
                if labelled {
                    for k in 0..=180 / SPOKE_STEP_DEG {
                        let degrees = k * SPOKE_STEP_DEG;
                        let gamma = f64::from(degrees).to_radians();
                        for left in [false, true] {
                            if left && (degrees == 0 || degrees == 180) {
                                continue;
                            }
                            // One cell outside the outer ring along the spoke.
                            let (x, y) = polar_xy(gamma, full, left);
                            let (ux, uy) = polar_xy(gamma, 1.0, left);
                            let at = (x + ux * 1.5 * cd_per_column, y + uy * 3.0 * cd_per_column);
                            let align = if ux > 0.3 {
                                0.0
                            } else if ux < -0.3 {
                                1.0
                            } else {
                                0.5
                            };
                            labels.add(at, align, format!("{degrees}°"), label_style);
                        }
                    }
                }
                labels.print(ctx);
                for (k, &(gamma_deg, cd)) in points.iter().enumerate() {
                    let (x, y) = polar_xy(gamma_deg.to_radians(), cd, false);
                    if k == self.selected {
                        ctx.print(
                            x,
                            y,
                            Span::styled(selected_mark, Style::new().fg(SELECTED_COLOR).bold()),
                        );
                    } else {
                        ctx.print(x, y, Span::styled(point_mark, Style::new().fg(Color::White)));
                    }
                }
            })
            .render(area, buf);
        if options.style == PolarStyle::Ascii {
            to_ascii(inner, buf);
        }
    }
}

/// One side of a C-plane spread as `(γ rad, cd)` samples: the lowest (`high` false) or highest
/// plane at each point.
pub fn spread_bound(spread: &[(f64, f64, f64)], high: bool) -> Vec<(f64, f64)> {
    spread
        .iter()
        .map(|&(gamma, lo, hi)| (gamma, if high { hi } else { lo }))
        .collect()
}

impl Widget for PolarDiagram<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        self.render_with(PolarOptions::default(), area, buf);
    }
}

/// Replaces the half-block dots in `area` by ASCII: upper `'`, lower `.`, both `:` (in the
/// upper half's colour when the halves differ).
fn to_ascii(area: Rect, buf: &mut Buffer) {
    for y in area.top()..area.bottom() {
        for x in area.left()..area.right() {
            let cell = &mut buf[(x, y)];
            let symbol = match cell.symbol() {
                "▀" if cell.bg != Color::Reset => ":",
                "▀" => "'",
                "▄" => ".",
                "█" => ":",
                _ => continue,
            };
            cell.set_symbol(symbol).set_bg(Color::Reset);
        }
    }
}

/// The legend line for `style`: which colour is which curve.
pub fn legend_for(order: usize, style: PolarStyle) -> TextLine<'static> {
    let (line, selected) = match style {
        PolarStyle::Ascii => ("--", "@"),
        PolarStyle::Braille | PolarStyle::Blocks => ("━", "◆"),
    };
    TextLine::from(vec![
        Span::styled(format!("{line} curve "), Style::new().fg(CURVE_COLOR)),
        Span::styled(format!("{line} series N={order} "), Style::new().fg(SERIES_COLOR)),
        Span::styled(format!("{selected} selected"), Style::new().fg(SELECTED_COLOR)),
    ])
}

#[cfg(test)]
mod tests {
    use insta::assert_snapshot;
    use ratatui::Terminal;
    use ratatui::backend::TestBackend;

    use super::*;

    /// A downlight: 1000 cd at the nadir falling to 0 at 90°.
    fn downlight() -> Curve {
        Curve::new(&[(0.0, 1000.0), (30.0, 950.0), (60.0, 700.0), (90.0, 0.0)]).unwrap()
    }

    fn draw(curve: &Curve, options: PolarOptions, width: u16, height: u16) -> Terminal<TestBackend> {
        let mut terminal = Terminal::new(TestBackend::new(width, height)).unwrap();
        terminal
            .draw(|frame| {
                PolarDiagram {
                    curve,
                    series: None,
                    spread: None,
                    selected: 1,
                    block: Block::bordered().title_bottom(legend_for(5, options.style)),
                }
                .render_with(options, frame.area(), frame.buffer_mut())
            })
            .unwrap();
        terminal
    }

    fn text(terminal: &Terminal<TestBackend>) -> String {
        terminal
            .backend()
            .buffer()
            .content()
            .iter()
            .map(|c| c.symbol())
            .collect()
    }

    #[test]
    fn scales_are_round_and_fit_the_peak() {
        let full = |peak| PolarScale::fitting(peak).full_cd;
        assert_eq!(full(1000.0), 1000.0);
        assert_eq!(full(1001.0), 1500.0);
        assert_eq!(full(2100.0), 2500.0);
        assert_eq!(full(7.2), 8.0);
        assert_eq!(full(8.5), 10.0);
        assert_eq!(full(0.31), 0.4);
        assert_eq!(full(0.0), 1.0);
        assert_eq!(full(f64::NAN), 1.0);
    }

    #[test]
    fn the_scale_changes_only_when_the_peak_leaves_it() {
        let scale = PolarScale::fitting(900.0);
        assert_eq!(scale.full_cd, 1000.0);
        // Raising the curve within the scale, or lowering it a lot, keeps it.
        assert_eq!(scale.follow(1000.0), scale);
        assert_eq!(scale.follow(460.0), scale);
        // Above it: the next round scale; far below it: the fitting one.
        assert_eq!(scale.follow(1010.0).full_cd, 1500.0);
        assert_eq!(scale.follow(440.0).full_cd, 500.0);
        // No flip-flop: after growing to 1500, going back to 1000 keeps 1500.
        assert_eq!(scale.follow(1010.0).follow(1000.0).full_cd, 1500.0);
    }

    #[test]
    fn rings_are_round_steps_up_to_the_full_scale() {
        assert_eq!(PolarScale { full_cd: 1000.0 }.rings(), vec![500.0, 1000.0]);
        assert_eq!(
            PolarScale { full_cd: 1500.0 }.rings(),
            vec![500.0, 1000.0, 1500.0]
        );
        assert_eq!(
            PolarScale { full_cd: 2500.0 }.rings(),
            vec![1000.0, 2000.0, 2500.0]
        );
        assert_eq!(PolarScale { full_cd: 0.4 }.rings(), vec![0.2, 0.4]);
        assert_eq!(cd_label(0.2), "0.2");
        assert_eq!(cd_label(2500.0), "2500");
        assert_eq!(cd_label(0.15), "0.15");
    }

    #[test]
    fn styles_come_from_the_environment() {
        let env = |pairs: &'static [(&'static str, &'static str)]| {
            move |name: &str| pairs.iter().find(|p| p.0 == name).map(|p| p.1.to_string())
        };
        assert_eq!(
            PolarStyle::detect(env(&[("TERM", "xterm-256color")])),
            PolarStyle::Braille
        );
        assert_eq!(PolarStyle::detect(env(&[("TERM", "mlterm")])), PolarStyle::Blocks);
        assert_eq!(
            PolarStyle::detect(env(&[("TERM", "xterm"), ("MLTERM", "3.9.0")])),
            PolarStyle::Blocks
        );
        assert_eq!(PolarStyle::detect(env(&[("TERM", "linux")])), PolarStyle::Ascii);
        assert_eq!(
            PolarStyle::detect(env(&[("TERM", "mlterm"), ("HAIKO_POLAR", "braille")])),
            PolarStyle::Braille
        );
        assert_eq!(
            PolarStyle::detect(env(&[("HAIKO_POLAR", "ASCII")])),
            PolarStyle::Ascii
        );
        // An unknown value is ignored.
        assert_eq!(
            PolarStyle::detect(env(&[("TERM", "linux"), ("HAIKO_POLAR", "x")])),
            PolarStyle::Ascii
        );
        assert_eq!(PolarStyle::from_name("blocks"), Some(PolarStyle::Blocks));
    }

    #[test]
    fn every_style_labels_the_angles_and_shows_the_peak() {
        for style in [PolarStyle::Braille, PolarStyle::Blocks, PolarStyle::Ascii] {
            let options = PolarOptions { style, scale: None };
            let text = text(&draw(&downlight(), options, 46, 24));
            for label in ["0°", "30°", "60°", "90°", "120°", "150°", "180°"] {
                assert!(text.contains(label), "{style:?}: no {label}");
            }
            assert!(text.contains("peak 1000 cd"), "{style:?}");
            assert!(text.contains("500") && text.contains("1000"), "{style:?}");
        }
    }

    #[test]
    fn ascii_and_blocks_use_no_braille() {
        let ascii: fn(char) -> bool = |c| c.is_ascii() || "°─│┌┐└┘".contains(c);
        let no_braille: fn(char) -> bool = |c| !('\u{2800}'..='\u{28FF}').contains(&c);
        for (style, allowed) in [(PolarStyle::Ascii, ascii), (PolarStyle::Blocks, no_braille)] {
            let text = text(&draw(&downlight(), PolarOptions { style, scale: None }, 46, 24));
            let bad: String = text.chars().filter(|&c| !allowed(c)).collect();
            assert!(bad.is_empty(), "{style:?}: {bad:?}");
        }
    }

    #[test]
    fn a_fixed_scale_draws_a_raised_curve_larger() {
        // At a fixed 1500 cd scale the 0° point of a 1000 cd and a 1400 cd curve: the brighter
        // one is further from the centre (lower on the screen).
        let row_of_selected = |peak: f64| {
            let curve = Curve::new(&[(0.0, peak), (30.0, 500.0), (90.0, 0.0)]).unwrap();
            let options = PolarOptions {
                style: PolarStyle::Braille,
                scale: Some(PolarScale { full_cd: 1500.0 }),
            };
            let mut terminal = Terminal::new(TestBackend::new(46, 24)).unwrap();
            terminal
                .draw(|frame| {
                    PolarDiagram {
                        curve: &curve,
                        series: None,
                        spread: None,
                        selected: 0,
                        block: Block::bordered(),
                    }
                    .render_with(options, frame.area(), frame.buffer_mut())
                })
                .unwrap();
            let buffer = terminal.backend().buffer().clone();
            (0..24u16)
                .find(|&y| (0..46u16).any(|x| buffer[(x, y)].symbol() == "◆"))
                .unwrap()
        };
        assert!(row_of_selected(1400.0) > row_of_selected(1000.0));
    }

    #[test]
    fn snapshot_braille() {
        let options = PolarOptions {
            style: PolarStyle::Braille,
            scale: None,
        };
        assert_snapshot!(draw(&downlight(), options, 46, 24).backend());
    }

    #[test]
    fn snapshot_blocks() {
        let options = PolarOptions {
            style: PolarStyle::Blocks,
            scale: None,
        };
        assert_snapshot!(draw(&downlight(), options, 46, 24).backend());
    }

    #[test]
    fn snapshot_ascii() {
        let options = PolarOptions {
            style: PolarStyle::Ascii,
            scale: None,
        };
        assert_snapshot!(draw(&downlight(), options, 46, 24).backend());
    }

    #[test]
    fn snapshot_ascii_at_a_fixed_scale_in_a_small_pane() {
        let options = PolarOptions {
            style: PolarStyle::Ascii,
            scale: Some(PolarScale { full_cd: 1500.0 }),
        };
        assert_snapshot!(draw(&downlight(), options, 40, 14).backend());
    }
}
