//! Per-pixel exact direct light (`haiko::render::PixelLighting`) against an exact per-pixel
//! computation written here from the room's numbers alone: the ray from the eye through the
//! pixel centre to the first surface (room box, boxes), then the curve, `cosθ / r²` and
//! visibility past the boxes; on rooms with hard-edged spots and box shadows, before and after
//! curve, aim, dimmer and position edits. Also: a dark room is exactly 0, and a room dimmed to
//! 10 % looks darker at a fixed exposure.

use std::path::Path;

use glam::DVec3;
use haiko::photometry::{Curve, LightState};
use haiko::render::{
    DisplayShader, Exposure, Frame, PixelLight, PixelLighting, PixelSurfaces, View, vertex_attributes,
};
use haiko::scene::{self, Scene};
use haiko::transport::occlusion::Occluders;

// ---------------------------------------------------------------------------------------------
// The oracle: the room's numbers, traced exactly.

/// An axis-aligned box (m).
#[derive(Clone, Copy)]
struct Block {
    min: DVec3,
    max: DVec3,
}

/// A light as the oracle sees it.
#[derive(Clone)]
struct Lamp {
    position: DVec3,
    aim: DVec3,
    curve: Vec<(f64, f64)>,
    dimmer: f64,
}

/// A test room: size, boxes, lights and camera, written as a room file too.
#[derive(Clone)]
struct TestRoom {
    size: DVec3,
    blocks: Vec<Block>,
    lamps: Vec<Lamp>,
    eye: DVec3,
    target: DVec3,
    fov_deg: f64,
}

/// The curve's value at `gamma_deg`: linear between points, 0 outside them.
fn curve_cd(points: &[(f64, f64)], gamma_deg: f64) -> f64 {
    let (first, last) = (points[0].0, points[points.len() - 1].0);
    if gamma_deg < first || gamma_deg > last {
        return 0.0;
    }
    let k = points.iter().position(|p| p.0 >= gamma_deg).unwrap();
    if k == 0 || points[k].0 == gamma_deg {
        return points[k].1;
    }
    let ((g0, i0), (g1, i1)) = (points[k - 1], points[k]);
    i0 + (i1 - i0) * (gamma_deg - g0) / (g1 - g0)
}

/// Entry and exit parameters of the line `o + t d` through the box, if it meets the box.
fn slab(b: &Block, o: DVec3, d: DVec3) -> Option<(f64, f64, usize)> {
    let (mut enter, mut exit, mut axis) = (f64::NEG_INFINITY, f64::INFINITY, 0);
    for a in 0..3 {
        if d[a] == 0.0 {
            if o[a] <= b.min[a] || o[a] >= b.max[a] {
                return None;
            }
            continue;
        }
        let (t0, t1) = ((b.min[a] - o[a]) / d[a], (b.max[a] - o[a]) / d[a]);
        let (near, far) = (t0.min(t1), t0.max(t1));
        if near > enter {
            enter = near;
            axis = a;
        }
        exit = exit.min(far);
    }
    (enter < exit).then_some((enter, exit, axis))
}

impl TestRoom {
    /// The unit ray through the centre of pixel (px, py) of a `w × h` image.
    fn ray(&self, w: u32, h: u32, px: u32, py: u32) -> DVec3 {
        let forward = (self.target - self.eye).normalize();
        let right = forward.cross(DVec3::Z).normalize();
        let up = right.cross(forward);
        let tan_half = (self.fov_deg.to_radians() / 2.0).tan();
        let aspect = f64::from(w) / f64::from(h);
        let sx = (2.0 * (f64::from(px) + 0.5) / f64::from(w) - 1.0) * tan_half * aspect;
        let sy = (1.0 - 2.0 * (f64::from(py) + 0.5) / f64::from(h)) * tan_half;
        (forward + sx * right + sy * up).normalize()
    }

