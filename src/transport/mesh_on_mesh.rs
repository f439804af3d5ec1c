//! Where OBJ triangles stand on other OBJ triangles (docs/DECISIONS.md "OBJ things on OBJ
//! furniture"): the parts of triangle edges lying on another triangle whose lit side the first
//! triangle rises into — a vase's foot on an OBJ sideboard's top, a back-rest's foot on a
//! seat, the inner crease of an L-shaped mesh. A convex crease (a block's own outer edge) is
//! not one: there the first triangle falls away behind the second. World frame, metres.

use std::collections::HashMap;

use glam::DVec3;

/// A uniform grid over triangles' bounds, for the triangles near a box; each cell's list in
/// the order of the triangles' planes ([`plane_groups`]).
struct TriangleGrid {
    /// Side (m) of a cell.
    cell: f64,
    cells: HashMap<[i64; 3], Vec<u32>>,
}

/// Per triangle, a group of triangles lying in one plane to well within `tolerance` (m): the
/// same unit normal and offset, each rounded so that a corner of one lies within `tolerance /
/// 2` of another's plane (normal steps of `tolerance / (4√3 (1 + the largest coordinate))`,
/// offset steps of `tolerance / 4`). Two triangles of a group can make no contact (one would
/// have to rise more than `tolerance` from the other's plane). A fan of one large convex face
/// is one group: its thousands of slivers all meet at its first corner, so every cell there
/// lists all of them.
fn plane_groups(triangles: &[([DVec3; 3], DVec3)], tolerance: f64) -> Vec<u32> {
    let largest = triangles
        .iter()
        .flat_map(|(t, _)| t.iter().map(|p| p.abs().max_element()))
        .fold(0.0, f64::max);
    let normal_step = tolerance / (4.0 * 3f64.sqrt() * (1.0 + largest));
    let offset_step = tolerance / 4.0;
    let mut ids: HashMap<[i64; 4], u32> = HashMap::new();
    triangles
        .iter()
        .map(|(t, normal)| {
            let n = (*normal / normal_step).round().as_i64vec3();
            let key = [n.x, n.y, n.z, (normal.dot(t[0]) / offset_step).round() as i64];
            let next = ids.len() as u32;
            *ids.entry(key).or_insert(next)
        })
        .collect()
}

/// Most cells a grid of triangles may have per axis across the meshes' bounds: bounds a huge
/// triangle's count of cells in a mesh of tiny ones.
const GRID_CELLS_PER_AXIS: f64 = 512.0;

