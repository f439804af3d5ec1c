//! The preview image on the terminal: every ratatui-image call lives here (its 12.0 release
//! will change the API). Picks the graphics protocol (asking the terminal, or as forced by
//! `--graphics`), encodes rendered pixmaps into a [`Protocol`] and measures what a frame costs
//! on the wire.

use std::hash::{DefaultHasher, Hash, Hasher};

use image::{DynamicImage, RgbaImage};
use ratatui::backend::{Backend, CrosstermBackend};
use ratatui::buffer::Buffer;
use ratatui::layout::{Rect, Size};
use ratatui::widgets::Widget;
use ratatui_image::picker::cap_parser::QueryStdioOptions;
use ratatui_image::picker::{Picker, ProtocolType};
use ratatui_image::protocol::Protocol;
use ratatui_image::{Image, Resize};
use tiny_skia::Pixmap;

use crate::error::{Error, Result};
use crate::tui::terminal::Graphics;

/// The environment variable OpenSSH sets in a remote session (turns on kitty compression).
pub const SSH_ENV: &str = "SSH_CONNECTION";

/// The picker for `graphics`. `Auto` asks the terminal (call it after entering the alternate
/// screen and before anything reads events); a terminal that does not answer within the
/// query's timeout gets half-blocks. A forced protocol still asks for the cell size in pixels.
/// Over SSH ([`SSH_ENV`] set), kitty's zlib compression is probed for and used if offered.
pub fn detect_picker(graphics: Graphics) -> Picker {
    let forced = match graphics {
        Graphics::Halfblocks => return Picker::halfblocks(),
        Graphics::Auto => None,
        Graphics::Sixel => Some(ProtocolType::Sixel),
        Graphics::Kitty => Some(ProtocolType::Kitty),
        Graphics::Iterm2 => Some(ProtocolType::Iterm2),
    };
    let options = QueryStdioOptions {
        kitty_compression: std::env::var_os(SSH_ENV).is_some_and(|v| !v.is_empty()),
        ..QueryStdioOptions::default()
    };
    let mut picker = Picker::from_query_stdio_with_options(options).unwrap_or_else(|_| Picker::halfblocks());
    if let Some(protocol) = forced {
        picker.set_protocol_type(protocol);
    }
    picker
}

/// The picker's cell size in pixels (width, height).
pub fn cell_px(picker: &Picker) -> (u16, u16) {
    let size = picker.font_size();
    (size.width.max(1), size.height.max(1))
}

/// The protocol's name for the status line, e.g. `sixel 9×18 px`.
pub fn protocol_label(picker: &Picker) -> String {
    let name = match picker.protocol_type() {
        ProtocolType::Halfblocks => "half-blocks",
        ProtocolType::Sixel => "sixel",
        ProtocolType::Kitty => "kitty",
        ProtocolType::Iterm2 => "iTerm2",
    };
    let (w, h) = cell_px(picker);
    format!("{name} {w}×{h} px")
}

/// A hash of the pixmap's size and pixels: equal hashes mean an unchanged frame, which is
/// neither re-encoded nor re-sent.
pub fn pixmap_hash(pixmap: &Pixmap) -> u64 {
    let mut hasher = DefaultHasher::new();
    (pixmap.width(), pixmap.height()).hash(&mut hasher);
    pixmap.data().hash(&mut hasher);
    hasher.finish()
}

/// Encodes an opaque pixmap for a preview of `cells` (columns, rows) with `picker`'s protocol.
/// The pixmap should be `cells × cell size` pixels; otherwise it is scaled to fit.
///
/// Errors (internal): the encoder failed.
pub fn encode(picker: &Picker, pixmap: &Pixmap, cells: Size) -> Result<Protocol> {
    // Opaque renders are premultiplied and straight RGBA alike (alpha = 255).
    let image = RgbaImage::from_raw(pixmap.width(), pixmap.height(), pixmap.data().to_vec())
        .ok_or_else(|| Error::internal("preview: pixmap size does not match its data"))?;
    picker
        .new_protocol(DynamicImage::ImageRgba8(image), cells, Resize::Fit(None))
        .map_err(|e| Error::internal(format!("preview: encoding the image failed: {e}")))
}

