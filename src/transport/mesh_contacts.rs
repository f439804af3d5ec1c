//! Where OBJ meshes stand on the room's surfaces, on boxes and on each other (docs/DECISIONS.md
//! "Interreflection", "OBJ furniture on its support", "OBJ things on a box", "OBJ things on OBJ
//! furniture"): the edges of OBJ triangles that lie on a room surface, a box face or another
//! OBJ triangle (a plinth's footprint on the floor, a cabinet's back against a wall, a vase's
//! base on a sideboard, [`edges_on_meshes`]), which the refinement grades towards like a box's
//! contact edges; the test for a point covered by a mesh (the floor under
//! a plinth), whose leaves are left out of the solve; and the OBJ faces lying on such a surface
//! facing into it. Boxes need none of this: the mesher conforms the room's cells to their edges
//! and drops the cells they cover. World frame, metres.

use glam::DVec3;

use crate::scene::mesher::AxisRect;
use crate::scene::{Aabb, Patch, Scene, SurfaceKind};
use crate::transport::mesh_on_mesh::edges_on_meshes;

/// How close (m) to a support's plane an OBJ vertex counts as lying on it.
const ON_PLANE_M: f64 = 1e-3;

/// An OBJ triangle edge lying on a support (a room surface, a box face or another OBJ
/// triangle).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Edge {
    a: DVec3,
    b: DVec3,
    /// The support's plane, `coordinate[axis] = offset`, when it is a room surface or a box
    /// face (whose cells the mesher makes); `None` on an OBJ triangle.
    plane: Option<(usize, f64)>,
}

/// The contact edge nearest something, as the refinement grades towards it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct NearestEdge {
    /// Distance (m) to the edge.
    pub distance: f64,
    /// Unit direction of the edge (world frame; either way along it).
    pub direction: DVec3,
}

impl NearestEdge {
    fn of(edge: &Edge, distance: f64) -> Self {
        NearestEdge {
            distance,
            direction: (edge.b - edge.a).normalize_or_zero(),
        }
    }
}

/// The flat surfaces OBJ furniture can stand on, each facing its free side: the room's six
/// surfaces (facing into the room) and every face of every box (facing out of it).
fn supports(scene: &Scene) -> Vec<AxisRect> {
    let room = Aabb {
        min: DVec3::ZERO,
        max: scene.room_size,
    };
    let mut out = Vec::new();
    for axis in 0..3 {
        out.push(AxisRect::face_of(&room, axis, false, true));
        out.push(AxisRect::face_of(&room, axis, true, false));
        for b in &scene.boxes {
            out.push(AxisRect::face_of(b, axis, true, true));
            out.push(AxisRect::face_of(b, axis, false, false));
        }
    }
    out
}

/// The triangles of the OBJ meshes of `scene`'s coarse mesh: their corners (world, m) and the
/// patch each belongs to.
pub(crate) fn obj_triangles(scene: &Scene) -> impl Iterator<Item = ([DVec3; 3], &Patch)> {
    scene.coarse.triangles().filter_map(|(corners, pid)| {
        let patch = &scene.coarse.patches[pid as usize];
        matches!(
            scene.surfaces[patch.surface as usize].kind,
            SurfaceKind::Mesh { .. }
        )
        .then(|| (corners.map(|i| scene.coarse.positions[i as usize]), patch))
    })
}

/// The contact edges and triangles of a scene's OBJ meshes, and the supports they stand on.
#[derive(Debug, Clone)]
pub(crate) struct MeshContacts {
    edges: Vec<Edge>,
    /// Every OBJ triangle (world, m) with its unit normal (the lit side), for [`Self::covered`].
    triangles: Vec<([DVec3; 3], DVec3)>,
    /// The room's surfaces and the boxes' faces ([`supports`]).
    supports: Vec<AxisRect>,
    /// The meshes' bounds.
    bounds: Vec<Aabb>,
}

