//! The hierarchical transfer operator (docs/DECISIONS.md "Interreflection"): a cluster tree over
//! the leaves (solver patches) of each planar surface, symmetric links between pairs of nodes at
//! the coarsest level where their transfer is accurate ([`crate::transport::links`]), and the
//! push–pull application of `F` to radiosity in O(nodes + links) (Hanrahan–Salzman–Aupperle 1991).
//!
//! A link couples nodes `R` and `S` with `G_RS = A_R F_RS = A_S F_SR` (m², symmetric, so
//! reciprocity holds link by link), and per side the in-plane gradient of the factor over the
//! receiving node. Applying `F` to leaf radiosity `x` (lm/m²): *pull* — a node's radiosity is the
//! area-weighted mean of its leaves'; *gather* — a node receives `Σ_links (G/A_R) B_S` and the
//! gradient `Σ_links ∇F B_S`; *push* — a child gets its parent's irradiance as a linear field
//! (value at the child's centroid, and the gradient), so a leaf at the edge of a large receiving
//! cluster does not get the cluster's mean (that error is first order in the cluster's size over
//! its distance; with the gradient it is second order). Diagonal scalings on both sides ([`Operator::balance`]) restore each leaf's row sum
//! (1 in a closed room: the furnace) and the area-weighted column sums (Sumpner's
//! `Σ A·H = Φ/(1−ρ)`).

use std::sync::OnceLock;

use glam::DVec3;
use rayon::prelude::*;

use crate::scene::PatchMesh;
use crate::transport::cache::{ValueSink, ValueSource};

/// Runs the transposed links of [`Operator::balance`] are split into (summed in order).
const TRANSPOSE_RUNS: usize = 16;

/// Marks a missing index (no parent, no children, not a leaf).
pub const NONE: u32 = u32::MAX;

/// Two patches lie in one plane when their normals agree to this (cosine from 1) and their
/// centroids' offsets along the normal to [`PLANE_OFFSET_M`]: the planar test room surfaces
/// pass.
const PLANE_NORMAL_TOLERANCE: f64 = 1e-12;
const PLANE_OFFSET_M: f64 = 1e-9;

/// `leaves` (patches of one surface) grouped by the plane they lie in, each group in the order
/// of `leaves`, the groups in the order of their first leaf. A patch is compared only with the
/// groups whose rounded plane (normal to 10⁻⁶, offset to 1 µm) is its own, so a plane split by
/// the rounding becomes two groups, never one group of two planes.
fn in_planes(mesh: &PatchMesh, leaves: &[u32]) -> Vec<Vec<u32>> {
    let mut groups: Vec<(DVec3, f64, Vec<u32>)> = Vec::new();
    let mut by_key: std::collections::HashMap<[i64; 4], Vec<usize>> = std::collections::HashMap::new();
    for &l in leaves {
        let patch = &mesh.patches[l as usize];
        let (n, offset) = (patch.normal, patch.normal.dot(patch.centroid));
        let key = [n.x * 1e6, n.y * 1e6, n.z * 1e6, offset * 1e6].map(|v| v.round() as i64);
        let candidates = by_key.entry(key).or_default();
        let found = candidates.iter().copied().find(|&g| {
            let (gn, go, _) = &groups[g];
            n.dot(*gn) > 1.0 - PLANE_NORMAL_TOLERANCE && (offset - go).abs() <= PLANE_OFFSET_M
        });
        match found {
            Some(g) => groups[g].2.push(l),
            None => {
                candidates.push(groups.len());
                groups.push((n, offset, vec![l]));
            }
        }
    }
    groups.into_iter().map(|(_, _, g)| g).collect()
}

/// The groups of one surface's `leaves` that get a tree each ([`Tree::build`]): all of them
/// when they share one normal (a room surface, a box face, a flat OBJ object), else one group
/// per plane they lie in ([`in_planes`]).
pub(crate) fn tree_groups(mesh: &PatchMesh, leaves: Vec<u32>) -> Vec<Vec<u32>> {
    let n0 = mesh.patches[leaves[0] as usize].normal;
    let planar = leaves
        .iter()
        .all(|&l| mesh.patches[l as usize].normal.dot(n0) > 1.0 - PLANE_NORMAL_TOLERANCE);
    if planar {
        vec![leaves]
    } else {
        in_planes(mesh, &leaves)
    }
}

/// A node of the cluster tree: one leaf, the union of its two children of one plane, or a
/// *volume cluster* (the children of one non-planar OBJ surface in different planes;
/// docs/DECISIONS.md "Volume clusters").
#[derive(Debug, Clone, PartialEq)]
pub struct Node {
    /// Surface of its leaves.
    pub surface: u32,
    /// The two children, or [`NONE`] for a leaf.
    pub children: [u32; 2],
    /// The parent, or [`NONE`] for a root.
    pub parent: u32,
    /// The leaf (patch index) when a leaf, else [`NONE`].
    pub leaf: u32,
    /// Number of leaves below (1 for a leaf).
    pub leaf_count: u32,
    /// Total area of its leaves (m²).
    pub area: f64,
    /// Area-weighted centroid (world, m).
    pub centroid: DVec3,
    /// Unit normal (world) of its leaves; of a volume cluster, the direction of its leaves'
    /// area-weighted normal sum (the normal its links are computed for).
    pub normal: DVec3,
    /// Bounds of its leaves' corners (world, m).
    pub lo: DVec3,
    pub hi: DVec3,
    /// Diagonal of the bounds (m).
    pub diameter: f64,
    /// The leaf below whose centroid is nearest the node's centroid (a point surely on it).
    pub representative: u32,
    /// True when its leaves tile its bounds exactly (an axis-aligned rectangle with no holes):
    /// its polygon is then the rectangle of its bounds.
    pub full_rect: bool,
    /// True when some leaf below lies next to a light (a possible hot spot): such a cluster is
    /// never linked or gathered as a whole.
    pub hot: bool,
    /// True for a volume cluster: its leaves lie in more than one plane.
    pub volume: bool,
    /// Upper bound (radians) of the angle between `normal` and any leaf normal below (0 unless
    /// `volume`; π when the normals cancel).
    pub cone: f64,
}

impl Node {
    /// A cluster of `surface` under `parent`, before [`Tree::join`] fills it in from its
    /// children.
    fn unjoined(surface: u32, parent: u32, normal: DVec3, volume: bool) -> Self {
        Node {
            surface,
            children: [NONE, NONE],
            parent,
            leaf: NONE,
            leaf_count: 0,
            area: 0.0,
            centroid: DVec3::ZERO,
            normal,
            lo: DVec3::ZERO,
            hi: DVec3::ZERO,
            diameter: 0.0,
            representative: NONE,
            full_rect: false,
            hot: false,
            volume,
            cone: 0.0,
        }
    }

    /// True for a leaf.
    pub fn is_leaf(&self) -> bool {
        self.leaf != NONE
    }

    /// True when the node may send the point `p` (unit normal `n`) light: some of it lies in
    /// front of `p`'s tangent plane, and a planar node faces `p`.
    pub fn seen_from(&self, p: DVec3, n: DVec3) -> bool {
        if !self.volume && self.normal.dot(p - self.centroid) <= 0.0 {
            return false;
        }
        let top = (0..3)
            .map(|k| (n[k] * self.lo[k]).max(n[k] * self.hi[k]))
            .sum::<f64>();
        top - n.dot(p) > 0.0
    }
}

/// The cluster trees of all surfaces. Nodes are stored in preorder (a parent before its
/// children), so pulls run backwards and pushes forwards.
#[derive(Debug, Clone, PartialEq)]
pub struct Tree {
    /// All nodes.
    pub nodes: Vec<Node>,
    /// The roots, one per surface (a volume cluster for a non-planar OBJ surface).
    pub roots: Vec<u32>,
    /// Per leaf (patch index), its node.
    pub leaf_node: Vec<u32>,
}

