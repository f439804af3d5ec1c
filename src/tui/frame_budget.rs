//! How big a preview frame may be (docs/DECISIONS.md "Terminal graphics"): while keys repeat,
//! interactive frames at a reduced resolution that stay under a byte budget; once input has
//! been idle for [`IDLE_FOR_FULL`], the full-resolution frame.
//!
//! The budget is fixed (`--frame-budget 64k`) or estimated ([`Budget::Auto`], the default):
//! [`DEFAULT_BUDGET`] until the terminal has been measured, then what it drains in
//! [`FRAME_INTERVAL`] at the rate measured over the last large writes (a write blocks once the
//! terminal, or the SSH connection behind it, stops taking bytes as fast as they come).
//!
//! The reduction is an integer divisor of the full frame's pixel size, chosen from the bytes
//! frames at each divisor were seen to take (scaled by pixel count from the nearest divisor
//! seen, or from [`prior_bytes_per_pixel`] before any frame).

use std::time::Duration;

use crate::error::{Error, Result};

/// Bytes one interactive frame may take unless told or measured otherwise (for a 160 × 48 cell
/// terminal: a 940 × 880 px preview).
pub const DEFAULT_BUDGET: usize = 64 * 1024;
/// The smallest budget the estimate goes down to.
pub const MIN_BUDGET: usize = 8 * 1024;
/// Input idle for this long: the next frame is the full one.
pub const IDLE_FOR_FULL: Duration = Duration::from_millis(150);
/// The time an interactive frame may take to drain (about the key repeat interval).
pub const FRAME_INTERVAL: Duration = Duration::from_millis(50);
/// Writes smaller than this say nothing about the drain rate (the pty buffers them).
pub const MIN_SAMPLE_BYTES: usize = 16 * 1024;
/// Writes remembered for the drain rate.
const RATE_WINDOW: usize = 8;
/// The divisors an interactive frame may use, finest first.
pub const DIVISORS: [u32; 6] = [1, 2, 3, 4, 6, 8];

/// The byte budget of an interactive frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Budget {
    /// At most this many bytes.
    Bytes(usize),
    /// Estimated from the drain rate.
    Auto,
}

impl Budget {
    /// Parses `auto` or a size: `65536`, `64k`, `64KiB`, `1m` (k and m are 1024 and 1024²).
    ///
    /// Errors (bad input, naming `flag`): anything else, or less than 1 KiB.
    pub fn parse(flag: &str, text: &str) -> Result<Budget> {
        let lower = text.trim().to_ascii_lowercase();
        if lower == "auto" {
            return Ok(Budget::Auto);
        }
        let digits = lower.trim_end_matches(|c: char| c.is_ascii_alphabetic());
        let unit = match &lower[digits.len()..] {
            "" | "b" => 1,
            "k" | "kb" | "kib" => 1024,
            "m" | "mb" | "mib" => 1024 * 1024,
            _ => 0,
        };
        match digits.trim().parse::<usize>() {
            Ok(n) if unit > 0 && n * unit >= 1024 => Ok(Budget::Bytes(n * unit)),
            _ => Err(Error::input(
                flag,
                "",
                format!("`{text}` is not a frame budget: give `auto` or a size of at least 1k, e.g. `64k`"),
            )),
        }
    }
}

/// A full frame's bytes a sixel frame is dithered within (docs/DECISIONS.md "Terminal
/// graphics": dithering hides sixel's one-percent steps).
pub const FULL_TARGET: usize = 100 * 1024;
/// How much larger a dithered sixel frame ([`crate::tui::sixel::Quality::DITHERED`]) is than a
/// flattened one (measured at 940 × 640: 1.24 in the office, 1.3 in the paper room).
pub const DITHER_GROWTH: f64 = 1.3;

/// Which frame to send next.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FramePlan {
    /// The full-resolution frame; for sixel dithered when `dither` is set.
    Full {
        /// Dither (sixel): expected to fit [`FULL_TARGET`].
        dither: bool,
    },
    /// A frame at 1 / `divisor` of the full resolution in each direction.
    Interactive {
        /// The reduction, one of [`DIVISORS`].
        divisor: u32,
    },
}

impl FramePlan {
    /// The divisor (1 for the full frame).
    pub fn divisor(self) -> u32 {
        match self {
            FramePlan::Full { .. } => 1,
            FramePlan::Interactive { divisor } => divisor,
        }
    }

