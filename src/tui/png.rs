//! PNG for terminal images (kitty and iTerm2): fast deflate with adaptive filters, which suit
//! rendered gradients (docs/BENCHMARKS.md "Terminal frames").

use image::ImageEncoder;
use image::codecs::png::{CompressionType, FilterType, PngEncoder};

use crate::error::{Error, Result};

/// The PNG of the opaque RGBA image `rgba` of `size` (width, height) pixels.
///
/// Errors (internal): `rgba` does not hold `size` pixels, or the encoder failed.
pub fn encode(rgba: &[u8], size: (u32, u32)) -> Result<Vec<u8>> {
    if rgba.len() as u64 != u64::from(size.0) * u64::from(size.1) * 4 {
        return Err(Error::internal(format!(
            "PNG: {} bytes are not a {} × {} RGBA image",
            rgba.len(),
            size.0,
            size.1
        )));
    }
    let mut png = Vec::new();
    PngEncoder::new_with_quality(&mut png, CompressionType::Fast, FilterType::Adaptive)
        .write_image(rgba, size.0, size.1, image::ExtendedColorType::Rgba8)
        .map_err(|e| Error::internal(format!("PNG encoding failed: {e}")))?;
    Ok(png)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_png_decodes_to_the_same_pixels() {
        let rgba: Vec<u8> = (0..37 * 11)
            .flat_map(|i: u32| [(i * 7) as u8, (i / 37 * 20) as u8, 5, 255])
            .collect();
        let png = encode(&rgba, (37, 11)).unwrap();
        assert_eq!(image::load_from_memory(&png).unwrap().to_rgba8().as_raw(), &rgba);
        assert_eq!(encode(&rgba, (36, 11)).unwrap_err().exit_code(), 1);
    }
}
