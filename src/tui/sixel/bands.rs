//! Sixel bands: an [`Indexed`] image written as DEC sixel data, six rows at a time
//! (docs/DECISIONS.md "Terminal graphics").
//!
//! In each band every colour's columns are cut into segments (a gap of [`SEGMENT_GAP`] empty
//! columns or more starts a new one), and segments whose columns do not overlap are packed into
//! one pass, left to right, so a pass needs neither a carriage return (`$`) nor a run of empty
//! columns per colour. The first pass of a band is painted solid (all six rows of each
//! segment): every pixel it paints wrongly belongs to a segment of a later pass, which paints
//! it over, and solid runs compress to a few bytes (`!940~`). Runs of equal sixels are written
//! as `!count char`.

use rayon::prelude::*;

use super::flatten::uniform_columns;
use super::palette::Indexed;

/// Empty columns after which a colour's run of columns is cut into a new segment (an empty run
/// costs `!n?`, 3–5 bytes, about what starting a segment costs).
const SEGMENT_GAP: usize = 10;

/// Bands encoded by one task of the thread pool.
pub const BANDS_PER_TASK: usize = 8;

/// The sixel data of `image`: one string per band joined by `-` (graphics new line), without
/// the introducer, raster attributes or palette.
pub fn encode_bands(image: &Indexed) -> String {
    let width = image.width;
    if width == 0 || image.height == 0 {
        return String::new();
    }
    let chunks: Vec<String> = image
        .indices
        .par_chunks(6 * BANDS_PER_TASK * width)
        .map(|rows| {
            let mut scratch = Scratch::default();
            let mut out = String::new();
            for (i, band) in rows.chunks(6 * width).enumerate() {
                if i > 0 {
                    out.push('-');
                }
                scratch.encode(band, width, &mut out);
            }
            out
        })
        .collect();
    chunks.join("-")
}

/// A colour's columns in a band: `entries[first..last]` of the band's sorted entries.
#[derive(Debug, Clone, Copy)]
struct Segment {
    colour: u8,
    /// First column.
    start: usize,
    /// One past the last column.
    end: usize,
    first: usize,
    last: usize,
}

/// A run of equal sixels of one colour: the first column, how many, the colour and which of the
/// six rows they paint.
#[derive(Debug, Clone, Copy, Default)]
struct Entry {
    x: u32,
    len: u32,
    colour: u8,
    mask: u8,
}

impl Entry {
    /// One past the last column.
    fn end(self) -> u32 {
        self.x + self.len
    }
}

/// Buffers reused from band to band.
#[derive(Default)]
struct Scratch {
    entries: Vec<Entry>,
    sorted: Vec<Entry>,
    segments: Vec<Segment>,
    used: Vec<bool>,
    uniform: Vec<bool>,
    /// The entries painting the previous column, and the current one's.
    previous: Vec<usize>,
    current: Vec<usize>,
}

impl Scratch {
    /// Appends the sixel data of one band (`band.len() / width` rows, 1 to 6) to `out`.
    fn encode(&mut self, band: &[u8], width: usize, out: &mut String) {
        let rows = band.len() / width;
        let full = (1u8 << rows) - 1;
        self.gather(band, width, rows, full);
        self.sort_by_colour();
        self.cut_segments();
        self.write_passes(full, out);
    }

    /// The entries of each colour of each column, in column order; a colour's equal sixels in
    /// neighbouring columns merged into one entry (a dithered band repeats the same few sixels
    /// along a row).
    fn gather(&mut self, band: &[u8], width: usize, rows: usize, full: u8) {
        self.entries.clear();
        uniform_columns(band, width, &mut self.uniform);
        let (mut previous, mut current) = (
            std::mem::take(&mut self.previous),
            std::mem::take(&mut self.current),
        );
        previous.clear();
        let mut x = 0;
        while x < width {
            if self.uniform[x] {
                // A run of columns all of one colour.
                let (start, colour) = (x, band[x]);
                x += 1;
                while x < width && self.uniform[x] && band[x] == colour {
                    x += 1;
                }
                self.push(start as u32, (x - start) as u32, colour, full);
                previous.clear();
                previous.push(self.entries.len() - 1);
                continue;
            }
            // The same colours as the column before (which was not uniform): its entries grow.
            if x > 0
                && !self.uniform[x - 1]
                && (0..rows).all(|r| band[r * width + x] == band[r * width + x - 1])
            {
                for &i in &previous {
                    self.entries[i].len += 1;
                }
                x += 1;
                continue;
            }
            let mut column: [(u8, u8); 6] = [(0, 0); 6];
            let mut n = 0;
            for r in 0..rows {
                let colour = band[r * width + x];
                match column[..n].iter_mut().find(|(c, _)| *c == colour) {
                    Some((_, mask)) => *mask |= 1 << r,
                    None => {
                        column[n] = (colour, 1 << r);
                        n += 1;
                    }
                }
            }
            current.clear();
            for &(colour, mask) in &column[..n] {
                let extends = previous.iter().copied().find(|&i| {
                    let e = self.entries[i];
                    e.colour == colour && e.mask == mask && e.end() == x as u32
                });
                match extends {
                    Some(i) => {
                        self.entries[i].len += 1;
                        current.push(i);
                    }
                    None => {
                        self.entries.push(Entry {
                            x: x as u32,
                            len: 1,
                            colour,
                            mask,
                        });
                        current.push(self.entries.len() - 1);
                    }
                }
            }
            std::mem::swap(&mut previous, &mut current);
            x += 1;
        }
        (self.previous, self.current) = (previous, current);
    }