    /// The pixel size to render for a full frame of `full` (width, height) pixels: each side
    /// divided, rounded up.
    pub fn size(self, full: (u32, u32)) -> (u32, u32) {
        let d = self.divisor();
        (full.0.div_ceil(d).max(1), full.1.div_ceil(d).max(1))
    }
}

/// The bytes per full-frame pixel assumed before any frame was measured, by the kind of
/// protocol: compressed images (`compressed`: PNG, zlib, sixel's run lengths) about 0.1, raw
/// RGBA in base64 about 5.4.
pub fn prior_bytes_per_pixel(compressed: bool) -> f64 {
    if compressed { 0.1 } else { 5.4 }
}

/// The frame size policy of one editor session.
#[derive(Debug, Clone)]
pub struct FrameBudget {
    budget: Budget,
    /// Bytes per full-frame pixel last seen at each divisor of [`DIVISORS`].
    seen: [Option<f64>; DIVISORS.len()],
    prior: f64,
    /// The last large writes: (bytes, seconds).
    writes: Vec<(usize, f64)>,
    /// The last full frame's bytes, and whether it was dithered.
    last_full: Option<(usize, bool)>,
}

impl FrameBudget {
    /// A policy with `budget`, assuming `prior` bytes per pixel ([`prior_bytes_per_pixel`])
    /// until frames are measured.
    pub fn new(budget: Budget, prior: f64) -> FrameBudget {
        FrameBudget {
            budget,
            seen: [None; DIVISORS.len()],
            prior,
            writes: Vec::new(),
            last_full: None,
        }
    }

    /// The measured drain rate, bytes per second, once large writes were seen.
    pub fn drain_rate(&self) -> Option<f64> {
        let (bytes, seconds) = self
            .writes
            .iter()
            .fold((0usize, 0.0), |(b, s), &(bytes, seconds)| {
                (b + bytes, s + seconds)
            });
        (bytes > 0 && seconds > 0.0).then(|| bytes as f64 / seconds)
    }

    /// The byte budget of an interactive frame now.
    pub fn budget_bytes(&self) -> usize {
        match self.budget {
            Budget::Bytes(bytes) => bytes,
            Budget::Auto => match self.drain_rate() {
                Some(rate) => ((rate * FRAME_INTERVAL.as_secs_f64()) as usize).max(MIN_BUDGET),
                None => DEFAULT_BUDGET,
            },
        }
    }

    /// The bytes expected for a frame of `pixels` full-frame pixels at `DIVISORS[index]`.
    fn expected_bytes(&self, index: usize, pixels: f64) -> f64 {
        if let Some(per_pixel) = self.seen[index] {
            return per_pixel * pixels;
        }
        // The nearest divisor seen, scaled by the pixel count (1 / d²).
        let nearest = (0..DIVISORS.len())
            .filter_map(|i| self.seen[i].map(|p| (i, p)))
            .min_by_key(|&(i, _)| i.abs_diff(index));
        let d = f64::from(DIVISORS[index]);
        match nearest {
            Some((i, per_pixel)) => per_pixel * pixels * (f64::from(DIVISORS[i]) / d).powi(2),
            None => self.prior * pixels / (d * d),
        }
    }

    /// True when the next full frame is expected to fit [`FULL_TARGET`] dithered: the last
    /// dithered one did, or the last flat one times [`DITHER_GROWTH`] does. The first full
    /// frame is dithered (most rooms fit).
    pub fn dither_full(&self) -> bool {
        match self.last_full {
            Some((bytes, true)) => bytes <= FULL_TARGET,
            Some((bytes, false)) => bytes as f64 * DITHER_GROWTH <= FULL_TARGET as f64,
            None => true,
        }
    }

    /// The frame to send after `input_idle` without input, for a full frame of `full` pixels:
    /// the full frame once idle for [`IDLE_FOR_FULL`], else the finest divisor expected to fit
    /// the budget (the coarsest when none does).
    pub fn plan(&self, input_idle: Duration, full: (u32, u32)) -> FramePlan {
        if input_idle >= IDLE_FOR_FULL {
            return FramePlan::Full {
                dither: self.dither_full(),
            };
        }
        let pixels = f64::from(full.0) * f64::from(full.1);
        let budget = self.budget_bytes() as f64;
        let index = (0..DIVISORS.len())
            .find(|&i| self.expected_bytes(i, pixels) <= budget)
            .unwrap_or(DIVISORS.len() - 1);
        FramePlan::Interactive {
            divisor: DIVISORS[index],
        }
    }

