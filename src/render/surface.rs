//! What every pixel of a view sees, exactly: the patch (from the ID buffer), the point where
//! the ray through the pixel centre meets that patch's plane, and the patch triangle and
//! barycentric weights there (to interpolate per-vertex values such as indirect light).
//!
//! The point is intersected in f64 and stored in f32 (≈ 5e-7 m at 10 m), so per-pixel light is
//! evaluated where the exact ray from the eye lands, not where interpolated depth says; the
//! patch under the pixel centre is the rasterizer's (exact top-left rule on vertices snapped to
//! 1/256 pixel), which differs from the exact first hit only within 1/256 pixel of an edge.
//! World frame: metres, z up; pixels row-major from the top-left (docs/DECISIONS.md, "Renderer").

use glam::DVec3;
use rayon::prelude::*;

use super::camera::{RayBasis, View};
use super::raster::{BACKGROUND_ID, Target, rasterize_into};
use super::{BACKGROUND_RGB, Frame, clip};
use crate::error::{Error, Result};
use crate::scene::model::{PatchMesh, Surface};

/// Per-pixel triangle code of a pixel that sees no surface.
pub const NO_TRIANGLE: u32 = u32::MAX;

/// The visible surface at every pixel of one view, plus the per-patch data the per-pixel
/// lighting needs (normals, vertices, luminance factors), so it is self-contained.
#[derive(Debug, Clone, Default)]
pub struct PixelSurfaces {
    width: u32,
    height: u32,
    /// Exact visible point per pixel (world, m); unused where `triangles` is [`NO_TRIANGLE`].
    points: Vec<[f32; 3]>,
    /// Per pixel `2 · patch + half` (half 0: corners 0, 1, 2; half 1: corners 0, 2, 3 of a
    /// quad), or [`NO_TRIANGLE`].
    triangles: Vec<u32>,
    /// Per pixel the barycentric weights of the triangle's 2nd and 3rd corner.
    weights: Vec<[f32; 2]>,
    /// Per patch: unit normal (world, into the room).
    patch_normals: Vec<[f32; 3]>,
    /// Per patch: its vertex ids (first 3 or 4 used).
    patch_vertices: Vec<[u32; 4]>,
    /// Per patch: `ρ / π` per channel (sr⁻¹): luminance per lux of illuminance.
    patch_luminance: Vec<[f32; 3]>,
    /// Per patch: its surface id.
    patch_surface: Vec<u32>,
    /// Vertices of the mesh the surfaces were built from.
    n_vertices: usize,
}

impl PixelSurfaces {
    /// Rasterizes `mesh` through `view` into `frame` (ids and depth; the colour is the
    /// background) and finds every pixel's exact surface point and triangle weights. `frame` is
    /// reused when it has the view's size. `surfaces` are the scene's (for reflectances).
    ///
    /// Errors (internal): a patch that is not 3 or 4 valid vertices, or a patch surface outside
    /// `surfaces`.
    pub fn build(frame: &mut Frame, mesh: &PatchMesh, surfaces: &[Surface], view: &View) -> Result<Self> {
        let mut built = PixelSurfaces::default();
        built.rebuild(frame, mesh, surfaces, view)?;
        Ok(built)
    }

