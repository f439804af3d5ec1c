//! Shadow rays against the scene's occluders: furniture boxes (exact f64 slab tests, in a
//! [`BoxBvh`] for rays that may meet any of them) and OBJ triangles (a BVH2 from the `obvhs`
//! crate, f32, built once per scene from the coarse mesh's triangles, the same surface as the
//! fine mesh's in fewer pieces: docs/DECISIONS.md "Shadow rays against the coarse OBJ
//! triangles").
//!
//! Room walls never occlude (the room is convex); only boxes and meshes can, so a scene
//! without them needs no visibility tests at all ([`crate::transport::visibility::Unoccluded`]).
//! Our own f64 BVH was measured against obvhs on the sculpture room (3 536 triangles, 13 650
//! shadow rays, one run): 3.17 ms against 1.36 ms, so the triangles go to obvhs; `benches/visibility.rs`
//! repeats the comparison for this wrapper.

use std::time::Duration;

use glam::{DVec3, Vec3A};
use obvhs::{BvhBuildParams, bvh2::Bvh2, bvh2::builder::build_bvh2_from_tris, ray::Ray, triangle::Triangle};

use crate::fsio::Fnv64;
use crate::scene::{Aabb, PatchMesh, Scene, SurfaceKind};
use crate::transport::box_bvh::{BoxBvh, slab};
use crate::transport::visibility::Visibility;

/// Relative margin that keeps a ray's end points off the surfaces they lie on (boxes, f64).
const END_EPS: f64 = 1e-7;
/// Distance (m) kept from both ends of a shadow ray against triangles (f32 BVH: coordinates of a
/// few metres carry about 5e-7 m of rounding).
const TRIANGLE_END_M: f32 = 1e-4;

/// OBJ triangles in an obvhs BVH2.
#[derive(Clone)]
struct TriangleBvh {
    triangles: Vec<Triangle>,
    bvh: Bvh2,
}

impl std::fmt::Debug for TriangleBvh {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "TriangleBvh({} triangles)", self.triangles.len())
    }
}

/// The scene's occluders. Answers shadow-ray queries for any number of threads.
#[derive(Debug, Clone)]
pub struct Occluders {
    boxes: BoxBvh,
    triangles: Option<TriangleBvh>,
}

impl Occluders {
    /// The boxes and OBJ triangles of a scene. Returns `None` when nothing can occlude (an
    /// empty convex room), so callers skip visibility entirely.
    pub fn of_scene(scene: &Scene) -> Option<Self> {
        let triangles: Vec<[DVec3; 3]> = mesh_triangles(occluder_mesh(scene), scene).collect();
        (!scene.boxes.is_empty() || !triangles.is_empty()).then(|| Self::from_parts(&scene.boxes, &triangles))
    }

    /// Boxes and triangles given directly (world, m).
    pub fn from_parts(boxes: &[Aabb], triangles: &[[DVec3; 3]]) -> Self {
        let triangles = (!triangles.is_empty()).then(|| {
            let triangles: Vec<Triangle> = triangles
                .iter()
                .map(|t| Triangle {
                    v0: t[0].as_vec3a(),
                    v1: t[1].as_vec3a(),
                    v2: t[2].as_vec3a(),
                })
                .collect();
            let bvh = build_bvh2_from_tris(
                &triangles,
                BvhBuildParams::medium_build(),
                &mut Duration::default(),
            );
            TriangleBvh { triangles, bvh }
        });
        Occluders {
            boxes: BoxBvh::new(boxes),
            triangles,
        }
    }

    /// Number of primitives (boxes + triangles).
    pub fn len(&self) -> usize {
        self.boxes.boxes().len() + self.triangles.as_ref().map_or(0, |t| t.triangles.len())
    }