    /// How long until the full frame is due after `input_idle` without input (zero: now).
    pub fn full_frame_in(&self, input_idle: Duration) -> Duration {
        IDLE_FOR_FULL.saturating_sub(input_idle)
    }

    /// Records a frame sent with `plan` for a full frame of `full` pixels: `bytes` written in
    /// `write_time` (from the first byte to the last accepted by the terminal).
    pub fn record(&mut self, plan: FramePlan, full: (u32, u32), bytes: usize, write_time: Duration) {
        let pixels = f64::from(full.0) * f64::from(full.1);
        if let FramePlan::Full { dither } = plan {
            self.last_full = Some((bytes, dither));
        }
        // Dithered frames say nothing about the flat interactive ones.
        if let Some(index) = DIVISORS.iter().position(|&d| d == plan.divisor())
            && pixels > 0.0
            && plan != (FramePlan::Full { dither: true })
        {
            self.seen[index] = Some(bytes as f64 / pixels);
        }
        if bytes >= MIN_SAMPLE_BYTES {
            if self.writes.len() == RATE_WINDOW {
                self.writes.remove(0);
            }
            // A write cannot have drained faster than 1 GB/s: a floor for instant writes.
            let seconds = write_time.as_secs_f64().max(bytes as f64 / 1e9);
            self.writes.push((bytes, seconds));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FULL: (u32, u32) = (940, 880);
    const TYPING: Duration = Duration::from_millis(30);

    #[test]
    fn budgets_parse_with_units() {
        assert_eq!(Budget::parse("--frame-budget", "auto").unwrap(), Budget::Auto);
        assert_eq!(
            Budget::parse("--frame-budget", "65536").unwrap(),
            Budget::Bytes(65536)
        );
        assert_eq!(
            Budget::parse("--frame-budget", "64k").unwrap(),
            Budget::Bytes(65536)
        );
        assert_eq!(
            Budget::parse("--frame-budget", "64KiB").unwrap(),
            Budget::Bytes(65536)
        );
        assert_eq!(
            Budget::parse("--frame-budget", "2M").unwrap(),
            Budget::Bytes(2 << 20)
        );
        for bad in ["", "k", "12 parsecs", "100", "-5k"] {
            let e = Budget::parse("--frame-budget", bad).unwrap_err();
            assert_eq!(e.exit_code(), 2);
            assert!(e.to_string().starts_with("--frame-budget: "), "{e}");
        }
    }

    #[test]
    fn idle_input_gets_the_full_frame() {
        let policy = FrameBudget::new(Budget::Bytes(1024), 5.4);
        let full = FramePlan::Full { dither: true };
        assert_eq!(policy.plan(IDLE_FOR_FULL, FULL), full);
        assert_eq!(policy.plan(Duration::from_secs(3), FULL), full);
        assert_ne!(policy.plan(TYPING, FULL), full);
        assert_eq!(policy.full_frame_in(TYPING), Duration::from_millis(120));
        assert_eq!(policy.full_frame_in(Duration::from_secs(1)), Duration::ZERO);
    }

    #[test]
    fn before_any_frame_the_prior_picks_the_divisor() {
        // Raw RGBA (5.4 B/px): 940 × 880 is 4.5 MB; under 64 KiB needs 1/8 (70 KB)… the
        // coarsest; with 0.1 B/px (83 KB at full size) 1/2 fits (21 KB).
        let raw = FrameBudget::new(Budget::Bytes(DEFAULT_BUDGET), prior_bytes_per_pixel(false));
        assert_eq!(raw.plan(TYPING, FULL), FramePlan::Interactive { divisor: 8 });
        let compressed = FrameBudget::new(Budget::Bytes(DEFAULT_BUDGET), prior_bytes_per_pixel(true));
        assert_eq!(
            compressed.plan(TYPING, FULL),
            FramePlan::Interactive { divisor: 2 }
        );
        let roomy = FrameBudget::new(Budget::Bytes(1 << 20), prior_bytes_per_pixel(true));
        assert_eq!(roomy.plan(TYPING, FULL), FramePlan::Interactive { divisor: 1 });
    }

    #[test]
    fn measured_frames_replace_the_prior() {
        let mut policy = FrameBudget::new(Budget::Bytes(DEFAULT_BUDGET), prior_bytes_per_pixel(true));
        // A full frame took 100 KB: at 1/2 that scales to 25 KB, which fits.
        policy.record(
            FramePlan::Full { dither: false },
            FULL,
            100_000,
            Duration::from_millis(5),
        );
        assert_eq!(policy.plan(TYPING, FULL), FramePlan::Interactive { divisor: 2 });
        // But 1/2 frames turn out to take 70 KB (sixel keeps its bytes when upscaled): 1/3
        // is estimated from them, 70 KB · (2/3)² = 31 KB.
        policy.record(
            FramePlan::Interactive { divisor: 2 },
            FULL,
            70_000,
            Duration::from_millis(5),
        );
        assert_eq!(policy.plan(TYPING, FULL), FramePlan::Interactive { divisor: 3 });
        // And a measured 1/3 frame of 60 KB still fits.
        policy.record(
            FramePlan::Interactive { divisor: 3 },
            FULL,
            60_000,
            Duration::from_millis(5),
        );
        assert_eq!(policy.plan(TYPING, FULL), FramePlan::Interactive { divisor: 3 });
    }

    #[test]
    fn the_automatic_budget_follows_the_drain_rate() {
        let mut policy = FrameBudget::new(Budget::Auto, prior_bytes_per_pixel(true));
        assert_eq!(policy.budget_bytes(), DEFAULT_BUDGET);
        assert_eq!(policy.drain_rate(), None);
        // Small writes say nothing.
        policy.record(
            FramePlan::Full { dither: false },
            FULL,
            4000,
            Duration::from_millis(100),
        );
        assert_eq!(policy.drain_rate(), None);
        // 10 Mbit/s: 1.25 MB/s, so 62.5 KB drain in 50 ms.
        for _ in 0..10 {
            policy.record(
                FramePlan::Full { dither: false },
                FULL,
                125_000,
                Duration::from_millis(100),
            );
        }
        assert!((policy.drain_rate().unwrap() - 1.25e6).abs() < 1.0);
        assert_eq!(policy.budget_bytes(), 62_500);
        // A 1 Mbit/s link: the floor.
        for _ in 0..RATE_WINDOW {
            policy.record(
                FramePlan::Full { dither: false },
                FULL,
                20_000,
                Duration::from_millis(160),
            );
        }
        assert_eq!(policy.budget_bytes(), MIN_BUDGET);
        // A fixed budget ignores the rate.
        let mut fixed = FrameBudget::new(Budget::Bytes(100_000), 0.1);
        fixed.record(
            FramePlan::Full { dither: false },
            FULL,
            20_000,
            Duration::from_secs(1),
        );
        assert_eq!(fixed.budget_bytes(), 100_000);
    }

    #[test]
    fn full_frames_are_dithered_while_they_fit() {
        let mut policy = FrameBudget::new(Budget::Auto, prior_bytes_per_pixel(true));
        let idle = Duration::from_secs(1);
        // The first full frame is dithered; one that grew past the target is followed by flat ones.
        assert_eq!(policy.plan(idle, FULL), FramePlan::Full { dither: true });
        policy.record(FramePlan::Full { dither: true }, FULL, 120_000, Duration::ZERO);
        assert_eq!(policy.plan(idle, FULL), FramePlan::Full { dither: false });
        // A 38 KB flat frame (the paper room): dithered, about 50 KB, fits.
        policy.record(FramePlan::Full { dither: false }, FULL, 38_000, Duration::ZERO);
        assert_eq!(policy.plan(idle, FULL), FramePlan::Full { dither: true });
        policy.record(FramePlan::Full { dither: true }, FULL, 90_000, Duration::ZERO);
        assert!(policy.dither_full());
        // The interactive estimate still comes from the flat frame: 38 KB at 1/1 fits 64 KiB.
        assert_eq!(policy.plan(TYPING, FULL), FramePlan::Interactive { divisor: 1 });
        // A dithered frame that grew past the target: the next one is flat.
        policy.record(FramePlan::Full { dither: true }, FULL, 110_000, Duration::ZERO);
        assert!(!policy.dither_full());
        // A 95 KB flat frame (the office) stays flat.
        policy.record(FramePlan::Full { dither: false }, FULL, 95_000, Duration::ZERO);
        assert!(!policy.dither_full());
    }

    #[test]
    fn frame_sizes_round_up() {
        assert_eq!(FramePlan::Full { dither: true }.size(FULL), FULL);
        assert_eq!(FramePlan::Interactive { divisor: 3 }.size(FULL), (314, 294));
        assert_eq!(FramePlan::Interactive { divisor: 8 }.size((5, 5)), (1, 1));
    }
}