    /// As [`PixelSurfaces::build`], reusing this value's buffers (a camera move in the editor).
    /// Errors as [`PixelSurfaces::build`].
    pub fn rebuild(
        &mut self,
        frame: &mut Frame,
        mesh: &PatchMesh,
        surfaces: &[Surface],
        view: &View,
    ) -> Result<()> {
        let n_vertices = mesh.n_vertices();
        let mut patch_luminance = Vec::with_capacity(mesh.patches.len());
        for (pid, p) in mesh.patches.iter().enumerate() {
            if !(3..=4).contains(&p.n_vertices) || p.vertex_ids().iter().any(|&v| v as usize >= n_vertices) {
                return Err(Error::internal(format!(
                    "pixel surfaces: patch {pid} is not 3 or 4 vertices of {n_vertices}"
                )));
            }
            let surface = surfaces.get(p.surface as usize).ok_or_else(|| {
                Error::internal(format!(
                    "pixel surfaces: patch {pid} has surface {} of {}",
                    p.surface,
                    surfaces.len()
                ))
            })?;
            patch_luminance.push(
                surface
                    .reflectance
                    .0
                    .map(|rho| (rho / std::f64::consts::PI) as f32),
            );
        }
        let (width, height) = (view.width(), view.height());
        if (frame.ids.width(), frame.ids.height()) != (width, height) {
            *frame = Frame::new(width, height)?;
        }
        let zeros = vec![[0.0f32; 3]; n_vertices];
        let screen = clip::screen_triangles(mesh, &zeros, view);
        let (pixels, _) = frame.pixmap.data_mut().as_chunks_mut::<4>();
        let target = Target::new(width, height, pixels, &mut frame.depth, &mut frame.ids.ids)
            .ok_or_else(|| Error::internal("pixel surfaces: frame buffers do not match the image size"))?;
        let background = [BACKGROUND_RGB[0], BACKGROUND_RGB[1], BACKGROUND_RGB[2], 255];
        rasterize_into(target, &screen, background, |_| background);

        let n = width as usize * height as usize;
        self.width = width;
        self.height = height;
        self.points.resize(n, [0.0; 3]);
        self.triangles.resize(n, NO_TRIANGLE);
        self.weights.resize(n, [0.0; 2]);
        self.patch_normals = mesh
            .patches
            .iter()
            .map(|p| p.normal.as_vec3().to_array())
            .collect();
        self.patch_vertices = mesh.patches.iter().map(|p| p.vertices).collect();
        self.patch_luminance = patch_luminance;
        self.patch_surface = mesh.patches.iter().map(|p| p.surface).collect();
        self.n_vertices = n_vertices;

        seal_cracks(frame, mesh, view);
        let row = width as usize;
        let ids = frame.ids.as_slice();
        let depth = &frame.depth;
        let rays = view.pixel_ray_basis();
        self.points
            .par_chunks_mut(row)
            .zip(self.triangles.par_chunks_mut(row))
            .zip(self.weights.par_chunks_mut(row))
            .enumerate()
            .for_each(|(y, ((points, triangles), weights))| {
                for x in 0..row {
                    let i = y * row + x;
                    let id = ids[i];
                    if id == BACKGROUND_ID {
                        triangles[x] = NO_TRIANGLE;
                        continue;
                    }
                    let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
                    let patch = &mesh.patches[id as usize];
                    let point = visible_point(view, &rays, mesh, patch, px, py, f64::from(depth[i]));
                    let (half, w) = triangle_weights(mesh, patch, point);
                    points[x] = point.as_vec3().to_array();
                    triangles[x] = 2 * id + half;
                    weights[x] = [w[1] as f32, w[2] as f32];
                }
            });
        Ok(())
    }

    /// Image width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }
    /// Image height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }
    /// Number of pixels.
    pub fn len(&self) -> usize {
        self.triangles.len()
    }
    /// Number of vertices of the mesh the surfaces were built from.
    pub fn n_vertices(&self) -> usize {
        self.n_vertices
    }
    /// True for an empty (never built) value.
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// The patch pixel `i` (row-major) shows, `None` for the background.
    pub fn patch(&self, i: usize) -> Option<u32> {
        let t = *self.triangles.get(i)?;
        (t != NO_TRIANGLE).then_some(t / 2)
    }

    /// The exact visible point at pixel `i` (world, m), `None` for the background.
    pub fn point(&self, i: usize) -> Option<DVec3> {
        self.patch(i).map(|_| DVec3::from(self.points[i].map(f64::from)))
    }

    /// The unit normal of the surface at pixel `i` (world), `None` for the background.
    pub fn normal(&self, i: usize) -> Option<DVec3> {
        self.patch(i)
            .map(|p| DVec3::from(self.patch_normals[p as usize].map(f64::from)))
    }

    /// The surface id at pixel `i`, `None` for the background.
    pub fn surface(&self, i: usize) -> Option<u32> {
        self.patch(i).map(|p| self.patch_surface[p as usize])
    }

