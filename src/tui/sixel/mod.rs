//! Our DEC sixel encoder (docs/DECISIONS.md "Terminal graphics"): the image's colours counted
//! ([`histogram`]), an adaptive palette of at most 256 colours on a luma-chroma grid in sixel's
//! own precision ([`palette`]), band columns of neighbouring colours flattened ([`flatten`]), and
//! a band writer that packs and run-length codes the bands ([`bands`]). Pixels are square (aspect 1:1 in the raster
//! attributes) and the background is left alone (`P2 = 1`), so a new frame is painted over the
//! old one without the terminal clearing the area first.

pub mod bands;
pub mod flatten;
pub mod histogram;
pub mod palette;

#[cfg(test)]
mod decode;

pub use palette::{Indexed, MAX_COLOURS, Quality, from_percent, quantise, quantise_dithered, to_percent};

use crate::error::{Error, Result};

/// The device control string that starts a sixel image: aspect 1:1 (`P1 = 9`), pixels left
/// unpainted keep what is on screen (`P2 = 1`).
pub const INTRODUCER: &str = "\x1bP9;1;0q";
/// The string terminator that ends it.
pub const TERMINATOR: &str = "\x1b\\";

/// Encodes the opaque RGBA image `rgba` (`width × height`, 4 bytes a pixel, alpha ignored) as a
/// complete sixel sequence, from [`INTRODUCER`] to [`TERMINATOR`], at `quality`.
///
/// Errors (internal): `rgba` does not hold `width × height` pixels.
pub fn encode(rgba: &[u8], width: usize, height: usize, quality: Quality) -> Result<String> {
    Ok(encode_indexed(&reduce(rgba, width, height, quality)?))
}

/// The palette image [`encode`] writes: quantised at `quality`, band columns flattened.
///
/// Errors (internal): `rgba` does not hold `width × height` pixels.
pub fn reduce(rgba: &[u8], width: usize, height: usize, quality: Quality) -> Result<Indexed> {
    let mut indexed = quantise_checked(rgba, width, height, quality)?;
    flatten::flatten_columns(&mut indexed);
    Ok(indexed)
}

/// [`quantise`] after checking the buffer's size.
fn quantise_checked(rgba: &[u8], width: usize, height: usize, quality: Quality) -> Result<Indexed> {
    check_size(rgba, width, height)?;
    Ok(quantise(rgba, width, height, quality))
}

/// Errors (internal) unless `rgba` holds `width × height` pixels.
fn check_size(rgba: &[u8], width: usize, height: usize) -> Result<()> {
    if rgba.len() != width * height * 4 {
        return Err(Error::internal(format!(
            "sixel: {} bytes are not a {width} × {height} RGBA image",
            rgba.len()
        )));
    }
    Ok(())
}

/// Encodes a frame rendered at 1 / `divisor` of the size it is shown at: `rgba` holds
/// `size.0 × size.1` pixels, each shown as `divisor × divisor` pixels, cut to `shown` (width,
/// height). The quality follows the divisor ([`Quality::for_divisor`]); the colours are counted
/// on the small image, so a reduced frame also encodes faster. A full-size frame (`divisor` 1)
/// is dithered when `dither` is set ([`quantise_dithered`] at [`Quality::DITHERED`]: no
/// banding, about a quarter more bytes), else its band columns are flattened.
///
/// Errors (internal): `rgba` does not hold `size.0 × size.1` pixels, or `shown` is larger than
/// the enlarged image.
pub fn encode_frame(
    rgba: &[u8],
    size: (usize, usize),
    divisor: u32,
    shown: (usize, usize),
    dither: bool,
) -> Result<String> {
    let d = divisor.max(1) as usize;
    if shown.0 > size.0 * d || shown.1 > size.1 * d {
        return Err(Error::internal(format!(
            "sixel: a {}×{} frame at 1/{d} cannot show {}×{} pixels",
            size.0, size.1, shown.0, shown.1
        )));
    }
    let quality = Quality::for_divisor(divisor);
    if dither && d == 1 && shown == size {
        check_size(rgba, size.0, size.1)?;
        return Ok(encode_indexed(&quantise_dithered(
            rgba,
            size.0,
            size.1,
            Quality::DITHERED,
        )));
    }
    let small = quantise_checked(rgba, size.0, size.1, quality)?;
    let mut indexed = if d == 1 && shown == size {
        small
    } else {
        enlarge(&small, d, shown)
    };
    flatten::flatten_columns(&mut indexed);
    Ok(encode_indexed(&indexed))
}

