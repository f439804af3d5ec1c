//! The preview image on the terminal: every ratatui-image call lives here (its 12.0 release
//! will change the API). Picks the graphics protocol (asking the terminal, or as forced by
//! `--graphics`), encodes rendered pixmaps into a [`Protocol`] and measures what a frame costs
//! on the wire.
//!
//! [`ImageSetup`] and [`encode_frame`] are the editor's own path (docs/DECISIONS.md "Terminal
//! graphics"): the protocol chosen with the multiplexer in mind (`tui::multiplexer`, asked by
//! `tui::probe`), sixel by our encoder (`tui::sixel`), kitty by ours (`tui::kitty`), iTerm2
//! stretched over the cells, half-blocks by ratatui-image; reduced interactive frames fill the
//! same cells, and no frame erases the area before it is drawn.

use std::hash::{DefaultHasher, Hash, Hasher};

use image::{DynamicImage, RgbaImage};
use ratatui::backend::{Backend, CrosstermBackend};
use ratatui::buffer::Buffer;
use ratatui::crossterm::terminal::window_size;
use ratatui::layout::{Rect, Size};
use ratatui::widgets::Widget;
use ratatui_image::picker::Picker;
use ratatui_image::protocol::Protocol;
use ratatui_image::protocol::halfblocks::Halfblocks;
use ratatui_image::protocol::iterm2::Iterm2;
use ratatui_image::protocol::sixel::Sixel;
use ratatui_image::{Image, Resize};
use tiny_skia::Pixmap;

use crate::error::{Error, Result};
use crate::tui::frame_budget::FramePlan;
use crate::tui::multiplexer as mux;
use crate::tui::terminal::Graphics;
use crate::tui::{kitty, png, probe, sixel};

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

/// The image protocol the editor settled on, and what it needs to know to send frames.
#[derive(Debug, Clone, PartialEq)]
pub struct ImageSetup {
    /// The protocol.
    pub protocol: mux::Protocol,
    /// kitty and iTerm2 sequences are wrapped for tmux passthrough.
    pub passthrough: bool,
    /// A cell's size in pixels (width, height); nominal 10 × 20 for half-blocks.
    pub cell_px: (u16, u16),
    /// The one-line hint to show once (images cannot get through, or a forced protocol may not).
    pub hint: Option<String>,
}

/// The nominal cell of half-blocks, px (their pixel size only sets the sampling).
pub const HALFBLOCK_CELL_PX: (u16, u16) = (10, 20);

impl ImageSetup {
    /// Settles `choice` with the cell size the terminal answered (`answered`) or the window
    /// reports (`window`: its pixels ÷ cells, when nonzero). Sixel without a known cell size
    /// cannot be sized to the preview: half-blocks and a hint instead.
    pub fn settle(
        choice: mux::Choice,
        answered: Option<(u16, u16)>,
        window: Option<(u16, u16)>,
    ) -> ImageSetup {
        let cell_px = answered.or(window).filter(|&(w, h)| w > 0 && h > 0);
        match (choice.protocol, cell_px) {
            (mux::Protocol::Halfblocks, _) => ImageSetup {
                protocol: mux::Protocol::Halfblocks,
                passthrough: false,
                cell_px: HALFBLOCK_CELL_PX,
                hint: choice.hint,
            },
            (mux::Protocol::Sixel, None) => ImageSetup {
                protocol: mux::Protocol::Halfblocks,
                passthrough: false,
                cell_px: HALFBLOCK_CELL_PX,
                hint: Some(
                    "half-blocks: the terminal did not tell its cell size in pixels, which sixel needs"
                        .into(),
                ),
            },
            (protocol, cell_px) => ImageSetup {
                protocol,
                passthrough: choice.passthrough,
                // kitty and iTerm2 scale the image to the cells: any size will do.
                cell_px: cell_px.unwrap_or(HALFBLOCK_CELL_PX),
                hint: choice.hint,
            },
        }
    }

