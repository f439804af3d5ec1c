//! The gather's near field (docs/DECISIONS.md "Receivers beside a large leaf"): a receiver
//! closer to a leaf than half the leaf's size sees the leaf's radiosity at a scale finer than
//! the leaf — the dark strip of a wall along the ceiling, a shadow wedge under a picture, the
//! corner of a slot — where one value per leaf, even a linear one, is the mean of a profile
//! that bends. Such a leaf is cut into pieces towards the receiver (each at most its distance
//! in size), and each visible piece's radiosity is evaluated where it lies: its reflectance
//! times its exact direct light (the mean at its quarters' centres) plus its own gather. The
//! receiver adds the piece's form factor times the difference to the leaf's linear radiosity
//! there.
//!
//! A receiver a few centimetres from a leaf up to one and a half times that leaf's size
//! ([`NEAR_CLOSE_M`], [`NEAR_CLOSE_SHARE`]) has its pieces resolve the indirect light only
//! (docs/DECISIONS.md "Indirect light beside a box face"): a far link ending at a cluster of
//! floor strips pushes one irradiance down to every strip, those a box hides from half the room
//! as much as the open floor, and a face beside the strips sees that at its own scale. Such a
//! piece adds its reflectance times its own gather less the leaf's solved indirect irradiance;
//! the leaf's direct light stays its exact mean over the leaf, which a few points per piece
//! would only make worse where a beam edge or a shadow line crosses it.
//!
//! The pieces depend only on the receivers and the leaves, so a set of receivers keeps them
//! ([`NearField`]); what changes edit by edit is the direct light at the pieces (the caller's,
//! exact in the lights' current state) and the leaves' radiosity and indirect irradiance.

use glam::DVec3;
use rayon::prelude::*;

use super::{Interreflection, RECEIVER_LIFT_M};
use crate::transport::direct::Receiver;
use crate::transport::formfactor::{PatchPiece, point_to_polygon_with};
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
/// A receiver not near a leaf by [`NEAR_SHARE`] still has the leaf's indirect light resolved
/// when its distance to the leaf's bounds is below both this distance (m) and
/// [`NEAR_CLOSE_SHARE`] of the leaf's size; leaves in slots excepted, whose partly visible
/// links are refined further already and whose pieces' gathers, each with less care than a
/// leaf's, were worse there (docs/DECISIONS.md "Indirect light beside a box face").
const NEAR_CLOSE_M: f64 = 0.1;
/// The share of a leaf's size within which [`NEAR_CLOSE_M`] applies.
const NEAR_CLOSE_SHARE: f64 = 1.5;

/// A piece that resolves its leaf's radiosity reads its direct light as the mean at this many
/// points, the centroids of its quarters (`PatchPiece::quarter_centres`, equal areas): a shadow
/// line or a beam edge crossing a piece as large as its distance to the receiver then shifts
/// the piece's direct light a quarter at a time, not all or nothing (docs/DECISIONS.md "Direct
/// light of a near piece").
const DIRECT_POINTS: usize = 4;

/// What a piece of a leaf resolves for its receiver.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Resolves {
    /// The leaf's radiosity where the piece lies: reflectance times the exact direct light at
    /// its quarters' centres plus its own gather, less the leaf's linear radiosity there.
    Radiosity,
    /// The leaf's indirect light where the piece lies: reflectance times its own gather less
    /// the leaf's solved indirect irradiance. The slope of the leaf's linear radiosity, which
    /// the receiver's own gather reads, stays: it comes from the neighbours' total radiosity,
    /// direct and indirect together, and cannot be split.
    Indirect,
}

/// One piece of a leaf near a receiver.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Piece {
    leaf: u32,
    /// The piece's form factor from its receiver.
    form_factor: f64,
    resolves: Resolves,
}

/// What a leaf of `size` (m) whose bounds are `gap` (m) from a receiver resolves for it;
/// `None` when it is far enough to be gathered whole. `in_slot`: the leaf lies in a slot.
fn resolves(gap: f64, size: f64, in_slot: bool) -> Option<Resolves> {
    if gap < NEAR_SHARE * size {
        Some(Resolves::Radiosity)
    } else if !in_slot && gap < close_reach(size) {
        Some(Resolves::Indirect)
    } else {
        None
    }
}

