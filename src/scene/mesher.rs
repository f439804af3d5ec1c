//! Meshing the room into patches: a pure function of (room, boxes, OBJ triangles, patch size).
//!
//! Room surfaces and box faces are axis-aligned rectangles, split into a grid of quads of about
//! the patch size. The grid conforms to boxes: the edges of every box crossing or resting on a
//! rectangle's plane (on its lit side) are extra grid lines, each interval between them is split
//! uniformly (`ceil(len / size)` cells), and cells covered by a box are dropped — the floor under
//! a desk, a wall behind a cabinet, a box face against another box. Box faces lying on a room
//! surface are not surfaces at all. OBJ triangles are split by midpoint subdivision until every
//! edge is at most the patch size.
//!
//! Vertices are shared within a surface and never across surfaces. All coordinates are world
//! metres, z up; patches are counter-clockwise seen from the side their normal points to.

use glam::DVec3;
use std::collections::HashMap;

use crate::scene::model::{Aabb, Patch, PatchMesh, SurfaceKind};

/// One OBJ surface (one OBJ model) in world coordinates, ready to mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct TriangleSurface {
    /// `mesh{i}:{object name}`.
    pub name: String,
    /// Index of the `[[mesh]]` it came from.
    pub mesh_index: usize,
    /// Vertex positions (world, m).
    pub positions: Vec<DVec3>,
    /// Triangles as vertex indices, counter-clockwise seen from the outside; none degenerate.
    pub triangles: Vec<[u32; 3]>,
}

/// The geometry the mesher works on.
#[derive(Debug, Clone, Copy)]
pub struct Geometry<'a> {
    /// Room interior from the origin to this corner (m).
    pub room_size: DVec3,
    /// Boxes (world, m).
    pub boxes: &'a [Aabb],
    /// OBJ surfaces (world, m).
    pub meshes: &'a [TriangleSurface],
}

/// An axis-aligned rectangle on the plane `coordinate[axis] = offset`, facing `+axis` when
/// `facing_positive`, else `−axis`; `min`/`max` bound its two in-plane coordinates
/// `(u, v)` = the axes returned by [`AxisRect::in_plane_axes`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisRect {
    /// The normal axis: 0 = x, 1 = y, 2 = z.
    pub axis: usize,
    /// Plane position along `axis` (m).
    pub offset: f64,
    /// Whether the normal is `+axis`.
    pub facing_positive: bool,
    /// Lower `(u, v)` corner (m).
    pub min: [f64; 2],
    /// Upper `(u, v)` corner (m).
    pub max: [f64; 2],
}

impl AxisRect {
    fn new(axis: usize, offset: f64, facing_positive: bool, lo: DVec3, hi: DVec3) -> Self {
        let [u, v] = Self::in_plane_axes(axis, facing_positive);
        AxisRect {
            axis,
            offset,
            facing_positive,
            min: [lo[u], lo[v]],
            max: [hi[u], hi[v]],
        }
    }

    /// The face of the box `b` on its `far` (max) or near (min) side along `axis`, facing
    /// `+axis` when `facing_positive`.
    pub(crate) fn face_of(b: &Aabb, axis: usize, far: bool, facing_positive: bool) -> Self {
        let offset = if far { b.max[axis] } else { b.min[axis] };
        Self::new(axis, offset, facing_positive, b.min, b.max)
    }

    /// True when the world point `p` lies on the rectangle, within `tolerance` (m) of its
    /// plane and its edges.
    pub(crate) fn holds(&self, p: DVec3, tolerance: f64) -> bool {
        let [u, v] = Self::in_plane_axes(self.axis, self.facing_positive);
        (p[self.axis] - self.offset).abs() <= tolerance
            && (0..2).all(|k| {
                let c = p[[u, v][k]];
                c >= self.min[k] - tolerance && c <= self.max[k] + tolerance
            })
    }

    /// The in-plane axes `(u, v)` ordered so that `u × v` is the normal (counter-clockwise
    /// seen from the normal side).
    pub(crate) fn in_plane_axes(axis: usize, facing_positive: bool) -> [usize; 2] {
        let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
        if facing_positive { [a, b] } else { [b, a] }
    }

    /// Unit normal (world).
    pub fn normal(&self) -> DVec3 {
        let mut n = DVec3::ZERO;
        n[self.axis] = if self.facing_positive { 1.0 } else { -1.0 };
        n
    }

    /// The world point at in-plane coordinates `(u, v)`.
    pub fn point(&self, u: f64, v: f64) -> DVec3 {
        let [ua, va] = Self::in_plane_axes(self.axis, self.facing_positive);
        let mut p = DVec3::ZERO;
        p[self.axis] = self.offset;
        p[ua] = u;
        p[va] = v;
        p
    }
}

