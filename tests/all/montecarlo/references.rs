//! Committed Monte-Carlo references of total illuminance for the rooms in
//! `tests/data/references/*.toml` (box contacts beside lamps close to the ceiling, grazing
//! wall-washers, hard-edged spots, a white room, an empty room, an office with desks, a 12 m hall,
//! OBJ furniture — a plinth turned 30° and a sideboard — in a coloured room under a warm spot,
//! furniture standing 5 and 10 cm off the walls, two cupboards 5 cm apart, boxes stacked against a
//! wall, a white corridor, a narrow spot across a desk's edge, a corner niche, a partition from
//! floor to ceiling with a doorway and a wall cabinet, wall sconces grazing a wall up and down,
//! cove lighting on a ledge under the ceiling, an open bookshelf with a shelf light in one of
//! its compartments, batwings under a low ceiling beside a column, lamps 1–2 cm from a ceiling,
//! a wall and the floor, a white closet, puck lights 1 cm above a desk, an 8 m atrium's wall
//! grazers, hard spots into corners, lamps at OBJ furniture, OBJ models hovering just above the
//! floor),
//! 148–268 points each on floors, box
//! and mesh tops and faces, walls and ceilings, including points 1–20 cm from box and mesh faces
//! and 2–15 cm from the room's floor and ceiling edges. Each `<room>.csv` holds `x,y,z,nx,ny,nz,lux,std_error,direct,paths`: the
//! estimate, its standard error (lx, < 0.3 % of the value), the exact direct part and the number of
//! paths.
//!
//! * [`committed_references_agree_with_fresh_estimates`] (always runs) re-estimates a few points
//!   per room at a low path count with another seed and checks they agree with the data within
//!   their joint statistical error, and that the data's points are the ones [`points`] makes, so
//!   the data cannot silently rot. With `HAIKO_UPDATE_REFERENCES=1` (or a comma-separated list of
//!   room names) it regenerates the data instead — minutes per room, so use a release build:
//!   `HAIKO_UPDATE_REFERENCES=1 cargo test --release --test all montecarlo::references`.
//! * [`errors_against_references`] measures Haiko's probe (exact direct light plus indirect light
//!   gathered from the bake) against the data: median and worst relative error per room.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use glam::DVec3;
use haiko::scene::{DirectMode, Scene, load};
use haiko::transport::bake::{BakeOptions, bake};
use haiko::transport::direct::{Dimmers, Receiver, lights_direct_rgb_at, luminance_weight, scene_direct_at};
use haiko::transport::gather::illuminance_at_receivers;
use haiko::transport::interreflection::{Interreflection, InterreflectionOptions};
use haiko::transport::occlusion::Occluders;
use haiko::transport::plan::{PlanOptions, plan};
use haiko::transport::radiosity::SolveOptions;
use rayon::prelude::*;

use super::tracer::{Estimate, Rng, Tracer};

/// The reference rooms (file stems in `tests/data/references/`).
pub const ROOMS: [&str; 33] = [
    "hotspot-box",
    "lamp-near-box",
    "wall-washers",
    "spots",
    "white-room",
    "empty",
    "office",
    "hall",
    "mesh-colour",
    "furniture-gaps",
    "cupboards",
    "stacked",
    "white-corridor",
    "spot-on-edge",
    "accents",
    "niche",
    "partition",
    "sconces",
    "cove",
    "pictures",
    "shelves",
    "batwing",
    "near-surfaces",
    "closet",
    "desk-lamps",
    "atrium",
    "corners",
    "mesh-lamps",
    "sofa-corner",
    "obj-on-box",
    "obj-on-obj",
    "table-things",
    "hovering-models",
];

/// The environment variable that regenerates the references.
pub const UPDATE_ENV: &str = "HAIKO_UPDATE_REFERENCES";

/// Target standard error of a reference, relative to its value (the data promises < 0.3 %).
const TARGET_RELATIVE_ERROR: f64 = 0.0025;
/// Paths per batch are `STRATA²` (the first direction stratified on this grid).
const STRATA: usize = 48;
/// Batches added per round of the adaptive estimate, and the most batches per point.
const ROUND_BATCHES: usize = 8;
const MAX_BATCHES: usize = 12_288;

/// The CSV header of a reference file.
const HEADER: &str = "x,y,z,nx,ny,nz,lux,std_error,direct,paths";

/// Directory of the reference rooms and data.
pub fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/references")
}

/// Loads reference room `name`.
pub fn room(name: &str) -> Scene {
    let path = dir().join(format!("{name}.toml"));
    load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// One committed reference point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reference {
    pub point: DVec3,
    pub normal: DVec3,
    pub lux: f64,
    pub std_error: f64,
    pub direct: f64,
    pub paths: usize,
}

impl Reference {
    /// The reference at `point` (unit `normal`) that the estimate `e` made.
    pub fn traced(point: DVec3, normal: DVec3, e: &Estimate) -> Self {
        Reference {
            point,
            normal,
            lux: e.total,
            std_error: e.std_error,
            direct: e.direct,
            paths: e.paths,
        }
    }

    /// The receiver the reference was traced at.
    pub fn receiver(&self) -> Receiver {
        Receiver {
            point: self.point,
            normal: self.normal,
        }
    }
}

/// Reads `<name>.csv`.
pub fn read(name: &str) -> Vec<Reference> {
    let path = dir().join(format!("{name}.csv"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some(HEADER), "{}: header", path.display());
    lines
        .map(|line| {
            let v: Vec<f64> = line
                .split(',')
                .map(|f| {
                    f.parse()
                        .unwrap_or_else(|_| panic!("{}: `{line}`", path.display()))
                })
                .collect();
            assert_eq!(v.len(), 10, "{}: `{line}`", path.display());
            Reference {
                point: DVec3::new(v[0], v[1], v[2]),
                normal: DVec3::new(v[3], v[4], v[5]),
                lux: v[6],
                std_error: v[7],
                direct: v[8],
                paths: v[9] as usize,
            }
        })
        .collect()
}

fn write(name: &str, refs: &[Reference]) {
    let mut out = format!("{HEADER}\n");
    for r in refs {
        let (p, n) = (r.point, r.normal);
        let _ = writeln!(
            out,
            "{},{},{},{},{},{},{:.6},{:.6},{:.6},{}",
            p.x, p.y, p.z, n.x, n.y, n.z, r.lux, r.std_error, r.direct, r.paths
        );
    }
    let path = dir().join(format!("{name}.csv"));
    std::fs::write(&path, out).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
}

/// Rounds to the millimetre (the points are written with full precision but made on a mm grid).
fn mm(x: f64) -> f64 {
    (x * 1000.0).round() / 1000.0
}

/// Collects receivers, dropping any whose surface side is inside or against a box, inside an OBJ
/// mesh's bounds (or outside the room).
struct Points<'a> {
    scene: &'a Scene,
    out: Vec<(DVec3, DVec3)>,
}

impl Points<'_> {
    fn add(&mut self, p: DVec3, n: DVec3) {
        self.add_checked(p, n, true);
    }

    /// A receiver placed beside an OBJ mesh's faces by the caller, inside the mesh's bounds.
    fn add_beside_mesh(&mut self, p: DVec3, n: DVec3) {
        self.add_checked(p, n, false);
    }

    fn add_checked(&mut self, p: DVec3, n: DVec3, outside_meshes: bool) {
        let p = DVec3::new(mm(p.x), mm(p.y), mm(p.z));
        // 5 mm off the surface the point must be in the room and at least 4 mm from every box
        // (a point on a box's own face is 5 mm from it; one on the floor under a box's edge is
        // not a receiver anyone can measure).
        let probe = p + n * 5e-3;
        let size = self.scene.room_size;
        let inside_room = probe.cmpgt(DVec3::ZERO).all() && probe.cmplt(size).all();
        let in_box = self
            .scene
            .boxes
            .iter()
            .any(|b| probe.distance(probe.clamp(b.min, b.max)) < 4e-3);
        let in_mesh = outside_meshes
            && self
                .scene
                .mesh_bounds
                .iter()
                .any(|b| probe.distance(probe.clamp(b.min, b.max)) < 4e-3);
        let duplicate = self.out.iter().any(|&(q, m)| q == p && m == n);
        if inside_room && !in_box && !in_mesh && !duplicate {
            self.out.push((p, n));
        }
    }
}