/// How far (m) from a leaf of `size` (m) a receiver may be for its indirect light to be
/// resolved.
fn close_reach(size: f64) -> f64 {
    NEAR_CLOSE_M.min(NEAR_CLOSE_SHARE * size)
}

/// The pieces of the leaves near each of a set of receivers.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct NearField {
    /// Per receiver, where its pieces start in `pieces`; one entry more than receivers.
    starts: Vec<u32>,
    /// The visible pieces, receiver by receiver.
    pieces: Vec<Piece>,
    /// Per piece, its centroid on its leaf with the leaf's normal (world, m): where its own
    /// gather is evaluated.
    centres: Vec<Receiver>,
    /// The [`DIRECT_POINTS`] direct-light points of each piece that resolves the leaf's
    /// radiosity, piece by piece: where the caller evaluates the direct light
    /// ([`Interreflection::gather_near`]), whose mean is the piece's.
    pub points: Vec<Receiver>,
    /// True when some piece resolves the indirect light only.
    resolves_indirect: bool,
}

impl NearField {
    /// Number of pieces.
    pub fn len(&self) -> usize {
        self.pieces.len()
    }

    /// True when some piece resolves the indirect light only: [`Interreflection::gather_near`]
    /// then reads the leaves' indirect irradiance.
    pub fn resolves_indirect(&self) -> bool {
        self.resolves_indirect
    }

    /// True when no receiver is near a leaf large for its distance or close to it.
    pub fn is_empty(&self) -> bool {
        self.pieces.is_empty()
    }
}

impl Interreflection {
    /// The pieces of the leaves near each of `receivers` (module doc).
    pub fn near_field(&self, receivers: &[Receiver]) -> NearField {
        let per_receiver: Vec<Vec<(Piece, PatchPiece)>> =
            receivers.par_iter().map(|rx| self.near_pieces(rx)).collect();
        let tree = &self.operator.tree;
        let mut near = NearField {
            starts: vec![0],
            ..NearField::default()
        };
        for pieces in per_receiver {
            for (piece, patch_piece) in pieces {
                let normal = tree.nodes[tree.leaf_node[piece.leaf as usize] as usize].normal;
                let on_leaf = |point| Receiver { point, normal };
                near.pieces.push(piece);
                near.centres.push(on_leaf(patch_piece.centroid()));
                match piece.resolves {
                    Resolves::Radiosity => {
                        let points: [DVec3; DIRECT_POINTS] = patch_piece.quarter_centres();
                        near.points.extend(points.map(on_leaf));
                    }
                    Resolves::Indirect => near.resolves_indirect = true,
                }
            }
            near.starts.push(near.pieces.len() as u32);
        }
        near
    }

    /// The visible pieces of the leaves near `rx`, each with its part of its leaf.
    fn near_pieces(&self, rx: &Receiver) -> Vec<(Piece, PatchPiece)> {
        let tree = &self.operator.tree;
        let (p, n) = (rx.point + rx.normal * RECEIVER_LIFT_M, rx.normal);
        let mut out = Vec::new();
        let mut scratch = Vec::with_capacity(6);
        let mut stack = tree.roots.clone();
        while let Some(i) = stack.pop() {
            let node = &tree.nodes[i as usize];
            // A leaf below is at most the node's diameter in size.
            let gap = p.distance(p.clamp(node.lo, node.hi));
            let reach = (NEAR_SHARE * node.diameter).max(close_reach(node.diameter));
            if gap >= reach || !node.seen_from(p, n) {
                continue;
            }
            if !node.is_leaf() {
                stack.extend(node.children);
                continue;
            }
            let leaf = node.leaf;
            let target = &self.geometry.targets[leaf as usize];
            let Some(what) = resolves(gap, target.size, self.solver.in_slot[leaf as usize]) else {
                continue;
            };
            target.pieces_toward(p, PIECE_ACCEPT, PIECE_DEPTH, |patch_piece| {
                let f = point_to_polygon_with(p, n, patch_piece.corners(), &mut scratch);
                let lifted = patch_piece.centroid() + node.normal * RECEIVER_LIFT_M;
                let visible = self.occluders.as_ref().is_none_or(|o| o.visible(p, lifted));
                if f > 0.0 && visible {
                    let piece = Piece {
                        leaf,
                        form_factor: f,
                        resolves: what,
                    };
                    out.push((piece, *patch_piece));
                }
            });
        }
        out
    }