/// Draws `protocol` into `area` of `buffer` (nothing when it does not fit).
pub fn draw(protocol: &Protocol, area: Rect, buffer: &mut Buffer) {
    Image::new(protocol).render(area, buffer);
}

/// True when `protocol`'s image fits in `area` (cells).
pub fn fits(protocol: &Protocol, area: Rect) -> bool {
    let size = protocol.size();
    size.width <= area.width && size.height <= area.height
}

/// Bytes a terminal receives to show `protocol` once in an empty `area` (cells): the escape
/// sequences crossterm writes for the drawn cells, image payload, colours and cursor moves.
///
/// Errors (internal): writing to the in-memory buffer failed.
pub fn bytes_on_wire(protocol: &Protocol, area: Rect) -> Result<usize> {
    let mut buffer = Buffer::empty(area);
    draw(protocol, area, &mut buffer);
    // What ratatui writes when the screen before was empty: the diff against an empty buffer.
    let changes = Buffer::empty(area).diff(&buffer);
    let mut written = Vec::new();
    CrosstermBackend::new(&mut written)
        .draw(changes.into_iter())
        .map_err(|e| Error::internal(format!("preview: measuring bytes failed: {e}")))?;
    Ok(written.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `width × height` opaque pixmap with a colour gradient.
    fn gradient(width: u32, height: u32) -> Pixmap {
        let mut pixmap = Pixmap::new(width, height).unwrap();
        for (i, px) in pixmap.data_mut().chunks_exact_mut(4).enumerate() {
            let (x, y) = (i as u32 % width, i as u32 / width);
            px.copy_from_slice(&[(x * 255 / width) as u8, (y * 255 / height) as u8, 90, 255]);
        }
        pixmap
    }

    fn picker(protocol: ProtocolType) -> Picker {
        let mut picker = Picker::halfblocks();
        picker.set_protocol_type(protocol);
        picker
    }

    #[test]
    fn the_hash_sees_every_pixel() {
        let a = gradient(40, 30);
        let mut b = a.clone();
        assert_eq!(pixmap_hash(&a), pixmap_hash(&b));
        b.data_mut()[4 * (17 * 40 + 23)] ^= 1;
        assert_ne!(pixmap_hash(&a), pixmap_hash(&b));
        assert_ne!(pixmap_hash(&gradient(40, 30)), pixmap_hash(&gradient(30, 40)));
    }

    #[test]
    fn an_image_of_cells_times_font_pixels_covers_exactly_those_cells() {
        // Half-blocks' nominal font is 10 × 20 px: 160 × 160 px is 16 × 8 cells.
        let cells = Size::new(16, 8);
        for protocol in [
            ProtocolType::Halfblocks,
            ProtocolType::Sixel,
            ProtocolType::Kitty,
            ProtocolType::Iterm2,
        ] {
            let image = encode(&picker(protocol), &gradient(160, 160), cells).unwrap();
            assert_eq!(image.size(), cells, "{protocol:?}");
            assert!(fits(&image, Rect::new(0, 0, 16, 8)));
            assert!(!fits(&image, Rect::new(0, 0, 15, 8)));
        }
    }

    #[test]
    fn kitty_sends_at_least_the_base64_of_the_raw_pixels() {
        let (w, h) = (160u32, 160u32);
        let image = encode(&picker(ProtocolType::Kitty), &gradient(w, h), Size::new(16, 8)).unwrap();
        let raw = (w * h * 4) as usize;
        let base64 = raw.div_ceil(3) * 4;
        let bytes = bytes_on_wire(&image, Rect::new(0, 0, 16, 8)).unwrap();
        assert!(bytes >= base64, "{bytes} < {base64}");
        // Half-blocks: every cell at least its ▀ (3 bytes of UTF-8).
        let blocks = encode(
            &picker(ProtocolType::Halfblocks),
            &gradient(w, h),
            Size::new(16, 8),
        )
        .unwrap();
        assert!(bytes_on_wire(&blocks, Rect::new(0, 0, 16, 8)).unwrap() >= 16 * 8 * 3);
    }
}