    /// Detects the setup for `requested` (in raw mode on the alternate screen, before anything
    /// reads the keyboard): the multiplexer, the terminal's answers, the environment.
    pub fn detect(requested: Graphics) -> ImageSetup {
        let multiplexer = mux::detect_here();
        let answers = probe::ask(multiplexer).unwrap_or_default();
        let hints = mux::TerminalHints::from_env(|name| std::env::var(name).ok());
        let choice = mux::choose(requested, multiplexer, &answers, hints);
        let window = window_size().ok().and_then(|w| {
            (w.columns > 0 && w.rows > 0 && w.width > 0 && w.height > 0)
                .then(|| (w.width / w.columns, w.height / w.rows))
        });
        ImageSetup::settle(choice, answers.cell_px, window)
    }

    /// The status line's name, e.g. `sixel 9×18 px`.
    pub fn label(&self) -> String {
        let (w, h) = self.cell_px;
        match self.protocol {
            mux::Protocol::Halfblocks => "half-blocks".into(),
            protocol => format!("{} {w}×{h} px", protocol.label()),
        }
    }

    /// The pixel size to render for a preview of `cells`: cells × cell size, except for
    /// half-blocks (one pixel per column, two per row: all they can show).
    pub fn frame_px(&self, cells: Size) -> (u32, u32) {
        match self.protocol {
            mux::Protocol::Halfblocks => (u32::from(cells.width), 2 * u32::from(cells.height)),
            _ => (
                u32::from(cells.width) * u32::from(self.cell_px.0),
                u32::from(cells.height) * u32::from(self.cell_px.1),
            ),
        }
    }
}

/// The kitty image id the editor uses for its preview: every frame replaces the image in place.
pub const KITTY_IMAGE_ID: u32 = 0x48_4B_31;

/// A frame ready for the terminal.
#[derive(Clone)]
pub enum FrameImage {
    /// Sixel, iTerm2 or half-blocks, drawn through ratatui-image.
    Protocol(Protocol),
    /// kitty placeholders and the image's transmission.
    Kitty {
        /// The transmission (sent with the first placeholder cell).
        transmit: String,
        /// The cells covered.
        cells: Size,
    },
}

impl FrameImage {
    /// The cells the image covers.
    pub fn size(&self) -> Size {
        match self {
            FrameImage::Protocol(protocol) => protocol.size(),
            FrameImage::Kitty { cells, .. } => *cells,
        }
    }

    /// Draws the image at the top left of `area` (nothing when it does not fit).
    pub fn draw(&self, area: Rect, buf: &mut Buffer) {
        let size = self.size();
        if size.width > area.width || size.height > area.height {
            return;
        }
        match self {
            FrameImage::Protocol(protocol) => Image::new(protocol).render(area, buf),
            FrameImage::Kitty { transmit, cells } => kitty::draw(
                transmit,
                KITTY_IMAGE_ID,
                Rect::new(area.x, area.y, cells.width, cells.height),
                buf,
            ),
        }
    }
}

/// Encodes a frame of `size` pixels (width, height), rendered for `plan` (its divisor of
/// [`ImageSetup::frame_px`], and for sixel whether a full frame is dithered) for a preview of
/// `cells`, with `setup`'s protocol. No sequence erases the area first: the new image is drawn
/// over the old one.
///
/// Errors (internal): `rgba` does not hold `size` pixels, or an encoder failed.
pub fn encode_frame(
    setup: &ImageSetup,
    rgba: &[u8],
    size: (u32, u32),
    plan: FramePlan,
    cells: Size,
) -> Result<FrameImage> {
    let failed = |e: ratatui_image::errors::Errors| {
        Error::internal(format!("preview: encoding the image failed: {e}"))
    };
    let image = || {
        RgbaImage::from_raw(size.0, size.1, rgba.to_vec())
            .map(DynamicImage::ImageRgba8)
            .ok_or_else(|| Error::internal("preview: the frame's size does not match its pixels"))
    };
    match setup.protocol {
        mux::Protocol::Sixel => {
            let shown = setup.frame_px(cells);
            let data = sixel::encode_frame(
                rgba,
                (size.0 as usize, size.1 as usize),
                plan.divisor(),
                (shown.0 as usize, shown.1 as usize),
                plan == FramePlan::Full { dither: true },
            )?;
            Ok(FrameImage::Protocol(Protocol::Sixel(Sixel {
                data,
                size: cells,
                is_tmux: false,
            })))
        }
        mux::Protocol::Kitty => Ok(FrameImage::Kitty {
            transmit: kitty::transmit(
                rgba,
                size,
                (cells.width, cells.height),
                KITTY_IMAGE_ID,
                kitty::Payload::Png,
                setup.passthrough,
            )?,
            cells,
        }),
        mux::Protocol::Iterm2 => Ok(FrameImage::Protocol(Protocol::ITerm2(Iterm2 {
            data: iterm2_sequence(&png::encode(rgba, size)?, cells, setup.passthrough),
            size: cells,
            is_tmux: setup.passthrough,
        }))),
        mux::Protocol::Halfblocks => Ok(FrameImage::Protocol(Protocol::Halfblocks(
            Halfblocks::new(image()?, cells).map_err(failed)?,
        ))),
    }
}

