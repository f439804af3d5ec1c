//! Golden-image harness for render tests (the resvg pattern): colour images are compared with
//! a per-channel threshold and a maximum count of differing pixels; ID buffers exactly. On a
//! mismatch an `expected | diff | actual` PNG is written to the diff folder; with
//! `HAIKO_UPDATE_SNAPSHOTS=1` in the environment the references are (re)written instead.
//! ID buffers are stored as RGB PNGs with the id in the colour bytes (`0xRRGGBB`; background
//! is white).

use std::path::{Path, PathBuf};

use tiny_skia::{IntSize, Pixmap};

use super::{BACKGROUND_ID, IdBuffer};
use crate::error::{Error, Result};

/// Environment variable that turns comparisons into reference updates when set to `1`.
pub const UPDATE_ENV: &str = "HAIKO_UPDATE_SNAPSHOTS";

/// Largest patch id an ID-buffer PNG can hold (`0xFFFFFF` stands for the background).
pub const MAX_PNG_ID: u32 = 0xFF_FFFE;

/// Colour tolerance of an image comparison.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Tolerance {
    /// A pixel differs when some channel differs by more than this (0–255).
    pub channel: u8,
    /// The comparison fails when more pixels than this differ.
    pub max_pixels: usize,
}

/// Where references live and where failure pictures go.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Golden {
    /// Folder of reference PNGs (`<name>.png`, `<name>.ids.png`).
    pub reference_dir: PathBuf,
    /// Folder for `expected | diff | actual` pictures of failures.
    pub diff_dir: PathBuf,
    /// Write references instead of comparing.
    pub update: bool,
}

impl Golden {
    /// A harness over the two folders, updating when [`UPDATE_ENV`] is `1`.
    pub fn from_env(reference_dir: impl Into<PathBuf>, diff_dir: impl Into<PathBuf>) -> Golden {
        Golden {
            reference_dir: reference_dir.into(),
            diff_dir: diff_dir.into(),
            update: std::env::var(UPDATE_ENV).is_ok_and(|v| v == "1"),
        }
    }

    /// Compares `actual` with reference `<name>.png`. Errors (internal) name the number of
    /// differing pixels and the diff picture written.
    pub fn check_image(&self, name: &str, actual: &Pixmap, tolerance: Tolerance) -> Result<()> {
        let reference = self.reference_dir.join(format!("{name}.png"));
        if self.update {
            return save_pixmap(actual, &reference);
        }
        let expected = load_pixmap(&reference)?;
        if (expected.width(), expected.height()) != (actual.width(), actual.height()) {
            return Err(Error::internal(format!(
                "golden {name}: reference is {}×{}, image is {}×{}",
                expected.width(),
                expected.height(),
                actual.width(),
                actual.height()
            )));
        }
        let differing = count_differing(&expected, actual, tolerance.channel);
        if differing <= tolerance.max_pixels {
            return Ok(());
        }
        let diff_path = self.diff_dir.join(format!("{name}.png"));
        save_pixmap(&triptych(&expected, actual, tolerance.channel)?, &diff_path)?;
        Err(Error::internal(format!(
            "golden {name}: {differing} pixels differ by more than {} (allowed {}); see {}",
            tolerance.channel,
            tolerance.max_pixels,
            diff_path.display()
        )))
    }

    /// Compares `actual` exactly with reference `<name>.ids.png`.
    pub fn check_ids(&self, name: &str, actual: &IdBuffer) -> Result<()> {
        let reference = self.reference_dir.join(format!("{name}.ids.png"));
        if self.update {
            return save_pixmap(&ids_to_pixmap(actual)?, &reference);
        }
        let expected = ids_from_pixmap(&load_pixmap(&reference)?)?;
        if expected == *actual {
            return Ok(());
        }
        let differing = if (expected.width(), expected.height()) == (actual.width(), actual.height()) {
            expected
                .as_slice()
                .iter()
                .zip(actual.as_slice())
                .filter(|(a, b)| a != b)
                .count()
        } else {
            expected.as_slice().len().max(actual.as_slice().len())
        };
        Err(Error::internal(format!("golden {name}: {differing} ids differ")))
    }
}