impl Tree {
    /// Builds the trees over the patches of `mesh`: per surface, recursive halving of the leaf
    /// centroids' bounding box along its longest side. Surfaces whose patches do not all share
    /// one normal (OBJ objects) get a planar tree per plane their patches lie in ([`in_planes`]):
    /// the faces of a table top, a shelf or a book are clusters like a wall's. Those trees are
    /// the leaves of a volume-cluster tree over the surface, halved the same way by their
    /// centroids, so a curved mesh — a patch alone in each plane — is one root, not a root per
    /// patch (docs/DECISIONS.md "Interreflection", "OBJ surfaces clustered by plane", "Volume
    /// clusters"). `hot` marks leaves no cluster holding which is linked as a whole (next to a
    /// light, or in a slot; may be empty: none).
    pub fn build(mesh: &PatchMesh, hot: &[bool]) -> Self {
        let n_surfaces = mesh
            .patches
            .iter()
            .map(|p| p.surface as usize + 1)
            .max()
            .unwrap_or(0);
        let mut by_surface: Vec<Vec<u32>> = vec![Vec::new(); n_surfaces];
        for (i, p) in mesh.patches.iter().enumerate() {
            by_surface[p.surface as usize].push(i as u32);
        }
        let mut tree = Tree {
            nodes: Vec::with_capacity(2 * mesh.patches.len()),
            roots: Vec::new(),
            leaf_node: vec![NONE; mesh.patches.len()],
        };
        for leaves in by_surface.into_iter().filter(|l| !l.is_empty()) {
            let mut groups: Vec<(DVec3, Vec<u32>)> = tree_groups(mesh, leaves)
                .into_iter()
                .map(|g| {
                    let (sum, area) = g.iter().fold((DVec3::ZERO, 0.0), |(s, a), &l| {
                        let p = &mesh.patches[l as usize];
                        (s + p.centroid * p.area, a + p.area)
                    });
                    let centroid = if area > 0.0 {
                        sum / area
                    } else {
                        mesh.patches[g[0] as usize].centroid
                    };
                    (centroid, g)
                })
                .collect();
            let root = tree.volume_subtree(mesh, hot, &mut groups, NONE);
            tree.roots.push(root);
        }
        tree
    }

    /// Appends the subtree over the plane `groups` (each with its centroid) of one surface and
    /// returns its root: the group's planar tree for one group, else a volume cluster over the
    /// two halves of the groups' centroids' bounding box along its longest side.
    fn volume_subtree(
        &mut self,
        mesh: &PatchMesh,
        hot: &[bool],
        groups: &mut [(DVec3, Vec<u32>)],
        parent: u32,
    ) -> u32 {
        if let [(_, leaves)] = groups {
            return self.subtree(mesh, hot, leaves, parent);
        }
        let split = halve(groups, |(c, _)| *c);
        let index = self.nodes.len() as u32;
        let surface = mesh.patches[groups[0].1[0] as usize].surface;
        self.nodes.push(Node::unjoined(surface, parent, DVec3::Z, true));
        let (left, right) = groups.split_at_mut(split);
        let a = self.volume_subtree(mesh, hot, left, index);
        let b = self.volume_subtree(mesh, hot, right, index);
        self.join(mesh, index, [a, b]);
        let (na, nb) = (&self.nodes[a as usize], &self.nodes[b as usize]);
        let sum = na.normal * na.area + nb.normal * nb.area;
        let normal = sum.try_normalize().unwrap_or(na.normal);
        let cone = [na, nb]
            .iter()
            .map(|c| c.normal.dot(normal).clamp(-1.0, 1.0).acos() + c.cone)
            .fold(0.0, f64::max)
            .min(std::f64::consts::PI);
        let node = &mut self.nodes[index as usize];
        node.normal = normal;
        node.cone = cone;
        index
    }

    /// Fills in node `index` as the union of its `children` (already built): leaf count, area,
    /// centroid, bounds, representative leaf, and whether it is hot.
    fn join(&mut self, mesh: &PatchMesh, index: u32, [a, b]: [u32; 2]) {
        let (na, nb) = (&self.nodes[a as usize], &self.nodes[b as usize]);
        let hot_children = na.hot || nb.hot;
        let leaf_count = na.leaf_count + nb.leaf_count;
        let area = na.area + nb.area;
        let centroid = (na.centroid * na.area + nb.centroid * nb.area) / area;
        let (lo, hi) = (na.lo.min(nb.lo), na.hi.max(nb.hi));
        let representative = [na.representative, nb.representative]
            .into_iter()
            .min_by(|x, y| {
                let dx = mesh.patches[*x as usize].centroid.distance_squared(centroid);
                let dy = mesh.patches[*y as usize].centroid.distance_squared(centroid);
                dx.total_cmp(&dy)
            })
            .unwrap_or(NONE);
        let node = &mut self.nodes[index as usize];
        node.children = [a, b];
        node.leaf_count = leaf_count;
        node.area = area;
        node.centroid = centroid;
        node.lo = lo;
        node.hi = hi;
        node.diameter = (hi - lo).length();
        node.representative = representative;
        node.hot = hot_children;
    }

    /// Appends the subtree over `leaves` (preorder) and returns its root.
    fn subtree(&mut self, mesh: &PatchMesh, hot: &[bool], leaves: &mut [u32], parent: u32) -> u32 {
        let index = self.nodes.len() as u32;
        if leaves.len() == 1 {
            let leaf = leaves[0];
            let patch = &mesh.patches[leaf as usize];
            let (lo, hi) = patch
                .vertex_ids()
                .iter()
                .map(|&v| mesh.positions[v as usize])
                .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), q| {
                    (lo.min(q), hi.max(q))
                });
            self.nodes.push(Node {
                surface: patch.surface,
                children: [NONE, NONE],
                parent,
                leaf,
                leaf_count: 1,
                area: patch.area,
                centroid: patch.centroid,
                normal: patch.normal,
                lo,
                hi,
                diameter: (hi - lo).length(),
                representative: leaf,
                full_rect: patch.n_vertices == 4
                    && (flat_area(lo, hi, patch.normal) - patch.area).abs() <= 1e-9 * patch.area,
                hot: hot.get(leaf as usize).copied().unwrap_or(false),
                volume: false,
                cone: 0.0,
            });
            self.leaf_node[leaf as usize] = index;
            return index;
        }
        let split = halve(leaves, |&l| mesh.patches[l as usize].centroid);
        let patch = &mesh.patches[leaves[0] as usize];
        self.nodes
            .push(Node::unjoined(patch.surface, parent, patch.normal, false));
        let (left, right) = leaves.split_at_mut(split);
        let a = self.subtree(mesh, hot, left, index);
        let b = self.subtree(mesh, hot, right, index);
        self.join(mesh, index, [a, b]);
        let node = &mut self.nodes[index as usize];
        node.full_rect = (flat_area(node.lo, node.hi, node.normal) - node.area).abs() <= 1e-9 * node.area;
        index
    }

    /// Number of leaves.
    pub fn n_leaves(&self) -> usize {
        self.leaf_node.len()
    }

    /// The root of the planar tree holding node `i`: its highest ancestor below any volume
    /// cluster.
    pub fn plane_root(&self, mut i: u32) -> u32 {
        loop {
            let p = self.nodes[i as usize].parent;
            if p == NONE || self.nodes[p as usize].volume {
                return i;
            }
            i = p;
        }
    }
}

