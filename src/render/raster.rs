//! The triangle rasterizer: screen-space triangles → colour, depth and ID buffers.
//!
//! Vertices are snapped to 1/256 pixel and the three edge functions are evaluated exactly in
//! i64 at pixel centres, with the top-left fill rule: a triangle sharing an edge with another
//! never leaves a crack and never covers a pixel twice, whatever the evaluation order. Depth
//! is reversed (larger = nearer, cleared to 0 = infinitely far) and interpolated linearly in
//! screen space; attributes are interpolated perspective-correctly (`attr/w` and `1/w`). Along a
//! row the interpolants are stepped per pixel from their exact value at the span's first pixel
//! (f64 sums, re-anchored every row: the drift along a row is ~1e-12 of the values' scale).
//! Rows are split into bands rendered in parallel; each band visits its triangles in input
//! order, so the result is the same on any number of threads (depth ties: first drawn wins).

use rayon::prelude::*;

/// Sub-pixel resolution of snapped vertex coordinates (1/256 pixel).
const SUBPIXEL: i64 = 256;
/// Rows per parallel band.
const BAND_ROWS: u32 = 16;

/// A triangle vertex in screen space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScreenVertex {
    /// Pixel x (continuous; pixel centres at +0.5).
    pub x: f64,
    /// Pixel y, down (continuous; pixel centres at +0.5).
    pub y: f64,
    /// Reversed NDC depth in (0, 1]: larger is nearer.
    pub depth: f32,
    /// `1 / w`: reciprocal of the clip `w` (distance along the view axis, 1/m); 1 for an
    /// orthographic (affine) triangle.
    pub inv_w: f32,
    /// The vertex attribute (linear RGB triple), interpolated perspective-correctly.
    pub attr: [f32; 3],
}

/// A triangle to rasterize with the id written to the ID buffer where it is visible.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScreenTriangle {
    /// Its vertices (either winding).
    pub vertices: [ScreenVertex; 3],
    /// The id (e.g. a patch id); must not be [`BACKGROUND_ID`].
    pub id: u32,
}

/// ID-buffer value of pixels no triangle covers.
pub const BACKGROUND_ID: u32 = u32::MAX;

/// Rasterized buffers, row-major from the top-left pixel, `width × height` each.
#[derive(Debug, Clone, PartialEq)]
pub struct Raster<P> {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The shaded value per pixel (the background where nothing is drawn).
    pub pixels: Vec<P>,
    /// Reversed NDC depth per pixel (0 where nothing is drawn).
    pub depth: Vec<f32>,
    /// Triangle id per pixel ([`BACKGROUND_ID`] where nothing is drawn).
    pub ids: Vec<u32>,
}

/// Rasterizes `triangles` into a `width × height` image: for each covered pixel the nearest
/// triangle's interpolated attribute goes through `shade`; uncovered pixels keep `background`.
pub fn rasterize<P, F>(
    triangles: &[ScreenTriangle],
    width: u32,
    height: u32,
    background: P,
    shade: F,
) -> Raster<P>
where
    P: Copy + Send + Sync,
    F: Fn([f32; 3]) -> P + Sync,
{
    let n_pixels = width as usize * height as usize;
    let mut raster = Raster {
        width,
        height,
        pixels: vec![background; n_pixels],
        depth: vec![0.0; n_pixels],
        ids: vec![BACKGROUND_ID; n_pixels],
    };
    let target = Target {
        width,
        height,
        pixels: &mut raster.pixels,
        depth: &mut raster.depth,
        ids: &mut raster.ids,
    };
    rasterize_into(target, triangles, background, shade);
    raster
}

/// The three output buffers of a `width × height` image, borrowed (row-major from the
/// top-left pixel): what [`rasterize_into`] draws into.
pub struct Target<'a, P> {
    width: u32,
    height: u32,
    pixels: &'a mut [P],
    depth: &'a mut [f32],
    ids: &'a mut [u32],
}

impl<'a, P> Target<'a, P> {
    /// Borrows the buffers; `None` unless each holds exactly `width × height` values.
    pub fn new(
        width: u32,
        height: u32,
        pixels: &'a mut [P],
        depth: &'a mut [f32],
        ids: &'a mut [u32],
    ) -> Option<Self> {
        let n = width as usize * height as usize;
        (pixels.len() == n && depth.len() == n && ids.len() == n).then_some(Target {
            width,
            height,
            pixels,
            depth,
            ids,
        })
    }
}

