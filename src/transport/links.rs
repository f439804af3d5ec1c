//! Building the links of the hierarchical operator ([`crate::transport::hierarchy`]).
//!
//! Every pair of tree roots that can see each other is refined recursively (and the halves of a
//! volume cluster with each other: a concave OBJ model sees itself): two nodes are linked
//! directly when they are *admissible* — the larger diameter is at most `eta ×` the distance
//! between their centroids, and a volume cluster's leaves all face the other node ([`faces`]) —
//! and otherwise the larger node (or the volume cluster that does not face) is split. Two leaves that are not
//! admissible are linked with the exact contour formula. So links grow about linearly with the
//! leaves, and every link's geometric error is bounded by its admissibility.
//!
//! * Far links: `G = Σ_a Σ_b A_a A_b cosθ_a cosθ_b / (π r_ab²)` over up to four pieces of each
//!   node (its grandchildren, or a 2 × 2 split of a leaf): a midpoint rule whose error is about a
//!   quarter of the single-point rule's.
//! * Near links (two leaves): `G = A_R F̄_{R→S}` from the smaller leaf `R` (both ways averaged
//!   when their sizes are alike), `F̄` the exact point-to-polygon factor averaged over a grid of
//!   up to 4 × 4 points of `R` (denser when the leaves are close).
//! * Visibility: none when no occluder's bounds meet the bounds of the two nodes (the shaft);
//!   otherwise the unblocked fraction of 16 rays between points spread over both nodes, each
//!   ray weighted by the kernel between its end points. A partially visible link whose larger
//!   form factor exceeds `visibility_refine` (`slot_visibility_refine` for a link to a leaf in a
//!   slot) is refined (split the larger node); between two leaves a partial result is
//!   re-estimated with 64 rays (8 × 8 points each), so shadow lines are resolved where they
//!   matter.
//! * A budget: at most `max_links` links are made; past it every task stops and the build
//!   reports [`TooManyLinks`] instead of links (docs/DECISIONS.md "Resource budget").

use std::f64::consts::{FRAC_PI_2, PI};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};

use glam::DVec3;
use rayon::prelude::*;

use crate::scene::PatchMesh;
use crate::transport::formfactor::{TargetPatch, kernel, point_to_polygon_with, triangle_quarters};
use crate::transport::hierarchy::{Link, MIN_FACING, NONE, Node, Tree, plane_axes};
use crate::transport::occlusion::{LocalOccluders, Occluders};
use crate::transport::slopes::plane_gradient;
use crate::transport::visibility::weighted_fraction;

/// Lift (m) of sample points off their surface.
const LIFT_M: f64 = 1e-6;
/// Rays per link between nodes, and between two leaves once partially visible.
const RAYS: usize = 16;
const LEAF_RAYS: usize = 64;
/// Most points [`NodeGeometry::spread_points`] spreads over a node (the size of its frontier).
pub const MAX_SPREAD_POINTS: usize = 64;
const _: () = assert!(RAYS <= MAX_SPREAD_POINTS && LEAF_RAYS <= MAX_SPREAD_POINTS);
/// Pieces of a node for the far-field midpoint rule.
const PIECES: usize = 4;

/// How links are made.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinkOptions {
    /// Link two nodes when the larger diameter is at most this many times their centroid
    /// distance. Default 0.1 (docs/ACCURACY.md "After": 0.5 leaves 7 % beside furniture).
    pub eta: f64,
    /// Farther than `near_m` (m) the ratio grows with the distance, `eta × distance / near_m`,
    /// up to `eta_far`, so that a leaf links to clusters beyond its neighbourhood instead of to
    /// every leaf within `1/eta` of its size (docs/DECISIONS.md "Interreflection", "Relaxed
    /// links"); not for a link with a leaf in a slot at either end (docs/DECISIONS.md "Links of
    /// a slot's leaves are not relaxed"). Defaults 1 m and 0.1: no growth.
    pub near_m: f64,
    pub eta_far: f64,
    /// Refine a partially visible link whose larger form factor exceeds this. Default 0.0001
    /// (0.002 on floors of more than 50 000 leaves: docs/DECISIONS.md "Shadow rays weighted by
    /// the kernel", "Dark pockets: partly visible links refined down to 0.0001").
    pub visibility_refine: f64,
    /// The same for a link to a leaf in a slot, which sees the room only through a narrow
    /// opening, so that small partly visible links carry most of its light. Default 0.0001.
    pub slot_visibility_refine: f64,
}

