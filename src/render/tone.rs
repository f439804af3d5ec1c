//! The photo tone curve, and its table: sRGB8 of an exposed luminance `x ≥ 0` without a
//! division or a power per pixel.
//!
//! The curve ([`tone_curve`]): up to mid-grey `x_m = 0.18 / 0.82` it is Reinhard's `x / (1 + x)`
//! then the sRGB transfer, so a surface at the key luminance shows at display value 0.18 (sRGB8
//! 118). Above mid-grey the encoded value rises **linearly in stops** `s = log₂(x / x_m)`,
//! reaching 90 % of the way to white [`HIGHLIGHT_STOPS`] × 0.9 stops up, then bends into white
//! with a continuous slope (`1 − v` decays exponentially). Every stop up to 6.3 stops above the
//! key gets the same ≈ 20 sRGB8 levels, so a spot pool 6 stops above the key shows its gradient
//! where Reinhard leaves it at 247–251 (≈ 4 levels per stop), nearly flat white; sRGB8 255 is
//! reached about 9 stops above mid-grey. (An exponential shoulder from mid-grey cannot do this:
//! at 6 stops it gives at most ≈ 8 levels per stop.)
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

/// Stops above mid-grey at which the linear part of the highlights would reach white.
pub const HIGHLIGHT_STOPS: f64 = 7.0;

/// Fraction of the range above mid-grey covered linearly before the bend into white.
const KNEE_FRACTION: f64 = 0.9;

/// The encoded display value (sRGB, 0–1) of an exposed luminance `x ≥ 0` (module docs).
pub fn tone_curve(x: f64) -> f64 {
    if x.is_nan() || x <= 0.0 {
        return 0.0;
    }
    if x <= X_MID {
        return srgb_encode(x / (1.0 + x));
    }
    let v_mid = srgb_encode(X_MID / (1.0 + X_MID));
    let per_stop = (1.0 - v_mid) / HIGHLIGHT_STOPS;
    let knee_stops = KNEE_FRACTION * HIGHLIGHT_STOPS;
    let stops = (x / X_MID).log2();
    if stops <= knee_stops {
        return v_mid + per_stop * stops;
    }
    let v_knee = v_mid + per_stop * knee_stops;
    1.0 - (1.0 - v_knee) * (-(stops - knee_stops) * per_stop / (1.0 - v_knee)).exp()
}

/// The tone table, for callers that look up many values (one lazy-init check).
#[inline]
pub fn table() -> &'static [u8; TABLE_SIZE] {
    &TABLE
}

/// sRGB8 of [`tone_curve`] for an exposed luminance `x` (negative and NaN show black), by
/// `table` (from [`table`]).
#[inline(always)]
pub fn tone_srgb8(table: &[u8; TABLE_SIZE], x: f32) -> u8 {
    // max() maps NaN and negatives to 0, whose bits index below the table: black.
    let bin = (x.max(0.0).to_bits() >> SHIFT) as i32 - FIRST_INDEX;
    table[bin.clamp(0, TABLE_SIZE as i32 - 1) as usize]
}

/// As [`tone_srgb8`] for an `x` known to be ≥ +0 and not NaN (an exposed, composed
/// illuminance): three integer operations and the table load, for the shading loop.
#[inline(always)]
pub fn tone_srgb8_lit(table: &[u8; TABLE_SIZE], x: f32) -> u8 {
    let bin = (x.to_bits() >> SHIFT).saturating_sub(FIRST_INDEX as u32);
    table[(bin as usize).min(TABLE_SIZE - 1)]
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

    #[test]
    fn the_lit_entry_agrees_with_the_general_one_for_every_non_negative_value() {
        let t = table();
        for x in [
            0.0,
            f32::MIN_POSITIVE,
            1e-30,
            1e-7,
            0.18 / 0.82,
            1e7,
            1e30,
            f32::MAX,
            f32::INFINITY,
        ] {
            assert_eq!(tone_srgb8_lit(t, x), tone_srgb8(t, x), "x = {x}");
        }
        for k in 0..=100_000 {
            let x = 10f32.powf(-9.0 + 18.0 * k as f32 / 100_000.0);
            assert_eq!(tone_srgb8_lit(t, x), tone_srgb8(t, x), "x = {x}");
        }
    }

    /// Below mid-grey the curve is Reinhard + sRGB; above it every stop up to 6 gets about
    /// 20 levels (every quarter stop up to 7 stops at least one of its own); value and slope
    /// are continuous at the knee; 255 only from about 9 stops up.
    #[test]
    fn highlights_rise_evenly_in_stops_and_bend_smoothly_into_white() {
        let reinhard = |x: f64| srgb_encode(x / (1.0 + x));
        for x in [1e-4, 0.01, 0.1, 0.2, X_MID] {
            assert!((tone_curve(x) - reinhard(x)).abs() < 1e-15, "x = {x}");
        }
        let at = |stops: f64| tone_curve(X_MID * stops.exp2());
        let level = |stops: f64| (at(stops) * 255.0).round();
        assert!((at(1e-9) - at(0.0)).abs() < 1e-9, "continuous at mid-grey");
        for s in 0..6 {
            let gained = level(f64::from(s) + 1.0) - level(f64::from(s));
            assert!((19.0..=20.0).contains(&gained), "stop {s}: {gained} levels");
        }
        for q in 0..28 {
            let s = f64::from(q) / 4.0;
            assert!(
                level(s + 0.25) > level(s),
                "{s} stops: {} vs {}",
                level(s),
                level(s + 0.25)
            );
        }
        let knee = KNEE_FRACTION * HIGHLIGHT_STOPS;
        let h = 1e-7;
        let (left, right) = ((at(knee) - at(knee - h)) / h, (at(knee + h) - at(knee)) / h);
        assert!(
            (left - right).abs() < 1e-5 * left,
            "slopes {left} and {right} at the knee"
        );
        assert!(level(8.0) < 255.0 && level(9.5) == 255.0);
        // Six stops above the key, Reinhard has 4 levels per stop left; this curve 20.
        let reinhard_levels = ((reinhard(X_MID * 128.0) - reinhard(X_MID * 64.0)) * 255.0).round();
        assert!(reinhard_levels <= 4.0, "{reinhard_levels}");
    }
}
