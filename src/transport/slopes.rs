//! Linear radiosity within the leaves, for receivers right beside them (docs/DECISIONS.md
//! "Interreflection", "Linear radiosity in the near gather").
//!
//! The solve gives every leaf one radiosity. A receiver a few leaf sizes away cannot tell the
//! difference, but one beside a leaf can: in a concave corner the light does not reach (the floor
//! in front of a box face in the box's shadow), the radiosity of both surfaces falls about
//! linearly to zero at the contact edge, and a floor point 2 cm from the face sees mostly the
//! face's lowest centimetres, darker than the face's lowest leaf on average. The gather therefore
//! reconstructs a linear field on each leaf, `B(x) = B_i + g_i · (x − c_i)`, with `g_i` fitted to
//! the radiosity of the touching leaves of the same planar surface and limited so that the field
//! stays non-negative over the leaf. The mean over the leaf is `B_i` whatever `g_i`, so the
//! reconstruction moves light within a leaf and never adds or removes any.

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use crate::transport::formfactor::TargetPatch;
use crate::transport::hierarchy::{Tree, plane_axes};

/// Bounds closer than this (m) touch.
const TOUCH_M: f64 = 1e-6;

/// Per leaf, the other leaves of its plane's tree whose bounds touch its bounds (edge or
/// corner neighbours; a leaf alone in its plane, as on a curved mesh, has none), in compressed rows.
#[derive(Debug, Clone, Default)]
pub struct LeafNeighbours {
    start: Vec<u32>,
    ids: Vec<u32>,
}

impl LeafNeighbours {
    /// The neighbours of every leaf of `tree` (one query down the leaf's own root per leaf).
    pub fn new(tree: &Tree) -> Self {
        let n = tree.leaf_node.len();
        let rows: Vec<Vec<u32>> = (0..n)
            .into_par_iter()
            .map(|leaf| {
                let node = &tree.nodes[tree.leaf_node[leaf] as usize];
                let pad = DVec3::splat(TOUCH_M);
                let (lo, hi) = (node.lo - pad, node.hi + pad);
                let mut out = Vec::new();
                let mut stack = vec![tree.plane_root(tree.leaf_node[leaf])];
                while let Some(i) = stack.pop() {
                    let m = &tree.nodes[i as usize];
                    if m.lo.cmpgt(hi).any() || m.hi.cmplt(lo).any() {
                        continue;
                    }
                    if m.is_leaf() {
                        if m.leaf as usize != leaf {
                            out.push(m.leaf);
                        }
                    } else {
                        stack.extend(m.children);
                    }
                }
                out
            })
            .collect();
        let mut start = Vec::with_capacity(n + 1);
        let mut ids = Vec::with_capacity(rows.iter().map(Vec::len).sum());
        start.push(0);
        for row in rows {
            ids.extend(row);
            start.push(ids.len() as u32);
        }
        LeafNeighbours { start, ids }
    }

    /// The neighbours of `leaf`.
    pub fn of(&self, leaf: usize) -> &[u32] {
        &self.ids[self.start[leaf] as usize..self.start[leaf + 1] as usize]
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        (self.start.len() + self.ids.len()) * std::mem::size_of::<u32>()
    }
}

/// The leaves' radiosity made linear on each leaf (lm/m², linear RGB): per leaf and channel the
/// gradient `g` of `B(x) = B_i + g · (x − c_i)` (lm/m² per m, world frame, in the leaf's plane;
/// zero for a leaf without neighbours), and per tree node and channel its first moment
/// `∫ B(x) (x − c) dA` about its centroid `c` (lm, times m): `J_i g` on a leaf (`J_i` its second
/// moment of area), `Σ (M_child + A_child B̄_child (c_child − c))` above. A receiver gathering
/// from a node that is small for its distance adds the kernel's first-order change over it,
/// `∇K · M`, to `B̄ F`.
///
/// Both are kept in f32, and for one channel when the radiosity is grey (12 bytes per leaf and
/// node instead of 72: 4.8 MB on the open-plan floor's 133 k leaves), precise enough for what
/// is a correction to `B̄ F`.
#[derive(Debug, Clone)]
pub struct LinearRadiosity {
    /// Channels held: 1 when every leaf's radiosity is grey (the three would be equal), else 3.
    channels: usize,
    /// Per leaf, then channel.
    slopes: Vec<Vec3>,
    /// Per node, then channel.
    moments: Vec<Vec3>,
}