    /// The first surface on the ray from the eye: point and unit normal (towards the eye).
    fn first_hit(&self, d: DVec3) -> (DVec3, DVec3) {
        let o = self.eye;
        let mut best = (f64::INFINITY, DVec3::ZERO);
        for a in 0..3 {
            if d[a] != 0.0 {
                let wall = if d[a] > 0.0 { self.size[a] } else { 0.0 };
                let t = (wall - o[a]) / d[a];
                if t > 0.0 && t < best.0 {
                    let mut n = DVec3::ZERO;
                    n[a] = -d[a].signum();
                    best = (t, n);
                }
            }
        }
        for b in &self.blocks {
            if let Some((enter, _, axis)) = slab(b, o, d)
                && enter > 0.0
                && enter < best.0
            {
                let mut n = DVec3::ZERO;
                n[axis] = -d[axis].signum();
                best = (enter, n);
            }
        }
        (o + best.0 * d, best.1)
    }

    /// True when a box's interior meets the open segment p → q.
    fn blocked(&self, p: DVec3, q: DVec3) -> bool {
        self.blocks
            .iter()
            .any(|b| slab(b, p, q - p).is_some_and(|(enter, exit, _)| enter.max(1e-9) < exit.min(1.0 - 1e-9)))
    }

    /// Exact direct illuminance (lx) at `p` with normal `n`.
    fn direct(&self, p: DVec3, n: DVec3) -> f64 {
        self.lamps
            .iter()
            .map(|l| {
                let to_light = l.position - p;
                let r2 = to_light.length_squared();
                let cos_theta = n.dot(to_light) / r2.sqrt();
                if cos_theta <= 0.0 || self.blocked(p, l.position) {
                    return 0.0;
                }
                let gamma_deg = l
                    .aim
                    .dot(-to_light / r2.sqrt())
                    .clamp(-1.0, 1.0)
                    .acos()
                    .to_degrees();
                l.dimmer * curve_cd(&l.curve, gamma_deg) * cos_theta / r2
            })
            .sum()
    }

    /// Exact direct illuminance at every pixel of a `w × h` image, row-major.
    fn image(&self, w: u32, h: u32) -> Vec<f64> {
        (0..h)
            .flat_map(|py| (0..w).map(move |px| (px, py)))
            .map(|(px, py)| {
                let (p, n) = self.first_hit(self.ray(w, h, px, py));
                self.direct(p, n)
            })
            .collect()
    }

    /// The room file.
    fn toml(&self) -> String {
        let v = |p: DVec3| format!("[{}, {}, {}]", p.x, p.y, p.z);
        let mut text = format!(
            "version = 1\nname = \"pixel test\"\n[room]\nsize = {}\n[room.reflectance]\nfloor = 0.3\nwalls = 0.5\nceiling = 0.7\n",
            v(self.size)
        );
        for b in &self.blocks {
            text += &format!(
                "[[box]]\nmin = {}\nmax = {}\nreflectance = 0.4\n",
                v(b.min),
                v(b.max)
            );
        }
        for (k, l) in self.lamps.iter().enumerate() {
            let lid: Vec<String> = l.curve.iter().map(|(g, i)| format!("[{g}, {i}]")).collect();
            text += &format!(
                "[[light]]\nname = \"l{k}\"\nposition = {}\naim_dir = {}\nlid = [{}]\ndimmer = {}\n",
                v(l.position),
                v(l.aim),
                lid.join(", "),
                l.dimmer
            );
        }
        text += &format!(
            "[settings]\npatch_size = 0.25\nsolver_patch_size = 1.0\n[camera]\neye = {}\ntarget = {}\nfov_deg = {}\n",
            v(self.eye),
            v(self.target),
            self.fov_deg
        );
        text
    }

    fn load(&self, dir: &Path) -> Scene {
        let path = dir.join("room.toml");
        std::fs::write(&path, self.toml()).unwrap();
        scene::load(&path).unwrap()
    }
}

fn aim_at(from: DVec3, to: DVec3) -> DVec3 {
    (to - from).normalize()
}