    /// True when there are no occluders.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The occluders that reach into the box `min`–`max` (world, m): boxes by their extent,
    /// triangles by their BVH nodes (conservatively). A segment inside that box can be blocked
    /// only by these, so the shadow rays of a tile of receivers test them alone — or none at all
    /// when the view is empty.
    pub fn within(&self, min: DVec3, max: DVec3) -> LocalOccluders<'_> {
        let boxes = self
            .boxes
            .boxes()
            .iter()
            .filter(|b| b.min.cmplt(max).all() && b.max.cmpgt(min).all())
            .copied()
            .collect();
        let triangles = self.triangles.as_ref().filter(|tris| {
            let margin = Vec3A::splat(TRIANGLE_END_M);
            let bounds = obvhs::aabb::Aabb {
                min: min.as_vec3a() - margin,
                max: max.as_vec3a() + margin,
            };
            let mut hit = false;
            tris.bvh.aabb_traverse(bounds, |_, _| {
                hit = true;
                false
            });
            hit
        });
        LocalOccluders { boxes, triangles }
    }

    /// The occluders that can meet a segment between a point of the box `a` and a point of the
    /// box `b` (each `(min, max)`, world, m): those of [`Self::within`] the two boxes' bounds,
    /// less the boxes that a plane along the line between the two centres separates from both
    /// (such a segment lies in the convex hull of the two boxes, whose projection on any axis
    /// spans the two boxes' projections; the axes tried are each coordinate axis crossed with
    /// that line). The links' shadow rays between a floor and a ceiling cluster test the desks
    /// in the tube between them, not every desk under the pair's bounding box.
    pub fn between(&self, a: (DVec3, DVec3), b: (DVec3, DVec3)) -> LocalOccluders<'_> {
        let mut local = self.within(a.0.min(b.0), a.1.max(b.1));
        let line = (b.0 + b.1 - a.0 - a.1) * 0.5;
        // The interval of a box's projection on `axis`.
        let span = |lo: DVec3, hi: DVec3, axis: DVec3| {
            let (c, r) = (axis.dot((lo + hi) * 0.5), axis.abs().dot((hi - lo) * 0.5));
            (c - r, c + r)
        };
        // Per axis, the hull's projection widened by the separation margin, made once.
        let hull = [DVec3::X, DVec3::Y, DVec3::Z].map(|e| {
            let axis = e.cross(line);
            let gap = SEPARATION_M * axis.length();
            let ((a_lo, a_hi), (b_lo, b_hi)) = (span(a.0, a.1, axis), span(b.0, b.1, axis));
            (axis, a_lo.min(b_lo) - gap, a_hi.max(b_hi) + gap)
        });
        local.boxes.retain(|o| {
            !hull.iter().any(|&(axis, lo, hi)| {
                let (o_lo, o_hi) = span(o.min, o.max, axis);
                hi < o_lo || o_hi < lo
            })
        });
        local
    }

    /// The occluders that can meet a segment from a point of the box `min`–`max` to `light`
    /// (world, m): boxes that overlap the convex hull of that box and the light, triangles by
    /// their BVH nodes against the hull's bounding box (conservatively). The shadow rays of a
    /// tile of pixels test only these. Tighter than [`Occluders::within`] of the hull's bounding
    /// box: a desk inside that box but off the cone from the light to the tile is dropped.
    pub fn toward(&self, min: DVec3, max: DVec3, light: DVec3) -> LocalOccluders<'_> {
        let (lo, hi) = (min.min(light), max.max(light));
        let mut near = self.within(lo, hi);
        near.boxes.retain(|b| hull_meets_box(min, max, light, b));
        near
    }

    /// True when any occluder meets the open segment `from → to`.
    pub fn blocked(&self, from: DVec3, to: DVec3) -> bool {
        segment_blocked(Boxes::Tree(&self.boxes), self.triangles.as_ref(), from, to)
    }
}

/// The occluders near a group of shadow rays ([`Occluders::within`]).
#[derive(Debug, Clone)]
pub struct LocalOccluders<'a> {
    boxes: Vec<Aabb>,
    triangles: Option<&'a TriangleBvh>,
}

/// The boxes a segment is tested against: a short list one by one (a local view), or all of
/// them through their hierarchy.
#[derive(Clone, Copy)]
enum Boxes<'a> {
    List(&'a [Aabb]),
    Tree(&'a BoxBvh),
}

impl LocalOccluders<'_> {
    /// True when nothing reaches into the region: no segment inside it is blocked.
    pub fn is_empty(&self) -> bool {
        self.boxes.is_empty() && self.triangles.is_none()
    }

    /// True when any of these occluders meets the open segment `from → to` (both inside the
    /// region the view was made for; the same answer as [`Occluders::blocked`] there).
    pub fn blocked(&self, from: DVec3, to: DVec3) -> bool {
        segment_blocked(Boxes::List(&self.boxes), self.triangles, from, to)
    }
}