impl LinearRadiosity {
    /// The linear radiosity for the leaves' radiosity `radiosity` and the nodes' area-weighted
    /// means `node_b`. The slopes: inverse squared distance weighted least squares of
    /// `B_j − B_i ≈ g · (c_j − c_i)` over the neighbours `j` (along the directions they span),
    /// scaled down where `B_i + g · (x − c_i)` would turn negative at a corner of the leaf's
    /// bounds.
    pub fn new(
        tree: &Tree,
        targets: &[TargetPatch],
        neighbours: &LeafNeighbours,
        radiosity: &[[f64; 3]],
        node_b: &[[f64; 3]],
    ) -> Self {
        let grey = radiosity.iter().all(|b| b[0] == b[1] && b[1] == b[2]);
        let channels = if grey { 1 } else { 3 };
        let slopes: Vec<Vec3> = (0..tree.leaf_node.len())
            .into_par_iter()
            .flat_map_iter(|leaf| {
                let node = &tree.nodes[tree.leaf_node[leaf] as usize];
                let axes = plane_axes(node.normal);
                let centre = node.centroid;
                let reach = axes.map(|k| (centre[k] - node.lo[k]).max(node.hi[k] - centre[k]));
                let b = radiosity[leaf];
                (0..channels).map(move |ch| {
                    // (A neighbour whose centroid projects onto this one's, possible only
                    // in degenerate OBJ geometry, says nothing about the slope.)
                    let samples = neighbours.of(leaf).iter().filter_map(|&j| {
                        let other = &tree.nodes[tree.leaf_node[j as usize] as usize];
                        let d = other.centroid - centre;
                        let d2 = [d[axes[0]], d[axes[1]]];
                        let w = (d2[0] * d2[0] + d2[1] * d2[1]).recip();
                        w.is_finite().then(|| (w, d2, radiosity[j as usize][ch] - b[ch]))
                    });
                    let mut g = plane_gradient(samples);
                    let swing = g[0].abs() * reach[0] + g[1].abs() * reach[1];
                    let floor = b[ch].max(0.0);
                    if swing > floor {
                        g = if swing > 0.0 {
                            g.map(|x| x * floor / swing)
                        } else {
                            [0.0; 2]
                        };
                    }
                    let mut world = Vec3::ZERO;
                    world[axes[0]] = g[0] as f32;
                    world[axes[1]] = g[1] as f32;
                    world
                })
            })
            .collect();
        let mut moments = vec![Vec3::ZERO; tree.nodes.len() * channels];
        for (i, node) in tree.nodes.iter().enumerate().rev() {
            for ch in 0..channels {
                let m = if node.is_leaf() {
                    let g = slopes[node.leaf as usize * channels + ch].as_dvec3();
                    targets[node.leaf as usize].second_moment() * g
                } else {
                    node.children
                        .iter()
                        .map(|&c| {
                            let child = &tree.nodes[c as usize];
                            moments[c as usize * channels + ch].as_dvec3()
                                + (child.centroid - node.centroid) * (child.area * node_b[c as usize][ch])
                        })
                        .sum()
                };
                moments[i * channels + ch] = m.as_vec3();
            }
        }
        LinearRadiosity {
            channels,
            slopes,
            moments,
        }
    }

    /// The gradients of `leaf` per channel (lm/m² per m, world frame).
    pub fn slopes(&self, leaf: usize) -> [DVec3; 3] {
        self.per_channel(&self.slopes, leaf)
    }

    /// The first moments of node `node` per channel (lm·m, world frame).
    pub fn moments(&self, node: usize) -> [DVec3; 3] {
        self.per_channel(&self.moments, node)
    }