impl LinkOptions {
    /// The admissibility ratio at centroid distance `dist` (m).
    pub fn eta_at(&self, dist: f64) -> f64 {
        (self.eta * dist / self.near_m).clamp(self.eta, self.eta_far.max(self.eta))
    }
}

impl Default for LinkOptions {
    fn default() -> Self {
        LinkOptions {
            eta: 0.1,
            near_m: 1.0,
            eta_far: 0.1,
            visibility_refine: 0.0001,
            slot_visibility_refine: 0.0001,
        }
    }
}

/// The links and what making them cost.
#[derive(Debug, Clone, Default)]
pub struct Links {
    /// The links, in lists (one or more per tree root, in the order they were made; kept apart
    /// so that no flat copy doubles their memory: 16 M links, 450 MB, on the open-plan floor).
    pub links: Vec<Vec<Link>>,
    /// Visibility rays cast.
    pub rays: u64,
    /// Links between two leaves with the exact contour formula.
    pub near: usize,
}

/// The build stopped: the links would be more than `max_links`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TooManyLinks {
    /// The budget that was reached.
    pub max_links: usize,
}

/// Up to four (area, centroid) pieces of a node for the far-field midpoint rule.
type Pieces = ([(f64, DVec3); PIECES], usize);

/// What links and gathers need of every node: the leaves' polygons and each node's pieces.
#[derive(Debug, Clone)]
pub struct NodeGeometry {
    /// Per leaf, its polygon as a form-factor target.
    pub targets: Vec<TargetPatch>,
    pieces: Vec<Pieces>,
}

impl NodeGeometry {
    /// The geometry of `tree` over the leaves of `mesh`.
    pub fn new(mesh: &PatchMesh, tree: &Tree) -> Self {
        let targets: Vec<TargetPatch> = mesh.patches.iter().map(|p| TargetPatch::new(mesh, p)).collect();
        let pieces = tree
            .nodes
            .iter()
            .map(|node| node_pieces(tree, &targets, node))
            .collect();
        NodeGeometry { targets, pieces }
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.targets.len() * std::mem::size_of::<TargetPatch>()
            + self.pieces.len() * std::mem::size_of::<Pieces>()
    }

    /// Far-field form factor from a point `p` (unit normal `n`) to node `i` of normal `normal`:
    /// the midpoint rule over the node's pieces.
    pub fn far_from_point(&self, i: u32, normal: DVec3, p: DVec3, n: DVec3) -> f64 {
        let (pieces, k) = &self.pieces[i as usize];
        let mut f = 0.0;
        for &(a, c) in &pieces[..*k] {
            let d = c - p;
            let d2 = d.length_squared();
            if d2 == 0.0 {
                continue;
            }
            let inv = d2.sqrt().recip();
            let (cos_p, cos_s) = (n.dot(d) * inv, -normal.dot(d) * inv);
            if cos_p > 0.0 && cos_s > 0.0 {
                f += a * cos_p * cos_s / (PI * d2);
            }
        }
        f
    }