/// Hard-edged spots on the floor (partly shadowed by a desk) and on a wall, a two-step spot, a
/// broad downlight throwing the shadows of a desk, a cabinet and a floating shelf.
fn spots_and_boxes() -> TestRoom {
    let spot_floor = DVec3::new(2.0, 1.0, 2.9);
    let spot_wall = DVec3::new(3.0, 3.4, 2.8);
    let two_step = DVec3::new(1.0, 1.2, 2.9);
    TestRoom {
        size: DVec3::new(6.0, 4.0, 3.0),
        blocks: vec![
            Block {
                min: DVec3::new(2.0, 1.2, 0.0),
                max: DVec3::new(3.2, 2.2, 0.8),
            },
            Block {
                min: DVec3::new(4.5, 2.8, 0.0),
                max: DVec3::new(5.0, 3.4, 1.8),
            },
            Block {
                min: DVec3::new(0.8, 2.6, 0.7),
                max: DVec3::new(1.8, 3.6, 0.76),
            },
        ],
        lamps: vec![
            Lamp {
                position: spot_floor,
                aim: aim_at(spot_floor, DVec3::new(2.8, 2.0, 0.0)),
                curve: vec![(0.0, 8000.0), (20.0, 8000.0), (20.0, 0.0), (90.0, 0.0)],
                dimmer: 1.0,
            },
            Lamp {
                position: spot_wall,
                aim: aim_at(spot_wall, DVec3::new(3.0, 4.0, 1.2)),
                curve: vec![(0.0, 5000.0), (12.0, 5000.0), (12.0, 0.0), (90.0, 0.0)],
                dimmer: 1.0,
            },
            Lamp {
                position: two_step,
                aim: aim_at(two_step, DVec3::new(0.0, 1.4, 1.2)),
                curve: vec![
                    (0.0, 4000.0),
                    (8.0, 4000.0),
                    (8.0, 1500.0),
                    (15.0, 1500.0),
                    (15.0, 0.0),
                ],
                dimmer: 1.0,
            },
            Lamp {
                position: DVec3::new(4.0, 2.0, 2.9),
                aim: DVec3::new(0.0, 0.0, -1.0),
                curve: vec![(0.0, 1200.0), (40.0, 1000.0), (70.0, 300.0), (90.0, 0.0)],
                dimmer: 0.8,
            },
        ],
        eye: DVec3::new(5.6, 0.4, 1.7),
        target: DVec3::new(2.0, 2.8, 0.6),
        fov_deg: 75.0,
    }
}

/// A long room seen from one end: spots on both long walls over plinths, one plinth shadowing
/// a spot pool, a light between two tall boxes.
fn gallery() -> TestRoom {
    let lamps = [
        (DVec3::new(2.5, 1.2, 3.3), DVec3::new(2.5, 0.0, 1.6), 12.0),
        (DVec3::new(6.0, 1.2, 3.3), DVec3::new(6.5, 0.0, 1.2), 10.0),
        (DVec3::new(4.0, 3.8, 3.3), DVec3::new(4.2, 5.0, 1.5), 15.0),
        (DVec3::new(8.0, 2.5, 3.3), DVec3::new(8.0, 2.5, 0.0), 30.0),
    ];
    TestRoom {
        size: DVec3::new(10.0, 5.0, 3.5),
        blocks: vec![
            Block {
                min: DVec3::new(2.2, 0.3, 0.0),
                max: DVec3::new(2.8, 0.9, 1.1),
            },
            Block {
                min: DVec3::new(7.0, 1.6, 0.0),
                max: DVec3::new(7.6, 2.2, 2.4),
            },
            Block {
                min: DVec3::new(8.4, 2.8, 0.0),
                max: DVec3::new(9.0, 3.4, 2.4),
            },
        ],
        lamps: lamps
            .iter()
            .map(|&(position, target, edge)| Lamp {
                position,
                aim: aim_at(position, target),
                curve: vec![(0.0, 6000.0), (edge, 6000.0), (edge, 0.0), (90.0, 0.0)],
                dimmer: 1.0,
            })
            .collect(),
        eye: DVec3::new(0.4, 2.5, 1.6),
        target: DVec3::new(6.0, 2.3, 1.2),
        fov_deg: 60.0,
    }
}

// ---------------------------------------------------------------------------------------------
// The library under test.

const SIZE: (u32, u32) = (256, 192);

fn lighting(scene: &Scene) -> (PixelLighting, Frame, Option<Occluders>) {
    let view = View::new(scene.camera, SIZE.0, SIZE.1).unwrap();
    let mut frame = Frame::new(SIZE.0, SIZE.1).unwrap();
    let surfaces = PixelSurfaces::build(&mut frame, &scene.fine, &scene.surfaces, &view).unwrap();
    let occluders = Occluders::of_scene(scene);
    let lights = scene.lights.iter().map(PixelLight::from).collect();
    (
        PixelLighting::new(surfaces, lights, occluders.as_ref()),
        frame,
        occluders,
    )
}

