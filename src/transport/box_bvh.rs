//! A bounding-volume hierarchy over the furniture boxes, for shadow rays that may meet any of
//! them (docs/DECISIONS.md "Shadow rays against many boxes").
//!
//! A shadow ray used to test every box of the scene in turn: 40 slab tests per ray on the
//! open-plan floor, most of its cold bake's ray time. Here the boxes sit in a binary tree of
//! their bounds (median split along the longest side, at most [`LEAF_BOXES`] per leaf), and a
//! ray descends only into nodes whose bounds it crosses. Every test — node or box — is the same
//! f64 slab test on the same ray, and a node's bounds contain its boxes', so a ray that meets a
//! box meets every node above it: the answers are those of the box-by-box loop, exactly.

use glam::DVec3;

use crate::scene::Aabb;

/// Most boxes in a leaf: below this a linear loop costs no more than another level.
const LEAF_BOXES: usize = 2;

/// Ray–box slab test: true when the segment `o + t d`, t in (t0, t1), passes through the box's
/// interior (`inv_d` = 1/d per axis). A ray parallel to an axis and lying in the plane of a face
/// makes `0 · ∞ = NaN` on that axis; the vector `min`/`max` keep it or not depending on the face
/// and the direction's sign, and the scalar chain below drops it, so such a grazing ray counts on
/// that axis as crossing one face's plane and not the other's. A node's bounds answer the same way
/// for every box of positive extent inside them.
pub fn slab(b: &Aabb, o: DVec3, inv_d: DVec3, t0: f64, t1: f64) -> bool {
    let ta = (b.min - o) * inv_d;
    let tb = (b.max - o) * inv_d;
    let near = ta.min(tb);
    let far = ta.max(tb);
    let enter = near.x.max(near.y).max(near.z).max(t0);
    let exit = far.x.min(far.y).min(far.z).min(t1);
    enter < exit
}

/// A node: its bounds, and either two children or a run of boxes.
#[derive(Debug, Clone, Copy)]
struct BvhNode {
    bounds: Aabb,
    /// Leaf: the first box and the count (`count > 0`). Inner node: the first child (the second
    /// follows its subtree; its index is `second`) and `count == 0`.
    first: u32,
    second: u32,
    count: u32,
}

/// The boxes (world, m) in a BVH.
#[derive(Debug, Clone, Default)]
pub struct BoxBvh {
    /// The boxes, in leaf order.
    boxes: Vec<Aabb>,
    nodes: Vec<BvhNode>,
}

impl BoxBvh {
    /// The hierarchy over `boxes`, each with a positive extent on every axis (as a room file's
    /// boxes are): a box flat on an axis could be met by a grazing ray its node's bounds miss.
    pub fn new(boxes: &[Aabb]) -> Self {
        debug_assert!(
            boxes.iter().all(|b| b.min.cmplt(b.max).all()),
            "boxes with a positive extent on every axis"
        );
        let mut bvh = BoxBvh {
            boxes: boxes.to_vec(),
            nodes: Vec::with_capacity(2 * boxes.len()),
        };
        if !boxes.is_empty() {
            bvh.subtree(0, boxes.len());
        }
        bvh
    }

    /// The boxes, in the hierarchy's order.
    pub fn boxes(&self) -> &[Aabb] {
        &self.boxes
    }

    /// Builds the node over `boxes[start..end]` and its subtree; returns its index.
    fn subtree(&mut self, start: usize, end: usize) -> u32 {
        let bounds = self.boxes[start..end].iter().fold(
            Aabb {
                min: DVec3::INFINITY,
                max: DVec3::NEG_INFINITY,
            },
            |acc, b| Aabb {
                min: acc.min.min(b.min),
                max: acc.max.max(b.max),
            },
        );
        let index = self.nodes.len() as u32;
        self.nodes.push(BvhNode {
            bounds,
            first: start as u32,
            second: 0,
            count: (end - start) as u32,
        });
        if end - start <= LEAF_BOXES {
            return index;
        }
        // Median split of the box centres along the bounds' longest side.
        let extent = bounds.max - bounds.min;
        let axis = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        let centre = |b: &Aabb| b.min[axis] + b.max[axis];
        self.boxes[start..end].sort_by(|a, b| centre(a).total_cmp(&centre(b)));
        let mid = start + (end - start) / 2;
        let first = self.subtree(start, mid);
        let second = self.subtree(mid, end);
        self.nodes[index as usize] = BvhNode {
            bounds,
            first,
            second,
            count: 0,
        };
        index
    }