    /// Form factor from a point `p` (unit normal `n`) to node `i`: the exact contour formula on
    /// a leaf's polygon or a full rectangle cluster, the pieces' midpoint rule otherwise. Zero
    /// when `p` is behind the node.
    pub fn node_factor(&self, tree: &Tree, i: u32, p: DVec3, n: DVec3, scratch: &mut Vec<DVec3>) -> f64 {
        let node = &tree.nodes[i as usize];
        if node.is_leaf() {
            return self.targets[node.leaf as usize].form_factor_with(p, n, f64::INFINITY, scratch);
        }
        if !node.volume && node.normal.dot(p - node.centroid) <= 0.0 {
            return 0.0;
        }
        if node.full_rect {
            point_to_polygon_with(p, n, &node.rect_corners(), scratch)
        } else {
            self.far_from_point(i, node.normal, p, n)
        }
    }

    /// `count` points (a power of four, 1 to [`MAX_SPREAD_POINTS`]) on the surface of a node, lifted
    /// off it, into `points` (cleared first): a grid on a leaf; on a cluster, the representative
    /// points of as many sub-clusters.
    pub fn spread_points(&self, tree: &Tree, node: &Node, count: usize, points: &mut Vec<DVec3>) {
        assert!((1..=MAX_SPREAD_POINTS).contains(&count), "{count} spread points");
        points.clear();
        let per_edge = (count as f64).sqrt().round() as usize;
        if node.is_leaf() {
            return self.targets[node.leaf as usize].sample_points_into(per_edge, points);
        }
        // Split the largest frontier node until there are `count` of them (or only leaves).
        let mut frontier = [node; MAX_SPREAD_POINTS];
        let mut len = 1;
        while len < count {
            let Some((i, _)) = frontier[..len]
                .iter()
                .enumerate()
                .filter(|(_, n)| !n.is_leaf())
                .max_by(|a, b| a.1.area.total_cmp(&b.1.area))
            else {
                break;
            };
            let [c0, c1] = frontier[i].children.map(|c| &tree.nodes[c as usize]);
            frontier[i] = frontier[len - 1];
            frontier[len - 1] = c0;
            frontier[len] = c1;
            len += 1;
        }
        let frontier = &frontier[..len];
        if len >= count {
            for n in frontier {
                let leaf = if n.is_leaf() { n.leaf } else { n.representative };
                debug_assert!(leaf != NONE);
                let t = &self.targets[leaf as usize];
                points.push(t.centroid + t.normal * LIFT_M);
            }
        } else {
            // Few leaves: several points on each.
            let each = count.div_ceil(len);
            let k = ((each as f64).sqrt().ceil() as usize).max(1);
            for n in frontier {
                self.targets[n.leaf as usize].sample_points_into(k, points);
            }
            points.truncate(count);
            let mut i = 0;
            while points.len() < count {
                points.push(points[i]);
                i += 1;
            }
        }
    }
}

/// A task's links, and the spread points of its shadow rays (kept to save an allocation per
/// link). Links go into `links`; the lists of the tasks a task splits into are moved after it in
/// `lists`, never copied into one list: copying the halves of a large pair of roots into a list
/// growing by doubling took up to six times their size at once (937 MB at the peak for 5.3 M
/// links of 28 B).
#[derive(Default)]
struct Run {
    lists: Vec<Vec<Link>>,
    links: Vec<Link>,
    points: [Vec<DVec3>; 2],
}

impl Run {
    /// Ends the current list (shrunk to its links: it grew by doubling) after the others.
    fn close_list(&mut self) {
        if !self.links.is_empty() {
            let mut list = std::mem::take(&mut self.links);
            list.shrink_to_fit();
            self.lists.push(list);
        }
    }

    /// The task's lists, in order.
    fn into_lists(mut self) -> Vec<Vec<Link>> {
        self.close_list();
        self.lists
    }
}

struct Context<'a> {
    tree: &'a Tree,
    /// Per leaf, whether it lies in a slot.
    in_slot: &'a [bool],
    geometry: &'a NodeGeometry,
    occluders: Option<&'a Occluders>,
    options: LinkOptions,
    rays: AtomicU64,
    /// Links made so far, the budget, and whether it was passed (every task then stops).
    made: AtomicUsize,
    max_links: usize,
    over: AtomicBool,
}