/// The iTerm2 inline image sequence for `png`, stretched over `cells`, without moving the
/// cursor; wrapped for tmux when `tmux` is set.
pub fn iterm2_sequence(png: &[u8], cells: Size, tmux: bool) -> String {
    let sequence = format!(
        "\x1b]1337;File=inline=1;size={};width={};height={};preserveAspectRatio=0;doNotMoveCursor=1:{}\x07",
        png.len(),
        cells.width,
        cells.height,
        base64_simd::STANDARD.encode_to_string(png)
    );
    if tmux {
        probe::wrap_for_tmux(&sequence)
    } else {
        sequence
    }
}

/// What a terminal receives to show `frame` once in an empty `area` (cells): the escape
/// sequences crossterm writes for the drawn cells, image payload, colours and cursor moves.
///
/// Errors (internal): writing to the in-memory buffer failed.
pub fn frame_sequence(frame: &FrameImage, area: Rect) -> Result<Vec<u8>> {
    let mut buffer = Buffer::empty(area);
    frame.draw(area, &mut buffer);
    let changes = Buffer::empty(area).diff(&buffer);
    let mut written = Vec::new();
    CrosstermBackend::new(&mut written)
        .draw(changes.into_iter())
        .map_err(|e| Error::internal(format!("preview: measuring bytes failed: {e}")))?;
    Ok(written)
}

/// The length of [`frame_sequence`].
///
/// Errors (internal): writing to the in-memory buffer failed.
pub fn frame_bytes(frame: &FrameImage, area: Rect) -> Result<usize> {
    Ok(frame_sequence(frame, area)?.len())
}

