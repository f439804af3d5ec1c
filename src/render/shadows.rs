//! Shadow rays of the per-pixel direct light and the visibility bits they leave: one bit per
//! (light, pixel), laid out so that the parallel sweep of [`super::lighting`] owns whole words.
//! The pixels are cut into chunks of a multiple of 64 that cover [`TILE`] rows; a chunk holds
//! the words of every light in turn (docs/DECISIONS.md, "Per-pixel direct light").

use glam::DVec3;

use super::surface::PixelSurfaces;
use crate::transport::occlusion::Occluders;

/// Side of the square pixel tiles whose shadow rays share one set of nearby occluders.
const TILE: usize = 16;

/// Shadow rays start this far above the visible point, along its normal (m): clear of the f32
/// rounding of the stored point (≤ 5e-7 m in a room of 10 m).
const RAY_LIFT_M: f64 = 1e-5;

/// Pixels per sweep chunk for an image `width` pixels wide: [`TILE`] rows rounded up to a whole
/// number of 64-bit words.
pub(crate) fn chunk_pixels(width: usize) -> usize {
    (TILE * width.max(1)).next_multiple_of(64)
}

/// Bit `i` of light `k`: set when pixel `i` faces the light and the shadow ray to it is free.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ShadowBits {
    /// Pixels per chunk (a multiple of 64).
    chunk_px: usize,
    n_pixels: usize,
    n_lights: usize,
    /// Chunk after chunk, each `n_lights × chunk_px / 64` words, light after light.
    words: Vec<u64>,
}

/// One chunk's words of every light ([`ShadowBits::chunks_mut`]).
pub(crate) struct ShadowChunk<'a> {
    words: &'a mut [u64],
    /// Words per light.
    per_light: usize,
}

impl ShadowBits {
    /// All bits clear, for `n_lights` lights over `n_pixels` pixels of an image `width` wide.
    pub(crate) fn new(n_pixels: usize, width: usize, n_lights: usize) -> ShadowBits {
        let chunk_px = chunk_pixels(width);
        let chunks = n_pixels.div_ceil(chunk_px);
        ShadowBits {
            chunk_px,
            n_pixels,
            n_lights,
            words: vec![0; chunks * n_lights * chunk_px / 64],
        }
    }

    /// True when these bits were made for this image and number of lights.
    pub(crate) fn fits(&self, n_pixels: usize, width: usize, n_lights: usize) -> bool {
        (self.n_pixels, self.chunk_px, self.n_lights) == (n_pixels, chunk_pixels(width), n_lights)
    }

    /// Every chunk's words, in pixel order, for a parallel sweep (none without lights).
    pub(crate) fn chunks_mut(&mut self) -> Vec<ShadowChunk<'_>> {
        let per_light = self.chunk_px / 64;
        if self.n_lights == 0 {
            return Vec::new();
        }
        self.words
            .chunks_mut(self.n_lights * per_light)
            .map(|words| ShadowChunk { words, per_light })
            .collect()
    }
}

impl ShadowChunk<'_> {
    /// Clears the factor of pixel `j` of the chunk wherever light `k`'s bit is clear.
    pub(crate) fn mask(&self, k: usize, factor: &mut [f32]) {
        let words = &self.words[k * self.per_light..(k + 1) * self.per_light];
        for (word, f) in words.iter().zip(factor.chunks_mut(64)) {
            for (b, f) in f.iter_mut().enumerate() {
                if word >> b & 1 == 0 {
                    *f = 0.0;
                }
            }
        }
    }

    /// Sets light `k`'s bits from the factors of the chunk's pixels: set where positive.
    pub(crate) fn store(&mut self, k: usize, factor: &[f32]) {
        let words = &mut self.words[k * self.per_light..(k + 1) * self.per_light];
        for (word, f) in words.iter_mut().zip(factor.chunks(64)) {
            *word = f
                .iter()
                .enumerate()
                .fold(0, |acc, (b, &f)| acc | (u64::from(f > 0.0) << b));
        }
    }
}

/// Clears `factor[j]`, the lit factor of pixel `start + j`, wherever the shadow ray from just
/// above that pixel's point to the light at `light` (world, m) is blocked. The chunk's pixels
/// are grouped by columns of [`TILE`] pixels; each group tests only the occluders that can meet
/// a segment from the box around its points to the light ([`Occluders::toward`]), and none
/// casts a ray when none does.
pub(crate) fn cast_shadow_rays(
    occluders: &Occluders,
    surfaces: &PixelSurfaces,
    start: usize,
    light: DVec3,
    factor: &mut [f32],
) {
    let width = (surfaces.width() as usize).max(1);
    let columns = width.div_ceil(TILE);
    // Bounds of the rays' start points in f32, widened below by f32 rounding.
    let mut bounds = vec![([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]); columns];
    let range = start..start + factor.len();
    let (points, triangles) = (
        &surfaces.raw_points()[range.clone()],
        &surfaces.triangle_codes()[range],
    );
    let normals = surfaces.patch_normals();
    // The pixel's column, kept by counting: no division per pixel.
    let mut x = start % width;
    for ((&f, p), &t) in factor.iter().zip(points).zip(triangles) {
        if f > 0.0 {
            let (lo, hi) = &mut bounds[x / TILE];
            let n = normals[(t / 2) as usize];
            for axis in 0..3 {
                let from = p[axis] + n[axis] * RAY_LIFT_M as f32;
                lo[axis] = lo[axis].min(from);
                hi[axis] = hi[axis].max(from);
            }
        }
        x = if x + 1 == width { 0 } else { x + 1 };
    }
    let from = |j: usize| {
        let i = start + j;
        let t = surfaces.triangle_codes()[i];
        let point = DVec3::from(surfaces.raw_points()[i].map(f64::from));
        let normal = DVec3::from(surfaces.patch_normals()[(t / 2) as usize].map(f64::from));
        point + normal * RAY_LIFT_M
    };
    let near: Vec<_> = bounds
        .iter()
        .map(|&(lo, hi)| {
            (lo[0] <= hi[0])
                .then(|| {
                    let (lo, hi) = (DVec3::from(lo.map(f64::from)), DVec3::from(hi.map(f64::from)));
                    // The f32 start points are two roundings (4 ulp with margin) from the f64
                    // ones: the widened box holds every ray's start.
                    let pad = lo.abs().max(hi.abs()) * (4.0 * f64::from(f32::EPSILON)) + 1e-9;
                    occluders.toward(lo - pad, hi + pad, light)
                })
                .filter(|near| !near.is_empty())
        })
        .collect();
    if near.iter().all(Option::is_none) {
        return;
    }
    let mut x = start % width;
    for (j, f) in factor.iter_mut().enumerate() {
        if *f > 0.0
            && let Some(near) = &near[x / TILE]
            && near.blocked(from(j), light)
        {
            *f = 0.0;
        }
        x = if x + 1 == width { 0 } else { x + 1 };
    }
}