/// Reorders `items` into two halves of their centroids' bounding box along its longest side
/// (by the median when one half would be empty) and returns where the second half starts.
fn halve<T>(items: &mut [T], centroid: impl Fn(&T) -> DVec3) -> usize {
    let (lo, hi) = items
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), item| {
            let c = centroid(item);
            (lo.min(c), hi.max(c))
        });
    let axis = (hi - lo).max_position();
    let mid = 0.5 * (lo[axis] + hi[axis]);
    let split = partition(items, |item| centroid(item)[axis] < mid);
    if split == 0 || split == items.len() {
        items.sort_by(|a, b| centroid(a)[axis].total_cmp(&centroid(b)[axis]));
        return items.len() / 2;
    }
    split
}

/// Area (m²) of the bounds `[lo, hi]` of an axis-aligned planar set with unit normal `normal`
/// (0 when the normal is not along an axis).
fn flat_area(lo: DVec3, hi: DVec3, normal: DVec3) -> f64 {
    let axis = normal.abs().max_position();
    if normal.abs()[axis] < 1.0 - 1e-12 {
        return 0.0;
    }
    let e = hi - lo;
    e[(axis + 1) % 3] * e[(axis + 2) % 3]
}

impl Node {
    /// The corners (world, m) of a [`Node::full_rect`] node's rectangle, in cyclic order.
    pub fn rect_corners(&self) -> [DVec3; 4] {
        let axis = self.normal.abs().max_position();
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        let corner = |a: f64, b: f64| {
            let mut p = self.lo;
            p[u] = a;
            p[v] = b;
            p
        };
        [
            corner(self.lo[u], self.lo[v]),
            corner(self.hi[u], self.lo[v]),
            corner(self.hi[u], self.hi[v]),
            corner(self.lo[u], self.hi[v]),
        ]
    }
}

/// Moves the elements satisfying `pred` to the front; returns how many there are.
fn partition<T>(items: &mut [T], pred: impl Fn(&T) -> bool) -> usize {
    let mut first = 0;
    for i in 0..items.len() {
        if pred(&items[i]) {
            items.swap(first, i);
            first += 1;
        }
    }
    first
}

/// A symmetric link between two nodes: `g = G_RS = A_R F_RS = A_S F_SR` (m²), and the in-plane
/// gradient (1/m, in the receiving node's plane coordinates, see [`plane_axes`]) of `F_{a←b}`
/// over `a` and of `F_{b←a}` over `b` (zero for a leaf).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Link {
    pub a: u32,
    pub b: u32,
    pub g: f32,
    pub grad_a: [f32; 2],
    pub grad_b: [f32; 2],
}

/// The two in-plane world axes of a node with this unit normal (the axis-aligned planes of rooms
/// and boxes; a tilted OBJ leaf gets the two axes of its largest normal component, unused since
/// leaves have no children).
pub fn plane_axes(normal: DVec3) -> [usize; 2] {
    let axis = normal.abs().max_position();
    [(axis + 1) % 3, (axis + 2) % 3]
}

/// The offsets (one more, from 0) of entries in runs of these `counts`.
fn offsets_of(counts: &[u32]) -> Vec<usize> {
    let mut offsets = Vec::with_capacity(counts.len() + 1);
    offsets.push(0usize);
    for &c in counts {
        offsets.push(offsets.last().expect("starts with 0") + c as usize);
    }
    offsets
}

/// Per node, where its entries' gradients start (a leaf's entries keep none), given the entries'
/// `offsets` by receiving node; one more element than nodes.
fn gradient_starts(tree: &Tree, offsets: &[usize]) -> Vec<usize> {
    let mut start = vec![0usize; tree.nodes.len() + 1];
    for (r, node) in tree.nodes.iter().enumerate() {
        let entries = if node.is_leaf() {
            0
        } else {
            offsets[r + 1] - offsets[r]
        };
        start[r + 1] = start[r] + entries;
    }
    start
}

/// Relative defect (of each leaf's area-weighted column sum) at which [`Operator::balance`]
/// stops: about the precision of the f32 coefficients it scales (6·10⁻⁸), so that balancing
/// further changes nothing they can hold. The rows are exact after every sweep. On the
/// open-plan floor 10⁻⁷ takes about half the sweeps of 10⁻⁹ (docs/DECISIONS.md
/// "Interreflection", "Memory and time of the open-plan floor").
pub const BALANCE_DEFECT: f64 = 1e-7;

/// Balancing also stops when its defect has not fallen below this fraction of what it was
/// [`BALANCE_STALL_SWEEPS`] sweeps before: the rows' targets and the columns' power then cannot
/// be met together (an OBJ room keeps each row's own sum, and those sums do not add up to the
/// area the columns conserve), and further sweeps change nothing (docs/DECISIONS.md "Balancing
/// stops when it stalls").
const BALANCE_STALL: f64 = 0.99;
const BALANCE_STALL_SWEEPS: usize = 5;

/// Columns a receiving node's gather sums at a time, in registers.
const GATHER_COLUMNS: usize = 4;

/// A receiving node's gather from the node radiosity `b` (node-major, `k` columns): per column
/// `c`, `value[c] = Σ_e f_e b[s_e][c]` over its links `(sources, coefficients)` and, with the
/// links' `gradients`, `grad[2c..2c + 2] = Σ_e ∇f_e b[s_e][c]`. The columns go in chunks of up to
/// [`GATHER_COLUMNS`] whose sums stay in registers across the links (each sum adds its terms in
/// the links' order, as one term at a time into `value` would). Without `gradients`, `grad` is
/// left as it is (zero in [`Operator::apply_block`]'s output). A single column goes through
/// [`gather_one`] instead.
fn gather(
    b: &[f64],
    k: usize,
    links: (&[u32], &[f32]),
    gradients: Option<&[[f32; 2]]>,
    value: &mut [f64],
    grad: &mut [f64],
) {
    if k == 1 {
        gather_one(b, links, gradients, value, grad);
        return;
    }
    let mut c0 = 0;
    while c0 < k {
        let w = (k - c0).min(GATHER_COLUMNS);
        match w {
            1 => gather_chunk::<1>(b, k, c0, links, gradients, value, grad),
            2 => gather_chunk::<2>(b, k, c0, links, gradients, value, grad),
            3 => gather_chunk::<3>(b, k, c0, links, gradients, value, grad),
            _ => gather_chunk::<GATHER_COLUMNS>(b, k, c0, links, gradients, value, grad),
        }
        c0 += w;
    }
}

/// Partial sums of a single column's gather ([`gather_one`]).
const GATHER_LANES: usize = 4;

/// [`gather`] of a single column (`k = 1`): link `e`'s term goes into partial sum
/// `e mod GATHER_LANES`, and the partial sums are added at the end. One sum makes every add wait
/// for the one before (docs/DECISIONS.md "A single column's gather in four sums": the product
/// alone about a third faster on the open-plan floor); the results differ from one sum, and
/// from the same column gathered in a block, in their last bits only.
fn gather_one(
    b: &[f64],
    (sources, coefficients): (&[u32], &[f32]),
    gradients: Option<&[[f32; 2]]>,
    value: &mut [f64],
    grad: &mut [f64],
) {
    const L: usize = GATHER_LANES;
    let whole = sources.len() - sources.len() % L;
    let (heads, tails) = (sources.split_at(whole), coefficients.split_at(whole));
    let mut sum = [0.0; L];
    match gradients {
        None => {
            for (s, f) in heads.0.chunks_exact(L).zip(tails.0.chunks_exact(L)) {
                for l in 0..L {
                    sum[l] += f64::from(f[l]) * b[s[l] as usize];
                }
            }
            for (l, (&s, &f)) in heads.1.iter().zip(tails.1).enumerate() {
                sum[l] += f64::from(f) * b[s as usize];
            }
        }
        Some(gradients) => {
            let (mut gu_sum, mut gv_sum) = ([0.0; L], [0.0; L]);
            let g = gradients.split_at(whole);
            let mut add = |l: usize, s: u32, f: f32, [gu, gv]: [f32; 2]| {
                let x = b[s as usize];
                sum[l] += f64::from(f) * x;
                gu_sum[l] += f64::from(gu) * x;
                gv_sum[l] += f64::from(gv) * x;
            };
            for ((s, f), g) in heads
                .0
                .chunks_exact(L)
                .zip(tails.0.chunks_exact(L))
                .zip(g.0.chunks_exact(L))
            {
                for l in 0..L {
                    add(l, s[l], f[l], g[l]);
                }
            }
            for (l, ((&s, &f), &g)) in heads.1.iter().zip(tails.1).zip(g.1).enumerate() {
                add(l, s, f, g);
            }
            grad[0] = gu_sum.iter().sum();
            grad[1] = gv_sum.iter().sum();
        }
    }
    value[0] = sum.iter().sum();
}