impl MeshContacts {
    /// The OBJ meshes of `scene` whose triangles have an edge on a support (a room surface, a
    /// box face, or another OBJ triangle whose lit side it rises into; the triangle itself off
    /// it); `None` when there are none.
    pub(crate) fn of_scene(scene: &Scene) -> Option<Self> {
        let supports = supports(scene);
        let mut triangles = Vec::new();
        let mut edges = Vec::new();
        for (t, patch) in obj_triangles(scene) {
            triangles.push((t, patch.normal));
            for support in &supports {
                let on = t.map(|p| support.holds(p, ON_PLANE_M));
                if on.iter().all(|&o| o) {
                    continue;
                }
                for e in 0..3 {
                    if on[e] && on[(e + 1) % 3] {
                        edges.push(Edge {
                            a: t[e],
                            b: t[(e + 1) % 3],
                            plane: Some((support.axis, support.offset)),
                        });
                    }
                }
            }
        }
        edges.extend(
            edges_on_meshes(&triangles, ON_PLANE_M)
                .into_iter()
                .map(|[a, b]| Edge { a, b, plane: None }),
        );
        (!edges.is_empty()).then(|| MeshContacts {
            edges,
            triangles,
            supports,
            bounds: scene.mesh_bounds.clone(),
        })
    }

    /// True when an OBJ triangle (world corners, its unit `normal` the side it lights) lies on
    /// a support facing into it, as a sofa's underside on the floor, its back against a wall or
    /// a vase's base on a sideboard does: it receives no light and sends none, so the solve
    /// leaves it out (docs/DECISIONS.md "OBJ faces against the room or inside another block").
    pub(crate) fn against_support(&self, corners: &[DVec3; 3], normal: DVec3) -> bool {
        self.supports
            .iter()
            .any(|s| corners.iter().all(|&p| s.holds(p, ON_PLANE_M)) && normal.dot(s.normal()) < 0.0)
    }

    /// Number of contact edges.
    pub(crate) fn len(&self) -> usize {
        self.edges.len()
    }

    /// The nearest contact edge to the flat box `cell` of a room surface in the plane
    /// `coordinate[axis] = offset`; `None` when no edge lies in it.
    pub(crate) fn nearest_to_cell(&self, axis: usize, offset: f64, cell: &Aabb) -> Option<NearestEdge> {
        self.edges
            .iter()
            .filter(|e| {
                e.plane
                    .is_some_and(|(a, o)| a == axis && (o - offset).abs() <= ON_PLANE_M)
            })
            .map(|e| NearestEdge::of(e, segment_box_distance(e.a, e.b, cell)))
            .min_by(|x, y| x.distance.total_cmp(&y.distance))
    }

    /// An OBJ contact edge running along a world axis through the interior of the flat box
    /// `cell` of a room surface in the plane `coordinate[axis] = offset` (more than 1 mm inside
    /// it, and overlapping it along its length): the world axis across the edge and the edge's
    /// coordinate on it. Cut there, the cells on the two sides of a block's footprint or of the
    /// top of an OBJ sideboard against a wall lie wholly outside or wholly under it.
    pub(crate) fn line_through(&self, axis: usize, offset: f64, cell: &Aabb) -> Option<(usize, f64)> {
        const MARGIN_M: f64 = 1e-3;
        self.edges.iter().find_map(|e| {
            let (plane_axis, o) = e.plane?;
            if plane_axis != axis || (o - offset).abs() > ON_PLANE_M {
                return None;
            }
            (0..3).filter(|&w| w != axis).find_map(|along| {
                let across = 3 - axis - along;
                let c = e.a[across];
                let overlap = e.a[along].min(e.b[along]).max(cell.min[along])
                    < e.a[along].max(e.b[along]).min(cell.max[along]) - 1e-9;
                ((e.b[across] - c).abs() < 1e-9
                    && overlap
                    && c > cell.min[across] + MARGIN_M
                    && c < cell.max[across] - MARGIN_M)
                    .then_some((across, c))
            })
        })
    }

