//! The gather's near field (docs/DECISIONS.md "Receivers beside a large leaf"): a receiver
//! closer to a leaf than half the leaf's size sees the leaf's radiosity at a scale finer than
//! the leaf — the dark strip of a wall along the ceiling, a shadow wedge under a picture, the
//! corner of a slot — where one value per leaf, even a linear one, is the mean of a profile
//! that bends. Such a leaf is cut into pieces towards the receiver (each at most its distance
//! in size), and each visible piece's radiosity is evaluated where it lies: its reflectance
//! times its exact direct light plus its own gather. The receiver adds the piece's form factor
//! times the difference to the leaf's linear radiosity there.
//!
//! The pieces depend only on the receivers and the leaves, so a set of receivers keeps them
//! ([`NearField`]); what changes edit by edit is the direct light at the pieces (the caller's,
//! exact in the lights' current state) and the leaves' radiosity.

use glam::DVec3;
use rayon::prelude::*;

use super::{Interreflection, RECEIVER_LIFT_M};
use crate::transport::direct::Receiver;
use crate::transport::formfactor::point_to_polygon_with;
use crate::transport::visibility::Visibility;

/// A receiver is near a leaf when its distance to the leaf's bounds is below this share of the
/// leaf's size (its largest corner-to-corner distance).
const NEAR_SHARE: f64 = 0.5;
/// A near leaf is cut into pieces at most this share of their distance to the receiver in
/// size, splitting each piece in four at most [`PIECE_DEPTH`] times.
const PIECE_ACCEPT: f64 = 1.0;
const PIECE_DEPTH: u32 = 8;
/// The pieces' own gathers look again at a node only while its doubt exceeds this share of
/// what they gathered (40 times the receivers' [`super::GATHER_DOUBT`]): a piece's value enters
/// its receiver times the piece's form factor, and the second looks cost a piece in a slot
/// four times its first (the reference rooms' near fields: 2.0 s instead of 6.3 s in the
/// office, the slot between two cupboards 2.62 % at worst instead of 2.46 %; none at all:
/// 5.22 %).
const PIECE_DOUBT: f64 = 0.02;

/// The pieces of the leaves near each of a set of receivers.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct NearField {
    /// Per receiver, where its pieces start in `pieces`; one entry more than receivers.
    starts: Vec<u32>,
    /// Per piece, its leaf and its form factor from its receiver (visible pieces only).
    pieces: Vec<(u32, f64)>,
    /// Per piece, its centroid on its leaf with the leaf's normal (world, m): where the
    /// caller evaluates the direct light ([`Interreflection::gather_near`]).
    pub points: Vec<Receiver>,
}

impl NearField {
    /// Number of pieces (and of points).
    pub fn len(&self) -> usize {
        self.pieces.len()
    }

    /// True when no receiver is near a leaf large for its distance.
    pub fn is_empty(&self) -> bool {
        self.pieces.is_empty()
    }
}

impl Interreflection {
    /// The pieces of the leaves near each of `receivers` (module doc).
    pub fn near_field(&self, receivers: &[Receiver]) -> NearField {
        let per_receiver: Vec<Vec<(u32, f64, DVec3)>> =
            receivers.par_iter().map(|rx| self.near_pieces(rx)).collect();
        let tree = &self.operator.tree;
        let mut near = NearField {
            starts: vec![0],
            ..NearField::default()
        };
        for pieces in per_receiver {
            for (leaf, f, point) in pieces {
                let normal = tree.nodes[tree.leaf_node[leaf as usize] as usize].normal;
                near.pieces.push((leaf, f));
                near.points.push(Receiver { point, normal });
            }
            near.starts.push(near.pieces.len() as u32);
        }
        near
    }

    /// The visible pieces (leaf, form factor, centroid) of the leaves near `rx`.
    fn near_pieces(&self, rx: &Receiver) -> Vec<(u32, f64, DVec3)> {
        let tree = &self.operator.tree;
        let (p, n) = (rx.point + rx.normal * RECEIVER_LIFT_M, rx.normal);
        let mut out = Vec::new();
        let mut scratch = Vec::with_capacity(6);
        let mut stack = tree.roots.clone();
        while let Some(i) = stack.pop() {
            let node = &tree.nodes[i as usize];
            // A leaf below is at most the node's diameter in size.
            let gap = p.distance(p.clamp(node.lo, node.hi));
            if gap >= NEAR_SHARE * node.diameter || !node.seen_from(p, n) {
                continue;
            }
            if !node.is_leaf() {
                stack.extend(node.children);
                continue;
            }
            let target = &self.geometry.targets[node.leaf as usize];
            if gap >= NEAR_SHARE * target.size {
                continue;
            }
            target.pieces_toward(p, PIECE_ACCEPT, PIECE_DEPTH, |corners, centroid| {
                let f = point_to_polygon_with(p, n, corners, &mut scratch);
                let lifted = centroid + node.normal * RECEIVER_LIFT_M;
                let visible = self.occluders.as_ref().is_none_or(|o| o.visible(p, lifted));
                if f > 0.0 && visible {
                    out.push((node.leaf, f, centroid));
                }
            });
        }
        out
    }