/// Makes the links of `tree`, whose leaf polygons and pieces are `geometry` and whose leaves
/// `in_slot` lie in slots, with visibility against `occluders` where given (in parallel;
/// deterministic output order).
///
/// Errors: more than `max_links` links (the build stops soon after passing it).
pub fn build(
    tree: &Tree,
    in_slot: &[bool],
    geometry: &NodeGeometry,
    occluders: Option<&Occluders>,
    options: LinkOptions,
    max_links: usize,
) -> Result<Links, TooManyLinks> {
    debug_assert_eq!(in_slot.len(), tree.leaf_node.len(), "one slot flag per leaf");
    let ctx = Context {
        tree,
        in_slot,
        geometry,
        occluders,
        options,
        rays: AtomicU64::new(0),
        made: AtomicUsize::new(0),
        max_links,
        over: AtomicBool::new(false),
    };
    // One task per root, refining it against every later root: a non-planar OBJ surface makes
    // a root of each of its leaves, so the pairs of roots can be millions, and a list (and
    // allocation) per pair once took more memory than the links.
    let roots = &tree.roots;
    let per_root: Vec<Vec<Vec<Link>>> = (0..roots.len())
        .into_par_iter()
        .map(|i| {
            let mut run = Run::default();
            ctx.refine_within(roots[i], &mut run);
            for &s in &roots[i + 1..] {
                ctx.refine(roots[i], s, &mut run);
            }
            run.into_lists()
        })
        .collect();
    if ctx.over.load(Ordering::Relaxed) {
        return Err(TooManyLinks { max_links });
    }
    let links: Vec<Vec<Link>> = per_root.into_iter().flatten().collect();
    let near = links
        .iter()
        .flatten()
        .filter(|l| tree.nodes[l.a as usize].is_leaf() && tree.nodes[l.b as usize].is_leaf())
        .count();
    Ok(Links {
        links,
        rays: ctx.rays.load(Ordering::Relaxed),
        near,
    })
}

/// The pieces of a node: its grandchildren (children that are leaves count as themselves), or
/// for a leaf a 2 × 2 split (four sub-triangles of a triangle).
fn node_pieces(tree: &Tree, targets: &[TargetPatch], node: &Node) -> Pieces {
    let mut out = [(0.0, DVec3::ZERO); PIECES];
    let mut n = 0;
    if node.is_leaf() {
        let t = &targets[node.leaf as usize];
        let c = t.corners();
        if c.len() == 4 {
            for (u, v) in [(0.25, 0.25), (0.75, 0.25), (0.75, 0.75), (0.25, 0.75)] {
                let q = c[0] * ((1.0 - u) * (1.0 - v))
                    + c[1] * (u * (1.0 - v))
                    + c[2] * (u * v)
                    + c[3] * ((1.0 - u) * v);
                out[n] = (t.area / 4.0, q);
                n += 1;
            }
        } else {
            for tri in triangle_quarters([c[0], c[1], c[2]]) {
                out[n] = (t.area / 4.0, (tri[0] + tri[1] + tri[2]) / 3.0);
                n += 1;
            }
        }
        return (out, n);
    }
    for child in node.children {
        let c = &tree.nodes[child as usize];
        if c.is_leaf() {
            out[n] = (c.area, c.centroid);
            n += 1;
        } else {
            for g in c.children {
                let g = &tree.nodes[g as usize];
                out[n] = (g.area, g.centroid);
                n += 1;
            }
        }
    }
    (out, n)
}

