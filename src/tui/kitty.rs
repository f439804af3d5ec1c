//! kitty graphics (docs/DECISIONS.md "Terminal graphics"): our own transmission, so a frame can
//! be PNG or zlib-compressed RGBA, scaled by the terminal to the preview's cells (a reduced
//! interactive frame fills the same cells), under one image id for the whole session (a new
//! frame replaces the old image in place: no flash, and the placeholder cells do not change).
//!
//! The image is shown through Unicode placeholders (`U+10EEEE`, kitty ≥ 0.28), plain text that
//! passes tmux: each row's first cell carries the row and column as combining diacritics and
//! the image id as its 24-bit foreground colour; the following cells of the row continue it.
//! Replies are suppressed (`q=2`) so nothing arrives on the keyboard.

use std::io::Write as _;

use ratatui::buffer::{Buffer, CellDiffOption};
use ratatui::layout::Rect;
use ratatui::style::Color;

use crate::error::{Error, Result};
use crate::tui::png;
use crate::tui::probe::wrap_for_tmux;

/// The character kitty reserves for image placeholders.
pub const PLACEHOLDER: char = '\u{10EEEE}';

/// Base64 characters per chunk of a transmission (the protocol's limit).
const CHUNK_CHARS: usize = 4096;

/// How the pixels travel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Payload {
    /// PNG (`f=100`): filtered and deflated, the smallest for renders.
    Png,
    /// Raw RGBA (`f=32`), zlib-compressed (`o=z`) when `true`.
    Rgba(bool),
}

/// The escape sequences that transmit `rgba` (`size` pixels, width × height) as image `id` with
/// a virtual placement over `cells` (columns, rows), wrapped for tmux when `tmux` is set.
///
/// Errors (internal): `rgba` does not hold `size` pixels, or the PNG encoder failed.
pub fn transmit(
    rgba: &[u8],
    size: (u32, u32),
    cells: (u16, u16),
    id: u32,
    payload: Payload,
    tmux: bool,
) -> Result<String> {
    if rgba.len() != size.0 as usize * size.1 as usize * 4 {
        return Err(Error::internal(format!(
            "kitty: {} bytes are not a {} × {} RGBA image",
            rgba.len(),
            size.0,
            size.1
        )));
    }
    let (format, bytes) = match payload {
        Payload::Png => ("f=100".to_string(), png::encode(rgba, size)?),
        Payload::Rgba(false) => (format!("f=32,s={},v={}", size.0, size.1), rgba.to_vec()),
        Payload::Rgba(true) => {
            let mut encoder = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
            let deflated = encoder
                .write_all(rgba)
                .and_then(|()| encoder.finish())
                .map_err(|e| Error::internal(format!("kitty: compression failed: {e}")))?;
            (format!("f=32,s={},v={},o=z", size.0, size.1), deflated)
        }
    };
    let encoded = base64_simd::STANDARD.encode_to_string(&bytes);
    let chunks: Vec<&str> = encoded
        .as_bytes()
        .chunks(CHUNK_CHARS)
        .map(|c| std::str::from_utf8(c).expect("base64 is ASCII"))
        .collect();
    let mut out = String::with_capacity(encoded.len() + 64 * chunks.len());
    for (i, chunk) in chunks.iter().enumerate() {
        let more = u8::from(i + 1 < chunks.len());
        let keys = if i == 0 {
            format!(
                "a=T,U=1,q=2,t=d,i={id},c={},r={},{format},m={more}",
                cells.0, cells.1
            )
        } else {
            format!("q=2,m={more}")
        };
        let sequence = format!("\x1b_G{keys};{chunk}\x1b\\");
        if tmux {
            out.push_str(&wrap_for_tmux(&sequence));
        } else {
            out.push_str(&sequence);
        }
    }
    Ok(out)
}

/// Draws the placeholders of image `id` over `area`, the first cell also carrying `transmit`
/// (the image's data, sent when this cell changes).
pub fn draw(transmit: &str, id: u32, area: Rect, buf: &mut Buffer) {
    let colour = Color::Rgb((id >> 16) as u8, (id >> 8) as u8, id as u8);
    let rows = area.height.min(DIACRITICS.len() as u16);
    let mut symbol = String::new();
    for row in 0..rows {
        for column in 0..area.width {
            let Some(cell) = buf.cell_mut((area.x + column, area.y + row)) else {
                continue;
            };
            symbol.clear();
            if row == 0 && column == 0 {
                symbol.push_str(transmit);
            }
            symbol.push(PLACEHOLDER);
            if column == 0 {
                symbol.push(DIACRITICS[usize::from(row)]);
                symbol.push(DIACRITICS[0]);
            }
            cell.set_symbol(&symbol)
                .set_fg(colour)
                .set_diff_option(CellDiffOption::ForcedWidth(std::num::NonZeroU16::MIN));
        }
    }
}

