//! A strict sixel decoder for the tests: reads back what [`super::encode`] writes (the
//! introducer, raster attributes, RGB colour definitions, colour selection, repeats, carriage
//! returns and new lines) and paints it the way a terminal does, later sixels over earlier
//! ones. Anything else, and any paint outside the raster, is an error.

/// A decoded image: `None` where nothing was painted.
pub struct Decoded {
    pub width: usize,
    pub height: usize,
    pub pixels: Vec<Option<[u8; 3]>>,
}

/// Reads a number at `*at` (none: `None`).
fn number(bytes: &[u8], at: &mut usize) -> Option<usize> {
    let start = *at;
    while *at < bytes.len() && bytes[*at].is_ascii_digit() {
        *at += 1;
    }
    std::str::from_utf8(&bytes[start..*at]).ok()?.parse().ok()
}

/// Reads `;`-separated numbers.
fn numbers(bytes: &[u8], at: &mut usize) -> Vec<usize> {
    let mut values = vec![number(bytes, at).unwrap_or(0)];
    while *at < bytes.len() && bytes[*at] == b';' {
        *at += 1;
        values.push(number(bytes, at).unwrap_or(0));
    }
    values
}

/// Decodes `data`, which must be exactly one sixel sequence with raster attributes.
pub fn decode(data: &str) -> Result<Decoded, String> {
    let bytes = data.as_bytes();
    if !bytes.starts_with(b"\x1bP") {
        return Err("no DCS introducer".into());
    }
    let mut at = 2;
    let params = numbers(bytes, &mut at);
    if bytes.get(at) != Some(&b'q') || params.get(1) != Some(&1) {
        return Err(format!("not a sixel with P2 = 1: {params:?}"));
    }
    at += 1;
    if bytes.get(at) != Some(&b'"') {
        return Err("no raster attributes".into());
    }
    at += 1;
    let raster = numbers(bytes, &mut at);
    let [1, 1, width, height] = raster[..] else {
        return Err(format!("raster attributes {raster:?}"));
    };
    let mut image = Decoded {
        width,
        height,
        pixels: vec![None; width * height],
    };
    let mut palette = vec![None::<[u8; 3]>; 256];
    let mut colour = 0usize;
    let (mut x, mut y) = (0usize, 0usize);
    while at < bytes.len() {
        let b = bytes[at];
        at += 1;
        let (sixel, count) = match b {
            b'#' => {
                let values = numbers(bytes, &mut at);
                match values[..] {
                    [c] => colour = c,
                    [c, 2, r, g, b] if r <= 100 && g <= 100 && b <= 100 => {
                        palette[c] = Some([r, g, b].map(|p| super::from_percent(p as u8)));
                        colour = c;
                    }
                    _ => return Err(format!("colour command {values:?}")),
                }
                continue;
            }
            b'$' => {
                x = 0;
                continue;
            }
            b'-' => {
                x = 0;
                y += 6;
                continue;
            }
            b'!' => {
                let count = number(bytes, &mut at).ok_or("repeat without a count")?;
                let sixel = *bytes.get(at).ok_or("repeat without a sixel")?;
                at += 1;
                (sixel, count)
            }
            0x1b => {
                return if bytes.get(at) == Some(&b'\\') && at + 1 == bytes.len() {
                    Ok(image)
                } else {
                    Err("ESC that is not the final string terminator".into())
                };
            }
            other => (other, 1),
        };
        if !(63..=126).contains(&sixel) {
            return Err(format!("byte {sixel} is not a sixel"));
        }
        let bits = sixel - 63;
        let rgb = palette[colour].ok_or(format!("colour {colour} used before it is defined"))?;
        for _ in 0..count {
            for row in 0..6 {
                if bits & (1 << row) != 0 {
                    if x >= width || y + row >= height {
                        return Err(format!("paint at ({x}, {}) outside the raster", y + row));
                    }
                    image.pixels[(y + row) * width + x] = Some(rgb);
                }
            }
            x += 1;
        }
    }
    Err("no string terminator".into())
}
