//! The photo tone curve, and its table: sRGB8 of an exposed luminance `x ≥ 0` without a
//! division or a power per pixel.
//!
//! The curve ([`tone_curve`]): up to mid-grey `x_m = 0.18 / 0.82` it is Reinhard's `x / (1 + x)`
//! then the sRGB transfer, so a surface at the key luminance shows at display value 0.18 (sRGB8
//! 118). Above it a highlight shoulder in stops: the encoded value approaches white as
//! `v = 1 − (1 − v_m) · exp(−s / S)` with `s = log₂(x / x_m)` and `S` chosen so that the curve's
//! slope is continuous at mid-grey (S ≈ 4.4 stops). Every stop above mid-grey keeps about 80 % of
//! the levels of the one below, so a spot pool 5 stops above the key still shows its gradient
//! (≈ 10 sRGB8 levels per stop there) instead of clipping to flat white as Reinhard does; sRGB8
//! 255 is reached about 25 stops above mid-grey.
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
pub const MAX_EXPONENT: i32 = 26;

const SHIFT: u32 = 23 - MANTISSA_BITS;
const FIRST_INDEX: i32 = (127 + MIN_EXPONENT) << MANTISSA_BITS;
const TABLE_SIZE: usize = ((MAX_EXPONENT - MIN_EXPONENT) as usize) << MANTISSA_BITS;

static TABLE: LazyLock<[u8; TABLE_SIZE]> = LazyLock::new(|| {
    std::array::from_fn(|i| {
        let lo = f64::from(f32::from_bits(((FIRST_INDEX + i as i32) as u32) << SHIFT));
        let hi = f64::from(f32::from_bits(((FIRST_INDEX + i as i32 + 1) as u32) << SHIFT));
        (tone_curve((lo * hi).sqrt()) * 255.0).round() as u8
    })
});

/// Exposed luminance shown as mid-grey (display value 0.18 under Reinhard).
const X_MID: f64 = 0.18 / 0.82;

/// The encoded display value (sRGB, 0–1) of an exposed luminance `x ≥ 0` (module docs).
pub fn tone_curve(x: f64) -> f64 {
    if x.is_nan() || x <= 0.0 {
        return 0.0;
    }
    if x <= X_MID {
        return srgb_encode(x / (1.0 + x));
    }
    let v_mid = srgb_encode(X_MID / (1.0 + X_MID));
    (1.0 - (1.0 - v_mid) * (-(x / X_MID).log2() / shoulder_stops()).exp()).min(1.0)
}

/// The shoulder's e-folding length in stops: `(1 − v_m) / (dv/ds at mid-grey)`, where the
/// Reinhard + sRGB branch has slope `dv/ds = sRGB'(y) · x ln 2 / (1 + x)²` at `x_m`.
pub fn shoulder_stops() -> f64 {
    let y = X_MID / (1.0 + X_MID);
    let srgb_slope = 1.055 / 2.4 * y.powf(1.0 / 2.4 - 1.0);
    let slope_per_stop = srgb_slope * X_MID * std::f64::consts::LN_2 / (1.0 + X_MID).powi(2);
    (1.0 - srgb_encode(y)) / slope_per_stop
}

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
        (tone_curve(x) * 255.0).round() as u8
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

    /// Below mid-grey the curve is Reinhard + sRGB; at mid-grey value and slope (per stop) are
    /// continuous; above, every quarter stop up to 8 stops gets at least one sRGB8 level of its
    /// own, and 5 stops above mid-grey is far from white.
    #[test]
    fn the_shoulder_continues_reinhard_smoothly_and_keeps_highlights_apart() {
        for x in [1e-4, 0.01, 0.1, 0.2, X_MID] {
            assert!(
                (tone_curve(x) - srgb_encode(x / (1.0 + x))).abs() < 1e-15,
                "x = {x}"
            );
        }
        let reinhard = |x: f64| srgb_encode(x / (1.0 + x));
        let h: f64 = 1e-6;
        let below = (reinhard(X_MID) - reinhard(X_MID * (-h).exp2())) / h;
        let above = (tone_curve(X_MID * h.exp2()) - tone_curve(X_MID)) / h;
        assert!(
            (below - above).abs() < 1e-4 * below,
            "slopes {below} and {above} per stop"
        );
        assert!((shoulder_stops() - 4.4).abs() < 0.05, "{}", shoulder_stops());
        let level = |stops: f64| (tone_curve(X_MID * stops.exp2()) * 255.0).round();
        for q in 0..32 {
            let s = f64::from(q) / 4.0;
            assert!(
                level(s + 0.25) > level(s),
                "{s} stops: {} vs {}",
                level(s),
                level(s + 0.25)
            );
        }
        assert_eq!(level(5.0), 211.0);
        assert!(
            reinhard(X_MID * 32.0) * 255.0 > 240.0,
            "Reinhard alone is near white there"
        );
    }
}