/// [`gather`] for the `W` columns from `c0`.
fn gather_chunk<const W: usize>(
    b: &[f64],
    k: usize,
    c0: usize,
    (sources, coefficients): (&[u32], &[f32]),
    gradients: Option<&[[f32; 2]]>,
    value: &mut [f64],
    grad: &mut [f64],
) {
    let mut sum = [0.0; W];
    let row = |s: u32| -> &[f64; W] {
        let start = s as usize * k + c0;
        b[start..start + W].try_into().expect("W columns")
    };
    match gradients {
        None => {
            for (&s, &f) in sources.iter().zip(coefficients) {
                let (f, x) = (f64::from(f), row(s));
                for c in 0..W {
                    sum[c] += f * x[c];
                }
            }
        }
        Some(gradients) => {
            let (mut gu_sum, mut gv_sum) = ([0.0; W], [0.0; W]);
            for ((&s, &f), g) in sources.iter().zip(coefficients).zip(gradients) {
                let (f, x) = (f64::from(f), row(s));
                let [gu, gv] = g.map(f64::from);
                for c in 0..W {
                    sum[c] += f * x[c];
                    gu_sum[c] += gu * x[c];
                    gv_sum[c] += gv * x[c];
                }
            }
            for c in 0..W {
                grad[2 * (c0 + c)] = gu_sum[c];
                grad[2 * (c0 + c) + 1] = gv_sum[c];
            }
        }
    }
    value[c0..c0 + W].copy_from_slice(&sum);
}

/// What [`Operator::balance`] found and reached.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Balance {
    /// Largest relative defect of the unbalanced rows against their target.
    pub row_defect: f64,
    /// Largest relative defect of the unbalanced area-weighted column sums.
    pub column_defect: f64,
    /// Sweeps made.
    pub sweeps: usize,
    /// Largest relative column defect left (below [`BALANCE_DEFECT`] unless it stalled).
    pub defect: f64,
}

/// A volume cluster's linear correction towards the node at `d` (world, from the cluster):
/// `u/(n̄·u)` with `u = d/|d|` (zero for a planar node). The links only join a volume cluster
/// to nodes well in front of all its leaves ([`crate::transport::links`]), so `n̄·u` is far from
/// zero; it is kept from below at [`MIN_FACING`] all the same.
fn facing_weight(node: &Node, d: DVec3) -> [f32; 3] {
    if !node.volume {
        return [0.0; 3];
    }
    let u = d.normalize_or_zero();
    let w = u / node.normal.dot(u).max(MIN_FACING);
    [w.x as f32, w.y as f32, w.z as f32]
}

/// The smallest cosine between a volume cluster's normal and the direction of a node linked
/// with it.
pub const MIN_FACING: f64 = 0.1;

/// The entries of the links with a volume cluster at either end (docs/DECISIONS.md "Volume
/// clusters"), by receiving node like the others. A volume cluster's leaves of unit normals `n`
/// receive from the direction `u` (unit, towards a far source) `E(n) = E(n̄)·(n·u)/(n̄·u)`,
/// linear in `n`: the link's irradiance at the cluster's normal `n̄` plus `W·(n − n̄)`, `W =
/// E(n̄)·u/(n̄·u)`, is what each leaf facing the source gets. Likewise a volume cluster sends
/// `B̄ + P·u/(n̄·u)` towards `u`, `B̄` its mean radiosity and `P = Σ A_l B_l (n_l − n̄) / A` its
/// normal moment.
#[derive(Debug, Clone)]
struct VolumeEntries {
    /// Entries `offsets[r]..offsets[r + 1]` are those of receiving node `r`.
    offsets: Vec<usize>,
    sources: Vec<u32>,
    /// `G/A_r`.
    coefficients: Vec<f32>,
    /// The in-plane gradient over a planar cluster receiving (zero otherwise).
    gradients: Vec<[f32; 2]>,
    /// `u/(n̄·u)` of a volume receiver towards its source (zero for a planar receiver).
    to_source: Vec<[f32; 3]>,
    /// `u/(n̄·u)` of a volume source towards its receiver (zero for a planar source).
    to_receiver: Vec<[f32; 3]>,
    /// Per node whose parent is a volume cluster, its normal less the parent's (zero
    /// otherwise: the leaves below a planar node share its normal).
    normal_offsets: Vec<DVec3>,
}

impl VolumeEntries {
    /// Zeroed entries for these offsets by receiving node.
    fn with_offsets(offsets: Vec<usize>) -> Self {
        let n = *offsets.last().expect("one more offset than nodes");
        VolumeEntries {
            offsets,
            sources: vec![0; n],
            coefficients: vec![0.0; n],
            gradients: vec![[0.0; 2]; n],
            to_source: vec![[0.0; 3]; n],
            to_receiver: vec![[0.0; 3]; n],
            normal_offsets: Vec::new(),
        }
    }

    /// Bytes held.
    fn bytes(&self) -> usize {
        self.offsets.len() * 8 + self.sources.len() * (4 + 4 + 8 + 12 + 12) + self.normal_offsets.len() * 24
    }

    /// Adds receiving node `r`'s volume entries to its gather from the node radiosity `b` and
    /// normal moments `moment` (`k` columns; 3 per column) into `out`: `k` values, the in-plane
    /// gradient (2 per column), then the normal gradient (3 per column).
    fn gather(&self, r: usize, b: &[f64], moment: &[f64], k: usize, out: &mut [f64]) {
        let (value, rest) = out.split_at_mut(k);
        let (grad, w) = rest.split_at_mut(2 * k);
        for e in self.offsets[r]..self.offsets[r + 1] {
            let s = self.sources[e] as usize;
            let (f, [gu, gv]) = (f64::from(self.coefficients[e]), self.gradients[e].map(f64::from));
            let to_receiver = self.to_receiver[e].map(f64::from);
            let to_source = self.to_source[e].map(f64::from);
            for c in 0..k {
                let m = &moment[(s * k + c) * 3..(s * k + c) * 3 + 3];
                let x = b[s * k + c] + m[0] * to_receiver[0] + m[1] * to_receiver[1] + m[2] * to_receiver[2];
                value[c] += f * x;
                grad[2 * c] += gu * x;
                grad[2 * c + 1] += gv * x;
                for j in 0..3 {
                    w[3 * c + j] += f * x * to_source[j];
                }
            }
        }
    }
}

