//! The photometric polar diagram of one light: the C0–C180 plane with γ = 0° pointing down
//! (the nadir of a downlight), γ drawn on both sides mirrored, intensity (cd) as the radius.
//! A ratatui `Canvas` with Braille dots: rings labelled in cd, the control-point curve, the
//! truncated series the light really emits, and the control points (the selected one marked).

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
/// Colour of the C-plane spread (lowest and highest plane) of an asymmetric file.
pub const SPREAD_COLOR: Color = Color::Magenta;

/// Largest γ step (degrees) between two drawn samples of the control-point curve.
const SAMPLE_STEP_DEG: f64 = 1.0;

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

impl PolarDiagram<'_> {
    /// Largest radius to show (cd): the curve's or the series' peak.
    fn max_cd(&self) -> f64 {
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
}

impl Widget for PolarDiagram<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let inner = self.block.inner(area);
        let step = ring_step_cd(self.max_cd());
        let rings = (self.max_cd() / step).ceil().max(1.0) as usize;
        let radius = rings as f64 * step * 1.05;
        // Braille: 2×4 dots per cell, and a cell is about twice as tall as wide, so a dot is
        // square; scale both axes by the same cd per dot so circles stay round.
        let dots_x = f64::from(inner.width.max(1)) * 2.0;
        let dots_y = f64::from(inner.height.max(1)) * 4.0;
        let cd_per_dot = (2.0 * radius / dots_x).max(2.0 * radius / dots_y);
        let (half_x, half_y) = (cd_per_dot * dots_x / 2.0, cd_per_dot * dots_y / 2.0);
        let curve_samples = curve_samples(self.curve);
        let points: Vec<(f64, f64)> = self.curve.points().collect();
        Canvas::default()
            .block(self.block)
            .marker(Marker::Braille)
            .x_bounds([-half_x, half_x])
            .y_bounds([-half_y, half_y])
            .paint(|ctx| {
                for k in 1..=rings {
                    let r = k as f64 * step;
                    ctx.draw(&Circle::new(0.0, 0.0, r, GRID_COLOR));
                }
                ctx.draw(&Line::new(0.0, -radius, 0.0, radius, GRID_COLOR));
                ctx.draw(&Line::new(-radius, 0.0, radius, 0.0, GRID_COLOR));
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
                for k in 1..=rings {
                    let r = k as f64 * step;
                    ctx.print(0.0, r, Span::styled(format!("{r}"), Style::new().fg(Color::Gray)));
                }
                for (k, &(gamma_deg, cd)) in points.iter().enumerate() {
                    let (x, y) = polar_xy(gamma_deg.to_radians(), cd, false);
                    if k == self.selected {
                        ctx.print(x, y, Span::styled("◆", Style::new().fg(SELECTED_COLOR).bold()));
                    } else {
                        ctx.print(x, y, Span::styled("•", Style::new().fg(Color::White)));
                    }
                }
            })
            .render(area, buf);
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

/// The legend line: which colour is which curve.
pub fn legend(order: usize) -> TextLine<'static> {
    TextLine::from(vec![
        Span::styled("━ curve ", Style::new().fg(CURVE_COLOR)),
        Span::styled(format!("━ series N={order} "), Style::new().fg(SERIES_COLOR)),
        Span::styled("◆ selected", Style::new().fg(SELECTED_COLOR)),
    ])
}