    fn per_channel(&self, values: &[Vec3], i: usize) -> [DVec3; 3] {
        let k = self.channels;
        std::array::from_fn(|ch| values[i * k + ch.min(k - 1)].as_dvec3())
    }
}

/// Weighted least-squares gradient `g` (per unit of the offsets) of `value ≈ g · offset` over
/// samples `(weight, offset, value)` with in-plane offsets: along both directions when the
/// offsets span the plane, along the one they span otherwise, zero when they span none.
pub fn plane_gradient(samples: impl IntoIterator<Item = (f64, [f64; 2], f64)>) -> [f64; 2] {
    let (mut m, mut rhs) = ([[0.0; 2]; 2], [0.0; 2]);
    for (w, d, v) in samples {
        for i in 0..2 {
            rhs[i] += w * d[i] * v;
            for j in 0..2 {
                m[i][j] += w * d[i] * d[j];
            }
        }
    }
    let scale = m[0][0] + m[1][1];
    if scale <= 0.0 {
        return [0.0; 2];
    }
    let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    if det.abs() > 1e-9 * scale * scale {
        let gu = (rhs[0] * m[1][1] - rhs[1] * m[0][1]) / det;
        let gv = (rhs[1] * m[0][0] - rhs[0] * m[1][0]) / det;
        return [gu, gv];
    }
    // Collinear offsets: the gradient along the line they span only.
    let (i, j) = if m[0][0] >= m[1][1] { (0, 1) } else { (1, 0) };
    let mut out = [0.0; 2];
    out[i] = rhs[i] / m[i][i];
    out[j] = 0.0;
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Scene, SurfaceKind};
    use crate::transport::hierarchy::NONE;

    /// A 4 × 3 × 2.5 m room in 0.5 m patches: 8 × 6 on the floor.
    fn room() -> Scene {
        let text = r#"version = 1
[room]
size = [4.0, 3.0, 2.5]
[room.reflectance]
floor = 0.2
walls = 0.5
ceiling = 0.7
[[light]]
name = "l"
position = [2.0, 1.5, 2.0]
lid = [[0, 100], [90, 0]]
[settings]
solver_patch_size = 0.5
"#;
        crate::scene::load::test_room(text)
    }

    /// The room's coarse mesh as leaves, with its tree, polygons and neighbours.
    struct Fixture {
        scene: Scene,
        tree: Tree,
        targets: Vec<TargetPatch>,
        neighbours: LeafNeighbours,
    }

    impl Fixture {
        fn new() -> Self {
            let scene = room();
            let mesh = &scene.coarse;
            let tree = Tree::build(mesh, &[]);
            let targets = mesh.patches.iter().map(|p| TargetPatch::new(mesh, p)).collect();
            let neighbours = LeafNeighbours::new(&tree);
            Fixture {
                scene,
                tree,
                targets,
                neighbours,
            }
        }

        fn leaves(&self) -> std::ops::Range<usize> {
            0..self.scene.coarse.patches.len()
        }

        fn is_floor(&self, i: usize) -> bool {
            let surface = self.scene.coarse.patches[i].surface as usize;
            self.scene.surfaces[surface].kind == SurfaceKind::Floor
        }

        /// Grey radiosity `floor(centroid)` on the floor, `other` elsewhere.
        fn radiosity(&self, floor: impl Fn(DVec3) -> f64, other: f64) -> Vec<[f64; 3]> {
            let patches = &self.scene.coarse.patches;
            self.leaves()
                .map(|i| {
                    [if self.is_floor(i) {
                        floor(patches[i].centroid)
                    } else {
                        other
                    }; 3]
                })
                .collect()
        }

        /// The linear radiosity of `radiosity`, with the nodes' area-weighted means.
        fn linear(&self, radiosity: &[[f64; 3]]) -> LinearRadiosity {
            let tree = &self.tree;
            let mut means = vec![[0.0; 3]; tree.nodes.len()];
            for (i, node) in tree.nodes.iter().enumerate().rev() {
                means[i] = if node.is_leaf() {
                    radiosity[node.leaf as usize]
                } else {
                    let [x, y] = node.children.map(|c| c as usize);
                    let (ax, ay) = (tree.nodes[x].area, tree.nodes[y].area);
                    std::array::from_fn(|ch| (ax * means[x][ch] + ay * means[y][ch]) / node.area)
                };
            }
            LinearRadiosity::new(tree, &self.targets, &self.neighbours, radiosity, &means)
        }
    }

    /// Floor leaves touch their 3 to 8 floor neighbours and nothing of another surface; a linear
    /// radiosity on the floor is fitted exactly on every leaf (the edge leaves too, each channel
    /// its own) and its first moment over the whole floor is `J g`, `J` the floor's second
    /// moment of area (4 × 3 m: `A a²/12`, `A b²/12`); a constant one has no slope.
    #[test]
    fn a_linear_radiosity_is_fitted_exactly_and_its_moments_add_up() {
        let f = Fixture::new();
        let mut counts: Vec<usize> = Vec::new();
        for i in f.leaves().filter(|&i| f.is_floor(i)) {
            assert!(f.neighbours.of(i).iter().all(|&j| f.is_floor(j as usize)));
            counts.push(f.neighbours.of(i).len());
        }
        assert_eq!(counts.len(), 48);
        assert_eq!(counts.iter().filter(|&&c| c == 3).count(), 4, "corners");
        assert_eq!(counts.iter().filter(|&&c| c == 8).count(), 6 * 4, "interior");
        let g = DVec3::new(3.0, 2.0, 0.0);
        let radiosity = f.radiosity(|c| 10.0 + g.dot(c), 5.0);
        let linear = f.linear(&radiosity);
        for i in f.leaves() {
            let want = if f.is_floor(i) { g } else { DVec3::ZERO };
            for slope in linear.slopes(i) {
                assert!(slope.distance(want) < 1e-6, "leaf {i}: {slope}");
            }
        }
        let coloured: Vec<[f64; 3]> = radiosity.iter().map(|b| [b[0], 2.0 * b[0], 5.0]).collect();
        let linear_rgb = f.linear(&coloured);
        for i in f.leaves().filter(|&i| f.is_floor(i)) {
            let [r, g2, b] = linear_rgb.slopes(i);
            assert!(
                r.distance(g) < 1e-6 && g2.distance(2.0 * g) < 1e-6 && b == DVec3::ZERO,
                "{i}"
            );
        }
        let first = f.leaves().find(|&i| f.is_floor(i)).unwrap();
        let mut root = f.tree.leaf_node[first] as usize;
        while f.tree.nodes[root].parent != NONE {
            root = f.tree.nodes[root].parent as usize;
        }
        let area = 12.0;
        let want = DVec3::new(area * 16.0 / 12.0 * g.x, area * 9.0 / 12.0 * g.y, 0.0);
        let got = linear.moments(root)[0];
        assert!(got.distance(want) < 1e-6 * want.length(), "{got} vs {want}");
    }

    /// A slope that would take the radiosity below zero inside the leaf is scaled until the
    /// leaf's lowest corner is at zero: `B = 3 (x − 0.1)` gives the leaves by the wall
    /// (`B` 0.45 at their centre, 0.25 m from their edge) 1.8 instead of 3.
    #[test]
    fn slopes_keep_the_radiosity_non_negative() {
        let f = Fixture::new();
        let linear = f.linear(&f.radiosity(|c| 3.0 * (c.x - 0.1), 1.0));
        for i in f.leaves().filter(|&i| f.is_floor(i)) {
            let x = f.scene.coarse.patches[i].centroid.x;
            let want = if x < 0.5 { 1.8 } else { 3.0 };
            let slope = linear.slopes(i)[0];
            assert!(
                (slope.x - want).abs() < 1e-6 && slope.y.abs() < 1e-6,
                "{x}: {slope}"
            );
        }
    }
}