/// The in-plane gradient (1/m, along world axes `axes`) of a factor known at the pieces
/// `(area, centroid, value)` of a node with centroid `centre`: area-weighted least squares of
/// `value ≈ mean + ∇·(c − centre)`, only along the directions the pieces span.
fn fit_gradient(pieces: &[(f64, DVec3, f64)], centre: DVec3, axes: [usize; 2]) -> [f32; 2] {
    let total: f64 = pieces.iter().map(|p| p.0).sum();
    if total <= 0.0 {
        return [0.0; 2];
    }
    let mean = pieces.iter().map(|p| p.0 * p.2).sum::<f64>() / total;
    let samples = pieces.iter().map(|&(a, c, f)| {
        let d = [c[axes[0]] - centre[axes[0]], c[axes[1]] - centre[axes[1]]];
        (a, d, f - mean)
    });
    plane_gradient(samples).map(|g| g as f32)
}

/// True when some part of `node` lies strictly in front of the plane of `of`.
fn in_front(node: &Node, of: &Node) -> bool {
    if of.volume {
        return true;
    }
    let n = of.normal;
    // The largest n·x over the box [lo, hi].
    let top = (0..3)
        .map(|i| (n[i] * node.lo[i]).max(n[i] * node.hi[i]))
        .sum::<f64>();
    top - n.dot(of.centroid) > 1e-9
}

/// True unless `v` is a volume cluster some leaf of which may not face `other` (centroids
/// `dist` apart): the angle from `v`'s normal to the direction of `other`, plus `v`'s cone, plus
/// the angle either node spans seen from the other, stays short of 90° (docs/DECISIONS.md
/// "Volume clusters").
fn faces(v: &Node, other: &Node, dist: f64) -> bool {
    if !v.volume {
        return true;
    }
    let d = (other.centroid - v.centroid) / dist;
    let span = (0.5 * (v.diameter + other.diameter) / dist).min(1.0).asin();
    let margin = v.cone + span;
    margin < FRAC_PI_2 && v.normal.dot(d) >= margin.sin().max(MIN_FACING)
}