/// The hierarchical form-factor operator `F` on the leaves.
#[derive(Debug, Clone)]
pub struct Operator {
    /// The cluster trees.
    pub tree: Tree,
    /// Directed transfers by receiving node: entries `offsets[r]..offsets[r + 1]` hold the
    /// source nodes and `G/A_r`.
    offsets: Vec<usize>,
    sources: Vec<u32>,
    coefficients: Vec<f32>,
    /// Per entry of a receiving cluster, the in-plane gradient of the coefficient over it (1/m):
    /// entry `e` of cluster `r` at `gradients[gradient_start[r] + e − offsets[r]]`. A leaf has no
    /// children to push a gradient to, so its entries (most of a large room's) keep none.
    gradient_start: Vec<usize>,
    gradients: Vec<[f32; 2]>,
    /// Per node, its centroid's in-plane offset from its parent's centroid (m).
    offsets_to_parent: Vec<[f64; 2]>,
    /// The entries with a volume cluster at either end, when the tree has volume clusters.
    volume: Option<VolumeEntries>,
    /// Number of symmetric links.
    n_links: usize,
    /// Per leaf: the row scaling (applied to what it receives) and the column scaling (applied
    /// to what it sends) of [`Self::balance`]; 1 before balancing.
    row_scale: Vec<f64>,
    col_scale: Vec<f64>,
    /// `Σ_j F_ij` per leaf with the scalings as they are, formed at the first call (every solve
    /// bounds its error with them) and forgotten when the scalings change.
    row_sums: OnceLock<Vec<f64>>,
}

impl Operator {
    /// The operator of `tree` with these links (in runs).
    pub fn new(tree: Tree, runs: &[Vec<Link>]) -> Self {
        let links = || runs.iter().flatten();
        let n_nodes = tree.nodes.len();
        let has_volume = tree.nodes.iter().any(|n| n.volume);
        let involves_volume =
            |l: &Link| has_volume && (tree.nodes[l.a as usize].volume || tree.nodes[l.b as usize].volume);
        let mut counts = vec![0usize; n_nodes + 1];
        let mut volume_counts = vec![0usize; n_nodes + 1];
        for l in links() {
            let counts = if involves_volume(l) {
                &mut volume_counts
            } else {
                &mut counts
            };
            counts[l.a as usize + 1] += 1;
            counts[l.b as usize + 1] += 1;
        }
        for i in 0..n_nodes {
            counts[i + 1] += counts[i];
            volume_counts[i + 1] += volume_counts[i];
        }
        let offsets = counts.clone();
        let gradient_start = gradient_starts(&tree, &offsets);
        let mut fill = counts;
        let mut sources = vec![0u32; offsets[n_nodes]];
        let mut coefficients = vec![0f32; offsets[n_nodes]];
        let mut gradients = vec![[0f32; 2]; gradient_start[n_nodes]];
        let mut volume = has_volume.then(|| VolumeEntries::with_offsets(volume_counts.clone()));
        let mut volume_fill = volume_counts;
        for l in links() {
            for (r, s, grad) in [(l.a, l.b, l.grad_a), (l.b, l.a, l.grad_b)] {
                let (ru, su) = (r as usize, s as usize);
                let coefficient = (f64::from(l.g) / tree.nodes[ru].area) as f32;
                if involves_volume(l) {
                    let v = volume.as_mut().expect("made when the tree has volume clusters");
                    let slot = volume_fill[ru];
                    volume_fill[ru] += 1;
                    let (nr, ns) = (&tree.nodes[ru], &tree.nodes[su]);
                    v.sources[slot] = s;
                    v.coefficients[slot] = coefficient;
                    v.gradients[slot] = if nr.volume || nr.is_leaf() { [0.0; 2] } else { grad };
                    v.to_source[slot] = facing_weight(nr, ns.centroid - nr.centroid);
                    v.to_receiver[slot] = facing_weight(ns, nr.centroid - ns.centroid);
                } else {
                    let slot = fill[ru];
                    fill[ru] += 1;
                    sources[slot] = s;
                    coefficients[slot] = coefficient;
                    if !tree.nodes[ru].is_leaf() {
                        gradients[gradient_start[ru] + slot - offsets[ru]] = grad;
                    }
                }
            }
        }
        let n = tree.n_leaves();
        Self::from_entries(
            tree,
            offsets,
            sources,
            coefficients,
            gradients,
            volume,
            [vec![1.0; n], vec![1.0; n]],
        )
    }

    /// The operator of `tree` from its entries by receiving node and its balancing's scalings
    /// `[row, col]`.
    fn from_entries(
        tree: Tree,
        offsets: Vec<usize>,
        sources: Vec<u32>,
        coefficients: Vec<f32>,
        gradients: Vec<[f32; 2]>,
        mut volume: Option<VolumeEntries>,
        [row_scale, col_scale]: [Vec<f64>; 2],
    ) -> Self {
        let gradient_start = gradient_starts(&tree, &offsets);
        let offsets_to_parent = tree
            .nodes
            .iter()
            .map(|node| {
                if node.parent == NONE {
                    return [0.0; 2];
                }
                let d = node.centroid - tree.nodes[node.parent as usize].centroid;
                let [u, v] = plane_axes(node.normal);
                [d[u], d[v]]
            })
            .collect();
        if let Some(v) = volume.as_mut() {
            v.normal_offsets = tree
                .nodes
                .iter()
                .map(|node| match node.parent {
                    NONE => DVec3::ZERO,
                    p if tree.nodes[p as usize].volume => node.normal - tree.nodes[p as usize].normal,
                    _ => DVec3::ZERO,
                })
                .collect();
        }
        let n_links = (sources.len() + volume.as_ref().map_or(0, |v| v.sources.len())) / 2;
        Operator {
            tree,
            offsets,
            n_links,
            sources,
            coefficients,
            gradient_start,
            gradients,
            offsets_to_parent,
            volume,
            row_scale,
            col_scale,
            row_sums: OnceLock::new(),
        }
    }

    /// Writes its entries and balancing scalings (not the tree, which is built again from the
    /// leaves) into a cache entry (docs/DECISIONS.md "Bake cache").
    pub fn write_to(&self, w: &mut impl ValueSink) {
        let counts: Vec<u32> = self.offsets.windows(2).map(|o| (o[1] - o[0]) as u32).collect();
        w.u32s(&counts);
        w.u32s(&self.sources);
        w.f32s(&self.coefficients);
        w.f32s(self.gradients.as_flattened());
        w.f64s(&self.row_scale);
        w.f64s(&self.col_scale);
        // The volume entries (none: an empty count list).
        let v = self.volume.as_ref();
        let counts: Vec<u32> = v.map_or(Vec::new(), |v| {
            v.offsets.windows(2).map(|o| (o[1] - o[0]) as u32).collect()
        });
        w.u32s(&counts);
        w.u32s(v.map_or(&[], |v| &v.sources));
        w.f32s(v.map_or(&[], |v| &v.coefficients));
        w.f32s(v.map_or(&[], |v| v.gradients.as_flattened()));
        w.f32s(v.map_or(&[], |v| v.to_source.as_flattened()));
        w.f32s(v.map_or(&[], |v| v.to_receiver.as_flattened()));
    }

