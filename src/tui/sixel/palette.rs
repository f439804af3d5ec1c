//! The sixel palette: an opaque RGBA image reduced to at most [`MAX_COLOURS`] colours
//! (docs/DECISIONS.md "Terminal graphics").
//!
//! Sixel colours are whole percent per channel (101 levels), so finer steps cannot be shown.
//! Rounding red, green and blue separately would split every smooth grey ramp three times (the
//! channels cross their rounding points at different places, leaving faint tinted stripes and
//! triple the colour changes to send), so colours are grouped on a grid of luma and chroma
//! instead ([`Quality`]): luma `Y = 0.299 R + 0.587 G + 0.114 B` in steps of
//! [`Quality::luma_step`] percent, chroma `B − Y` and `R − Y` in steps of
//! [`Quality::chroma_step`]. Each grid cell shows the mean of its pixels. When more than
//! [`MAX_COLOURS`] cells are used they are split into boxes by variance (the box with the
//! largest squared error, chroma weighted by [`CHROMA_WEIGHT`], is cut where the halves' errors
//! are smallest), each box showing its mean.

use rayon::prelude::*;

use super::histogram::{Run, count_colours, unpack};

/// Most colours in a sixel palette (colour registers the editor uses).
pub const MAX_COLOURS: usize = 256;

/// Weight of a chroma difference against a luma difference in the box split: the eye resolves
/// luma steps best.
pub const CHROMA_WEIGHT: f64 = 0.25;

/// Chroma (percent) up to which the grid keeps its chroma step.
pub const FINE_CHROMA: f64 = 6.0;
/// How much coarser the chroma step is beyond [`FINE_CHROMA`].
pub const COARSE_CHROMA_FACTOR: f64 = 3.0;

/// The grid colours are grouped on, in percent.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quality {
    /// Luma step, percent.
    pub luma_step: f64,
    /// Chroma step, percent.
    pub chroma_step: f64,
}

impl Quality {
    /// Sixel's own precision: one percent of luma (chroma 1.5 %).
    pub const FINE: Quality = Quality {
        luma_step: 1.0,
        chroma_step: 1.5,
    };

    /// The grid of dithered full frames ([`quantise_dithered`]): 1.5 % luma steps. Dithering
    /// between levels leaves no visible step at any luma step, while the bytes follow the number
    /// of levels a gradient crosses (measured on the office frame at 940 × 640: 102 KB at 1 %,
    /// 82 KB at 1.5 %, 71 KB at 2 %, where the row pattern starts to show; 66 KB flat at 1 %).
    pub const DITHERED: Quality = Quality {
        luma_step: 1.5,
        chroma_step: 1.5,
    };

    /// The quality of a frame rendered at 1 / `divisor` of the full resolution: interactive
    /// frames are coarser in colour too, since sixel's bytes follow the colour changes more than
    /// the pixel count (1: [`Quality::FINE`]; 2: 1.5 % luma; 3 and more: 2 %).
    pub fn for_divisor(divisor: u32) -> Quality {
        match divisor {
            0 | 1 => Quality::FINE,
            2 => Quality {
                luma_step: 1.5,
                chroma_step: 2.0,
            },
            _ => Quality {
                luma_step: 2.0,
                chroma_step: 3.0,
            },
        }
    }

    /// The grid cell of `rgb` (8-bit): luma divided by its step; chroma `B − Y` and `R − Y`
    /// divided by theirs up to [`FINE_CHROMA`] percent, by [`COARSE_CHROMA_FACTOR`] times
    /// theirs beyond (a tint is seen against grey, a change of a strong colour much less);
    /// rounded.
    pub fn cell(self, rgb: [u8; 3]) -> [i32; 3] {
        let [y, cb, cr] = luma_chroma(rgb.map(|c| f64::from(c) * 100.0 / 255.0));
        let chroma = |c: f64| {
            let fine = c.abs().min(FINE_CHROMA);
            let coarse = (c.abs() - FINE_CHROMA).max(0.0) / COARSE_CHROMA_FACTOR;
            (c.signum() * (fine + coarse) / self.chroma_step).round() as i32
        };
        [(y / self.luma_step).round() as i32, chroma(cb), chroma(cr)]
    }
}

