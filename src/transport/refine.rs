//! Graded refinement of the solver mesh (docs/DECISIONS.md "Interreflection"): the coarse patches
//! of a scene are split where a piecewise-constant radiosity would miss what matters for the
//! indirect light next to them.
//!
//! * **Near lights**: a patch is halved across its longer side while that side exceeds
//!   `lamp_ratio ×` its distance to a light in front of it (down to `lamp_min_m`, or to the
//!   light's distance when it is nearer). A lamp hung 0.2 m below a ceiling lights a hot spot
//!   of a few decimetres there, which acts as a second source for everything around it; a
//!   0.5 m patch would smear it, and a 3 cm patch the spot of a puck 1 cm above a desk.
//! * **Along box contacts**: where a box stands on the floor (or on another box, or against a
//!   wall or the ceiling), the patches of the supporting surface and of the box's faces that meet
//!   along the contact edge are halved across the edge while their width across it exceeds
//!   `contact_ratio ×` their distance to it, down to strips of `contact_min_m`. Light next to a
//!   contact changes over centimetres (the dark strip of a box face by the floor, the floor in the
//!   box's shadow), along the edge only over the box's size, so the strips are anisotropic (a strip
//!   at most `CONTACT_ASPECT` = 4 times as long as its far side's distance to the edge). A strip
//!   near a box's contact edge that a light edge crosses — a shadow line (the box's own shadow
//!   next to its base, a few centimetres wide beside a bright pool) or a beam's cut-off (a
//!   spot's edge over a picture frame's top) of the direct light of all the lights together —
//!   is halved further across the edge, down to `shadow_min_m`; one that a beam's cut-off
//!   crosses is halved along it too while longer than `LIGHT_EDGE_LENGTH` times its far side's
//!   distance to the edge, and its direct light is sampled finely ([`SolverMesh::beam_edge`]).
//!   The room's own edges near a light hung close to a room surface (a wall-washer under the
//!   ceiling) are graded the same way, without the light-edge rule.
//! * **Along room edges where the direct light bends**: the pieces of the room's own edges
//!   where the direct light on either surface next to them is far from linear across a coarse
//!   patch, or steep beside a surface left dark ([`crate::transport::room_edges`]: a pool ending
//!   by a wall, a lamp's horizon under the ceiling, a batwing lighting the walls' tops) are
//!   graded like contacts down to strips of `room_edge_min_m`, up to `ROOM_EDGE_ASPECT` times as
//!   long as their distance to the edge.
//! * **In slots**: a box face standing up to `slot_max_m` off a parallel room surface (a
//!   sideboard 5 cm in front of a wall), or off the facing face of another box (two cupboards
//!   side by side) lets light into the slot only at its outline, and that
//!   light fades over a few slot widths. Both sides — the room surface and the box face — are
//!   graded along the face's outline like a contact (their distance to it counted with the gap
//!   added) and meshed over the slot no coarser than twice the gap; where a light's shadow line
//!   crosses the slot (the lit band on the wall below the box's top edge, from which the rest
//!   of the slot is lit), the cells are halved across it down to `shadow_min_m`.
//! * **Along OBJ contacts**: where an OBJ mesh stands on a room surface, a box or another OBJ
//!   mesh (its triangles' edges lying on one, in any direction), the cells of that surface and
//!   the meshes' triangles are cut in strips by the boxes' rule ([`strip_cut`]) beside an edge
//!   along a cell's side or flat to a triangle's plane, and halved across their longer side
//!   beside a turned or steep one, down to `contact_min_m`; a cell an edge runs through along
//!   one of its sides is first cut on it; a strip that a shadow line or a beam's cut-off
//!   crosses is split across it by the light-edge rule. The room surface's cells the mesh
//!   covers (the floor under a plinth), the mesh's faces against a room surface (its
//!   underside) and those inside another of its blocks are left out of the solve
//!   (docs/DECISIONS.md "OBJ contacts graded in strips", "OBJ faces against the room or inside
//!   another block", "OBJ things on OBJ furniture").
//!
//! Splits are binary and axis-aligned on the room's and boxes' rectangles (so leaves stay
//! rectangles of one surface); OBJ triangles are split 1 → 4 by edge midpoints near lights and
//! cut in two or three triangles across a direction beside contacts ([`halve_triangle`]).
//! Leaves keep the surface of their coarse patch; vertices are shared within a surface where they
//! coincide (T-junctions are allowed). World frame: metres, z up.

use std::collections::HashMap;

use glam::DVec3;
use rayon::prelude::*;

use crate::scene::mesher::AxisRect;
use crate::scene::{Aabb, Light, Patch, PatchMesh, Scene, SurfaceKind};
use crate::transport::mesh_contacts::MeshContacts;
use crate::transport::occlusion::Occluders;
use crate::transport::room_edges::{BendingPiece, bending_edge_pieces};
use crate::transport::visibility::Visibility;

/// How the solver mesh is graded. `Default` is what the bake uses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefineOptions {
    /// Halve a patch while its longer side exceeds this many times its distance to a light in
    /// front of it; 0 turns the rule off. Default 0.5.
    pub lamp_ratio: f64,
    /// Shortest side (m) the light rule makes near a light farther than this from the patch;
    /// a nearer light (a puck 1 cm above a desk) takes the patches down to its distance, not
    /// below [`LAMP_MIN_FLOOR_M`] ([`RefineOptions::lamp_min_for`]). Default 0.03 m.
    pub lamp_min_m: f64,
    /// Halve a patch across a box contact edge while its width across the edge exceeds this
    /// many times its distance to the edge; 0 turns the rule off. Default 0.5.
    pub contact_ratio: f64,
    /// Narrowest strip (m) along a contact edge (a strip is halved while wider than twice this).
    /// Default 0.015 m.
    pub contact_min_m: f64,
    /// A strip along a box's contact edge that a light edge crosses (a shadow line or a beam's
    /// cut-off: some points of the strip are lit and others not) is halved across the edge
    /// while wider than twice this (m), and, for a beam's cut-off, along it while longer than
    /// twice this; a slot's cell across a light edge through it while wider than
    /// `SLOT_LIGHT_EDGE_FACTOR` times this; 0 turns both off. Default 0.005 m.
    pub shadow_min_m: f64,
    /// A box face up to this far (m) from a parallel room surface, and not touching it, makes a
    /// slot: the room surface behind it is graded along the face's outline as along a contact
    /// edge, the distance to the outline counted with the gap added (so the strips there stay
    /// about half the gap wide), and both sides of the slot are meshed no coarser than twice the
    /// gap (docs/DECISIONS.md "Slots behind furniture", "Slots up to 0.6 m"); 0 turns it off.
    /// Default 0.6 m.
    pub slot_max_m: f64,
    /// Pieces of the room's own edges (floor, ceiling and walls meeting) where the direct light
    /// next to them bends are graded like contact edges down to strips of this width (m; a strip
    /// is halved while wider than twice this), without the shadow rule and up to
    /// `ROOM_EDGE_ASPECT` times as long as far from the edge (docs/DECISIONS.md "Room edges are
    /// graded where the direct light bends"); 0 turns it off. Default 0.1 m.
    pub room_edge_min_m: f64,
}

/// The shortest side (m) the light rule makes for a light nearer a patch than
/// [`RefineOptions::lamp_min_m`] (docs/DECISIONS.md "Patches near a lamp almost touching
/// them"): 5 mm, a sixth of the usual 3 cm.
pub const LAMP_MIN_FLOOR_M: f64 = 0.005;

impl RefineOptions {
    /// The shortest side (m) the light rule makes near a light `distance_m` from the patch:
    /// `lamp_min_m`, or the distance when the light is nearer, not below
    /// [`LAMP_MIN_FLOOR_M`] (nor above `lamp_min_m`). A lamp 1 cm above a desk pours half its
    /// light within 2 cm of its foot, and that spot lights the wall 15 cm away as a second
    /// source whose place, to a few millimetres, sets how much: 3 cm patches smear it.
    pub fn lamp_min_for(&self, distance_m: f64) -> f64 {
        self.lamp_min_m.min(distance_m.max(LAMP_MIN_FLOOR_M))
    }
}

impl Default for RefineOptions {
    fn default() -> Self {
        // docs/ACCURACY.md "After": the finest grading measured; the reference rooms' worst
        // errors beside boxes fall from 5.7 % (ratios 1, 6 cm strips) to 3.4 %.
        RefineOptions {
            lamp_ratio: 0.5,
            lamp_min_m: 0.03,
            contact_ratio: 0.5,
            contact_min_m: 0.015,
            shadow_min_m: 0.005,
            slot_max_m: 0.6,
            room_edge_min_m: 0.1,
        }
    }
}

impl RefineOptions {
    /// No refinement at all: the solver mesh is the coarse mesh.
    pub fn none() -> Self {
        RefineOptions {
            lamp_ratio: 0.0,
            contact_ratio: 0.0,
            shadow_min_m: 0.0,
            slot_max_m: 0.0,
            room_edge_min_m: 0.0,
            ..RefineOptions::default()
        }
    }
}

/// What the refinement did near one light.
#[derive(Debug, Clone, PartialEq)]
pub struct LampRefinement {
    /// The light's index in the scene.
    pub light: usize,
    /// Distance (m) to the nearest room or box surface in front of it, and that surface's name.
    pub distance_m: f64,
    pub surface: String,
    /// Coarse patches split because of this light, and the leaves they became.
    pub patches_split: usize,
    pub leaves: usize,
}

/// The graded solver mesh.
#[derive(Debug, Clone)]
pub struct SolverMesh {
    /// The leaves (patches the interreflection is solved on).
    pub mesh: PatchMesh,
    /// Per leaf, the coarse patch it came from.
    pub coarse_patch: Vec<u32>,
    /// Per leaf, true when no cluster holding it may be linked as a whole: it was split off
    /// because a light is close (its direct light can be a hot spot that must not be averaged
    /// with its surroundings), or it lies in a slot (dark beside lit neighbours, whose
    /// cluster's one irradiance would light it; docs/DECISIONS.md "Slots behind furniture").
    pub alone: Vec<bool>,
    /// Per leaf, true when it lies in a slot: its partly visible links are refined further
    /// ([`crate::transport::links::LinkOptions::slot_visibility_refine`]) and its links are not
    /// relaxed with distance ([`crate::transport::links::LinkOptions::eta_far`]).
    pub in_slot: Vec<bool>,
    /// Per leaf, true when a light's beam edge (a hard cut-off of its curve) runs through it
    /// beside a contact, where the light-edge rule split it: its direct light is sampled in
    /// pieces no longer than [`crate::transport::patchdirect::BEAM_EDGE_PIECE`] of its shorter
    /// side (docs/DECISIONS.md "Light edges beside contacts").
    pub beam_edge: Vec<bool>,
    /// Per light that caused splits, what it did.
    pub lamps: Vec<LampRefinement>,
    /// Edges where OBJ meshes stand on room surfaces, the leaves made along them (beyond the
    /// coarse patches they replaced), and the room-surface leaves left out as covered by a mesh.
    pub mesh_contacts: usize,
    pub mesh_contact_leaves_added: usize,
    pub covered_leaves: usize,
    /// Contact edges graded towards (where a box meets its support, and room edges beside a
    /// lamp close to them), and the leaves made along them (beyond the coarse patches they
    /// replaced).
    pub contacts: usize,
    pub contact_leaves_added: usize,
    /// Slots graded: box faces standing up to [`RefineOptions::slot_max_m`] off a room surface
    /// or another box
    /// (both sides meshed along the face's outline and over it; their leaves are counted in
    /// `contact_leaves_added`).
    pub slots: usize,
    /// The slot distance it was graded with (for the notes).
    pub slot_max_m: f64,
    /// Pieces of the room's own edges graded towards (about one coarse patch long each, where
    /// the direct light next to them bends), the option they were graded with
    /// ([`RefineOptions::room_edge_min_m`], m), and
    /// the leaves made along them (beyond the coarse patches they replaced; patches a light or a
    /// contact split too are counted there).
    pub room_edges: usize,
    pub room_edge_min_m: f64,
    pub room_edge_leaves_added: usize,
}

impl SolverMesh {
    /// One line per refinement decision, for the plan ("refined near light L0: 0.20 m below
    /// the ceiling", "graded along 4 contact edges"); empty when nothing was refined.
    pub fn notes(&self, scene: &Scene) -> Vec<String> {
        let mut notes: Vec<String> = self
            .lamps
            .iter()
            .map(|l| {
                format!(
                    "refined near light {}: {:.2} m from the {}; {} coarse patches → {} patches",
                    scene.lights[l.light].name, l.distance_m, l.surface, l.patches_split, l.leaves
                )
            })
            .collect();
        if self.contacts + self.slots > 0 && self.contact_leaves_added > 0 {
            let slots = if self.slots > 0 {
                format!(
                    " and {} slots (box faces or OBJ undersides standing up to {:.2} m off a room surface or another box)",
                    self.slots, self.slot_max_m
                )
            } else {
                String::new()
            };
            notes.push(format!(
                "graded along {} contact edges (boxes on their supports, room edges beside lamps){slots}: +{} patches",
                self.contacts, self.contact_leaves_added
            ));
        }
        let beam_edge = self.beam_edge.iter().filter(|&&b| b).count();
        if beam_edge > 0 {
            notes.push(format!(
                "sampled {beam_edge} patches beside contacts finely in their direct light, where a beam's hard edge crosses them"
            ));
        }
        if self.room_edges > 0 && self.room_edge_leaves_added > 0 {
            notes.push(format!(
                "graded along {} pieces of the room's edges where the light next to them (direct, or from a lamp's spot on a surface it almost touches) bends, or steps beside a dark surface (strips at most {:.2} m wide at the edge, half that beside narrow pools): +{} patches",
                self.room_edges,
                2.0 * self.room_edge_min_m,
                self.room_edge_leaves_added
            ));
        }
        if self.mesh_contacts > 0 {
            notes.push(format!(
                "graded along {} OBJ contact edges (meshes on room surfaces): +{} patches, {} covered patches left out",
                self.mesh_contacts, self.mesh_contact_leaves_added, self.covered_leaves
            ));
        }
        notes
    }
}

/// A contact edge: an axis-aligned segment where a box meets a supporting surface, or where the
/// outline of a box face standing a little off a room surface falls on that surface (a slot).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Contact {
    /// The segment as a degenerate box (zero extent in two axes).
    segment: Aabb,
    /// Width (m) of the slot between the box face and the room surface; 0 for a contact.
    gap: f64,
    /// What meets there.
    kind: EdgeKind,
    /// Cells closer to the edge than its length are split along it while longer than this
    /// (m): a piece of room edge whose direct light bends along it; infinite otherwise.
    max_length: f64,
}

/// Contact edges or slots filed by the axis planes they lie in, for the few near a cell: a room
/// of many boxes has thousands of contacts and slots on its floor, and every floor cell looked
/// at each of them.
#[derive(Default)]
struct PlaneIndex {
    /// Per axis `a`: `(the plane's coordinate on a, the item's low end on (a + 1) % 3, index)`,
    /// sorted.
    planes: [Vec<(f64, f64, u32)>; 3],
    /// Per axis `a`: the largest extent along `(a + 1) % 3` of an item filed there.
    longest: [f64; 3],
}

impl PlaneIndex {
    /// Files item `index` in the plane `axis` = `offset`, spanning `lo`–`hi` (m).
    fn file(&mut self, axis: usize, offset: f64, lo: &DVec3, hi: &DVec3, index: usize) {
        let b = (axis + 1) % 3;
        self.planes[axis].push((offset, lo[b], index as u32));
        self.longest[axis] = self.longest[axis].max(hi[b] - lo[b]);
    }