    /// [`Self::gather`] at `receivers` with the near field `near` (made by
    /// [`Self::near_field`] for these receivers) resolved: `direct` is the direct irradiance
    /// (lx, linear RGB, colour applied) at `near.points` in the state the leaves' radiosity
    /// `radiosity` was solved for, and `leaf_indirect` the leaves' indirect irradiance `H − E`
    /// in that state (lx, linear RGB, colour applied; read only when
    /// [`NearField::resolves_indirect`], and may be empty otherwise).
    pub fn gather_near(
        &self,
        radiosity: &[[f64; 3]],
        leaf_indirect: &[[f64; 3]],
        receivers: &[Receiver],
        near: &NearField,
        direct: &[[f64; 3]],
    ) -> Vec<[f64; 3]> {
        assert_eq!(
            near.starts.len(),
            receivers.len() + 1,
            "a near field of these receivers"
        );
        assert_eq!(
            direct.len(),
            near.points.len(),
            "direct light at every radiosity piece's points"
        );
        assert!(
            !near.resolves_indirect() || leaf_indirect.len() == radiosity.len(),
            "the leaves' indirect irradiance for the pieces that resolve it"
        );
        let prepared = self.prepare_gather(radiosity);
        let mut gathered = self.gather_prepared(&prepared, receivers, self.options.gather_doubt);
        if near.is_empty() {
            return gathered;
        }
        let at_pieces = self.gather_prepared(&prepared, &near.centres, PIECE_DOUBT);
        let tree = &self.operator.tree;
        let channels = self.reflectance.len();
        // Per piece: what it reflects where it lies, less what the leaf's solve gave there.
        let mut direct = direct.chunks_exact(DIRECT_POINTS);
        let residual: Vec<[f64; 3]> = near
            .pieces
            .iter()
            .zip(&near.centres)
            .zip(&at_pieces)
            .map(|((piece, centre), g)| {
                let leaf = piece.leaf as usize;
                let rho = |ch: usize| self.reflectance[ch.min(channels - 1)][leaf];
                if piece.resolves == Resolves::Indirect {
                    return std::array::from_fn(|ch| rho(ch) * (g[ch] - leaf_indirect[leaf][ch]));
                }
                let d = direct
                    .next()
                    .expect("direct values at every radiosity piece's points");
                let d: [f64; 3] =
                    std::array::from_fn(|ch| d.iter().map(|v| v[ch]).sum::<f64>() / DIRECT_POINTS as f64);
                let centroid = tree.nodes[tree.leaf_node[leaf] as usize].centroid;
                let slopes = prepared.linear.as_ref().map(|l| l.slopes(leaf));
                std::array::from_fn(|ch| {
                    let model =
                        radiosity[leaf][ch] + slopes.map_or(0.0, |s| s[ch].dot(centre.point - centroid));
                    rho(ch) * (d[ch] + g[ch]) - model
                })
            })
            .collect();
        for (r, e) in gathered.iter_mut().enumerate() {
            let pieces = near.starts[r] as usize..near.starts[r + 1] as usize;
            for (piece, res) in near.pieces[pieces.clone()].iter().zip(&residual[pieces]) {
                for ch in 0..3 {
                    e[ch] += piece.form_factor * res[ch];
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

    /// Asserts that the form factors of the pieces of `leaf` among `pieces`, seen from `rx`, sum
    /// to the leaf's exact factor (the contour integral is additive over a partition).
    fn assert_pieces_tile_leaf<'a>(
        engine: &Interreflection,
        pieces: impl IntoIterator<Item = &'a Piece>,
        leaf: u32,
        rx: &Receiver,
    ) {
        let p = rx.point + rx.normal * RECEIVER_LIFT_M;
        let sum: f64 = pieces
            .into_iter()
            .filter(|piece| piece.leaf == leaf)
            .map(|piece| piece.form_factor)
            .sum();
        let corners = engine.geometry.targets[leaf as usize].corners();
        let whole = point_to_polygon(p, rx.normal, corners);
        assert!(
            (sum - whole).abs() <= 1e-9 * whole,
            "leaf {leaf}: {sum} vs {whole}"
        );
    }

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
        let mut leaves: Vec<u32> = near.pieces.iter().map(|piece| piece.leaf).collect();
        leaves.dedup();
        for leaf in leaves {
            let node = &engine.operator.tree.nodes[engine.operator.tree.leaf_node[leaf as usize] as usize];
            assert_eq!(node.normal, DVec3::Y, "only the wall y = 0 is near");
            assert_pieces_tile_leaf(&engine, &near.pieces, leaf, &beside);
        }
        // The pieces nearest the receiver are the smallest.
        let nearest = near
            .centres
            .iter()
            .map(|q| q.point.distance(p))
            .fold(f64::INFINITY, f64::min);
        assert!(nearest < 0.03, "{nearest}");
    }

    /// Which leaves a receiver resolves: within half a leaf's size its radiosity; past that,
    /// within 10 cm and 1.5 times its size, its indirect light (not in a slot); else nothing.
    #[test]
    fn close_leaves_resolve_their_indirect_light() {
        assert_eq!(resolves(0.01, 0.04, false), Some(Resolves::Radiosity));
        assert_eq!(resolves(0.01, 0.04, true), Some(Resolves::Radiosity));
        assert_eq!(resolves(0.03, 0.04, false), Some(Resolves::Indirect));
        assert_eq!(resolves(0.03, 0.04, true), None);
        assert_eq!(resolves(0.07, 0.04, false), None, "beyond 1.5 sizes");
        assert_eq!(resolves(0.3, 1.0, false), Some(Resolves::Radiosity));
        assert_eq!(resolves(0.09, 0.1, false), Some(Resolves::Indirect));
        assert_eq!(resolves(0.11, 0.1, false), None, "beyond 10 cm");
    }

    /// A receiver on a box face 3 cm above the graded floor beside it: some floor leaves are
    /// close enough to have their indirect light resolved, only the pieces resolving radiosity
    /// have a direct-light point, and the indirect pieces tile their leaves too.
    #[test]
    fn a_box_face_above_graded_floor_strips_resolves_their_indirect_light() {
        let scene = crate::scene::load::test_room(
            r#"version = 1
[room]
size = [4.0, 3.0, 2.5]
[room.reflectance]
floor = 0.3
walls = 0.6
ceiling = 0.8
[[box]]
min = [1.0, 1.0, 0.0]
max = [2.0, 2.0, 0.8]
reflectance = 0.5
[[light]]
name = "l"
position = [3.0, 1.5, 2.0]
lid = [[0, 800], [180, 100]]
[settings]
patch_size = 0.1
solver_patch_size = 0.5
"#,
        );
        let engine = Interreflection::build(&scene, 1, true, &InterreflectionOptions::default()).unwrap();
        let face = Receiver {
            point: DVec3::new(2.0, 1.5, 0.03),
            normal: DVec3::X,
        };
        let near = engine.near_field(&[face]);
        let indirect: Vec<&Piece> = near
            .pieces
            .iter()
            .filter(|p| p.resolves == Resolves::Indirect)
            .collect();
        assert!(!indirect.is_empty(), "{} pieces, none indirect", near.len());
        assert!(near.resolves_indirect());
        assert_eq!(near.points.len(), DIRECT_POINTS * (near.len() - indirect.len()));
        let p = face.point + face.normal * RECEIVER_LIFT_M;
        let mut leaves: Vec<u32> = indirect.iter().map(|piece| piece.leaf).collect();
        leaves.dedup();
        for leaf in leaves {
            let node = &engine.operator.tree.nodes[engine.operator.tree.leaf_node[leaf as usize] as usize];
            assert_eq!(node.normal, DVec3::Z, "floor leaves");
            let target = &engine.geometry.targets[leaf as usize];
            let gap = p.distance(p.clamp(node.lo, node.hi));
            assert!(gap >= NEAR_SHARE * target.size && gap < close_reach(target.size));
            assert_pieces_tile_leaf(&engine, indirect.iter().copied(), leaf, &face);
        }
    }
}