/// `image` with every pixel repeated `factor × factor` times, cut to `shown` (width, height).
fn enlarge(image: &Indexed, factor: usize, shown: (usize, usize)) -> Indexed {
    let mut indices = Vec::with_capacity(shown.0 * shown.1);
    let mut row = Vec::with_capacity(shown.0);
    for source in image.indices.chunks_exact(image.width) {
        row.clear();
        row.extend(
            source
                .iter()
                .flat_map(|&c| std::iter::repeat_n(c, factor))
                .take(shown.0),
        );
        for _ in 0..factor.min(shown.1 - indices.len() / shown.0) {
            indices.extend_from_slice(&row);
        }
    }
    Indexed {
        width: shown.0,
        height: shown.1,
        indices,
        ..image.clone()
    }
}

/// The complete sixel sequence of a palette image.
pub fn encode_indexed(image: &Indexed) -> String {
    let body = bands::encode_bands(image);
    let mut out = String::with_capacity(body.len() + 16 * image.palette.len() + 64);
    out.push_str(INTRODUCER);
    out.push_str("\"1;1;");
    bands::push_number(&mut out, image.width);
    out.push(';');
    bands::push_number(&mut out, image.height);
    for (i, colour) in image.palette.iter().enumerate() {
        out.push('#');
        bands::push_number(&mut out, i);
        out.push_str(";2");
        for &channel in colour {
            out.push(';');
            bands::push_number(&mut out, usize::from(channel));
        }
    }
    out.push_str(&body);
    out.push_str(TERMINATOR);
    out
}

#[cfg(test)]
mod tests {
    use super::decode::decode;
    use super::*;

    /// A `width × height` RGBA image from a colour function of (x, y).
    fn image(width: usize, height: usize, colour: impl Fn(usize, usize) -> [u8; 3]) -> Vec<u8> {
        let mut rgba = Vec::with_capacity(width * height * 4);
        for y in 0..height {
            for x in 0..width {
                rgba.extend_from_slice(&colour(x, y));
                rgba.push(255);
            }
        }
        rgba
    }

    /// The colours a terminal shows for `indexed`, pixel by pixel.
    fn shown(indexed: &Indexed) -> Vec<[u8; 3]> {
        indexed
            .indices
            .iter()
            .map(|&i| indexed.palette[usize::from(i)].map(from_percent))
            .collect()
    }

    /// Encodes `rgba`, decodes the sequence and checks every pixel against the reduced image.
    fn round_trip(rgba: &[u8], width: usize, height: usize) -> (Indexed, String) {
        let indexed = reduce(rgba, width, height, Quality::FINE).unwrap();
        let data = encode_indexed(&indexed);
        let decoded = decode(&data).expect("our sixel decodes");
        assert_eq!((decoded.width, decoded.height), (width, height));
        let expected = shown(&indexed);
        for (i, (got, want)) in decoded.pixels.iter().zip(&expected).enumerate() {
            assert_eq!(*got, Some(*want), "pixel ({}, {})", i % width, i / width);
        }
        (indexed, data)
    }

    #[test]
    fn percent_levels_round_trip_and_round_to_nearest() {
        for p in 0..=100u8 {
            assert_eq!(to_percent(from_percent(p)), p);
        }
        assert_eq!(to_percent(0), 0);
        assert_eq!(to_percent(255), 100);
        // 128 / 255 = 50.2 %; 129 / 255 = 50.6 %.
        assert_eq!(to_percent(128), 50);
        assert_eq!(to_percent(129), 51);
        assert_eq!(from_percent(50), 128);
    }