    /// True when a box meets the segment `o + t d`, t in (t0, t1) (`inv_d` = 1/d per axis): the
    /// same answer as [`slab`] on each box in turn.
    pub fn blocked(&self, o: DVec3, inv_d: DVec3, t0: f64, t1: f64) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        // Depth is about log2 of the boxes over LEAF_BOXES; 64 covers any scene.
        let mut stack = [0u32; 64];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let node = &self.nodes[stack[top] as usize];
            if !slab(&node.bounds, o, inv_d, t0, t1) {
                continue;
            }
            if node.count > 0 {
                let boxes = &self.boxes[node.first as usize..(node.first + node.count) as usize];
                if boxes.iter().any(|b| slab(b, o, inv_d, t0, t1)) {
                    return true;
                }
            } else {
                stack[top] = node.second;
                stack[top + 1] = node.first;
                top += 2;
            }
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator (xorshift) for random cases.
    fn next(state: &mut u64) -> f64 {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        (*state >> 11) as f64 / (1u64 << 53) as f64
    }

    #[test]
    fn answers_as_the_box_by_box_loop() {
        let mut s = 0x9e37_79b9_7f4a_7c15;
        // Desks on a floor, some touching, one sharing a face with another, plus shelves.
        let mut boxes = Vec::new();
        for i in 0..37 {
            let (x, y) = (8.0 * next(&mut s), 6.0 * next(&mut s));
            let z = if i % 5 == 0 { 1.0 + next(&mut s) } else { 0.0 };
            let size = DVec3::new(0.3 + next(&mut s), 0.3 + next(&mut s), 0.2 + 0.6 * next(&mut s));
            let min = DVec3::new(x, y, z);
            boxes.push(Aabb { min, max: min + size });
        }
        boxes.push(Aabb {
            min: boxes[0].max - DVec3::new(0.0, 0.5, 0.5),
            max: boxes[0].max + DVec3::new(0.7, 0.0, 0.0),
        });
        let bvh = BoxBvh::new(&boxes);
        assert_eq!(bvh.boxes().len(), boxes.len());
        let (mut hits, mut misses) = (0, 0);
        for k in 0..20_000 {
            let (from, to) = if k % 4 == 0 {
                // Along x in the plane of a box's faces (y on its side face, z on its top or
                // through its middle): the 0 · ∞ case of the slab test.
                let b = boxes[k % boxes.len()];
                let y = if k % 8 == 0 {
                    b.min.y
                } else {
                    0.5 * (b.min.y + b.max.y)
                };
                let z = if k % 12 == 0 {
                    0.5 * (b.min.z + b.max.z)
                } else {
                    b.max.z
                };
                (
                    DVec3::new(9.0 * next(&mut s), y, z),
                    DVec3::new(9.0 * next(&mut s), y, z),
                )
            } else {
                let mut point = || DVec3::new(9.0 * next(&mut s), 7.0 * next(&mut s), 3.0 * next(&mut s));
                (point(), point())
            };
            let inv_d = (to - from).recip();
            let brute = boxes.iter().any(|b| slab(b, from, inv_d, 1e-7, 1.0 - 1e-7));
            assert_eq!(bvh.blocked(from, inv_d, 1e-7, 1.0 - 1e-7), brute, "{from} → {to}");
            if brute {
                hits += 1;
            } else {
                misses += 1;
            }
        }
        // Both answers occur often enough for the comparison to mean something.
        assert!(hits > 2_000 && misses > 2_000, "{hits} hits, {misses} misses");
    }

    #[test]
    fn empty_and_single_box() {
        let inv_d = DVec3::new(1.0, 1.0, 1.0).recip();
        assert!(!BoxBvh::new(&[]).blocked(DVec3::ZERO, inv_d, 0.0, 1.0));
        let one = BoxBvh::new(&[Aabb {
            min: DVec3::splat(0.4),
            max: DVec3::splat(0.6),
        }]);
        assert!(one.blocked(DVec3::ZERO, inv_d, 0.0, 1.0));
        assert!(!one.blocked(DVec3::ZERO, inv_d, 0.0, 0.3));
    }
}
