//! Rooms drawn at random — boxes on the floor, against and just off the walls, stacked and hung
//! on walls; lamps of several kinds (downlights, hard and soft spots, pendants, up-lights,
//! batwings, bare lamps) near ceilings, walls and furniture, aimed at random surfaces —
//! traced fresh at points on every kind of surface and beside contacts, and the engine measured
//! against them as a session gives it: a study of rooms nobody wrote a test for
//! (docs/ACCURACY.md "Rooms drawn at random").
//!
//! `HAIKO_RANDOM_ROOMS=0..60 cargo test --release --test all
//! montecarlo::random_rooms::print_random_rooms -- --ignored --nocapture` prints one row per
//! room (median and worst error, where the worst is, every point more than 3 % off) and writes
//! each room to `target/random-rooms/room-<seed>.toml`. `HAIKO_RANDOM_ROOMS` also takes a list
//! of seeds (`2,9,33`); `HAIKO_ENGINE` sets the engine's knobs as for
//! `references::print_engine_variant`; `HAIKO_POINTS_FILE` (lines `x y z nx ny nz`) traces and
//! prints those points instead of the random ones; `HAIKO_ROOM_FILES` (comma-separated paths)
//! measures those rooms instead of random ones.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use glam::DVec3;
use haiko::scene::{Scene, load};
use haiko::transport::direct::Receiver;
use haiko::transport::interreflection::InterreflectionOptions;
use haiko::transport::plan::{PlanOptions, plan};
use rayon::prelude::*;

use super::references::{Reference, estimate_to, summarize};
use super::tracer::{Rng, Tracer};

/// Standard error the traces aim for, relative to the value (studies need less than the 0.3 % of
/// the committed references).
const TARGET_RELATIVE_ERROR: f64 = 0.005;
const STRATA: usize = 32;
const MAX_BATCHES: usize = 2048;

/// An axis-aligned box (m).
#[derive(Clone, Copy)]
struct Block {
    min: DVec3,
    max: DVec3,
}

impl Block {
    fn overlaps(&self, o: &Block) -> bool {
        (self.min.cmplt(o.max) & o.min.cmplt(self.max)).all()
    }
}

fn between(rng: &mut Rng, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.uniform()
}

fn pick<T: Copy>(rng: &mut Rng, items: &[T]) -> T {
    items[((rng.uniform() * items.len() as f64) as usize).min(items.len() - 1)]
}

fn round_mm(x: f64) -> f64 {
    (x * 1000.0).round() / 1000.0
}

fn v3(v: DVec3) -> String {
    format!("[{}, {}, {}]", round_mm(v.x), round_mm(v.y), round_mm(v.z))
}

