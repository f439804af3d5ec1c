//! Mesh → screen triangles: back-face culling, clipping in homogeneous clip space and the
//! perspective divide.
//!
//! Triangles are clipped (Sutherland–Hodgman) against the near plane `w = z` (see
//! [`super::camera`]: `z = near` for a perspective view, the depth for an orthographic one) and a guard
//! band `|x|, |y| ≤ GUARD_BAND · w` that keeps snapped pixel coordinates small; the guard band
//! lies outside the image, so its cuts are never seen. An edge crossing a plane is always cut
//! from its inside end towards its outside end, so two triangles sharing that edge get
//! bit-identical new vertices and stay crack-free.

use glam::{DVec3, DVec4};
use rayon::prelude::*;

use super::camera::View;
use super::raster::{ScreenTriangle, ScreenVertex};
use crate::scene::model::PatchMesh;

/// Half-width of the guard band in NDC units (the image spans ±1).
const GUARD_BAND: f64 = 8.0;
/// Number of clip planes: near, then ±x and ±y guard band.
const N_PLANES: usize = 5;

/// A vertex in clip space with its attribute.
#[derive(Debug, Clone, Copy)]
struct ClipVertex {
    clip: DVec4,
    attr: DVec3,
}

impl ClipVertex {
    fn lerp(self, other: ClipVertex, t: f64) -> ClipVertex {
        ClipVertex {
            clip: self.clip.lerp(other.clip, t),
            attr: self.attr.lerp(other.attr, t),
        }
    }
}

/// Signed distance of a clip-space point to plane `plane` (inside when ≥ 0).
fn plane_distance(plane: usize, c: DVec4) -> f64 {
    match plane {
        0 => c.w - c.z,
        1 => GUARD_BAND * c.w - c.x,
        2 => GUARD_BAND * c.w + c.x,
        3 => GUARD_BAND * c.w - c.y,
        _ => GUARD_BAND * c.w + c.y,
    }
}

/// The screen triangles of every patch of `mesh` seen by `view`, with per-vertex `attrs`, in
/// patch order. The caller guarantees `attrs.len() == mesh.n_vertices()` and valid indices.
pub(crate) fn screen_triangles(mesh: &PatchMesh, attrs: &[[f32; 3]], view: &View) -> Vec<ScreenTriangle> {
    // Once per vertex: its clip-space form and, when it is inside every clip plane, its screen
    // vertex (shared bit for bit by all its triangles).
    let vertices: Vec<(ClipVertex, Option<ScreenVertex>)> = mesh
        .positions
        .par_iter()
        .zip(attrs.par_iter())
        .map(|(&position, attr)| {
            let v = ClipVertex {
                clip: view.clip_from_world(position),
                attr: DVec3::from(attr.map(f64::from)),
            };
            let inside = (0..N_PLANES).all(|k| plane_distance(k, v.clip) >= 0.0);
            (v, inside.then(|| to_screen(&v, view)))
        })
        .collect();
    let triangles: Vec<([u32; 3], u32)> = mesh.triangles().collect();
    let unused = ScreenVertex {
        x: 0.0,
        y: 0.0,
        depth: 0.0,
        inv_w: 0.0,
        attr: [0.0; 3],
    };
    triangles
        .par_iter()
        .flat_map_iter(|&(ids, patch_id)| {
            let patch = &mesh.patches[patch_id as usize];
            let facing = view.sees_front(patch.normal, patch.centroid);
            let [a, b, c] = ids.map(|i| vertices[i as usize]);
            let mut screen = [unused; MAX_POLYGON];
            let n = if view.culls_back_faces() && !facing {
                0
            } else if let (Some(sa), Some(sb), Some(sc)) = (a.1, b.1, c.1) {
                screen[..3].copy_from_slice(&[sa, sb, sc]);
                3
            } else {
                let polygon = clip_triangle([a.0, b.0, c.0]);
                for (s, v) in screen.iter_mut().zip(&polygon.vertices[..polygon.len]) {
                    *s = to_screen(v, view);
                }
                polygon.len
            };
            (1..n.saturating_sub(1)).map(move |k| ScreenTriangle {
                vertices: [screen[0], screen[k], screen[k + 1]],
                id: patch_id,
            })
        })
        .collect()
}

/// Most vertices a clipped triangle can have: 3, plus one per clip plane.
const MAX_POLYGON: usize = 3 + N_PLANES;

/// A convex polygon of at most [`MAX_POLYGON`] vertices, on the stack (the first `len` count).
#[derive(Clone, Copy)]
struct Polygon {
    vertices: [ClipVertex; MAX_POLYGON],
    len: usize,
}

impl Polygon {
    /// No vertices (`filler` only fills the unused slots).
    fn empty(filler: ClipVertex) -> Polygon {
        Polygon {
            vertices: [filler; MAX_POLYGON],
            len: 0,
        }
    }
    fn push(&mut self, v: ClipVertex) {
        self.vertices[self.len] = v;
        self.len += 1;
    }
}

/// The convex polygon (0 or 3..=8 vertices) of `triangle` inside all clip planes.
fn clip_triangle(triangle: [ClipVertex; 3]) -> Polygon {
    let mut polygon = Polygon::empty(triangle[0]);
    triangle.iter().for_each(|&v| polygon.push(v));
    for plane in 0..N_PLANES {
        let mut clipped = Polygon::empty(triangle[0]);
        let corners = &polygon.vertices[..polygon.len];
        for (k, &current) in corners.iter().enumerate() {
            let next = corners[(k + 1) % corners.len()];
            let d_current = plane_distance(plane, current.clip);
            let d_next = plane_distance(plane, next.clip);
            if d_current >= 0.0 {
                clipped.push(current);
            }
            if (d_current >= 0.0) != (d_next >= 0.0) {
                let (inside, d_in, outside, d_out) = if d_current >= 0.0 {
                    (current, d_current, next, d_next)
                } else {
                    (next, d_next, current, d_current)
                };
                clipped.push(inside.lerp(outside, d_in / (d_in - d_out)));
            }
        }
        polygon = clipped;
        if polygon.len == 0 {
            break;
        }
    }
    polygon
}

/// Perspective divide and viewport transform of a clipped vertex (`w ≥ z > 0`).
fn to_screen(v: &ClipVertex, view: &View) -> ScreenVertex {
    let pixel = view.pixel_from_clip(v.clip);
    ScreenVertex {
        x: pixel.x,
        y: pixel.y,
        depth: pixel.z as f32,
        inv_w: (1.0 / v.clip.w) as f32,
        attr: v.attr.to_array().map(|a| a as f32),
    }
}
