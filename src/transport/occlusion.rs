//! Shadow rays against the scene's occluders: furniture boxes (exact slab tests) and OBJ
//! triangles, in a bounding-volume hierarchy (binned SAH, built once per scene).
//!
//! Room walls never occlude (the room is convex); only boxes and meshes can, so a scene
//! without them needs no visibility tests at all ([`crate::transport::visibility::Unoccluded`]).

use glam::DVec3;

use crate::scene::{Aabb, PatchMesh, Scene, SurfaceKind};
use crate::transport::visibility::Visibility;

/// Relative margin that keeps a ray's end points off the surfaces they lie on.
const END_EPS: f64 = 1e-7;

/// One occluding primitive.
#[derive(Debug, Clone, Copy)]
enum Primitive {
    /// An axis-aligned box (a `[[box]]`), tested with the slab method.
    Box(Aabb),
    /// A triangle of an OBJ mesh (world, m).
    Triangle([DVec3; 3]),
}

impl Primitive {
    fn bounds(&self) -> Aabb {
        match *self {
            Primitive::Box(b) => b,
            Primitive::Triangle([a, b, c]) => Aabb {
                min: a.min(b).min(c),
                max: a.max(b).max(c),
            },
        }
    }

    /// True when the primitive meets the ray `o + t d` for t in (t0, t1).
    fn hits(&self, o: DVec3, d: DVec3, inv_d: DVec3, t0: f64, t1: f64) -> bool {
        match *self {
            Primitive::Box(b) => slab(&b, o, inv_d, t0, t1),
            Primitive::Triangle(tri) => triangle_hit(tri, o, d).is_some_and(|t| t > t0 && t < t1),
        }
    }
}

/// Ray–box slab test: the ray's parameter interval inside the box, clipped to [t0, t1]
/// (empty when enter > exit).
fn slab_interval(b: &Aabb, o: DVec3, inv_d: DVec3, t0: f64, t1: f64) -> (f64, f64) {
    let ta = (b.min - o) * inv_d;
    let tb = (b.max - o) * inv_d;
    let near = ta.min(tb);
    let far = ta.max(tb);
    // NaN (0 · ∞ for a ray in a slab's plane) is dropped by max/min on each axis.
    let enter = near.x.max(near.y).max(near.z).max(t0);
    let exit = far.x.min(far.y).min(far.z).min(t1);
    (enter, exit)
}

/// True when the ray passes through the box's interior within the open interval (t0, t1).
fn slab(b: &Aabb, o: DVec3, inv_d: DVec3, t0: f64, t1: f64) -> bool {
    let (enter, exit) = slab_interval(b, o, inv_d, t0, t1);
    enter < exit
}