/// Direct illuminance (lx) per pixel from the library (luma of white light = the value).
fn library_image(lighting: &PixelLighting) -> Vec<f64> {
    let mut out = Vec::new();
    lighting.direct_into(&mut out);
    out.iter().map(|e| f64::from(e[1])).collect()
}

/// The agreement the issue asks for, and what we measure.
struct Agreement {
    median_rel: f64,
    off_fraction: f64,
    lit: usize,
}

fn agreement(got: &[f64], exact: &[f64]) -> Agreement {
    let max = exact.iter().fold(0.0f64, |m, &x| m.max(x));
    assert!(max > 0.0, "the test room is lit");
    let mut rel: Vec<f64> = got
        .iter()
        .zip(exact)
        .filter(|&(_, &e)| e > 0.01 * max)
        .map(|(&g, &e)| (g - e).abs() / e)
        .collect();
    rel.sort_by(f64::total_cmp);
    let off = got
        .iter()
        .zip(exact)
        .filter(|&(&g, &e)| (g - e).abs() > 0.05 * max)
        .count();
    Agreement {
        median_rel: rel[rel.len() / 2],
        off_fraction: off as f64 / exact.len() as f64,
        lit: rel.len(),
    }
}

fn assert_agrees(what: &str, lighting: &PixelLighting, room: &TestRoom) {
    assert_agrees_at(what, lighting, room, SIZE);
}

fn assert_agrees_at(what: &str, lighting: &PixelLighting, room: &TestRoom, size: (u32, u32)) {
    let a = agreement(&library_image(lighting), &room.image(size.0, size.1));
    println!(
        "{what}: {} lit pixels, median relative error {:.2e}, {:.3} % of pixels off by > 5 % of the maximum",
        a.lit,
        a.median_rel,
        100.0 * a.off_fraction
    );
    let n = (size.0 * size.1) as usize;
    assert!(a.lit > n / 20, "{what}: only {} pixels are lit", a.lit);
    // The bounds are 0.5 % and 1 %; exact evaluation at the exact point does far better
    // (f32 storage of the point: ~1e-7; the edge pixels are the rasterizer's 1/256-pixel snap).
    assert!(
        a.median_rel <= 1e-5,
        "{what}: median relative error {}",
        a.median_rel
    );
    assert!(
        a.off_fraction <= 0.002,
        "{what}: {} of pixels off",
        a.off_fraction
    );
}

#[test]
fn per_pixel_direct_light_equals_the_exact_trace_on_spots_and_box_shadows() {
    let dir = tempfile::tempdir().unwrap();
    for (name, room) in [("spots and boxes", spots_and_boxes()), ("gallery", gallery())] {
        let scene = room.load(dir.path());
        assert!(!scene.boxes.is_empty());
        let (lighting, _, _) = lighting(&scene);
        assert_agrees(name, &lighting, &room);
    }
}

#[test]
fn edits_keep_the_per_pixel_direct_light_exact() {
    let dir = tempfile::tempdir().unwrap();
    let mut room = spots_and_boxes();
    let scene = room.load(dir.path());
    let (mut lighting, _, occluders) = lighting(&scene);
    let state = |l: &Lamp| LightState {
        curve: Curve::new(&l.curve).unwrap(),
        aim: l.aim,
        dimmer: l.dimmer,
        color: [1.0; 3],
    };

    // A curve edit of the floor spot: its edge moves from 20° to 26°, its peak drops.
    room.lamps[0].curve = vec![(0.0, 6000.0), (26.0, 6000.0), (26.0, 0.0), (90.0, 0.0)];
    lighting.set_state(0, state(&room.lamps[0])).unwrap();
    assert_eq!(lighting.active_light(), Some(0));
    assert_agrees("curve edit", &lighting, &room);

    // The same light re-aimed (γ per pixel again), then another light dimmed (it becomes active).
    room.lamps[0].aim = aim_at(room.lamps[0].position, DVec3::new(3.5, 1.0, 0.0));
    lighting.set_state(0, state(&room.lamps[0])).unwrap();
    assert_agrees("re-aim", &lighting, &room);
    room.lamps[3].dimmer = 0.25;
    lighting.set_state(3, state(&room.lamps[3])).unwrap();
    assert_eq!(lighting.active_light(), Some(3));
    assert_agrees("dimmer of another light", &lighting, &room);

    // Moving a light casts its shadow rays again.
    room.lamps[1].position = DVec3::new(4.8, 1.5, 2.7);
    room.lamps[1].aim = aim_at(room.lamps[1].position, DVec3::new(4.0, 1.0, 0.0));
    lighting
        .set_position(1, room.lamps[1].position, 0.0, occluders.as_ref())
        .unwrap();
    lighting.set_state(1, state(&room.lamps[1])).unwrap();
    assert_agrees("moved light", &lighting, &room);
}

