//! Counting an image's colours: a small open-addressing hash table from each distinct colour to
//! an id (in order of first appearance), and the id of every pixel. Renders hold hundreds to a
//! few thousand colours; past [`MAX_DISTINCT`] the low bits of each channel are dropped.

/// Most distinct colours counted exactly; beyond that the low bits of each channel are dropped
/// and the image is counted again.
pub const MAX_DISTINCT: usize = 1 << 16;

/// `[r, g, b]` of a packed `0x00RRGGBB` key.
pub fn unpack(key: u32) -> [u8; 3] {
    [(key >> 16) as u8, (key >> 8) as u8, key as u8]
}

/// The distinct colours of an image, in order of first appearance, with their pixel counts.
pub struct ColourTable {
    /// Open-addressing slots: a colour key, or [`EMPTY`].
    slots: Vec<u32>,
    /// The colour id in each slot.
    slot_ids: Vec<u16>,
    /// The colour (packed `0x00RRGGBB`, low bits cleared) of each id.
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

/// Counts the colours of `rgba` and gives each pixel its colour id. Beyond [`MAX_DISTINCT`]
/// colours the low bits of every channel are dropped (one more bit each time) and the pixels
/// counted again; a dropped-bits key stands for the middle of its range.
pub fn count_colours(rgba: &[u8]) -> (ColourTable, Vec<u16>) {
    let mut dropped = 0u32;
    loop {
        let keep = (0xFFu32 << dropped) & 0xFF;
        let mask = keep << 16 | keep << 8 | keep;
        let half = (1u32 << dropped) >> 1;
        let middle = half << 16 | half << 8 | half;
        let mut table = ColourTable::new();
        let mut ids = Vec::with_capacity(rgba.len() / 4);
        let mut previous = (EMPTY, 0u16);
        let mut complete = true;
        for px in rgba.chunks_exact(4) {
            let key = (u32::from(px[0]) << 16 | u32::from(px[1]) << 8 | u32::from(px[2])) & mask | middle;
            let id = if key == previous.0 {
                previous.1
            } else {
                match table.id(key) {
                    Some(id) => {
                        previous = (key, id);
                        id
                    }
                    None => {
                        complete = false;
                        break;
                    }
                }
            };
            table.counts[usize::from(id)] += 1;
            ids.push(id);
        }
        if complete {
            return (table, ids);
        }
        dropped += 1;
    }
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
        let (table, ids) = count_colours(&rgba(&[a, b, b, a, c, a]));
        assert_eq!(ids, vec![0, 1, 1, 0, 2, 0]);
        assert_eq!(table.colours, vec![0x010203, 0xC86400, 0x010204]);
        assert_eq!(table.counts, vec![3, 2, 1]);
        assert_eq!(unpack(table.colours[1]), b);
    }

    #[test]
    fn past_the_limit_low_bits_are_dropped() {
        // 2^17 distinct colours (256 reds × 256 greens × 2 blues): with one bit dropped per
        // channel, 128 × 128 × 1 keys remain.
        let colours: Vec<[u8; 3]> = (0..1u32 << 17)
            .map(|i| [(i & 0xFF) as u8, ((i >> 8) & 0xFF) as u8, (i >> 16) as u8])
            .collect();
        let (table, ids) = count_colours(&rgba(&colours));
        assert_eq!(ids.len(), colours.len());
        assert!(table.colours.len() <= MAX_DISTINCT);
        assert_eq!(table.colours.len(), 128 * 128);
        // Pixels (3, 2, 0) and (2, 2, 0) share the key of the middle of their ranges, (3, 3, 1).
        assert_eq!(table.colours[usize::from(ids[0x0203])], 0x03_0301);
        assert_eq!(ids[0x0202], ids[0x0203]);
        assert_eq!(
            table.counts.iter().map(|&c| c as usize).sum::<usize>(),
            colours.len()
        );
    }
}
