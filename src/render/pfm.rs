//! Per-pixel numbers out: the Portable Float Map (PFM) greyscale format, for tools and tests.
//!
//! The file is the header `Pf\n<width> <height>\n-1.0\n` (`Pf`: one channel; a negative scale
//! means little-endian floats, and its magnitude 1.0 leaves the values as they are) followed by
//! `width × height` f32 values, **rows from the bottom of the image to the top**, each row left
//! to right. Haiko writes illuminance in lux, 0 where a pixel sees no surface.

use std::path::Path;

use crate::error::{Error, Result};

/// The PFM file of a one-channel image given row-major from the **top**-left pixel (as Haiko's
/// buffers are). Errors (internal): `values` does not hold `width × height` values.
pub fn encode_pfm(width: u32, height: u32, values: &[f32]) -> Result<Vec<u8>> {
    let (w, h) = (width as usize, height as usize);
    if values.len() != w * h || w == 0 || h == 0 {
        return Err(Error::internal(format!(
            "pfm: {} values for a {width}×{height} image",
            values.len()
        )));
    }
    let header = format!("Pf\n{width} {height}\n-1.0\n");
    let mut bytes = Vec::with_capacity(header.len() + 4 * values.len());
    bytes.extend_from_slice(header.as_bytes());
    for row in values.chunks_exact(w).rev() {
        for v in row {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    Ok(bytes)
}

/// Writes [`encode_pfm`] of the image to `path` atomically (a failed write leaves the previous
/// file, if any; see [`crate::fsio`]). Errors (internal): the file cannot be written.
pub fn write_pfm(path: &Path, width: u32, height: u32, values: &[f32]) -> Result<()> {
    crate::fsio::write_atomic(path, &encode_pfm(width, height, values)?)
}

/// Rec. 709 luma (lx for illuminance) of per-pixel linear RGB values: what a PFM of
/// illuminance holds for coloured light (docs/DECISIONS.md, "Units"); a grey value is returned
/// exactly.
pub fn luma_values(rgb: &[[f32; 3]]) -> Vec<f32> {
    rgb.iter()
        .map(|e| {
            if e[0] == e[1] && e[1] == e[2] {
                e[1]
            } else {
                0.2126 * e[0] + 0.7152 * e[1] + 0.0722 * e[2]
            }
        })
        .collect()
}