/// The receivers of a reference room: grids on the floor, ceiling and walls; per box its top, the
/// floor 1–20 cm from its sides and its sides 1–20 cm above the floor; the ceiling and walls near
/// lights hung close to them; for the wall-washer room, the ceiling 5–50 cm from the washed
/// wall and that wall's top; for the OBJ room, the floor 1–20 cm from the turned plinth's faces
/// and the sideboard's front, those faces 1 cm–0.6 m up, their tops, and the wall above and
/// beside the sideboard; for the room of furniture off the walls, the walls in each slot (its
/// middle, near its end, beside it and above), the floor and the cupboard's back face in it; for
/// the two cupboards, both faces in the slot between them, the floor there and the taller
/// one's face above the slot; in every room the floor, ceiling and walls 2–15 cm from the
/// middles of the floor and ceiling edges; for the stacked boxes, the cabinet's top and the
/// upper box's faces around their contact and the wall beside them; for the white corridor, the
/// washed end wall, the ceiling by it and the corner the spot's pool fills; for the spot on the
/// edge, the desk's top, front face and the floor across the spot's cut-off, and the side table
/// and ceiling around the table lamp; for the niche, the corner cupboard's grazed front face,
/// its side, the wall beside it and the ceiling above it, the step light's pool and the wall
/// below it, and the corner by the pendant; for the partition, its dark face up to the ceiling
/// and the ceiling beyond it, its washed face and the ceiling beside it, the doorway, the dark
/// corner behind it, and the wall cabinet's underside, the wall and the floor below it; for the
/// sconces, the wall along and beside one sconce's beams up to the ceiling, the ceiling's edge
/// above it, the sideboard's top under the sconces from its contact with the wall out, and the
/// wall just above it; for the cove, the ceiling from the cove's wall out, the wall above the
/// ledge, the ledge's front and underside and the wall under it; for the pictures, their faces,
/// the wall 1–30 cm above, below and beside them, their frames' top faces and the ceiling above
/// them by the wall; for the shelves, in each compartment its floor, the wall behind it, the
/// shelf's underside above it and the side panel's face, and the floor in front of the shelf;
/// for the batwings, the ceiling out from each and beside the column, and the column's faces.
pub fn points(name: &str, scene: &Scene) -> Vec<(DVec3, DVec3)> {
    let s = scene.room_size;
    let mut pts = Points {
        scene,
        out: Vec::new(),
    };
    let grid = |n: usize, k: usize| (k as f64 + 0.5) / n as f64;
    for i in 0..8 {
        for j in 0..5 {
            pts.add(DVec3::new(s.x * grid(8, i), s.y * grid(5, j), 0.0), DVec3::Z);
        }
    }
    for i in 0..5 {
        for j in 0..4 {
            pts.add(DVec3::new(s.x * grid(5, i), s.y * grid(4, j), s.z), DVec3::NEG_Z);
        }
    }
    for k in 0..3 {
        for z in [0.8, 1.5, s.z - 0.3] {
            let (fx, fy) = (s.x * grid(3, k), s.y * grid(3, k));
            pts.add(DVec3::new(0.0, fy, z), DVec3::X);
            pts.add(DVec3::new(s.x, fy, z), DVec3::NEG_X);
            pts.add(DVec3::new(fx, 0.0, z), DVec3::Y);
            pts.add(DVec3::new(fx, s.y, z), DVec3::NEG_Y);
        }
    }
    // The room's edges: the floor and the ceiling 2–15 cm from the middle of each wall, and
    // the wall 2–15 cm from them (where the other surface fills half of what a point sees).
    for (wall, inward) in [
        (DVec3::new(0.0, s.y / 2.0, 0.0), DVec3::X),
        (DVec3::new(s.x, s.y / 2.0, 0.0), DVec3::NEG_X),
        (DVec3::new(s.x / 2.0, 0.0, 0.0), DVec3::Y),
        (DVec3::new(s.x / 2.0, s.y, 0.0), DVec3::NEG_Y),
    ] {
        for d in [0.02, 0.05, 0.15] {
            pts.add(wall + inward * d, DVec3::Z);
            pts.add(wall + inward * d + DVec3::Z * s.z, DVec3::NEG_Z);
            pts.add(wall + DVec3::Z * d, inward);
            pts.add(wall + DVec3::Z * (s.z - d), inward);
        }
    }
    let detailed_boxes = if scene.boxes.len() > 2 {
        1
    } else {
        scene.boxes.len()
    };
    for (index, b) in scene.boxes.iter().enumerate() {
        let c = (b.min + b.max) / 2.0;
        pts.add(DVec3::new(c.x, c.y, b.max.z), DVec3::Z);
        pts.add(DVec3::new(b.min.x + 0.05, b.min.y + 0.05, b.max.z), DVec3::Z);
        let distances: &[f64] = if index < detailed_boxes {
            &[0.01, 0.02, 0.05, 0.1, 0.2]
        } else {
            &[0.02, 0.1]
        };
        // The four sides: (outward normal, point on the side at floor level, along-side vector).
        let sides = [
            (
                DVec3::NEG_X,
                DVec3::new(b.min.x, c.y, 0.0),
                DVec3::Y * (b.max.y - b.min.y),
            ),
            (
                DVec3::X,
                DVec3::new(b.max.x, c.y, 0.0),
                DVec3::Y * (b.max.y - b.min.y),
            ),
            (
                DVec3::NEG_Y,
                DVec3::new(c.x, b.min.y, 0.0),
                DVec3::X * (b.max.x - b.min.x),
            ),
            (
                DVec3::Y,
                DVec3::new(c.x, b.max.y, 0.0),
                DVec3::X * (b.max.x - b.min.x),
            ),
        ];
        for (out, mid, along) in sides {
            for &d in distances {
                pts.add(mid + out * d, DVec3::Z);
            }
            if index < detailed_boxes {
                for &d in &[0.05, 0.2] {
                    pts.add(mid + along * 0.25 + out * d, DVec3::Z);
                }
                for h in [0.01, 0.05, 0.2] {
                    pts.add(mid + DVec3::Z * h, out);
                }
            }
        }
    }
    for light in &scene.lights {
        let p = light.position;
        if s.z - p.z <= 0.5 {
            for r in [0.0, 0.1, 0.3, 0.6] {
                pts.add(DVec3::new(p.x + r, p.y, s.z), DVec3::NEG_Z);
            }
        }
    }
    if name == "accents" {
        // The accent's pool on the wall x = 5 just under the ceiling, and the ceiling beside it.
        for y in [2.0, 2.3] {
            for z in [2.78, 2.75, 2.7, 2.6, 2.4] {
                pts.add(DVec3::new(s.x, y, z), DVec3::NEG_X);
            }
        }
        for d in [0.02, 0.05, 0.15] {
            pts.add(DVec3::new(s.x - d, 2.3, s.z), DVec3::NEG_Z);
        }
        // The floor between the floor spot's pool (ending 0.58 m from the wall y = 0) and the
        // wall, and the wall above it.
        for d in [0.3, 0.5, 0.6, 0.7] {
            pts.add(DVec3::new(2.5, d, 0.0), DVec3::Z);
        }
        for z in [0.05, 0.15, 0.3] {
            pts.add(DVec3::new(2.5, 0.0, z), DVec3::Y);
        }
        // The ceiling the up-lighter washes beside the wall y = 4, and that wall's top.
        for y in [3.9, 3.7, 3.5] {
            pts.add(DVec3::new(2.5, y, s.z), DVec3::NEG_Z);
        }
        for z in [2.75, 2.65, 2.5] {
            pts.add(DVec3::new(2.5, s.y, z), DVec3::NEG_Y);
        }
    }
    if name == "niche" {
        // The corner cupboard's front face (y = 0.6) under the grazing spot, its side face
        // (x = 3.3), the wall y = 0 beside it, and the ceiling above it.
        for x in [3.9, 3.4] {
            for z in [0.05, 0.5, 1.0, 1.5, 1.9, 1.98] {
                pts.add(DVec3::new(x, 0.6, z), DVec3::Y);
            }
        }
        for z in [0.05, 1.0, 1.95] {
            pts.add(DVec3::new(3.3, 0.3, z), DVec3::NEG_X);
        }
        for x in [3.28, 3.2, 3.05] {
            for z in [1.0, 2.02, 2.2] {
                pts.add(DVec3::new(x, 0.0, z), DVec3::Y);
            }
        }
        pts.add(DVec3::new(3.9, 0.3, s.z), DVec3::NEG_Z);
        // The step light's pool on the dark floor and the wall x = 0 below and beside it.
        for x in [0.03, 0.1, 0.2, 0.4, 0.7, 1.0, 1.5] {
            pts.add(DVec3::new(x, 2.0, 0.0), DVec3::Z);
        }
        pts.add(DVec3::new(0.5, 2.4, 0.0), DVec3::Z);
        for (y, z) in [(2.0, 0.05), (2.0, 0.15), (2.3, 0.3), (2.0, 0.6)] {
            pts.add(DVec3::new(0.0, y, z), DVec3::X);
        }
        // The corner by the pendant: the ceiling and both walls.
        for (x, y) in [(0.15, 3.35), (0.05, 3.45), (0.4, 3.1)] {
            pts.add(DVec3::new(x, y, s.z), DVec3::NEG_Z);
        }
        for z in [1.8, 2.2, 2.38] {
            pts.add(DVec3::new(0.0, 3.35, z), DVec3::X);
            pts.add(DVec3::new(0.15, s.y, z), DVec3::NEG_Y);
        }
    }
    if name == "partition" {
        // The partition's dark face (x = 3.1) up to its contact with the ceiling, and the
        // ceiling beyond it.
        for y in [0.5, 1.4, 2.6] {
            for z in [0.05, 1.0, 2.0, 2.6, 2.68] {
                pts.add(DVec3::new(3.1, y, z), DVec3::X);
            }
        }
        for x in [3.12, 3.15, 3.3, 3.6] {
            pts.add(DVec3::new(x, 1.4, s.z), DVec3::NEG_Z);
        }
        // The lit face (x = 2.9) the uplight washes, and the ceiling between them.
        for z in [1.9, 2.3, 2.6, 2.68] {
            pts.add(DVec3::new(2.9, 1.0, z), DVec3::NEG_X);
        }
        for x in [2.88, 2.85, 2.75, 2.5] {
            pts.add(DVec3::new(x, 1.0, s.z), DVec3::NEG_Z);
        }
        // The doorway: its floor, the partition's end face and the wall y = 0 in the dark
        // corner behind the partition.
        for x in [2.8, 3.0, 3.2, 3.6] {
            pts.add(DVec3::new(x, 3.4, 0.0), DVec3::Z);
        }
        for z in [0.5, 1.5, 2.5] {
            pts.add(DVec3::new(3.0, 2.8, z), DVec3::Y);
        }
        for x in [3.15, 3.3, 4.0] {
            for z in [1.0, 2.6] {
                pts.add(DVec3::new(x, 0.0, z), DVec3::Y);
            }
        }
        // Under the wall cabinet: its underside beside the strip light, the wall below it and
        // the floor under it.
        for (x, y) in [(5.65, 1.0), (5.9, 1.6)] {
            pts.add(DVec3::new(x, y, 1.5), DVec3::NEG_Z);
        }
        for z in [1.45, 1.3, 1.0, 0.5] {
            pts.add(DVec3::new(s.x, 1.2, z), DVec3::NEG_X);
        }
        for x in [5.8, 5.5, 5.0] {
            pts.add(DVec3::new(x, 1.2, 0.0), DVec3::Z);
        }
    }
    if name == "sconces" {
        // The wall x = 0 along and beside the left sconce's beams, up to the ceiling, and the
        // ceiling's edge above it.
        for y in [1.3, 1.4, 1.6] {
            for z in [1.2, 1.5, 1.7, 1.9, 2.1, 2.4, 2.6, 2.68] {
                pts.add(DVec3::new(0.0, y, z), DVec3::X);
            }
        }
        for x in [0.02, 0.05, 0.15, 0.3, 0.6] {
            pts.add(DVec3::new(x, 1.3, s.z), DVec3::NEG_Z);
        }
        // The sideboard's top under the sconces, from its contact with the wall out, and the
        // wall just above it.
        for x in [0.02, 0.05, 0.1, 0.2, 0.4] {
            pts.add(DVec3::new(x, 1.3, 0.9), DVec3::Z);
            pts.add(DVec3::new(x, 2.0, 0.9), DVec3::Z);
        }
        for z in [0.92, 1.0, 1.1] {
            pts.add(DVec3::new(0.0, 1.3, z), DVec3::X);
            pts.add(DVec3::new(0.0, 2.0, z), DVec3::X);
        }
    }
    if name == "cove" {
        // The ceiling from the cove's wall out, over and between the lamps.
        for y in [2.0, 1.35] {
            for x in [0.02, 0.05, 0.15, 0.3, 0.5, 1.0] {
                pts.add(DVec3::new(x, y, s.z), DVec3::NEG_Z);
            }
        }
        // The wall above the ledge, the ledge's front face and its underside, and the wall
        // under it.
        for z in [2.42, 2.5, 2.6, 2.68] {
            pts.add(DVec3::new(0.0, 2.0, z), DVec3::X);
        }
        for z in [2.32, 2.38] {
            pts.add(DVec3::new(0.3, 2.0, z), DVec3::X);
        }
        for x in [0.02, 0.15, 0.28] {
            pts.add(DVec3::new(x, 2.0, 2.3), DVec3::NEG_Z);
        }
        for z in [2.28, 2.2, 2.0, 1.5] {
            pts.add(DVec3::new(0.0, 2.0, z), DVec3::X);
        }
    }
    if name == "pictures" {
        // Each picture's face, the wall just above and below its frame and beside it, and the
        // frame's top face.
        for (x, z0, z1) in [(1.6, 1.2, 2.0), (4.3, 1.0, 2.1)] {
            for z in [z0 + 0.1, (z0 + z1) / 2.0] {
                pts.add(DVec3::new(x, 0.04, z), DVec3::Y);
            }
            for d in [0.01, 0.03, 0.1, 0.3] {
                pts.add(DVec3::new(x, 0.0, z1 + d), DVec3::Y);
                pts.add(DVec3::new(x, 0.0, z0 - d), DVec3::Y);
            }
            pts.add(DVec3::new(x, 0.02, z1), DVec3::Z);
        }
        for d in [0.01, 0.05, 0.2] {
            pts.add(DVec3::new(1.0 - d, 0.0, 1.6), DVec3::Y);
            pts.add(DVec3::new(5.0 + d, 0.0, 1.5), DVec3::Y);
        }
        // The ceiling above the pictures, by the wall.
        for d in [0.02, 0.1, 0.3] {
            pts.add(DVec3::new(1.6, d, s.z), DVec3::NEG_Z);
            pts.add(DVec3::new(4.3, d, s.z), DVec3::NEG_Z);
        }
    }
    if name == "shelves" {
        // In each compartment: its floor (front, middle, back, by the side panel), the wall
        // behind it (low, middle, high), the underside of the shelf above, and the side panel's
        // inner face; the floor in front of the shelf.
        let compartments = [(0.1, 0.48), (0.5, 0.88), (0.9, 1.28), (1.3, 1.68), (1.7, 1.98)];
        for (z0, z1) in compartments {
            for y in [3.18, 3.3, 3.47] {
                pts.add(DVec3::new(1.8, y, z0), DVec3::Z);
            }
            pts.add(DVec3::new(1.05, 3.3, z0), DVec3::Z);
            for z in [z0 + 0.02, (z0 + z1) / 2.0, z1 - 0.02] {
                pts.add(DVec3::new(1.8, s.y, z), DVec3::NEG_Y);
            }
            for y in [3.2, 3.45] {
                pts.add(DVec3::new(1.8, y, z1), DVec3::NEG_Z);
            }
            pts.add(DVec3::new(1.02, 3.3, (z0 + z1) / 2.0), DVec3::X);
        }
        for d in [0.01, 0.05, 0.2] {
            pts.add(DVec3::new(1.8, 3.15 - d, 0.0), DVec3::Z);
        }
    }
    if name == "batwing" {
        // The ceiling the batwings graze from 5 cm, out from each; the column's faces towards
        // and away from the near one, low, middle and just under the ceiling; the ceiling beside
        // the column.
        for x0 in [1.8, 4.5] {
            for d in [0.1, 0.2, 0.4, 0.8] {
                pts.add(DVec3::new(x0 + d, 2.0, s.z), DVec3::NEG_Z);
            }
        }
        for (x, n) in [(2.35, DVec3::NEG_X), (2.65, DVec3::X)] {
            for z in [0.3, 1.2, 2.2, 2.38] {
                pts.add(DVec3::new(x, 2.0, z), n);
            }
        }
        for d in [0.02, 0.1] {
            pts.add(DVec3::new(2.35 - d, 2.0, s.z), DVec3::NEG_Z);
            pts.add(DVec3::new(2.5, 1.85 - d, s.z), DVec3::NEG_Z);
        }
    }
    if name == "near-surfaces" {
        // The wall x = 5 the grazer lights up and down from 2 cm, in line with it and beside
        // it, and the ceiling above it.
        for y in [1.0, 1.3] {
            for z in [0.3, 1.0, 1.5, 1.7, 1.9, 2.1, 2.4, 2.55] {
                pts.add(DVec3::new(s.x, y, z), DVec3::NEG_X);
            }
        }
        for d in [0.02, 0.1, 0.3] {
            pts.add(DVec3::new(s.x - d, 1.0, s.z), DVec3::NEG_Z);
        }
        // The wall y = 4 the in-ground uplight grazes from 10 cm, the ceiling above it and the
        // floor around the light.
        for z in [0.05, 0.3, 1.0, 2.0, 2.5] {
            pts.add(DVec3::new(0.8, s.y, z), DVec3::NEG_Y);
        }
        for y in [3.95, 3.8, 3.5] {
            pts.add(DVec3::new(0.8, y, s.z), DVec3::NEG_Z);
        }
        for (x, y) in [(0.8, 3.97), (0.8, 3.7), (0.6, 3.9), (1.2, 3.9)] {
            pts.add(DVec3::new(x, y, 0.0), DVec3::Z);
        }
        // The floor under the up-down light and the table's top towards it.
        for x in [1.5, 2.0, 2.5] {
            pts.add(DVec3::new(x, 2.0, 0.0), DVec3::Z);
        }
    }
    if name == "closet" {
        // The shelf's top by the back wall and at its front, its underside, the back wall just
        // above and below it, and the side walls in the dark corner above it.
        for y in [0.52, 0.7, 0.88] {
            pts.add(DVec3::new(0.6, y, 1.63), DVec3::Z);
            pts.add(DVec3::new(0.3, y, 1.6), DVec3::NEG_Z);
        }
        for z in [1.4, 1.58, 1.65, 1.8, 2.2, 2.38] {
            pts.add(DVec3::new(0.6, s.y, z), DVec3::NEG_Y);
        }
        for (x, n) in [(0.0, DVec3::X), (s.x, DVec3::NEG_X)] {
            for z in [1.65, 2.0, 2.38] {
                pts.add(DVec3::new(x, 0.7, z), n);
            }
        }
    }
    if name == "desk-lamps" {
        // The desk's top around each puck, the wall above the desk behind them, the
        // bookcase's side facing them, and the wall under the shelf.
        for (x, y) in [
            (1.4, 0.15),
            (1.4, 0.05),
            (1.6, 0.15),
            (2.1, 0.4),
            (2.1, 0.6),
            (2.25, 0.4),
        ] {
            pts.add(DVec3::new(x, y, 0.74), DVec3::Z);
        }
        for x in [1.4, 2.1] {
            for z in [0.76, 0.8, 0.9, 1.1, 1.4, 1.49] {
                pts.add(DVec3::new(x, 0.0, z), DVec3::Y);
            }
        }
        for y in [0.05, 0.2, 0.33] {
            for z in [0.76, 0.85, 1.1, 1.5] {
                pts.add(DVec3::new(2.3, y, z), DVec3::NEG_X);
            }
        }
    }
    if name == "atrium" {
        // Each wall along its grazer's stripe from the floor to the roof, and beside it; the
        // roof above each stripe.
        let stripes = [
            (DVec3::new(0.0, 0.8, 0.0), DVec3::X, DVec3::Y),
            (DVec3::new(s.x, 3.2, 0.0), DVec3::NEG_X, DVec3::Y),
            (DVec3::new(1.5, 0.0, 0.0), DVec3::Y, DVec3::X),
            (DVec3::new(1.5, s.y, 0.0), DVec3::NEG_Y, DVec3::X),
        ];
        for (foot, inward, along) in stripes {
            for z in [0.1, 0.4, 1.0, 2.5, 4.0, 6.0, 7.5, 7.95] {
                pts.add(foot + DVec3::Z * z, inward);
            }
            for z in [1.0, 4.0] {
                pts.add(foot + along * 0.4 + DVec3::Z * z, inward);
            }
            for d in [0.02, 0.1, 0.4] {
                pts.add(foot + inward * d + DVec3::Z * s.z, DVec3::NEG_Z);
            }
        }
    }
    if name == "corners" {
        // The floor's corner the first spot lights and both walls over it.
        for (x, y) in [(0.03, 0.03), (0.1, 0.05), (0.2, 0.2), (0.5, 0.4), (0.8, 0.1)] {
            pts.add(DVec3::new(x, y, 0.0), DVec3::Z);
        }
        for (a, z) in [(0.05, 0.03), (0.2, 0.1), (0.3, 0.4), (0.6, 0.2), (0.1, 0.8)] {
            pts.add(DVec3::new(0.0, a, z), DVec3::X);
            pts.add(DVec3::new(a, 0.0, z), DVec3::Y);
        }
        // The ceiling's corner the up-light lights and the walls under it.
        for (d, e) in [(0.03, 0.03), (0.1, 0.05), (0.2, 0.2), (0.5, 0.3)] {
            pts.add(DVec3::new(s.x - d, e, s.z), DVec3::NEG_Z);
        }
        for (a, h) in [(0.05, 0.03), (0.2, 0.1), (0.3, 0.4)] {
            pts.add(DVec3::new(s.x, a, s.z - h), DVec3::NEG_X);
            pts.add(DVec3::new(s.x - a, 0.0, s.z - h), DVec3::Y);
        }
        // The box in the third corner: its top, its open faces, the walls above it and the floor
        // in front of it.
        for (x, y) in [(4.45, 3.45), (4.7, 3.7), (4.97, 3.97)] {
            pts.add(DVec3::new(x, y, 0.9), DVec3::Z);
        }
        for z in [0.3, 0.85] {
            pts.add(DVec3::new(4.4, 3.7, z), DVec3::NEG_X);
            pts.add(DVec3::new(4.7, 3.4, z), DVec3::NEG_Y);
        }
        for z in [0.92, 1.0, 1.3, 1.8] {
            pts.add(DVec3::new(s.x, 3.7, z), DVec3::NEG_X);
            pts.add(DVec3::new(4.7, s.y, z), DVec3::NEG_Y);
        }
        for (x, y) in [(4.35, 3.7), (4.2, 3.5), (4.7, 3.3)] {
            pts.add(DVec3::new(x, y, 0.0), DVec3::Z);
        }
    }
    if name == "mesh-lamps" {
        // The table top around the puck 1 cm above it, and the floor around the pedestal and
        // past the table's rim.
        for (x, y) in [
            (2.75, 2.0),
            (2.75, 2.05),
            (2.85, 2.0),
            (2.6, 2.0),
            (2.5, 2.3),
            (2.3, 1.8),
        ] {
            pts.add_beside_mesh(DVec3::new(x, y, 0.74), DVec3::Z);
        }
        for x in [2.35, 2.65, 3.15, 3.3] {
            pts.add_beside_mesh(DVec3::new(x, 2.0, 0.0), DVec3::Z);
        }
        // The baffle's underside (its lower face, tilted 30° about x) the up-light lights from
        // 3 cm, and the ceiling above the baffle.
        let (sin, cos) = (0.5_f64, 0.75_f64.sqrt());
        let down = DVec3::new(0.0, sin, -cos);
        for (x, y) in [
            (0.0, 0.0),
            (0.3, 0.0),
            (0.55, 0.0),
            (0.0, 0.2),
            (0.0, -0.25),
            (-0.4, 0.1),
        ] {
            let p = DVec3::new(1.6 + x, 0.9 + y * cos + 0.01 * sin, 2.2 + y * sin - 0.01 * cos);
            pts.add_beside_mesh(p, down);
        }
        for (x, y) in [(1.6, 0.9), (1.6, 1.3), (2.4, 0.9)] {
            pts.add_beside_mesh(DVec3::new(x, y, s.z), DVec3::NEG_Z);
        }
    }
    if name == "obj-on-box" || name == "obj-on-obj" {
        // The sideboard's top (a box, or an OBJ block) in front of, beside and behind the block
        // of books and between it and the vase; the books' faces just above the top; the wall
        // just above the sideboard. Some lie within the bounds of the OBJ file (the books and the
        // vase together), all within the OBJ sideboard's in `obj-on-obj`.
        for (x, y) in [
            (1.5, 0.41),
            (1.5, 0.43),
            (1.5, 0.47),
            (1.29, 0.25),
            (1.27, 0.25),
            (1.2, 0.25),
            (1.75, 0.25),
            (1.9, 0.25),
            (1.5, 0.05),
            (2.4, 0.45),
        ] {
            pts.add_beside_mesh(DVec3::new(x, y, 0.8), DVec3::Z);
        }
        for z in [0.81, 0.85, 1.0] {
            pts.add_beside_mesh(DVec3::new(1.5, 0.4, z), DVec3::Y);
            pts.add_beside_mesh(DVec3::new(1.3, 0.25, z), DVec3::NEG_X);
            pts.add_beside_mesh(DVec3::new(1.5, 0.0, z + 0.04), DVec3::Y);
        }
    }
    if name == "table-things" {
        // The table's top around the box and the turned block and between them, the box's
        // faces just above the top, the top's underside beside a leg and in its middle, a leg's
        // face from the floor up, and the floor under the table and beside it.
        for (x, y) in [
            (1.42, 1.3),
            (1.4, 1.3),
            (1.6, 1.17),
            (1.6, 1.48),
            (1.9, 1.45),
            (2.3, 1.45),
            (1.3, 1.15),
        ] {
            pts.add_beside_mesh(DVec3::new(x, y, 0.76), DVec3::Z);
        }
        for z in [0.77, 0.8] {
            pts.add_beside_mesh(DVec3::new(1.45, 1.3, z), DVec3::NEG_X);
            pts.add_beside_mesh(DVec3::new(1.6, 1.2, z), DVec3::NEG_Y);
        }
        for (x, y) in [(1.35, 1.1), (1.8, 1.4)] {
            pts.add_beside_mesh(DVec3::new(x, y, 0.72), DVec3::NEG_Z);
        }
        for z in [0.02, 0.3, 0.7] {
            pts.add_beside_mesh(DVec3::new(1.3, 1.075, z), DVec3::X);
        }
        for (x, y) in [(1.8, 1.4), (1.35, 1.075), (1.32, 1.2), (2.5, 1.4), (1.1, 1.4)] {
            pts.add_beside_mesh(DVec3::new(x, y, 0.0), DVec3::Z);
        }
    }
    if name == "hovering-models" {
        // The floor under the torus's ring (centre (1.3, 1.4), radii 0.6 ± 0.25 m) and in its
        // hole, its underside 5 cm above the floor (facing down), the floor under the cabinet (2.6–3.6 ×
        // 3.0–3.5 m, 6 cm up) and just outside it, and the cabinet's underside.
        for (dx, dy) in [(-1.0, 0.0), (0.0, 1.0), (0.7, -0.7)] {
            for r in [0.2, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9] {
                pts.add_beside_mesh(DVec3::new(1.3 + r * dx, 1.4 + r * dy, 0.0), DVec3::Z);
            }
        }
        // Under the tube's lowest edge (z = 0.05 at the ring's radius) and 15 cm to each side.
        for (r, z) in [(0.45, 0.055), (0.6, 0.05), (0.75, 0.055)] {
            pts.add_beside_mesh(DVec3::new(1.3 - r, 1.4, z), DVec3::NEG_Z);
        }
        for (x, y) in [
            (2.62, 3.2),
            (2.7, 3.1),
            (3.0, 3.25),
            (3.5, 3.45),
            (3.1, 2.95),
            (3.1, 3.6),
        ] {
            pts.add_beside_mesh(DVec3::new(x, y, 0.0), DVec3::Z);
        }
        for (x, y) in [(2.65, 3.25), (3.1, 3.25), (3.55, 3.05)] {
            pts.add_beside_mesh(DVec3::new(x, y, 0.06), DVec3::NEG_Z);
        }
    }
    if name == "sofa-corner" {
        // The floor in the L's inner corner around the up-light, the sofa's inner faces there,
        // the wall y = 0 above the sofa's back, and the seat under the reading light.
        for (x, y) in [
            (1.45, 0.95),
            (1.5, 1.2),
            (1.7, 1.0),
            (2.0, 1.3),
            (1.45, 1.8),
            (2.6, 0.95),
        ] {
            pts.add_beside_mesh(DVec3::new(x, y, 0.0), DVec3::Z);
        }
        for z in [0.02, 0.2, 0.44] {
            pts.add_beside_mesh(DVec3::new(1.4, 1.3, z), DVec3::X);
            pts.add_beside_mesh(DVec3::new(1.9, 0.9, z), DVec3::Y);
        }
        for x in [1.0, 1.6, 2.2] {
            for z in [0.87, 1.0, 1.5, 2.2] {
                pts.add_beside_mesh(DVec3::new(x, 0.0, z), DVec3::Y);
            }
        }
        for (x, y) in [(1.0, 0.5), (1.0, 0.25), (0.8, 1.2), (2.2, 0.6)] {
            pts.add_beside_mesh(DVec3::new(x, y, 0.45), DVec3::Z);
        }
    }
    if name == "wall-washers" {
        for x in [1.5, 2.25, 3.0] {
            for d in [0.05, 0.15, 0.3, 0.5] {
                pts.add(DVec3::new(x, d, s.z), DVec3::NEG_Z);
            }
        }
        for x in [1.5, 2.25] {
            for z in [2.75, 2.6, 2.4, 2.0, 1.5, 0.8] {
                pts.add(DVec3::new(x, 0.0, z), DVec3::Y);
            }
        }
    }
    if name == "furniture-gaps" {
        // The back wall (y = 4) behind the sideboard standing 5 cm in front of it (x 1.5–3.1, up to
        // 0.8 m): in the slot at its middle and 5 cm inside its end, beside the end, and above.
        for x in [2.3, 1.55, 1.45] {
            for z in [0.05, 0.2, 0.4, 0.6, 0.75, 0.85, 1.0] {
                pts.add(DVec3::new(x, s.y, z), DVec3::NEG_Y);
            }
        }
        // The side wall (x = 5) behind the cupboard standing 10 cm in front of it (y 0.8–1.6, up
        // to 1.8 m), and the floor in that slot.
        for y in [1.2, 0.85, 0.75] {
            for z in [0.05, 0.5, 1.2, 1.7, 1.9, 2.2] {
                pts.add(DVec3::new(s.x, y, z), DVec3::NEG_X);
            }
        }
        for y in [1.2, 0.85] {
            pts.add(DVec3::new(4.95, y, 0.0), DVec3::Z);
        }
        // The cupboard's back face in its slot, and its front.
        for z in [0.3, 1.0, 1.6] {
            pts.add(DVec3::new(4.9, 1.2, z), DVec3::X);
            pts.add(DVec3::new(4.3, 1.2, z), DVec3::NEG_X);
        }
    }
    if name == "cupboards" {
        // The 5 cm slot between the 1.6 m cupboard's face x = 2.4 and the 1.2 m one's face
        // x = 2.45 (overlapping over y 1.5–2.2, z 0–1.2): both faces in its middle and near its
        // ends, from 5 cm up to just under the lower cupboard's top; the floor between them; the
        // taller cupboard's face above the slot.
        for y in [1.85, 1.55, 2.15] {
            for z in [0.05, 0.2, 0.6, 1.0, 1.15] {
                pts.add(DVec3::new(2.4, y, z), DVec3::X);
                pts.add(DVec3::new(2.45, y, z), DVec3::NEG_X);
            }
        }
        for y in [1.85, 1.55] {
            pts.add(DVec3::new(2.425, y, 0.0), DVec3::Z);
        }
        for z in [1.3, 1.5] {
            pts.add(DVec3::new(2.4, 1.85, z), DVec3::X);
        }
    }
    if name == "stacked" {
        // The cabinet's top (z = 0.9) around the box standing on it (x 0.1–0.5, y 1.2–1.8), that
        // box's faces just above the cabinet, and the wall x = 0 above the cabinet beside it.
        for d in [0.01, 0.02, 0.05, 0.1] {
            pts.add(DVec3::new(0.5 + d, 1.5, 0.9), DVec3::Z);
            pts.add(DVec3::new(0.3, 1.2 - d, 0.9), DVec3::Z);
        }
        for h in [0.01, 0.05, 0.2] {
            pts.add(DVec3::new(0.5, 1.5, 0.9 + h), DVec3::X);
            pts.add(DVec3::new(0.3, 1.2, 0.9 + h), DVec3::NEG_Y);
        }
        for z in [0.95, 1.1, 1.4, 2.0] {
            pts.add(DVec3::new(0.0, 1.1, z), DVec3::X);
            pts.add(DVec3::new(0.0, 2.0, z), DVec3::X);
        }
        for y in [0.98, 0.9, 0.8] {
            pts.add(DVec3::new(0.0, y, 0.5), DVec3::X);
        }
    }
    if name == "white-corridor" {
        // The end wall y = 7 washed from 0.25 m, up to just under the ceiling; the ceiling 5–50
        // cm from it; the floor across the corner spot's pool edge and the wall x = 0 beside it.
        for z in [3.15, 3.0, 2.7, 2.2, 1.5, 0.5] {
            pts.add(DVec3::new(1.1, s.y, z), DVec3::NEG_Y);
            pts.add(DVec3::new(0.4, s.y, z), DVec3::NEG_Y);
        }
        for d in [0.05, 0.15, 0.3, 0.5] {
            pts.add(DVec3::new(1.1, s.y - d, s.z), DVec3::NEG_Z);
        }
        for x in [0.05, 0.2, 0.45, 0.6, 0.7, 0.8, 1.0] {
            pts.add(DVec3::new(x, 5.0, 0.0), DVec3::Z);
        }
        for z in [0.05, 0.3, 0.8, 1.5] {
            pts.add(DVec3::new(0.0, 5.0, z), DVec3::X);
        }
    }
    if name == "spot-on-edge" {
        // Across the narrow spot's pool: the desk's top (z = 0.75) from its front edge y = 1.5,
        // its front face, the floor in front of it; the side table's top and the ceiling around
        // the table lamp.
        for y in [1.52, 1.6, 1.7, 1.85, 2.0] {
            pts.add(DVec3::new(2.3, y, 0.75), DVec3::Z);
        }
        for z in [0.05, 0.3, 0.5, 0.65, 0.73] {
            pts.add(DVec3::new(2.3, 1.5, z), DVec3::NEG_Y);
        }
        for y in [1.45, 1.35, 1.2, 1.0, 0.8] {
            pts.add(DVec3::new(2.3, y, 0.0), DVec3::Z);
        }
        for d in [0.02, 0.08, 0.2] {
            pts.add(DVec3::new(3.8 + d, 3.45, 0.55), DVec3::Z);
        }
        for r in [0.0, 0.2, 0.5] {
            pts.add(DVec3::new(4.05 - r, 3.45, s.z), DVec3::NEG_Z);
        }
    }
    if name == "mesh-colour" {
        // The plinth of `mesh-colour-plinth.obj`: a 0.6 m square turned 30° about (1.7, 2.0),
        // 1 m high; its faces' outward normals at 30° + k · 90°. Points on a face are 2 mm in
        // front of it (the millimetre grid would put some inside the plinth).
        let centre = DVec3::new(1.7, 2.0, 0.0);
        for k in 0..4 {
            let angle = (30.0 + 90.0 * k as f64).to_radians();
            let out = DVec3::new(angle.cos(), angle.sin(), 0.0);
            let mid = centre + out * 0.3;
            for d in [0.01, 0.02, 0.05, 0.1, 0.2] {
                pts.add_beside_mesh(mid + out * d, DVec3::Z);
            }
            for h in [0.01, 0.05, 0.2, 0.6] {
                pts.add_beside_mesh(mid + out * 0.002 + DVec3::Z * h, out);
            }
        }
        pts.add_beside_mesh(centre + DVec3::Z, DVec3::Z);
        // The sideboard of `mesh-colour-sideboard.obj`: x 3.0–4.4, y 3.55–4.0 (against the wall
        // y = 4), 0.8 m high.
        let front = DVec3::new(3.7, 3.55, 0.0);
        for d in [0.01, 0.02, 0.05, 0.1, 0.2] {
            pts.add_beside_mesh(front - DVec3::Y * d, DVec3::Z);
        }
        for h in [0.01, 0.05, 0.2, 0.5] {
            pts.add_beside_mesh(front + DVec3::Z * h, DVec3::NEG_Y);
        }
        pts.add_beside_mesh(DVec3::new(3.7, 3.775, 0.8), DVec3::Z);
        for z in [0.81, 0.85, 1.0] {
            pts.add_beside_mesh(DVec3::new(3.7, 4.0, z), DVec3::NEG_Y);
        }
        for d in [0.02, 0.1] {
            pts.add_beside_mesh(DVec3::new(4.4 + d, 3.8, 0.0), DVec3::Z);
            pts.add_beside_mesh(DVec3::new(4.4 + d, 4.0, 0.2), DVec3::NEG_Y);
        }
    }
    pts.out
}