/// Möller–Trumbore: the ray parameter of the hit, if any.
fn triangle_hit([a, b, c]: [DVec3; 3], o: DVec3, d: DVec3) -> Option<f64> {
    let e1 = b - a;
    let e2 = c - a;
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-300 {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - a;
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    Some(e2.dot(q) * inv)
}

/// A BVH node: leaves hold a range of primitives, inner nodes two children.
#[derive(Debug, Clone, Copy)]
struct Node {
    bounds: Aabb,
    /// Leaf: first primitive; inner: index of the left child (right = left + 1).
    first: u32,
    /// Number of primitives (0 for an inner node).
    count: u32,
}

/// The scene's occluders in a BVH. Answers shadow-ray queries for any number of threads.
#[derive(Debug, Clone)]
pub struct Occluders {
    primitives: Vec<Primitive>,
    nodes: Vec<Node>,
}

impl Occluders {
    /// The boxes and OBJ triangles of a scene. Returns `None` when nothing can occlude (an
    /// empty convex room), so callers skip visibility entirely.
    pub fn of_scene(scene: &Scene) -> Option<Self> {
        let mut primitives: Vec<Primitive> = scene.boxes.iter().copied().map(Primitive::Box).collect();
        primitives.extend(mesh_triangles(&scene.fine, scene));
        (!primitives.is_empty()).then(|| Self::build(primitives))
    }

    /// Boxes and triangles given directly (world, m).
    pub fn from_parts(boxes: &[Aabb], triangles: &[[DVec3; 3]]) -> Self {
        let mut primitives: Vec<Primitive> = boxes.iter().copied().map(Primitive::Box).collect();
        primitives.extend(triangles.iter().copied().map(Primitive::Triangle));
        Self::build(primitives)
    }

    /// Number of primitives (boxes + triangles).
    pub fn len(&self) -> usize {
        self.primitives.len()
    }

    /// True when there are no occluders.
    pub fn is_empty(&self) -> bool {
        self.primitives.is_empty()
    }

    fn build(mut primitives: Vec<Primitive>) -> Self {
        let mut nodes = Vec::with_capacity(2 * primitives.len());
        let n = primitives.len() as u32;
        nodes.push(Node {
            bounds: bounds_of(&primitives),
            first: 0,
            count: n,
        });
        let mut stack = vec![0usize];
        while let Some(ni) = stack.pop() {
            let Node { first, count, .. } = nodes[ni];
            if count <= 4 {
                continue;
            }
            let range = first as usize..(first + count) as usize;
            let Some(mid) = split_sah(&mut primitives[range.clone()]) else {
                continue;
            };
            let left_count = mid as u32;
            let left = nodes.len();
            let (lp, rp) = primitives[range].split_at(mid);
            nodes.push(Node {
                bounds: bounds_of(lp),
                first,
                count: left_count,
            });
            nodes.push(Node {
                bounds: bounds_of(rp),
                first: first + left_count,
                count: count - left_count,
            });
            nodes[ni] = Node {
                bounds: nodes[ni].bounds,
                first: left as u32,
                count: 0,
            };
            stack.push(left);
            stack.push(left + 1);
        }
        Occluders { primitives, nodes }
    }

    /// True when any occluder meets the open segment `from → to`.
    pub fn blocked(&self, from: DVec3, to: DVec3) -> bool {
        if self.primitives.is_empty() {
            return false;
        }
        let d = to - from;
        let inv_d = d.recip();
        let (t0, t1) = (END_EPS, 1.0 - END_EPS);
        let mut stack = [0u32; 64];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let node = self.nodes[stack[top] as usize];
            // Node bounds may be flat (coplanar triangles): touching counts.
            let (enter, exit) = slab_interval(&node.bounds, from, inv_d, 0.0, 1.0);
            if enter > exit {
                continue;
            }
            if node.count > 0 {
                let prims = &self.primitives[node.first as usize..(node.first + node.count) as usize];
                if prims.iter().any(|p| p.hits(from, d, inv_d, t0, t1)) {
                    return true;
                }
            } else {
                stack[top] = node.first;
                stack[top + 1] = node.first + 1;
                top += 2;
            }
        }
        false
    }
}

impl Visibility for Occluders {
    fn visible(&self, from: DVec3, to: DVec3) -> bool {
        !self.blocked(from, to)
    }
}

fn bounds_of(prims: &[Primitive]) -> Aabb {
    prims.iter().fold(
        Aabb {
            min: DVec3::splat(f64::INFINITY),
            max: DVec3::splat(f64::NEG_INFINITY),
        },
        |acc, p| {
            let b = p.bounds();
            Aabb {
                min: acc.min.min(b.min),
                max: acc.max.max(b.max),
            }
        },
    )
}

fn area(b: &Aabb) -> f64 {
    let e = (b.max - b.min).max(DVec3::ZERO);
    2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
}