    /// Sorts what was filed; call before [`Self::near`].
    fn sorted(mut self) -> Self {
        for list in &mut self.planes {
            list.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.total_cmp(&y.1)));
        }
        self
    }

    /// Appends to `out` the items filed in the plane `axis` = `offset` (within 1e-9 m, the
    /// tolerance of the tests that use them) that reach within `reach` (m) of `bounds` along
    /// `(axis + 1) % 3` (an item may come twice if filed twice).
    fn near(&self, axis: usize, offset: f64, bounds: &Aabb, reach: f64, out: &mut Vec<usize>) {
        let list = &self.planes[axis];
        let b = (axis + 1) % 3;
        let (from, to) = (bounds.min[b] - reach - self.longest[axis], bounds.max[b] + reach);
        let start = list.partition_point(|e| e.0 < offset - 1e-9);
        let end = list.partition_point(|e| e.0 <= offset + 1e-9);
        // One run per distinct coordinate in the range (almost always one), sorted along b.
        let mut run = start;
        while run < end {
            let at = list[run].0;
            let run_end = run + list[run..end].partition_point(|e| e.0 == at);
            let lo = run + list[run..run_end].partition_point(|e| e.1 < from);
            let hi = run + list[run..run_end].partition_point(|e| e.1 <= to);
            out.extend(list[lo..hi].iter().map(|e| e.2 as usize));
            run = run_end;
        }
    }
}

/// What a [`Contact`] edge is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum EdgeKind {
    /// A box meets its support (a room surface or another box): graded to `contact_min_m`,
    /// and where a light's edge runs beside it to `shadow_min_m`.
    Box,
    /// The outline of a box face standing off a room surface or another box (the contact's
    /// `gap`), on either side of the slot.
    Slot,
    /// One of the room's own edges near a light close to a room surface.
    NearLamp,
    /// A piece of the room's own edges where the direct light next to it bends, graded to
    /// [`RefineOptions::room_edge_min_m`].
    Bending,
}

/// A slot: a box face standing a little off a parallel room surface, or off the facing face of
/// another box (up to [`RefineOptions::slot_max_m`], not touching it); or an OBJ object's
/// triangles facing a room surface from as close.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Slot {
    /// The axis both surfaces face along, and the coordinates on it of the surface the box
    /// faces (a room surface or the other box's face) and of the box face (of an OBJ object,
    /// its facing triangles' nearest corner).
    axis: usize,
    room_side: f64,
    box_side: f64,
    /// The slot's extent on the other two axes (the box's, where the two boxes' faces overlap,
    /// or the bounds of the OBJ object's facing triangles).
    bounds: Aabb,
    /// True under an OBJ object: only the room surface's side is meshed as a slot (the
    /// object's triangles are not cells of the mesher).
    from_mesh: bool,
}

impl Slot {
    /// The coordinates (on its axis) of the sides meshed as a slot: the room surface's, and a
    /// box face's.
    fn sides(&self) -> impl Iterator<Item = f64> {
        std::iter::once(self.room_side).chain((!self.from_mesh).then_some(self.box_side))
    }

    /// Width (m) between the box face and the room surface.
    fn gap(&self) -> f64 {
        (self.box_side - self.room_side).abs()
    }

    /// The box between the box face and the room surface, within the face's outline.
    fn volume(&self) -> Aabb {
        let mut lo = self.bounds.min;
        let mut hi = self.bounds.max;
        lo[self.axis] = self.room_side.min(self.box_side);
        hi[self.axis] = self.room_side.max(self.box_side);
        Aabb { min: lo, max: hi }
    }

    /// Whether `p` lies in the slot (between the box face and the room surface, within the
    /// face's outline, boundaries included).
    fn contains(&self, p: DVec3) -> bool {
        let v = self.volume();
        (p.cmpge(v.min - 1e-9) & p.cmple(v.max + 1e-9)).all()
    }

    /// Whether `cell` lies on either side of the slot and overlaps it.
    fn holds(&self, cell: &Cell) -> bool {
        let r = &cell.rect;
        let on_box_side = !self.from_mesh && (r.offset - self.box_side).abs() <= 1e-9;
        if r.axis != self.axis || ((r.offset - self.room_side).abs() > 1e-9 && !on_box_side) {
            return false;
        }
        let b = cell.bounds();
        (0..3)
            .filter(|&k| k != self.axis)
            .all(|k| b.min[k] < self.bounds.max[k] - 1e-9 && b.max[k] > self.bounds.min[k] + 1e-9)
    }
}

/// Three points on the edge of `cell` where in-plane coordinate `k` is `side` (at 1/6, 1/2 and
/// 5/6 along it), lifted 1 µm off the surface: where shadow lines are looked for.
fn edge_points(cell: &Cell, k: usize, side: f64) -> [DVec3; 3] {
    let r = &cell.rect;
    [1.0 / 6.0, 0.5, 5.0 / 6.0].map(|t| {
        let mut uv = [0.0; 2];
        uv[k] = side;
        uv[1 - k] = r.min[1 - k] + t * (r.max[1 - k] - r.min[1 - k]);
        r.point(uv[0], uv[1]) + r.normal() * 1e-6
    })
}

/// The points of `cell`'s two sides across its axis `k` (three on each, [`edge_points`]): the
/// lower side's first.
fn side_points(cell: &Cell, k: usize) -> Vec<DVec3> {
    [cell.rect.min[k], cell.rect.max[k]]
        .into_iter()
        .flat_map(|side| edge_points(cell, k, side))
        .collect()
}

/// Each face of box `b` with the room surface parallel to it: (axis, the box face's coordinate,
/// the room surface's coordinate), for a room of `size`.
fn faces_to_room(b: &Aabb, size: DVec3) -> impl Iterator<Item = (usize, f64, f64)> + '_ {
    (0..3).flat_map(move |axis| [(axis, b.min[axis], 0.0), (axis, b.max[axis], size[axis])])
}

/// Tolerance (m) below which a box face lies on a room surface, for a room of `size`.
fn touch_eps(size: DVec3) -> f64 {
    1e-9 * (1.0 + size.max_element())
}

/// Whether a face `gap` (m) off a parallel surface makes a slot: it does not touch it, and it
/// stands at most `slot_max_m` off, within the touch tolerance `eps` — a gap of `slot_max_m`
/// counts however the room's numbers round (3.0 − 2.4 is 0.6000000000000001).
fn slot_gap(gap: f64, slot_max_m: f64, eps: f64) -> bool {
    gap > eps && gap <= slot_max_m + eps
}

/// The slots of `scene`: box faces standing up to `slot_max_m` off a parallel room surface, and
/// pairs of box faces facing each other across a gap up to `slot_max_m` where they overlap.
fn slots(scene: &Scene, slot_max_m: f64) -> Vec<Slot> {
    let (size, eps) = (scene.room_size, touch_eps(scene.room_size));
    let to_room = scene
        .boxes
        .iter()
        .flat_map(|b| faces_to_room(b, size).map(move |face| (b, face)))
        .filter(|(_, (_, box_side, room_side))| slot_gap((box_side - room_side).abs(), slot_max_m, eps))
        .map(|(b, (axis, box_side, room_side))| Slot {
            axis,
            room_side,
            box_side,
            bounds: *b,
            from_mesh: false,
        });
    // Box `a`'s upper face on `axis` facing box `b`'s lower face.
    let between = scene.boxes.iter().flat_map(|a| {
        scene.boxes.iter().flat_map(move |b| {
            (0..3).filter_map(move |axis| {
                let gap = b.min[axis] - a.max[axis];
                let bounds = Aabb {
                    min: a.min.max(b.min),
                    max: a.max.min(b.max),
                };
                let overlaps = (0..3)
                    .filter(|&k| k != axis)
                    .all(|k| bounds.max[k] - bounds.min[k] > eps);
                (slot_gap(gap, slot_max_m, eps) && overlaps).then_some(Slot {
                    axis,
                    room_side: b.min[axis],
                    box_side: a.max[axis],
                    bounds,
                    from_mesh: false,
                })
            })
        })
    });
    to_room
        .chain(between)
        .chain(mesh_slots(scene, slot_max_m))
        .collect()
}

/// A triangle faces a room surface when its normal is within this cosine of the surface's
/// opposite.
const MESH_SLOT_FACING: f64 = 0.7;

/// The slots under OBJ objects: per object and room surface, the triangles facing that surface
/// ([`MESH_SLOT_FACING`]) whose corners all lie off it but within `slot_max_m` — a sofa's or
/// a cabinet's underside on short legs, the lower half of a round thing just above the floor —
/// as one slot over their bounds, as wide as their nearest corner's gap (docs/DECISIONS.md
/// "Slots under OBJ objects").
fn mesh_slots(scene: &Scene, slot_max_m: f64) -> Vec<Slot> {
    let (size, eps) = (scene.room_size, touch_eps(scene.room_size));
    // Per OBJ object, its slots against the room surfaces so far.
    let mut found: Vec<(u32, Slot)> = Vec::new();
    for (t, patch) in crate::transport::mesh_contacts::obj_triangles(scene) {
        for axis in 0..3 {
            // The room surface at 0 faces +axis, the one at the room's size −axis.
            for (room_side, toward) in [(0.0, 1.0), (size[axis], -1.0)] {
                if -patch.normal[axis] * toward < MESH_SLOT_FACING {
                    continue;
                }
                let gaps = t.map(|p| (p[axis] - room_side).abs());
                let near = gaps.iter().copied().fold(f64::INFINITY, f64::min);
                if !gaps.iter().all(|&g| slot_gap(g, slot_max_m, eps)) {
                    continue;
                }
                let bounds = Aabb {
                    min: t[0].min(t[1]).min(t[2]),
                    max: t[0].max(t[1]).max(t[2]),
                };
                let box_side = room_side + toward * near;
                let same = |(surface, slot): &&mut (u32, Slot)| {
                    *surface == patch.surface && slot.axis == axis && slot.room_side == room_side
                };
                match found.iter_mut().find(same) {
                    Some((_, slot)) => {
                        slot.bounds = Aabb {
                            min: slot.bounds.min.min(bounds.min),
                            max: slot.bounds.max.max(bounds.max),
                        };
                        if near < slot.gap() {
                            slot.box_side = box_side;
                        }
                    }
                    None => found.push((
                        patch.surface,
                        Slot {
                            axis,
                            room_side,
                            box_side,
                            bounds,
                            from_mesh: true,
                        },
                    )),
                }
            }
        }
    }
    found.into_iter().map(|(_, slot)| slot).collect()
}

/// An axis-aligned rectangle cell of a surface, in its plane's `(u, v)` coordinates.
#[derive(Debug, Clone, Copy)]
struct Cell {
    rect: AxisRect,
}

impl Cell {
    fn extent(&self, k: usize) -> f64 {
        self.rect.max[k] - self.rect.min[k]
    }

    /// The cell as a flat 3D box.
    fn bounds(&self) -> Aabb {
        let a = self.rect.point(self.rect.min[0], self.rect.min[1]);
        let b = self.rect.point(self.rect.max[0], self.rect.max[1]);
        Aabb {
            min: a.min(b),
            max: a.max(b),
        }
    }

    fn halves(&self, k: usize) -> [Cell; 2] {
        self.cut(k, 0.5 * (self.rect.min[k] + self.rect.max[k]))
    }

    /// The two parts of the cell on either side of `at` along its axis `k`.
    fn cut(&self, k: usize, at: f64) -> [Cell; 2] {
        let mut lo = *self;
        let mut hi = *self;
        lo.rect.max[k] = at;
        hi.rect.min[k] = at;
        [lo, hi]
    }
}

/// Distance (m) between two axis-aligned boxes (0 when they touch or overlap).
fn box_distance(a: &Aabb, b: &Aabb) -> f64 {
    let gap = (a.min - b.max).max(b.min - a.max).max(DVec3::ZERO);
    gap.length()
}

/// Distance (m) from a point to an axis-aligned box.
fn point_box_distance(p: DVec3, b: &Aabb) -> f64 {
    p.distance(p.clamp(b.min, b.max))
}

/// An OBJ contact edge within this (1 − cosine) of one of a room cell's sides is graded towards
/// with strips along it; a turned one with squares.
const ALIGNED_EDGE_TOLERANCE: f64 = 1e-6;

/// An OBJ contact edge at most 60° to a triangle's plane (the cosine of the angle at least this)
/// is graded towards with strips along it; a steeper one (a sofa's upright corner against the
/// wall, seen from its seat) by cutting the triangle across its longest side, since the
/// distance to it grows about radially in the plane.
const FLAT_EDGE_COSINE: f64 = 0.5;

/// A strip along a contact edge is split along it while longer than this many times the
/// distance of its far side to the edge (its width, for a strip touching the edge).
const CONTACT_ASPECT: f64 = 4.0;

/// Which way the strip rule cuts a cell or triangle beside a contact edge.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum StripCut {
    /// Across the edge: the piece is wider than `ratio ×` its distance to it.
    Across,
    /// Along the edge: the piece is longer than `aspect ×` its far side's distance to it.
    Along,
}

/// The strip rule every contact grading shares: a piece `width` across an edge and `length`
/// along it, `distance` from it (its near side), is cut across while wider than `ratio ×` the
/// distance, else along while longer than `aspect ×` its far side's distance, never into
/// pieces narrower (shorter) than `min_m`.
fn strip_cut(
    width: f64,
    length: f64,
    distance: f64,
    ratio: f64,
    min_m: f64,
    aspect: f64,
) -> Option<StripCut> {
    if width > 2.0 * min_m && width > ratio * distance {
        Some(StripCut::Across)
    } else if length > 2.0 * min_m && length > aspect * (distance + width) {
        Some(StripCut::Along)
    } else {
        None
    }
}

/// A strip along one of the room's own edges is split along it while longer than this many times
/// the distance of its far side to the edge: the light on a room surface changes along its
/// edges slowly (over the room's and the lights' spacing), so the strips stay long
/// (docs/DECISIONS.md "Room edges are graded where the direct light bends").
const ROOM_EDGE_ASPECT: f64 = 8.0;

/// Where the direct light bends along a piece of room edge too (a pool narrower than the
/// piece), the cells within the piece's length of it are split along the edge while longer
/// than this fraction of the piece (docs/DECISIONS.md "Room edges are graded where the direct
/// light bends").
const ROOM_EDGE_ALONG_FRACTION: f64 = 0.125;

/// A piece of a room edge is graded where the direct light next to it bends enough to put the
/// indirect light a few centimetres from the edge off by this fraction of the room's indirect
/// irradiance (docs/DECISIONS.md "Room edges are graded where the direct light bends").
const ROOM_EDGE_TOLERANCE: f64 = 0.02;

/// A strip is split at a light's edge (a shadow line or a beam's cut-off) while it lies within
/// this many of its widths of the contact edge.
const SHADOW_REACH: f64 = 4.0;

/// A slot's cell is halved across a light edge through it while wider than this many times
/// `shadow_min_m` (2 cm): the strips of 1 cm that twice its factor at contacts makes put the
/// deep slot of the furniture-gaps reference room 3.1 % off instead of 2.4 %
/// (docs/DECISIONS.md "Light edges beside contacts").
const SLOT_LIGHT_EDGE_FACTOR: f64 = 4.0;

/// A strip along a contact edge that a light's edge crosses, once as narrow as the light-edge
/// rule makes it, is split along the edge while longer than this many times its far side's
/// distance to the edge: about the reach of the kernel of a receiver that far from the edge
/// (docs/DECISIONS.md "Light edges beside contacts").
const LIGHT_EDGE_LENGTH: f64 = 1.0;

/// A point of a cell is lit when its direct light, over what the lights' geometry alone makes
/// there, is at least this fraction of the largest such ratio among the points looked at in
/// the cell ([`Splitter::lit_points`]); a light edge runs through a cell when some of them are
/// lit and others not.
const LIGHT_EDGE_RATIO: f64 = 0.5;

/// A light this close (m) to a room surface grades the room's edges near it like box contacts
/// (a wall-washer's grazing light makes the wall/ceiling corner next to it change over
/// centimetres), within `CORNER_REACH_FACTOR ×` that distance (plus `CORNER_REACH_M`) of it.
const CORNER_LAMP_M: f64 = 0.5;
const CORNER_REACH_FACTOR: f64 = 6.0;
const CORNER_REACH_M: f64 = 0.3;

/// Which rule of [`Splitter::contact_axis`] split a cell.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Grading {
    /// Towards a contact edge: a box's, a slot's outline, or a room edge beside a lamp.
    Contact,
    /// Towards a piece of the room's own edges.
    RoomEdge,
    /// At a light's edge beside a contact.
    LightEdge,
}