/// A random room's TOML text and the boxes it holds.
fn random_room(seed: u64) -> (String, Vec<Block>) {
    let mut rng = Rng::new(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0x5EED);
    let size = DVec3::new(
        round_mm(between(&mut rng, 3.0, 9.0)),
        round_mm(between(&mut rng, 3.0, 7.0)),
        round_mm(between(&mut rng, 2.4, 4.0)),
    );
    let white = rng.uniform() < 0.2;
    let (floor, walls, ceiling) = if white {
        (
            between(&mut rng, 0.6, 0.85),
            between(&mut rng, 0.8, 0.9),
            between(&mut rng, 0.8, 0.9),
        )
    } else {
        (
            between(&mut rng, 0.1, 0.5),
            between(&mut rng, 0.3, 0.85),
            between(&mut rng, 0.5, 0.9),
        )
    };
    let mut text = format!(
        "version = 1\nname = \"random {seed}\"\n\n[room]\nsize = {}\n[room.reflectance]\nfloor = {:.2}\nwalls = {:.2}\nceiling = {:.2}\n",
        v3(size),
        floor,
        walls,
        ceiling
    );
    let mut blocks: Vec<Block> = Vec::new();
    let wanted = (rng.uniform() * 6.0) as usize;
    let mut tries = 0;
    while blocks.len() < wanted && tries < 200 {
        tries += 1;
        let kind = rng.uniform();
        let w = between(&mut rng, 0.3, 1.6).min(size.x - 0.2);
        let d = between(&mut rng, 0.3, 1.2).min(size.y - 0.2);
        let h = between(&mut rng, 0.3, 2.0).min(size.z - 0.3);
        let mut min = DVec3::new(
            between(&mut rng, 0.0, size.x - w),
            between(&mut rng, 0.0, size.y - d),
            0.0,
        );
        let mut dims = DVec3::new(w, d, h);
        if kind < 0.3 {
            // Against a wall.
            match (rng.uniform() * 4.0) as usize {
                0 => min.x = 0.0,
                1 => min.x = size.x - w,
                2 => min.y = 0.0,
                _ => min.y = size.y - d,
            }
        } else if kind < 0.45 {
            // Just off a wall.
            let gap = between(&mut rng, 0.02, 0.1);
            if rng.uniform() < 0.5 {
                min.x = gap;
            } else {
                min.y = size.y - d - gap;
            }
        } else if kind < 0.6 && !blocks.is_empty() {
            // Stacked on another box.
            let under = pick(&mut rng, &blocks);
            let top = under.max.z;
            let uw = (under.max.x - under.min.x) * between(&mut rng, 0.3, 0.9);
            let ud = (under.max.y - under.min.y) * between(&mut rng, 0.3, 0.9);
            let uh = between(&mut rng, 0.1, 0.6).min(size.z - top - 0.3);
            if uh < 0.05 {
                continue;
            }
            dims = DVec3::new(uw, ud, uh);
            min = DVec3::new(
                between(&mut rng, under.min.x, under.max.x - uw),
                between(&mut rng, under.min.y, under.max.y - ud),
                top,
            );
        } else if kind < 0.75 {
            // Hung on a wall: a picture or a cabinet.
            let depth: f64 = pick(&mut rng, &[0.03, 0.05, 0.3, 0.4]);
            let z = between(&mut rng, 0.8, (size.z - 0.6).max(0.9));
            let hh = between(&mut rng, 0.3, 0.8).min(size.z - z - 0.05);
            if rng.uniform() < 0.5 {
                dims = DVec3::new(depth, d, hh);
                min = DVec3::new(0.0, min.y, z);
            } else {
                dims = DVec3::new(w, depth, hh);
                min = DVec3::new(min.x, 0.0, z);
            }
        }
        let min = DVec3::new(round_mm(min.x), round_mm(min.y), round_mm(min.z));
        let max = (min + dims).min(size);
        let max = DVec3::new(round_mm(max.x), round_mm(max.y), round_mm(max.z));
        let block = Block { min, max };
        if (max - min).min_element() < 0.02 || blocks.iter().any(|b| b.overlaps(&block)) {
            continue;
        }
        let _ = write!(
            text,
            "\n[[box]]\nmin = {}\nmax = {}\nreflectance = {:.2}\n",
            v3(min),
            v3(max),
            between(&mut rng, 0.1, 0.8)
        );
        blocks.push(block);
    }
    let lights = 1 + (rng.uniform() * 3.5) as usize;
    for i in 0..lights {
        let _ = write!(text, "\n{}", random_light(&mut rng, i, size, &blocks));
    }
    text.push_str("\n[settings]\npatch_size = 0.1\nsolver_patch_size = 0.5\n");
    (text, blocks)
}

/// A point on a random surface of the room (a wall, the floor, a box top) to aim at.
fn random_target(rng: &mut Rng, size: DVec3, blocks: &[Block]) -> DVec3 {
    let r = rng.uniform();
    if r < 0.3 && !blocks.is_empty() {
        let b = pick(rng, blocks);
        return DVec3::new(
            between(rng, b.min.x, b.max.x),
            between(rng, b.min.y, b.max.y),
            b.max.z,
        );
    }
    if r < 0.6 {
        return DVec3::new(between(rng, 0.0, size.x), between(rng, 0.0, size.y), 0.0);
    }
    let z = between(rng, 0.0, size.z);
    match (rng.uniform() * 4.0) as usize {
        0 => DVec3::new(0.0, between(rng, 0.0, size.y), z),
        1 => DVec3::new(size.x, between(rng, 0.0, size.y), z),
        2 => DVec3::new(between(rng, 0.0, size.x), 0.0, z),
        _ => DVec3::new(between(rng, 0.0, size.x), size.y, z),
    }
}

