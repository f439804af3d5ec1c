//! What the false-colour picture means, drawn into it: a colour bar with lux ticks at round
//! values, and isolux lines at the same values over the per-pixel illuminance.
//!
//! Round values are the steps of the scale of maintained illuminance values used in lighting
//! standards (EN 12464-1): 1, 1.5, 2, 3, 5, 7.5 × 10ᵏ lx (… 50, 75, 100, 150, 200, 300, 500, 750,
//! 1000, 1500, 2000 …), thinned to 1, 2, 3, 5, 7.5, then 1, 2, 5, then 1 × 10ᵏ when the bar has
//! no room for all labels. Pixel coordinates as in [`super::camera`] (y down).

use tiny_skia::{Paint, Pixmap, Rect, Transform};

use super::shade::{FalseColor, LuxScale, viridis};
use super::text::{draw_text, text_height, text_width};

/// Mantissas of the round lux values, from the densest set to the sparsest.
const MANTISSA_SETS: [&[f64]; 4] = [
    &[1.0, 1.5, 2.0, 3.0, 5.0, 7.5],
    &[1.0, 2.0, 3.0, 5.0, 7.5],
    &[1.0, 2.0, 5.0],
    &[1.0],
];

/// The round lux values inside `[min_lx, max_lx]` from the densest set that has at most
/// `max_count` of them (the sparsest set, every other decade if need be, otherwise), ascending.
pub fn round_levels(min_lx: f64, max_lx: f64, max_count: usize) -> Vec<f64> {
    if !(min_lx.is_finite() && max_lx.is_finite() && max_lx > 0.0 && max_lx >= min_lx) || max_count == 0 {
        return Vec::new();
    }
    let low = min_lx.max(max_lx * 1e-6);
    let levels_of = |mantissas: &[f64], decade_step: i32| {
        let first = low.log10().floor() as i32 - 1;
        let last = max_lx.log10().ceil() as i32 + 1;
        let mut levels = Vec::new();
        for k in (first..=last).filter(|k| k.rem_euclid(decade_step) == 0) {
            for &m in mantissas {
                // Round to 12 significant digits so 1.5e2 is exactly 150.
                let v = format!("{:.12e}", m * 10f64.powi(k))
                    .parse::<f64>()
                    .unwrap_or(0.0);
                if v >= min_lx && v <= max_lx {
                    levels.push(v);
                }
            }
        }
        levels
    };
    for mantissas in MANTISSA_SETS {
        let levels = levels_of(mantissas, 1);
        if levels.len() <= max_count {
            return levels;
        }
    }
    (2..)
        .map(|step| levels_of(&[1.0], step))
        .find(|l| l.len() <= max_count)
        .unwrap_or_default()
}

/// Evenly spaced round values (steps of 1, 2, 2.5 or 5 × 10ᵏ lx) inside `[min_lx, max_lx]`, at
/// most `max_count` of them: the ticks of a linear scale.
pub fn linear_levels(min_lx: f64, max_lx: f64, max_count: usize) -> Vec<f64> {
    if !(min_lx.is_finite() && max_lx.is_finite() && max_lx > min_lx) || max_count < 2 {
        return Vec::new();
    }
    let span = max_lx - min_lx;
    let mut decade = 10f64.powf((span / max_count as f64).log10().floor());
    loop {
        for m in [1.0, 2.0, 2.5, 5.0] {
            let step = m * decade;
            let first = (min_lx / step).ceil() as i64;
            let last = (max_lx / step).floor() as i64;
            if last - first < max_count as i64 {
                return (first..=last).map(|k| k as f64 * step).collect();
            }
        }
        decade *= 10.0;
    }
}

/// A lux value as a tick label: `0.5`, `75`, `1500`, `15k`.
pub fn lux_label(lux: f64) -> String {
    let trim = |v: f64| {
        let s = format!("{v:.1}");
        s.strip_suffix(".0").map_or(s.clone(), str::to_owned)
    };
    if lux >= 1e4 {
        format!("{}k", trim(lux / 1e3))
    } else if lux >= 1.0 {
        trim(lux)
    } else {
        format!("{lux}")
    }
}

/// Where the legend was drawn: the bar and its ticks, in image pixels.
#[derive(Debug, Clone, PartialEq)]
pub struct Legend {
    /// Left, top, right, bottom edges of the colour bar (pixels; right and bottom exclusive).
    pub bar: [u32; 4],
    /// `(lux, y)`: each tick's value and the pixel row of its mark.
    pub ticks: Vec<(f64, u32)>,
    /// Image pixels per font pixel of the labels.
    pub scale: u32,
}

impl Legend {
    /// The pixel row where `fraction ∈ [0, 1]` of the scale lies on the bar (0 at the bottom).
    pub fn row_of(&self, fraction: f64) -> u32 {
        let [_, top, _, bottom] = self.bar;
        let span = f64::from(bottom - top);
        let y = f64::from(bottom) - fraction.clamp(0.0, 1.0) * span;
        (y.floor() as u32).clamp(top, bottom - 1)
    }