#[cfg(test)]
mod tests {
    use ratatui_image::picker::ProtocolType;

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
        }
    }

    fn setup(protocol: mux::Protocol) -> ImageSetup {
        ImageSetup {
            protocol,
            passthrough: false,
            cell_px: (10, 20),
            hint: None,
        }
    }

    #[test]
    fn the_setup_needs_a_cell_size_for_sixel_only() {
        let choice = |protocol| mux::Choice {
            protocol,
            passthrough: true,
            hint: None,
        };
        let sixel = ImageSetup::settle(choice(mux::Protocol::Sixel), Some((9, 18)), Some((8, 16)));
        assert_eq!(
            (sixel.protocol, sixel.cell_px, sixel.label().as_str()),
            (mux::Protocol::Sixel, (9, 18), "sixel 9×18 px")
        );
        let from_window = ImageSetup::settle(choice(mux::Protocol::Sixel), None, Some((8, 16)));
        assert_eq!(from_window.cell_px, (8, 16));
        let unknown = ImageSetup::settle(choice(mux::Protocol::Sixel), None, Some((0, 0)));
        assert_eq!(unknown.protocol, mux::Protocol::Halfblocks);
        assert!(unknown.hint.unwrap().contains("cell size"));
        let kitty = ImageSetup::settle(choice(mux::Protocol::Kitty), None, None);
        assert_eq!(
            (kitty.protocol, kitty.passthrough, kitty.cell_px),
            (mux::Protocol::Kitty, true, (10, 20))
        );
        let blocks = ImageSetup::settle(choice(mux::Protocol::Halfblocks), Some((9, 18)), None);
        assert_eq!(
            (blocks.passthrough, blocks.label().as_str()),
            (false, "half-blocks")
        );
        assert_eq!(blocks.frame_px(Size::new(94, 44)), (94, 88));
        assert_eq!(sixel.frame_px(Size::new(94, 44)), (846, 792));
    }

    #[test]
    fn a_sixel_frame_is_our_sequence_alone_over_its_cells() {
        let cells = Size::new(16, 8);
        let frame = encode_frame(
            &setup(mux::Protocol::Sixel),
            gradient(160, 160).data(),
            (160, 160),
            FramePlan::Full { dither: false },
            cells,
        )
        .unwrap();
        let FrameImage::Protocol(Protocol::Sixel(ref image)) = frame else {
            panic!("not a sixel");
        };
        assert_eq!(image.size, cells);
        // Nothing erases the cells first (no ECH): the image is drawn over the old one.
        assert!(
            image.data.starts_with(sixel::INTRODUCER),
            "{:?}",
            &image.data[..20]
        );
        assert!(image.data.ends_with(sixel::TERMINATOR));
        // On the wire: the sequence plus a cursor move.
        let bytes = frame_bytes(&frame, Rect::new(0, 0, 16, 8)).unwrap();
        assert!(
            bytes >= image.data.len() && bytes < image.data.len() + 64,
            "{bytes} for {}",
            image.data.len()
        );
        // An interactive frame at 1/2 covers the same cells.
        let half = encode_frame(
            &setup(mux::Protocol::Sixel),
            gradient(80, 80).data(),
            (80, 80),
            FramePlan::Interactive { divisor: 2 },
            cells,
        )
        .unwrap();
        assert_eq!(half.size(), cells);
    }

    #[test]
    fn a_kitty_frame_is_placeholders_carrying_the_png() {
        let cells = Size::new(16, 8);
        let frame = encode_frame(
            &setup(mux::Protocol::Kitty),
            gradient(80, 80).data(),
            (80, 80),
            FramePlan::Interactive { divisor: 2 },
            cells,
        )
        .unwrap();
        let area = Rect::new(0, 0, 20, 10);
        let mut buffer = Buffer::empty(area);
        frame.draw(area, &mut buffer);
        let first = buffer[(0, 0)].symbol().to_string();
        assert!(
            first.starts_with("\x1b_Ga=T,U=1,q=2,t=d,i=4737841,c=16,r=8,f=100"),
            "{:?}",
            &first[..40]
        );
        assert!(buffer[(15, 7)].symbol().starts_with(kitty::PLACEHOLDER));
        assert_eq!(buffer[(16, 7)].symbol(), " ");
        // Too small an area: nothing drawn.
        let mut small = Buffer::empty(Rect::new(0, 0, 15, 8));
        frame.draw(Rect::new(0, 0, 15, 8), &mut small);
        assert_eq!(small, Buffer::empty(Rect::new(0, 0, 15, 8)));
    }

    #[test]
    fn an_iterm2_frame_is_stretched_over_its_cells() {
        let cells = Size::new(16, 8);
        let frame = encode_frame(
            &setup(mux::Protocol::Iterm2),
            gradient(40, 40).data(),
            (40, 40),
            FramePlan::Interactive { divisor: 4 },
            cells,
        )
        .unwrap();
        let FrameImage::Protocol(Protocol::ITerm2(ref image)) = frame else {
            panic!("not iTerm2");
        };
        assert!(
            image.data.starts_with("\x1b]1337;File=inline=1;size="),
            "{:?}",
            &image.data[..30]
        );
        assert!(
            image
                .data
                .contains(";width=16;height=8;preserveAspectRatio=0;doNotMoveCursor=1:")
        );
        let wrapped = iterm2_sequence(b"png", cells, true);
        assert!(wrapped.starts_with("\x1bPtmux;\x1b\x1b]1337;"), "{wrapped:?}");
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