    #[test]
    fn few_colours_are_shown_exactly() {
        let colours = [
            [255, 0, 0],
            [0, 255, 0],
            [0, 0, 255],
            [255, 255, 255],
            [10, 20, 30],
        ];
        let (w, h) = (37, 23);
        let rgba = image(w, h, |x, y| colours[(x / 5 + y / 4) % colours.len()]);
        let (indexed, _) = round_trip(&rgba, w, h);
        assert_eq!(indexed.palette.len(), colours.len());
        for (i, px) in rgba.chunks_exact(4).enumerate() {
            let shown = indexed.palette[usize::from(indexed.indices[i])].map(from_percent);
            let exact: [u8; 3] = [px[0], px[1], px[2]].map(|c| from_percent(to_percent(c)));
            assert_eq!(shown, exact, "pixel {i}");
        }
    }

    #[test]
    fn a_smooth_grey_ramp_keeps_every_percent_level() {
        // 256 grey levels round to the 101 percent levels, all of which fit the palette.
        let (w, h) = (512, 13);
        let rgba = image(w, h, |x, _| [(x / 2) as u8; 3]);
        let (indexed, _) = round_trip(&rgba, w, h);
        assert_eq!(indexed.palette.len(), 101);
        for x in 0..w {
            let grey = (x / 2) as u8;
            let shown = indexed.palette[usize::from(indexed.indices[x])];
            assert_eq!(shown, [to_percent(grey); 3], "column {x}");
        }
    }

    #[test]
    fn many_colours_get_256_boxes_with_small_luma_error() {
        // A colour ramp over two channels: 101 × 101 percent colours, far more than 256.
        let (w, h) = (202, 202);
        let rgba = image(w, h, |x, y| {
            [(x * 255 / (w - 1)) as u8, (y * 255 / (h - 1)) as u8, 128]
        });
        let (indexed, _) = round_trip(&rgba, w, h);
        assert_eq!(indexed.palette.len(), MAX_COLOURS);
        let luma = |rgb: [f64; 3]| palette::luma_chroma(rgb)[0];
        let mut sum = 0.0;
        let mut worst: f64 = 0.0;
        for (i, px) in rgba.chunks_exact(4).enumerate() {
            let shown = indexed.palette[usize::from(indexed.indices[i])].map(f64::from);
            let exact = [px[0], px[1], px[2]].map(|c| f64::from(c) * 100.0 / 255.0);
            let error = (luma(shown) - luma(exact)).abs();
            sum += error;
            worst = worst.max(error);
        }
        // The luma range (about 6 % to 92 %) spread over 256 boxes that also split chroma:
        // a few percent at worst, about one on average.
        let mean = sum / (w * h) as f64;
        assert!(mean < 1.5 && worst < 5.0, "mean {mean:.2} %, worst {worst:.2} %");
    }

    #[test]
    fn flattening_makes_a_slanted_ramp_much_cheaper() {
        // A grey ramp along a diagonal: every boundary crosses each band on a slant. Flat, a
        // boundary costs one colour and one run in each band (`#12!9~`, 6–8 bytes).
        let (w, h) = (600, 60);
        let rgba = image(w, h, |x, y| [(40 + (2 * x + y) / 8) as u8; 3]);
        let exact = encode_indexed(&quantise(&rgba, w, h, Quality::FINE));
        let (_, flattened) = round_trip(&rgba, w, h);
        let indexed = quantise(&rgba, w, h, Quality::FINE);
        let boundaries = (0..w - 1)
            .filter(|&x| indexed.indices[x] != indexed.indices[x + 1])
            .count()
            * h.div_ceil(6);
        let header = encode_indexed(&Indexed {
            indices: vec![0; w * h],
            ..indexed
        })
        .len();
        assert!(
            flattened.len() - header <= 8 * boundaries && 5 * flattened.len() < 3 * exact.len(),
            "{} bytes flattened, {} exact, {boundaries} boundaries",
            flattened.len(),
            exact.len()
        );
    }

