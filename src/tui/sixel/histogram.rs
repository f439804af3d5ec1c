//! Counting an image's colours: a small open-addressing hash table from each distinct colour to
//! an id (in order of first appearance), and the image as runs of ids. Renders hold hundreds to a
//! few thousand colours; past [`MAX_DISTINCT`] the low bits of each channel are dropped.

/// Most distinct colours counted exactly; beyond that the low bits of each channel are dropped
/// and the image is counted again.
pub const MAX_DISTINCT: usize = 1 << 16;

/// `[r, g, b]` of a packed `0x00BBGGRR` key.
pub fn unpack(key: u32) -> [u8; 3] {
    [key as u8, (key >> 8) as u8, (key >> 16) as u8]
}

/// The distinct colours of an image, in order of first appearance, with their pixel counts.
pub struct ColourTable {
    /// Open-addressing slots: a colour key, or [`EMPTY`].
    slots: Vec<u32>,
    /// The colour id in each slot.
    slot_ids: Vec<u16>,
    /// The colour (packed `0x00BBGGRR`, low bits cleared) of each id.
    pub colours: Vec<u32>,
    /// Pixels of each id.
    pub counts: Vec<u32>,
}

/// An empty hash slot (no packed colour has the top byte set).
const EMPTY: u32 = u32::MAX;

impl ColourTable {
    fn new() -> ColourTable {
        ColourTable {
            slots: vec![EMPTY; 1024],
            slot_ids: vec![0; 1024],
            colours: Vec::new(),
            counts: Vec::new(),
        }
    }

    fn slot_of(&self, key: u32) -> usize {
        let bits = self.slots.len().trailing_zeros();
        (key.wrapping_mul(0x9E37_79B1) >> (32 - bits)) as usize
    }

    /// The id of `key`, inserting it; `None` once [`MAX_DISTINCT`] colours are taken.
    fn id(&mut self, key: u32) -> Option<u16> {
        let mask = self.slots.len() - 1;
        let mut slot = self.slot_of(key);
        loop {
            match self.slots[slot] {
                k if k == key => return Some(self.slot_ids[slot]),
                EMPTY => break,
                _ => slot = (slot + 1) & mask,
            }
        }
        let id = self.colours.len();
        if id == MAX_DISTINCT {
            return None;
        }
        self.colours.push(key);
        self.counts.push(0);
        self.slots[slot] = key;
        self.slot_ids[slot] = id as u16;
        if 2 * self.colours.len() > self.slots.len() {
            self.grow();
        }
        Some(id as u16)
    }

    /// Doubles the slots (ids stay).
    fn grow(&mut self) {
        let size = 2 * self.slots.len();
        self.slots = vec![EMPTY; size];
        self.slot_ids = vec![0; size];
        for (id, &key) in self.colours.iter().enumerate() {
            let mut slot = self.slot_of(key);
            while self.slots[slot] != EMPTY {
                slot = (slot + 1) & (size - 1);
            }
            self.slots[slot] = key;
            self.slot_ids[slot] = id as u16;
        }
    }
}

/// A run of equal pixels (in reading order): the colour id and how many.
pub type Run = (u16, u32);

/// Images smaller than this are counted on one thread.
const SPLIT_PIXELS: usize = 1 << 16;

/// Counts the colours of `rgba` and returns them with the image as runs of equal colour ids.
/// Beyond [`MAX_DISTINCT`] colours the low bits of every channel are dropped (one more bit each
/// time) and the pixels counted again; a dropped-bits key stands for the middle of its range.
/// Large images are counted in two halves on two threads, then merged.
pub fn count_colours(rgba: &[u8]) -> (ColourTable, Vec<Run>) {
    let pixels = rgba.len() / 4;
    (0..8)
        .find_map(|dropped| {
            if pixels < SPLIT_PIXELS {
                return count_part(rgba, dropped);
            }
            let (first, second) = rgba.split_at(pixels / 2 * 4);
            let (a, b) = rayon::join(|| count_part(first, dropped), || count_part(second, dropped));
            merge(a?, b?)
        })
        .expect("with seven bits dropped at most 8 colours remain")
}