/// One `[[light]]` table: a kind of lamp, where it hangs and where it aims.
fn random_light(rng: &mut Rng, i: usize, size: DVec3, blocks: &[Block]) -> String {
    let k = between(rng, 200.0, 3000.0).round();
    let a = between(rng, 8.0, 40.0).round();
    let (lid, kind) = match (rng.uniform() * 7.0) as usize {
        0 => (
            format!(
                "[[0, {k}], [30, {}], [50, {}], [70, {}], [90, 0], [180, 0]]",
                0.9 * k,
                0.6 * k,
                0.2 * k
            ),
            "downlight",
        ),
        1 => (format!("[[0, {k}], [{a}, {k}], [{a}, 0], [180, 0]]"), "hard spot"),
        2 => (
            format!("[[0, {k}], [{a}, {}], [{}, 0], [180, 0]]", 0.8 * k, a + 10.0),
            "soft spot",
        ),
        3 => (
            format!(
                "[[0, {k}], [45, {}], [90, {}], [135, {}], [180, {}]]",
                0.8 * k,
                0.4 * k,
                0.6 * k,
                0.8 * k
            ),
            "pendant",
        ),
        4 => (
            format!(
                "[[0, {}], [30, {}], [60, {k}], [75, {}], [90, 0], [180, 0]]",
                0.3 * k,
                0.6 * k,
                0.5 * k
            ),
            "batwing",
        ),
        5 => (format!("[[0, {}], [180, {}]]", 0.3 * k, 0.3 * k), "bare lamp"),
        _ => (
            format!(
                "[[0, {k}], [20, {}], [35, {}], [50, 0], [180, 0]]",
                0.9 * k,
                0.3 * k
            ),
            "up-light",
        ),
    };
    let near_wall = |rng: &mut Rng, p: &mut DVec3| {
        let gap: f64 = pick(rng, &[0.05, 0.1, 0.2, 0.4]);
        match (rng.uniform() * 4.0) as usize {
            0 => p.x = gap,
            1 => p.x = size.x - gap,
            2 => p.y = gap,
            _ => p.y = size.y - gap,
        }
    };
    let mut p = DVec3::new(
        between(rng, 0.3, size.x - 0.3),
        between(rng, 0.3, size.y - 0.3),
        0.0,
    );
    let place = rng.uniform();
    if kind == "up-light" {
        if place < 0.5 {
            near_wall(rng, &mut p);
        }
        p.z = pick(rng, &[0.05, 0.3, 1.8]);
    } else if place < 0.15 && !blocks.is_empty() {
        // Just above a box top.
        let b = pick(rng, blocks);
        p = DVec3::new(
            between(rng, b.min.x + 0.05, b.max.x - 0.05),
            between(rng, b.min.y + 0.05, b.max.y - 0.05),
            b.max.z + pick(rng, &[0.02, 0.05, 0.3]),
        );
    } else {
        if place < 0.45 {
            near_wall(rng, &mut p);
        }
        p.z = size.z - pick(rng, &[0.02, 0.05, 0.15, 0.3, 0.6, 1.0]);
    }
    let aim = if kind == "up-light" {
        "aim_dir = [0.0, 0.0, 1.0]".to_string()
    } else if rng.uniform() < 0.5 {
        "aim_dir = [0.0, 0.0, -1.0]".to_string()
    } else {
        let t = random_target(rng, size, blocks);
        if t.distance(p) < 0.2 {
            "aim_dir = [0.0, 0.0, -1.0]".to_string()
        } else {
            format!("aim = {}", v3(t))
        }
    };
    let radius = pick(rng, &[0.0, 0.01, 0.02, 0.05]);
    format!(
        "[[light]]\nname = \"L{i} {kind}\"\nposition = {}\n{aim}\nlid = {lid}\nradius = {radius}\n",
        v3(p)
    )
}