    #[test]
    fn a_rare_saturated_colour_keeps_its_own_entry() {
        // A smooth grey background with 600 distinct grey-blue shades and a few yellow pixels:
        // the yellow must not be merged into a grey.
        let (w, h) = (300, 200);
        let rgba = image(w, h, |x, y| {
            if (140..143).contains(&x) && (100..103).contains(&y) {
                [250, 200, 10]
            } else {
                [(x * 255 / w) as u8, (y * 255 / h) as u8, ((x + y) % 256) as u8]
            }
        });
        let (indexed, _) = round_trip(&rgba, w, h);
        let yellow = indexed.palette[usize::from(indexed.indices[101 * w + 141])];
        assert_eq!(yellow, [to_percent(250), to_percent(200), to_percent(10)]);
    }

    #[test]
    fn every_band_height_and_odd_widths_decode() {
        for h in 1..=13 {
            for w in [1, 2, 7, 31] {
                let rgba = image(w, h, |x, y| {
                    [(x * 40 % 256) as u8, (y * 70 % 256) as u8, ((x ^ y) * 9) as u8]
                });
                round_trip(&rgba, w, h);
            }
        }
    }

    #[test]
    fn the_sequence_has_square_pixels_and_keeps_the_background() {
        let rgba = image(4, 3, |_, _| [0, 0, 0]);
        let data = encode(&rgba, 4, 3, Quality::FINE).unwrap();
        assert!(data.starts_with("\x1bP9;1;0q\"1;1;4;3#0;2;0;0;0"), "{data:?}");
        assert!(data.ends_with(TERMINATOR));
        // One colour, one solid pass of three rows over four columns: `#0!4F`.
        assert_eq!(&data[INTRODUCER.len()..], "\"1;1;4;3#0;2;0;0;0#0!4F\x1b\\");
    }

    #[test]
    fn flat_areas_compress_to_runs() {
        // Left half dark, right half light: per band two solid segments in one pass.
        let (w, h) = (900, 60);
        let rgba = image(w, h, |x, _| if x < 450 { [30; 3] } else { [200; 3] });
        let (_, data) = round_trip(&rgba, w, h);
        let band = "#0!450~#1!450~";
        let expected_body = [band; 10].join("-");
        assert!(data.contains(&expected_body), "{data}");
    }

    #[test]
    fn a_reduced_frame_is_shown_enlarged_and_cut() {
        // 5 × 4 pixels at 1/3, shown as 14 × 10: each pixel a 3 × 3 block, the last cut.
        let small = image(5, 4, |x, y| [(x * 50) as u8, (y * 60) as u8, 0]);
        let data = encode_frame(&small, (5, 4), 3, (14, 10), false).unwrap();
        let decoded = decode(&data).unwrap();
        assert_eq!((decoded.width, decoded.height), (14, 10));
        let quantised = quantise(&small, 5, 4, Quality::for_divisor(3));
        for y in 0..10 {
            for x in 0..14 {
                let i = usize::from(quantised.indices[(y / 3) * 5 + x / 3]);
                assert_eq!(
                    decoded.pixels[y * 14 + x],
                    Some(quantised.palette[i].map(from_percent)),
                    "({x}, {y})"
                );
            }
        }
        // Full size at 1/1 is plain encoding.
        let full = image(6, 6, |x, y| [(x * 40) as u8, (y * 40) as u8, 9]);
        assert_eq!(
            encode_frame(&full, (6, 6), 1, (6, 6), false).unwrap(),
            encode(&full, 6, 6, Quality::FINE).unwrap()
        );
        assert!(encode_frame(&small, (5, 4), 3, (16, 10), false).is_err());
    }

