//! The independent Monte-Carlo reference ([`tracer`]) checked against closed forms (docs/METHOD.md
//! §8): point sources over a plane, Sumpner's flux balance `Σ A·H = Φ/(1−ρ)` and the mean indirect
//! irradiance `ρΦ/((1−ρ)A)` of a closed furnished room, and the furnace (uniform self-emission `M`
//! gives `H = M/(1−ρ)` everywhere in a closed room, beside boxes and OBJ solids too). The committed
//! references and the comparison of Haiko against them are in [`references`].

pub mod engine;
pub mod random_rooms;
pub mod references;
pub mod session;
pub mod tracer;

use std::path::Path;

use glam::DVec3;
use haiko::scene::{Scene, load};
use tracer::{Rng, Tracer, cosine_direction, lux};

/// Writes a room file (and extra files) into `dir` and loads it.
fn room(dir: &Path, text: &str, extra: &[(&str, &str)]) -> Scene {
    for (name, content) in extra {
        std::fs::write(dir.join(name), content).unwrap();
    }
    let path = dir.join("room.toml");
    std::fs::write(&path, text).unwrap();
    load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// A black 12 × 12 × 4 m room with one light 2 m above the floor centre and `extra` TOML.
fn black_room(dir: &Path, lid: &str, radius: f64, extra: &str) -> Scene {
    room(
        dir,
        &format!(
            r#"version = 1
[room]
size = [12.0, 12.0, 4.0]
[room.reflectance]
floor = 0.0
walls = 0.0
ceiling = 0.0
{extra}
[[light]]
name = "l"
position = [6.0, 6.0, 2.0]
aim_dir = [0.0, 0.0, -1.0]
lid = {lid}
radius = {radius}
[settings]
patch_size = 1.0
solver_patch_size = 2.0
"#
        ),
        &[],
    )
}

fn floor_point(d: f64) -> (DVec3, DVec3) {
    (DVec3::new(6.0 + d, 6.0, 0.0), DVec3::Z)
}

/// The tracer's direct light — its own shadow rays against boxes and its own BVH of the OBJ
/// triangles — equals Haiko's exact direct light at every point of every reference room, to
/// 10⁻⁶: the references' visibility is independent and agrees, behind OBJ faces too (the wall
/// behind the OBJ sideboard of `mesh-colour` is in its shadow). A BVH node holding only an
/// axis-aligned face once let every ray through it: the tracer saw 248 lx behind the sideboard's
/// front face where there is none.
#[test]
fn the_tracers_direct_light_is_haikos_at_every_reference_point() {
    use haiko::transport::direct::{Receiver, scene_direct_at};
    for name in references::ROOMS {
        let scene = references::room(name);
        let tracer = Tracer::new(&scene);
        let points = references::points(name, &scene);
        let receivers: Vec<Receiver> = points
            .iter()
            .map(|&(point, normal)| Receiver { point, normal })
            .collect();
        let haiko = scene_direct_at(&scene, &receivers);
        for (&(p, n), h) in points.iter().zip(&haiko) {
            let traced = tracer.direct_lux(p, n);
            assert!(
                (traced - h).abs() <= 1e-6 * h.max(1.0),
                "{name} at {p} facing {n}: tracer {traced} lx, Haiko {h} lx"
            );
        }
        if name == "mesh-colour" {
            let behind = tracer.direct_lux(DVec3::new(3.7, 4.0, 0.2), DVec3::NEG_Y);
            assert_eq!(behind, 0.0, "the wall behind the sideboard is in its shadow");
        }
    }
}

/// Isotropic `I` at height h, offset d: `E = I h/(h²+d²)^{3/2}` (250 / 178.885438 / 88.388348 /
/// 22.360680 lx for 1000 cd, h = 2 m, d = 0/1/2/4 m); a hard spot of half-angle γc gives the same
/// inside `d < h tan γc` and 0 outside; the luminous radius `a` gives `I/(h² + a²)` on axis; a box
/// between the light and the floor puts the point in shadow. Black walls: no indirect light, so the
/// estimate is exact with zero standard error.
#[test]
fn direct_part_matches_point_source_closed_forms() {
    let dir = tempfile::tempdir().unwrap();
    let iso = black_room(dir.path(), "[[0, 1000], [180, 1000]]", 0.0, "");
    let tracer = Tracer::new(&iso);
    let mut rng = Rng::new(1);
    for (d, want) in [
        (0.0, 250.0),
        (1.0, 178.885438),
        (2.0, 88.388348),
        (4.0, 22.360680),
    ] {
        let (p, n) = floor_point(d);
        let e = tracer.estimate(p, n, 2, 4, &mut rng);
        assert!((e.total - want).abs() < 1e-6, "d = {d}: {} vs {want}", e.total);
        assert_eq!(e.std_error, 0.0);
        assert_eq!(e.total, e.direct);
    }
    // A hard 30° spot: tan 30° · 2 m = 1.1547 m.
    let spot = black_room(dir.path(), "[[0, 1000], [30, 1000], [30, 0], [180, 0]]", 0.0, "");
    let tracer = Tracer::new(&spot);
    for (d, want) in [(0.0, 250.0), (1.0, 178.885438), (2.0, 0.0), (4.0, 0.0)] {
        let (p, n) = floor_point(d);
        assert!(
            (tracer.estimate(p, n, 1, 2, &mut rng).total - want).abs() < 1e-6,
            "spot d = {d}"
        );
    }
    // Luminous radius 0.5 m: on axis 1000 / (4 + 0.25).
    let soft = black_room(dir.path(), "[[0, 1000], [180, 1000]]", 0.5, "");
    let (p, n) = floor_point(0.0);
    let e = Tracer::new(&soft).estimate(p, n, 1, 2, &mut rng).total;
    assert!((e - 1000.0 / 4.25).abs() < 1e-9, "{e}");
    // A box over the point at d = 1 (but not the one at d = 2) casts a shadow.
    let boxed = black_room(
        dir.path(),
        "[[0, 1000], [180, 1000]]",
        0.0,
        "[[box]]\nmin = [6.8, 5.8, 0.0]\nmax = [7.2, 6.2, 0.5]\nreflectance = 0.0\n",
    );
    let tracer = Tracer::new(&boxed);
    let (p1, n1) = floor_point(1.0);
    let (p2, n2) = floor_point(2.0);
    assert_eq!(tracer.estimate(p1, n1, 1, 2, &mut rng).total, 0.0);
    assert!((tracer.estimate(p2, n2, 1, 2, &mut rng).total - 88.388348).abs() < 1e-6);
}

/// Cosine-weighted directions: `E[cos θ] = 2/3` and `E[cos² θ] = 1/2` (to 4 standard errors),
/// all in the hemisphere of the normal.
#[test]
fn hemisphere_samples_are_cosine_distributed() {
    let n = DVec3::new(0.3, -0.5, 0.8).normalize();
    let mut rng = Rng::new(7);
    let count = 200_000;
    let (mut s1, mut s2, mut s4) = (0.0, 0.0, 0.0);
    for _ in 0..count {
        let d = cosine_direction(n, rng.uniform(), rng.uniform());
        let c = d.dot(n);
        assert!(c >= 0.0 && (d.length() - 1.0).abs() < 1e-12);
        s1 += c;
        s2 += c * c;
        s4 += c.powi(4);
    }
    let k = count as f64;
    let (m1, m2, m4) = (s1 / k, s2 / k, s4 / k);
    // Var[cos] = 1/2 − 4/9, Var[cos²] = E[cos⁴] − 1/4 = 1/3 − 1/4.
    assert!((m1 - 2.0 / 3.0).abs() < 4.0 * (1.0 / 18.0 / k).sqrt(), "{m1}");
    assert!((m2 - 0.5).abs() < 4.0 * (1.0 / 12.0 / k).sqrt(), "{m2}");
    assert!((m4 - 1.0 / 3.0).abs() < 0.01, "{m4}");
}

/// A closed 4 × 3 × 2.5 m room with a box (and, when given, an OBJ cube), every surface of grey
/// reflectance `rho`, and one point light (radius 0: the near-field softening would keep a little
/// of the flux of a lamp close to a surface from landing) of the given curve.
fn closed_room(dir: &Path, rho: f64, lid: &str, with_cube: bool) -> Scene {
    closed_room_with_light(dir, rho, lid, with_cube, "[2.2, 1.4, 1.9]")
}

/// [`closed_room`] with the light at `position` (TOML).
fn closed_room_with_light(dir: &Path, rho: f64, lid: &str, with_cube: bool, position: &str) -> Scene {
    let cube = if with_cube {
        "[[mesh]]\nfile = \"cube.obj\"\ntranslate = [3.0, 2.0, 0.0]\nup = \"z\"\n"
    } else {
        ""
    };
    // A 0.6 m cube standing on the floor, outward normals; no mtl: the OBJ is 0.5 grey.
    let obj = "v -0.3 -0.3 0\nv 0.3 -0.3 0\nv 0.3 0.3 0\nv -0.3 0.3 0\nv -0.3 -0.3 0.6\nv 0.3 -0.3 0.6\nv 0.3 0.3 0.6\nv -0.3 0.3 0.6\n\
f 1 4 3\nf 1 3 2\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n";
    room(
        dir,
        &format!(
            r#"version = 1
[room]
size = [4.0, 3.0, 2.5]
[room.reflectance]
floor = {rho}
walls = {rho}
ceiling = {rho}
[[box]]
min = [1.0, 1.0, 0.0]
max = [2.0, 1.8, 0.9]
reflectance = {rho}
{cube}
[[light]]
name = "l"
position = {position}
aim_dir = [0.2, 0.1, -1.0]
lid = {lid}
[settings]
patch_size = 0.5
solver_patch_size = 1.0
"#
        ),
        &[("cube.obj", obj)],
    )
}

/// Maps a unit-square sample to a point on one face and its normal.
type FaceSampler<'a> = dyn Fn(f64, f64) -> (DVec3, DVec3) + 'a;

/// A point drawn uniformly over the surfaces a closed room exposes, with its normal: floor (less
/// the box footprint), ceiling, four walls, and the box's four sides and top.
fn uniform_surface_point(rng: &mut Rng) -> (DVec3, DVec3) {
    let (lo, hi) = (DVec3::new(1.0, 1.0, 0.0), DVec3::new(2.0, 1.8, 0.9));
    let size = DVec3::new(4.0, 3.0, 2.5);
    // (area, sampler) of each face.
    let faces: [(f64, &FaceSampler<'_>); 11] = [
        (12.0, &|u, v| (DVec3::new(4.0 * u, 3.0 * v, 0.0), DVec3::Z)),
        (12.0, &|u, v| (DVec3::new(4.0 * u, 3.0 * v, size.z), DVec3::NEG_Z)),
        (7.5, &|u, v| (DVec3::new(0.0, 3.0 * u, 2.5 * v), DVec3::X)),
        (7.5, &|u, v| (DVec3::new(4.0, 3.0 * u, 2.5 * v), DVec3::NEG_X)),
        (10.0, &|u, v| (DVec3::new(4.0 * u, 0.0, 2.5 * v), DVec3::Y)),
        (10.0, &|u, v| (DVec3::new(4.0 * u, 3.0, 2.5 * v), DVec3::NEG_Y)),
        (0.72, &|u, v| {
            (DVec3::new(lo.x, 1.0 + 0.8 * u, 0.9 * v), DVec3::NEG_X)
        }),
        (0.72, &|u, v| (DVec3::new(hi.x, 1.0 + 0.8 * u, 0.9 * v), DVec3::X)),
        (0.9, &|u, v| (DVec3::new(1.0 + u, lo.y, 0.9 * v), DVec3::NEG_Y)),
        (0.9, &|u, v| (DVec3::new(1.0 + u, hi.y, 0.9 * v), DVec3::Y)),
        (0.8, &|u, v| (DVec3::new(1.0 + u, 1.0 + 0.8 * v, hi.z), DVec3::Z)),
    ];
    let total: f64 = faces.iter().map(|f| f.0).sum();
    loop {
        let mut pick = rng.uniform() * total;
        for (area, sample) in &faces {
            if pick < *area {
                let (p, n) = sample(rng.uniform(), rng.uniform());
                // Floor points under the box are not exposed: draw again.
                let under_box =
                    n == DVec3::Z && p.z == 0.0 && p.x > lo.x && p.x < hi.x && p.y > lo.y && p.y < hi.y;
                if under_box {
                    break;
                }
                return (p, n);
            }
            pick -= area;
        }
    }
}

/// Exposed area of [`closed_room`] without the cube (m²).
const CLOSED_ROOM_AREA: f64 = 12.0 + 12.0 - 0.8 + 7.5 + 7.5 + 10.0 + 10.0 + 0.72 + 0.72 + 0.9 + 0.9 + 0.8;

/// Sumpner: in a closed room of uniform ρ, `Σ A·H = Φ/(1−ρ)`, so the area-mean indirect
/// irradiance is `ρΦ/((1−ρ)A)` and the area integral of the direct part is Φ. Estimated from
/// surface points drawn uniformly by area, each with one path; agreement within 4 standard errors,
/// which are below 1 %. Also with the lamp 5 cm below the ceiling (its hot spot is sampled from
/// the light).
#[test]
fn closed_room_flux_balance_is_sumpner() {
    let dir = tempfile::tempdir().unwrap();
    let lid = "[[0, 900], [30, 800], [60, 500], [90, 200], [120, 100], [180, 50]]";
    let cases = [
        (0.5, "[2.2, 1.4, 1.9]", 60_000),
        (0.8, "[2.2, 1.4, 1.9]", 60_000),
        (0.8, "[2.9, 1.4, 2.45]", 300_000),
    ];
    for (rho, position, samples) in cases {
        let scene = closed_room_with_light(dir.path(), rho, lid, false, position);
        let phi = scene.lights[0].curve.flux_lm();
        let tracer = Tracer::new(&scene);
        let mut rng = Rng::new(42);
        let (mut sd, mut sd2, mut si, mut si2) = (0.0, 0.0, 0.0, 0.0);
        for _ in 0..samples {
            let (p, n) = uniform_surface_point(&mut rng);
            let e = tracer.estimate(p, n, 1, 1, &mut rng);
            let ind = e.total - e.direct;
            sd += e.direct;
            sd2 += e.direct * e.direct;
            si += ind;
            si2 += ind * ind;
        }
        let k = samples as f64;
        let a = CLOSED_ROOM_AREA;
        let (md, mi) = (sd / k, si / k);
        let (ed, ei) = (((sd2 / k - md * md) / k).sqrt(), ((si2 / k - mi * mi) / k).sqrt());
        let direct_flux = md * a;
        let indirect_mean = mi;
        let want_indirect = rho * phi / ((1.0 - rho) * a);
        assert!(
            ed * a < 0.01 * phi && ei < 0.01 * want_indirect,
            "ρ {rho}: errors {ed} {ei}"
        );
        assert!(
            (direct_flux - phi).abs() < 4.0 * ed * a,
            "ρ {rho}: direct flux {direct_flux} vs Φ {phi} (σ {})",
            ed * a
        );
        assert!(
            (indirect_mean - want_indirect).abs() < 4.0 * ei,
            "ρ {rho}: mean indirect {indirect_mean} vs {want_indirect} (σ {ei})"
        );
        let total = (md + mi) * a;
        let want_total = phi / (1.0 - rho);
        assert!(
            (total - want_total).abs() < 4.0 * (ed + ei) * a,
            "ρ {rho}: Σ A·H {total} vs Φ/(1−ρ) {want_total}"
        );
    }
}

/// The furnace: every surface emits `M` and reflects ρ, so `H = M/(1−ρ)` at every point of the
/// closed room — beside the box, in corners, on the box, on an OBJ cube — within 4 standard
/// errors that are below 0.5 %.
#[test]
fn uniform_self_emission_gives_m_over_one_minus_rho_everywhere() {
    let dir = tempfile::tempdir().unwrap();
    let rho = 0.5; // the OBJ cube is 0.5 grey (no material)
    let scene = closed_room(dir.path(), rho, "[[0, 100], [180, 100]]", true);
    let mut tracer = Tracer::new(&scene);
    tracer.emit_uniformly([10.0; 3]);
    let want = 10.0 / (1.0 - rho);
    let points = [
        (DVec3::new(2.01, 1.4, 0.0), DVec3::Z),    // floor 1 cm from the box
        (DVec3::new(0.01, 0.01, 0.0), DVec3::Z),   // floor corner
        (DVec3::new(1.5, 1.4, 0.9), DVec3::Z),     // box top
        (DVec3::new(2.0, 1.4, 0.01), DVec3::X),    // box side at the floor
        (DVec3::new(2.0, 1.5, 2.5), DVec3::NEG_Z), // ceiling
        (DVec3::new(2.69, 2.0, 0.0), DVec3::Z),    // floor 1 cm from the OBJ cube
        (DVec3::new(3.0, 2.0, 0.6), DVec3::Z),     // top of the OBJ cube
        (DVec3::new(3.3, 2.1, 0.3), DVec3::X),     // side of the OBJ cube
    ];
    let mut rng = Rng::new(3);
    for (p, n) in points {
        let e = tracer.estimate(p, n, 12, 300, &mut rng);
        assert!(e.std_error < 0.005 * want, "{p}: σ {}", e.std_error);
        assert!(
            (e.total - want).abs() < 4.0 * e.std_error,
            "{p}: {} vs {want} (σ {})",
            e.total,
            e.std_error
        );
    }
    // And a coloured emission is carried per channel with the photopic weights.
    tracer.emit_uniformly([10.0, 0.0, 0.0]);
    let e = tracer.estimate(points[0].0, points[0].1, 8, 50, &mut rng);
    assert!((e.total - lux([want, 0.0, 0.0])).abs() < 4.0 * e.std_error + 1e-12);
}