/// Receivers of a random room: random points on the floor, ceiling, walls, box tops and faces;
/// the floor 1–20 cm from box faces and the faces 1–20 cm above their support; the ceiling, walls
/// and floor 2–15 cm from the room's edges; and the surfaces just beside each lamp.
fn random_points(seed: u64, scene: &Scene, blocks: &[Block]) -> Vec<(DVec3, DVec3)> {
    let mut rng = Rng::new(seed ^ 0xA11CE);
    let s = scene.room_size;
    let mut out: Vec<(DVec3, DVec3)> = Vec::new();
    let mut add = |p: DVec3, n: DVec3| {
        let p = DVec3::new(round_mm(p.x), round_mm(p.y), round_mm(p.z));
        let probe = p + n * 5e-3;
        let inside = probe.cmpgt(DVec3::ZERO).all() && probe.cmplt(s).all();
        let in_box = scene
            .boxes
            .iter()
            .any(|b| probe.distance(probe.clamp(b.min, b.max)) < 4e-3);
        if inside && !in_box && !out.contains(&(p, n)) {
            out.push((p, n));
        }
    };
    let wall_point = |rng: &mut Rng, z: f64| match (rng.uniform() * 4.0) as usize {
        0 => (DVec3::new(0.0, between(rng, 0.0, s.y), z), DVec3::X),
        1 => (DVec3::new(s.x, between(rng, 0.0, s.y), z), DVec3::NEG_X),
        2 => (DVec3::new(between(rng, 0.0, s.x), 0.0, z), DVec3::Y),
        _ => (DVec3::new(between(rng, 0.0, s.x), s.y, z), DVec3::NEG_Y),
    };
    for _ in 0..10 {
        add(
            DVec3::new(between(&mut rng, 0.0, s.x), between(&mut rng, 0.0, s.y), 0.0),
            DVec3::Z,
        );
    }
    for _ in 0..6 {
        add(
            DVec3::new(between(&mut rng, 0.0, s.x), between(&mut rng, 0.0, s.y), s.z),
            DVec3::NEG_Z,
        );
    }
    for _ in 0..8 {
        let z = between(&mut rng, 0.0, s.z);
        let (p, n) = wall_point(&mut rng, z);
        add(p, n);
    }
    // Near the room's edges: ceiling and floor 2–15 cm from a wall, the wall 2–15 cm from them.
    for _ in 0..6 {
        let d = between(&mut rng, 0.02, 0.15);
        let top = rng.uniform() < 0.5;
        let (z, nz) = if top { (s.z, DVec3::NEG_Z) } else { (0.0, DVec3::Z) };
        let (wp, wn) = wall_point(&mut rng, if top { s.z - d } else { d });
        add(wp, wn);
        add(DVec3::new(wp.x, wp.y, z) + wn * d, nz);
    }
    for b in blocks {
        let c = DVec3::new(
            between(&mut rng, b.min.x, b.max.x),
            between(&mut rng, b.min.y, b.max.y),
            b.max.z,
        );
        add(c, DVec3::Z);
        for _ in 0..2 {
            let d: f64 = pick(&mut rng, &[0.01, 0.03, 0.08, 0.2]);
            let along = rng.uniform();
            let z = b.min.z + d.min(b.max.z - b.min.z);
            let (face, n) = match (rng.uniform() * 4.0) as usize {
                0 => (
                    DVec3::new(b.min.x, b.min.y + along * (b.max.y - b.min.y), z),
                    DVec3::NEG_X,
                ),
                1 => (
                    DVec3::new(b.max.x, b.min.y + along * (b.max.y - b.min.y), z),
                    DVec3::X,
                ),
                2 => (
                    DVec3::new(b.min.x + along * (b.max.x - b.min.x), b.min.y, z),
                    DVec3::NEG_Y,
                ),
                _ => (
                    DVec3::new(b.min.x + along * (b.max.x - b.min.x), b.max.y, z),
                    DVec3::Y,
                ),
            };
            add(face, n);
            // The support beside that face (the floor, or the top below), `d` out.
            add(DVec3::new(face.x, face.y, b.min.z) + n * d, DVec3::Z);
            // Under a hung box: the wall below it and the box's underside.
            if b.min.z > 0.0 {
                let mid = DVec3::new(
                    between(&mut rng, b.min.x, b.max.x),
                    between(&mut rng, b.min.y, b.max.y),
                    b.min.z,
                );
                add(mid, DVec3::NEG_Z);
            }
        }
    }
    for l in &scene.lights {
        for _ in 0..3 {
            let off = DVec3::new(between(&mut rng, -0.4, 0.4), between(&mut rng, -0.4, 0.4), 0.0);
            add(
                DVec3::new(l.position.x + off.x, l.position.y + off.y, s.z),
                DVec3::NEG_Z,
            );
            add(
                DVec3::new(l.position.x + off.x, l.position.y + off.y, 0.0),
                DVec3::Z,
            );
        }
        // The nearest wall beside the lamp, at its height and 20 cm above and below.
        let p = l.position;
        let cands = [
            (DVec3::new(0.0, p.y, p.z), DVec3::X, p.x),
            (DVec3::new(s.x, p.y, p.z), DVec3::NEG_X, s.x - p.x),
            (DVec3::new(p.x, 0.0, p.z), DVec3::Y, p.y),
            (DVec3::new(p.x, s.y, p.z), DVec3::NEG_Y, s.y - p.y),
        ];
        let (w, n, _) = cands
            .iter()
            .copied()
            .min_by(|a, b| a.2.total_cmp(&b.2))
            .expect("four walls");
        for dz in [-0.2, 0.0, 0.2] {
            add(w + DVec3::Z * dz, n);
        }
    }
    out
}

fn out_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("target/random-rooms")
}