/// What the recursive split of one rectangle made.
#[derive(Default)]
struct Split {
    /// The leaves, each with whether a light's beam edge runs through it
    /// ([`SolverMesh::beam_edge`]).
    leaves: Vec<(Cell, bool)>,
    /// The first light whose rule split it.
    lamp: Option<usize>,
    by_contact: bool,
    by_room_edge: bool,
    by_mesh_contact: bool,
    covered: usize,
}

/// What the recursive splits need.
struct Splitter<'a> {
    scene: &'a Scene,
    options: &'a RefineOptions,
    contacts: Vec<Contact>,
    /// The contacts by the planes their segments lie in, and those graded within their own
    /// length whatever a cell's size (finite `max_length`).
    contact_index: PlaneIndex,
    contacts_anywhere: Vec<usize>,
    slots: Vec<Slot>,
    /// The slots by the planes of their two sides, and by where their volumes start along x.
    slot_index: PlaneIndex,
    slots_by_x: SlotsByX,
    occluders: Option<Occluders>,
    mesh_contacts: Option<MeshContacts>,
}

/// The indices `near` (below `len`) each once, ascending: sorted when few, else through a bit
/// per index (sorting hundreds of candidates per cell cost more than testing them).
fn in_order(mut near: Vec<usize>, len: usize) -> Vec<usize> {
    if near.len() * 16 < len.max(64) {
        near.sort_unstable();
        near.dedup();
        return near;
    }
    let mut bits = vec![0u64; len.div_ceil(64)];
    for &i in &near {
        bits[i / 64] |= 1 << (i % 64);
    }
    near.clear();
    for (w, &word) in bits.iter().enumerate() {
        near.extend((0..64).filter(|b| word & (1 << b) != 0).map(|b| w * 64 + b));
    }
    near
}

/// The slots sorted by where their volumes start along x, for the slots that may hold a point
/// (a slot per gap between boxes; every leaf asks).
struct SlotsByX {
    /// `(volume's low x, index)`, sorted.
    starts: Vec<(f64, u32)>,
    /// The widest volume along x (m).
    widest: f64,
}

impl SlotsByX {
    fn new(slots: &[Slot]) -> Self {
        let mut starts: Vec<(f64, u32)> = slots
            .iter()
            .enumerate()
            .map(|(i, s)| (s.volume().min.x, i as u32))
            .collect();
        starts.sort_by(|a, b| a.0.total_cmp(&b.0));
        let widest = slots
            .iter()
            .map(|s| {
                let v = s.volume();
                v.max.x - v.min.x
            })
            .fold(0.0, f64::max);
        SlotsByX { starts, widest }
    }

    /// Whether any of `slots` ([`Slot::contains`]) holds `p`.
    fn any_contains(&self, slots: &[Slot], p: DVec3) -> bool {
        let from = self.starts.partition_point(|e| e.0 < p.x - self.widest - 1e-9);
        let to = self.starts.partition_point(|e| e.0 <= p.x + 1e-9);
        self.starts[from..to]
            .iter()
            .any(|&(_, i)| slots[i as usize].contains(p))
    }
}

/// The contacts by the planes their segments lie in (each segment lies in two).
fn contact_index(contacts: &[Contact]) -> PlaneIndex {
    let mut index = PlaneIndex::default();
    for (i, c) in contacts.iter().enumerate() {
        let seg = &c.segment;
        for a in (0..3).filter(|&a| seg.max[a] - seg.min[a] <= 2e-9) {
            index.file(a, seg.min[a], &seg.min, &seg.max, i);
        }
    }
    index.sorted()
}

/// The slots by the planes of their two sides (the cells [`Slot::holds`] lie in one).
fn slot_index(slots: &[Slot]) -> PlaneIndex {
    let mut index = PlaneIndex::default();
    for (i, slot) in slots.iter().enumerate() {
        for side in slot.sides() {
            index.file(slot.axis, side, &slot.bounds.min, &slot.bounds.max, i);
        }
    }
    index.sorted()
}

/// Refines the coarse mesh of `scene`.
pub fn refine(scene: &Scene, options: &RefineOptions) -> SolverMesh {
    let (contacts, slots) = if options.contact_ratio > 0.0 {
        let slots = slots(scene, options.slot_max_m);
        let room_edges = if options.room_edge_min_m > 0.0 {
            bending_edge_pieces(scene, scene.settings.solver_patch_size, ROOM_EDGE_TOLERANCE)
        } else {
            Vec::new()
        };
        (contact_edges(scene, &slots, &room_edges), slots)
    } else {
        (Vec::new(), Vec::new())
    };
    let splitter = Splitter {
        scene,
        options,
        occluders: ((!contacts.is_empty() || !scene.mesh_bounds.is_empty()) && options.shadow_min_m > 0.0)
            .then(|| Occluders::of_scene(scene))
            .flatten(),
        contact_index: contact_index(&contacts),
        contacts_anywhere: (0..contacts.len())
            .filter(|&i| contacts[i].max_length.is_finite())
            .collect(),
        contacts,
        slot_index: slot_index(&slots),
        slots_by_x: SlotsByX::new(&slots),
        slots,
        mesh_contacts: (options.contact_ratio > 0.0)
            .then(|| MeshContacts::of_scene(scene))
            .flatten(),
    };
    // The coarse patches split independently (in parallel); their leaves join the mesh in patch
    // order, so the result does not depend on the threads.
    let split: Vec<SplitPatch> = scene
        .coarse
        .patches
        .par_iter()
        .map(|patch| splitter.split_patch(patch))
        .collect();
    let mut out = Builder::default();
    let mut lamp_split = vec![(0usize, 0usize); scene.lights.len()];
    let (mut contact_added, mut mesh_contact_added, mut covered) = (0usize, 0usize, 0usize);
    let mut room_edge_added = 0usize;
    for (index, (patch, split)) in scene.coarse.patches.iter().zip(split).enumerate() {
        let near_lamp = split.lamp.is_some();
        covered += split.covered;
        let added = (split.leaves.len() + split.covered).saturating_sub(1);
        if let Some(light) = split.lamp {
            lamp_split[light].0 += 1;
            lamp_split[light].1 += split.leaves.len();
        } else if split.by_mesh_contact {
            mesh_contact_added += added;
        } else if split.by_contact {
            contact_added += added;
        } else if split.by_room_edge {
            room_edge_added += added;
        }
        match split.leaves {
            Leaves::Triangles(leaves) => {
                for tri in leaves {
                    out.triangle(patch, index, tri, near_lamp);
                }
            }
            Leaves::Rects(leaves) => {
                for (leaf, beam_edge) in &leaves {
                    let bounds = leaf.bounds();
                    let centre = (bounds.min + bounds.max) / 2.0;
                    let in_slot = splitter.slots_by_x.any_contains(&splitter.slots, centre);
                    out.rect(patch, index, leaf, near_lamp, in_slot, *beam_edge);
                }
            }
        }
    }
    let lamps = lamp_split
        .iter()
        .enumerate()
        .filter(|(_, s)| s.0 > 0)
        .map(|(light, &(patches_split, leaves))| {
            let (distance_m, surface) = nearest_surface(scene, scene.lights[light].position);
            LampRefinement {
                light,
                distance_m,
                surface,
                patches_split,
                leaves,
            }
        })
        .collect();
    SolverMesh {
        mesh: out.mesh,
        coarse_patch: out.coarse_patch,
        alone: out.alone,
        in_slot: out.in_slot,
        beam_edge: out.beam_edge,
        lamps,
        contacts: splitter
            .contacts
            .iter()
            .filter(|c| matches!(c.kind, EdgeKind::Box | EdgeKind::NearLamp))
            .count(),
        room_edges: splitter
            .contacts
            .iter()
            .filter(|c| c.kind == EdgeKind::Bending)
            .count(),
        room_edge_min_m: options.room_edge_min_m,
        room_edge_leaves_added: room_edge_added,
        slots: splitter.slots.len(),
        slot_max_m: options.slot_max_m,
        contact_leaves_added: contact_added,
        mesh_contacts: splitter.mesh_contacts.as_ref().map_or(0, MeshContacts::len),
        mesh_contact_leaves_added: mesh_contact_added,
        covered_leaves: covered,
    }
}

/// The nearest room surface or box face to `p` (distance, name).
fn nearest_surface(scene: &Scene, p: DVec3) -> (f64, String) {
    let s = scene.room_size;
    let mut best = [
        (p.z, "floor".to_string()),
        (s.z - p.z, "ceiling".to_string()),
        (p.x, "wall x = 0".to_string()),
        (s.x - p.x, "wall x = max".to_string()),
        (p.y, "wall y = 0".to_string()),
        (s.y - p.y, "wall y = max".to_string()),
    ]
    .into_iter()
    .min_by(|a, b| a.0.total_cmp(&b.0))
    .unwrap_or((f64::INFINITY, String::new()));
    for (i, b) in scene.boxes.iter().enumerate() {
        let d = point_box_distance(p, b);
        if d < best.0 {
            best = (d, format!("box {i}"));
        }
    }
    best
}

/// The cell of an axis-aligned quad patch.
fn cell_of(mesh: &PatchMesh, patch: &Patch) -> Cell {
    let axis = patch.normal.abs().max_position();
    let facing_positive = patch.normal[axis] > 0.0;
    let [u, v] = AxisRect::in_plane_axes(axis, facing_positive);
    let corners = patch.vertex_ids().iter().map(|&i| mesh.positions[i as usize]);
    let (lo, hi) = corners.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), q| {
        (lo.min(q), hi.max(q))
    });
    Cell {
        rect: AxisRect {
            axis,
            offset: patch.centroid[axis],
            facing_positive,
            min: [lo[u], lo[v]],
            max: [hi[u], hi[v]],
        },
    }
}

/// The leaves one coarse patch became.
enum Leaves {
    Triangles(Vec<[DVec3; 3]>),
    /// Each with whether a light's beam edge runs through it.
    Rects(Vec<(Cell, bool)>),
}

impl Leaves {
    fn len(&self) -> usize {
        match self {
            Leaves::Triangles(t) => t.len(),
            Leaves::Rects(r) => r.len(),
        }
    }
}

/// What the refinement made of one coarse patch.
struct SplitPatch {
    leaves: Leaves,
    /// The first light whose rule split it.
    lamp: Option<usize>,
    /// Split by the contact rules (and by no light).
    by_contact: bool,
    /// Split by the room-edge rule (and by no light nor contact).
    by_room_edge: bool,
    /// Split by the OBJ contact rule (and by no light).
    by_mesh_contact: bool,
    /// Leaves left out as covered by an OBJ mesh.
    covered: usize,
}