/// Whether the convex hull of the box `min`–`max` and the point `apex` may meet the box `b`:
/// false only when a separating axis shows a gap (more than [`SEPARATION_M`]). The axes of two
/// convex solids' separation are their face normals and the cross products of their edges:
/// here the coordinate axes and each axis × (corner − apex) (docs/DECISIONS.md, "Per-pixel
/// direct light").
fn hull_meets_box(min: DVec3, max: DVec3, apex: DVec3, b: &Aabb) -> bool {
    let (center, half) = ((min + max) * 0.5, (max - min) * 0.5);
    let (b_center, b_half) = ((b.min + b.max) * 0.5, (b.max - b.min) * 0.5);
    let separated = |axis: DVec3| {
        let reach = axis.abs().dot(half);
        let c = axis.dot(center);
        let a = axis.dot(apex);
        let (h_lo, h_hi) = ((c - reach).min(a), (c + reach).max(a));
        let (b_c, b_reach) = (axis.dot(b_center), axis.abs().dot(b_half));
        let gap = SEPARATION_M * axis.length();
        h_hi + gap < b_c - b_reach || b_c + b_reach + gap < h_lo
    };
    let axes = [DVec3::X, DVec3::Y, DVec3::Z];
    if axes.into_iter().any(separated) {
        return false;
    }
    let corners = (0..8).map(|k| {
        DVec3::new(
            if k & 1 == 0 { min.x } else { max.x },
            if k & 2 == 0 { min.y } else { max.y },
            if k & 4 == 0 { min.z } else { max.z },
        )
    });
    !corners
        .flat_map(|c| axes.map(|e| e.cross(c - apex)))
        .any(separated)
}

/// A gap smaller than this (m) between a tile's hull and a box does not drop the box: rounding
/// never drops an occluder a shadow ray could meet.
const SEPARATION_M: f64 = 1e-9;

/// True when a box or a triangle meets the open segment `from → to`.
fn segment_blocked(boxes: Boxes<'_>, triangles: Option<&TriangleBvh>, from: DVec3, to: DVec3) -> bool {
    let d = to - from;
    let inv_d = d.recip();
    let (t0, t1) = (END_EPS, 1.0 - END_EPS);
    let box_hit = match boxes {
        Boxes::List(list) => list.iter().any(|b| slab(b, from, inv_d, t0, t1)),
        Boxes::Tree(tree) => tree.blocked(from, inv_d, t0, t1),
    };
    if box_hit {
        return true;
    }
    let Some(tris) = triangles else { return false };
    let len = d.length();
    let (t0, t1) = (TRIANGLE_END_M, len as f32 - TRIANGLE_END_M);
    if len == 0.0 || t1 <= t0 {
        return false;
    }
    let ray = Ray::new(from.as_vec3a(), (d / len).as_vec3a(), t0, t1);
    !tris.bvh.ray_traverse_miss(ray, |r, id| {
        ray_meets_triangle(&tris.triangles[tris.bvh.primitive_indices[id] as usize], r)
    })
}

/// How far (barycentric, of the triangle's size) past its edges a ray still meets a triangle:
/// about a micrometre on a 0.1 m triangle, 5 µm on a 0.5 m one.
const TRIANGLE_EDGE_MARGIN: f32 = 1e-5;

/// Distance along `ray` at which it meets `t` within the ray's range, or infinity: Möller–Trumbore
/// with the edges widened by [`TRIANGLE_EDGE_MARGIN`] (docs/DECISIONS.md "Shadow rays through a
/// mesh's edges"). obvhs' own test rounds a ray through the edge two triangles share a hair
/// outside both, so light passed through an OBJ panel along every line of its fine grid — the
/// plane of a light and a receiver standing over such a line.
fn ray_meets_triangle(t: &Triangle, ray: &Ray) -> f32 {
    let (e1, e2) = (t.v1 - t.v0, t.v2 - t.v0);
    let p = ray.direction.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 {
        return f32::INFINITY;
    }
    let inv = 1.0 / det;
    let s = ray.origin - t.v0;
    let u = s.dot(p) * inv;
    let q = s.cross(e1);
    let v = ray.direction.dot(q) * inv;
    if u < -TRIANGLE_EDGE_MARGIN || v < -TRIANGLE_EDGE_MARGIN || u + v > 1.0 + TRIANGLE_EDGE_MARGIN {
        return f32::INFINITY;
    }
    let distance = e2.dot(q) * inv;
    if distance >= ray.tmin && distance <= ray.tmax {
        distance
    } else {
        f32::INFINITY
    }
}

impl Visibility for Occluders {
    fn visible(&self, from: DVec3, to: DVec3) -> bool {
        !self.blocked(from, to)
    }
}