/// The combining characters that number placeholder rows and columns (kitty's
/// `rowcolumn-diacritics.txt`): the n-th stands for n.
static DIACRITICS: [char; 297] = [
    '\u{305}',
    '\u{30D}',
    '\u{30E}',
    '\u{310}',
    '\u{312}',
    '\u{33D}',
    '\u{33E}',
    '\u{33F}',
    '\u{346}',
    '\u{34A}',
    '\u{34B}',
    '\u{34C}',
    '\u{350}',
    '\u{351}',
    '\u{352}',
    '\u{357}',
    '\u{35B}',
    '\u{363}',
    '\u{364}',
    '\u{365}',
    '\u{366}',
    '\u{367}',
    '\u{368}',
    '\u{369}',
    '\u{36A}',
    '\u{36B}',
    '\u{36C}',
    '\u{36D}',
    '\u{36E}',
    '\u{36F}',
    '\u{483}',
    '\u{484}',
    '\u{485}',
    '\u{486}',
    '\u{487}',
    '\u{592}',
    '\u{593}',
    '\u{594}',
    '\u{595}',
    '\u{597}',
    '\u{598}',
    '\u{599}',
    '\u{59C}',
    '\u{59D}',
    '\u{59E}',
    '\u{59F}',
    '\u{5A0}',
    '\u{5A1}',
    '\u{5A8}',
    '\u{5A9}',
    '\u{5AB}',
    '\u{5AC}',
    '\u{5AF}',
    '\u{5C4}',
    '\u{610}',
    '\u{611}',
    '\u{612}',
    '\u{613}',
    '\u{614}',
    '\u{615}',
    '\u{616}',
    '\u{617}',
    '\u{657}',
    '\u{658}',
    '\u{659}',
    '\u{65A}',
    '\u{65B}',
    '\u{65D}',
    '\u{65E}',
    '\u{6D6}',
    '\u{6D7}',
    '\u{6D8}',
    '\u{6D9}',
    '\u{6DA}',
    '\u{6DB}',
    '\u{6DC}',
    '\u{6DF}',
    '\u{6E0}',
    '\u{6E1}',
    '\u{6E2}',
    '\u{6E4}',
    '\u{6E7}',
    '\u{6E8}',
    '\u{6EB}',
    '\u{6EC}',
    '\u{730}',
    '\u{732}',
    '\u{733}',
    '\u{735}',
    '\u{736}',
    '\u{73A}',
    '\u{73D}',
    '\u{73F}',
    '\u{740}',
    '\u{741}',
    '\u{743}',
    '\u{745}',
    '\u{747}',
    '\u{749}',
    '\u{74A}',
    '\u{7EB}',
    '\u{7EC}',
    '\u{7ED}',
    '\u{7EE}',
    '\u{7EF}',
    '\u{7F0}',
    '\u{7F1}',
    '\u{7F3}',
    '\u{816}',
    '\u{817}',
    '\u{818}',
    '\u{819}',
    '\u{81B}',
    '\u{81C}',
    '\u{81D}',
    '\u{81E}',
    '\u{81F}',
    '\u{820}',
    '\u{821}',
    '\u{822}',
    '\u{823}',
    '\u{825}',
    '\u{826}',
    '\u{827}',
    '\u{829}',
    '\u{82A}',
    '\u{82B}',
    '\u{82C}',
    '\u{82D}',
    '\u{951}',
    '\u{953}',
    '\u{954}',
    '\u{F82}',
    '\u{F83}',
    '\u{F86}',
    '\u{F87}',
    '\u{135D}',
    '\u{135E}',
    '\u{135F}',
    '\u{17DD}',
    '\u{193A}',
    '\u{1A17}',
    '\u{1A75}',
    '\u{1A76}',
    '\u{1A77}',
    '\u{1A78}',
    '\u{1A79}',
    '\u{1A7A}',
    '\u{1A7B}',
    '\u{1A7C}',
    '\u{1B6B}',
    '\u{1B6D}',
    '\u{1B6E}',
    '\u{1B6F}',
    '\u{1B70}',
    '\u{1B71}',
    '\u{1B72}',
    '\u{1B73}',
    '\u{1CD0}',
    '\u{1CD1}',
    '\u{1CD2}',
    '\u{1CDA}',
    '\u{1CDB}',
    '\u{1CE0}',
    '\u{1DC0}',
    '\u{1DC1}',
    '\u{1DC3}',
    '\u{1DC4}',
    '\u{1DC5}',
    '\u{1DC6}',
    '\u{1DC7}',
    '\u{1DC8}',
    '\u{1DC9}',
    '\u{1DCB}',
    '\u{1DCC}',
    '\u{1DD1}',
    '\u{1DD2}',
    '\u{1DD3}',
    '\u{1DD4}',
    '\u{1DD5}',
    '\u{1DD6}',
    '\u{1DD7}',
    '\u{1DD8}',
    '\u{1DD9}',
    '\u{1DDA}',
    '\u{1DDB}',
    '\u{1DDC}',
    '\u{1DDD}',
    '\u{1DDE}',
    '\u{1DDF}',
    '\u{1DE0}',
    '\u{1DE1}',
    '\u{1DE2}',
    '\u{1DE3}',
    '\u{1DE4}',
    '\u{1DE5}',
    '\u{1DE6}',
    '\u{1DFE}',
    '\u{20D0}',
    '\u{20D1}',
    '\u{20D4}',
    '\u{20D5}',
    '\u{20D6}',
    '\u{20D7}',
    '\u{20DB}',
    '\u{20DC}',
    '\u{20E1}',
    '\u{20E7}',
    '\u{20E9}',
    '\u{20F0}',
    '\u{2CEF}',
    '\u{2CF0}',
    '\u{2CF1}',
    '\u{2DE0}',
    '\u{2DE1}',
    '\u{2DE2}',
    '\u{2DE3}',
    '\u{2DE4}',
    '\u{2DE5}',
    '\u{2DE6}',
    '\u{2DE7}',
    '\u{2DE8}',
    '\u{2DE9}',
    '\u{2DEA}',
    '\u{2DEB}',
    '\u{2DEC}',
    '\u{2DED}',
    '\u{2DEE}',
    '\u{2DEF}',
    '\u{2DF0}',
    '\u{2DF1}',
    '\u{2DF2}',
    '\u{2DF3}',
    '\u{2DF4}',
    '\u{2DF5}',
    '\u{2DF6}',
    '\u{2DF7}',
    '\u{2DF8}',
    '\u{2DF9}',
    '\u{2DFA}',
    '\u{2DFB}',
    '\u{2DFC}',
    '\u{2DFD}',
    '\u{2DFE}',
    '\u{2DFF}',
    '\u{A66F}',
    '\u{A67C}',
    '\u{A67D}',
    '\u{A6F0}',
    '\u{A6F1}',
    '\u{A8E0}',
    '\u{A8E1}',
    '\u{A8E2}',
    '\u{A8E3}',
    '\u{A8E4}',
    '\u{A8E5}',
    '\u{A8E6}',
    '\u{A8E7}',
    '\u{A8E8}',
    '\u{A8E9}',
    '\u{A8EA}',
    '\u{A8EB}',
    '\u{A8EC}',
    '\u{A8ED}',
    '\u{A8EE}',
    '\u{A8EF}',
    '\u{A8F0}',
    '\u{A8F1}',
    '\u{AAB0}',
    '\u{AAB2}',
    '\u{AAB3}',
    '\u{AAB7}',
    '\u{AAB8}',
    '\u{AABE}',
    '\u{AABF}',
    '\u{AAC1}',
    '\u{FE20}',
    '\u{FE21}',
    '\u{FE22}',
    '\u{FE23}',
    '\u{FE24}',
    '\u{FE25}',
    '\u{FE26}',
    '\u{10A0F}',
    '\u{10A38}',
    '\u{1D185}',
    '\u{1D186}',
    '\u{1D187}',
    '\u{1D188}',
    '\u{1D189}',
    '\u{1D1AA}',
    '\u{1D1AB}',
    '\u{1D1AC}',
    '\u{1D1AD}',
    '\u{1D242}',
    '\u{1D243}',
    '\u{1D244}',
];