impl TriangleGrid {
    /// The grid over `triangles`' bounds grown by `margin` (m), its cells as large as nine in
    /// ten triangles' largest extent, each cell's list ordered by `groups` (then index).
    fn new(triangles: &[([DVec3; 3], DVec3)], margin: f64, groups: &[u32]) -> Self {
        let bounds: Vec<(DVec3, DVec3)> = triangles
            .iter()
            .map(|(t, _)| {
                (
                    t[0].min(t[1]).min(t[2]) - margin,
                    t[0].max(t[1]).max(t[2]) + margin,
                )
            })
            .collect();
        let mut extents: Vec<f64> = bounds.iter().map(|(lo, hi)| (*hi - *lo).max_element()).collect();
        extents.sort_by(f64::total_cmp);
        let typical = extents.get(extents.len() * 9 / 10).copied().unwrap_or(1.0);
        let (lo, hi) = bounds
            .iter()
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), (a, b)| {
                (lo.min(*a), hi.max(*b))
            });
        let span = (hi - lo).max_element().max(0.0);
        let cell = typical.max(span / GRID_CELLS_PER_AXIS).max(1e-6);
        let mut grid = TriangleGrid {
            cell,
            cells: HashMap::new(),
        };
        for (i, (lo, hi)) in bounds.iter().enumerate() {
            grid.for_each_cell(*lo, *hi, |grid, key| {
                grid.cells.entry(key).or_default().push(i as u32);
            });
        }
        for list in grid.cells.values_mut() {
            list.sort_unstable_by_key(|&i| (groups[i as usize], i));
        }
        grid
    }

    fn key(&self, p: DVec3) -> [i64; 3] {
        (p / self.cell).floor().as_i64vec3().to_array()
    }

    fn for_each_cell(&mut self, lo: DVec3, hi: DVec3, mut f: impl FnMut(&mut Self, [i64; 3])) {
        let (a, b) = (self.key(lo), self.key(hi));
        for x in a[0]..=b[0] {
            for y in a[1]..=b[1] {
                for z in a[2]..=b[2] {
                    f(self, [x, y, z]);
                }
            }
        }
    }

    /// [`Self::near`] without the triangles of plane group `group` (`groups` as the grid was
    /// made with), skipped a cell's run at a time; the rest of a cell in the triangles' order,
    /// as [`Self::near`] gives them (the order the contact edges are found in counts: the
    /// grading takes the first that applies).
    fn near_off_plane(&self, lo: DVec3, hi: DVec3, groups: &[u32], group: u32, mut f: impl FnMut(usize)) {
        let (a, b) = (self.key(lo), self.key(hi));
        let mut rest: Vec<u32> = Vec::new();
        for x in a[0]..=b[0] {
            for y in a[1]..=b[1] {
                for z in a[2]..=b[2] {
                    let Some(list) = self.cells.get(&[x, y, z]) else {
                        continue;
                    };
                    let start = list.partition_point(|&i| groups[i as usize] < group);
                    let end = start + list[start..].partition_point(|&i| groups[i as usize] == group);
                    rest.clear();
                    rest.extend(list[..start].iter().chain(&list[end..]));
                    rest.sort_unstable();
                    for &i in &rest {
                        f(i as usize);
                    }
                }
            }
        }
    }

    /// Calls `f` with every triangle whose grown bounds share a cell with the box `lo`–`hi`
    /// (a triangle may come more than once).
    fn near(&self, lo: DVec3, hi: DVec3, mut f: impl FnMut(usize)) {
        let (a, b) = (self.key(lo), self.key(hi));
        for x in a[0]..=b[0] {
            for y in a[1]..=b[1] {
                for z in a[2]..=b[2] {
                    for &i in self.cells.get(&[x, y, z]).into_iter().flatten() {
                        f(i as usize);
                    }
                }
            }
        }
    }
}

/// Two OBJ triangles meet in a crease (a contact edge) only when their normals are more than
/// about 45° apart (cosine below this): the folds between the facets of a curved model are
/// gentler (docs/DECISIONS.md "Slots under OBJ objects").
const CREASE_COS: f64 = 0.7;

/// The segments of OBJ triangle edges that lie within `tolerance` (m) of another OBJ triangle
/// (each with its unit normal, the lit side) and rise from it into its lit side: for every
/// triangle `u` with two corners within `tolerance` of the plane of a triangle `t` and its
/// third corner more than `tolerance` in front of it, the part of that edge inside `t` (grown
/// by `tolerance`), when longer than `tolerance`, when their normals are more than a crease
/// apart ([`CREASE_COS`]) and when `t` is seen in front of `u` there ([`seen_in_front`]).
pub(crate) fn edges_on_meshes(triangles: &[([DVec3; 3], DVec3)], tolerance: f64) -> Vec<[DVec3; 2]> {
    let groups = plane_groups(triangles, tolerance);
    let grid = TriangleGrid::new(triangles, tolerance, &groups);
    let mut seen = vec![usize::MAX; triangles.len()];
    let mut out = Vec::new();
    for (ti, (t, normal)) in triangles.iter().enumerate() {
        let (lo, hi) = (
            t[0].min(t[1]).min(t[2]) - tolerance,
            t[0].max(t[1]).max(t[2]) + tolerance,
        );
        grid.near_off_plane(lo, hi, &groups, groups[ti], |ui| {
            if ui == ti || seen[ui] == ti {
                return;
            }
            seen[ui] = ti;
            let (u, u_normal) = &triangles[ui];
            if u_normal.dot(*normal) > CREASE_COS {
                // A gentle fold of a curved surface, not a corner anything stands in.
                return;
            }
            let height = u.map(|p| normal.dot(p - t[0]));
            for e in 0..3 {
                let (i, j, k) = (e, (e + 1) % 3, (e + 2) % 3);
                let on = |h: f64| h.abs() <= tolerance;
                if on(height[i]) && on(height[j]) && height[k] > tolerance {
                    let piece = clip_to_triangle(u[i], u[j], t, *normal, tolerance);
                    if let Some(piece) =
                        piece.filter(|p| seen_in_front(triangles, &grid, ti, *u_normal, p, tolerance))
                    {
                        out.push(piece);
                    }
                }
            }
        });
    }
    out
}