#[test]
fn a_camera_change_keeps_the_per_pixel_direct_light_exact_at_any_image_width() {
    // New views of an image whose pixel count and rows are not whole 64-bit words (the sweep's
    // chunks and visibility words are padded), with a light being edited and after one moved:
    // every light's shadow rays are cast again for the new pixels.
    let dir = tempfile::tempdir().unwrap();
    let mut room = spots_and_boxes();
    let scene = room.load(dir.path());
    let (mut lighting, mut frame, occluders) = lighting(&scene);
    room.lamps[2].dimmer = 0.5;
    let mut state = LightState::from(&scene.lights[2]);
    state.dimmer = 0.5;
    lighting.set_state(2, state).unwrap();
    for (eye, size) in [
        (DVec3::new(5.6, 0.3, 2.2), (251, 187)),
        (DVec3::new(0.4, 0.5, 2.6), (97, 61)),
        (room.eye, SIZE),
    ] {
        room.eye = eye;
        let camera = scene::Camera { eye, ..scene.camera };
        let view = View::new(camera, size.0, size.1).unwrap();
        lighting
            .set_view(
                &mut frame,
                &scene.fine,
                &scene.surfaces,
                &view,
                occluders.as_ref(),
            )
            .unwrap();
        assert_eq!(lighting.active_light(), Some(2));
        assert_agrees_at(&format!("view from {eye} at {size:?}"), &lighting, &room, size);
    }
}

#[test]
fn a_room_with_every_light_off_is_exactly_zero_and_black() {
    let dir = tempfile::tempdir().unwrap();
    let room = spots_and_boxes();
    let scene = room.load(dir.path());
    let (mut lighting, mut frame, _) = lighting(&scene);
    for (i, light) in scene.lights.iter().enumerate() {
        let mut state = LightState::from(light);
        state.dimmer = 0.0;
        lighting.set_state(i, state).unwrap();
    }
    let indirect = vec![[0.0f32; 3]; scene.fine.n_vertices()];
    let mut lux = Vec::new();
    lighting.illuminance_into(&indirect, &mut lux).unwrap();
    assert!(
        lux.iter().flatten().all(|&e| e.to_bits() == 0),
        "every pixel reads +0 lx"
    );
    let attrs = vec![[0.0f32; 3]; scene.fine.n_vertices()];
    for exposure in [Exposure::Auto, Exposure::Fixed { ev100: 4.0 }] {
        let shader = DisplayShader::Photo(exposure.photo(&scene.fine, &attrs));
        lighting
            .render_into(&mut frame, Some(&indirect), &shader, None)
            .unwrap();
        let lit: Vec<(usize, [u8; 3])> = frame
            .pixmap
            .pixels()
            .iter()
            .map(|p| [p.red(), p.green(), p.blue()])
            .enumerate()
            .filter(|(_, p)| *p != [0, 0, 0])
            .collect();
        assert!(
            lit.is_empty(),
            "{exposure:?}: {} pixels not black, e.g. {:?}",
            lit.len(),
            &lit[..lit.len().min(5)]
        );
    }
}