    /// The nearest contact edge to the nearest of `points`.
    pub(crate) fn nearest_to_points(&self, points: &[DVec3]) -> Option<NearestEdge> {
        self.edges
            .iter()
            .flat_map(|e| {
                points
                    .iter()
                    .map(move |&p| NearestEdge::of(e, point_segment_distance(p, e.a, e.b)))
            })
            .min_by(|x, y| x.distance.total_cmp(&y.distance))
    }

    /// True when the point `p` of a surface facing the unit `normal` is covered by an OBJ mesh:
    /// the nearest OBJ triangle along the normal is seen from behind (the point is inside the
    /// mesh, as the floor under a plinth is).
    pub(crate) fn covered(&self, p: DVec3, normal: DVec3) -> bool {
        let inside_bounds = self
            .bounds
            .iter()
            .any(|b| p.cmpge(b.min - ON_PLANE_M).all() && p.cmple(b.max + ON_PLANE_M).all());
        if !inside_bounds {
            return false;
        }
        let origin = p + normal * 1e-6;
        self.triangles
            .iter()
            .filter_map(|(t, n)| ray_triangle(origin, normal, t).map(|d| (d, n)))
            .min_by(|x, y| x.0.total_cmp(&y.0))
            .is_some_and(|(_, n)| n.dot(normal) > 0.0)
    }
}

/// Distance from `p` to the segment `a b`.
fn point_segment_distance(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let t = ((p - a).dot(ab) / ab.length_squared().max(f64::MIN_POSITIVE)).clamp(0.0, 1.0);
    p.distance(a + ab * t)
}

/// Distance between the segment `a b` and a (possibly flat) axis-aligned box: 0 when the segment
/// meets it, else the least of its end points' distances to the box and the box corners'
/// distances to the segment (exact for a segment and a rectangle in one plane, where two disjoint
/// convex shapes are closest at a vertex of one of them).
fn segment_box_distance(a: DVec3, b: DVec3, cell: &Aabb) -> f64 {
    let d = b - a;
    let (mut enter, mut exit) = (0.0f64, 1.0f64);
    for k in 0..3 {
        if d[k].abs() < 1e-15 {
            if a[k] < cell.min[k] - 1e-12 || a[k] > cell.max[k] + 1e-12 {
                exit = -1.0;
            }
            continue;
        }
        let (t0, t1) = ((cell.min[k] - a[k]) / d[k], (cell.max[k] - a[k]) / d[k]);
        enter = enter.max(t0.min(t1));
        exit = exit.min(t0.max(t1));
    }
    if enter <= exit {
        return 0.0;
    }
    let to_box = |p: DVec3| p.distance(p.clamp(cell.min, cell.max));
    let corners = (0..8).map(|i| {
        DVec3::new(
            if i & 1 == 0 { cell.min.x } else { cell.max.x },
            if i & 2 == 0 { cell.min.y } else { cell.max.y },
            if i & 4 == 0 { cell.min.z } else { cell.max.z },
        )
    });
    corners
        .map(|c| point_segment_distance(c, a, b))
        .chain([to_box(a), to_box(b)])
        .fold(f64::INFINITY, f64::min)
}

/// The distance along the unit ray `o + t d` (t > 0) to the triangle `t`, either side.
fn ray_triangle(o: DVec3, d: DVec3, [a, b, c]: &[DVec3; 3]) -> Option<f64> {
    let (e1, e2) = (*b - *a, *c - *a);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-18 {
        return None;
    }
    let s = o - *a;
    let u = s.dot(p) / det;
    let q = s.cross(e1);
    let v = d.dot(q) / det;
    let t = e2.dot(q) / det;
    ((0.0..=1.0).contains(&u) && v >= 0.0 && u + v <= 1.0 && t > 0.0).then_some(t)
}