    /// The three vertex ids and barycentric weights that interpolate a per-vertex value at
    /// pixel `i` (the renderer's triangles: quads split along their 0–2 diagonal), `None` for
    /// the background.
    pub fn corners(&self, i: usize) -> Option<([u32; 3], [f32; 3])> {
        let t = *self.triangles.get(i)?;
        (t != NO_TRIANGLE).then(|| self.corners_of(t, self.weights[i]))
    }

    #[inline]
    fn corners_of(&self, triangle: u32, w: [f32; 2]) -> ([u32; 3], [f32; 3]) {
        let v = self.patch_vertices[(triangle / 2) as usize];
        let ids = if triangle & 1 == 0 {
            [v[0], v[1], v[2]]
        } else {
            [v[0], v[2], v[3]]
        };
        (ids, [1.0 - w[0] - w[1], w[0], w[1]])
    }

    /// `ρ / π` (sr⁻¹, per channel) of the surface at pixel `i`: luminance (cd/m²) per lux;
    /// `[0; 3]` for the background.
    #[inline]
    pub fn luminance_factor(&self, i: usize) -> [f32; 3] {
        match self.triangles[i] {
            NO_TRIANGLE => [0.0; 3],
            t => self.patch_luminance[(t / 2) as usize],
        }
    }

    /// Raw per-pixel triangle codes (`2 · patch + half` or [`NO_TRIANGLE`]).
    pub(crate) fn triangle_codes(&self) -> &[u32] {
        &self.triangles
    }

    /// Raw per-pixel barycentric weights of the triangle's 2nd and 3rd corner.
    pub(crate) fn raw_weights(&self) -> &[[f32; 2]] {
        &self.weights
    }

    /// Per-patch vertex ids (first 3 or 4 used).
    pub(crate) fn patch_vertex_ids(&self) -> &[[u32; 4]] {
        &self.patch_vertices
    }

    /// Per-patch `ρ / π` (sr⁻¹, per channel).
    pub(crate) fn patch_luminance_factors(&self) -> &[[f32; 3]] {
        &self.patch_luminance
    }

    /// Raw per-pixel points (world, m, f32).
    pub(crate) fn raw_points(&self) -> &[[f32; 3]] {
        &self.points
    }

    /// Per-patch unit normals (f32).
    pub(crate) fn patch_normals(&self) -> &[[f32; 3]] {
        &self.patch_normals
    }

    /// Bytes held per pixel (points, triangle codes, weights), for memory reports.
    pub const BYTES_PER_PIXEL: usize = 12 + 4 + 8;
}

/// Largest distance (pixels) between a pixel centre and a neighbour's patch for the pixel to
/// count as a crack in that patch: far above the 1/256-pixel vertex snapping that opens cracks
/// where two surfaces meet along an edge with different vertices, far below a pixel.
const CRACK_TOLERANCE_PX: f64 = 1.0 / 16.0;

/// Gives background pixels that lie on a neighbour's patch (within [`CRACK_TOLERANCE_PX`]) that
/// patch: where two surfaces meet along a line with vertices at different places (a box
/// standing on the floor), snapped edges can leave single pixel centres uncovered.
fn seal_cracks(frame: &mut Frame, mesh: &PatchMesh, view: &View) {
    let (w, h) = (frame.ids.width() as usize, frame.ids.height() as usize);
    let mut sealed = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if frame.ids.ids[i] != BACKGROUND_ID {
                continue;
            }
            let neighbours = [
                (x.wrapping_sub(1), y),
                (x + 1, y),
                (x, y.wrapping_sub(1)),
                (x, y + 1),
            ];
            let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
            let found = neighbours
                .iter()
                .filter(|&&(nx, ny)| nx < w && ny < h)
                .map(|&(nx, ny)| frame.ids.ids[ny * w + nx])
                .filter(|&id| id != BACKGROUND_ID)
                .find_map(|id| {
                    let patch = &mesh.patches[id as usize];
                    if view.culls_back_faces() && !view.sees_front(patch.normal, patch.centroid) {
                        return None;
                    }
                    let point = visible_point(view, &view.pixel_ray_basis(), mesh, patch, px, py, 0.0);
                    let (half, w) = triangle_weights(mesh, patch, point);
                    let v = patch.vertices;
                    let corners = if half == 0 {
                        [v[0], v[1], v[2]]
                    } else {
                        [v[0], v[2], v[3]]
                    };
                    let nearest: DVec3 = corners
                        .iter()
                        .zip(w)
                        .map(|(&c, wk)| mesh.positions[c as usize] * wk)
                        .sum();
                    let on_screen = view.project(nearest)?;
                    let off = (on_screen.x - px).hypot(on_screen.y - py);
                    (off <= CRACK_TOLERANCE_PX).then_some((id, on_screen.z as f32))
                });
            if let Some(hit) = found {
                sealed.push((i, hit));
            }
        }
    }
    for (i, (id, depth)) in sealed {
        frame.ids.ids[i] = id;
        frame.depth[i] = depth;
    }
}