#[test]
fn dimming_every_light_to_ten_percent_darkens_the_photo_at_a_fixed_exposure() {
    let dir = tempfile::tempdir().unwrap();
    let room = spots_and_boxes();
    let scene = room.load(dir.path());
    let (mut lighting, mut frame, _) = lighting(&scene);
    let indirect = vec![[5.0f32; 3]; scene.fine.n_vertices()];
    let mean_value = |lighting: &PixelLighting, frame: &mut Frame, exposure: &Exposure, vertex_lux: f32| {
        let scaled: Vec<[f32; 3]> = indirect.iter().map(|e| e.map(|x| x * vertex_lux)).collect();
        let vertex: Vec<[f64; 3]> = vec![[f64::from(100.0 * vertex_lux); 3]; scene.fine.n_vertices()];
        let attrs = vertex_attributes(
            haiko::render::DisplayMode::Photo,
            &scene.fine,
            &scene.surfaces,
            &vertex,
        )
        .unwrap();
        let shader = DisplayShader::Photo(exposure.photo(&scene.fine, &attrs));
        lighting.render_into(frame, Some(&scaled), &shader, None).unwrap();
        let sum: u64 = frame
            .pixmap
            .pixels()
            .iter()
            .map(|p| u64::from(p.red()) + u64::from(p.green()) + u64::from(p.blue()))
            .sum();
        sum as f64 / (3 * frame.pixmap.pixels().len()) as f64
    };
    let attrs_full = vertex_attributes(
        haiko::render::DisplayMode::Photo,
        &scene.fine,
        &scene.surfaces,
        &vec![[100.0; 3]; scene.fine.n_vertices()],
    )
    .unwrap();
    let fixed = Exposure::fixed_for(&scene.fine, &attrs_full);
    let full_fixed = mean_value(&lighting, &mut frame, &fixed, 1.0);
    let full_auto = mean_value(&lighting, &mut frame, &Exposure::Auto, 1.0);
    for (i, light) in scene.lights.iter().enumerate() {
        let mut state = LightState::from(light);
        state.dimmer *= 0.1;
        lighting.set_state(i, state).unwrap();
    }
    let dim_fixed = mean_value(&lighting, &mut frame, &fixed, 0.1);
    let dim_auto = mean_value(&lighting, &mut frame, &Exposure::Auto, 0.1);
    println!("mean pixel value: fixed {full_fixed:.1} → {dim_fixed:.1}, auto {full_auto:.1} → {dim_auto:.1}");
    assert!(dim_fixed < 0.6 * full_fixed, "fixed: {full_fixed} → {dim_fixed}");
    // Automatic exposure re-exposes: the picture stays (within rounding) the same.
    assert!(
        (dim_auto - full_auto).abs() < 1.0,
        "auto: {full_auto} → {dim_auto}"
    );
}

// ---------------------------------------------------------------------------------------------
// The same through `haiko render` and the session.

/// Runs the built `haiko` with `args` (its bake cache in a temporary folder).
fn haiko(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_haiko"))
        .args(args)
        .env(
            "HAIKO_CACHE_DIR",
            std::env::temp_dir().join("haiko-test-bake-cache"),
        )
        .output()
        .unwrap()
}

/// Reads a one-channel PFM as this test expects it (`Pf`, `W H`, scale −1.0 for little-endian,
/// rows bottom to top) into row-major values from the top-left pixel.
fn read_pfm(path: &Path) -> (u32, u32, Vec<f64>) {
    let bytes = std::fs::read(path).unwrap();
    let mut lines = Vec::new();
    let mut at = 0;
    while lines.len() < 3 {
        let end = at + bytes[at..].iter().position(|&b| b == b'\n').unwrap();
        lines.push(String::from_utf8(bytes[at..end].to_vec()).unwrap());
        at = end + 1;
    }
    assert_eq!(lines[0], "Pf");
    let size: Vec<u32> = lines[1].split_whitespace().map(|s| s.parse().unwrap()).collect();
    assert_eq!(lines[2].parse::<f64>().unwrap(), -1.0, "little-endian scale");
    let (w, h) = (size[0], size[1]);
    let floats: Vec<f64> = bytes[at..]
        .chunks_exact(4)
        .map(|c| f64::from(f32::from_le_bytes([c[0], c[1], c[2], c[3]])))
        .collect();
    assert_eq!(floats.len(), (w * h) as usize);
    let rows: Vec<&[f64]> = floats.chunks_exact(w as usize).rev().collect();
    (w, h, rows.concat())
}