/// Adds what [`Occluders::of_scene`] is made of — the boxes' corners, then the OBJ surfaces'
/// coarse triangles — to a cache key (world, m; by bit pattern).
pub fn hash_occluders(scene: &Scene, h: &mut Fnv64) {
    for b in &scene.boxes {
        for v in [b.min, b.max] {
            h.f64(v.x).f64(v.y).f64(v.z);
        }
    }
    for triangle in mesh_triangles(occluder_mesh(scene), scene) {
        for p in triangle {
            h.f64(p.x).f64(p.y).f64(p.z);
        }
    }
}

/// The mesh whose OBJ triangles the occluders hold: the coarse one, or the fine one when a room
/// sets `solver_patch_size` below `patch_size` — whichever cuts the same surfaces into fewer
/// pieces.
fn occluder_mesh(scene: &Scene) -> &PatchMesh {
    if scene.coarse.patches.len() <= scene.fine.patches.len() {
        &scene.coarse
    } else {
        &scene.fine
    }
}

/// The triangles of `mesh`'s patches that belong to OBJ meshes (world, m).
fn mesh_triangles<'a>(mesh: &'a PatchMesh, scene: &'a Scene) -> impl Iterator<Item = [DVec3; 3]> + 'a {
    mesh.triangles().filter_map(move |([a, b, c], pid)| {
        let surface = mesh.patches[pid as usize].surface as usize;
        matches!(scene.surfaces[surface].kind, SurfaceKind::Mesh { .. }).then(|| {
            [
                mesh.positions[a as usize],
                mesh.positions[b as usize],
                mesh.positions[c as usize],
            ]
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Möller–Trumbore in f64: does the segment `from + t d`, t in (0, 1), cross the triangle?
    fn brute_hit([a, b, c]: [DVec3; 3], o: DVec3, d: DVec3) -> bool {
        let (e1, e2) = (b - a, c - a);
        let p = d.cross(e2);
        let det = e1.dot(p);
        if det.abs() < 1e-300 {
            return false;
        }
        let s = o - a;
        let u = s.dot(p) / det;
        let q = s.cross(e1);
        let v = d.dot(q) / det;
        let t = e2.dot(q) / det;
        (0.0..=1.0).contains(&u) && v >= 0.0 && u + v <= 1.0 && t > 0.0 && t < 1.0
    }

    fn unit_box(min: [f64; 3], max: [f64; 3]) -> Aabb {
        Aabb {
            min: DVec3::from(min),
            max: DVec3::from(max),
        }
    }

    /// A square panel of two triangles meeting along its diagonal, and a 0.5 m square of eight
    /// meeting along lines through its middle (a fine grid): a segment through the shared edge
    /// or the shared corner, exactly, is blocked; one past the panel's outer edge is not.
    #[test]
    fn a_ray_through_an_edge_two_triangles_share_is_blocked() {
        let (a, b, c, d) = (
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(1.0, 0.0, 1.0),
            DVec3::new(1.0, 1.0, 1.0),
            DVec3::new(0.0, 1.0, 1.0),
        );
        let occ = Occluders::from_parts(&[], &[[a, b, c], [a, c, d]]);
        for k in 1..20 {
            let x = k as f64 / 20.0;
            let on_diagonal = DVec3::new(x, x, 1.0);
            let below = DVec3::new(0.37, 0.61, 0.2);
            let above = below + (on_diagonal - below) * 2.0;
            assert!(occ.blocked(below, above), "through ({x}, {x})");
        }
        assert!(!occ.blocked(DVec3::new(1.01, 0.5, 0.0), DVec3::new(1.01, 0.5, 2.0)));
        // A grid of 0.25 m squares over x, y in [1, 1.5] at z = 2.2, crossed in the plane
        // x = 1.25 from a light 3.5 cm under it to points over it (the reference room's baffle,
        // flattened).
        let mut grid = Vec::new();
        for i in 0..2 {
            for j in 0..2 {
                let (x, y) = (1.0 + 0.25 * i as f64, 1.0 + 0.25 * j as f64);
                let z = 2.2;
                let q = [
                    DVec3::new(x, y, z),
                    DVec3::new(x + 0.25, y, z),
                    DVec3::new(x + 0.25, y + 0.25, z),
                    DVec3::new(x, y + 0.25, z),
                ];
                grid.push([q[0], q[1], q[2]]);
                grid.push([q[0], q[2], q[3]]);
            }
        }
        let occ = Occluders::from_parts(&[], &grid);
        let light = DVec3::new(1.25, 1.27, 2.1654);
        for y in [1.1, 1.25, 1.3, 1.45] {
            assert!(
                occ.blocked(light, DVec3::new(1.25, y, 2.8)),
                "to (1.25, {y}, 2.8)"
            );
        }
    }

    #[test]
    fn box_blocks_only_segments_through_it() {
        let occ = Occluders::from_parts(&[unit_box([1.0, 1.0, 0.0], [2.0, 2.0, 1.0])], &[]);
        let light = DVec3::new(1.5, 1.5, 3.0);
        assert!(occ.blocked(light, DVec3::new(1.5, 1.5, -0.5)));
        assert!(!occ.blocked(light, DVec3::new(3.0, 1.5, 0.0)));
        // A point on the box's top face sees the light (end point excluded).
        assert!(!occ.blocked(light, DVec3::new(1.5, 1.5, 1.0)));
        // Grazing along a face plane (NaN in the slab test) does not count as a hit.
        assert!(!occ.blocked(DVec3::new(0.0, 1.0, 2.0), DVec3::new(3.0, 1.0, 2.0)));
        // No occluders at all (a forced visibility pass in an empty room) blocks nothing.
        assert!(!Occluders::from_parts(&[], &[]).blocked(light, DVec3::ZERO));
    }

    #[test]
    fn toward_drops_only_boxes_no_segment_to_the_light_meets() {
        // A desk between a ceiling light and the floor: tiles of floor points in its shadow or
        // at its edge keep it; tiles well off to the side, whose boxes with the light still
        // hold the desk, drop it. Checked against many segments per tile.
        let desk = unit_box([2.0, 2.0, 0.0], [3.6, 2.8, 0.75]);
        let occ = Occluders::from_parts(&[desk], &[]);
        let light = DVec3::new(2.8, 2.4, 2.8);
        let mut dropped = 0;
        for ix in 0..40 {
            for iy in 0..30 {
                let lo = DVec3::new(0.1 * f64::from(ix) - 0.3, 0.1 * f64::from(iy) - 0.3, 0.0);
                let hi = lo + DVec3::new(0.1, 0.1, 0.0);
                let near = occ.toward(lo, hi, light);
                let any_blocked = (0..=8).any(|a| {
                    (0..=8).any(|b| {
                        let p = lo + (hi - lo) * DVec3::new(f64::from(a) / 8.0, f64::from(b) / 8.0, 0.0);
                        occ.blocked(p, light)
                    })
                });
                if any_blocked {
                    assert!(!near.is_empty(), "tile at {lo} is shadowed but dropped the desk");
                }
                let in_box = !occ.within(lo.min(light), hi.max(light)).is_empty();
                if in_box && near.is_empty() {
                    dropped += 1;
                }
            }
        }
        // Most tiles whose bounding box with the light holds the desk are not behind it.
        assert!(dropped > 300, "only {dropped} tiles dropped the desk");
        // A tile right under the desk's edge keeps it; one on the far wall side drops it.
        assert!(
            !occ.toward(DVec3::new(3.6, 2.3, 0.0), DVec3::new(3.7, 2.4, 0.0), light)
                .is_empty()
        );
        assert!(
            occ.toward(DVec3::new(0.0, 4.0, 0.0), DVec3::new(0.1, 4.1, 0.0), light)
                .is_empty()
        );
    }

    #[test]
    fn within_keeps_only_what_reaches_into_the_region() {
        let occ = Occluders::from_parts(
            &[unit_box([1.0, 1.0, 0.0], [2.0, 2.0, 1.0])],
            &[[
                DVec3::new(4.0, 4.0, 2.0),
                DVec3::new(5.0, 4.0, 2.0),
                DVec3::new(4.0, 5.0, 2.0),
            ]],
        );
        let (lo, hi) = (DVec3::new(1.5, 1.5, 0.5), DVec3::new(3.0, 3.0, 3.0));
        let near_box = occ.within(lo, hi);
        assert!(!near_box.is_empty());
        // It answers like the whole set for segments inside the region.
        for (from, to) in [
            (DVec3::new(1.6, 1.6, 2.9), DVec3::new(1.7, 1.7, 0.6)),
            (DVec3::new(2.9, 2.9, 2.9), DVec3::new(2.5, 2.5, 0.6)),
        ] {
            assert_eq!(near_box.blocked(from, to), occ.blocked(from, to));
        }
        assert!(near_box.blocked(DVec3::new(1.6, 1.6, 2.9), DVec3::new(1.7, 1.7, 0.6)));
        assert!(
            !occ.within(DVec3::new(4.2, 4.2, 1.0), DVec3::new(4.3, 4.3, 3.0))
                .is_empty()
        );
        // Beside the box (touching its face is not reaching into it), and far from both.
        assert!(
            occ.within(DVec3::new(2.0, 0.0, 0.0), DVec3::new(3.0, 3.0, 3.0))
                .is_empty()
        );
        assert!(
            occ.within(DVec3::new(0.0, 0.0, 1.5), DVec3::new(3.0, 3.0, 1.9))
                .is_empty()
        );
        assert!(
            Occluders::from_parts(&[], &[])
                .within(DVec3::ZERO, DVec3::ONE)
                .is_empty()
        );
    }

    /// Between a floor patch and a ceiling patch 4 m along: a low desk under the pair's bounds
    /// but below every segment between them is dropped, a tall cabinet in the way is kept; and
    /// for random boxes and occluders the view answers every segment between the two boxes as
    /// the whole set does.
    #[test]
    fn between_keeps_every_box_a_segment_between_the_two_can_meet() {
        let desk = unit_box([2.2, 0.0, 0.0], [3.0, 1.0, 0.75]);
        let cabinet = unit_box([2.0, 0.0, 0.0], [3.0, 1.0, 2.5]);
        let floor = (DVec3::new(0.0, 0.0, 0.0), DVec3::new(1.0, 1.0, 0.0));
        let ceiling = (DVec3::new(4.0, 0.0, 3.0), DVec3::new(5.0, 1.0, 3.0));
        let occ = Occluders::from_parts(&[desk], &[]);
        assert!(!occ.within(floor.0, ceiling.1).is_empty());
        assert!(occ.between(floor, ceiling).is_empty());
        let occ = Occluders::from_parts(&[desk, cabinet], &[]);
        let view = occ.between(floor, ceiling);
        assert_eq!(view.boxes, vec![cabinet]);

        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let random_box = |next: &mut dyn FnMut() -> f64, size: f64| {
            let lo = DVec3::new(next(), next(), next()) * 5.0;
            let extent = DVec3::new(next(), next(), next()) * size;
            (lo, lo + extent)
        };
        let (mut checked, mut dropped) = (0, 0);
        for _ in 0..200 {
            let a = random_box(&mut next, 1.0);
            let b = random_box(&mut next, 1.0);
            let boxes: Vec<Aabb> = (0..6)
                .map(|_| {
                    let (min, max) = random_box(&mut next, 1.5);
                    Aabb { min, max }
                })
                .collect();
            let occ = Occluders::from_parts(&boxes, &[]);
            let view = occ.between(a, b);
            dropped += occ.within(a.0.min(b.0), a.1.max(b.1)).boxes.len() - view.boxes.len();
            for _ in 0..20 {
                let p = a.0 + (a.1 - a.0) * DVec3::new(next(), next(), next());
                let q = b.0 + (b.1 - b.0) * DVec3::new(next(), next(), next());
                assert_eq!(view.blocked(p, q), occ.blocked(p, q), "{a:?} {b:?} {boxes:?}");
                checked += usize::from(occ.blocked(p, q));
            }
        }
        // The random cases block some segments and the view drops some boxes (so the
        // comparison means something).
        assert!(
            checked > 100 && dropped > 50,
            "{checked} blocked, {dropped} dropped"
        );
    }

    #[test]
    fn triangle_bvh_agrees_with_brute_force() {
        // A 20×20 grid of small triangles in the plane z = 1, with gaps between them.
        let mut tris = Vec::new();
        for i in 0..20 {
            for j in 0..20 {
                let (x, y) = (i as f64 * 0.2, j as f64 * 0.2);
                tris.push([
                    DVec3::new(x, y, 1.0),
                    DVec3::new(x + 0.1, y, 1.0),
                    DVec3::new(x, y + 0.1, 1.0),
                ]);
            }
        }
        let occ = Occluders::from_parts(&[], &tris);
        let from = DVec3::new(2.0, 2.0, 3.0);
        let mut hits = 0;
        for a in 0..80 {
            for b in 0..80 {
                let to = DVec3::new(a as f64 * 0.05 + 0.013, b as f64 * 0.05 + 0.017, 0.0);
                let d = to - from;
                let brute = tris.iter().any(|&t| brute_hit(t, from, d));
                assert_eq!(occ.blocked(from, to), brute, "ray to {to}");
                hits += usize::from(brute);
            }
        }
        assert!(
            hits > 100 && hits < 6400 - 100,
            "test rays must both hit and miss: {hits}"
        );
    }
}