/// A reproducible seed per (room, point, purpose).
fn seed(name: &str, index: usize, purpose: u64) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in name.bytes() {
        h = (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
    }
    h ^ (index as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ purpose.wrapping_mul(0xD1B5_4A32_D192_ED03)
}

/// Estimates a point until its standard error is below [`TARGET_RELATIVE_ERROR`] of its value.
fn converged_estimate(tracer: &Tracer, p: DVec3, n: DVec3, rng: &mut Rng) -> Estimate {
    estimate_to(tracer, (p, n), rng, TARGET_RELATIVE_ERROR, STRATA, MAX_BATCHES)
}

/// Estimates the receiver `(p, n)` in rounds of [`ROUND_BATCHES`] batches of `strata²` paths
/// until its standard error is below `target` of its value or it has `max_batches` batches.
pub fn estimate_to(
    tracer: &Tracer,
    (p, n): (DVec3, DVec3),
    rng: &mut Rng,
    target: f64,
    strata: usize,
    max_batches: usize,
) -> Estimate {
    let direct = tracer.direct_lux(p, n);
    let mut means = Vec::new();
    loop {
        means.extend(tracer.indirect_batches(p, n, strata, ROUND_BATCHES, rng));
        let e = Estimate::from_batches(direct, &means, strata * strata);
        if e.std_error <= target * e.total || means.len() >= max_batches {
            return e;
        }
    }
}

/// Regenerates `<name>.csv`.
fn regenerate(name: &str) {
    let scene = room(name);
    let tracer = Tracer::new(&scene);
    let pts = points(name, &scene);
    let start = std::time::Instant::now();
    let refs: Vec<Reference> = pts
        .par_iter()
        .enumerate()
        .map(|(i, &(p, n))| {
            let mut rng = Rng::new(seed(name, i, 0));
            Reference::traced(p, n, &converged_estimate(&tracer, p, n, &mut rng))
        })
        .collect();
    let worst = refs.iter().map(|r| r.std_error / r.lux).fold(0.0, f64::max);
    eprintln!(
        "{name}: {} points in {:.1} s, worst relative standard error {:.3} %",
        refs.len(),
        start.elapsed().as_secs_f64(),
        100.0 * worst
    );
    write(name, &refs);
}

/// Regenerates the rooms named in [`UPDATE_ENV`] (`1` or `all` for every room) and returns true,
/// or returns false when the variable is unset.
fn regenerate_requested() -> bool {
    let Ok(value) = std::env::var(UPDATE_ENV) else {
        return false;
    };
    let all = value == "1" || value == "all";
    for name in ROOMS {
        if all || value.split(',').any(|v| v.trim() == name) {
            regenerate(name);
        }
    }
    true
}

/// Re-estimates points `0, n/3, 2n/3` of every room with another seed and 24 batches (6 144 paths):
/// each agrees with the committed value within 4.5 joint standard errors; every committed
/// standard error is below 0.3 % of its value; the committed points are the ones [`points`] makes.
#[test]
fn committed_references_agree_with_fresh_estimates() {
    if regenerate_requested() {
        return;
    }
    for name in ROOMS {
        let scene = room(name);
        let refs = read(name);
        let pts = points(name, &scene);
        assert_eq!(refs.len(), pts.len(), "{name}: number of points");
        assert!((140..=280).contains(&refs.len()), "{name}: {} points", refs.len());
        for (r, &(p, n)) in refs.iter().zip(&pts) {
            assert!(r.point == p && r.normal == n, "{name}: point {p} {n} vs {r:?}");
            assert!(r.std_error < 0.003 * r.lux, "{name}: {r:?}");
        }
        let tracer = Tracer::new(&scene);
        let picks = [0, refs.len() / 3, 2 * refs.len() / 3];
        for &i in &picks {
            let r = refs[i];
            let mut rng = Rng::new(seed(name, i, 1));
            let e = tracer.estimate(r.point, r.normal, STRATA, 24, &mut rng);
            assert!(
                (e.direct - r.direct).abs() <= 1e-6 * r.direct.max(1.0),
                "{name} #{i}: direct"
            );
            let sigma = e.std_error.hypot(r.std_error);
            assert!(
                (e.total - r.lux).abs() <= 4.5 * sigma,
                "{name} #{i} at {}: fresh {} ± {} vs committed {} ± {}",
                r.point,
                e.total,
                e.std_error,
                r.lux,
                r.std_error
            );
        }
    }
}

/// Relative errors of Haiko's probe against the references of one room.
#[derive(Debug, Clone)]
pub struct RoomErrors {
    pub name: &'static str,
    pub points: usize,
    pub median: f64,
    pub worst: f64,
    /// The point with the worst error, Haiko's value and the reference.
    pub worst_at: (DVec3, f64, f64),
    /// Signed mean error of the indirect part relative to the reference's indirect part.
    pub indirect_bias: f64,
}

/// Haiko's probe (default bake, hybrid mode, no cache) against the references of `name`.
pub fn errors_against_references(name: &'static str) -> RoomErrors {
    let scene = room(name);
    let refs = read(name);
    let receivers: Vec<Receiver> = refs.iter().map(Reference::receiver).collect();
    let baked = bake(&scene, &BakeOptions::default(), &mut |_| {}).unwrap_or_else(|e| panic!("{name}: {e}"));
    let lux = illuminance_at_receivers(&scene, Some(&baked), DirectMode::Exact, &receivers);
    summarize(name, &refs, &lux)
}

/// The interreflection engine ([`Interreflection`]) with `options` against the references of
/// `name`, as a session gives it ([`engine_lux_at`]).
pub fn engine_errors(name: &'static str, options: &InterreflectionOptions) -> RoomErrors {
    let (refs, lux) = engine_lux(name, options);
    summarize(name, &refs, &lux)
}

/// The references of `name` and the engine's total illuminance (lx) at their points.
fn engine_lux(name: &str, options: &InterreflectionOptions) -> (Vec<Reference>, Vec<f64>) {
    let scene = room(name);
    let refs = read(name);
    let receivers: Vec<Receiver> = refs.iter().map(Reference::receiver).collect();
    let lux = engine_lux_at(&scene, options, &receivers);
    (refs, lux)
}

/// The engine's total illuminance (lx) at `receivers` of `scene` as a session gives it: the
/// plan's channels and visibility, the lights solved to the session's tolerance, exact direct
/// light plus the indirect light gathered from the leaves with the near field resolved.
pub fn engine_lux_at(scene: &Scene, options: &InterreflectionOptions, receivers: &[Receiver]) -> Vec<f64> {
    let p = plan(scene, PlanOptions::default());
    let engine = Interreflection::build(scene, p.channels, p.visibility.on, options).unwrap();
    let leaves = engine
        .scene_leaves(scene, SolveOptions::default().tolerance)
        .unwrap_or_else(|e| panic!("{}: {e}", scene.name));
    let near = engine.near_field(receivers);
    let occluders = Occluders::of_scene(scene);
    let near_direct = lights_direct_rgb_at(scene, occluders.as_ref(), &near.points, Dimmers::AsSet);
    let indirect = engine.gather_near(
        &leaves.radiosity,
        &leaves.indirect,
        receivers,
        &near,
        &near_direct,
    );
    total_lux(&scene_direct_at(scene, receivers), &indirect)
}

/// Total illuminance (lx, photopic): the direct part `direct` (lx) plus the indirect
/// irradiance `indirect` (lx, linear RGB) weighted to luminance.
pub fn total_lux(direct: &[f64], indirect: &[[f64; 3]]) -> Vec<f64> {
    direct
        .iter()
        .zip(indirect)
        .map(|(d, e)| d + luminance_weight(*e))
        .collect()
}

/// What the interreflection engine reaches with the plan's options on each reference room
/// (docs/ACCURACY.md "After"): (room, median bound, worst bound). Every median is within 0.26 %
/// (bound 0.5 %) and every worst within 2.59 % (bounds a little above each room's, all within
/// the 5 % the engine is meant to hold). The
/// furniture-gaps room's deepest slot points were 25 % high before shadow rays were weighted by
/// the kernel and the gather looked again at nodes its first rays found hidden (a ceiling seen
/// through the slot's top), the office's desk faces 1 cm above the floor 3.9 % before partly
/// visible links were refined down to a form factor of 0.0005 (docs/DECISIONS.md "Shadow rays
/// weighted by the kernel"); the two cupboards' slot 300 % high before slots between boxes were
/// graded and then 15 % off where its faces gathered the room's walls through the slot's ends
/// with too few rays, 1.9 % since the gather looks again where its rays may have missed a gap
/// (docs/DECISIONS.md "The gather looks again where its rays may have missed a gap").
/// Points 2–15 cm from the rooms' floor and ceiling edges (sixteenth round) were up to 14.6 %
/// off (spot-on-edge, the floor by a wall beside the spot's pool; 6.6 % stacked, 6.1 % spots)
/// before the pieces of room edges where the direct light bends were graded (docs/DECISIONS.md
/// "Room edges are graded where the direct light bends"); the empty room's ceiling edge, lit
/// only indirectly and left coarse, is the worst left (3.1 %). The `accents` room (seventeenth
/// round: a hard spot's pool on a wall just under the ceiling, a floor pool ending 0.58 m from a
/// wall) was 25 % and 8.5 % off before the pieces were also graded along the edge beside narrow
/// pools and the light sampled two pieces deep. The `niche` room (eighteenth round) and the
/// `partition` room (nineteenth), each added as it came with no option changed for it, are
/// 2.7 % and 2.1 % off at worst. The `sconces` room (nineteenth) was 5.2 % low on the wall
/// under the ceiling between two up-lit pools until cells beside pieces that bend along the
/// edge were split to an eighth of a piece along it (2.1 % since; accents 3.0 → 1.6 %). The
/// `cove` room (nineteenth) was 6.7 % high on the floor beyond the ledge until a cluster that
/// all its rays reached past an occluder was looked at again (2.4 % since). The `pictures`
/// room (twentieth) was 17.6 % low on the wall 3 cm above a picture frame whose top a spot's
/// edge lights only at the front, until strips beside a box contact that a beam's edge crosses
/// were graded along the edge too and sampled finely in their direct light (4.3 % since, the
/// frame's top 2 cm from the wall; docs/DECISIONS.md "Light edges beside contacts"). The
/// `shelves` room (twenty-second round: an open bookshelf whose compartments are slots open only
/// to the room, a shelf light inside one) was added as it came, with no option changed for it:
/// 2.3 % at worst, on a side panel's inner face. The `batwing` room (twenty-second round: two
/// batwings 5 cm under a low ceiling, a column) was 7.1 % high on the ceiling 2 cm from a wall
/// whose top they light in a steep, straight profile, until such a step beside a surface the
/// lights leave dark graded the edge too (1.0 % since; docs/DECISIONS.md "Room edges are graded
/// where the direct light bends"). The `near-surfaces` room (twenty-third round: lamps with no
/// luminous radius 1–2 cm from a ceiling, a wall and the floor, lighting them) was 6.0 % high on
/// the ceiling 2 cm from a wall that the ceiling lamp's reflected spot lights at grazing
/// incidence, until such spots counted in the room-edge rules (1.3 % since). The `closet`
/// (twenty-third round: white, a shelf touching three walls, clothes hanging 8 cm from the back
/// wall) came in at 3.0 % with no change. The `desk-lamps` room (twenty-third round: pucks 1 cm
/// above a desk against a wall) was 3.7 % low on the wall 6 cm above the desk until leaves near
/// a lamp that close went down to its distance (1.7 % since; docs/DECISIONS.md "Patches near a
/// lamp almost touching them"). The `atrium` (3 × 4 × 8 m, in-ground grazers 10 cm from each
/// wall up to the roof) and `corners` (hard spots into a floor corner, a ceiling corner and onto
/// a box in a corner) came in at 2.2 % and 1.4 % with no change. The `mesh-lamps` room
/// (twenty-third round: a puck 1 cm above an OBJ table, an up-light 3 cm under a tilted OBJ
/// baffle) first could not be written — the light under the baffle lay in its bounds, which
/// were refused — and then had the ceiling above the baffle 2 888 % high: shadow rays passed
/// through the baffle along its fine triangles' shared edges (1.6 % since; docs/DECISIONS.md
/// "Shadow rays through a mesh's edges", "A light inside an OBJ"). The `obj-on-obj` room
/// (twenty-fourth round: books and a vase on an OBJ sideboard against a wall) measured 2.98 %
/// until its points on the sideboard's top, the books' faces and the wall behind them were
/// added (they lay within the sideboard's bounds and had been dropped): then it was 23 % high
/// in the slot between the books and the wall. OBJ triangles on OBJ triangles became contacts,
/// shadows along OBJ contacts split strips, and room cells are cut on OBJ contact edges (2.4 %
/// since; docs/DECISIONS.md "OBJ things on OBJ furniture"); that took `obj-on-box` 2.0 → 2.6 %
/// (the same slot; traced again with 6 points it had lost the same way), `sofa-corner` 1.8 →
/// 2.0 %, `mesh-lamps` 1.6 → 1.8 % (both traced again with the 15 and 8 points they had lost).
/// The `table-things` room (twenty-fifth round: a box and a turned block on an OBJ table top on
/// four OBJ legs, a pendant 0.5 m above) came in at 2.0 % with no change, but grades to 15 380
/// leaves (docs/BENCHMARKS.md "A table of OBJ things: what it costs").
///
/// Twenty-sixth round: the table measures what a session gives — the lights solved to the
/// session's tolerance, the near field resolved — where it had measured a solve to 10⁻⁵ and the
/// leaves' gather alone. At the session's 10⁻³ the solve had stopped relative to a lamp's hot
/// spot a centimetre from a ceiling: `haiko probe` was 22 % off at the median in
/// `near-surfaces`, 34 % in `mesh-lamps`, 3.3 % in `desk-lamps` (docs/DECISIONS.md "The solve's
/// scale"). Receivers beside a leaf large for their distance now see it piece by piece
/// (docs/DECISIONS.md "Receivers beside a large leaf"): every room within 2.59 % at worst
/// (`pictures` 4.33 → 1.06 %, `empty` 3.12 → 0.96 %, `lamp-near-box` 2.70 → 1.10 %). OBJ
/// surfaces clustered by plane (twenty-seventh round) took `obj-on-box` from 2.59 to 1.28 %.
/// The `hovering-models` room (twenty-ninth round: a faceted torus 5 cm and an OBJ cabinet 6 cm
/// above the floor) was 46.8 % high on the floor under the torus's ring before OBJ undersides
/// made slots (docs/DECISIONS.md "Slots under OBJ objects"); 2.01 % since. Thirty-second
/// round: a near piece's direct light is the mean over its quarters (docs/DECISIONS.md "Direct
/// light of a near piece"). `closet`'s two faces beside its door, mirror images, read 107.82
/// and 108.70 lx 5 cm up with one point per piece, 108.66 and 108.70 lx since, against traces
/// of 106.65 and 107.11 (the references' own mirror difference, 0.43 %, is their noise): its
/// worst 1.49 → 1.89 %, so its bound is 2.1 %. Thirty-third round: slots up to 0.6 m
/// (docs/DECISIONS.md "Slots up to 0.6 m") took `shelves` 2.25 → 1.40 % and `closet` to 1.64 %;
/// the bounds are left as they were.
const ENGINE_BOUNDS: [(&str, f64, f64); 33] = [
    ("hotspot-box", 0.005, 0.016),
    ("lamp-near-box", 0.005, 0.015),
    ("wall-washers", 0.005, 0.017),
    ("spots", 0.005, 0.015),
    ("white-room", 0.005, 0.01),
    ("empty", 0.005, 0.013),
    ("office", 0.005, 0.019),
    ("hall", 0.005, 0.011),
    ("mesh-colour", 0.005, 0.028),
    ("furniture-gaps", 0.005, 0.027),
    ("cupboards", 0.005, 0.03),
    ("stacked", 0.005, 0.015),
    ("white-corridor", 0.005, 0.014),
    ("spot-on-edge", 0.005, 0.013),
    ("accents", 0.005, 0.019),
    ("niche", 0.005, 0.011),
    ("partition", 0.005, 0.018),
    ("sconces", 0.005, 0.016),
    ("cove", 0.005, 0.025),
    ("pictures", 0.005, 0.014),
    ("shelves", 0.005, 0.026),
    ("batwing", 0.005, 0.014),
    ("near-surfaces", 0.005, 0.013),
    ("closet", 0.005, 0.021),
    ("desk-lamps", 0.005, 0.013),
    ("atrium", 0.005, 0.014),
    ("corners", 0.005, 0.017),
    ("mesh-lamps", 0.005, 0.015),
    ("sofa-corner", 0.005, 0.013),
    ("obj-on-box", 0.005, 0.014),
    ("obj-on-obj", 0.005, 0.024),
    ("table-things", 0.005, 0.011),
    ("hovering-models", 0.005, 0.025),
];

/// The engine's options for reference room `name` as the plan sets them
/// ([`InterreflectionOptions::for_leaves`]).
fn planned_options(name: &str) -> InterreflectionOptions {
    InterreflectionOptions::for_leaves(plan(&room(name), PlanOptions::default()).leaves)
}

/// The engine's total illuminance (exact direct light plus the indirect light gathered from its
/// graded, hierarchical solve) against the Monte-Carlo references of every room: medians and
/// worst errors within the bounds of [`ENGINE_BOUNDS`].
#[test]
fn engine_meets_its_bounds_on_every_reference_room() {
    let mut failures = Vec::new();
    let mut rows = Vec::new();
    for (name, median, worst) in ENGINE_BOUNDS {
        let e = engine_errors(name, &planned_options(name));
        if e.median > median || e.worst > worst {
            failures.push(format!(
                "{name}: median {:.2} % (bound {:.1} %), worst {:.2} % (bound {:.1} %)",
                100.0 * e.median,
                100.0 * median,
                100.0 * e.worst,
                100.0 * worst
            ));
        }
        rows.push(e);
    }
    println!("{}", format_errors(&rows));
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Median and worst relative error of `lux` against `refs`.
pub fn summarize(name: &'static str, refs: &[Reference], lux: &[f64]) -> RoomErrors {
    let mut rel: Vec<(f64, usize)> = refs
        .iter()
        .zip(lux)
        .enumerate()
        .map(|(i, (r, &e))| ((e - r.lux).abs() / r.lux, i))
        .collect();
    rel.sort_by(|a, b| a.0.total_cmp(&b.0));
    let median = rel[rel.len() / 2].0;
    let (worst, wi) = *rel.last().expect("references have points");
    let (num, den) = refs.iter().zip(lux).fold((0.0, 0.0), |(n, d), (r, &e)| {
        (n + (e - r.lux), d + (r.lux - r.direct))
    });
    RoomErrors {
        name,
        points: refs.len(),
        median,
        worst,
        worst_at: (refs[wi].point, lux[wi], refs[wi].lux),
        indirect_bias: num / den,
    }
}

/// A table of [`RoomErrors`].
pub fn format_errors(rows: &[RoomErrors]) -> String {
    let mut s = String::from(
        "room            points  median   worst   indirect bias  worst at (haiko / reference lx)\n",
    );
    for r in rows {
        let (p, got, want) = r.worst_at;
        let _ = writeln!(
            s,
            "{:<15} {:>6} {:>6.2}% {:>6.2}% {:>+13.2}%  ({:.2}, {:.2}, {:.2}) {:.1} / {:.1}",
            r.name,
            r.points,
            100.0 * r.median,
            100.0 * r.worst,
            100.0 * r.indirect_bias,
            p.x,
            p.y,
            p.z,
            got,
            want
        );
    }
    s
}

/// Prints Haiko's errors against every reference room (the accuracy table of docs/ACCURACY.md):
/// `cargo test --release --test all montecarlo::references::print_errors -- --ignored --nocapture`.
#[test]
#[ignore = "a report, not a check: prints the error table of every reference room"]
fn print_errors() {
    let rows: Vec<RoomErrors> = ROOMS
        .iter()
        .map(|&name| errors_against_references(name))
        .collect();
    println!("{}", format_errors(&rows));
}

/// Prints the interreflection engine's errors against every reference room.
#[test]
#[ignore = "a report, not a check: prints the engine's error table of every reference room"]
fn print_engine_errors() {
    let rows: Vec<RoomErrors> = ROOMS
        .iter()
        .map(|&name| engine_errors(name, &planned_options(name)))
        .collect();
    println!("{}", format_errors(&rows));
}

/// Options of the engine from `HAIKO_ENGINE` (comma-separated `knob=value`; knobs: `eta`,
/// `lamp_ratio`, `lamp_min`, `contact_ratio`, `contact_min`, `shadow_min`, `slot_max`, `room_edge_min`, `split`,
/// `gather_eta`, `gather_uniformity`, `linear_gather` (0 or 1), `visibility_refine`, `slot_visibility_refine`), over the defaults.
pub fn engine_options_from_env() -> InterreflectionOptions {
    let mut o = InterreflectionOptions::default();
    for pair in std::env::var("HAIKO_ENGINE").unwrap_or_default().split(',') {
        let Some((k, v)) = pair.split_once('=') else {
            continue;
        };
        let v: f64 = v
            .trim()
            .parse()
            .unwrap_or_else(|_| panic!("HAIKO_ENGINE: {pair}"));
        match k.trim() {
            "eta" => o.links.eta = v,
            "eta_far" => o.links.eta_far = v,
            "near" => o.links.near_m = v,
            "visibility_refine" => o.links.visibility_refine = v,
            "slot_visibility_refine" => o.links.slot_visibility_refine = v,
            "lamp_ratio" => o.refine.lamp_ratio = v,
            "lamp_min" => o.refine.lamp_min_m = v,
            "contact_ratio" => o.refine.contact_ratio = v,
            "contact_min" => o.refine.contact_min_m = v,
            "shadow_min" => o.refine.shadow_min_m = v,
            "slot_max" => o.refine.slot_max_m = v,
            "room_edge_min" => o.refine.room_edge_min_m = v,
            "split" => o.direct_split = v,
            "shadow_splits" => o.shadow_splits = v as u32,
            "gather_eta" => o.gather_eta = v,
            "gather_uniformity" => o.gather_uniformity = v,
            "gather_doubt" => o.gather_doubt = v,
            "linear_gather" => o.linear_gather = v != 0.0,
            other => panic!("HAIKO_ENGINE: unknown knob {other}"),
        }
    }
    o
}

/// The box `HAIKO_POINTS=x0,y0,z0,x1,y1,z1` (m) whose points [`print_engine_variant`] lists one
/// by one.
fn points_window() -> Option<(DVec3, DVec3)> {
    let text = std::env::var("HAIKO_POINTS").ok()?;
    let v: Vec<f64> = text
        .split(',')
        .map(|x| {
            x.trim()
                .parse()
                .unwrap_or_else(|_| panic!("HAIKO_POINTS: {text}"))
        })
        .collect();
    assert_eq!(v.len(), 6, "HAIKO_POINTS: six numbers, x0,y0,z0,x1,y1,z1");
    Some((DVec3::new(v[0], v[1], v[2]), DVec3::new(v[3], v[4], v[5])))
}

/// Prints the engine's errors with the knobs of `HAIKO_ENGINE` on the rooms of `HAIKO_ROOMS`
/// (comma-separated; all by default), with its sizes and build time, and with `HAIKO_POINTS`
/// each point inside that box: a study, not a check.
#[test]
#[ignore = "a study: prints the engine's errors for the knobs in HAIKO_ENGINE"]
fn print_engine_variant() {
    let rooms: Vec<&'static str> = std::env::var("HAIKO_ROOMS")
        .map(|v| {
            v.split(',')
                .filter_map(|n| ROOMS.iter().find(|r| **r == n.trim()).copied())
                .collect()
        })
        .unwrap_or_else(|_| ROOMS.to_vec());
    let options = engine_options_from_env();
    println!("{options:?}");
    let window = points_window();
    let mut rows = Vec::new();
    for &name in &rooms {
        let (refs, lux) = engine_lux(name, &options);
        if let Some((lo, hi)) = window {
            println!("{name}: x y z nx ny nz haiko reference direct error");
            for (r, e) in refs.iter().zip(&lux) {
                if r.point.cmpge(lo).all() && r.point.cmple(hi).all() {
                    let (p, n) = (r.point, r.normal);
                    println!(
                        "{:.3} {:.3} {:.3} {} {} {} {e:.4} {:.4} {:.4} {:+.2}%",
                        p.x,
                        p.y,
                        p.z,
                        n.x,
                        n.y,
                        n.z,
                        r.lux,
                        r.direct,
                        100.0 * (e - r.lux) / r.lux
                    );
                }
            }
        }
        rows.push(summarize(name, &refs, &lux));
    }
    println!("{}", format_errors(&rows));
    for &name in &rooms {
        let scene = room(name);
        let p = plan(&scene, PlanOptions::default());
        let t = std::time::Instant::now();
        let engine = Interreflection::build(&scene, p.channels, p.visibility.on, &options).unwrap();
        println!(
            "{name}: {} coarse → {} leaves, {} links, build {:.2} s",
            engine.stats.coarse_patches,
            engine.stats.leaves,
            engine.stats.links,
            t.elapsed().as_secs_f64()
        );
    }
}

/// Measures the engine on the open-plan floor of `benches/rooms/open-plan.toml` with the knobs of
/// `HAIKO_ENGINE` (over the defaults: `eta_far=0.3,near=0.5` for the plan's relaxed links): build,
/// one light's direct cache, cold and warm solves (a study, not a check).
#[test]
#[ignore = "a study: prints the engine's sizes and times on the open-plan floor"]
fn print_open_plan_costs() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/rooms/open-plan.toml");
    let t = std::time::Instant::now();
    let scene = load(&path).expect("the open-plan room loads");
    println!(
        "load {:.2} s, fine vertices {}, coarse patches {}",
        t.elapsed().as_secs_f64(),
        scene.fine.n_vertices(),
        scene.coarse.patches.len()
    );
    let options = engine_options_from_env();
    let t = std::time::Instant::now();
    let engine = Interreflection::build(&scene, 1, true, &options).unwrap();
    println!("build {:.2} s: {:?}", t.elapsed().as_secs_f64(), engine.stats);
    let t = std::time::Instant::now();
    // One light's cache (all 48 took the resident memory to 11 GB; the session keeps 256 MiB).
    let caches = [engine.direct_cache(&scene.lights[0])];
    println!(
        "direct cache of one light {:.2} s, {} bytes",
        t.elapsed().as_secs_f64(),
        caches[0].bytes()
    );
    let state = haiko::photometry::LightState::from(&scene.lights[0]);
    let t = std::time::Instant::now();
    let sol = engine
        .solve_light(&caches[0], &state, None, 1e-3)
        .expect("solves");
    println!(
        "cold solve of one light {:.3} s, {} iterations",
        t.elapsed().as_secs_f64(),
        sol[0].columns[0].iterations
    );
    let mut edited = state.clone();
    edited.dimmer = 0.8;
    let x0 = vec![sol[0].radiosity.clone()];
    let t = std::time::Instant::now();
    let warm = engine
        .solve_light(&caches[0], &edited, Some(&x0), 1e-3)
        .expect("solves");
    println!(
        "warm solve after a dimmer edit {:.4} s, {} iterations",
        t.elapsed().as_secs_f64(),
        warm[0].columns[0].iterations
    );
    let t = std::time::Instant::now();
    let _ = engine.operator.apply_block(&vec![1.0; engine.n_leaves()], 1);
    println!("one operator application {:.4} s", t.elapsed().as_secs_f64());
    let t = std::time::Instant::now();
    let all = engine.scene_radiosity(&scene, 1e-3).expect("solves");
    println!(
        "all lights solved {:.2} s ({} leaves)",
        t.elapsed().as_secs_f64(),
        all.len()
    );
}

/// Measures the editor's estimates of light 0's 10° re-aim and curve edit on the open-plan
/// floor of `benches/rooms/open-plan.toml` from SH responses of the degrees in
/// `HAIKO_ESTIMATE_ORDERS` (comma-separated; 2,4,6 by default): the response's build, the
/// estimate's time and its error against the edit's solve (a study, not a check; table 8 of
/// `haiko accuracy` on a room that fits the accuracy run).
#[test]
#[ignore = "a study: prints the estimates' costs and errors on the open-plan floor"]
fn print_open_plan_estimates() {
    use haiko::transport::indirect::{HierarchicalIndirect, measured_curve_edit, measured_reaim};
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/rooms/open-plan.toml");
    let scene = load(&path).expect("the open-plan room loads");
    let p = plan(&scene, PlanOptions::default());
    let engine = HierarchicalIndirect::planned(
        &scene,
        &p,
        scene.settings.tolerance,
        &InterreflectionOptions::for_leaves(p.leaves),
    )
    .expect("solves");
    let orders = std::env::var("HAIKO_ESTIMATE_ORDERS").unwrap_or_else(|_| "2,4,6".into());
    let light = &scene.lights[0];
    println!(
        "degree | build s | re-aim: estimate ms, error, without, of total worst/median | curve: estimate ms, error, without, of total worst/median"
    );
    for order in orders
        .split(',')
        .map(|o| o.trim().parse::<usize>().expect("a degree"))
    {
        let aimed = engine
            .measure_estimate(&scene, 0, &measured_reaim(light), order)
            .expect("solves");
        let edited = engine
            .measure_estimate(&scene, 0, &measured_curve_edit(light), order)
            .expect("solves");
        println!(
            "{order} | {:.2} | {:.2} {:.2} % {:.2} % {:.3} % / {:.4} % | {:.2} {:.2} % {:.2} % {:.3} % / {:.4} %",
            aimed.build_s,
            1e3 * aimed.estimate_s,
            100.0 * aimed.error,
            100.0 * aimed.unestimated_error,
            100.0 * aimed.error_of_total,
            100.0 * aimed.median_error_of_total,
            1e3 * edited.estimate_s,
            100.0 * edited.error,
            100.0 * edited.unestimated_error,
            100.0 * edited.error_of_total,
            100.0 * edited.median_error_of_total,
        );
    }
}

/// Measures what an edit costs with the interreflection engine on the rooms named by
/// `HAIKO_COST_ROOMS` (comma-separated paths relative to the crate; `rooms/paper.toml` and
/// `rooms/office.toml` by default): build, leaves, every light's direct cache, cold solves, a
/// curve edit of light 0 (patch direct light, warm-started solve) and the gather to every fine
/// vertex (a study, not a check).
#[test]
#[ignore = "a study: prints the engine's build and per-edit costs on rooms"]
fn print_engine_edit_costs() {
    use haiko::photometry::{Curve, LightState};
    use std::time::Instant;
    let rooms =
        std::env::var("HAIKO_COST_ROOMS").unwrap_or_else(|_| "rooms/paper.toml,rooms/office.toml".into());
    for name in rooms.split(',') {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(name.trim());
        let scene = load(&path).expect("the room loads");
        let p = plan(&scene, PlanOptions::default());
        let tolerance = scene.settings.tolerance;
        let t = Instant::now();
        let engine = Interreflection::build(
            &scene,
            p.channels,
            p.visibility.on,
            &InterreflectionOptions::default(),
        )
        .unwrap();
        let build_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let caches: Vec<_> = scene.lights.iter().map(|l| engine.direct_cache(l)).collect();
        let caches_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let _ = engine.direct_cache(&scene.lights[0]);
        let one_cache_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let mut solutions = Vec::new();
        for (light, cache) in scene.lights.iter().zip(&caches) {
            solutions.push(
                engine
                    .solve_light(cache, &LightState::from(light), None, tolerance)
                    .expect("solves"),
            );
        }
        let cold_s = t.elapsed().as_secs_f64();
        let mut state = LightState::from(&scene.lights[0]);
        let points: Vec<(f64, f64)> = state
            .curve
            .points()
            .map(|(g, i)| (g, if g > 20.0 { 0.7 * i } else { i }))
            .collect();
        state.curve = Curve::new(&points).expect("a curve");
        let mut e = vec![0.0; engine.n_leaves()];
        let t = Instant::now();
        caches[0].irradiance_into(&state.curve, state.aim, state.dimmer, &mut e);
        let patch_direct_s = t.elapsed().as_secs_f64();
        let x0: Vec<_> = solutions[0].iter().map(|s| s.radiosity.clone()).collect();
        let t = Instant::now();
        let warm = engine
            .solve_light(&caches[0], &state, Some(&x0), tolerance)
            .expect("solves");
        let warm_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let _ = engine.operator.apply_block(&e, 1);
        let apply_s = t.elapsed().as_secs_f64();
        let b = engine.scene_radiosity(&scene, tolerance).expect("solves");
        let receivers = haiko::transport::direct::fine_receivers(&scene);
        let t = Instant::now();
        let _ = engine.gather(&b, &receivers);
        let gather_s = t.elapsed().as_secs_f64();
        println!(
            "{name}: {} lights, {} coarse → {} leaves, {} links, build {build_s:.3} s \
             (refine {:.3}, links {:.3}, balance {:.3}); direct caches {caches_s:.3} s (one {one_cache_s:.4} s); \
             cold solves {cold_s:.3} s ({} iterations light 0); curve edit: patch direct {patch_direct_s:.5} s, \
             warm solve {warm_s:.4} s ({} iterations), one operator application {apply_s:.5} s; \
             gather to {} fine vertices {gather_s:.3} s",
            scene.lights.len(),
            engine.stats.coarse_patches,
            engine.stats.leaves,
            engine.stats.links,
            engine.stats.refine_s,
            engine.stats.links_s,
            engine.stats.balance_s,
            solutions[0][0].columns[0].iterations,
            warm[0].columns[0].iterations,
            receivers.len(),
        );
    }
}