#[test]
fn render_direct_only_lux_pfm_equals_the_exact_trace() {
    let dir = tempfile::tempdir().unwrap();
    for (name, room) in [("spots and boxes", spots_and_boxes()), ("gallery", gallery())] {
        let path = dir.path().join("room.toml");
        std::fs::write(&path, room.toml()).unwrap();
        let (png, pfm) = (dir.path().join("out.png"), dir.path().join("out.pfm"));
        let (w, h) = (SIZE.0.to_string(), SIZE.1.to_string());
        let run = haiko(&[
            "render",
            path.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
            "--width",
            &w,
            "--height",
            &h,
            "--direct-only",
            "--lux",
            pfm.to_str().unwrap(),
        ]);
        assert!(
            run.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&run.stderr)
        );
        let (width, height, got) = read_pfm(&pfm);
        assert_eq!((width, height), SIZE);
        let a = agreement(&got, &room.image(SIZE.0, SIZE.1));
        println!(
            "{name} (haiko render --lux): {} lit pixels, median relative error {:.2e}, {:.3} % off by > 5 % of the maximum",
            a.lit,
            a.median_rel,
            100.0 * a.off_fraction
        );
        // The bounds.
        assert!(a.median_rel <= 0.005, "{name}: median {}", a.median_rel);
        assert!(a.off_fraction <= 0.01, "{name}: {} off", a.off_fraction);
        // What exact evaluation at the exact point gives (see `assert_agrees`).
        assert!(a.median_rel <= 1e-5 && a.off_fraction <= 0.002, "{name}");
    }
}

#[test]
fn render_lux_with_indirect_light_adds_to_the_direct_light_and_sky_pixels_hold_zero() {
    let dir = tempfile::tempdir().unwrap();
    let room = spots_and_boxes();
    let path = dir.path().join("room.toml");
    std::fs::write(&path, room.toml()).unwrap();
    let mut images = Vec::new();
    for direct_only in [true, false] {
        let pfm = dir.path().join(format!("{direct_only}.pfm"));
        let png = dir.path().join("out.png");
        let mut args = vec![
            "render",
            path.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
            "--width",
            "64",
            "--height",
            "48",
            "--view",
            "plan",
            "--lux",
            pfm.to_str().unwrap(),
        ];
        if direct_only {
            args.push("--direct-only");
        }
        let run = haiko(&args);
        assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
        images.push(read_pfm(&pfm).2);
    }
    let (direct, total) = (&images[0], &images[1]);
    // The plan's margin around the footprint sees no surface: exactly 0 in both.
    assert_eq!(direct[0], 0.0);
    assert_eq!(total[0], 0.0);
    // Interreflection only adds light (ρ > 0 everywhere): every floor pixel gains.
    let floor: Vec<usize> = (0..direct.len()).filter(|&i| total[i] > 0.0).collect();
    assert!(floor.len() > direct.len() / 2, "the plan shows the floor");
    assert!(floor.iter().all(|&i| total[i] >= direct[i]));
    let gain: f64 = floor.iter().map(|&i| total[i] - direct[i]).sum::<f64>() / floor.len() as f64;
    assert!(gain > 1.0, "mean indirect gain {gain} lx");
}

/// `haiko render --view work-plane` draws the work plane's plan: the same lux image as the
/// session's work-plane frame (the CLI only parses and prints), the margin 0, most pixels on the
/// plane, and a plane 0.8 m up that is not the floor's image.
#[test]
fn render_view_work_plane_writes_the_work_planes_lux() {
    use haiko::render::DisplayMode;
    use haiko::session::{FrameSpec, Session, SessionOptions, ViewChoice};
    let dir = tempfile::tempdir().unwrap();
    let room = spots_and_boxes();
    let path = dir.path().join("room.toml");
    std::fs::write(&path, room.toml()).unwrap();
    let mut images = Vec::new();
    for view in ["work-plane", "plan"] {
        let (png, pfm) = (
            dir.path().join(format!("{view}.png")),
            dir.path().join(format!("{view}.pfm")),
        );
        let p = |p: &std::path::Path| p.to_str().unwrap().to_string();
        let args = [
            "render",
            &p(&path),
            "-o",
            &p(&png),
            "--width",
            "64",
            "--height",
            "48",
            "--view",
            view,
            "--lux",
            &p(&pfm),
            "--direct-only",
        ];
        let run = haiko(&args);
        assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
        images.push(read_pfm(&pfm).2);
    }
    let (plane, floor) = (&images[0], &images[1]);
    assert_eq!(plane[0], 0.0, "the margin sees nothing");
    assert!(plane.iter().filter(|&&e| e > 0.0).count() > plane.len() / 2);
    assert_ne!(plane, floor);
    let options = SessionOptions {
        indirect: false,
        ..SessionOptions::default()
    };
    let mut session = Session::new(room.load(dir.path()), options, &mut |_| {}).unwrap();
    let spec = FrameSpec {
        view: ViewChoice::WorkPlane,
        ..FrameSpec::new((64, 48), DisplayMode::Photo)
    };
    session.render(&spec).unwrap();
    let want: Vec<f64> = session.lux_image().unwrap().into_iter().map(f64::from).collect();
    assert_eq!(plane, &want);
}

