//! Labels drawn into an image with a built-in 5 × 7 pixel font (digits, lower-case letters — an
//! upper-case letter is drawn as its lower-case one — and `. - _ + %`), scaled by whole pixels:
//! legend ticks, plan-view names. tiny-skia draws no text, and a TrueType font would be a
//! dependency and a file for a dozen short labels.

use tiny_skia::Pixmap;

/// Glyph width and height in font pixels.
pub const GLYPH: (u32, u32) = (5, 7);
/// Horizontal advance from one glyph to the next, font pixels.
pub const ADVANCE: u32 = 6;

/// Rows (top to bottom) of a glyph, the 5 low bits of each row from left to right; `None` for a
/// character the font does not have (drawn as an empty box).
fn glyph(c: char) -> Option<[u8; 7]> {
    let rows: [u8; 7] = match c.to_ascii_lowercase() {
        '0' => [0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E],
        '1' => [0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E],
        '2' => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F],
        '3' => [0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E],
        '4' => [0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02],
        '5' => [0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E],
        '6' => [0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E],
        '7' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08],
        '8' => [0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E],
        '9' => [0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C],
        'a' => [0x00, 0x00, 0x0E, 0x01, 0x0F, 0x11, 0x0F],
        'b' => [0x10, 0x10, 0x16, 0x19, 0x11, 0x11, 0x1E],
        'c' => [0x00, 0x00, 0x0E, 0x10, 0x10, 0x11, 0x0E],
        'd' => [0x01, 0x01, 0x0D, 0x13, 0x11, 0x11, 0x0F],
        'e' => [0x00, 0x00, 0x0E, 0x11, 0x1F, 0x10, 0x0E],
        'f' => [0x06, 0x09, 0x08, 0x1C, 0x08, 0x08, 0x08],
        'g' => [0x00, 0x0F, 0x11, 0x11, 0x0F, 0x01, 0x0E],
        'h' => [0x10, 0x10, 0x16, 0x19, 0x11, 0x11, 0x11],
        'i' => [0x04, 0x00, 0x0C, 0x04, 0x04, 0x04, 0x0E],
        'j' => [0x02, 0x00, 0x06, 0x02, 0x02, 0x12, 0x0C],
        'k' => [0x10, 0x10, 0x12, 0x14, 0x18, 0x14, 0x12],
        'l' => [0x0C, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E],
        'm' => [0x00, 0x00, 0x1A, 0x15, 0x15, 0x11, 0x11],
        'n' => [0x00, 0x00, 0x16, 0x19, 0x11, 0x11, 0x11],
        'o' => [0x00, 0x00, 0x0E, 0x11, 0x11, 0x11, 0x0E],
        'p' => [0x00, 0x00, 0x1E, 0x11, 0x1E, 0x10, 0x10],
        'q' => [0x00, 0x00, 0x0D, 0x13, 0x0F, 0x01, 0x01],
        'r' => [0x00, 0x00, 0x16, 0x19, 0x10, 0x10, 0x10],
        's' => [0x00, 0x00, 0x0E, 0x10, 0x0E, 0x01, 0x1E],
        't' => [0x08, 0x08, 0x1C, 0x08, 0x08, 0x09, 0x06],
        'u' => [0x00, 0x00, 0x11, 0x11, 0x11, 0x13, 0x0D],
        'v' => [0x00, 0x00, 0x11, 0x11, 0x11, 0x0A, 0x04],
        'w' => [0x00, 0x00, 0x11, 0x11, 0x15, 0x15, 0x0A],
        'x' => [0x00, 0x00, 0x11, 0x0A, 0x04, 0x0A, 0x11],
        'y' => [0x00, 0x00, 0x11, 0x11, 0x0F, 0x01, 0x0E],
        'z' => [0x00, 0x00, 0x1F, 0x02, 0x04, 0x08, 0x1F],
        '.' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C],
        '-' => [0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00],
        '_' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x1F],
        '+' => [0x00, 0x04, 0x04, 0x1F, 0x04, 0x04, 0x00],
        '%' => [0x18, 0x19, 0x02, 0x04, 0x08, 0x13, 0x03],
        ' ' => [0x00; 7],
        _ => return None,
    };
    Some(rows)
}

/// Width in image pixels of `text` at `scale` image pixels per font pixel.
pub fn text_width(text: &str, scale: u32) -> u32 {
    let n = text.chars().count() as u32;
    if n == 0 { 0 } else { (n * ADVANCE - 1) * scale }
}

/// Height in image pixels of a line of text at `scale`.
pub fn text_height(scale: u32) -> u32 {
    GLYPH.1 * scale
}

/// Draws `text` with its top-left corner at image pixel (x, y), `scale` image pixels per font
/// pixel, in opaque `rgb`; pixels outside the image are skipped. A character the font lacks
/// is drawn as a box outline.
pub fn draw_text(pixmap: &mut Pixmap, x: i64, y: i64, text: &str, scale: u32, rgb: [u8; 3]) {
    let (w, h) = (i64::from(pixmap.width()), i64::from(pixmap.height()));
    let s = i64::from(scale.max(1));
    let (pixels, _) = pixmap.data_mut().as_chunks_mut::<4>();
    for (k, c) in text.chars().enumerate() {
        let rows = glyph(c).unwrap_or([0x1F, 0x11, 0x11, 0x11, 0x11, 0x11, 0x1F]);
        let left = x + k as i64 * i64::from(ADVANCE) * s;
        for (row, bits) in rows.iter().enumerate() {
            for col in 0..5 {
                if bits >> (4 - col) & 1 == 0 {
                    continue;
                }
                for dy in 0..s {
                    for dx in 0..s {
                        let (px, py) = (left + col * s + dx, y + row as i64 * s + dy);
                        if px >= 0 && px < w && py >= 0 && py < h {
                            pixels[(py * w + px) as usize] = [rgb[0], rgb[1], rgb[2], 255];
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_one_is_drawn_where_the_glyph_says() {
        let mut pixmap = Pixmap::new(20, 20).unwrap();
        draw_text(&mut pixmap, 3, 4, "1", 2, [255, 0, 0]);
        let lit = |x: u32, y: u32| pixmap.pixel(x, y).unwrap().red() == 255;
        // Row 0 of '1' is 00100: font pixel (2, 0) → image pixels x 7..9, y 4..6.
        assert!(lit(7, 4) && lit(8, 5));
        assert!(!lit(6, 4) && !lit(9, 4));
        // The bottom row 01110: x 5..11 at y 16..18.
        assert!((5..11).all(|x| lit(x, 16)) && !lit(4, 16) && !lit(11, 16));
        let count = pixmap.pixels().iter().filter(|p| p.red() == 255).count();
        assert_eq!(count, 4 * (1 + 2 + 1 + 1 + 1 + 1 + 3));
        assert_eq!(text_width("500 lx", 1), 35);
        assert_eq!(text_width("", 3), 0);
    }

    #[test]
    fn upper_case_uses_the_lower_case_glyph_and_text_off_the_image_is_clipped() {
        assert_eq!(glyph('D'), glyph('d'));
        assert!(glyph('é').is_none());
        let mut pixmap = Pixmap::new(8, 8).unwrap();
        draw_text(&mut pixmap, -3, -2, "88", 1, [0, 255, 0]);
        assert!(pixmap.pixels().iter().any(|p| p.green() == 255));
    }
}