    /// The luma (percent, before the terminal's 8-bit rounding, which is the same for both
    /// ways) of each pixel, averaged over each band's rows, per column.
    fn band_means(indexed: &Indexed) -> Vec<f64> {
        let (w, h) = (indexed.width, indexed.height);
        let mut means = Vec::new();
        for band in (0..h).step_by(6) {
            for x in 0..w {
                let rows = band..(band + 6).min(h);
                let n = rows.len() as f64;
                let sum: f64 = rows
                    .map(|y| {
                        let p = indexed.palette[usize::from(indexed.indices[y * w + x])];
                        palette::luma_chroma(p.map(f64::from))[0]
                    })
                    .sum();
                means.push(sum / n);
            }
        }
        means
    }

    #[test]
    fn dithering_keeps_the_average_of_a_ramp_between_levels() {
        // A slow grey ramp: 60 8-bit levels (24 percent) over 600 columns.
        let (w, h) = (600, 36);
        let rgba = image(w, h, |x, _| [(100 + x / 10) as u8; 3]);
        let dithered = quantise_dithered(&rgba, w, h, Quality::FINE);
        let flat = quantise(&rgba, w, h, Quality::FINE);
        let exact: Vec<f64> = (0..h / 6 * w)
            .map(|i| f64::from((100 + i % w / 10) as u8) * 100.0 / 255.0)
            .collect();
        let worst = |means: Vec<f64>| {
            means
                .iter()
                .zip(&exact)
                .map(|(m, e)| (m - e).abs())
                .fold(0.0, f64::max)
        };
        // Rounding to whole percent is off by up to half a percent; the dither's average by
        // at most a twelfth (six thresholds), plus the palette's own rounding.
        let (flat_worst, dithered_worst) = (worst(band_means(&flat)), worst(band_means(&dithered)));
        assert!(flat_worst > 0.35, "{flat_worst}");
        assert!(dithered_worst < 0.15, "{dithered_worst}");
        // At the full frames' 1.5 % steps, levels on whole percents (0, 2, 3, 5, … %): at most
        // a twelfth of the wider 2 % step.
        let coarse_worst = worst(band_means(&quantise_dithered(&rgba, w, h, Quality::DITHERED)));
        assert!(coarse_worst <= 2.0 / 12.0 + 1e-9, "{coarse_worst}");
        // And it decodes exactly.
        let decoded = decode(&encode_indexed(&dithered)).unwrap();
        for (i, &c) in dithered.indices.iter().enumerate() {
            assert_eq!(
                decoded.pixels[i],
                Some(dithered.palette[usize::from(c)].map(from_percent))
            );
        }
    }

    #[test]
    fn dither_thresholds_are_a_shuffled_sixth_ladder() {
        for band in 0..50 {
            let mut t = row_thresholds_sorted(band);
            t.iter_mut().for_each(|v| *v *= 12.0);
            assert_eq!(t, [1.0, 3.0, 5.0, 7.0, 9.0, 11.0]);
        }
        assert_ne!(palette::row_thresholds(0), palette::row_thresholds(1));
        // A full frame is dithered only when asked.
        let rgba = image(60, 12, |x, _| [(100 + x / 3) as u8; 3]);
        let plain = encode_frame(&rgba, (60, 12), 1, (60, 12), false).unwrap();
        let dithered = encode_frame(&rgba, (60, 12), 1, (60, 12), true).unwrap();
        assert_eq!(
            dithered,
            encode_indexed(&quantise_dithered(&rgba, 60, 12, Quality::DITHERED))
        );
        assert_ne!(plain, dithered);
    }

    fn row_thresholds_sorted(band: usize) -> [f64; 6] {
        let mut t = palette::row_thresholds(band);
        t.sort_by(f64::total_cmp);
        t
    }

    #[test]
    fn a_wrong_buffer_length_is_an_internal_error() {
        let e = encode(&[0; 12], 2, 2, Quality::FINE).unwrap_err();
        assert_eq!(e.exit_code(), 1);
    }
}