/// Luma and chroma `[Y, B − Y, R − Y]` of an RGB colour (any common scale).
pub fn luma_chroma([r, g, b]: [f64; 3]) -> [f64; 3] {
    let y = 0.299 * r + 0.587 * g + 0.114 * b;
    [y, b - y, r - y]
}

/// An image reduced to a sixel palette.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Indexed {
    /// Width, pixels.
    pub width: usize,
    /// Height, pixels.
    pub height: usize,
    /// The palette, red, green, blue in percent (0..=100), at most [`MAX_COLOURS`] entries, the
    /// most used first.
    pub palette: Vec<[u8; 3]>,
    /// The grid cell ([`Quality::cell`]) of each palette colour.
    pub cells: Vec<[i32; 3]>,
    /// The palette index of each pixel, rows top to bottom.
    pub indices: Vec<u8>,
}

/// The 0..=100 percent level nearest to the 8-bit channel value `c`.
pub fn to_percent(c: u8) -> u8 {
    ((u32::from(c) * 100 + 127) / 255) as u8
}

/// The 8-bit channel value a terminal shows for percent level `p` (rounded; xterm's rule).
pub fn from_percent(p: u8) -> u8 {
    ((u32::from(p.min(100)) * 255 + 50) / 100) as u8
}

/// Reduces the opaque RGBA image `rgba` (`width × height`, 4 bytes a pixel, alpha ignored) to a
/// sixel palette on the grid of `quality`, each pixel taking its grid cell's colour. `rgba` must
/// hold exactly `width × height` pixels.
pub fn quantise(rgba: &[u8], width: usize, height: usize, quality: Quality) -> Indexed {
    debug_assert_eq!(rgba.len(), width * height * 4);
    let (table, runs) = count_colours(rgba);
    let contributions: Vec<Contribution> = (0..table.colours.len())
        .map(|id| {
            let rgb = unpack(table.colours[id]);
            Contribution {
                cell: quality.cell(rgb),
                weight: f64::from(table.counts[id]),
                rgb: rgb.map(f64::from),
            }
        })
        .collect();
    let (palette, cells, entry_of) = build_palette(&contributions, quality);
    Indexed {
        width,
        height,
        palette,
        cells,
        indices: expand(&runs, &entry_of, width * height),
    }
}

/// The rows of a band in the order they take the upper of two levels as a pixel's fraction
/// between them grows, before each band's shuffle ([`row_thresholds`]).
const DITHER_ORDER: [u8; 6] = [0, 3, 1, 4, 2, 5];