impl Context<'_> {
    fn node(&self, i: u32) -> &Node {
        &self.tree.nodes[i as usize]
    }

    fn refine(&self, r: u32, s: u32, out: &mut Run) {
        if self.over.load(Ordering::Relaxed) {
            return;
        }
        let (nr, ns) = (self.node(r), self.node(s));
        if !in_front(ns, nr) || !in_front(nr, ns) {
            return;
        }
        let dist = nr.centroid.distance(ns.centroid);
        let both_leaves = nr.is_leaf() && ns.is_leaf();
        // A cluster holding a possible hot spot is never linked as a whole: its mean radiosity
        // and area-sampled visibility would misplace the spot.
        let whole = |n: &Node| n.is_leaf() || !n.hot;
        let slot = [nr, ns]
            .iter()
            .any(|n| n.is_leaf() && self.in_slot[n.leaf as usize]);
        // A leaf in a slot is lit through its opening by what lies beyond, so its links are
        // not relaxed with distance (docs/DECISIONS.md "Links of a slot's leaves are not relaxed").
        let eta = if slot {
            self.options.eta
        } else {
            self.options.eta_at(dist)
        };
        let admissible = nr.diameter.max(ns.diameter) <= eta * dist && whole(nr) && whole(ns);
        if admissible {
            // A volume cluster is linked as a whole only when all its leaves face the other.
            if !faces(nr, ns, dist) {
                return self.split_node(r, s, out);
            }
            if !faces(ns, nr, dist) {
                return self.split_node(s, r, out);
            }
        }
        if admissible || both_leaves {
            let (g, grad_a, grad_b) = if admissible {
                self.far(r, s)
            } else {
                let points = &mut out.points[0];
                (self.near(nr.leaf, ns.leaf, dist, points), [0.0; 2], [0.0; 2])
            };
            if g <= 0.0 {
                return;
            }
            let shaft = self.shaft(nr, ns);
            let v = self.visibility(shaft.as_ref(), nr, ns, RAYS, &mut out.points);
            let partial = v > 0.0 && v < 1.0;
            let refine_above = if slot {
                self.options.slot_visibility_refine
            } else {
                self.options.visibility_refine
            };
            let important = g / nr.area.min(ns.area) > refine_above;
            if partial && !both_leaves && important {
                return self.split(r, s, out);
            }
            let v = if partial && both_leaves {
                self.visibility(shaft.as_ref(), nr, ns, LEAF_RAYS, &mut out.points)
            } else {
                v
            };
            if v > 0.0 {
                if self.made.fetch_add(1, Ordering::Relaxed) >= self.max_links {
                    self.over.store(true, Ordering::Relaxed);
                    return;
                }
                out.links.push(Link {
                    a: r,
                    b: s,
                    g: (g * v) as f32,
                    grad_a: grad_a.map(|x| (f64::from(x) * v) as f32),
                    grad_b: grad_b.map(|x| (f64::from(x) * v) as f32),
                });
            }
            return;
        }
        self.split(r, s, out);
    }

    /// Splits the larger of the two (a leaf is never split; a hot cluster first) and refines
    /// both halves.
    fn split(&self, r: u32, s: u32, out: &mut Run) {
        let (nr, ns) = (self.node(r), self.node(s));
        let split_r = if nr.hot != ns.hot && !nr.is_leaf() && !ns.is_leaf() {
            nr.hot
        } else {
            !nr.is_leaf() && (ns.is_leaf() || nr.diameter >= ns.diameter)
        };
        if split_r {
            self.split_node(r, s, out)
        } else {
            self.split_node(s, r, out)
        }
    }

    /// Refines both children of cluster `big` against `other`.
    fn split_node(&self, big: u32, other: u32, out: &mut Run) {
        let big = self.node(big);
        let [c0, c1] = big.children;
        if big.leaf_count > 512 {
            let (mut a, mut b) = (Run::default(), Run::default());
            rayon::join(
                || self.refine(c0, other, &mut a),
                || self.refine(c1, other, &mut b),
            );
            out.close_list();
            out.lists.extend(a.into_lists());
            out.lists.extend(b.into_lists());
        } else {
            self.refine(c0, other, out);
            self.refine(c1, other, out);
        }
    }

    /// Links the leaves of volume cluster `v` that see each other (a concave mesh lights
    /// itself): its two children against each other, and within each.
    fn refine_within(&self, v: u32, out: &mut Run) {
        let node = self.node(v);
        if !node.volume {
            return;
        }
        let [c0, c1] = node.children;
        if node.leaf_count > 512 {
            let (mut a, mut b, mut c) = (Run::default(), Run::default(), Run::default());
            rayon::join(
                || self.refine(c0, c1, &mut a),
                || {
                    rayon::join(
                        || self.refine_within(c0, &mut b),
                        || self.refine_within(c1, &mut c),
                    )
                },
            );
            out.close_list();
            for run in [a, b, c] {
                out.lists.extend(run.into_lists());
            }
        } else {
            self.refine(c0, c1, out);
            self.refine_within(c0, out);
            self.refine_within(c1, out);
        }
    }

    /// Far-field `G`: `½ (Σ_a A_a F(a → S) + Σ_b A_b F(b → R))` over the pieces `a` of `R` and
    /// `b` of `S`, each `F` exact on the other node's polygon where it is a rectangle; and the
    /// in-plane gradients of `F(· → S)` over `R` and of `F(· → R)` over `S` fitted to the pieces.
    fn far(&self, r: u32, s: u32) -> (f64, [f32; 2], [f32; 2]) {
        let mut scratch = Vec::with_capacity(6);
        let mut one_way = |from: u32, to: u32| {
            let node = self.node(from);
            let normal = node.normal;
            let (pieces, k) = &self.geometry.pieces[from as usize];
            let mut values = [(0.0, DVec3::ZERO, 0.0); PIECES];
            for (v, &(a, c)) in values.iter_mut().zip(&pieces[..*k]) {
                let f = self
                    .geometry
                    .node_factor(self.tree, to, c + normal * LIFT_M, normal, &mut scratch);
                *v = (a, c, f);
            }
            let values = &values[..*k];
            let g: f64 = values.iter().map(|(a, _, f)| a * f).sum();
            let gradient = if node.is_leaf() || node.volume || node.area <= 0.0 {
                [0.0; 2]
            } else {
                let axes = plane_axes(normal);
                let grad = fit_gradient(values, node.centroid, axes);
                // Keep the linear field non-negative over the node's bounds.
                let reach = axes.map(|k| (node.centroid[k] - node.lo[k]).max(node.hi[k] - node.centroid[k]));
                let mean = g / node.area;
                let swing = f64::from(grad[0]).abs() * reach[0] + f64::from(grad[1]).abs() * reach[1];
                if swing > mean && swing > 0.0 {
                    grad.map(|x| (f64::from(x) * mean / swing) as f32)
                } else {
                    grad
                }
            };
            (g, gradient)
        };
        let (g_r, grad_r) = one_way(r, s);
        let (g_s, grad_s) = one_way(s, r);
        (0.5 * (g_r + g_s), grad_r, grad_s)
    }

    /// Near `G` of two leaves: the exact contour factor averaged over points of the receiving
    /// leaf, `A_R F̄_{R→S}`, from the smaller leaf (whose factor to the other varies least over
    /// it), averaged both ways when their sizes are alike.
    fn near(&self, a: u32, b: u32, dist: f64, points: &mut Vec<DVec3>) -> f64 {
        let (ta, tb) = (
            &self.geometry.targets[a as usize],
            &self.geometry.targets[b as usize],
        );
        let mut scratch = Vec::with_capacity(6);
        let mut one_way = |from: &TargetPatch, to: &TargetPatch| {
            let k = ((2.0 * from.size / dist).ceil() as usize).clamp(1, 4);
            points.clear();
            from.sample_points_into(k, points);
            let sum: f64 = points
                .iter()
                .map(|&p| to.form_factor_with(p, from.normal, f64::INFINITY, &mut scratch))
                .sum();
            from.area * sum / points.len() as f64
        };
        if ta.size > 2.0 * tb.size {
            one_way(tb, ta)
        } else if tb.size > 2.0 * ta.size {
            one_way(ta, tb)
        } else {
            0.5 * (one_way(ta, tb) + one_way(tb, ta))
        }
    }

    /// The occluders a segment between the two nodes can meet (their shaft), `None` when there
    /// are none: made once per link, for its rays and, when partial, its denser re-estimate.
    fn shaft(&self, a: &Node, b: &Node) -> Option<LocalOccluders<'_>> {
        let pad = DVec3::splat(LIFT_M * 2.0);
        let shaft = self
            .occluders?
            .between((a.lo - pad, a.hi + pad), (b.lo - pad, b.hi + pad));
        (!shaft.is_empty()).then_some(shaft)
    }

    /// Visible fraction between the two nodes: `rays` rays between points spread over both,
    /// weighted by the kernel (1 without occluders in their `shaft`).
    fn visibility(
        &self,
        shaft: Option<&LocalOccluders<'_>>,
        a: &Node,
        b: &Node,
        rays: usize,
        [pa, pb]: &mut [Vec<DVec3>; 2],
    ) -> f64 {
        let Some(shaft) = shaft else { return 1.0 };
        self.geometry.spread_points(self.tree, a, rays, pa);
        self.geometry.spread_points(self.tree, b, rays, pb);
        // Pair point j of `a` with a permuted point of `b` (the multiplier is odd, so coprime
        // with the power-of-two count).
        let stride = if rays == LEAF_RAYS { 27 } else { 7 };
        self.rays.fetch_add(rays as u64, Ordering::Relaxed);
        weighted_fraction((0..rays).map(|j| {
            let (from, to) = (pa[j], pb[(j * stride + 3) % rays]);
            (kernel(a.normal, b.normal, to - from), !shaft.blocked(from, to))
        }))
    }
}