/// The shape of a surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// A room surface or box face.
    Rect(AxisRect),
    /// An OBJ surface: index into [`Geometry::meshes`].
    Triangles(usize),
}

/// A surface to mesh: its name, what it belongs to, its shape.
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceLayout {
    /// Name (see [`crate::scene::Surface::name`]).
    pub name: String,
    /// What it belongs to.
    pub kind: SurfaceKind,
    /// Its geometry.
    pub shape: Shape,
}

/// The mesh would have more vertices than allowed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TooManyVertices {
    /// At least this many vertices would be made.
    pub estimated: f64,
}

/// Every visible surface, in a fixed order: floor, ceiling, walls (x0, x1, y0, y1), then each
/// box's faces (x0, x1, y0, y1, bottom, top) and each OBJ surface. Box faces that are entirely
/// hidden (on a room surface, or covered by other boxes) are left out.
pub fn layout(geometry: &Geometry) -> Vec<SurfaceLayout> {
    let size = geometry.room_size;
    let mut surfaces = Vec::new();
    let room_faces = [
        ("floor", SurfaceKind::Floor, 2, 0.0, true),
        ("ceiling", SurfaceKind::Ceiling, 2, size.z, false),
        ("wall-x0", SurfaceKind::Wall, 0, 0.0, true),
        ("wall-x1", SurfaceKind::Wall, 0, size.x, false),
        ("wall-y0", SurfaceKind::Wall, 1, 0.0, true),
        ("wall-y1", SurfaceKind::Wall, 1, size.y, false),
    ];
    for (name, kind, axis, offset, facing_positive) in room_faces {
        let rect = AxisRect::new(axis, offset, facing_positive, DVec3::ZERO, size);
        surfaces.push(SurfaceLayout {
            name: name.to_string(),
            kind,
            shape: Shape::Rect(rect),
        });
    }
    let box_faces = [
        ("x0", 0, false),
        ("x1", 0, true),
        ("y0", 1, false),
        ("y1", 1, true),
    ];
    let box_faces = box_faces
        .into_iter()
        .chain([("bottom", 2, false), ("top", 2, true)]);
    for (box_index, b) in geometry.boxes.iter().enumerate() {
        for (suffix, axis, facing_positive) in box_faces.clone() {
            let rect = AxisRect::face_of(b, axis, facing_positive, facing_positive);
            let lines = grid_lines(geometry, &rect, f64::INFINITY);
            if kept_cells(geometry, &rect, &lines).next().is_some() {
                surfaces.push(SurfaceLayout {
                    name: format!("box{box_index}-{suffix}"),
                    kind: SurfaceKind::BoxFace { box_index },
                    shape: Shape::Rect(rect),
                });
            }
        }
    }
    for (index, mesh) in geometry.meshes.iter().enumerate() {
        surfaces.push(SurfaceLayout {
            name: mesh.name.clone(),
            kind: SurfaceKind::Mesh {
                mesh_index: mesh.mesh_index,
            },
            shape: Shape::Triangles(index),
        });
    }
    surfaces
}

/// Meshes `surfaces` (from [`layout`]) with patches of edge about `size` metres; refuses before
/// allocating when the mesh would exceed `max_vertices`.
pub fn mesh(
    geometry: &Geometry,
    surfaces: &[SurfaceLayout],
    size: f64,
    max_vertices: usize,
) -> Result<PatchMesh, TooManyVertices> {
    let estimated: f64 = surfaces
        .iter()
        .map(|s| match s.shape {
            Shape::Rect(rect) => {
                let [nu, nv] = line_counts(geometry, &rect, size);
                nu * nv
            }
            Shape::Triangles(index) => triangle_vertex_bound(&geometry.meshes[index], size),
        })
        .sum();
    if estimated > max_vertices as f64 {
        return Err(TooManyVertices { estimated });
    }
    let mut out = PatchMesh::default();
    for (surface_id, surface) in surfaces.iter().enumerate() {
        let surface_id = surface_id as u32;
        match surface.shape {
            Shape::Rect(rect) => mesh_rect(geometry, &rect, size, surface_id, &mut out),
            Shape::Triangles(index) => mesh_triangles(&geometry.meshes[index], size, surface_id, &mut out),
        }
    }
    Ok(out)
}

/// A small length (m) for "on the lit side of a plane" tests, relative to the room size.
fn epsilon(geometry: &Geometry) -> f64 {
    1e-9 * (1.0 + geometry.room_size.max_element())
}