/// The dither threshold of each row of band `band`: `(k + ½) / 6` for the row's place `k`, the
/// six places shuffled per band (a fixed pseudo-random permutation) so no line pattern repeats
/// from band to band.
pub fn row_thresholds(band: usize) -> [f64; 6] {
    let mut order = DITHER_ORDER;
    let mut state = (band as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    for i in (1..6).rev() {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        order.swap(i, (state % (i as u64 + 1)) as usize);
    }
    order.map(|k| (f64::from(k) + 0.5) / 6.0)
}

/// Like [`quantise`], but a pixel between two luma levels of the grid takes the lower or the
/// upper one by an ordered threshold that depends on its row only ([`row_thresholds`]): the
/// average over a band matches the pixel's luma (no banding), while a column's sixels stay the
/// same along a row of equal colours (long runs). The levels sit on whole percents of luma
/// ([`dither_level`]), so a grey stays grey in sixel's precision; the palette colours sit
/// exactly on their levels.
pub fn quantise_dithered(rgba: &[u8], width: usize, height: usize, quality: Quality) -> Indexed {
    debug_assert_eq!(rgba.len(), width * height * 4);
    let (table, runs) = count_colours(rgba);
    let mut contributions = Vec::with_capacity(2 * table.colours.len());
    // Per colour id: its fraction above the lower level, and its two contributions.
    let mut levels: Vec<(f64, usize, usize)> = Vec::with_capacity(table.colours.len());
    for id in 0..table.colours.len() {
        let rgb = unpack(table.colours[id]).map(f64::from);
        let luma = luma_chroma(rgb)[0] * 100.0 / 255.0;
        let mut lower = (luma / quality.luma_step).floor();
        if dither_level(lower, quality) > luma {
            lower -= 1.0;
        }
        if dither_level(lower + 1.0, quality) <= luma {
            lower += 1.0;
        }
        let (low, high) = (dither_level(lower, quality), dither_level(lower + 1.0, quality));
        let f = (luma - low) / (high - low);
        let [_, cb, cr] = quality.cell(unpack(table.colours[id]));
        let count = f64::from(table.counts[id]);
        let mut push = |level: f64, weight: f64| {
            // The colour moved onto the level: the same shift on every channel moves luma by it.
            let shift = (dither_level(level, quality) - luma) * 255.0 / 100.0;
            contributions.push(Contribution {
                cell: [level as i32, cb, cr],
                weight: count * weight,
                rgb: rgb.map(|c| c + shift),
            });
            contributions.len() - 1
        };
        let below = push(lower, 1.0 - f);
        // Exactly on a level: the upper one is never taken.
        let above = if f > 0.0 { push(lower + 1.0, f) } else { below };
        levels.push((f, below, above));
    }
    let (palette, cells, entry_of) = build_palette(&contributions, quality);
    // Per pixel: its lower and upper level's entries and its fraction between them (in 1/255),
    // each written run by run; then each row takes the upper entry where the fraction passes the
    // row's threshold.
    let n = levels.len();
    let (mut lower_of, mut upper_of, mut fraction_of) = (
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
    );
    for &(f, below, above) in &levels {
        lower_of.push(entry_of[below]);
        upper_of.push(entry_of[above]);
        fraction_of.push((f * 255.0).round() as u8);
    }
    let pixels = width * height;
    let mut indices = expand(&runs, &lower_of, pixels);
    let upper = expand(&runs, &upper_of, pixels);
    let fraction = expand(&runs, &fraction_of, pixels);
    indices
        .par_chunks_mut(width)
        .zip(upper.par_chunks(width).zip(fraction.par_chunks(width)))
        .enumerate()
        .for_each(|(y, (row, (upper, fraction)))| {
            let threshold = (row_thresholds(y / 6)[y % 6] * 255.0).round() as u8;
            for ((entry, &up), &f) in row.iter_mut().zip(upper).zip(fraction) {
                if f > threshold {
                    *entry = up;
                }
            }
        });
    Indexed {
        width,
        height,
        palette,
        cells,
        indices,
    }
}

/// Pixels of a distinct colour going to one grid cell: how many (weight) and the colour they
/// bring (8-bit scale, possibly moved in luma).
#[derive(Debug, Clone, Copy)]
struct Contribution {
    cell: [i32; 3],
    weight: f64,
    rgb: [f64; 3],
}

/// The palette (percent), its grid cells and the palette entry of each contribution: cells
/// grouped, more than [`MAX_COLOURS`] cells split into boxes, the most used colours first.
fn build_palette(contributions: &[Contribution], quality: Quality) -> (Vec<[u8; 3]>, Vec<[i32; 3]>, Vec<u8>) {
    let mut order: Vec<u32> = (0..contributions.len() as u32).collect();
    order.sort_unstable_by_key(|&i| contributions[i as usize].cell);
    let mut groups: Vec<Group> = Vec::new();
    let mut group_of = vec![0u32; contributions.len()];
    for &i in &order {
        let c = contributions[i as usize];
        if groups.last().is_none_or(|g| g.cell != c.cell) {
            groups.push(Group {
                cell: c.cell,
                count: 0.0,
                sum: [0.0; 3],
            });
        }
        let group = groups.last_mut().expect("just pushed");
        group.count += c.weight;
        for k in 0..3 {
            group.sum[k] += c.weight * c.rgb[k];
        }
        group_of[i as usize] = (groups.len() - 1) as u32;
    }
    let (boxes, box_of_group) = split_boxes(&groups);
    // The most used colours first: their numbers are the shortest to write.
    let mut by_use: Vec<usize> = (0..boxes.len()).collect();
    by_use.sort_by(|&a, &b| boxes[b].count.total_cmp(&boxes[a].count).then(a.cmp(&b)));
    let mut rank = vec![0u8; boxes.len()];
    for (r, &b) in by_use.iter().enumerate() {
        rank[b] = r as u8;
    }
    let means: Vec<[u8; 3]> = by_use.iter().map(|&b| boxes[b].mean_rgb()).collect();
    let entry_of = group_of
        .iter()
        .map(|&g| rank[usize::from(box_of_group[g as usize])])
        .collect();
    (
        means.iter().map(|m| m.map(to_percent)).collect(),
        means.iter().map(|&m| quality.cell(m)).collect(),
        entry_of,
    )
}

/// The luma of dither level `k` at `quality`, percent: `k` luma steps rounded to a whole
/// percent. A grey on a level is a whole-percent grey, which sixel shows exactly; with 1.5 %
/// steps the levels are 0, 2, 3, 5, 6, … percent, and dithering between uneven neighbours keeps
/// the averages right.
pub fn dither_level(k: f64, quality: Quality) -> f64 {
    (k * quality.luma_step).round()
}

/// The palette index of every pixel from the runs of colour ids. Most runs are short: each is
/// written eight bytes at a time (into slack at the end, cut off afterwards).
fn expand(runs: &[Run], palette_of_id: &[u8], pixels: usize) -> Vec<u8> {
    let mut indices = vec![0u8; pixels + 8];
    let mut at = 0;
    for &(id, n) in runs {
        let colour = palette_of_id[usize::from(id)];
        let n = n as usize;
        indices[at..at + 8].copy_from_slice(&[colour; 8]);
        if n > 8 {
            indices[at + 8..at + n].fill(colour);
        }
        at += n;
    }
    indices.truncate(pixels);
    indices
}

/// The pixels of one grid cell: how many and the sum of their 8-bit colours.
#[derive(Debug, Clone, Copy)]
struct Group {
    cell: [i32; 3],
    count: f64,
    sum: [f64; 3],
}

/// A box's weighted statistics over luma and chroma of its groups' mean colours.
#[derive(Debug, Clone, Copy, Default)]
struct Moments {
    count: f64,
    /// Σ count · 8-bit colour (for the mean).
    rgb: [f64; 3],
    /// Σ count · [Y, B − Y, R − Y].
    sum: [f64; 3],
    /// Σ count · [Y, B − Y, R − Y]².
    sum_sq: [f64; 3],
}

impl Moments {
    fn add(&mut self, group: &Group) {
        self.count += group.count;
        let mean = group.sum.map(|s| s / group.count.max(1.0));
        let ycc = luma_chroma(mean);
        for c in 0..3 {
            self.rgb[c] += group.sum[c];
            self.sum[c] += group.count * ycc[c];
            self.sum_sq[c] += group.count * ycc[c] * ycc[c];
        }
    }

    fn subtract(&self, part: &Moments) -> Moments {
        Moments {
            count: self.count - part.count,
            rgb: std::array::from_fn(|c| self.rgb[c] - part.rgb[c]),
            sum: std::array::from_fn(|c| self.sum[c] - part.sum[c]),
            sum_sq: std::array::from_fn(|c| self.sum_sq[c] - part.sum_sq[c]),
        }
    }

    /// The weighted squared error about the mean, per axis (luma, then the chromas).
    fn error(&self) -> [f64; 3] {
        if self.count <= 0.0 {
            return [0.0; 3];
        }
        std::array::from_fn(|c| {
            let weight = if c == 0 { 1.0 } else { CHROMA_WEIGHT };
            weight * (self.sum_sq[c] - self.sum[c] * self.sum[c] / self.count).max(0.0)
        })
    }

    fn total_error(&self) -> f64 {
        self.error().iter().sum()
    }

    /// The mean colour, 8-bit.
    fn mean_rgb(&self) -> [u8; 3] {
        self.rgb
            .map(|s| (s / self.count.max(1.0)).round().clamp(0.0, 255.0) as u8)
    }
}

/// A box of groups (a range of the list being split).
#[derive(Debug, Clone, Copy)]
struct GroupBox {
    start: usize,
    end: usize,
    moments: Moments,
    /// False once the box holds one group or cannot be cut.
    splittable: bool,
}

/// Splits the groups into at most [`MAX_COLOURS`] boxes by variance (each group its own box
/// when they fit); returns the boxes' moments and the box of each group.
fn split_boxes(groups: &[Group]) -> (Vec<Moments>, Vec<u8>) {
    let single = |g: &Group| {
        let mut m = Moments::default();
        m.add(g);
        m
    };
    if groups.len() <= MAX_COLOURS {
        return (
            groups.iter().map(single).collect(),
            (0..groups.len()).map(|i| i as u8).collect(),
        );
    }
    // (luma-chroma of the group's mean, group index), sorted within boxes as they are cut.
    let mut tagged: Vec<([f64; 3], usize)> = groups
        .iter()
        .enumerate()
        .map(|(i, g)| (luma_chroma(g.sum.map(|s| s / g.count.max(1.0))), i))
        .collect();
    let mut all = Moments::default();
    groups.iter().for_each(|g| all.add(g));
    let mut boxes = vec![GroupBox {
        start: 0,
        end: tagged.len(),
        moments: all,
        splittable: true,
    }];
    while boxes.len() < MAX_COLOURS {
        let Some(worst) = (0..boxes.len())
            .filter(|&i| boxes[i].splittable)
            .max_by(|&a, &b| {
                boxes[a]
                    .moments
                    .total_error()
                    .total_cmp(&boxes[b].moments.total_error())
            })
        else {
            break;
        };
        match split_box(&mut tagged, groups, boxes[worst]) {
            Some((left, right)) => {
                boxes[worst] = left;
                boxes.push(right);
            }
            None => boxes[worst].splittable = false,
        }
    }
    let mut box_of = vec![0u8; groups.len()];
    for (b, group_box) in boxes.iter().enumerate() {
        for &(_, g) in &tagged[group_box.start..group_box.end] {
            box_of[g] = b as u8;
        }
    }
    (boxes.iter().map(|b| b.moments).collect(), box_of)
}

/// Cuts `b` along its axis of largest error where the halves' summed error is least; `None`
/// when its groups are all equal on that axis.
fn split_box(
    tagged: &mut [([f64; 3], usize)],
    groups: &[Group],
    b: GroupBox,
) -> Option<(GroupBox, GroupBox)> {
    let error = b.moments.error();
    let axis = (0..3).max_by(|&i, &j| error[i].total_cmp(&error[j]))?;
    let range = &mut tagged[b.start..b.end];
    range.sort_unstable_by(|p, q| p.0[axis].total_cmp(&q.0[axis]));
    let mut left = Moments::default();
    let mut best: Option<(f64, usize, Moments)> = None;
    for i in 0..range.len() - 1 {
        left.add(&groups[range[i].1]);
        if range[i].0[axis] == range[i + 1].0[axis] {
            continue;
        }
        let total = left.total_error() + b.moments.subtract(&left).total_error();
        if best.is_none_or(|(e, _, _)| total < e) {
            best = Some((total, i + 1, left));
        }
    }
    let (_, cut, left) = best?;
    let part = |start, end, moments| GroupBox {
        start,
        end,
        moments,
        splittable: end - start > 1,
    };
    Some((
        part(b.start, b.start + cut, left),
        part(b.start + cut, b.end, b.moments.subtract(&left)),
    ))
}