    /// [`Self::gather`] at `receivers` with the near field `near` (made by
    /// [`Self::near_field`] for these receivers) resolved: `direct` is the direct irradiance
    /// (lx, linear RGB, colour applied) at `near.points` in the state the leaves' radiosity
    /// `radiosity` was solved for.
    pub fn gather_near(
        &self,
        radiosity: &[[f64; 3]],
        receivers: &[Receiver],
        near: &NearField,
        direct: &[[f64; 3]],
    ) -> Vec<[f64; 3]> {
        assert_eq!(
            near.starts.len(),
            receivers.len() + 1,
            "a near field of these receivers"
        );
        assert_eq!(direct.len(), near.points.len(), "direct light at every piece");
        let prepared = self.prepare_gather(radiosity);
        let mut gathered = self.gather_prepared(&prepared, receivers, self.options.gather_doubt);
        if near.is_empty() {
            return gathered;
        }
        let at_pieces = self.gather_prepared(&prepared, &near.points, PIECE_DOUBT);
        let tree = &self.operator.tree;
        let channels = self.reflectance.len();
        // Per piece: what it reflects where it lies, less the leaf's linear radiosity there.
        let residual: Vec<[f64; 3]> = near
            .pieces
            .iter()
            .zip(&near.points)
            .zip(direct.iter().zip(&at_pieces))
            .map(|((&(leaf, _), piece), (d, g))| {
                let leaf = leaf as usize;
                let centroid = tree.nodes[tree.leaf_node[leaf] as usize].centroid;
                let slopes = prepared.linear.as_ref().map(|l| l.slopes(leaf));
                std::array::from_fn(|ch| {
                    let rho = self.reflectance[ch.min(channels - 1)][leaf];
                    let model =
                        radiosity[leaf][ch] + slopes.map_or(0.0, |s| s[ch].dot(piece.point - centroid));
                    rho * (d[ch] + g[ch]) - model
                })
            })
            .collect();
        for (r, e) in gathered.iter_mut().enumerate() {
            let pieces = near.starts[r] as usize..near.starts[r + 1] as usize;
            for (&(_, f), res) in near.pieces[pieces.clone()].iter().zip(&residual[pieces]) {
                for ch in 0..3 {
                    e[ch] += f * res[ch];
                }
            }
            e.iter_mut().for_each(|v| *v = v.max(0.0));
        }
        gathered
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transport::formfactor::point_to_polygon;
    use crate::transport::interreflection::InterreflectionOptions;
    use crate::transport::refine::RefineOptions;

    /// A receiver on the floor 2 cm from a wall of 1 m leaves (no refinement, no occluders):
    /// only that wall's leaves beside it are near, their pieces' factors sum to each leaf's exact
    /// factor (the contour integral is additive over a partition), and the finest lie within
    /// 3 cm of the receiver. A receiver in the middle of the floor, 1.5 m from every wall, has
    /// none.
    #[test]
    fn near_pieces_tile_the_leaves_beside_a_receiver() {
        let scene = crate::scene::load::test_room(
            r#"version = 1
[room]
size = [4.0, 3.0, 2.5]
[room.reflectance]
floor = 0.3
walls = 0.6
ceiling = 0.8
[[light]]
name = "l"
position = [2.0, 1.5, 1.7]
lid = [[0, 800], [180, 100]]
[settings]
patch_size = 0.5
solver_patch_size = 1.0
"#,
        );
        let options = InterreflectionOptions {
            refine: RefineOptions::none(),
            ..InterreflectionOptions::default()
        };
        let engine = Interreflection::build(&scene, 1, false, &options).unwrap();
        let beside = Receiver {
            point: DVec3::new(2.2, 0.02, 0.0),
            normal: DVec3::Z,
        };
        let middle = Receiver {
            point: DVec3::new(2.0, 1.5, 0.0),
            normal: DVec3::Z,
        };
        let near = engine.near_field(&[beside, middle]);
        assert_eq!(near.starts, vec![0, near.len() as u32, near.len() as u32]);
        assert!(near.len() > 10, "{} pieces", near.len());
        let p = beside.point + beside.normal * RECEIVER_LIFT_M;
        let mut leaves: Vec<u32> = near.pieces.iter().map(|&(leaf, _)| leaf).collect();
        leaves.dedup();
        for leaf in leaves {
            let node = &engine.operator.tree.nodes[engine.operator.tree.leaf_node[leaf as usize] as usize];
            assert_eq!(node.normal, DVec3::Y, "only the wall y = 0 is near");
            let target = &engine.geometry.targets[leaf as usize];
            let sum: f64 = near
                .pieces
                .iter()
                .filter(|(l, _)| *l == leaf)
                .map(|(_, f)| f)
                .sum();
            let whole = point_to_polygon(p, beside.normal, target.corners());
            assert!(
                (sum - whole).abs() <= 1e-9 * whole,
                "leaf {leaf}: {sum} vs {whole}"
            );
        }
        // The pieces nearest the receiver are the smallest.
        let nearest = near
            .points
            .iter()
            .map(|q| q.point.distance(p))
            .fold(f64::INFINITY, f64::min);
        assert!(nearest < 0.03, "{nearest}");
    }
}