#[cfg(test)]
mod tests {
    use super::*;

    fn gradient(width: u32, height: u32) -> Vec<u8> {
        (0..width * height)
            .flat_map(|i| {
                [
                    (i % width * 255 / width) as u8,
                    (i / width * 255 / height) as u8,
                    90,
                    255,
                ]
            })
            .collect()
    }

    /// The decoded payload and the keys of the first chunk of a transmission.
    fn payload_of(transmission: &str) -> (String, Vec<u8>) {
        let mut keys = String::new();
        let mut data = String::new();
        for sequence in transmission.split("\x1b\\").filter(|s| !s.is_empty()) {
            let body = sequence.strip_prefix("\x1b_G").expect("an APC G sequence");
            let (k, d) = body.split_once(';').expect("keys;data");
            if keys.is_empty() {
                keys = k.to_string();
            } else {
                assert!(k.starts_with("q=2,m="), "{k}");
            }
            assert!(d.len() <= CHUNK_CHARS);
            data.push_str(d);
        }
        (keys, base64_simd::STANDARD.decode_to_vec(data).expect("base64"))
    }

    #[test]
    fn rgba_is_sent_raw_or_deflated_and_scaled_to_the_cells() {
        // 40 × 30 × 4 bytes are 6400 base64 characters: two chunks.
        let rgba = gradient(40, 30);
        let raw = transmit(&rgba, (40, 30), (16, 8), 7, Payload::Rgba(false), false).unwrap();
        let (keys, bytes) = payload_of(&raw);
        assert_eq!(keys, "a=T,U=1,q=2,t=d,i=7,c=16,r=8,f=32,s=40,v=30,m=1");
        assert_eq!(raw.matches("\x1b_G").count(), 2);
        assert!(raw.contains("\x1b_Gq=2,m=0;"));
        assert_eq!(bytes, rgba);
        let zlib = transmit(&rgba, (40, 30), (16, 8), 7, Payload::Rgba(true), false).unwrap();
        let (keys, bytes) = payload_of(&zlib);
        assert!(keys.ends_with("o=z,m=0"), "{keys}");
        let mut inflated = Vec::new();
        std::io::Read::read_to_end(&mut flate2::read::ZlibDecoder::new(&bytes[..]), &mut inflated).unwrap();
        assert_eq!(inflated, rgba);
    }