/// The edges of the rectangle and of the boxes crossing its plane just on its lit side, along
/// u and v, sorted and without duplicates.
fn breakpoints(geometry: &Geometry, rect: &AxisRect) -> [Vec<f64>; 2] {
    let eps = epsilon(geometry);
    let lit_side = rect.offset + if rect.facing_positive { eps } else { -eps };
    let [ua, va] = AxisRect::in_plane_axes(rect.axis, rect.facing_positive);
    let near: Vec<&Aabb> = geometry
        .boxes
        .iter()
        .filter(|b| b.min[rect.axis] < lit_side && lit_side < b.max[rect.axis])
        .collect();
    [(0, ua), (1, va)].map(|(k, world_axis)| {
        let (lo, hi) = (rect.min[k], rect.max[k]);
        let mut breaks = vec![lo, hi];
        for b in &near {
            breaks.extend(
                [b.min[world_axis], b.max[world_axis]]
                    .into_iter()
                    .filter(|&x| lo < x && x < hi),
            );
        }
        breaks.sort_by(f64::total_cmp);
        breaks.dedup_by(|a, b| (*a - *b).abs() <= eps);
        breaks
    })
}

/// Cells of about `size` in `[a, b]`: `ceil(len / size)`, at least 1 (`size = ∞` gives 1). The
/// tolerance keeps 2.7 / 0.15 = 18.000000000000004 at 18 cells.
pub(crate) fn cells_between(a: f64, b: f64, size: f64) -> f64 {
    ((b - a) / size - 1e-9).ceil().max(1.0)
}

/// Number of grid lines along u and v (without building them).
fn line_counts(geometry: &Geometry, rect: &AxisRect, size: f64) -> [f64; 2] {
    breakpoints(geometry, rect).map(|breaks| {
        1.0 + breaks
            .windows(2)
            .map(|w| cells_between(w[0], w[1], size))
            .sum::<f64>()
    })
}

/// Grid lines along u and v: the [`breakpoints`], each interval between them split uniformly
/// into [`cells_between`] cells.
fn grid_lines(geometry: &Geometry, rect: &AxisRect, size: f64) -> [Vec<f64>; 2] {
    breakpoints(geometry, rect).map(|breaks| {
        let mut lines = vec![breaks[0]];
        for pair in breaks.windows(2) {
            let (a, b) = (pair[0], pair[1]);
            let cells = cells_between(a, b, size) as usize;
            lines.extend((1..cells).map(|i| a + (b - a) * i as f64 / cells as f64));
            lines.push(b);
        }
        lines
    })
}

/// Cells `(i, j)` of the grid whose lit side is inside the room and in no box.
fn kept_cells<'a>(
    geometry: &'a Geometry,
    rect: &'a AxisRect,
    lines: &'a [Vec<f64>; 2],
) -> impl Iterator<Item = (usize, usize)> + 'a {
    let eps = epsilon(geometry);
    let offset = rect.normal() * eps;
    let (nu, nv) = (lines[0].len() - 1, lines[1].len() - 1);
    (0..nv)
        .flat_map(move |j| (0..nu).map(move |i| (i, j)))
        .filter(move |&(i, j)| {
            let u = 0.5 * (lines[0][i] + lines[0][i + 1]);
            let v = 0.5 * (lines[1][j] + lines[1][j + 1]);
            let p = rect.point(u, v) + offset;
            let in_room = p.cmpgt(DVec3::ZERO).all() && p.cmplt(geometry.room_size).all();
            in_room && !geometry.boxes.iter().any(|b| b.contains_strictly(p))
        })
}

fn mesh_rect(geometry: &Geometry, rect: &AxisRect, size: f64, surface: u32, out: &mut PatchMesh) {
    let lines = grid_lines(geometry, rect, size);
    let stride = lines[0].len();
    let normal = rect.normal();
    let mut ids = vec![u32::MAX; stride * lines[1].len()];
    let mut vertex = |i: usize, j: usize, out: &mut PatchMesh| {
        let slot = &mut ids[j * stride + i];
        if *slot == u32::MAX {
            *slot = out.positions.len() as u32;
            out.positions.push(rect.point(lines[0][i], lines[1][j]));
            out.normals.push(normal);
            out.vertex_surface.push(surface);
        }
        *slot
    };
    let cells: Vec<(usize, usize)> = kept_cells(geometry, rect, &lines).collect();
    for (i, j) in cells {
        let corners = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)];
        let vertices = corners.map(|(a, b)| vertex(a, b, out));
        let (du, dv) = (lines[0][i + 1] - lines[0][i], lines[1][j + 1] - lines[1][j]);
        let centroid = rect.point(lines[0][i] + 0.5 * du, lines[1][j] + 0.5 * dv);
        out.patches.push(Patch {
            vertices,
            n_vertices: 4,
            surface,
            normal,
            area: du * dv,
            centroid,
        });
    }
}