impl Splitter<'_> {
    /// Splits one coarse patch: OBJ and other triangles by the light rule only, axis-aligned
    /// quads by the light and contact rules.
    fn split_patch(&self, patch: &Patch) -> SplitPatch {
        let scene = self.scene;
        let surface = &scene.surfaces[patch.surface as usize];
        if matches!(surface.kind, SurfaceKind::Mesh { .. }) || patch.n_vertices != 4 {
            let corners = [0, 1, 2].map(|k| scene.coarse.positions[patch.vertices[k] as usize]);
            let contacts = self.mesh_contacts.as_ref();
            // A face against a room surface or a box, or inside another block of the furniture (the
            // seat under a sofa's back-rest), is left out whole before any rule splits it, and
            // so is each piece the rules make that is covered whole.
            let hidden = contacts.is_some_and(|c| {
                c.against_support(&corners, patch.normal) || triangle_covered(c, &corners, patch.normal)
            });
            if hidden {
                return SplitPatch {
                    leaves: Leaves::Triangles(Vec::new()),
                    lamp: None,
                    by_contact: false,
                    by_room_edge: false,
                    by_mesh_contact: false,
                    covered: 1,
                };
            }
            let (mut leaves, lamp, by_mesh_contact) = split_triangle(self, corners, patch);
            let before = leaves.len();
            // An unsplit triangle is the coarse one, already found not covered whole.
            if let Some(c) = contacts.filter(|_| before > 1) {
                leaves.retain(|t| !triangle_covered(c, t, patch.normal));
            }
            return SplitPatch {
                covered: before - leaves.len(),
                leaves: Leaves::Triangles(leaves),
                lamp,
                by_contact: false,
                by_room_edge: false,
                by_mesh_contact,
            };
        }
        let mut split = Split::default();
        self.split(cell_of(&scene.coarse, patch), false, &mut split);
        SplitPatch {
            leaves: Leaves::Rects(split.leaves),
            lamp: split.lamp,
            by_contact: split.by_contact,
            by_room_edge: split.by_room_edge,
            by_mesh_contact: split.by_mesh_contact,
            covered: split.covered,
        }
    }

    /// Splits a rectangle cell recursively (see the module docs), appending the leaves; a leaf
    /// an OBJ mesh covers is counted and left out. `light_edge`: the light-edge rule split the
    /// cell or one it came from, so a leaf it becomes is checked for a beam edge.
    fn split(&self, cell: Cell, light_edge: bool, out: &mut Split) {
        // A cell an OBJ mesh covers whole is left out before any rule splits it.
        if self.covered(&cell, true) {
            out.covered += 1;
            return;
        }
        // A cell an OBJ contact edge runs through is cut on it first (docs/DECISIONS.md "OBJ
        // things on OBJ furniture").
        if let Some((k, at)) = self.mesh_contact_line(&cell) {
            out.by_mesh_contact = true;
            for part in cell.cut(k, at) {
                self.split(part, light_edge, out);
            }
            return;
        }
        let mut light_edge = light_edge;
        let axis = self
            .lamp_axis(&cell, &mut out.lamp)
            .or_else(|| match self.contact_axis(&cell) {
                Some((axis, Grading::RoomEdge)) => {
                    out.by_room_edge = true;
                    Some(axis)
                }
                by_contact => {
                    light_edge |= matches!(by_contact, Some((_, Grading::LightEdge)));
                    let axis = by_contact.map(|(k, _)| k).or_else(|| self.slot_axis(&cell));
                    out.by_contact |= axis.is_some();
                    axis
                }
            })
            .or_else(|| {
                let by_mesh_contact = self.mesh_contact_axis(&cell);
                light_edge |= matches!(by_mesh_contact, Some((_, Grading::LightEdge)));
                out.by_mesh_contact |= by_mesh_contact.is_some();
                by_mesh_contact.map(|(k, _)| k)
            });
        match axis {
            None if self.covered(&cell, false) => out.covered += 1,
            None => {
                let beam_edge = light_edge && self.beam_edge_crosses(&cell);
                out.leaves.push((cell, beam_edge));
            }
            Some(k) => {
                for half in cell.halves(k) {
                    self.split(half, light_edge, out);
                }
            }
        }
    }

    /// True when an OBJ mesh covers the cell's centre, or with `whole` its centre and every
    /// corner (pulled 1 mm inside the cell).
    fn covered(&self, cell: &Cell, whole: bool) -> bool {
        let Some(contacts) = &self.mesh_contacts else {
            return false;
        };
        let r = &cell.rect;
        let at = |s: f64, k: usize| {
            let inset = (1e-3f64).min(0.5 * (r.max[k] - r.min[k]));
            (r.min[k] + s * (r.max[k] - r.min[k])).clamp(r.min[k] + inset, r.max[k] - inset)
        };
        let corners: &[(f64, f64)] = if whole {
            &[(0.5, 0.5), (0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
        } else {
            &[(0.5, 0.5)]
        };
        corners
            .iter()
            .all(|&(u, v)| contacts.covered(r.point(at(u, 0), at(v, 1)), r.normal()))
    }

    /// The cell's axis and coordinate on it of an OBJ contact edge running through it along one
    /// of its sides ([`MeshContacts::line_through`]).
    fn mesh_contact_line(&self, cell: &Cell) -> Option<(usize, f64)> {
        let contacts = self.mesh_contacts.as_ref()?;
        let (across, at) = contacts.line_through(cell.rect.axis, cell.rect.offset, &cell.bounds())?;
        let [u, v] = AxisRect::in_plane_axes(cell.rect.axis, cell.rect.facing_positive);
        let k = [u, v].iter().position(|&w| w == across)?;
        Some((k, at))
    }

    /// The axis to halve a cell of a room surface that an OBJ mesh stands on: beside a contact
    /// edge along one of the cell's sides (a sofa set square to the walls), by the strip rule
    /// of box contacts ([`strip_cut`]); beside a turned one, the longer side while the cell is
    /// larger than `contact_ratio ×` its distance to it (down to `contact_min_m`).
    fn mesh_contact_axis(&self, cell: &Cell) -> Option<(usize, Grading)> {
        let contacts = self.mesh_contacts.as_ref()?;
        let options = self.options;
        let near = contacts.nearest_to_cell(cell.rect.axis, cell.rect.offset, &cell.bounds())?;
        let [u, v] = AxisRect::in_plane_axes(cell.rect.axis, cell.rect.facing_positive);
        let along = [u, v]
            .iter()
            .position(|&k| near.direction[k].abs() > 1.0 - ALIGNED_EDGE_TOLERANCE);
        if let Some(along) = along {
            let across = 1 - along;
            let (width, length) = (cell.extent(across), cell.extent(along));
            let strip = strip_cut(
                width,
                length,
                near.distance,
                options.contact_ratio,
                options.contact_min_m,
                CONTACT_ASPECT,
            )
            .map(|cut| {
                (
                    if cut == StripCut::Across { across } else { along },
                    Grading::Contact,
                )
            });
            return strip
                .or_else(|| self.light_edge_axis(cell, across, near.distance, true, &mut None, &mut None));
        }
        let longer = if cell.extent(0) >= cell.extent(1) { 0 } else { 1 };
        (cell.extent(longer) > 2.0 * options.contact_min_m
            && cell.extent(longer) > options.contact_ratio * near.distance)
            .then_some((longer, Grading::Contact))
    }

    /// The longer side, when the cell is larger than `lamp_ratio ×` its distance to a light in
    /// front of it (recording the first such light).
    fn lamp_axis(&self, cell: &Cell, first_lamp: &mut Option<usize>) -> Option<usize> {
        let options = self.options;
        let longer = if cell.extent(0) >= cell.extent(1) { 0 } else { 1 };
        let extent = cell.extent(longer);
        // No light, however near, splits a cell this short (`lamp_min_for` grows with distance).
        if options.lamp_ratio <= 0.0 || extent <= 2.0 * options.lamp_min_for(0.0) {
            return None;
        }
        let bounds = cell.bounds();
        let normal = cell.rect.normal();
        let centre = (bounds.min + bounds.max) / 2.0;
        let (i, _) = self.scene.lights.iter().enumerate().find(|(_, light)| {
            let distance = point_box_distance(light.position, &bounds);
            normal.dot(light.position - centre) > 0.0
                && extent > options.lamp_ratio * distance
                && extent > 2.0 * options.lamp_min_for(distance)
        })?;
        first_lamp.get_or_insert(i);
        Some(longer)
    }

    /// The axis across a contact edge in the cell's plane, when the cell is wider across it than
    /// `contact_ratio ×` its distance to it, or the axis along it when it is too long for its
    /// distance; or either where a light's edge runs through it near the edge; with the rule
    /// that split it.
    fn contact_axis(&self, cell: &Cell) -> Option<(usize, Grading)> {
        let options = self.options;
        if options.contact_ratio <= 0.0 {
            return None;
        }
        let bounds = cell.bounds();
        let [ua, va] = AxisRect::in_plane_axes(cell.rect.axis, cell.rect.facing_positive);
        // The light-edge tests, once per cell (per axis across) whatever the contacts near it.
        let mut edge_across: [Option<bool>; 2] = [None; 2];
        let mut beam_edge: Option<bool> = None;
        // The farthest a rule below reaches from a cell this large: across while wider than
        // `contact_ratio ×` the distance, a light edge within `SHADOW_REACH` widths, along
        // while longer than the distance (`LIGHT_EDGE_LENGTH`; the strip rule's aspects reach
        // less); the pool rule, within a contact's own length, is the index's `anywhere`.
        let extent = cell.extent(0).max(cell.extent(1));
        let reach = extent
            * (1.0 / options.contact_ratio)
                .max(SHADOW_REACH)
                .max(1.0 / LIGHT_EDGE_LENGTH);
        let mut near = self.contacts_anywhere.clone();
        self.contact_index
            .near(cell.rect.axis, cell.rect.offset, &bounds, reach, &mut near);
        for contact in in_order(near, self.contacts.len())
            .into_iter()
            .map(|i| &self.contacts[i])
        {
            let seg = &contact.segment;
            // The contact must lie in the cell's plane.
            let a = cell.rect.axis;
            if (seg.min[a] - cell.rect.offset).abs() > 1e-9 || (seg.max[a] - cell.rect.offset).abs() > 1e-9 {
                continue;
            }
            // Across the edge: the in-plane axis along which the segment has no extent.
            let across = if (seg.max[ua] - seg.min[ua]).abs() < 1e-12 {
                0
            } else {
                1
            };
            let world_across = [ua, va][across];
            if (seg.max[world_across] - seg.min[world_across]).abs() > 1e-12 {
                continue;
            }
            let width = cell.extent(across);
            let distance = box_distance(&bounds, seg) + contact.gap;
            let bending = contact.kind == EdgeKind::Bending;
            let (min_m, aspect) = if bending {
                // A pool narrower than the piece changes over less than the piece's strips.
                let min_m = if contact.max_length.is_finite() {
                    0.5 * options.room_edge_min_m
                } else {
                    options.room_edge_min_m
                };
                (min_m, ROOM_EDGE_ASPECT)
            } else {
                (options.contact_min_m, CONTACT_ASPECT)
            };
            let grading = if bending {
                Grading::RoomEdge
            } else {
                Grading::Contact
            };
            let split = |k: usize| Some((k, grading));
            // A strip is kept within `CONTACT_ASPECT` times its far side's distance to the edge
            // along it: what it receives varies along the edge with the light and shadow on the
            // partner surface (a box face at the floor beside a pool that the box's shadow cuts),
            // and what it reflects lights the partner's strips, which the shadow rule below
            // makes short (docs/DECISIONS.md "Interreflection", "Contact strips short along the
            // edge").
            let length = cell.extent(1 - across);
            match strip_cut(width, length, distance, options.contact_ratio, min_m, aspect) {
                Some(StripCut::Across) => return split(across),
                Some(StripCut::Along) => return split(1 - across),
                None => {}
            }
            // A pool narrower than the piece: the cells beside it are short along the edge too.
            let reach = (seg.max - seg.min).max_element();
            if length > contact.max_length && distance < reach && length > 2.0 * min_m {
                return split(1 - across);
            }
            // The light-edge rule: a strip within a few of its widths of the edge that a
            // shadow line or a beam's cut-off crosses (the box's shadow beside its base, a
            // spot's edge over a box's top face against a wall) is halved across the edge,
            // where the nearest receivers still see it at a steep angle; one that a beam's
            // cut-off crosses is halved along the edge too while longer than
            // `LIGHT_EDGE_LENGTH ×` its far side's distance to it (docs/DECISIONS.md "Light
            // edges beside contacts").
            if contact.kind == EdgeKind::Box {
                let cut = self.light_edge_axis(
                    cell,
                    across,
                    distance,
                    false,
                    &mut edge_across[across],
                    &mut beam_edge,
                );
                if cut.is_some() {
                    return cut;
                }
            }
        }
        None
    }

    /// The light-edge rule beside a contact edge running along a cell's side (`across`: the axis
    /// across it; `distance` (m) to it): the axis across the edge when a shadow line or a beam's
    /// cut-off runs through the cell parallel to it and the cell is within `SHADOW_REACH` of its
    /// widths of the edge and wider than twice `shadow_min_m`; else the axis along the edge when
    /// a beam's cut-off (with `shadows_along`, any light edge) crosses the cell that way and it
    /// is longer than `LIGHT_EDGE_LENGTH ×` its far side's distance. The tests run once per cell
    /// (`edge_across`, `beam_edge` keep them). Beside an OBJ contact the shadows count along
    /// the edge too: nothing conforms the cells to an OBJ's outline, so a strip along its contact
    /// can run from the shadow a block casts into the light beside it (docs/DECISIONS.md "OBJ
    /// things on OBJ furniture").
    fn light_edge_axis(
        &self,
        cell: &Cell,
        across: usize,
        distance: f64,
        shadows_along: bool,
        edge_across: &mut Option<bool>,
        beam_edge: &mut Option<bool>,
    ) -> Option<(usize, Grading)> {
        if self.options.shadow_min_m <= 0.0 {
            return None;
        }
        let min_m = 2.0 * self.options.shadow_min_m;
        let (width, length) = (cell.extent(across), cell.extent(1 - across));
        if width > min_m
            && distance <= SHADOW_REACH * width
            && *edge_across.get_or_insert_with(|| self.light_edge_across(cell, across))
        {
            return Some((across, Grading::LightEdge));
        }
        (length > min_m
            && length > LIGHT_EDGE_LENGTH * (distance + width)
            && *beam_edge.get_or_insert_with(|| {
                if shadows_along {
                    self.light_edge_across(cell, 1 - across)
                } else {
                    self.beam_edge_crosses(cell)
                }
            }))
        .then_some((1 - across, Grading::LightEdge))
    }

    /// The longer side, when the cell lies in a slot (on either side) and is longer than twice
    /// the slot's width: the light a slot lets in fades over a few of its widths
    /// (docs/DECISIONS.md "Slots behind furniture"), never below strips of `contact_min_m`;
    /// otherwise the axis across a light edge through the slot cell, while wider than
    /// `SLOT_LIGHT_EDGE_FACTOR × shadow_min_m` (docs/DECISIONS.md "The shadow line in a slot").
    fn slot_axis(&self, cell: &Cell) -> Option<usize> {
        let longer = if cell.extent(0) >= cell.extent(1) { 0 } else { 1 };
        let extent = cell.extent(longer);
        let mut near = Vec::new();
        self.slot_index
            .near(cell.rect.axis, cell.rect.offset, &cell.bounds(), 0.0, &mut near);
        let mut slots = in_order(near, self.slots.len())
            .into_iter()
            .map(|i| &self.slots[i])
            .filter(|s| s.holds(cell))
            .peekable();
        slots.peek()?;
        if extent > 2.0 * self.options.contact_min_m && slots.any(|s| extent > 2.0 * s.gap()) {
            return Some(longer);
        }
        // The box's shadow line on the room surface in the slot (the lit band below the box's
        // top edge): everything deeper in the slot is lit from that band, so a cell smearing it
        // would carry its light too deep.
        let shadow_min = self.options.shadow_min_m;
        if shadow_min <= 0.0 {
            return None;
        }
        self.shadow_line_axis(cell)
            .filter(|&k| cell.extent(k) > SLOT_LIGHT_EDGE_FACTOR * shadow_min)
    }

    /// The in-plane axis across which a light edge (a shadow line or a beam's cut-off) runs
    /// through the cell: of the two, the one whose opposite edges (three points on each, lifted
    /// off the surface) differ most in how many of their points are lit ([`Self::lit_points`]);
    /// `None` when no light edge runs through it.
    fn shadow_line_axis(&self, cell: &Cell) -> Option<usize> {
        let mut best: Option<(usize, usize)> = None;
        for k in 0..2 {
            let Some(lit) = self.lit_points(cell, &side_points(cell, k), true) else {
                continue;
            };
            let count = |side: &[bool]| side.iter().filter(|&&l| l).count();
            let differ = count(&lit[..3]).abs_diff(count(&lit[3..]));
            if differ > 0 && best.is_none_or(|(_, d)| differ > d) {
                best = Some((k, differ));
            }
        }
        best.map(|(k, _)| k)
    }

    /// True when a light edge (a shadow line or a beam's cut-off) runs through the cell between
    /// its two sides parallel to a contact edge (`across`: the axis across it): of the points on
    /// them (three on each, lifted off the surface), some are lit and others not
    /// ([`Self::lit_points`]).
    fn light_edge_across(&self, cell: &Cell, across: usize) -> bool {
        self.lit_and_dark(cell, &side_points(cell, across), true)
    }

    /// True when a beam edge (a cut-off of the lights' curves, occluders left out) runs through
    /// the cell: its direct light there is sampled finely ([`SolverMesh::beam_edge`]).
    fn beam_edge_crosses(&self, cell: &Cell) -> bool {
        self.light_edge_crosses(cell, false)
    }

    /// True when a light edge (with `occluded`, a shadow line or a beam's cut-off; else a
    /// cut-off only) runs through the cell: of the points on its four edges (three on each,
    /// lifted off the surface), some are lit and others not ([`Self::lit_points`]).
    fn light_edge_crosses(&self, cell: &Cell, occluded: bool) -> bool {
        self.lit_and_dark(
            cell,
            &[side_points(cell, 0), side_points(cell, 1)].concat(),
            occluded,
        )
    }

    /// True when some of `points` (of `cell`) are lit and others not ([`Self::lit_points`]).
    fn lit_and_dark(&self, cell: &Cell, points: &[DVec3], occluded: bool) -> bool {
        self.lit_points(cell, points, occluded)
            .is_some_and(|lit| lit.contains(&true) && lit.contains(&false))
    }

    /// Per point of `cell` (on its surface), whether it is lit: the direct illuminance of all
    /// the lights together there (curves and aims counted, occluders with `occluded`; every
    /// light at full output, so dimmers and colours do not count), over what the same lights
    /// would give there with the intensity each sends towards the cell's centre (the geometry
    /// alone: distance and angle), is at least `LIGHT_EDGE_RATIO ×` the largest of these
    /// ratios. So a light edge is where the light leaves what its geometry makes of it — a
    /// shadow line or a beam's cut-off — not a smooth fall-off across a large cell; and the
    /// edge of one light among many that light the cell as much is not an edge of the light
    /// there (docs/DECISIONS.md "Light edges beside contacts"). `None` when no light reaches
    /// any of the points.
    fn lit_points(&self, cell: &Cell, points: &[DVec3], occluded: bool) -> Option<Vec<bool>> {
        let bounds = cell.bounds();
        self.lit_points_at(
            cell.rect.normal(),
            0.5 * (bounds.min + bounds.max),
            points,
            occluded,
        )
    }

    /// [`Self::lit_points`] for points of any flat piece of unit `normal` whose centre is
    /// `centre` (an OBJ triangle's).
    fn lit_points_at(
        &self,
        normal: DVec3,
        centre: DVec3,
        points: &[DVec3],
        occluded: bool,
    ) -> Option<Vec<bool>> {
        let intensity = |light: &Light, to_light: DVec3| {
            let gamma = light.aim.dot(-to_light.normalize()).clamp(-1.0, 1.0).acos();
            light.curve.eval_rad(gamma)
        };
        let towards_centre: Vec<f64> = self
            .scene
            .lights
            .iter()
            .map(|light| intensity(light, light.position - centre))
            .collect();
        let ratios: Vec<f64> = points
            .iter()
            .map(|&p| {
                let (mut direct, mut geometric) = (0.0, 0.0);
                for (light, &central) in self.scene.lights.iter().zip(&towards_centre) {
                    let to_light = light.position - p;
                    let cos = normal.dot(to_light);
                    if cos <= 0.0 {
                        continue;
                    }
                    let r2 = to_light.length_squared();
                    let g = cos / (r2 * r2.sqrt());
                    geometric += central * g;
                    let e = intensity(light, to_light) * g;
                    // A ray only where the light sends some.
                    if e > 0.0
                        && (!occluded
                            || self
                                .occluders
                                .as_ref()
                                .is_none_or(|occ| occ.visible(light.position, p)))
                    {
                        direct += e;
                    }
                }
                match (direct > 0.0, geometric > 0.0) {
                    (false, _) => 0.0,
                    (true, false) => f64::INFINITY,
                    (true, true) => direct / geometric,
                }
            })
            .collect();
        let largest = ratios.iter().fold(0.0f64, |a, &r| a.max(r));
        (largest > 0.0).then(|| ratios.iter().map(|&r| r >= LIGHT_EDGE_RATIO * largest).collect())
    }
}

/// Splits an OBJ triangle 1 → 4 while its longest edge exceeds `lamp_ratio ×` its distance to a
/// light in front of it, and in halves across a direction ([`mesh_contact_cut`],
/// [`halve_triangle`]) where the strip rule asks for it beside an OBJ contact edge; returns the
/// pieces, the first light that caused a split, and whether the contact rule split it.
fn split_triangle(
    splitter: &Splitter,
    corners: [DVec3; 3],
    patch: &Patch,
) -> (Vec<[DVec3; 3]>, Option<usize>, bool) {
    let (scene, options) = (splitter.scene, splitter.options);
    let mut out = Vec::new();
    let mut first = None;
    let mut by_contact = false;
    let mut stack = vec![corners];
    while let Some(t) = stack.pop() {
        let longest = (0..3).map(|e| t[e].distance(t[(e + 1) % 3])).fold(0.0, f64::max);
        let centre = (t[0] + t[1] + t[2]) / 3.0;
        let near = (options.lamp_ratio > 0.0 && longest > 2.0 * options.lamp_min_for(0.0))
            .then(|| {
                scene.lights.iter().position(|l| {
                    let distance = (l.position.distance(centre) - longest / 2.0).max(0.0);
                    patch.normal.dot(l.position - centre) > 0.0
                        && longest > options.lamp_ratio * distance
                        && longest > 2.0 * options.lamp_min_for(distance)
                })
            })
            .flatten();
        if let Some(i) = near {
            first.get_or_insert(i);
            let m = [(t[0] + t[1]) / 2.0, (t[1] + t[2]) / 2.0, (t[2] + t[0]) / 2.0];
            stack.extend([
                [t[0], m[0], m[2]],
                [m[0], t[1], m[1]],
                [m[2], m[1], t[2]],
                [m[0], m[1], m[2]],
            ]);
        } else if let Some(direction) = mesh_contact_cut(splitter, &t, patch.normal) {
            by_contact = true;
            halve_triangle(&t, direction, &mut stack);
        } else {
            out.push(t);
        }
    }
    (out, first, by_contact)
}

/// True when an OBJ mesh covers the triangle `t` (unit `normal`) at its centroid and its corners
/// (pulled 1 mm towards the centroid): a face of one block of a piece of furniture inside
/// another (the top of a sofa's seat under its back-rest). A triangle only partly covered is
/// kept whole: nothing grades towards the outline of a block standing on another, so a piece
/// across it can be large, and its centroid can lie under the block while most of it is seen
/// (the top of the bundled sculpture's plinth).
fn triangle_covered(contacts: &MeshContacts, t: &[DVec3; 3], normal: DVec3) -> bool {
    let centre = (t[0] + t[1] + t[2]) / 3.0;
    let inset = |p: DVec3| p + (centre - p).clamp_length_max(1e-3);
    contacts.covered(centre, normal) && t.iter().all(|&p| contacts.covered(inset(p), normal))
}

/// The direction (unit, in the plane of the OBJ triangle `t` with unit `normal`) across which to
/// halve the triangle beside its nearest OBJ contact edge, if any: by the strip rule of box
/// contacts ([`strip_cut`]: across the contact edge or along it) when the contact edge runs
/// flat to the triangle's plane (a seat's side standing on the floor, its top above that edge),
/// else across its longest side while that is longer than `contact_ratio ×` the distance; never
/// into pieces narrower than `contact_min_m` (docs/DECISIONS.md "OBJ contacts graded in
/// strips").
fn mesh_contact_cut(splitter: &Splitter, t: &[DVec3; 3], normal: DVec3) -> Option<DVec3> {
    let options = splitter.options;
    let near = splitter.mesh_contacts.as_ref()?.nearest_to_points(t)?;
    let sides = [t[1] - t[0], t[2] - t[1], t[0] - t[2]];
    let along = near.direction - normal * near.direction.dot(normal);
    if along.length() < FLAT_EDGE_COSINE {
        let longest = sides
            .iter()
            .copied()
            .max_by(|a, b| a.length().total_cmp(&b.length()))?;
        let length = longest.length();
        return (length > 2.0 * options.contact_min_m && length > options.contact_ratio * near.distance)
            .then(|| longest / length);
    }
    let along = along.normalize();
    let across = normal.cross(along);
    let extent = |direction: DVec3| sides.iter().map(|s| s.dot(direction).abs()).fold(0.0, f64::max);
    let (width, length) = (extent(across), extent(along));
    strip_cut(
        width,
        length,
        near.distance,
        options.contact_ratio,
        options.contact_min_m,
        CONTACT_ASPECT,
    )
    .map(|cut| if cut == StripCut::Across { across } else { along })
    .or_else(|| triangle_light_edge_cut(splitter, t, normal, [across, along], near.distance))
}

/// The light-edge rule of contacts ([`Splitter::light_edge_axis`]) for an OBJ triangle `t` (unit
/// `normal`) beside a contact edge flat to its plane (`directions`: unit, across the edge and
/// along it; `distance` (m) to it): where a shadow line or a beam's cut-off runs through the
/// triangle (some of its corners, side middles and centre lit and others not,
/// [`Splitter::lit_points_at`]), the direction of the two that best separates the lit points
/// from the dark ones — across the edge while the triangle is within `SHADOW_REACH` of its
/// widths of the edge, along it while longer than `LIGHT_EDGE_LENGTH ×` its far side's
/// distance; never into pieces under twice `shadow_min_m` (docs/DECISIONS.md "OBJ things on OBJ
/// furniture"). A strip along a contact may run through the shadow a block beside it casts
/// (the slot between a block of books and the wall behind it), which the strip rule alone
/// would leave lit on average.
fn triangle_light_edge_cut(
    splitter: &Splitter,
    t: &[DVec3; 3],
    normal: DVec3,
    directions: [DVec3; 2],
    distance: f64,
) -> Option<DVec3> {
    let min_m = 2.0 * splitter.options.shadow_min_m;
    if min_m <= 0.0 {
        return None;
    }
    let centre = (t[0] + t[1] + t[2]) / 3.0;
    let extent = |d: DVec3| {
        let s = t.map(|p| p.dot(d));
        s.iter().copied().fold(f64::NEG_INFINITY, f64::max) - s.iter().copied().fold(f64::INFINITY, f64::min)
    };
    let [width, length] = directions.map(extent);
    let may_cut = [
        width > min_m && distance <= SHADOW_REACH * width,
        length > min_m && length > LIGHT_EDGE_LENGTH * (distance + width),
    ];
    if !may_cut.contains(&true) {
        return None;
    }
    // The corners (1 mm inside), the sides' middles and the centre, just off the face.
    let inset = |p: DVec3| p + (centre - p).clamp_length_max(1e-3);
    let points: Vec<DVec3> = (0..3)
        .flat_map(|k| [inset(t[k]), (t[k] + t[(k + 1) % 3]) / 2.0])
        .chain([centre])
        .map(|p| p + normal * 1e-6)
        .collect();
    let lit = splitter.lit_points_at(normal, centre, &points, true)?;
    if !(lit.contains(&true) && lit.contains(&false)) {
        return None;
    }
    // How far apart the lit and the dark points lie along a direction, in its extents.
    let separation = |d: DVec3, size: f64| {
        let mean = |want: bool| {
            let (sum, n) = points
                .iter()
                .zip(&lit)
                .filter(|(_, l)| **l == want)
                .fold((0.0, 0.0), |(sum, n), (p, _)| (sum + p.dot(d), n + 1.0));
            sum / n
        };
        (mean(true) - mean(false)).abs() / size.max(f64::MIN_POSITIVE)
    };
    let best = if separation(directions[0], width) >= separation(directions[1], length) {
        0
    } else {
        1
    };
    may_cut[best].then_some(directions[best])
}

/// Cuts the triangle `t` by the line through the middle of its extent along the in-plane unit
/// `direction`, pushing the two or three triangles the two halves make (each half's extent
/// along `direction` is half the triangle's; corners keep their order, so the pieces face as
/// `t` does).
fn halve_triangle(t: &[DVec3; 3], direction: DVec3, out: &mut Vec<[DVec3; 3]>) {
    let s = t.map(|p| p.dot(direction));
    let (lo, hi) = (
        s.iter().copied().fold(f64::INFINITY, f64::min),
        s.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    );
    let middle = 0.5 * (lo + hi);
    // A corner within rounding of the line lies on it (in both halves, cutting no side).
    let offset = s.map(|v| {
        if (v - middle).abs() <= 1e-9 * (hi - lo) {
            0.0
        } else {
            v - middle
        }
    });
    for side in [1.0, -1.0] {
        // Sutherland–Hodgman against the half-plane side·(s − middle) ≥ 0.
        let mut polygon: Vec<DVec3> = Vec::with_capacity(4);
        for k in 0..3 {
            let (a, b) = (k, (k + 1) % 3);
            let (da, db) = (side * offset[a], side * offset[b]);
            if da >= 0.0 {
                polygon.push(t[a]);
            }
            if (da > 0.0 && db < 0.0) || (da < 0.0 && db > 0.0) {
                polygon.push(t[a] + (t[b] - t[a]) * (da / (da - db)));
            }
        }
        match polygon[..] {
            [a, b, c] => out.push([a, b, c]),
            // The quad split along its shorter diagonal.
            [a, b, c, d] if a.distance(c) <= b.distance(d) => out.extend([[a, b, c], [a, c, d]]),
            [a, b, c, d] => out.extend([[a, b, d], [b, c, d]]),
            _ => {}
        }
    }
}

/// The edges where a box rests on (or against) a room surface or the top of another box,
/// clipped to the support, leaving out edges that lie on the room's own edges; the room's own
/// edges within reach of a light close to a room surface; and the pieces `room_edges` of the
/// room's own edges.
fn contact_edges(scene: &Scene, slots: &[Slot], room_edges: &[BendingPiece]) -> Vec<Contact> {
    let size = scene.room_size;
    let eps = touch_eps(size);
    let mut out = Vec::new();
    let mut push_rect_edges =
        |axis: usize, offset: f64, gap: f64, lo: DVec3, hi: DVec3, support_lo: DVec3, support_hi: DVec3| {
            // The rectangle [lo, hi] in the plane coordinate[axis] = offset, clipped to the support.
            let lo = lo.max(support_lo);
            let hi = hi.min(support_hi);
            let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
            if hi[a] - lo[a] <= eps || hi[b] - lo[b] <= eps {
                return;
            }
            for (fixed, along) in [(a, b), (b, a)] {
                for value in [lo[fixed], hi[fixed]] {
                    // Edges on the support's own boundary are not contacts with its visible part.
                    if (value - support_lo[fixed]).abs() <= eps || (value - support_hi[fixed]).abs() <= eps {
                        continue;
                    }
                    let mut min = DVec3::ZERO;
                    let mut max = DVec3::ZERO;
                    min[axis] = offset;
                    max[axis] = offset;
                    min[fixed] = value;
                    max[fixed] = value;
                    min[along] = lo[along];
                    max[along] = hi[along];
                    out.push(Contact {
                        segment: Aabb { min, max },
                        gap,
                        kind: if gap > 0.0 { EdgeKind::Slot } else { EdgeKind::Box },
                        max_length: f64::INFINITY,
                    });
                }
            }
        };
    for b in &scene.boxes {
        // Faces lying on a room surface.
        for (axis, box_side, room_side) in faces_to_room(b, size) {
            if (box_side - room_side).abs() <= eps {
                push_rect_edges(axis, room_side, 0.0, b.min, b.max, DVec3::ZERO, size);
            }
        }
        // Resting on top of another box.
        for other in &scene.boxes {
            if std::ptr::eq(b, other) || (b.min.z - other.max.z).abs() > eps {
                continue;
            }
            let lo = DVec3::new(other.min.x, other.min.y, other.max.z);
            let hi = DVec3::new(other.max.x, other.max.y, other.max.z);
            push_rect_edges(2, other.max.z, 0.0, b.min, b.max, lo, hi);
        }
    }
    // A slot's outline on both its sides, the room surface and the box face.
    for slot in slots {
        let b = &slot.bounds;
        for side in slot.sides() {
            push_rect_edges(slot.axis, side, slot.gap(), b.min, b.max, DVec3::ZERO, size);
        }
    }
    // The room's edges near lights close to a room surface.
    for light in &scene.lights {
        let p = light.position;
        let near = p.min(size - p).min_element();
        if near > CORNER_LAMP_M {
            continue;
        }
        let reach = CORNER_REACH_FACTOR * near + CORNER_REACH_M;
        // Each room edge runs along `along` at fixed values of the other two coordinates.
        for along in 0..3 {
            let (a, b) = ((along + 1) % 3, (along + 2) % 3);
            for va in [0.0, size[a]] {
                for vb in [0.0, size[b]] {
                    let gap = (p[a] - va).hypot(p[b] - vb);
                    if gap > reach {
                        continue;
                    }
                    let half = (reach * reach - gap * gap).sqrt();
                    let (lo, hi) = ((p[along] - half).max(0.0), (p[along] + half).min(size[along]));
                    if hi - lo <= eps {
                        continue;
                    }
                    let mut min = DVec3::ZERO;
                    min[a] = va;
                    min[b] = vb;
                    let mut max = min;
                    min[along] = lo;
                    max[along] = hi;
                    out.push(Contact {
                        segment: Aabb { min, max },
                        gap: 0.0,
                        kind: EdgeKind::NearLamp,
                        max_length: f64::INFINITY,
                    });
                }
            }
        }
    }
    out.extend(room_edges.iter().map(|piece| {
        let length = (piece.segment.max - piece.segment.min).max_element();
        Contact {
            segment: piece.segment,
            gap: 0.0,
            kind: EdgeKind::Bending,
            max_length: if piece.along {
                ROOM_EDGE_ALONG_FRACTION * length
            } else {
                f64::INFINITY
            },
        }
    }));
    out
}

/// Collects leaves into a mesh, sharing vertices within a surface.
#[derive(Default)]
struct Builder {
    mesh: PatchMesh,
    coarse_patch: Vec<u32>,
    alone: Vec<bool>,
    in_slot: Vec<bool>,
    beam_edge: Vec<bool>,
    ids: HashMap<(u32, [u64; 3]), u32>,
}

impl Builder {
    fn vertex(&mut self, surface: u32, p: DVec3, normal: DVec3) -> u32 {
        let key = (surface, p.to_array().map(|x| (x + 0.0).to_bits()));
        let mesh = &mut self.mesh;
        *self.ids.entry(key).or_insert_with(|| {
            mesh.positions.push(p);
            mesh.normals.push(normal);
            mesh.vertex_surface.push(surface);
            (mesh.positions.len() - 1) as u32
        })
    }

    fn rect(
        &mut self,
        parent: &Patch,
        index: usize,
        cell: &Cell,
        near_lamp: bool,
        in_slot: bool,
        beam_edge: bool,
    ) {
        let r = &cell.rect;
        let corners = [
            r.point(r.min[0], r.min[1]),
            r.point(r.max[0], r.min[1]),
            r.point(r.max[0], r.max[1]),
            r.point(r.min[0], r.max[1]),
        ];
        let vertices = corners.map(|c| self.vertex(parent.surface, c, parent.normal));
        self.mesh.patches.push(Patch {
            vertices,
            n_vertices: 4,
            surface: parent.surface,
            normal: parent.normal,
            area: cell.extent(0) * cell.extent(1),
            centroid: r.point(0.5 * (r.min[0] + r.max[0]), 0.5 * (r.min[1] + r.max[1])),
        });
        self.coarse_patch.push(index as u32);
        self.alone.push(near_lamp || in_slot);
        self.in_slot.push(in_slot);
        self.beam_edge.push(beam_edge);
    }

    fn triangle(&mut self, parent: &Patch, index: usize, t: [DVec3; 3], alone: bool) {
        let v = t.map(|c| self.vertex(parent.surface, c, parent.normal));
        self.mesh.patches.push(Patch {
            vertices: [v[0], v[1], v[2], v[2]],
            n_vertices: 3,
            surface: parent.surface,
            normal: parent.normal,
            area: 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length(),
            centroid: (t[0] + t[1] + t[2]) / 3.0,
        });
        self.coarse_patch.push(index as u32);
        self.alone.push(alone);
        self.in_slot.push(false);
        self.beam_edge.push(false);
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    #[test]
    fn candidates_come_once_and_in_order_however_many() {
        assert_eq!(in_order(vec![7, 3, 7, 1], 1000), vec![1, 3, 7]);
        // Many against the count: through the bits, the same answer.
        let many: Vec<usize> = (0..200).rev().flat_map(|i| [3 * i, 3 * i]).collect();
        let expected: Vec<usize> = (0..200).map(|i| 3 * i).collect();
        assert_eq!(in_order(many, 600), expected);
    }

    #[test]
    fn a_plane_index_finds_what_lies_in_a_plane_near_a_box() {
        let mut index = PlaneIndex::default();
        // Along x in the floor (z = 0): segments from x = 0, 1, 2, 3 m, 0.5 m long.
        for i in 0..4 {
            let x = f64::from(i);
            index.file(
                2,
                0.0,
                &DVec3::new(x, 1.0, 0.0),
                &DVec3::new(x + 0.5, 1.0, 0.0),
                i as usize,
            );
        }
        // One on the ceiling (z = 3) above the first.
        index.file(2, 3.0, &DVec3::new(0.0, 1.0, 3.0), &DVec3::new(0.5, 1.0, 3.0), 4);
        let index = index.sorted();
        let cell = Aabb {
            min: DVec3::new(1.7, 0.0, 0.0),
            max: DVec3::new(1.9, 2.0, 0.0),
        };
        let near = |offset: f64, reach: f64| {
            let mut out = Vec::new();
            index.near(2, offset, &cell, reach, &mut out);
            in_order(out, 5)
        };
        // Within 0.2 m along x: the segments from 1 (ends at 1.5) and 2 m; not 0 or 3.
        assert_eq!(near(0.0, 0.2), vec![1, 2]);
        // Touching only: the segment from 1 m ends 0.2 m short of the box.
        assert_eq!(near(0.0, 0.0), Vec::<usize>::new());
        assert_eq!(near(1e-10, 5.0), vec![0, 1, 2, 3]);
        assert_eq!(near(3.0, 5.0), vec![4]);
        assert_eq!(near(1.0, 5.0), Vec::<usize>::new());
    }

    /// A coarser grading than the default (ratios 1, 6 cm strips, slots up to 0.3 m as by
    /// default until the thirty-third round; room edges as by default), whose leaves the tests
    /// below state exactly.
    fn coarse_grading() -> RefineOptions {
        RefineOptions {
            lamp_ratio: 1.0,
            lamp_min_m: 0.03,
            contact_ratio: 1.0,
            contact_min_m: 0.06,
            shadow_min_m: 0.01,
            slot_max_m: 0.3,
            room_edge_min_m: 0.1,
        }
    }

    fn scene(text: &str) -> Scene {
        crate::scene::load::test_room(text)
    }

    /// A 4 × 3 × 2.5 m room (ρ 0.2 / 0.5 / 0.7, 0.5 m solver patches) with one light 1.2 m up
    /// in its middle, aimed down with a cosine-like curve.
    pub(crate) const EMPTY: &str = r#"
version = 1
[room]
size = [4.0, 3.0, 2.5]
[room.reflectance]
floor = 0.2
walls = 0.5
ceiling = 0.7
[[light]]
name = "l"
position = [2.0, 1.5, 1.2]
lid = [[0, 100], [90, 0]]
[settings]
solver_patch_size = 0.5
"#;

    /// The bounds of leaf `p` of `mesh` (world, m): its corners' extent.
    fn leaf_box(mesh: &PatchMesh, p: &Patch) -> Aabb {
        p.vertex_ids().iter().map(|&v| mesh.positions[v as usize]).fold(
            Aabb {
                min: DVec3::INFINITY,
                max: DVec3::NEG_INFINITY,
            },
            |b, q| Aabb {
                min: b.min.min(q),
                max: b.max.max(q),
            },
        )
    }

    /// The empty room with a 1 × 1 × 0.8 m box on the floor and its light at `light`.
    fn box_room(light: &str) -> Scene {
        scene(&EMPTY.replace("[2.0, 1.5, 1.2]", light).replace(
            "[[light]]",
            "[[box]]\nmin = [1.0, 1.0, 0.0]\nmax = [2.0, 2.0, 0.8]\nreflectance = 0.4\n[[light]]",
        ))
    }

    fn total_area(mesh: &PatchMesh) -> f64 {
        mesh.patches.iter().map(|p| p.area).sum()
    }

    /// An OBJ plinth turned 30° on the floor: no floor leaf is left under it (the covered cells
    /// are left out, so the floor's leaves cover the floor less the footprint, to the strips
    /// along its edges), the floor leaves touching its footprint are at most twice
    /// `contact_min_m` across (its edges are turned, so they are squares), its sides' pieces
    /// touching the floor are strips at most twice `contact_min_m` high and `CONTACT_ASPECT`
    /// times that long, its underside on the floor is left out, and the plan says so.
    #[test]
    fn obj_furniture_grades_its_support_and_leaves_out_what_it_covers() {
        let scene = crate::transport::mesh_contacts::plinth_room();
        let options = RefineOptions::default();
        let solver = refine(&scene, &options);
        let contacts = MeshContacts::of_scene(&scene).expect("contacts");
        let floor: Vec<&Patch> = solver
            .mesh
            .patches
            .iter()
            .filter(|p| matches!(scene.surfaces[p.surface as usize].kind, SurfaceKind::Floor))
            .collect();
        let footprint = 0.6 * 0.6;
        let area: f64 = floor.iter().map(|p| p.area).sum();
        // Strips of ≤ 3 cm along 2.4 m of edges: at most half of each is misassigned.
        assert!(
            (area - (12.0 - footprint)).abs() < 2.4 * 0.015,
            "floor leaves {area} m²"
        );
        for p in &floor {
            assert!(
                !contacts.covered(p.centroid, DVec3::Z),
                "a leaf under the plinth at {}",
                p.centroid
            );
            let bounds = leaf_box(&solver.mesh, p);
            if contacts.nearest_to_cell(2, 0.0, &bounds).map(|e| e.distance) == Some(0.0) {
                let longer = (bounds.max - bounds.min).max_element();
                assert!(
                    longer <= 2.0 * options.contact_min_m + 1e-9,
                    "a {longer} m leaf on the footprint's edge"
                );
            }
        }
        let faces: Vec<&Patch> = solver
            .mesh
            .patches
            .iter()
            .filter(|p| matches!(scene.surfaces[p.surface as usize].kind, SurfaceKind::Mesh { .. }))
            .collect();
        let mut at_floor = 0;
        for p in &faces {
            let b = leaf_box(&solver.mesh, p);
            assert!(b.max.z > 1e-9, "a leaf of the underside at {}", p.centroid);
            if b.min.z.abs() < 1e-9 {
                at_floor += 1;
                let (high, long) = (b.max.z - b.min.z, (b.max - b.min).truncate().length());
                assert!(
                    high <= 2.0 * options.contact_min_m + 1e-9,
                    "a piece {high} m high at the floor"
                );
                assert!(
                    long <= (CONTACT_ASPECT * high).max(2.0 * options.contact_min_m) + 1e-9,
                    "a piece {high} m high and {long} m long at the floor"
                );
            }
        }
        // 0.6 m sides in pieces at most 4 × 3 cm long.
        assert!(at_floor >= 4 * 5, "{at_floor} pieces of the faces at the floor");
        // The sides and the top, whole.
        let area: f64 = faces.iter().map(|p| p.area).sum();
        assert!((area - (4.0 * 0.6 + 0.36)).abs() < 1e-9, "{area} m² of faces");
        assert_eq!(solver.mesh_contacts, contacts.len());
        let underside = scene
            .coarse
            .patches
            .iter()
            .filter(|p| p.normal.z < -0.5 && p.centroid.z.abs() < 1e-9)
            .count();
        assert!(
            underside > 0 && solver.covered_leaves > underside,
            "{underside}, {}",
            solver.covered_leaves
        );
        let notes = solver.notes(&scene).join("\n");
        let said = format!("graded along {} OBJ contact edges", contacts.len());
        assert!(notes.contains(&said), "{notes}");
    }

    /// The OBJ text of a closed axis-aligned block `lo..hi` (z up, m) whose first vertex is
    /// number `first`.
    fn obj_block(lo: [f64; 3], hi: [f64; 3], first: usize) -> String {
        let mut text = String::new();
        for z in [lo[2], hi[2]] {
            for (x, y) in [(lo[0], lo[1]), (hi[0], lo[1]), (hi[0], hi[1]), (lo[0], hi[1])] {
                text.push_str(&format!("v {x} {y} {z}\n"));
            }
        }
        for face in [
            [0, 1, 5, 4],
            [1, 2, 6, 5],
            [2, 3, 7, 6],
            [3, 0, 4, 7],
            [4, 5, 6, 7],
            [3, 2, 1, 0],
        ] {
            let [a, b, c, d] = face.map(|i| i + first);
            text.push_str(&format!("f {a} {b} {c} {d}\n"));
        }
        text
    }

    /// The test room with two OBJ blocks (`lo`–`hi` corners, one OBJ file), its default
    /// refinement options and its solver mesh.
    fn two_blocks_refined(
        lo: [f64; 3],
        hi: [f64; 3],
        lo2: [f64; 3],
        hi2: [f64; 3],
    ) -> (Scene, RefineOptions, SolverMesh) {
        let obj = obj_block(lo, hi, 1) + &obj_block(lo2, hi2, 9);
        let scene = crate::transport::mesh_contacts::obj_room(&obj, "");
        let options = RefineOptions::default();
        let solver = refine(&scene, &options);
        (scene, options, solver)
    }

    /// Asserts that a leaf (bounds `b`) of a horizontal surface, `distance` (m) from a contact
    /// edge running along x, is a strip by the strip rule ([`strip_cut`]): at most twice
    /// `contact_min_m` wide across the edge, and along it at most `CONTACT_ASPECT` times its far
    /// side's distance, or twice `contact_min_m`.
    fn assert_strip_along_x(b: &Aabb, distance: f64, options: &RefineOptions) {
        let (wide, long) = (b.max.y - b.min.y, b.max.x - b.min.x);
        let min = 2.0 * options.contact_min_m;
        assert!(wide <= min + 1e-9, "a strip {wide} m wide");
        assert!(
            long <= (CONTACT_ASPECT * (distance + wide)).max(min) + 1e-9,
            "a strip {wide} × {long} m, {distance} m from the edge"
        );
    }

    /// An OBJ block standing on a box (a vase on a sideboard) is graded like one on the floor:
    /// the box top's leaves touching its footprint are strips at most twice `contact_min_m`
    /// wide, no leaf of the box top lies wholly under it, and its underside on the box is left
    /// out.
    #[test]
    fn obj_furniture_on_a_box_grades_the_box_top_and_leaves_out_its_underside() {
        let obj = obj_block([1.8, 1.3, 0.8], [2.2, 1.7, 1.1], 1);
        let boxes = "[[box]]\nmin = [1.0, 1.0, 0.0]\nmax = [3.0, 2.0, 0.8]\nreflectance = 0.5\n";
        let scene = crate::transport::mesh_contacts::obj_room(&obj, boxes);
        let options = RefineOptions::default();
        let solver = refine(&scene, &options);
        let kind = |p: &Patch| &scene.surfaces[p.surface as usize].kind;
        let mut strips = 0;
        for p in &solver.mesh.patches {
            let b = leaf_box(&solver.mesh, p);
            let on_top = matches!(kind(p), SurfaceKind::BoxFace { .. }) && b.min.z > 0.8 - 1e-9;
            if on_top {
                let under = b.min.x >= 1.8 - 1e-9
                    && b.max.x <= 2.2 + 1e-9
                    && b.min.y >= 1.3 - 1e-9
                    && b.max.y <= 1.7 + 1e-9;
                assert!(!under, "a leaf of the box top under the block at {}", p.centroid);
                // Within 3 cm in front of the footprint's front side y = 1.3, along it (the box
                // top is not meshed to it, so the strips need not end on it).
                let distance = (1.3 - b.max.y).max(0.0);
                if b.min.y < 1.3 && distance < 0.03 && b.max.x > 1.8 + 1e-9 && b.min.x < 2.2 - 1e-9 {
                    strips += 1;
                    assert_strip_along_x(&b, distance, &options);
                }
            }
            if matches!(kind(p), SurfaceKind::Mesh { .. }) {
                assert!(
                    p.centroid.z > 0.8 + 1e-9,
                    "a leaf of the underside at {}",
                    p.centroid
                );
            }
        }
        assert!(strips >= 4, "{strips} strips along the front");
    }

    /// An OBJ block standing on an OBJ sideboard against a wall (books on it): the sideboard's
    /// top is graded in strips towards the block's foot and keeps no leaf wholly under it, the
    /// block's underside is left out, and no leaf of the wall behind the sideboard reaches both
    /// above and below its top (the wall's cells are cut on that contact edge).
    #[test]
    fn obj_furniture_on_obj_furniture_grades_the_lower_top_and_cuts_the_wall_on_its_edge() {
        let (scene, options, solver) =
            two_blocks_refined([1.0, 0.0, 0.0], [3.0, 0.5, 0.8], [1.8, 0.1, 0.8], [2.2, 0.4, 1.1]);
        let kind = |p: &Patch| &scene.surfaces[p.surface as usize].kind;
        let mut strips = 0;
        for p in &solver.mesh.patches {
            let b = leaf_box(&solver.mesh, p);
            match kind(p) {
                SurfaceKind::Mesh { .. } if p.normal.z > 0.5 && b.max.z < 0.8 + 1e-9 => {
                    let under = b.min.x >= 1.8 - 1e-9
                        && b.max.x <= 2.2 + 1e-9
                        && b.min.y >= 0.1 - 1e-9
                        && b.max.y <= 0.4 + 1e-9;
                    assert!(
                        !under,
                        "a leaf of the sideboard's top under the block at {}",
                        p.centroid
                    );
                    // Touching the block's front side y = 0.4 from in front, along it.
                    if b.min.y < 0.4 + 1e-9
                        && b.max.y > 0.4 + 1e-9
                        && b.max.x > 1.8 + 1e-9
                        && b.min.x < 2.2 - 1e-9
                    {
                        strips += 1;
                        let wide = b.max.y - b.min.y;
                        assert!(
                            wide <= 2.0 * options.contact_min_m + 1e-9,
                            "a piece {wide} m wide at {}",
                            p.centroid
                        );
                    }
                }
                SurfaceKind::Mesh { .. } => {
                    let underside = p.normal.z < -0.5 && (p.centroid.z - 0.8).abs() < 1e-9;
                    assert!(!underside, "a leaf of the block's underside at {}", p.centroid);
                }
                SurfaceKind::Wall if b.max.y < 1e-9 && b.max.x > 1.0 + 1e-9 && b.min.x < 3.0 - 1e-9 => {
                    assert!(
                        b.min.z >= 0.8 - 1e-9 || b.max.z <= 0.8 + 1e-9,
                        "a wall leaf across the sideboard's top: z {}..{}",
                        b.min.z,
                        b.max.z
                    );
                }
                _ => {}
            }
        }
        assert!(strips >= 4, "{strips} pieces along the block's front");
    }

    /// A closed OBJ block on the floor set square to the walls, with a second block standing
    /// on its back half (a seat and its back-rest): the floor leaves along its footprint are
    /// strips at most twice `contact_min_m` wide and `CONTACT_ASPECT` times as long as far, far
    /// fewer than the turned plinth's squares; the seat's top under the back-rest, the
    /// back-rest's underside and both undersides on the floor are left out, and the faces
    /// left keep their area.
    #[test]
    fn obj_furniture_set_square_grades_in_strips_and_leaves_out_its_hidden_faces() {
        // The seat 1.2 × 0.6 × 0.4 m, the back-rest 1.2 × 0.2 × 0.4 m on its back 0.2 m.
        let (scene, options, solver) =
            two_blocks_refined([1.4, 1.2, 0.0], [2.6, 1.8, 0.4], [1.4, 1.6, 0.4], [2.6, 1.8, 0.8]);
        let kind = |p: &Patch| &scene.surfaces[p.surface as usize].kind;
        let mut strips = 0;
        for p in solver
            .mesh
            .patches
            .iter()
            .filter(|p| matches!(kind(p), SurfaceKind::Floor))
        {
            let b = leaf_box(&solver.mesh, p);
            // Touching the footprint's front side y = 1.2 (the floor is not meshed to it).
            if b.min.y <= 1.2 && b.max.y >= 1.2 && b.max.x > 1.4 + 1e-9 && b.min.x < 2.6 - 1e-9 {
                strips += 1;
                assert_strip_along_x(&b, 0.0, &options);
            }
        }
        // 1.2 m in strips at most 4 × 3 cm long, where squares would take 40.
        assert!((10..40).contains(&strips), "{strips} strips along the front");
        let faces: Vec<&Patch> = solver
            .mesh
            .patches
            .iter()
            .filter(|p| matches!(kind(p), SurfaceKind::Mesh { .. }))
            .collect();
        for p in &faces {
            let (c, b) = (p.centroid, leaf_box(&solver.mesh, p));
            assert!(c.z > 1e-9, "a leaf of an underside on the floor at {c}");
            let at_seat_top = (c.z - 0.4).abs() < 1e-9 && p.normal.z > 0.5;
            assert!(
                !(at_seat_top && b.min.y > 1.6 - 1e-9),
                "a leaf wholly under the back-rest at {c}"
            );
        }
        // Seen: the seat's four sides and its front 0.4 m of top; the back-rest's sides and top
        // (1.44 m² of faces hidden). The seat top's pieces across the back-rest's front edge
        // (0.15 m deep in the coarse mesh) are kept whole, so at most that row is added.
        let seen = 2.0 * (1.2 + 0.6) * 0.4 + 1.2 * 0.4 + 2.0 * (1.2 + 0.2) * 0.4 + 1.2 * 0.2;
        let area: f64 = faces.iter().map(|p| p.area).sum();
        assert!(
            area > seen - 1e-9 && area < seen + 1.2 * 0.15,
            "{area} m² of faces against {seen}"
        );
        // The seat's top keeps all its seen 0.48 m², whatever the centroids of the pieces
        // across that edge.
        let top: f64 = faces
            .iter()
            .filter(|p| (p.centroid.z - 0.4).abs() < 1e-9 && p.normal.z > 0.5)
            .map(|p| p.area)
            .sum();
        assert!(
            top > 1.2 * 0.4 - 1e-9 && top < 1.2 * (0.4 + 0.15),
            "{top} m² of the seat's top"
        );
    }

    /// A light far from every surface, whose light is smooth next to the room's edges, and no
    /// boxes: nothing to refine, the coarse mesh is kept patch for patch, and there are no notes.
    #[test]
    fn a_scene_that_does_not_call_for_it_gets_no_refinement() {
        let s = scene(EMPTY);
        let solver = refine(&s, &coarse_grading());
        assert_eq!(solver.mesh.patches.len(), s.coarse.patches.len());
        assert!(solver.notes(&s).is_empty(), "{:?}", solver.notes(&s));
        for (a, b) in solver.mesh.patches.iter().zip(&s.coarse.patches) {
            assert_eq!(a.area, b.area);
            assert_eq!(a.centroid, b.centroid);
        }
    }

    /// A lamp 0.2 m below the ceiling: the ceiling patches around it are split until no leaf is
    /// longer than its distance to the lamp; the area is kept and leaves stay on their surface.
    #[test]
    fn patches_near_a_lamp_are_no_larger_than_their_distance_to_it() {
        let s = scene(&EMPTY.replace("[2.0, 1.5, 1.2]", "[2.0, 1.5, 2.3]"));
        let solver = refine(&s, &coarse_grading());
        assert!(solver.mesh.patches.len() > s.coarse.patches.len());
        assert!((total_area(&solver.mesh) - total_area(&s.coarse)).abs() < 1e-9);
        let lamp = s.lights[0].position;
        let mut smallest = f64::INFINITY;
        for p in &solver.mesh.patches {
            let bounds = leaf_box(&solver.mesh, p);
            let longest = (bounds.max - bounds.min).max_element();
            let d = point_box_distance(lamp, &bounds);
            if p.normal.dot(lamp - p.centroid) > 0.0 {
                assert!(longest <= d.max(2.0 * 0.03) + 1e-12, "{longest} at distance {d}");
            }
            smallest = smallest.min(longest);
            assert_eq!(solver.mesh.vertex_surface[p.vertices[0] as usize], p.surface);
        }
        assert!(
            smallest < 0.2,
            "the ceiling above the lamp is refined: {smallest}"
        );
        let notes = solver.notes(&s);
        assert_eq!(notes.len(), 2, "{notes:?}");
        assert!(
            notes[0].contains("refined near light l: 0.20 m from the ceiling"),
            "{notes:?}"
        );
        // The lamp's horizon lies 0.2 m under the ceiling: the walls go dark just below their
        // top edges, which are graded.
        assert!(notes[1].contains("pieces of the room's edges"), "{notes:?}");
    }

    /// A lamp 1 cm under the ceiling takes the ceiling leaves at its foot down to its distance
    /// (halving 0.5 m patches: 1.5625 cm, at most twice the distance), where the usual
    /// 3 cm floor would stop at 3.125 cm, as it still does for the lamp 5 cm under it; no leaf
    /// goes below 5 mm ([`LAMP_MIN_FLOOR_M`]).
    #[test]
    fn a_lamp_almost_touching_a_surface_takes_its_foot_below_the_usual_floor() {
        let foot_leaves = |z: &str| {
            let s = scene(&EMPTY.replace("[2.0, 1.5, 1.2]", &format!("[2.0, 1.5, {z}]")));
            let solver = refine(&s, &coarse_grading());
            let foot = DVec3::new(2.0, 1.5, 2.5);
            let mut sizes = Vec::new();
            let mut smallest = f64::INFINITY;
            for p in &solver.mesh.patches {
                let Aabb { min: lo, max: hi } = leaf_box(&solver.mesh, p);
                let longest = (hi - lo).max_element();
                smallest = smallest.min(longest);
                if foot.cmpge(lo - 1e-9).all() && foot.cmple(hi + 1e-9).all() {
                    sizes.push(longest);
                }
            }
            (sizes, smallest)
        };
        let (near, smallest) = foot_leaves("2.49");
        assert_eq!(near, [0.015625; 4], "the four leaves meeting at the foot");
        assert!(smallest >= LAMP_MIN_FLOOR_M, "{smallest}");
        let (farther, _) = foot_leaves("2.45");
        assert_eq!(farther, [0.03125; 4]);
    }

    /// A box on the floor: floor strips and the box sides' bottom strips are graded to 6.25 cm
    /// at the contact (anisotropically: longer along the edge, graded towards the box's corners), the four edges are
    /// counted, and the far floor is untouched.
    #[test]
    fn box_contacts_are_graded_with_strips() {
        // The light is on the +x side: the floor strip beside the box's x = 2 face is not in its
        // shadow.
        let s = box_room("[3.2, 1.5, 1.5]");
        let solver = refine(&s, &coarse_grading());
        assert_eq!(solver.contacts, 4);
        assert!(solver.contact_leaves_added > 0);
        assert!((total_area(&solver.mesh) - total_area(&s.coarse)).abs() < 1e-9);
        let floor = s
            .surfaces
            .iter()
            .position(|x| x.kind == SurfaceKind::Floor)
            .unwrap() as u32;
        // The floor leaf touching the box's x = 2 face at y = 1.5: a strip 0.0625 wide across.
        let strip = solver
            .mesh
            .patches
            .iter()
            .find(|p| {
                p.surface == floor
                    && (p.centroid.x - 2.03125).abs() < 1e-9
                    && (p.centroid.y - 1.375).abs() < 1e-9
            })
            .expect("a strip beside the box");
        // Halfway along the face it is 0.25 m long (its distance to the box's corner edges,
        // 0.375 m, bounds its length); next to a corner it is square.
        assert!((strip.area - 0.0625 * 0.25).abs() < 1e-12, "{}", strip.area);
        let corner = solver
            .mesh
            .patches
            .iter()
            .find(|p| p.surface == floor && p.centroid.distance(DVec3::new(2.03125, 1.03125, 0.0)) < 1e-9)
            .expect("a leaf at the box's corner");
        assert!((corner.area - 0.0625 * 0.0625).abs() < 1e-12, "{}", corner.area);
        // A box side's bottom strip.
        let side = s.surfaces.iter().position(|x| x.name == "box0-x1").unwrap() as u32;
        let lowest = solver
            .mesh
            .patches
            .iter()
            .filter(|p| p.surface == side)
            .map(|p| p.centroid.z)
            .fold(f64::INFINITY, f64::min);
        // 0.8 m halved while wider than twice the 6 cm minimum: a 0.1 m strip at the floor.
        assert!((lowest - 0.05).abs() < 1e-12, "{lowest}");
        // Far from the box the floor keeps its 0.5 m patches.
        assert!(
            solver
                .mesh
                .patches
                .iter()
                .any(|p| p.surface == floor && p.centroid.x > 3.5 && (p.area - 0.25).abs() < 1e-12)
        );
        assert!(
            solver
                .notes(&s)
                .iter()
                .any(|n| n.contains("graded along 4 contact edges"))
        );
    }

    /// Two cupboards 5 cm apart make a slot between their facing faces (graded no coarser than
    /// twice the gap where the faces overlap, its leaves — the floor strip between them too —
    /// linked alone); 0.7 m apart (beyond `slot_max_m`) they make none.
    #[test]
    fn slots_between_boxes_are_graded() {
        let room = |x1: f64| {
            scene(&EMPTY.replace(
                "[[light]]",
                &format!(
                    "[[box]]\nmin = [1.0, 1.0, 0.0]\nmax = [1.6, 1.8, 1.5]\nreflectance = 0.5\n\
                     [[box]]\nmin = [{x1}, 1.2, 0.0]\nmax = [{}, 2.0, 1.2]\nreflectance = 0.5\n[[light]]",
                    x1 + 0.6
                ),
            ))
        };
        // The longest side of every leaf on the plane x = `x` facing `sign` · x within the
        // faces' overlap (y 1.2–1.8, z 0–1.2).
        let longest = |solver: &SolverMesh, x: f64, sign: f64| {
            solver
                .mesh
                .patches
                .iter()
                .filter(|p| (p.centroid.x - x).abs() < 1e-9 && p.normal.x * sign > 0.5)
                .filter(|p| (1.2..1.8).contains(&p.centroid.y) && p.centroid.z < 1.2)
                .map(|p| {
                    let corners = p.vertex_ids().iter().map(|&v| solver.mesh.positions[v as usize]);
                    let (lo, hi) = corners.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), c| {
                        (lo.min(c), hi.max(c))
                    });
                    (hi - lo).max_element()
                })
                .fold(0.0f64, f64::max)
        };
        let s = room(1.65);
        let solver = refine(&s, &RefineOptions::default());
        assert_eq!(solver.slots, 1);
        assert!(
            longest(&solver, 1.6, 1.0) <= 0.1 + 1e-9,
            "{}",
            longest(&solver, 1.6, 1.0)
        );
        assert!(
            longest(&solver, 1.65, -1.0) <= 0.1 + 1e-9,
            "{}",
            longest(&solver, 1.65, -1.0)
        );
        let floor_strip = solver
            .mesh
            .patches
            .iter()
            .position(|p| {
                p.normal.z > 0.5
                    && p.centroid.z.abs() < 1e-9
                    && (1.6..1.65).contains(&p.centroid.x)
                    && (1.2..1.8).contains(&p.centroid.y)
            })
            .expect("a floor leaf between the boxes");
        assert!(solver.in_slot[floor_strip] && solver.alone[floor_strip]);
        let far = refine(&room(2.3), &RefineOptions::default());
        assert_eq!(far.slots, 0);
        assert!(longest(&far, 1.6, 1.0) >= 0.2, "{}", longest(&far, 1.6, 1.0));
    }

    /// The box's shadow line on the wall in a slot (the light 1.5 m up in front of a 0.8 m box
    /// 5 cm off the wall lights the wall behind it down to z ≈ 0.78) is graded across the line
    /// down to `SLOT_LIGHT_EDGE_FACTOR × shadow_min_m`: thin strips there (and along the box's
    /// outline, which the slot rule grades anyway), none holding the line with the rule off.
    #[test]
    fn shadow_line_in_a_slot_is_graded() {
        let s = scene(&EMPTY.replace("[2.0, 1.5, 1.2]", "[1.5, 1.5, 1.5]").replace(
            "[[light]]",
            "[[box]]\nmin = [1.0, 2.45, 0.0]\nmax = [2.0, 2.95, 0.8]\nreflectance = 0.4\n[[light]]",
        ));
        // (bottom, top) of every wall leaf behind the box (y = 3, facing −y, x 1–2, z < 0.8).
        let wall_leaves = |solver: &SolverMesh| -> Vec<(f64, f64)> {
            solver
                .mesh
                .patches
                .iter()
                .filter(|p| (p.centroid.y - 3.0).abs() < 1e-9 && p.normal.y < -0.5)
                .filter(|p| (1.0..2.0).contains(&p.centroid.x) && p.centroid.z < 0.8)
                .map(|p| {
                    let z = p
                        .vertex_ids()
                        .iter()
                        .map(|&v| solver.mesh.positions[v as usize].z);
                    z.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), z| {
                        (lo.min(z), hi.max(z))
                    })
                })
                .collect()
        };
        // The shadow line at x = 1.5: the ray from the light over the box's top edge.
        let line = 0.8 - 0.05 * (1.5 - 0.8) / (2.95 - 1.5);
        let options = RefineOptions::default();
        let graded = wall_leaves(&refine(&s, &options));
        let thin: Vec<_> = graded
            .iter()
            .filter(|(lo, hi)| hi - lo <= SLOT_LIGHT_EDGE_FACTOR * options.shadow_min_m + 1e-9)
            .collect();
        assert!(!thin.is_empty(), "{graded:?}");
        for (lo, hi) in &thin {
            assert!(
                *hi > line - 0.05 && *lo < line + 0.05,
                "a thin strip at {lo}–{hi}, the line at {line}"
            );
        }
        assert!(
            thin.iter().any(|(lo, hi)| *lo <= line && line <= *hi),
            "no thin strip holds the line at {line}: {thin:?}"
        );
        let off = wall_leaves(&refine(
            &s,
            &RefineOptions {
                shadow_min_m: 0.0,
                ..options
            },
        ));
        assert!(
            !off.iter().any(
                |(lo, hi)| hi - lo <= SLOT_LIGHT_EDGE_FACTOR * options.shadow_min_m + 1e-9
                    && *lo <= line
                    && line <= *hi
            ),
            "{off:?}"
        );
    }

    /// A hard 15° spot 1.2 m out from a picture frame (a box 4 cm deep against the wall) lights
    /// the frame's top only over a sliver at its front, where the beam's upper edge passes over
    /// it: the leaves there are graded to 1 cm or less across the wall contact and no longer
    /// along it than their far side's distance to the wall, and are sampled finely
    /// (`beam_edge`), as is every leaf that the beam's edge crosses beside a contact (on the
    /// wall beside the frame too) and no other; 0.6 m along the frame, beyond the beam, the top
    /// keeps the contact rule's 2 cm strips. The spot aimed at the floor grades none of it.
    #[test]
    fn a_beam_edge_beside_a_contact_is_graded_and_sampled_finely() {
        let room = |aim: &str| {
            scene(&format!(
                r#"
version = 1
[room]
size = [6.0, 4.5, 3.0]
[room.reflectance]
floor = 0.15
walls = 0.75
ceiling = 0.8
[[box]]
min = [3.6, 0.0, 1.0]
max = [5.0, 0.04, 2.1]
reflectance = 0.2
[[light]]
name = "spot"
position = [4.3, 1.2, 2.9]
aim = {aim}
lid = [[0, 9000], [15, 9000], [15, 0], [180, 0]]
[settings]
solver_patch_size = 0.5
"#
            ))
        };
        // The frame's top leaf holding (x, y) on z = 2.1: its index and extents along x and y.
        let top_leaf = |solver: &SolverMesh, x: f64, y: f64| -> (usize, f64, f64) {
            let m = &solver.mesh;
            m.patches
                .iter()
                .enumerate()
                .filter(|(_, p)| (p.centroid.z - 2.1).abs() < 1e-9 && p.normal.z > 0.5)
                .map(|(k, p)| {
                    let b = leaf_box(m, p);
                    (k, b.min, b.max)
                })
                .find(|(_, lo, hi)| lo.x <= x && x <= hi.x && lo.y <= y && y <= hi.y)
                .map(|(k, lo, hi)| (k, hi.x - lo.x, hi.y - lo.y))
                .expect("a leaf of the frame's top there")
        };
        let lit = refine(&room("[4.3, 0.04, 1.55]"), &RefineOptions::default());
        // At x = 4.31 the beam's edge crosses the top at y ≈ 2.9 cm, 1.1 cm from its front.
        let (k, along, across) = top_leaf(&lit, 4.31, 0.025);
        assert!(across <= 0.01 + 1e-9 && along <= 0.03, "{along} × {across} m");
        assert!(lit.beam_edge[k]);
        let (k, along, across) = top_leaf(&lit, 3.7, 0.035);
        assert!(
            (across - 0.02).abs() < 1e-9 && along > 0.05,
            "{along} × {across} m"
        );
        assert!(!lit.beam_edge[k]);
        // Every leaf sampled finely is crossed by the beam's edge: of 5 × 5 points over it,
        // some lie inside the 15° cone and some outside.
        let m = &lit.mesh;
        let (light, aim) = (
            DVec3::new(4.3, 1.2, 2.9),
            (DVec3::new(4.3, 0.04, 1.55) - DVec3::new(4.3, 1.2, 2.9)).normalize(),
        );
        let fine: Vec<usize> = (0..m.patches.len()).filter(|&k| lit.beam_edge[k]).collect();
        assert!(fine.len() >= 4, "{fine:?}");
        for &k in &fine {
            let c: Vec<DVec3> = m.patches[k]
                .vertex_ids()
                .iter()
                .map(|&v| m.positions[v as usize])
                .collect();
            let angles: Vec<f64> = (0..25)
                .map(|i| {
                    let (u, v) = ((i % 5) as f64 / 4.0, (i / 5) as f64 / 4.0);
                    let p = c[0] + (c[1] - c[0]) * u + (c[3] - c[0]) * v;
                    aim.angle_between(p - light).to_degrees()
                })
                .collect();
            assert!(
                angles.iter().any(|&a| a < 15.0) && angles.iter().any(|&a| a > 15.0),
                "{:?}: {angles:?}",
                m.patches[k].centroid
            );
        }
        let away = refine(&room("[4.3, 3.0, 0.0]"), &RefineOptions::default());
        let (_, along, across) = top_leaf(&away, 4.31, 0.035);
        assert!(
            (across - 0.02).abs() < 1e-9 && along > 0.05,
            "{along} × {across} m"
        );
        assert!(!away.beam_edge.contains(&true));
    }

    /// An OBJ block 5 cm above the floor makes a slot under it as a box does: the floor under
    /// it is meshed no coarser than twice the gap (0.1 m) and linked alone, the floor beside it
    /// is not. Resting on the floor (a contact, not a slot) or 0.7 m up (beyond `slot_max_m`)
    /// it makes none.
    #[test]
    fn slots_under_obj_objects_are_graded() {
        let solved = |z0: f64| {
            let obj = obj_block([1.0, 1.0, z0], [2.0, 1.8, z0 + 0.5], 1);
            let scene = crate::transport::mesh_contacts::obj_room(&obj, "");
            let solver = refine(&scene, &RefineOptions::default());
            (scene, solver)
        };
        let floor_under = |solver: &SolverMesh| -> Vec<(usize, f64)> {
            solver
                .mesh
                .patches
                .iter()
                .enumerate()
                .filter(|(_, p)| p.normal.z > 0.5 && p.centroid.z.abs() < 1e-9)
                .filter(|(_, p)| (1.0..2.0).contains(&p.centroid.x) && (1.0..1.8).contains(&p.centroid.y))
                .map(|(i, p)| {
                    let corners = p.vertex_ids().iter().map(|&v| solver.mesh.positions[v as usize]);
                    let (lo, hi) = corners.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), c| {
                        (lo.min(c), hi.max(c))
                    });
                    (i, (hi - lo).max_element())
                })
                .collect()
        };
        let (scene, solver) = solved(0.05);
        assert_eq!(solver.slots, 1);
        let under = floor_under(&solver);
        assert!(under.len() >= 10 * 8, "{} leaves", under.len());
        for &(i, size) in &under {
            assert!(
                size <= 0.1 + 1e-9 && solver.alone[i] && solver.in_slot[i],
                "{size} m"
            );
        }
        let beside = solver
            .mesh
            .patches
            .iter()
            .position(|p| p.normal.z > 0.5 && p.centroid.z.abs() < 1e-9 && p.centroid.x > 3.0)
            .expect("a floor leaf away from the block");
        assert!(!solver.alone[beside] && !solver.in_slot[beside]);
        assert!(solver.notes(&scene).join("\n").contains("and 1 slots"));
        for z0 in [0.0, 0.7] {
            let (_, solver) = solved(z0);
            assert_eq!(solver.slots, 0, "{z0} m up");
            assert!(
                floor_under(&solver).iter().all(|&(i, _)| !solver.in_slot[i]),
                "{z0} m up"
            );
        }
    }

    /// A gap of exactly `slot_max_m` (0.6 m here) makes a slot however the room's numbers round:
    /// two boxes 0.6 m off the wall y = 3 (3.0 − 2.4 = 0.6000000000000001) and 0.6 m apart (2.2 − 1.6,
    /// the same) make three slots, and moved 1 cm further, none.
    #[test]
    fn gaps_of_slot_max_are_slots_however_they_round() {
        let room = |shift: f64| {
            let boxes: String = [(1.0, 1.6), (2.2 + shift, 2.8 + shift)]
                .iter()
                .map(|(x0, x1)| {
                    format!(
                        "[[box]]\nmin = [{x0}, {}, 0.0]\nmax = [{x1}, {}, 0.8]\nreflectance = 0.4\n",
                        1.4 - shift,
                        2.4 - shift
                    )
                })
                .collect();
            scene(&EMPTY.replace("[[light]]", &format!("{boxes}[[light]]")))
        };
        let slot_max_m = 0.6;
        assert_eq!(3.0 - 2.4, 0.6000000000000001);
        assert_eq!(slots(&room(0.0), slot_max_m).len(), 3);
        assert_eq!(slots(&room(0.01), slot_max_m).len(), 0);
    }

    /// A box standing 5 cm in front of the wall y = 3 makes a slot: the wall behind it and the
    /// box's back face are meshed no coarser than twice the gap (0.1 m) over the slot, and the
    /// plan says so; 0.45 m off it makes a wider one, graded along its outline; 0.7 m off the
    /// wall, or with the rule off, none.
    #[test]
    fn slots_behind_boxes_are_graded() {
        let room = |y0: f64, y1: f64| {
            scene(&EMPTY.replace("[2.0, 1.5, 1.2]", "[3.2, 1.5, 1.5]").replace(
                "[[light]]",
                &format!(
                    "[[box]]\nmin = [1.0, {y0}, 0.0]\nmax = [2.0, {y1}, 0.8]\nreflectance = 0.4\n[[light]]"
                ),
            ))
        };
        // The longest side of every leaf at y = `y` facing `-y` that overlaps the slot's
        // outline (x 1–2, z 0–0.8), and their number.
        let in_slot = |solver: &SolverMesh, y: f64| {
            solver
                .mesh
                .patches
                .iter()
                .filter(|p| (p.centroid.y - y).abs() < 1e-9 && p.normal.y < -0.5)
                .filter_map(|p| {
                    let corners = p.vertex_ids().iter().map(|&v| solver.mesh.positions[v as usize]);
                    let (lo, hi) = corners.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), c| {
                        (lo.min(c), hi.max(c))
                    });
                    (lo.x < 2.0 - 1e-9 && hi.x > 1.0 + 1e-9 && lo.z < 0.8 - 1e-9)
                        .then(|| (hi - lo).max_element())
                })
                .fold((0.0f64, 0usize), |(m, n), l| (m.max(l), n + 1))
        };
        let s = room(2.45, 2.95);
        let solver = refine(&s, &RefineOptions::default());
        assert_eq!(solver.slots, 1);
        let (wall, n_wall) = in_slot(&solver, 3.0);
        assert!(
            wall <= 0.1 + 1e-9 && n_wall >= 10 * 8,
            "{wall} m, {n_wall} leaves"
        );
        // The box's back face faces +y: its leaves are at y = 2.95 facing +y.
        let back = solver
            .mesh
            .patches
            .iter()
            .filter(|p| (p.centroid.y - 2.95).abs() < 1e-9 && p.normal.y > 0.5)
            .map(|p| {
                let corners = p.vertex_ids().iter().map(|&v| solver.mesh.positions[v as usize]);
                let (lo, hi) = corners.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), c| {
                    (lo.min(c), hi.max(c))
                });
                (hi - lo).max_element()
            })
            .fold(0.0f64, f64::max);
        assert!(back <= 0.1 + 1e-9, "{back} m on the box's back face");
        // Every leaf in the slot — the wall, the box's back face and the floor strip between
        // them — is linked alone; the wall beside the box is not.
        let floor_strip = solver
            .mesh
            .patches
            .iter()
            .position(|p| {
                p.normal.z > 0.5
                    && p.centroid.z.abs() < 1e-9
                    && p.centroid.y > 2.95
                    && (1.0..2.0).contains(&p.centroid.x)
            })
            .expect("a floor leaf in the slot");
        assert!(solver.alone[floor_strip]);
        for (i, p) in solver.mesh.patches.iter().enumerate() {
            if (p.centroid.y - 3.0).abs() < 1e-9 {
                let behind = (1.0..=2.0).contains(&p.centroid.x) && p.centroid.z <= 0.8;
                assert_eq!(solver.alone[i], behind, "{:?}", p.centroid);
            }
        }
        let notes = solver.notes(&s).join("\n");
        assert!(notes.contains("and 1 slots"), "{notes}");
        // The rule off: the wall behind keeps leaves of 0.25 m and more there.
        let rule_off = |scene: &Scene| {
            refine(
                scene,
                &RefineOptions {
                    slot_max_m: 0.0,
                    ..RefineOptions::default()
                },
            )
        };
        let off = rule_off(&s);
        assert_eq!(off.slots, 0);
        assert!(in_slot(&off, 3.0).0 >= 0.25, "{:?}", in_slot(&off, 3.0));
        // 0.7 m off the wall (beyond `slot_max_m`, 0.6 m): no slot.
        let far = refine(&room(1.8, 2.3), &RefineOptions::default());
        assert_eq!(far.slots, 0);
        assert!(in_slot(&far, 3.0).0 >= 0.25, "{:?}", in_slot(&far, 3.0));
        // 0.45 m off (a wide slot): graded along the outline (more leaves on
        // the wall behind than with the rule off), its leaves linked alone.
        let wide = room(2.1, 2.55);
        let (graded, ungraded) = (refine(&wide, &RefineOptions::default()), rule_off(&wide));
        assert_eq!(graded.slots, 1);
        let (behind, behind_off) = (in_slot(&graded, 3.0), in_slot(&ungraded, 3.0));
        assert!(behind.1 > behind_off.1, "{behind:?} against {behind_off:?}");
        assert!(graded.in_slot.contains(&true) && !ungraded.in_slot.contains(&true));
    }

    /// With the default grading the strips of a box side along the floor are at most
    /// `CONTACT_ASPECT` times as long as their top's height — the strips above the lowest one
    /// too (0.5 m long before, the coarse patch's length, where the side's light varies along
    /// the floor's pattern).
    #[test]
    fn contact_strips_are_short_along_the_edge() {
        let s = box_room("[3.2, 1.5, 1.5]");
        let solver = refine(&s, &RefineOptions::default());
        let side = s.surfaces.iter().position(|x| x.name == "box0-x1").unwrap() as u32;
        let mut strips = 0;
        for p in solver.mesh.patches.iter().filter(|p| p.surface == side) {
            let corners = p.vertex_ids().iter().map(|&v| solver.mesh.positions[v as usize]);
            let (lo, hi) = corners.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), c| {
                (lo.min(c), hi.max(c))
            });
            let length = hi.y - lo.y;
            assert!(length <= CONTACT_ASPECT * hi.z + 1e-9, "{lo:?}..{hi:?}");
            if hi.z < 0.1 && lo.z > 0.0 {
                strips += 1;
                assert!(length < 0.5, "{lo:?}..{hi:?}");
            }
        }
        assert!(strips > 0);
    }

    /// A hard spot's pool ending 0.13 m from the wall y = 0 (docs/DECISIONS.md "Room edges are
    /// graded where the direct light bends"): the floor and the wall next to that edge under
    /// the pool, where the light bends across and (the pool being round) along the edge, are
    /// graded to strips of 0.0625 m (0.5 m halved while wider than twice half of 0.1 m) at most
    /// 0.125 m long,
    /// more coarsely with the distance from those pieces along the edge, the far wall keeps its
    /// 0.5 m patches, and the plan says so; with the rule off the floor there keeps its coarse
    /// patches.
    #[test]
    fn room_edges_are_graded_where_the_direct_light_bends() {
        let s = scene(&EMPTY.replace("[2.0, 1.5, 1.2]", "[2.0, 1.0, 2.4]").replace(
            "[[0, 100], [90, 0]]",
            "[[0, 5000], [20, 5000], [20, 0], [180, 0]]",
        ));
        // The (across, along) extents of the leaves of surface `name` touching y = 0.
        let at_wall = |solver: &SolverMesh, name: &str| -> Vec<(f64, f64, f64)> {
            let surface = s.surfaces.iter().position(|x| x.name == name).unwrap() as u32;
            solver
                .mesh
                .patches
                .iter()
                .filter(|p| p.surface == surface)
                .filter_map(|p| {
                    let corners = p.vertex_ids().iter().map(|&v| solver.mesh.positions[v as usize]);
                    let (lo, hi) = corners.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), c| {
                        (lo.min(c), hi.max(c))
                    });
                    let touches = if name == "floor" { lo.y == 0.0 } else { lo.z == 0.0 };
                    let across = if name == "floor" { hi.y - lo.y } else { hi.z - lo.z };
                    touches.then_some((p.centroid.x, across, hi.x - lo.x))
                })
                .collect()
        };
        let options = RefineOptions::default();
        let solver = refine(&s, &options);
        for name in ["floor", "wall-y0"] {
            let leaves = at_wall(&solver, name);
            assert!(leaves.len() >= 8, "{name}: {leaves:?}");
            for &(x, across, along) in &leaves {
                if (1.0..3.0).contains(&x) {
                    // The round pool's end bends along the edge too: strips of at most twice
                    // half of 0.1 m across, at most an eighth of a piece along.
                    assert!(across <= 0.1 + 1e-12, "{name} at x {x}: {across} m wide");
                    assert!(along <= 0.0625 + 1e-12, "{name} at x {x}: {along} m long");
                } else if !(0.5..3.5).contains(&x) {
                    // 0.5 m from the graded pieces: halved once (0.5 > 0.5 × 0.5 m), no more.
                    assert!((across - 0.25).abs() < 1e-12, "{name} at x {x}: {across} m wide");
                }
            }
        }
        assert_eq!(solver.room_edges, 4);
        let notes = solver.notes(&s).join("\n");
        assert!(
            notes.contains("graded along 4 pieces of the room's edges") && notes.contains("0.20 m"),
            "{notes}"
        );
        // The far wall y = 3 keeps its coarse patches along the floor.
        let far = s.surfaces.iter().position(|x| x.name == "wall-y1").unwrap() as u32;
        assert!(
            solver
                .mesh
                .patches
                .iter()
                .filter(|p| p.surface == far)
                .all(|p| (p.area - 0.25).abs() < 1e-12)
        );
        let off = refine(
            &s,
            &RefineOptions {
                room_edge_min_m: 0.0,
                ..options
            },
        );
        assert_eq!(off.room_edges, 0);
        assert!(
            at_wall(&off, "floor")
                .iter()
                .all(|&(_, across, _)| (across - 0.5).abs() < 1e-12)
        );
    }

    /// The refinement can be turned off.
    #[test]
    fn refinement_off_keeps_the_coarse_mesh() {
        let s = box_room("[2.1, 1.4, 2.3]");
        let solver = refine(&s, &RefineOptions::none());
        assert_eq!(solver.mesh.patches.len(), s.coarse.patches.len());
    }
}