    #[test]
    fn png_decodes_to_the_image() {
        let rgba = gradient(300, 200);
        let png = transmit(&rgba, (300, 200), (30, 10), 9, Payload::Png, false).unwrap();
        let (keys, bytes) = payload_of(&png);
        assert!(
            keys.starts_with("a=T,U=1,q=2,t=d,i=9,c=30,r=10,f=100,m="),
            "{keys}"
        );
        let decoded = image::load_from_memory(&bytes).unwrap().to_rgba8();
        assert_eq!(decoded.as_raw(), &rgba);
        assert!(transmit(&rgba, (301, 200), (30, 10), 9, Payload::Png, false).is_err());
    }

    #[test]
    fn inside_tmux_each_chunk_is_wrapped() {
        let rgba = gradient(4, 4);
        let wrapped = transmit(&rgba, (4, 4), (2, 1), 3, Payload::Rgba(false), true).unwrap();
        assert!(wrapped.starts_with("\x1bPtmux;\x1b\x1b_Ga=T,"), "{wrapped:?}");
        assert!(wrapped.ends_with("\x1b\x1b\\\x1b\\"), "{wrapped:?}");
    }

    #[test]
    fn placeholders_number_rows_and_carry_the_id() {
        let area = Rect::new(2, 1, 3, 2);
        let mut buf = Buffer::empty(Rect::new(0, 0, 6, 4));
        draw("DATA", 0x01_0203, area, &mut buf);
        let first = buf[(2, 1)].symbol().to_string();
        assert_eq!(first, format!("DATA{PLACEHOLDER}\u{305}\u{305}"));
        assert_eq!(buf[(3, 1)].symbol(), PLACEHOLDER.to_string());
        assert_eq!(buf[(2, 2)].symbol(), format!("{PLACEHOLDER}\u{30D}\u{305}"));
        assert_eq!(buf[(2, 2)].fg, Color::Rgb(1, 2, 3));
        assert_eq!(buf[(1, 1)].symbol(), " ");
        assert_eq!(buf[(5, 2)].symbol(), " ");
    }
}