/// Midpoint-subdivision level: the number of segments per edge, `2^k`, with the longest edge
/// split into pieces of at most `size`.
fn subdivisions(corners: [DVec3; 3], size: f64) -> u64 {
    let longest = (0..3)
        .map(|e| corners[e].distance(corners[(e + 1) % 3]))
        .fold(0.0, f64::max);
    let mut n = 1u64;
    while longest / n as f64 > size * (1.0 + 1e-12) && n < 1 << 40 {
        n *= 2;
    }
    n
}

fn triangle_vertex_bound(surface: &TriangleSurface, size: f64) -> f64 {
    surface
        .triangles
        .iter()
        .map(|t| {
            let n = subdivisions(t.map(|i| surface.positions[i as usize]), size) as f64;
            (n + 1.0) * (n + 2.0) / 2.0
        })
        .sum()
}

/// Identity of a vertex within one surface: an OBJ corner in one plane orientation, a point at
/// the reduced fraction `num / den` along the edge between two such corners (lower id first), or
/// a point inside one OBJ triangle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum VertexKey {
    Corner { normal: [i64; 3], position: [u64; 3] },
    Edge { from: u32, to: u32, num: u64, den: u64 },
    Interior { triangle: usize, i: u64, j: u64 },
}

/// Adds a subdivided OBJ surface. Vertices are shared between triangles of the same plane
/// orientation (normals equal to 1e-6); a crease splits them, as a floor/wall edge does, so each
/// vertex normal is exactly the normal of the faces using it. Neighbouring triangles split to
/// different levels share the coarser one's edge vertices (a T-junction, no gap).
fn mesh_triangles(surface: &TriangleSurface, size: f64, surface_id: u32, out: &mut PatchMesh) {
    let mut ids: HashMap<VertexKey, u32> = HashMap::new();
    let mut vertex = |key: VertexKey, position: DVec3, normal: DVec3, out: &mut PatchMesh| {
        *ids.entry(key).or_insert_with(|| {
            out.positions.push(position);
            out.normals.push(normal);
            out.vertex_surface.push(surface_id);
            out.positions.len() as u32 - 1
        })
    };
    for (triangle, tri) in surface.triangles.iter().enumerate() {
        let p = tri.map(|i| surface.positions[i as usize]);
        let cross = (p[1] - p[0]).cross(p[2] - p[0]);
        let normal = cross.normalize();
        let normal_key = (normal * 1e6).round().as_i64vec3().to_array();
        let corner = p.map(|q| {
            let position = q.to_array().map(f64::to_bits);
            vertex(
                VertexKey::Corner {
                    normal: normal_key,
                    position,
                },
                q,
                normal,
                out,
            )
        });
        let n = subdivisions(p, size);
        // Grid point (i, j) is p0 + (i/n)(p1 − p0) + (j/n)(p2 − p0).
        let mut grid = |i: u64, j: u64, out: &mut PatchMesh| -> u32 {
            let (a, b, steps) = match (i, j) {
                (0, 0) => return corner[0],
                (_, 0) if i == n => return corner[1],
                (0, _) if j == n => return corner[2],
                (_, 0) => (0, 1, i),
                (0, _) => (0, 2, j),
                _ if i + j == n => (1, 2, j),
                _ => {
                    let (s, t) = (i as f64 / n as f64, j as f64 / n as f64);
                    let q = p[0] + s * (p[1] - p[0]) + t * (p[2] - p[0]);
                    return vertex(VertexKey::Interior { triangle, i, j }, q, normal, out);
                }
            };
            // On an edge: computed from its lower-id end so both triangles get the same point.
            let (from, to, steps) = if corner[a] < corner[b] {
                (a, b, steps)
            } else {
                (b, a, n - steps)
            };
            let shift = steps.trailing_zeros().min(n.trailing_zeros());
            let (num, den) = (steps >> shift, n >> shift);
            let q = p[from] + (num as f64 / den as f64) * (p[to] - p[from]);
            let key = VertexKey::Edge {
                from: corner[from],
                to: corner[to],
                num,
                den,
            };
            vertex(key, q, normal, out)
        };
        let area = 0.5 * cross.length() / (n * n) as f64;
        for i in 0..n {
            for j in 0..n - i {
                let up = [(i, j), (i + 1, j), (i, j + 1)];
                let down = [(i + 1, j), (i + 1, j + 1), (i, j + 1)];
                let has_down = i + j + 1 < n;
                for small in std::iter::once(up).chain(has_down.then_some(down)) {
                    let v = small.map(|(a, b)| grid(a, b, out));
                    let centroid = v.iter().map(|&k| out.positions[k as usize]).sum::<DVec3>() / 3.0;
                    out.patches.push(Patch {
                        vertices: [v[0], v[1], v[2], v[2]],
                        n_vertices: 3,
                        surface: surface_id,
                        normal,
                        area,
                        centroid,
                    });
                }
            }
        }
    }
}