/// Number of pixels where some RGBA channel of `a` and `b` differs by more than `channel`
/// (the images must have the same size; extra pixels of the larger count as differing).
pub fn count_differing(a: &Pixmap, b: &Pixmap, channel: u8) -> usize {
    let pairs = a.data().chunks_exact(4).zip(b.data().chunks_exact(4));
    let extra = a.data().len().abs_diff(b.data().len()) / 4;
    extra
        + pairs
            .filter(|(p, q)| p.iter().zip(*q).any(|(x, y)| x.abs_diff(*y) > channel))
            .count()
}

/// `expected | mask | actual` side by side; the mask is red where pixels differ, else a dimmed
/// copy of the expected image.
fn triptych(expected: &Pixmap, actual: &Pixmap, channel: u8) -> Result<Pixmap> {
    let (w, h) = (expected.width() as usize, expected.height() as usize);
    let mut data = Vec::with_capacity(3 * w * h * 4);
    for row in 0..h {
        let span = row * w * 4..(row + 1) * w * 4;
        let (e, a) = (&expected.data()[span.clone()], &actual.data()[span]);
        data.extend_from_slice(e);
        for (p, q) in e.chunks_exact(4).zip(a.chunks_exact(4)) {
            let differs = p.iter().zip(q).any(|(x, y)| x.abs_diff(*y) > channel);
            data.extend_from_slice(&if differs {
                [255, 0, 0, 255]
            } else {
                [p[0] / 3, p[1] / 3, p[2] / 3, 255]
            });
        }
        data.extend_from_slice(a);
    }
    let size =
        IntSize::from_wh(3 * w as u32, h as u32).ok_or_else(|| Error::internal("golden: empty image"))?;
    Pixmap::from_vec(data, size).ok_or_else(|| Error::internal("golden: bad triptych size"))
}

/// The ID buffer as an opaque image with each id in the RGB bytes (`0xRRGGBB`).
/// Errors (internal) for an id above [`MAX_PNG_ID`].
pub fn ids_to_pixmap(ids: &IdBuffer) -> Result<Pixmap> {
    let mut data = Vec::with_capacity(ids.as_slice().len() * 4);
    for &id in ids.as_slice() {
        let code = match id {
            BACKGROUND_ID => 0xFF_FFFF,
            id if id <= MAX_PNG_ID => id,
            id => {
                return Err(Error::internal(format!(
                    "golden: patch id {id} does not fit a PNG id image"
                )));
            }
        };
        data.extend_from_slice(&[(code >> 16) as u8, (code >> 8) as u8, code as u8, 255]);
    }
    let size =
        IntSize::from_wh(ids.width(), ids.height()).ok_or_else(|| Error::internal("golden: empty ids"))?;
    Pixmap::from_vec(data, size).ok_or_else(|| Error::internal("golden: bad id image size"))
}

/// The inverse of [`ids_to_pixmap`].
pub fn ids_from_pixmap(image: &Pixmap) -> Result<IdBuffer> {
    let ids = image
        .data()
        .chunks_exact(4)
        .map(
            |p| match u32::from(p[0]) << 16 | u32::from(p[1]) << 8 | u32::from(p[2]) {
                0xFF_FFFF => BACKGROUND_ID,
                id => id,
            },
        )
        .collect();
    IdBuffer::new(image.width(), image.height(), ids)
}

fn load_pixmap(path: &Path) -> Result<Pixmap> {
    Pixmap::load_png(path).map_err(|e| {
        Error::internal(format!(
            "golden: cannot read reference {} ({e}); run with {UPDATE_ENV}=1 to create it",
            path.display()
        ))
    })
}

fn save_pixmap(pixmap: &Pixmap, path: &Path) -> Result<()> {
    let fail =
        |e: &dyn std::fmt::Display| Error::internal(format!("golden: cannot write {}: {e}", path.display()));
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| fail(&e))?;
    }
    pixmap.save_png(path).map_err(|e| fail(&e))
}