/// True when the triangle `triangles[ti]` is seen just in front of the triangle of unit normal
/// `u_normal` rising from it along `piece`: the point of `t` `2 × tolerance` from the piece's
/// middle, on `u`'s lit side, lies inside `t` and in no triangle lying back to back with `t`
/// there. Two blocks set side by side make a seam whose faces are edges of each other's
/// hidden faces; neither is a crease anyone sees.
fn seen_in_front(
    triangles: &[([DVec3; 3], DVec3)],
    grid: &TriangleGrid,
    ti: usize,
    u_normal: DVec3,
    piece: &[DVec3; 2],
    tolerance: f64,
) -> bool {
    let (t, normal) = &triangles[ti];
    let across = (u_normal - *normal * u_normal.dot(*normal)).normalize_or_zero();
    let mut q = (piece[0] + piece[1]) * 0.5 + across * 2.0 * tolerance;
    q -= *normal * normal.dot(q - t[0]);
    if !inside(t, *normal, q) {
        return false;
    }
    let mut hidden = false;
    grid.near(q, q, |wi| {
        let (w, w_normal) = &triangles[wi];
        hidden |= wi != ti
            && w_normal.dot(*normal) < 0.0
            && w.iter().all(|p| normal.dot(*p - t[0]).abs() <= tolerance)
            && inside(w, *w_normal, q);
    });
    !hidden
}

/// Per side of the triangle `t` (unit `normal`), a corner of the side and its in-plane unit
/// normal pointing into `t`.
fn inward_sides(t: &[DVec3; 3], normal: DVec3) -> [(DVec3, DVec3); 3] {
    [0, 1, 2].map(|k| {
        let (p, q, r) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
        let inward = normal.cross(q - p).normalize_or_zero();
        (p, if inward.dot(r - p) < 0.0 { -inward } else { inward })
    })
}

/// True when `q` (in the plane of the triangle `t` of unit `normal`) lies inside `t` or on its
/// sides.
fn inside(t: &[DVec3; 3], normal: DVec3, q: DVec3) -> bool {
    inward_sides(t, normal)
        .iter()
        .all(|(p, inward)| inward.dot(q - *p) >= 0.0)
}

