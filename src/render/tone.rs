//! The photo tone curve by table: sRGB8 of the Reinhard curve `x / (1 + x)` of an exposed
//! luminance `x ≥ 0`, without a division or a power per pixel.
//!
//! The table is indexed by the bits of the f32 `x`: its exponent and top [`MANTISSA_BITS`]
//! mantissa bits, i.e. `x` on a logarithmic grid with 256 steps per octave (bins 0.27 % wide).
//! Each entry is the exact sRGB8 value at its bin's geometric centre, so a result is off by at
//! most one sRGB8 level, and only where `x` lies near a level boundary. `x` below
//! 2^[`MIN_EXPONENT`] shows black, above 2^[`MAX_EXPONENT`] white (the exact values are 0 and
//! 255 there too).

use std::sync::LazyLock;

use super::shade::srgb_encode;

/// Mantissa bits kept in the table index.
pub const MANTISSA_BITS: u32 = 8;
/// Smallest binary exponent of `x` in the table.
pub const MIN_EXPONENT: i32 = -20;
/// One past the largest binary exponent of `x` in the table.
pub const MAX_EXPONENT: i32 = 16;

const SHIFT: u32 = 23 - MANTISSA_BITS;
const FIRST_INDEX: i32 = (127 + MIN_EXPONENT) << MANTISSA_BITS;
const TABLE_SIZE: usize = ((MAX_EXPONENT - MIN_EXPONENT) as usize) << MANTISSA_BITS;

static TABLE: LazyLock<[u8; TABLE_SIZE]> = LazyLock::new(|| {
    std::array::from_fn(|i| {
        let lo = f64::from(f32::from_bits(((FIRST_INDEX + i as i32) as u32) << SHIFT));
        let hi = f64::from(f32::from_bits(((FIRST_INDEX + i as i32 + 1) as u32) << SHIFT));
        let x = (lo * hi).sqrt();
        (srgb_encode(x / (1.0 + x)) * 255.0).round() as u8
    })
});

/// The tone table, for callers that look up many values (one lazy-init check).
#[inline]
pub fn table() -> &'static [u8; TABLE_SIZE] {
    &TABLE
}

/// sRGB8 of `x / (1 + x)` for an exposed luminance `x` (negative and NaN show black), by
/// `table` (from [`table`]).
#[inline(always)]
pub fn tone_srgb8(table: &[u8; TABLE_SIZE], x: f32) -> u8 {
    // max() maps NaN and negatives to 0, whose bits index below the table: black.
    let bin = (x.max(0.0).to_bits() >> SHIFT) as i32 - FIRST_INDEX;
    table[bin.clamp(0, TABLE_SIZE as i32 - 1) as usize]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn exact(x: f64) -> u8 {
        (srgb_encode(x / (1.0 + x)) * 255.0).round() as u8
    }

    #[test]
    fn table_is_within_one_level_of_the_exact_curve_and_monotone() {
        let t = table();
        let mut previous = 0;
        let mut off = 0;
        for k in 0..=200_000 {
            // 1e-8 … 1e8 on a log grid.
            let x = 10f64.powf(-8.0 + 16.0 * f64::from(k) / 200_000.0);
            let by_table = tone_srgb8(t, x as f32);
            let reference = exact(x);
            assert!(
                by_table.abs_diff(reference) <= 1,
                "x = {x}: {by_table} vs {reference}"
            );
            off += usize::from(by_table != reference);
            assert!(by_table >= previous, "not monotone at x = {x}");
            previous = by_table;
        }
        assert!(off < 2_000, "{off} of 200001 values off by one");
    }

    #[test]
    fn ends_and_bad_values() {
        let t = table();
        assert_eq!(tone_srgb8(t, 0.0), 0);
        assert_eq!(tone_srgb8(t, -3.0), 0);
        assert_eq!(tone_srgb8(t, f32::NAN), 0);
        assert_eq!(tone_srgb8(t, f32::INFINITY), 255);
        assert_eq!(tone_srgb8(t, 1e30), 255);
        // Mid-grey: x = 0.18 / 0.82 gives display value 0.18, sRGB8 118.
        assert_eq!(tone_srgb8(t, 0.18 / 0.82), 118);
    }
}