/// Mean sRGB value of a frame's pixels.
fn mean_pixel(pixmap: &tiny_skia::Pixmap) -> f64 {
    let sum: u64 = pixmap
        .pixels()
        .iter()
        .map(|p| u64::from(p.red()) + u64::from(p.green()) + u64::from(p.blue()))
        .sum();
    sum as f64 / (3 * pixmap.pixels().len()) as f64
}

#[test]
fn through_the_session_a_dimmed_room_is_darker_at_the_room_exposure_and_an_unlit_one_black() {
    use haiko::render::DisplayMode;
    use haiko::session::{Command, ExposureChoice, FrameSpec, Session, SessionOptions};
    let dir = tempfile::tempdir().unwrap();
    let room = spots_and_boxes();
    let scene = room.load(dir.path());
    let n = scene.lights.len();
    let mut session = Session::new(scene, SessionOptions::default(), &mut |_| {}).unwrap();
    let fixed = FrameSpec::new(SIZE, DisplayMode::Photo);
    let auto = FrameSpec {
        exposure: ExposureChoice::Auto,
        ..fixed
    };
    let full = mean_pixel(&session.render(&fixed).unwrap().pixmap);
    let full_auto = mean_pixel(&session.render(&auto).unwrap().pixmap);
    let dim_to = |session: &mut Session, factor: f64| {
        for (light, dimmer) in room.lamps.iter().map(|l| l.dimmer * factor).enumerate() {
            session.apply(Command::SetDimmer { light, dimmer }).unwrap();
        }
    };
    dim_to(&mut session, 0.1);
    let dim = mean_pixel(&session.render(&fixed).unwrap().pixmap);
    let dim_auto = mean_pixel(&session.render(&auto).unwrap().pixmap);
    println!(
        "mean pixel value: room exposure {full:.1} → {dim:.1}, automatic {full_auto:.1} → {dim_auto:.1}"
    );
    assert!(dim < 0.6 * full, "room exposure: {full} → {dim}");
    assert!(
        (dim_auto - full_auto).abs() < 2.0,
        "automatic: {full_auto} → {dim_auto}"
    );
    // One stop brighter than the room's exposure is brighter than it.
    let brighter = FrameSpec {
        exposure: ExposureChoice::Room { brighter_ev: 1.0 },
        ..fixed
    };
    assert!(mean_pixel(&session.render(&brighter).unwrap().pixmap) > dim + 1.0);

    // Every light off, indirect light included: every pixel black, every lux 0.
    dim_to(&mut session, 0.0);
    let frame = session.render(&fixed).unwrap();
    let shown: Vec<[u8; 3]> = frame
        .pixmap
        .pixels()
        .iter()
        .map(|p| [p.red(), p.green(), p.blue()])
        .collect();
    // Only the light markers (an overlay) are drawn: every other pixel is black.
    let view = View::new(session.camera(), SIZE.0, SIZE.1).unwrap();
    let markers: Vec<DVec3> = room
        .lamps
        .iter()
        .filter_map(|l| view.project(l.position))
        .collect();
    let reach = f64::from(haiko::render::overlay::LIGHT_RADIUS_PX) + 2.0;
    for (i, &p) in shown.iter().enumerate() {
        let (x, y) = ((i as u32 % SIZE.0) as f64 + 0.5, (i as u32 / SIZE.0) as f64 + 0.5);
        let on_marker = markers.iter().any(|m| (m.x - x).hypot(m.y - y) <= reach);
        assert!(
            on_marker || p == [0, 0, 0],
            "pixel ({x}, {y}) of an unlit room shows {p:?}"
        );
    }
    let lux = session.lux_image().unwrap();
    assert_eq!(lux.len(), (SIZE.0 * SIZE.1) as usize);
    assert!(lux.iter().all(|&e| e.to_bits() == 0), "every pixel reads +0 lx");
    assert_eq!(n, room.lamps.len());
}