    /// The operator [`Self::write_to`] wrote for this `tree`, or `None` when what is read does
    /// not fit the tree (its node and leaf counts, source nodes that exist, finite values):
    /// a damaged or foreign entry is never applied.
    pub fn read_from(tree: Tree, r: &mut impl ValueSource) -> Option<Self> {
        let n_nodes = tree.nodes.len();
        let counts = r.u32s()?;
        let sources = r.u32s()?;
        let coefficients = r.f32s()?;
        let gradients = r.f32s()?;
        let scales = [r.f64s()?, r.f64s()?];
        let offsets = offsets_of(&counts);
        let volume_counts = r.u32s()?;
        let volume = [r.u32s()?];
        let volume_values = [r.f32s()?, r.f32s()?, r.f32s()?, r.f32s()?];
        let has_volume = tree.nodes.iter().any(|n| n.volume);
        let volume_offsets = offsets_of(&volume_counts);
        let [volume_sources] = volume;
        let [volume_coefficients, volume_gradients, to_source, to_receiver] = volume_values;
        let m = volume_sources.len();
        let fits = counts.len() == n_nodes
            && offsets[n_nodes] == sources.len()
            && sources.len() == coefficients.len()
            && sources.iter().all(|&s| (s as usize) < n_nodes)
            && gradients.len() == 2 * gradient_starts(&tree, &offsets)[n_nodes]
            && scales.iter().all(|s| s.len() == tree.n_leaves())
            && volume_counts.len() == if has_volume { n_nodes } else { 0 }
            && volume_offsets.last() == Some(&m)
            && (sources.len() + m) % 2 == 0
            && volume_sources.iter().all(|&s| (s as usize) < n_nodes)
            && volume_coefficients.len() == m
            && volume_gradients.len() == 2 * m
            && to_source.len() == 3 * m
            && to_receiver.len() == 3 * m
            && coefficients
                .iter()
                .chain(&gradients)
                .chain(&volume_coefficients)
                .chain(&volume_gradients)
                .chain(&to_source)
                .chain(&to_receiver)
                .all(|x| x.is_finite())
            && scales.iter().flatten().all(|x| x.is_finite());
        fits.then(|| {
            let gradients = gradients.chunks_exact(2).map(|g| [g[0], g[1]]).collect();
            let volume = has_volume.then(|| VolumeEntries {
                offsets: volume_offsets,
                sources: volume_sources,
                coefficients: volume_coefficients,
                gradients: volume_gradients.chunks_exact(2).map(|g| [g[0], g[1]]).collect(),
                to_source: to_source.chunks_exact(3).map(|g| [g[0], g[1], g[2]]).collect(),
                to_receiver: to_receiver.chunks_exact(3).map(|g| [g[0], g[1], g[2]]).collect(),
                normal_offsets: Vec::new(),
            });
            Self::from_entries(tree, offsets, sources, coefficients, gradients, volume, scales)
        })
    }

    /// Number of leaves.
    pub fn n_leaves(&self) -> usize {
        self.tree.n_leaves()
    }

    /// Number of symmetric links.
    pub fn n_links(&self) -> usize {
        self.n_links
    }

    /// Bytes held by the links and the tree.
    pub fn bytes(&self) -> usize {
        self.sources.len() * 4
            + self.coefficients.len() * 4
            + self.gradients.len() * 8
            + self.offsets_to_parent.len() * 16
            + (self.offsets.len() + self.gradient_start.len()) * 8
            + self.tree.nodes.len() * std::mem::size_of::<Node>()
            + (self.row_scale.len() + self.col_scale.len() + self.row_sums.get().map_or(0, Vec::len)) * 8
            + self.volume.as_ref().map_or(0, VolumeEntries::bytes)
    }

    /// `F·X` for a leaf-major block `X` of `width` columns (lx per unit radiosity): pull, gather,
    /// push, with the balancing scalings.
    pub fn apply_block(&self, block: &[f64], width: usize) -> Vec<f64> {
        self.apply_scaled(block, width, true)
    }

    fn apply_scaled(&self, block: &[f64], width: usize, scaled: bool) -> Vec<f64> {
        let k = width;
        let n = self.n_leaves();
        let mut out = vec![0.0; n * k];
        if k == 0 || n == 0 {
            return out;
        }
        let nodes = &self.tree.nodes;
        let mut b = vec![0.0; nodes.len() * k];
        for (leaf, &node) in self.tree.leaf_node.iter().enumerate() {
            let s = if scaled { self.col_scale[leaf] } else { 1.0 };
            for c in 0..k {
                b[node as usize * k + c] = s * block[leaf * k + c];
            }
        }
        for (i, node) in nodes.iter().enumerate().rev() {
            if node.is_leaf() {
                continue;
            }
            let [c0, c1] = node.children.map(|c| c as usize);
            let (w0, w1) = (nodes[c0].area / node.area, nodes[c1].area / node.area);
            for c in 0..k {
                b[i * k + c] = w0 * b[c0 * k + c] + w1 * b[c1 * k + c];
            }
        }
        // The volume clusters' normal moments (3 per column), pulled like the radiosity.
        let moment = match &self.volume {
            Some(v) => {
                let mut m = vec![0.0; nodes.len() * k * 3];
                for (i, node) in nodes.iter().enumerate().rev() {
                    if !node.volume {
                        continue;
                    }
                    for child in node.children.map(|c| c as usize) {
                        let w = nodes[child].area / node.area;
                        let d = v.normal_offsets[child];
                        for c in 0..k {
                            let x = b[child * k + c];
                            for j in 0..3 {
                                m[(i * k + c) * 3 + j] += w * (m[(child * k + c) * 3 + j] + x * d[j]);
                            }
                        }
                    }
                }
                m
            }
            None => Vec::new(),
        };
        // Per node: k values, 2k gradient components (u, v per column), and with volume
        // clusters 3k components of the normal gradient.
        let normal_parts = if self.volume.is_some() { 3 * k } else { 0 };
        let stride = 3 * k + normal_parts;
        let mut h = vec![0.0; nodes.len() * stride];
        h.par_chunks_mut(stride)
            .enumerate()
            .with_min_len(512)
            .for_each(|(r, out)| {
                let (value, grad) = out[..3 * k].split_at_mut(k);
                let entries = self.offsets[r]..self.offsets[r + 1];
                let links = (&self.sources[entries.clone()], &self.coefficients[entries]);
                if nodes[r].is_leaf() {
                    gather(&b, k, links, None, value, grad);
                } else {
                    let gradients = &self.gradients[self.gradient_start[r]..self.gradient_start[r + 1]];
                    gather(&b, k, links, Some(gradients), value, grad);
                }
                if let Some(v) = &self.volume {
                    v.gather(r, &b, &moment, k, out);
                }
            });
        // Push: a child gets its parent's linear field at its centroid, and the gradient; below
        // a volume cluster, also the normal gradient times its normal's offset.
        for i in 0..nodes.len() {
            let p = nodes[i].parent;
            if p == NONE {
                continue;
            }
            let [du, dv] = self.offsets_to_parent[i];
            let (parent, child) = (p as usize * stride, i * stride);
            for c in 0..k {
                let (gu, gv) = (h[parent + k + 2 * c], h[parent + k + 2 * c + 1]);
                h[child + c] += h[parent + c] + gu * du + gv * dv;
                h[child + k + 2 * c] += gu;
                h[child + k + 2 * c + 1] += gv;
            }
            if let Some(v) = &self.volume {
                let d = v.normal_offsets[i];
                for c in 0..k {
                    let (wp, wc) = (parent + 3 * k + 3 * c, child + 3 * k + 3 * c);
                    let w = [h[wp], h[wp + 1], h[wp + 2]];
                    h[child + c] += w[0] * d.x + w[1] * d.y + w[2] * d.z;
                    for j in 0..3 {
                        h[wc + j] += w[j];
                    }
                }
            }
        }
        for (leaf, &node) in self.tree.leaf_node.iter().enumerate() {
            let s = if scaled { self.row_scale[leaf] } else { 1.0 };
            for c in 0..k {
                out[leaf * k + c] = s * h[node as usize * stride + c];
            }
        }
        out
    }

    /// `Σ_j F_ij` per leaf (after balancing).
    pub fn row_sums(&self) -> Vec<f64> {
        self.row_sums
            .get_or_init(|| self.apply_block(&vec![1.0; self.n_leaves()], 1))
            .clone()
    }