/// A 4 × 3 × 2.5 m room with an OBJ plinth (0.6 × 0.6 × 1 m, closed) turned 30° standing on
/// the floor.
#[cfg(test)]
pub(crate) fn plinth_room() -> Scene {
    let (c, h, turn) = (DVec3::new(2.0, 1.5, 0.0), 0.3, 30f64.to_radians());
    let corner = |sx: f64, sy: f64| {
        let (x, y) = (sx * h, sy * h);
        c + DVec3::new(
            x * turn.cos() - y * turn.sin(),
            x * turn.sin() + y * turn.cos(),
            0.0,
        )
    };
    let base = [
        corner(-1.0, -1.0),
        corner(1.0, -1.0),
        corner(1.0, 1.0),
        corner(-1.0, 1.0),
    ];
    let mut obj = String::new();
    for z in [0.0, 1.0] {
        for p in base {
            obj.push_str(&format!("v {} {} {z}\n", p.x, p.y));
        }
    }
    // Four sides, the top, and the underside on the floor (facing down, out of the room).
    obj.push_str("f 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\nf 5 6 7 8\nf 4 3 2 1\n");
    obj_room(&obj, "")
}

/// A 4 × 3 × 2.5 m room (floor 0.3, walls 0.5, ceiling 0.7) with the OBJ `obj` (z up, metres),
/// one light at (1, 1, 2), and `more` (room-file tables, such as boxes) after them.
#[cfg(test)]
pub(crate) fn obj_room(obj: &str, more: &str) -> Scene {
    let dir = tempfile::tempdir().expect("a temporary directory");
    std::fs::write(dir.path().join("plinth.obj"), obj).expect("writes");
    crate::scene::load::load_text(
        &dir.path().join("room.toml"),
        (r#"version = 1
[room]
size = [4.0, 3.0, 2.5]
[room.reflectance]
floor = 0.3
walls = 0.5
ceiling = 0.7
[[mesh]]
file = "plinth.obj"
up = "z"
[[light]]
name = "l"
position = [1.0, 1.0, 2.0]
lid = [[0, 500], [180, 500]]
"#
        .to_string()
            + more)
            .as_str(),
    )
    .expect("the test room is valid")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_plinth_on_the_floor_has_its_footprint_as_contact_edges_and_covers_the_floor_inside_it() {
        let scene = plinth_room();
        let contacts = MeshContacts::of_scene(&scene).expect("the plinth stands on the floor");
        // The four sides' bottom edges (in as many pieces as the coarse mesh cut them into),
        // nothing on the walls or ceiling.
        let length: f64 = contacts.edges.iter().map(|e| e.a.distance(e.b)).sum();
        assert!((length - 4.0 * 0.6).abs() < 1e-9, "{length} m of edges");
        assert!(contacts.edges.iter().all(|e| e.plane == Some((2, 0.0))));
        let centre = DVec3::new(2.0, 1.5, 0.0);
        assert!(contacts.covered(centre, DVec3::Z));
        assert!(contacts.covered(centre + DVec3::new(0.25, 0.0, 0.0), DVec3::Z));
        // Past a corner of the turned square but inside its bounds: not covered.
        assert!(!contacts.covered(centre + DVec3::new(0.3, 0.3, 0.0), DVec3::Z));
        assert!(!contacts.covered(DVec3::new(3.5, 2.5, 0.0), DVec3::Z));
        // The ceiling above it faces down, away from the plinth's top: not covered.
        assert!(!contacts.covered(centre + DVec3::Z * 2.5, DVec3::NEG_Z));
        // A floor cell around the centre meets the footprint's edges only if it reaches them:
        // the face midpoints are 0.3 m from the centre.
        let cell = |half: f64| Aabb {
            min: centre - DVec3::new(half, half, 0.0),
            max: centre + DVec3::new(half, half, 0.0),
        };
        let near = contacts
            .nearest_to_cell(2, 0.0, &cell(0.1))
            .expect("in the floor plane")
            .distance;
        // The corner (0.1, 0.1) from the centre, to the side facing 30°: 0.3 − 0.1 (cos 30° + sin 30°).
        let (cos, sin) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
        assert!((near - (0.3 - 0.1 * (cos + sin))).abs() < 1e-9, "{near}");
        assert_eq!(
            contacts.nearest_to_cell(2, 0.0, &cell(0.35)).map(|e| e.distance),
            Some(0.0)
        );
        assert_eq!(contacts.nearest_to_cell(2, 2.5, &cell(0.35)), None);
        let d = contacts
            .nearest_to_points(&[centre + DVec3::new(0.0, 0.0, 0.4)])
            .expect("edges")
            .distance;
        assert!((d - (0.3f64.hypot(0.4))).abs() < 1e-9, "{d}");
    }

    /// Triangles lying on a support face into it when their normal points through it: a
    /// plinth's underside on the floor, a cabinet's back on a wall, a vase's base on a box; one
    /// facing away (a rug drawn on the floor), off the plane, or on the box's plane but past
    /// its face is kept.
    #[test]
    fn only_triangles_on_a_support_facing_into_it_are_against_it() {
        let mut scene = plinth_room();
        scene.boxes.push(Aabb {
            min: DVec3::new(3.0, 0.0, 0.0),
            max: DVec3::new(4.0, 1.0, 0.8),
        });
        let contacts = MeshContacts::of_scene(&scene).expect("the plinth stands on the floor");
        let floor = [
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(2.0, 1.0, 0.0),
            DVec3::new(1.0, 2.0, 0.0),
        ];
        assert!(contacts.against_support(&floor, DVec3::NEG_Z));
        assert!(!contacts.against_support(&floor, DVec3::Z));
        let wall = floor.map(|p| DVec3::new(p.x, 3.0, p.y));
        assert!(contacts.against_support(&wall, DVec3::Y));
        assert!(!contacts.against_support(&wall, DVec3::NEG_Y));
        let lifted = floor.map(|p| p + DVec3::Z * 0.01);
        assert!(!contacts.against_support(&lifted, DVec3::NEG_Z));
        let on_box = [
            DVec3::new(3.2, 0.2, 0.8),
            DVec3::new(3.5, 0.2, 0.8),
            DVec3::new(3.2, 0.5, 0.8),
        ];
        assert!(contacts.against_support(&on_box, DVec3::NEG_Z));
        let past_box = on_box.map(|p| p - DVec3::X * 1.0);
        assert!(!contacts.against_support(&past_box, DVec3::NEG_Z));
    }

    #[test]
    fn segment_box_distance_is_exact_in_the_plane() {
        let cell = Aabb {
            min: DVec3::new(0.0, 0.0, 0.0),
            max: DVec3::new(1.0, 1.0, 0.0),
        };
        // Crossing, beside, beyond a corner, diagonal past a corner.
        assert_eq!(
            segment_box_distance(DVec3::new(-1.0, 0.5, 0.0), DVec3::new(2.0, 0.5, 0.0), &cell),
            0.0
        );
        assert!(
            (segment_box_distance(DVec3::new(1.5, -1.0, 0.0), DVec3::new(1.5, 2.0, 0.0), &cell) - 0.5).abs()
                < 1e-12
        );
        assert!(
            (segment_box_distance(DVec3::new(2.0, 2.0, 0.0), DVec3::new(3.0, 3.0, 0.0), &cell) - 2f64.sqrt())
                .abs()
                < 1e-12
        );
        let d = segment_box_distance(DVec3::new(2.0, 0.0, 0.0), DVec3::new(0.0, 2.0, 0.0), &cell);
        assert!(
            (d - 0.0).abs() < 1e-12,
            "the diagonal x + y = 2 touches the corner (1, 1): {d}"
        );
        let d = segment_box_distance(DVec3::new(2.5, 0.0, 0.0), DVec3::new(0.0, 2.5, 0.0), &cell);
        assert!((d - 0.5 / 2f64.sqrt()).abs() < 1e-12, "{d}");
    }
}