    /// Appends an entry, extending the last entry when it is the same sixel just before.
    fn push(&mut self, x: u32, len: u32, colour: u8, mask: u8) {
        if let Some(last) = self.entries.last_mut()
            && last.colour == colour
            && last.mask == mask
            && last.end() == x
        {
            last.len += len;
            return;
        }
        self.entries.push(Entry { x, len, colour, mask });
    }

    /// `sorted`: the entries grouped by colour (a counting sort, so each colour's entries stay
    /// in column order).
    fn sort_by_colour(&mut self) {
        let mut starts = [0usize; 257];
        for e in &self.entries {
            starts[usize::from(e.colour) + 1] += 1;
        }
        for c in 0..256 {
            starts[c + 1] += starts[c];
        }
        self.sorted.clear();
        self.sorted.resize(self.entries.len(), Entry::default());
        for e in &self.entries {
            let at = &mut starts[usize::from(e.colour)];
            self.sorted[*at] = *e;
            *at += 1;
        }
    }

    /// Cuts each colour's entries into segments, ordered by first column (longest first).
    fn cut_segments(&mut self) {
        self.segments.clear();
        let mut i = 0;
        while i < self.sorted.len() {
            let first = i;
            let colour = self.sorted[i].colour;
            i += 1;
            while i < self.sorted.len()
                && self.sorted[i].colour == colour
                && ((self.sorted[i].x - self.sorted[i - 1].end()) as usize) < SEGMENT_GAP
            {
                i += 1;
            }
            self.segments.push(Segment {
                colour,
                start: self.sorted[first].x as usize,
                end: self.sorted[i - 1].end() as usize,
                first,
                last: i,
            });
        }
        self.segments
            .sort_unstable_by_key(|s| (s.start, std::cmp::Reverse(s.end)));
    }

    /// Packs the segments into passes and writes them; the first pass solid.
    fn write_passes(&mut self, full: u8, out: &mut String) {
        self.used.clear();
        self.used.resize(self.segments.len(), false);
        let mut first_unused = 0;
        let mut pass = 0;
        while first_unused < self.segments.len() {
            if pass > 0 {
                out.push('$');
            }
            let mut x = 0;
            for s in first_unused..self.segments.len() {
                let segment = self.segments[s];
                if self.used[s] || segment.start < x {
                    continue;
                }
                self.used[s] = true;
                out.push('#');
                push_number(out, usize::from(segment.colour));
                let mut runs = Runs::new(x);
                if pass == 0 {
                    runs.skip_to(segment.start, out);
                    runs.repeat(full, segment.end - segment.start, out);
                } else {
                    for e in &self.sorted[segment.first..segment.last] {
                        runs.skip_to(e.x as usize, out);
                        runs.repeat(e.mask, e.len as usize, out);
                    }
                }
                runs.flush(out);
                x = segment.end;
            }
            while first_unused < self.segments.len() && self.used[first_unused] {
                first_unused += 1;
            }
            pass += 1;
        }
    }
}

/// Sixels written as runs: a pending sixel repeated `count` times, flushed when another follows.
struct Runs {
    /// The column the next sixel lands in.
    x: usize,
    mask: u8,
    count: usize,
}

impl Runs {
    fn new(x: usize) -> Runs {
        Runs { x, mask: 0, count: 0 }
    }

    /// Empty sixels up to column `to`.
    fn skip_to(&mut self, to: usize, out: &mut String) {
        if to > self.x {
            let gap = to - self.x;
            self.repeat(0, gap, out);
        }
    }

    /// The sixel painting rows `mask`, `count` times.
    fn repeat(&mut self, mask: u8, count: usize, out: &mut String) {
        if mask != self.mask {
            self.flush(out);
            self.mask = mask;
        }
        self.count += count;
        self.x += count;
    }

    fn flush(&mut self, out: &mut String) {
        let sixel = char::from(63 + self.mask);
        match self.count {
            0 => {}
            1..=3 => (0..self.count).for_each(|_| out.push(sixel)),
            n => {
                out.push('!');
                push_number(out, n);
                out.push(sixel);
            }
        }
        self.count = 0;
    }
}

/// Appends the decimal digits of `n`.
pub fn push_number(out: &mut String, n: usize) {
    let mut digits = [0u8; 20];
    let mut i = digits.len();
    let mut n = n;
    loop {
        i -= 1;
        digits[i] = b'0' + (n % 10) as u8;
        n /= 10;
        if n == 0 {
            break;
        }
    }
    for &d in &digits[i..] {
        out.push(char::from(d));
    }
}