    /// Alternating diagonal scalings (Sinkhorn) until, to [`BALANCE_DEFECT`], each leaf's row sums to
    /// `target` (or, with `None`, to its unbalanced sum) and every column conserves power:
    /// `Σ_i A_i F_ij = A_j` (the column sums come from the transposed operator, since the
    /// gradient terms make it unsymmetric), or until it stalls ([`BALANCE_STALL`]).
    pub fn balance(&mut self, target: Option<f64>) -> Balance {
        let n = self.n_leaves();
        let areas = self.leaf_areas();
        let ones = vec![1.0; n];
        let raw = |v: &[f64]| self.apply_scaled(v, 1, false);
        // Σ_i A_i v_i F_ij / A_j: the area-weighted column sums with row weights v.
        let raw_columns = |v: &[f64]| {
            let weighted: Vec<f64> = v.iter().zip(&areas).map(|(x, a)| x * a).collect();
            let t = self.apply_transpose_raw(&weighted);
            t.iter().zip(&areas).map(|(x, a)| x / a).collect::<Vec<f64>>()
        };
        let raw_rows = raw(&ones);
        let targets: Vec<f64> = match target {
            Some(t) => vec![t; n],
            None => raw_rows.clone(),
        };
        let row_defect = raw_rows
            .iter()
            .zip(&targets)
            .map(|(r, t)| (r - t).abs() / t.max(1e-300))
            .fold(0.0, f64::max);
        // The area-weighted column sums for the current row scaling (none yet): computed once
        // per iteration below, for the check and then for the next column scaling.
        let mut cd = raw_columns(&ones);
        let column_defect = cd.iter().map(|c| (c - 1.0).abs()).fold(0.0, f64::max);
        let mut row = vec![1.0; n];
        let mut col = vec![1.0; n];
        let mut defects: Vec<f64> = Vec::new();
        for _ in 0..200 {
            for j in 0..n {
                col[j] = if cd[j] > 0.0 { 1.0 / cd[j] } else { 1.0 };
            }
            let rd = raw(&col);
            for i in 0..n {
                row[i] = if rd[i] > 0.0 { targets[i] / rd[i] } else { 1.0 };
            }
            // Rows now hit their targets exactly; check the columns.
            cd = raw_columns(&row);
            let worst = (0..n)
                .filter(|&j| cd[j] > 0.0)
                .map(|j| (col[j] * cd[j] - 1.0).abs())
                .fold(0.0, f64::max);
            let stalled = defects
                .len()
                .checked_sub(BALANCE_STALL_SWEEPS)
                .is_some_and(|i| worst > BALANCE_STALL * defects[i]);
            defects.push(worst);
            if worst < BALANCE_DEFECT || stalled {
                break;
            }
        }
        self.row_scale = row;
        self.col_scale = col;
        self.row_sums = OnceLock::new();
        Balance {
            row_defect,
            column_defect,
            sweeps: defects.len(),
            defect: defects.last().copied().unwrap_or(0.0),
        }
    }

    /// `Fᵀ y` of the unscaled operator (one column): the transposed push (a node collects its
    /// leaves' values and their first moment about its centroid), the transposed links, the
    /// transposed pull (a leaf gets its share `A_leaf/A_node` of each ancestor's value).
    fn apply_transpose_raw(&self, y: &[f64]) -> Vec<f64> {
        let nodes = &self.tree.nodes;
        let volume = self.volume.as_ref();
        // Transposed push: per node the sum of its leaves' y, the in-plane moments
        // Σ y (c_leaf − c_node) and (with volume clusters) the normal moments
        // Σ y (n_leaf − n_node), accumulated bottom-up.
        let mut sum = vec![0.0; nodes.len()];
        let mut moment = vec![[0.0; 2]; nodes.len()];
        let mut normal_moment = vec![DVec3::ZERO; if volume.is_some() { nodes.len() } else { 0 }];
        for (leaf, &node) in self.tree.leaf_node.iter().enumerate() {
            sum[node as usize] = y[leaf];
        }
        for i in (0..nodes.len()).rev() {
            let p = nodes[i].parent;
            if p == NONE {
                continue;
            }
            let [du, dv] = self.offsets_to_parent[i];
            let (s_i, m_i) = (sum[i], moment[i]);
            let p = p as usize;
            sum[p] += s_i;
            moment[p][0] += m_i[0] + s_i * du;
            moment[p][1] += m_i[1] + s_i * dv;
            if let Some(v) = volume {
                let m = normal_moment[i] + s_i * v.normal_offsets[i];
                normal_moment[p] += m;
            }
        }
        // Transposed links: entry (r ← s) sends back coefficient × Σ_r y + gradient · moment_r
        // (and for a volume entry the normal terms). The links are stored by receiver, so the
        // sources are scattered: a few contiguous runs of receivers each scatter into their own
        // vectors, summed afterwards in order (a fixed number of runs, so that the sums do not
        // depend on the machine's thread count).
        let per_run = nodes.len().div_ceil(TRANSPOSE_RUNS).max(1);
        let runs: Vec<(Vec<f64>, Vec<DVec3>)> = (0..nodes.len().div_ceil(per_run))
            .into_par_iter()
            .map(|run| {
                let mut back = vec![0.0; nodes.len()];
                let mut back_moment = vec![DVec3::ZERO; normal_moment.len()];
                for r in run * per_run..((run + 1) * per_run).min(nodes.len()) {
                    let entries = self.offsets[r]..self.offsets[r + 1];
                    if nodes[r].is_leaf() {
                        // A leaf's moment about itself is zero.
                        for e in entries {
                            back[self.sources[e] as usize] += f64::from(self.coefficients[e]) * sum[r];
                        }
                    } else {
                        let gradients = &self.gradients[self.gradient_start[r]..self.gradient_start[r + 1]];
                        for (e, g) in entries.zip(gradients) {
                            let [gu, gv] = g.map(f64::from);
                            back[self.sources[e] as usize] += f64::from(self.coefficients[e]) * sum[r]
                                + gu * moment[r][0]
                                + gv * moment[r][1];
                        }
                    }
                    let Some(v) = volume else { continue };
                    for e in v.offsets[r]..v.offsets[r + 1] {
                        let f = f64::from(v.coefficients[e]);
                        let [gu, gv] = v.gradients[e].map(f64::from);
                        let to_source = DVec3::from_array(v.to_source[e].map(f64::from));
                        let to_receiver = DVec3::from_array(v.to_receiver[e].map(f64::from));
                        let t = f * sum[r]
                            + gu * moment[r][0]
                            + gv * moment[r][1]
                            + f * to_source.dot(normal_moment[r]);
                        let s = v.sources[e] as usize;
                        back[s] += t;
                        back_moment[s] += t * to_receiver;
                    }
                }
                (back, back_moment)
            })
            .collect();
        let mut back = vec![0.0; nodes.len()];
        let mut back_moment = vec![DVec3::ZERO; normal_moment.len()];
        for (run, run_moment) in runs {
            back.iter_mut().zip(run).for_each(|(b, x)| *b += x);
            back_moment.iter_mut().zip(run_moment).for_each(|(b, x)| *b += x);
        }
        // Transposed pull: top-down, each node passes its value to its children by area share
        // (a volume cluster also its normal moment's share, through each child's normal offset).
        for i in 0..nodes.len() {
            let p = nodes[i].parent;
            if p == NONE {
                continue;
            }
            let (p, share) = (p as usize, nodes[i].area / nodes[p as usize].area);
            back[i] += back[p] * share;
            if let Some(v) = volume.filter(|_| nodes[p].volume) {
                let from_parent = share * back_moment[p];
                back[i] += from_parent.dot(v.normal_offsets[i]);
                back_moment[i] += from_parent;
            }
        }
        self.tree
            .leaf_node
            .iter()
            .map(|&node| back[node as usize])
            .collect()
    }

    /// Leaf areas (m²).
    pub fn leaf_areas(&self) -> Vec<f64> {
        self.tree
            .leaf_node
            .iter()
            .map(|&n| self.tree.nodes[n as usize].area)
            .collect()
    }
}

#[cfg(test)]
impl Operator {
    /// `F·x` before balancing (for tests).
    pub(crate) fn apply_raw(&self, x: &[f64], width: usize) -> Vec<f64> {
        self.apply_scaled(x, width, false)
    }