/// The part of the segment `a b` (lying in the plane of the triangle `t` of unit `normal`) inside
/// `t` grown by `tolerance` (m) on every side, when longer than `tolerance`.
fn clip_to_triangle(a: DVec3, b: DVec3, t: &[DVec3; 3], normal: DVec3, tolerance: f64) -> Option<[DVec3; 2]> {
    let d = b - a;
    let (mut enter, mut exit) = (0.0f64, 1.0f64);
    for (p, inward) in inward_sides(t, normal) {
        // inward · (a + s d − p) ≥ −tolerance for s in [enter, exit].
        let (start, rate) = (inward.dot(a - p) + tolerance, inward.dot(d));
        if rate.abs() < 1e-15 {
            if start < 0.0 {
                return None;
            }
        } else if rate > 0.0 {
            enter = enter.max(-start / rate);
        } else {
            exit = exit.min(-start / rate);
        }
    }
    ((exit - enter) * d.length() > tolerance).then(|| [a + d * enter, a + d * exit])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The closed block `lo`–`hi` as twelve triangles facing out.
    fn block(lo: DVec3, hi: DVec3) -> Vec<([DVec3; 3], DVec3)> {
        let mut out = Vec::new();
        for axis in 0..3 {
            for far in [false, true] {
                let normal = if far {
                    DVec3::AXES[axis]
                } else {
                    -DVec3::AXES[axis]
                };
                let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                let corner = |su: bool, sv: bool| {
                    let mut p = if far { hi } else { lo };
                    p[u] = if su { hi[u] } else { lo[u] };
                    p[v] = if sv { hi[v] } else { lo[v] };
                    p
                };
                let q = [
                    corner(false, false),
                    corner(true, false),
                    corner(true, true),
                    corner(false, true),
                ];
                out.push(([q[0], q[1], q[2]], normal));
                out.push(([q[0], q[2], q[3]], normal));
            }
        }
        out
    }

    fn total_length(edges: &[[DVec3; 2]]) -> f64 {
        edges.iter().map(|[a, b]| a.distance(*b)).sum()
    }

    /// Asserts that the edges' lengths add up to `expected` (m) within 1 cm (pieces cut by a
    /// support's diagonal overlap by the tolerance).
    fn assert_total_length(edges: &[[DVec3; 2]], expected: f64) {
        let total = total_length(edges);
        assert!(
            (total - expected).abs() < 0.01,
            "{total} m of edges, {expected} m expected"
        );
    }

    /// A round table top as one convex face of 200 corners, fanned into slivers that all meet
    /// at its first corner (one plane group, so no sliver is tested against another), with a
    /// 0.4 × 0.3 m block standing on it: every point of the block's foot lies on an edge found,
    /// and every edge on the foot. (With thousands of corners the slivers under the foot get
    /// narrower than the 1 mm tolerance, and pieces that short are dropped.)
    #[test]
    fn a_block_on_a_fanned_round_top_has_its_foot_on_it() {
        let n = 200;
        let rim: Vec<DVec3> = (0..n)
            .map(|i| {
                let a = std::f64::consts::TAU * f64::from(i) / f64::from(n);
                DVec3::new(1.5 + 0.6 * a.cos(), 1.0 + 0.6 * a.sin(), 0.75)
            })
            .collect();
        let mut triangles: Vec<([DVec3; 3], DVec3)> = (1..rim.len() - 1)
            .map(|k| ([rim[0], rim[k], rim[k + 1]], DVec3::Z))
            .collect();
        let groups = plane_groups(&triangles, 1e-3);
        assert!(groups.iter().all(|&g| g == groups[0]), "one plane");
        triangles.extend(block(DVec3::new(1.3, 0.85, 0.75), DVec3::new(1.7, 1.15, 1.0)));
        let groups = plane_groups(&triangles, 1e-3);
        assert_ne!(
            groups[0],
            groups[triangles.len() - 1],
            "the block's top is another plane"
        );
        let edges = edges_on_meshes(&triangles, 1e-3);
        let on_foot = |p: DVec3| {
            (p.z - 0.75).abs() < 1e-12
                && ((p.x - 1.3).abs() < 1e-9
                    || (p.x - 1.7).abs() < 1e-9
                    || (p.y - 0.85).abs() < 1e-9
                    || (p.y - 1.15).abs() < 1e-9)
        };
        assert!(edges.iter().flatten().all(|&p| on_foot(p)), "{edges:?}");
        let corners = [(1.3, 0.85), (1.7, 0.85), (1.7, 1.15), (1.3, 1.15), (1.3, 0.85)];
        let mut missed = Vec::new();
        for side in corners.windows(2) {
            let (a, b) = (
                DVec3::new(side[0].0, side[0].1, 0.75),
                DVec3::new(side[1].0, side[1].1, 0.75),
            );
            for k in 0..=100 {
                let p = a.lerp(b, f64::from(k) / 100.0);
                let covered = edges.iter().any(|[s, e]| {
                    let t = ((p - *s).dot(*e - *s) / (*e - *s).length_squared()).clamp(0.0, 1.0);
                    p.distance(s.lerp(*e, t)) < 1e-9
                });
                if !covered {
                    missed.push(p);
                }
            }
        }
        // A piece whose test point beside it ([`seen_in_front`]) falls off its narrow sliver is
        // not kept: 4 of the 404 points, within 8 mm of two corners, lie in such gaps.
        assert!(
            missed.len() <= 4,
            "{} points on no edge: {missed:?}",
            missed.len()
        );
    }

    #[test]
    fn a_block_alone_has_no_edges_on_itself() {
        let one = block(DVec3::ZERO, DVec3::new(1.0, 0.5, 0.8));
        assert!(edges_on_meshes(&one, 1e-3).is_empty());
    }

    /// A 0.4 × 0.3 m block standing on a 1.6 × 0.5 m one: its foot's four edges lie on the
    /// lower top, each once (its sides rise from it; its base lies in it and rises nowhere), and
    /// they lie inside the lower top's two triangles, whose shared diagonal cuts some of them.
    #[test]
    fn a_block_on_a_block_has_its_foot_on_the_lower_top() {
        let mut triangles = block(DVec3::new(1.0, 0.0, 0.0), DVec3::new(2.6, 0.5, 0.8));
        triangles.extend(block(DVec3::new(1.3, 0.1, 0.8), DVec3::new(1.7, 0.4, 1.15)));
        let edges = edges_on_meshes(&triangles, 1e-3);
        assert_total_length(&edges, 1.4);
        for [a, b] in &edges {
            for p in [a, b] {
                assert!((p.z - 0.8).abs() < 1e-12, "{p}");
                assert!(p.x >= 1.3 - 1e-12 && p.x <= 1.7 + 1e-12 && p.y >= 0.1 - 1e-12 && p.y <= 0.4 + 1e-12);
            }
        }
    }

    /// An edge running off the lower block's top keeps only its part over the top; one that
    /// meets the top's plane beside it keeps nothing.
    #[test]
    fn a_foot_over_the_lower_tops_edge_keeps_its_part_on_it() {
        let mut triangles = block(DVec3::ZERO, DVec3::new(1.0, 1.0, 0.5));
        triangles.extend(block(DVec3::new(0.8, 0.2, 0.5), DVec3::new(1.4, 0.4, 0.7)));
        triangles.extend(block(DVec3::new(2.0, 0.2, 0.5), DVec3::new(2.2, 0.4, 0.7)));
        let edges = edges_on_meshes(&triangles, 1e-3);
        // The foot's side x = 0.8 (0.2 m) and its two long sides over the top (0.2 m each,
        // grown by the tolerance at the top's edge x = 1), and under the overhang the lower
        // block's side x = 1 rising to the foot's underside (0.2 m, a crease like a shelf's
        // underside against a wall).
        assert_total_length(&edges, 0.804);
        assert!(
            edges
                .iter()
                .all(|[a, b]| a.x <= 1.001 + 1e-12 && b.x <= 1.001 + 1e-12)
        );
    }

    /// Two blocks sharing an L's inner crease along z at (1, 1): the crease is an edge on each
    /// block's face, the convex edges are not.
    #[test]
    fn an_inner_crease_is_an_edge_and_an_outer_one_is_not() {
        // The long arm 0–2 × 0–1, the short arm 0–1 × 1–2, both 0.5 m high.
        let mut triangles = block(DVec3::ZERO, DVec3::new(2.0, 1.0, 0.5));
        triangles.extend(block(DVec3::new(0.0, 1.0, 0.0), DVec3::new(1.0, 2.0, 0.5)));
        let edges = edges_on_meshes(&triangles, 1e-3);
        let crease = |p: &DVec3| (p.x - 1.0).abs() < 1e-9 && (p.y - 1.0).abs() < 1e-9;
        let upright: Vec<_> = edges.iter().filter(|[a, b]| crease(a) && crease(b)).collect();
        assert!(!upright.is_empty(), "{edges:?}");
        assert_total_length(&upright.into_iter().copied().collect::<Vec<_>>(), 0.5);
        // The seam where the two blocks stand side by side (x from 0 to 1 at y = 1) makes each
        // block's faces there rise from the other's hidden face: no edges.
        assert!(edges.iter().all(|[a, b]| crease(a) && crease(b)), "{edges:?}");
    }
}