/// Binned surface-area-heuristic split; reorders `prims` and returns the split index, or
/// `None` when no split beats a leaf.
fn split_sah(prims: &mut [Primitive]) -> Option<usize> {
    const BINS: usize = 12;
    let centre = |p: &Primitive| {
        let b = p.bounds();
        (b.min + b.max) * 0.5
    };
    let cb = prims.iter().fold(
        Aabb {
            min: DVec3::splat(f64::INFINITY),
            max: DVec3::splat(f64::NEG_INFINITY),
        },
        |acc, p| Aabb {
            min: acc.min.min(centre(p)),
            max: acc.max.max(centre(p)),
        },
    );
    let mut best: Option<(f64, usize, f64)> = None;
    for axis in 0..3 {
        let (lo, hi) = (cb.min[axis], cb.max[axis]);
        if hi - lo <= 1e-12 {
            continue;
        }
        let bin_of =
            |p: &Primitive| (((centre(p)[axis] - lo) / (hi - lo) * BINS as f64) as usize).min(BINS - 1);
        let mut counts = [0usize; BINS];
        let mut boxes = [Aabb {
            min: DVec3::splat(f64::INFINITY),
            max: DVec3::splat(f64::NEG_INFINITY),
        }; BINS];
        for p in prims.iter() {
            let i = bin_of(p);
            counts[i] += 1;
            let b = p.bounds();
            boxes[i] = Aabb {
                min: boxes[i].min.min(b.min),
                max: boxes[i].max.max(b.max),
            };
        }
        for split in 1..BINS {
            let merge = |r: std::ops::Range<usize>| {
                r.fold(
                    (
                        0usize,
                        Aabb {
                            min: DVec3::splat(f64::INFINITY),
                            max: DVec3::splat(f64::NEG_INFINITY),
                        },
                    ),
                    |(n, a), i| {
                        (
                            n + counts[i],
                            Aabb {
                                min: a.min.min(boxes[i].min),
                                max: a.max.max(boxes[i].max),
                            },
                        )
                    },
                )
            };
            let (nl, bl) = merge(0..split);
            let (nr, br) = merge(split..BINS);
            if nl == 0 || nr == 0 {
                continue;
            }
            let cost = nl as f64 * area(&bl) + nr as f64 * area(&br);
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, lo + (hi - lo) * split as f64 / BINS as f64));
            }
        }
    }
    let (cost, axis, plane) = best?;
    if cost >= prims.len() as f64 * area(&bounds_of(prims)) {
        return None;
    }
    let mut mid = 0;
    for i in 0..prims.len() {
        if centre(&prims[i])[axis] < plane {
            prims.swap(i, mid);
            mid += 1;
        }
    }
    (mid > 0 && mid < prims.len()).then_some(mid)
}

/// The triangles of the fine patches that belong to OBJ meshes (world, m).
fn mesh_triangles<'a>(mesh: &'a PatchMesh, scene: &'a Scene) -> impl Iterator<Item = Primitive> + 'a {
    mesh.triangles().filter_map(move |([a, b, c], pid)| {
        let surface = mesh.patches[pid as usize].surface as usize;
        matches!(scene.surfaces[surface].kind, SurfaceKind::Mesh { .. }).then(|| {
            Primitive::Triangle([
                mesh.positions[a as usize],
                mesh.positions[b as usize],
                mesh.positions[c as usize],
            ])
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_box(min: [f64; 3], max: [f64; 3]) -> Aabb {
        Aabb {
            min: DVec3::from(min),
            max: DVec3::from(max),
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
    fn bvh_over_many_triangles_agrees_with_brute_force() {
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
        assert!(occ.nodes.len() > 1, "the BVH must split");
        let from = DVec3::new(2.0, 2.0, 3.0);
        let mut hits = 0;
        for a in 0..80 {
            for b in 0..80 {
                let to = DVec3::new(a as f64 * 0.05 + 0.013, b as f64 * 0.05 + 0.017, 0.0);
                let d = to - from;
                let brute = tris
                    .iter()
                    .any(|&t| triangle_hit(t, from, d).is_some_and(|t| t > END_EPS && t < 1.0 - END_EPS));
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