    /// Entries with a volume cluster at either end.
    pub(crate) fn volume_links(&self) -> usize {
        self.volume.as_ref().map_or(0, |v| v.sources.len() / 2)
    }

    /// The same operator with its volume entries' normal terms dropped (for tests).
    pub(crate) fn without_normal_terms_for_test(&self) -> Self {
        let mut flat = self.clone();
        if let Some(v) = flat.volume.as_mut() {
            v.to_source
                .iter_mut()
                .chain(&mut v.to_receiver)
                .for_each(|w| *w = [0.0; 3]);
        }
        flat
    }

    /// `Fᵀ·y` before balancing (for tests).
    pub(crate) fn apply_transpose_for_test(&self, y: &[f64]) -> Vec<f64> {
        self.apply_transpose_raw(y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Patch;

    /// One OBJ-like surface of unit squares: two apart in the plane z = 0, one 10⁻¹⁰ m above
    /// it (the same plane within the tolerance), one in the parallel plane z = 0.5, one facing
    /// +x. Its planar trees are one per plane: the three squares of z = 0 under one, the others
    /// alone, every planar node's leaves sharing its normal and offset; over them one root, a
    /// volume cluster whose normal is the direction of the area-weighted normal sum and whose
    /// cone bounds the angle to every leaf's normal. Each leaf's plane root is its planar tree's.
    #[test]
    fn an_obj_surface_gets_a_tree_per_plane() {
        let mut mesh = PatchMesh {
            positions: Vec::new(),
            normals: Vec::new(),
            vertex_surface: Vec::new(),
            patches: Vec::new(),
        };
        let mut square = |origin: DVec3, u: DVec3, v: DVec3| {
            let first = mesh.positions.len() as u32;
            let normal = u.cross(v);
            for corner in [origin, origin + u, origin + u + v, origin + v] {
                mesh.positions.push(corner);
                mesh.normals.push(normal);
                mesh.vertex_surface.push(0);
            }
            mesh.patches.push(Patch {
                vertices: [first, first + 1, first + 2, first + 3],
                n_vertices: 4,
                surface: 0,
                normal,
                area: 1.0,
                centroid: origin + 0.5 * (u + v),
            });
        };
        square(DVec3::ZERO, DVec3::X, DVec3::Y);
        square(DVec3::new(0.0, 0.0, 0.5), DVec3::X, DVec3::Y);
        square(DVec3::new(3.0, 0.0, 0.0), DVec3::X, DVec3::Y);
        square(DVec3::new(5.0, 0.0, 0.0), DVec3::Y, DVec3::Z);
        square(DVec3::new(1.0, 2.0, 1e-10), DVec3::X, DVec3::Y);
        let tree = Tree::build(&mesh, &[]);
        let leaves_of = |root: u32| {
            let mut out = Vec::new();
            let mut stack = vec![root];
            while let Some(i) = stack.pop() {
                let node = &tree.nodes[i as usize];
                if node.is_leaf() {
                    out.push(node.leaf);
                } else {
                    stack.extend(node.children);
                }
            }
            out.sort_unstable();
            out
        };
        assert_eq!(tree.roots.len(), 1);
        let mut planes: Vec<Vec<u32>> = (0..5)
            .map(|leaf| tree.plane_root(tree.leaf_node[leaf]))
            .collect::<std::collections::BTreeSet<u32>>()
            .into_iter()
            .map(leaves_of)
            .collect();
        planes.sort();
        assert_eq!(planes, vec![vec![0, 2, 4], vec![1], vec![3]]);
        let leaf_normals = |i: u32| {
            leaves_of(i)
                .into_iter()
                .map(|l| tree.nodes[tree.leaf_node[l as usize] as usize].normal)
                .collect::<Vec<DVec3>>()
        };
        for (i, node) in tree.nodes.iter().enumerate() {
            let normals = leaf_normals(i as u32);
            if node.volume {
                for n in normals {
                    assert!(
                        n.dot(node.normal).clamp(-1.0, 1.0).acos() <= node.cone + 1e-12,
                        "{node:?}"
                    );
                }
            } else {
                assert!(normals.iter().all(|&n| n == node.normal), "{node:?}");
                assert!(
                    node.normal == DVec3::Z || node.normal == DVec3::X,
                    "{:?}",
                    node.normal
                );
            }
        }
        let root = &tree.nodes[tree.roots[0] as usize];
        assert!(
            root.volume && root.leaf_count == 5 && root.area == 5.0,
            "{root:?}"
        );
        let sum = DVec3::new(1.0, 0.0, 4.0);
        assert!(root.normal.distance(sum.normalize()) < 1e-12, "{:?}", root.normal);
        let top = &tree.nodes[tree.plane_root(tree.leaf_node[0]) as usize];
        assert_eq!((top.leaf_count, top.area), (3, 3.0));
        assert!(top.lo.z == 0.0 && top.hi.z <= 1e-9);
    }

    /// Two facing squares at z = 0 (side 1, up) and z = 1 (side `s`, down), each its own surface.
    fn two_squares(s: f64) -> PatchMesh {
        let positions = vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(0.0, s, 1.0),
            DVec3::new(s, s, 1.0),
            DVec3::new(s, 0.0, 1.0),
        ];
        let patch = |first: u32, surface: u32, normal: DVec3, area: f64, centroid: DVec3| Patch {
            vertices: [first, first + 1, first + 2, first + 3],
            n_vertices: 4,
            surface,
            normal,
            area,
            centroid,
        };
        PatchMesh {
            normals: vec![
                DVec3::Z,
                DVec3::Z,
                DVec3::Z,
                DVec3::Z,
                DVec3::NEG_Z,
                DVec3::NEG_Z,
                DVec3::NEG_Z,
                DVec3::NEG_Z,
            ],
            vertex_surface: vec![0, 0, 0, 0, 1, 1, 1, 1],
            patches: vec![
                patch(0, 0, DVec3::Z, 1.0, DVec3::new(0.5, 0.5, 0.0)),
                patch(4, 1, DVec3::NEG_Z, s * s, DVec3::new(s / 2.0, s / 2.0, 1.0)),
            ],
            positions,
        }
    }

    /// Rows summing to 1 on two leaves of areas 1 and 2 that see only each other would need
    /// `A_1 · 1 = A_2` for the second's power: no scaling meets both, and balancing stops when
    /// its defect stalls instead of running its 200 sweeps, with the rows exact (also as the
    /// operator reports them after reporting them unbalanced).
    #[test]
    fn balancing_stops_when_rows_and_columns_cannot_both_be_met() {
        let operator = |side: f64| {
            let tree = Tree::build(&two_squares(side), &[]);
            let link = Link {
                a: tree.leaf_node[0],
                b: tree.leaf_node[1],
                g: 0.4,
                grad_a: [0.0; 2],
                grad_b: [0.0; 2],
            };
            Operator::new(tree, &[vec![link]])
        };
        let mut operator_unequal = operator(2f64.sqrt());
        // Before balancing each leaf receives `G/A` (the areas 1 and 2); the sums formed here
        // are forgotten when balancing changes the scalings.
        let unbalanced = operator_unequal.row_sums();
        assert!(
            (unbalanced[0] - 0.4).abs() < 1e-7 && (unbalanced[1] - 0.2).abs() < 1e-7,
            "{unbalanced:?}"
        );
        let balance = operator_unequal.balance(Some(1.0));
        assert!(balance.sweeps <= 2 * BALANCE_STALL_SWEEPS, "{balance:?}");
        assert!(balance.defect > 0.1, "{balance:?}");
        for row in operator_unequal.row_sums() {
            assert!((row - 1.0).abs() < 1e-12, "row sum {row}");
        }
        // Equal areas: both can be met, and balancing meets them.
        let balance = operator(1.0).balance(Some(1.0));
        assert!(balance.defect < BALANCE_DEFECT, "{balance:?}");
    }
}