/// Counts `rgba` with `dropped` low bits dropped per channel; `None` past [`MAX_DISTINCT`].
fn count_part(rgba: &[u8], dropped: u32) -> Option<(ColourTable, Vec<Run>)> {
    let keep = (0xFFu32 << dropped) & 0xFF;
    let mask = keep << 16 | keep << 8 | keep;
    let half = (1u32 << dropped) >> 1;
    let middle = half << 16 | half << 8 | half;
    let mut table = ColourTable::new();
    let mut runs: Vec<Run> = Vec::with_capacity(rgba.len() / 16);
    // The current run: its key, id and length; and the run before (smooth gradients often
    // return to the previous colour).
    let (mut key, mut id, mut run) = (EMPTY, 0u16, 0u32);
    let mut before = (EMPTY, 0u16);
    for px in rgba.chunks_exact(4) {
        let next = u32::from_le_bytes([px[0], px[1], px[2], px[3]]) & mask | middle;
        if next == key {
            run += 1;
            continue;
        }
        if run > 0 {
            table.counts[usize::from(id)] += run;
            runs.push((id, run));
        }
        let next_id = if next == before.0 {
            before.1
        } else {
            table.id(next)?
        };
        before = (key, id);
        (key, id, run) = (next, next_id, 1);
    }
    if run > 0 {
        table.counts[usize::from(id)] += run;
        runs.push((id, run));
    }
    Some((table, runs))
}

/// The counts of two parts of an image as one; `None` past [`MAX_DISTINCT`].
fn merge(
    (mut table, mut runs): (ColourTable, Vec<Run>),
    (other, other_runs): (ColourTable, Vec<Run>),
) -> Option<(ColourTable, Vec<Run>)> {
    let mut new_id = Vec::with_capacity(other.colours.len());
    for (&key, &count) in other.colours.iter().zip(&other.counts) {
        let id = table.id(key)?;
        table.counts[usize::from(id)] += count;
        new_id.push(id);
    }
    runs.reserve(other_runs.len());
    for (id, n) in other_runs {
        let id = new_id[usize::from(id)];
        match runs.last_mut() {
            Some(last) if last.0 == id => last.1 += n,
            _ => runs.push((id, n)),
        }
    }
    Some((table, runs))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rgba(colours: &[[u8; 3]]) -> Vec<u8> {
        colours.iter().flat_map(|c| [c[0], c[1], c[2], 255]).collect()
    }

    #[test]
    fn every_pixel_gets_its_colours_id_in_order_of_appearance() {
        let (a, b, c) = ([1, 2, 3], [200, 100, 0], [1, 2, 4]);
        let (table, runs) = count_colours(&rgba(&[a, b, b, a, c, a]));
        assert_eq!(runs, vec![(0, 1), (1, 2), (0, 1), (2, 1), (0, 1)]);
        assert_eq!(table.colours, vec![0x030201, 0x0064C8, 0x040201]);
        assert_eq!(table.counts, vec![3, 2, 1]);
        assert_eq!(unpack(table.colours[1]), b);
    }

    #[test]
    fn halves_counted_apart_merge_into_the_same_counts() {
        // 300 × 300 pixels (split in two) of 7 colours in stripes that cross the middle.
        let colours: Vec<[u8; 3]> = (0..90_000u32)
            .map(|i| [(i / 4000 % 7 * 30) as u8, 1, 2])
            .collect();
        assert!(colours.len() >= SPLIT_PIXELS);
        let (table, runs) = count_colours(&rgba(&colours));
        assert_eq!(table.colours.len(), 7);
        // Stripes of 4000 pixels: 23 runs (the one across the split merged back).
        assert_eq!(runs.len(), 90_000usize.div_ceil(4000));
        for (k, &(id, n)) in runs.iter().enumerate() {
            assert_eq!(unpack(table.colours[usize::from(id)]), colours[k * 4000]);
            assert_eq!(n, if k == 22 { 2000 } else { 4000 });
        }
        assert_eq!(table.counts.iter().sum::<u32>(), 90_000);
    }

    #[test]
    fn past_the_limit_low_bits_are_dropped() {
        // 2^17 distinct colours (256 reds × 256 greens × 2 blues): with one bit dropped per
        // channel, 128 × 128 × 1 keys remain.
        let colours: Vec<[u8; 3]> = (0..1u32 << 17)
            .map(|i| [(i & 0xFF) as u8, ((i >> 8) & 0xFF) as u8, (i >> 16) as u8])
            .collect();
        let (table, runs) = count_colours(&rgba(&colours));
        let ids: Vec<u16> = runs
            .iter()
            .flat_map(|&(id, n)| std::iter::repeat_n(id, n as usize))
            .collect();
        assert_eq!(ids.len(), colours.len());
        assert!(table.colours.len() <= MAX_DISTINCT);
        assert_eq!(table.colours.len(), 128 * 128);
        // Pixels (3, 2, 0) and (2, 2, 0) share the key of the middle of their ranges, (3, 3, 1).
        assert_eq!(unpack(table.colours[usize::from(ids[0x0203])]), [3, 3, 1]);
        assert_eq!(ids[0x0202], ids[0x0203]);
        assert_eq!(
            table.counts.iter().map(|&c| c as usize).sum::<usize>(),
            colours.len()
        );
    }
}