/// As [`rasterize`], into existing buffers: they are cleared (to `background`, depth 0 and
/// [`BACKGROUND_ID`]) and drawn band by band in parallel, without allocating image-sized memory
/// (the editor redraws into the same buffers after every edit).
pub fn rasterize_into<P, F>(target: Target<'_, P>, triangles: &[ScreenTriangle], background: P, shade: F)
where
    P: Copy + Send + Sync,
    F: Fn([f32; 3]) -> P + Sync,
{
    let Target {
        width,
        height,
        pixels,
        depth,
        ids,
    } = target;
    let setups: Vec<Setup> = triangles
        .par_iter()
        .filter_map(|t| Setup::new(t, width, height))
        .collect();
    let n_bands = height.div_ceil(BAND_ROWS) as usize;
    let mut bins: Vec<Vec<u32>> = vec![Vec::new(); n_bands];
    for (index, setup) in setups.iter().enumerate() {
        let first = (setup.rows.0 / BAND_ROWS) as usize;
        let last = (setup.rows.1 / BAND_ROWS) as usize;
        for bin in &mut bins[first..=last] {
            bin.push(index as u32);
        }
    }
    let band_len = (BAND_ROWS * width) as usize;
    pixels
        .par_chunks_mut(band_len)
        .zip(depth.par_chunks_mut(band_len))
        .zip(ids.par_chunks_mut(band_len))
        .zip(bins.par_iter())
        .enumerate()
        .for_each(|(band, (((pixels, depth), ids), bin))| {
            pixels.fill(background);
            depth.fill(0.0);
            ids.fill(BACKGROUND_ID);
            let mut target = Band {
                width,
                first_row: band as u32 * BAND_ROWS,
                pixels,
                depth,
                ids,
            };
            for &index in bin {
                target.draw(&setups[index as usize], &shade);
            }
        });
}

/// A triangle ready to scan: snapped vertices, edge functions, pixel bounds, attributes.
struct Setup {
    /// Edge i runs from vertex i+1 to vertex i+2: origin (fixed point) and direction.
    origin: [[i64; 2]; 3],
    delta: [[i64; 2]; 3],
    /// 0 for top-left edges, 1 otherwise: a centre is inside edge i when `E_i ≥ threshold_i`.
    threshold: [i64; 3],
    /// Inclusive pixel column and row ranges (clamped to the image).
    cols: (u32, u32),
    rows: (u32, u32),
    /// Per vertex: the quantities interpolated linearly in screen space, [`Interpolants`].
    values: [Interpolants; 3],
    /// Change of each interpolant per pixel to the right.
    dx: Interpolants,
    /// Change of each edge function per pixel to the right.
    step: [i64; 3],
    inv_area: f64,
    id: u32,
}

/// Depth, `1/w` and `attr/w` (three channels): what is linear in screen space.
type Interpolants = [f64; 5];

/// The interpolants of a point with barycentric weights `b`.
#[inline(always)]
fn blend(values: &[Interpolants; 3], b: [f64; 3]) -> Interpolants {
    let mut out = [0.0; 5];
    for (q, o) in out.iter_mut().enumerate() {
        *o = b[0] * values[0][q] + b[1] * values[1][q] + b[2] * values[2][q];
    }
    out
}

impl Setup {
    /// `None` when the triangle is degenerate, not finite or entirely outside the image.
    fn new(triangle: &ScreenTriangle, width: u32, height: u32) -> Option<Setup> {
        let mut v = triangle.vertices;
        let limit = 1e9;
        if v.iter().any(|p| !(p.x.abs() < limit && p.y.abs() < limit)) {
            return None;
        }
        let snap = |p: &ScreenVertex| {
            [
                (p.x * SUBPIXEL as f64).round() as i64,
                (p.y * SUBPIXEL as f64).round() as i64,
            ]
        };
        let mut pos = [snap(&v[0]), snap(&v[1]), snap(&v[2])];
        let mut area = edge_function(pos[0], pos[1], pos[2]);
        if area == 0 {
            return None;
        }
        if area < 0 {
            v.swap(1, 2);
            pos.swap(1, 2);
            area = -area;
        }
        let cols = pixel_range(pos.iter().map(|p| p[0]), width)?;
        let rows = pixel_range(pos.iter().map(|p| p[1]), height)?;
        let mut origin = [[0; 2]; 3];
        let mut delta = [[0; 2]; 3];
        let mut threshold = [0; 3];
        for i in 0..3 {
            let (a, b) = (pos[(i + 1) % 3], pos[(i + 2) % 3]);
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            origin[i] = a;
            delta[i] = [dx, dy];
            // y is down and the winding makes the interior lie where E > 0: left edges go up,
            // top edges are horizontal going right.
            let top_left = dy < 0 || (dy == 0 && dx > 0);
            threshold[i] = i64::from(!top_left);
        }
        let values = v.map(|p| {
            let inv_w = f64::from(p.inv_w);
            let [r, g, b] = p.attr.map(|a| f64::from(a) * inv_w);
            [f64::from(p.depth), inv_w, r, g, b]
        });
        let inv_area = 1.0 / area as f64;
        let step = [0, 1, 2].map(|i| -delta[i][1] * SUBPIXEL);
        let dx = blend(&values, step.map(|s| s as f64 * inv_area));
        Some(Setup {
            origin,
            delta,
            threshold,
            cols,
            rows,
            values,
            dx,
            step,
            inv_area,
            id: triangle.id,
        })
    }
}

/// Twice the signed area of (a, b, p) in fixed point: `E_ab(p) = (b−a) × (p−a)` (y down).
fn edge_function(a: [i64; 2], b: [i64; 2], p: [i64; 2]) -> i64 {
    (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
}

/// Inclusive range of pixel indices whose centres lie within the fixed-point extent of
/// `coords`, clamped to `0..size`; `None` when empty.
fn pixel_range(coords: impl Iterator<Item = i64> + Clone, size: u32) -> Option<(u32, u32)> {
    let lo = coords.clone().min()?;
    let hi = coords.max()?;
    let half = SUBPIXEL / 2;
    // First index with centre ≥ lo: ceil((lo − half) / SUBPIXEL); last with centre ≤ hi.
    let first = -(half - lo).div_euclid(SUBPIXEL);
    let last = (hi - half).div_euclid(SUBPIXEL);
    let first = first.max(0);
    let last = last.min(i64::from(size) - 1);
    (first <= last).then_some((first as u32, last as u32))
}

/// One band of rows of the output buffers.
struct Band<'a, P> {
    width: u32,
    first_row: u32,
    pixels: &'a mut [P],
    depth: &'a mut [f32],
    ids: &'a mut [u32],
}

impl<P: Copy> Band<'_, P> {
    fn draw(&mut self, t: &Setup, shade: &impl Fn([f32; 3]) -> P) {
        let band_rows = (self.pixels.len() / self.width as usize) as u32;
        let row_lo = t.rows.0.max(self.first_row);
        let row_hi = t.rows.1.min(self.first_row + band_rows - 1);
        let half = SUBPIXEL / 2;
        let x0 = i64::from(t.cols.0) * SUBPIXEL + half;
        for row in row_lo..=row_hi {
            let y = i64::from(row) * SUBPIXEL + half;
            let mut e = [0i64; 3];
            for i in 0..3 {
                let ([ax, ay], [dx, dy]) = (t.origin[i], t.delta[i]);
                e[i] = dx * (y - ay) - dy * (x0 - ax);
            }
            let Some((first, last)) = covered_span(e, t.step, t.threshold, t.cols.1 - t.cols.0) else {
                continue;
            };
            let b = [0, 1, 2].map(|i| (e[i] + t.step[i] * i64::from(first)) as f64 * t.inv_area);
            let mut v = blend(&t.values, b);
            let row_start = (row - self.first_row) as usize * self.width as usize;
            let span = row_start + (t.cols.0 + first) as usize..=row_start + (t.cols.0 + last) as usize;
            let pixels = &mut self.pixels[span.clone()];
            let depth = &mut self.depth[span.clone()];
            let ids = &mut self.ids[span];
            for ((pixel, stored), id) in pixels.iter_mut().zip(depth.iter_mut()).zip(ids.iter_mut()) {
                let z = v[0] as f32;
                if z > *stored {
                    // Perspective-correct: attr/w and 1/w are linear in screen space.
                    let w = 1.0 / v[1];
                    *stored = z;
                    *id = t.id;
                    *pixel = shade([(v[2] * w) as f32, (v[3] * w) as f32, (v[4] * w) as f32]);
                }
                for q in 0..5 {
                    v[q] += t.dx[q];
                }
            }
        }
    }
}

/// The pixel offsets `k ∈ [0, max_k]` along a row where every edge function `e_i + k·step_i`
/// reaches its threshold, exactly (integer arithmetic; the same set a per-pixel test gives).
fn covered_span(e: [i64; 3], step: [i64; 3], threshold: [i64; 3], max_k: u32) -> Option<(u32, u32)> {
    let (mut lo, mut hi) = (0i64, i64::from(max_k));
    for i in 0..3 {
        let need = threshold[i] - e[i]; // k·step ≥ need
        match step[i].signum() {
            1 => lo = lo.max(-(-need).div_euclid(step[i])),
            -1 => hi = hi.min((-need).div_euclid(-step[i])),
            _ if need > 0 => return None,
            _ => {}
        }
    }
    (lo <= hi).then_some((lo as u32, hi as u32))
}