    /// The scale fraction a pixel row of the bar stands for (at the row's centre).
    pub fn fraction_of_row(&self, row: u32) -> f64 {
        let [_, top, _, bottom] = self.bar;
        ((f64::from(bottom) - (f64::from(row) + 0.5)) / f64::from(bottom - top)).clamp(0.0, 1.0)
    }
}

/// Where the legend of a `width × height` image goes (pixels): label scale, bar width, margin,
/// tick levels, panel width, bar top and bottom rows.
struct Layout {
    s: u32,
    bar_w: u32,
    margin: u32,
    levels: Vec<f64>,
    panel_w: u32,
    top: u32,
    bottom: u32,
}

/// The legend's layout in a `w × h` image, `None` when the image is too small for one.
fn layout(w: u32, h: u32, scale: &FalseColor) -> Option<Layout> {
    let s = (h / 240).max(1);
    let bar_w = 10 * s;
    let margin = 6 * s;
    let (min_lx, max_lx) = scale.range();
    let bar_height = h.saturating_sub(5 * margin + text_height(s));
    let room = (bar_height / (2 * text_height(s))) as usize;
    let levels = match scale.scale() {
        LuxScale::Log => round_levels(min_lx, max_lx, room),
        LuxScale::Linear => linear_levels(min_lx, max_lx, room),
    };
    let label_w = levels
        .iter()
        .map(|&l| text_width(&lux_label(l), s))
        .max()
        .unwrap_or(0)
        .max(text_width("lx", s));
    let panel_w = margin + label_w + 3 * s + 4 * s + bar_w + margin;
    let top = margin + text_height(s) + 2 * margin;
    let bottom = h.checked_sub(2 * margin)?;
    if panel_w + 2 * margin > w || bottom <= top + 4 * text_height(s) {
        return None;
    }
    Some(Layout {
        s,
        bar_w,
        margin,
        levels,
        panel_w,
        top,
        bottom,
    })
}

/// Pixels at the right edge of a `width × height` image that [`draw_legend`] covers for `scale`
/// (its panel and the margin beside it), 0 when the image is too small for a legend: what a
/// plan view leaves free so the legend stands beside the footprint.
pub fn legend_width(width: u32, height: u32, scale: &FalseColor) -> u32 {
    layout(width, height, scale).map_or(0, |l| l.panel_w + l.margin)
}

/// Label colour (sRGB8).
const LABEL_RGB: [u8; 3] = [235, 235, 235];

/// Draws the legend of `scale` at the right edge of `pixmap`: a dark panel, the viridis bar
/// (bottom = the scale's minimum, top = its maximum), a tick and a label at each round value
/// ([`round_levels`] of the scale's range on a log scale, [`linear_levels`] on a linear one, as
/// many as the bar has room for) and the unit `lx` above. Returns where it drew (the ticks are the levels to draw isolux lines at); `None`
/// when the image is too small for a legend.
pub fn draw_legend(pixmap: &mut Pixmap, scale: &FalseColor) -> Option<Legend> {
    let (w, h) = (pixmap.width(), pixmap.height());
    let Layout {
        s,
        bar_w,
        margin,
        levels,
        panel_w,
        top,
        bottom,
    } = layout(w, h, scale)?;
    let bar_right = w - 2 * margin;
    let bar_left = bar_right - bar_w;
    let mut legend = Legend {
        bar: [bar_left, top, bar_right, bottom],
        ticks: Vec::new(),
        scale: s,
    };
    // The panel behind it all, translucent.
    let panel_left = bar_right + margin - panel_w;
    fill_rect(
        pixmap,
        panel_left as f32,
        margin as f32,
        panel_w as f32,
        (h - 2 * margin) as f32,
        [0, 0, 0, 170],
    );
    let (pixels, _) = pixmap.data_mut().as_chunks_mut::<4>();
    for row in top..bottom {
        let [r, g, b] = viridis(legend.fraction_of_row(row));
        for x in bar_left..bar_right {
            pixels[(row * w + x) as usize] = [r, g, b, 255];
        }
    }
    for &lux in &levels {
        let row = legend.row_of(scale.position(lux));
        for x in bar_left - 4 * s..bar_left {
            for dy in 0..s.min(bottom - row) {
                pixels[((row + dy) * w + x) as usize] = [LABEL_RGB[0], LABEL_RGB[1], LABEL_RGB[2], 255];
            }
        }
        legend.ticks.push((lux, row));
    }
    for &(lux, row) in &legend.ticks {
        let label = lux_label(lux);
        let x = bar_left - 4 * s - 3 * s - text_width(&label, s);
        let y = i64::from(row) - i64::from(text_height(s) / 2);
        draw_text(pixmap, i64::from(x), y, &label, s, LABEL_RGB);
    }
    let unit_x = bar_left + bar_w / 2 - text_width("lx", s) / 2;
    draw_text(
        pixmap,
        i64::from(unit_x),
        i64::from(2 * margin),
        "lx",
        s,
        LABEL_RGB,
    );
    Some(legend)
}