/// Prints the engine's errors (plan options) against fresh traces in the random rooms of
/// `HAIKO_RANDOM_ROOMS` (`first..last`, seeds; `0..20` by default).
#[test]
#[ignore = "a study: traces random rooms and prints the engine's errors in them"]
fn print_random_rooms() {
    let range = std::env::var("HAIKO_RANDOM_ROOMS").unwrap_or_else(|_| "0..20".into());
    let seeds: Vec<u64> = match range.split_once("..") {
        Some((a, b)) => (a.trim().parse().unwrap()..b.trim().parse().unwrap()).collect(),
        None => range.split(',').map(|s| s.trim().parse().unwrap()).collect(),
    };
    std::fs::create_dir_all(out_dir()).unwrap();
    // Room files of one's own (`HAIKO_ROOM_FILES`, comma-separated) instead of random ones.
    let files: Vec<PathBuf> = std::env::var("HAIKO_ROOM_FILES")
        .map(|v| v.split(',').map(|f| PathBuf::from(f.trim())).collect())
        .unwrap_or_default();
    let jobs: Vec<(u64, PathBuf, Vec<Block>)> = if files.is_empty() {
        seeds
            .into_iter()
            .map(|seed| {
                let (text, blocks) = random_room(seed);
                let path = out_dir().join(format!("room-{seed}.toml"));
                std::fs::write(&path, &text).unwrap();
                (seed, path, blocks)
            })
            .collect()
    } else {
        files
            .into_iter()
            .enumerate()
            .map(|(i, f)| (i as u64, f, Vec::new()))
            .collect()
    };
    let mut rows = Vec::new();
    for (seed, path, blocks) in jobs {
        let scene = match load(&path) {
            Ok(s) => s,
            Err(e) => {
                println!("seed {seed}: refused: {e}");
                continue;
            }
        };
        let pts = match std::env::var("HAIKO_POINTS_FILE") {
            Ok(file) => std::fs::read_to_string(file)
                .unwrap()
                .lines()
                .filter(|l| !l.trim().is_empty())
                .map(|l| {
                    let v: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
                    (DVec3::new(v[0], v[1], v[2]), DVec3::new(v[3], v[4], v[5]))
                })
                .collect(),
            Err(_) => random_points(seed, &scene, &blocks),
        };
        let tracer = Tracer::new(&scene);
        let t = std::time::Instant::now();
        let refs: Vec<Reference> = pts
            .par_iter()
            .enumerate()
            .map(|(i, &(p, n))| {
                let mut rng = Rng::new(seed.wrapping_mul(1_000_003) + i as u64);
                let e = estimate_to(
                    &tracer,
                    (p, n),
                    &mut rng,
                    TARGET_RELATIVE_ERROR,
                    STRATA,
                    MAX_BATCHES,
                );
                Reference::traced(p, n, &e)
            })
            .filter(|r| r.lux > 0.0)
            .collect();
        let traced = t.elapsed().as_secs_f64();
        let receivers: Vec<Receiver> = refs.iter().map(Reference::receiver).collect();
        let t = std::time::Instant::now();
        let leaves = plan(&scene, PlanOptions::default()).leaves;
        let options = if std::env::var("HAIKO_ENGINE").is_ok() {
            super::references::engine_options_from_env()
        } else {
            InterreflectionOptions::for_leaves(leaves)
        };
        let lux = super::references::engine_lux_at(&scene, &options, &receivers);
        let built = t.elapsed().as_secs_f64();
        let name = match path.file_stem() {
            Some(stem) if !stem.to_string_lossy().starts_with("room-") => stem.to_string_lossy().into_owned(),
            _ => format!("room-{seed}"),
        };
        let name: &'static str = Box::leak(name.into_boxed_str());
        let e = summarize(name, &refs, &lux);
        let worst_noise = refs.iter().map(|r| r.std_error / r.lux).fold(0.0, f64::max);
        println!(
            "{name}: {} points, median {:.2} %, worst {:.2} % at {} ({:.1} / {:.1} lx), noise ≤ {:.2} %, {leaves} leaves, trace {traced:.0} s, engine {built:.1} s",
            e.points,
            100.0 * e.median,
            100.0 * e.worst,
            e.worst_at.0,
            e.worst_at.1,
            e.worst_at.2,
            100.0 * worst_noise,
        );
        for (r, l) in refs.iter().zip(&lux) {
            let err = (l - r.lux) / r.lux;
            if err.abs() > 0.03 || std::env::var("HAIKO_POINTS_FILE").is_ok() {
                println!(
                    "    {:.3} {:.3} {:.3} n {} {} {}: {l:.2} vs {:.2} ± {:.2} (direct {:.2}) {:+.2} %",
                    r.point.x,
                    r.point.y,
                    r.point.z,
                    r.normal.x,
                    r.normal.y,
                    r.normal.z,
                    r.lux,
                    r.std_error,
                    r.direct,
                    100.0 * err
                );
            }
        }
        rows.push(e);
    }
    println!("{}", super::references::format_errors(&rows));
}