/// Smallest |cos| between the pixel ray and a patch plane for which the plane intersection is
/// trusted; below it (a patch seen edge-on) the depth buffer's point is used.
const MIN_RAY_PLANE_COS: f64 = 1e-6;

/// The point where the ray through pixel `(x, y)` meets `patch`'s plane; the depth buffer's
/// point (`depth`) when the ray grazes the plane.
fn visible_point(
    view: &View,
    rays: &RayBasis,
    mesh: &PatchMesh,
    patch: &crate::scene::model::Patch,
    x: f64,
    y: f64,
    depth: f64,
) -> DVec3 {
    let (origin, dir) = rays.ray(x, y);
    let on_plane = mesh.positions[patch.vertices[0] as usize];
    let denominator = patch.normal.dot(dir);
    if denominator.abs() > MIN_RAY_PLANE_COS * dir.length() {
        let t = patch.normal.dot(on_plane - origin) / denominator;
        if t > 0.0 && t.is_finite() {
            return origin + t * dir;
        }
    }
    view.unproject(x, y, depth)
}

/// Which half of `patch` holds `point` (0 for a triangle) and its barycentric weights there
/// (clamped into the triangle, for points a rounding outside it).
fn triangle_weights(mesh: &PatchMesh, patch: &crate::scene::model::Patch, point: DVec3) -> (u32, [f64; 3]) {
    let v = patch.vertices;
    let p = |i: u32| mesh.positions[i as usize];
    let halves: &[[u32; 3]] = if patch.n_vertices == 4 {
        &[[v[0], v[1], v[2]], [v[0], v[2], v[3]]]
    } else {
        &[[v[0], v[1], v[2]]]
    };
    let mut best = (0, [1.0, 0.0, 0.0], f64::NEG_INFINITY);
    for (half, t) in halves.iter().enumerate() {
        let w = barycentric(point, p(t[0]), p(t[1]), p(t[2]));
        let inside = w[0].min(w[1]).min(w[2]);
        if inside > best.2 {
            best = (half as u32, w, inside);
        }
        if inside >= 0.0 {
            break;
        }
    }
    let w = best.1.map(|x| x.max(0.0));
    let sum = w[0] + w[1] + w[2];
    let w = if sum > 0.0 {
        w.map(|x| x / sum)
    } else {
        [1.0, 0.0, 0.0]
    };
    (best.0, w)
}

/// Barycentric weights of `p` (projected onto the triangle's plane) in triangle `a b c`; equal
/// weights for a degenerate triangle.
fn barycentric(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> [f64; 3] {
    let (e0, e1, d) = (b - a, c - a, p - a);
    let (d00, d01, d11) = (e0.dot(e0), e0.dot(e1), e1.dot(e1));
    let (d20, d21) = (d.dot(e0), d.dot(e1));
    let denom = d00 * d11 - d01 * d01;
    if denom.abs() <= f64::EPSILON * d00 * d11 {
        return [1.0 / 3.0; 3];
    }
    let v = (d11 * d20 - d01 * d21) / denom;
    let w = (d00 * d21 - d01 * d20) / denom;
    [1.0 - v - w, v, w]
}