/// Draws isolux lines at `levels` (lx) over `pixmap`: a pixel is on the line of level `E` when
/// it is at or above `E` and its right or lower neighbour on the same surface is below it, or
/// the other way round (the line runs along the bright side of the contour, one pixel wide).
/// `lux` is the per-pixel illuminance (row-major, the image's size); `surface(i)` names the
/// surface at pixel `i` (`None` for the background), so jumps across an edge between two
/// surfaces draw no line. Lines are black over bright pixels and white over dark ones.
pub fn draw_isolux(pixmap: &mut Pixmap, lux: &[f32], surface: impl Fn(usize) -> Option<u32>, levels: &[f64]) {
    let (w, h) = (pixmap.width() as usize, pixmap.height() as usize);
    if lux.len() != w * h || levels.is_empty() {
        return;
    }
    let levels: Vec<f32> = levels.iter().map(|&l| l as f32).collect();
    // A level lies between two values exactly when they have different numbers of levels at or
    // below them (NaN has none): one branch-free count per pixel instead of a test per level and
    // pair; the surfaces are looked up only where the count changes.
    let band: Vec<usize> = lux
        .iter()
        .map(|&e| levels.iter().filter(|&&l| l <= e).count())
        .collect();
    let mut on_line = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            for j in [(x + 1 < w).then_some(i + 1), (y + 1 < h).then_some(i + w)]
                .into_iter()
                .flatten()
            {
                if band[i] != band[j]
                    && let Some(here) = surface(i)
                    && surface(j) == Some(here)
                {
                    on_line[if lux[i] >= lux[j] { i } else { j }] = true;
                }
            }
        }
    }
    let (pixels, _) = pixmap.data_mut().as_chunks_mut::<4>();
    for (p, _) in pixels.iter_mut().zip(&on_line).filter(|(_, on)| **on) {
        let luma = 0.2126 * f64::from(p[0]) + 0.7152 * f64::from(p[1]) + 0.0722 * f64::from(p[2]);
        *p = if luma > 140.0 {
            [0, 0, 0, 255]
        } else {
            [255, 255, 255, 255]
        };
    }
}

/// Fills a rectangle with a premultiplied-alpha blend of `rgba` (sRGB8 + alpha).
fn fill_rect(pixmap: &mut Pixmap, x: f32, y: f32, w: f32, h: f32, rgba: [u8; 4]) {
    let Some(rect) = Rect::from_xywh(x, y, w, h) else {
        return;
    };
    let mut paint = Paint {
        anti_alias: false,
        force_hq_pipeline: true,
        ..Paint::default()
    };
    paint.set_color_rgba8(rgba[0], rgba[1], rgba[2], rgba[3]);
    pixmap.fill_rect(rect, &paint, Transform::identity(), None);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_levels_follow_the_standard_scale_and_thin_out() {
        assert_eq!(
            round_levels(40.0, 2500.0, 20),
            [
                50.0, 75.0, 100.0, 150.0, 200.0, 300.0, 500.0, 750.0, 1000.0, 1500.0, 2000.0
            ]
        );
        assert_eq!(
            round_levels(40.0, 2500.0, 10),
            [50.0, 75.0, 100.0, 200.0, 300.0, 500.0, 750.0, 1000.0, 2000.0]
        );
        assert_eq!(
            round_levels(40.0, 2500.0, 6),
            [50.0, 100.0, 200.0, 500.0, 1000.0, 2000.0]
        );
        assert_eq!(round_levels(40.0, 2500.0, 3), [100.0, 1000.0]);
        assert_eq!(round_levels(0.1, 1e6, 3), [1.0, 1000.0, 1e6]);
        assert!(round_levels(0.0, 0.0, 5).is_empty());
        assert!(round_levels(f64::NAN, 10.0, 5).is_empty());
    }

    #[test]
    fn linear_levels_are_even_round_steps() {
        assert_eq!(
            linear_levels(0.0, 1000.0, 11),
            [
                0.0, 100.0, 200.0, 300.0, 400.0, 500.0, 600.0, 700.0, 800.0, 900.0, 1000.0
            ]
        );
        assert_eq!(
            linear_levels(0.0, 1000.0, 6),
            [0.0, 200.0, 400.0, 600.0, 800.0, 1000.0]
        );
        assert_eq!(linear_levels(0.0, 1000.0, 5), [0.0, 250.0, 500.0, 750.0, 1000.0]);
        assert_eq!(linear_levels(12.0, 480.0, 5), [100.0, 200.0, 300.0, 400.0]);
        assert!(linear_levels(5.0, 5.0, 5).is_empty());
    }

    #[test]
    fn labels_are_short() {
        assert_eq!(lux_label(75.0), "75");
        assert_eq!(lux_label(1500.0), "1500");
        assert_eq!(lux_label(15000.0), "15k");
        assert_eq!(lux_label(2.0e6), "2000k");
        assert_eq!(lux_label(0.5), "0.5");
    }
}
