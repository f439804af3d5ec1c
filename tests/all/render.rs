//! The software renderer: coverage rules, depth, perspective-correct interpolation, near-plane
//! clipping, picking, display modes, overlays and goldens — on synthetic meshes built here.

use std::f64::consts::PI;
use std::path::PathBuf;

use glam::DVec3;
use haiko::render::golden::{Golden, Tolerance, count_differing, ids_from_pixmap, ids_to_pixmap};
use haiko::render::shade::{VIRIDIS, srgb_encode};
use haiko::render::{
    BACKGROUND_ID, DisplayMode, DisplayShader, FalseColor, FalseColorTable, LightMarker, LuxScale, Photo,
    ScreenTriangle, ScreenVertex, Shader, View, aim_direction, draw_crosshair, draw_lights, pick, rasterize,
    render, render_attributes, render_into, vertex_attributes,
};
use haiko::scene::model::{Camera, Patch, PatchMesh, Reflectance, Surface, SurfaceKind};
use proptest::prelude::*;

// ---------------------------------------------------------------------------------------------
// Screen-space helpers

/// An orthographic (affine) screen vertex.
fn sv(x: f64, y: f64, depth: f32, attr: f32) -> ScreenVertex {
    ScreenVertex {
        x,
        y,
        depth,
        inv_w: 1.0,
        attr: [attr; 3],
    }
}

fn flat(points: [(f64, f64); 3], id: u32) -> ScreenTriangle {
    ScreenTriangle {
        vertices: points.map(|(x, y)| sv(x, y, 0.5, 0.0)),
        id,
    }
}

/// Covered pixels (x, y) of one triangle, sorted.
fn covered(triangle: ScreenTriangle, w: u32, h: u32) -> Vec<(u32, u32)> {
    let raster = rasterize(&[triangle], w, h, 0u8, |_| 1u8);
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .filter(|&(x, y)| raster.ids[(y * w + x) as usize] != BACKGROUND_ID)
        .collect()
}

/// How many of `triangles` cover each pixel, each rasterized on its own.
fn coverage_counts(triangles: &[ScreenTriangle], w: u32, h: u32) -> Vec<u32> {
    let mut counts = vec![0; (w * h) as usize];
    for &t in triangles {
        for (x, y) in covered(t, w, h) {
            counts[(y * w + x) as usize] += 1;
        }
    }
    counts
}

#[test]
fn triangle_covers_the_hand_counted_pixels() {
    // Legs on the top and left edges through pixel centres (included by the top-left rule),
    // hypotenuse x + y = 9 through centres (a right edge: excluded): x, y ≥ 0, x + y ≤ 7.
    let expected: Vec<(u32, u32)> = (0..12)
        .flat_map(|y| (0..12).map(move |x| (x, y)))
        .filter(|&(x, y)| x + y <= 7)
        .collect();
    assert_eq!(expected.len(), 36);
    for points in [
        [(0.5, 0.5), (8.5, 0.5), (0.5, 8.5)],
        [(0.5, 0.5), (0.5, 8.5), (8.5, 0.5)],
    ] {
        assert_eq!(covered(flat(points, 0), 12, 12), expected, "winding {points:?}");
    }
    // Vertices on pixel corners: no centre on the legs, centres on x + y = 8 excluded.
    let corner = covered(flat([(0.0, 0.0), (8.0, 0.0), (0.0, 8.0)], 0), 12, 12);
    assert_eq!(corner.len(), 28);
    assert!(corner.iter().all(|&(x, y)| x + y <= 6));
}

#[test]
fn two_triangles_sharing_an_edge_cover_each_pixel_once() {
    // A 12 × 12 square from (0.5, 0.5): its diagonal passes through pixel centres; the top and
    // left sides are included, the right and bottom ones excluded: exactly pixels 0..12².
    let (a, b, c, d) = ((0.5, 0.5), (12.5, 0.5), (12.5, 12.5), (0.5, 12.5));
    for (t0, t1) in [([a, b, c], [a, c, d]), ([b, c, d], [b, d, a])] {
        let counts = coverage_counts(&[flat(t0, 0), flat(t1, 1)], 16, 16);
        for y in 0..16 {
            for x in 0..16 {
                let inside = x < 12 && y < 12;
                assert_eq!(
                    counts[(y * 16 + x) as usize],
                    u32::from(inside),
                    "pixel ({x}, {y})"
                );
            }
        }
    }
}

#[test]
fn a_fan_around_a_vertex_covers_each_pixel_once() {
    // Seven triangles around a centre placed on a pixel centre; the outer polygon is convex.
    let centre = (16.5, 16.5);
    let angles = [0.1, 0.9, 1.7, 2.9, 3.6, 4.4, 5.5f64];
    let outer: Vec<(f64, f64)> = angles
        .iter()
        .map(|a| (centre.0 + 12.3 * a.cos(), centre.1 + 12.3 * a.sin()))
        .collect();
    let fan: Vec<ScreenTriangle> = (0..outer.len())
        .map(|k| flat([centre, outer[k], outer[(k + 1) % outer.len()]], k as u32))
        .collect();
    let counts = coverage_counts(&fan, 34, 34);
    let mut inside_count = 0;
    for y in 0..34u32 {
        for x in 0..34u32 {
            let p = (f64::from(x) + 0.5, f64::from(y) + 0.5);
            // Signed distance to each outer edge (y down, counter-clockwise on screen = inside left).
            let distances: Vec<f64> = (0..outer.len())
                .map(|k| {
                    let (a, b) = (outer[k], outer[(k + 1) % outer.len()]);
                    let (ex, ey) = (b.0 - a.0, b.1 - a.1);
                    (ex * (p.1 - a.1) - ey * (p.0 - a.0)) / ex.hypot(ey)
                })
                .collect();
            assert!(
                distances.iter().all(|d| d.abs() > 1e-6),
                "a centre on the outer boundary makes the count ambiguous"
            );
            let inside = distances.iter().all(|&d| d > 0.0);
            inside_count += usize::from(inside);
            assert_eq!(
                counts[(y * 34 + x) as usize],
                u32::from(inside),
                "pixel ({x}, {y})"
            );
        }
    }
    assert!(inside_count > 300);
    assert_eq!(
        counts[16 * 34 + 16],
        1,
        "the shared centre vertex is covered exactly once"
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    /// Two triangles on either side of a random shared edge (quarter-pixel grid, so centres can
    /// lie exactly on edges): no pixel twice, and every centre strictly inside either triangle
    /// or on the open shared edge is covered.
    #[test]
    fn shared_edges_never_crack_or_overlap(
        a in (0i32..96, 0i32..96), b in (0i32..96, 0i32..96), c in (0i32..96, 0i32..96), d in (0i32..96, 0i32..96),
    ) {
        let q = |p: (i32, i32)| (f64::from(p.0) / 4.0, f64::from(p.1) / 4.0);
        let (a, b, c, d) = (q(a), q(b), q(c), q(d));
        let side = |p: (f64, f64)| (b.0 - a.0) * (p.1 - a.1) - (b.1 - a.1) * (p.0 - a.0);
        prop_assume!(side(c) * side(d) < 0.0);
        let counts = coverage_counts(&[flat([a, b, c], 0), flat([b, a, d], 1)], 24, 24);
        prop_assert!(counts.iter().all(|&n| n <= 1));
        let strictly_inside = |t: [(f64, f64); 3], p: (f64, f64)| {
            let e = |u: (f64, f64), v: (f64, f64)| (v.0 - u.0) * (p.1 - u.1) - (v.1 - u.1) * (p.0 - u.0);
            let s = [e(t[0], t[1]), e(t[1], t[2]), e(t[2], t[0])];
            s.iter().all(|&x| x > 0.0) || s.iter().all(|&x| x < 0.0)
        };
        for y in 0..24u32 {
            for x in 0..24u32 {
                let p = (f64::from(x) + 0.5, f64::from(y) + 0.5);
                let t = if (b.0 - a.0).abs() > (b.1 - a.1).abs() { (p.0 - a.0) / (b.0 - a.0) } else { (p.1 - a.1) / (b.1 - a.1) };
                let on_shared_edge = side(p) == 0.0 && t > 0.0 && t < 1.0;
                if strictly_inside([a, b, c], p) || strictly_inside([b, a, d], p) || on_shared_edge {
                    prop_assert_eq!(counts[(y * 24 + x) as usize], 1, "pixel ({}, {})", x, y);
                }
            }
        }
    }
}

#[test]
fn nearest_of_two_interpenetrating_triangles_wins() {
    // Both cover the same right triangle (0, 0), (64, 0), (0, 64). Depth (reversed: larger is
    // nearer) is linear in x: d(x) = left + (right − left)·x/32. Triangle 0 rises from 0.2 and
    // triangle 1 falls from 0.8, so they intersect along x = 16: 1 is nearer left of it.
    let ramp = |left: f32, right: f32, id| ScreenTriangle {
        vertices: [
            sv(0.0, 0.0, left, 0.0),
            sv(64.0, 0.0, left + 2.0 * (right - left), 0.0),
            sv(0.0, 64.0, left, 0.0),
        ],
        id,
    };
    let (rising, falling) = (ramp(0.2, 0.8, 0), ramp(0.8, 0.2, 1));
    for order in [[rising, falling], [falling, rising]] {
        let r = rasterize(&order, 32, 32, 0u8, |_| 0);
        for y in 0..32u32 {
            for x in 0..32u32 {
                let i = (y * 32 + x) as usize;
                let s = (x as f32 + 0.5) / 32.0;
                let nearest = (0.2 + 0.6 * s).max(0.8 - 0.6 * s);
                assert_eq!(r.ids[i], if x < 16 { 1 } else { 0 }, "pixel ({x}, {y})");
                assert!(
                    (r.depth[i] - nearest).abs() < 1e-6,
                    "pixel ({x}, {y}): depth {}",
                    r.depth[i]
                );
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// World-space helpers: a box room built by hand, an independent camera ray

/// Adds an `nu × nv` grid of quads spanning `origin + [0,1]·u + [0,1]·v`, facing `normal`.
fn add_grid(
    mesh: &mut PatchMesh,
    origin: DVec3,
    u: DVec3,
    v: DVec3,
    normal: DVec3,
    surface: u32,
    n: (u32, u32),
) {
    let (u, v, n) = if u.cross(v).dot(normal) > 0.0 {
        (u, v, n)
    } else {
        (v, u, (n.1, n.0))
    };
    let base = mesh.positions.len() as u32;
    for j in 0..=n.1 {
        for i in 0..=n.0 {
            mesh.positions
                .push(origin + u * f64::from(i) / f64::from(n.0) + v * f64::from(j) / f64::from(n.1));
            mesh.normals.push(normal);
            mesh.vertex_surface.push(surface);
        }
    }
    let id = |i: u32, j: u32| base + j * (n.0 + 1) + i;
    for j in 0..n.1 {
        for i in 0..n.0 {
            let vertices = [id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)];
            let centroid = vertices
                .iter()
                .map(|&k| mesh.positions[k as usize])
                .sum::<DVec3>()
                / 4.0;
            let area = (u / f64::from(n.0)).cross(v / f64::from(n.1)).length();
            mesh.patches.push(Patch {
                vertices,
                n_vertices: 4,
                surface,
                normal,
                area,
                centroid,
            });
        }
    }
}

/// An axis-aligned rectangle of the room, for the ray oracle.
#[derive(Clone, Copy)]
struct Face {
    axis: usize,
    value: f64,
    lo: DVec3,
    hi: DVec3,
    surface: u32,
}

struct Room {
    mesh: PatchMesh,
    surfaces: Vec<Surface>,
    faces: Vec<Face>,
}

const ROOM: DVec3 = DVec3::new(6.0, 4.0, 3.0);
const BOX_MIN: DVec3 = DVec3::new(2.5, 1.5, 0.0);
const BOX_MAX: DVec3 = DVec3::new(3.5, 2.5, 0.75);
const PATCH: f64 = 0.5;

/// The 6 × 4 × 3 m room with a 1 × 1 × 0.75 m box on the floor, 0.5 m patches.
fn box_room() -> Room {
    let mut room = Room {
        mesh: PatchMesh::default(),
        surfaces: Vec::new(),
        faces: Vec::new(),
    };
    // (name, kind, reflectance, lo corner, hi corner, axis, normal)
    let mut add =
        |name: &str, kind: SurfaceKind, rho: f64, lo: DVec3, hi: DVec3, axis: usize, normal: DVec3| {
            let surface = room.surfaces.len() as u32;
            room.surfaces.push(Surface {
                name: name.into(),
                kind,
                reflectance: Reflectance::grey(rho),
            });
            let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
            let (mut u, mut v) = (DVec3::ZERO, DVec3::ZERO);
            u[a] = hi[a] - lo[a];
            v[b] = hi[b] - lo[b];
            let n = ((u[a] / PATCH).ceil() as u32, (v[b] / PATCH).ceil() as u32);
            add_grid(&mut room.mesh, lo, u, v, normal, surface, n);
            room.faces.push(Face {
                axis,
                value: lo[axis],
                lo,
                hi,
                surface,
            });
        };
    let s = ROOM;
    add(
        "floor",
        SurfaceKind::Floor,
        0.2,
        DVec3::ZERO,
        DVec3::new(s.x, s.y, 0.0),
        2,
        DVec3::Z,
    );
    add(
        "ceiling",
        SurfaceKind::Ceiling,
        0.7,
        DVec3::new(0.0, 0.0, s.z),
        s,
        2,
        -DVec3::Z,
    );
    add(
        "wall-x0",
        SurfaceKind::Wall,
        0.5,
        DVec3::ZERO,
        DVec3::new(0.0, s.y, s.z),
        0,
        DVec3::X,
    );
    add(
        "wall-x1",
        SurfaceKind::Wall,
        0.5,
        DVec3::new(s.x, 0.0, 0.0),
        s,
        0,
        -DVec3::X,
    );
    add(
        "wall-y0",
        SurfaceKind::Wall,
        0.5,
        DVec3::ZERO,
        DVec3::new(s.x, 0.0, s.z),
        1,
        DVec3::Y,
    );
    add(
        "wall-y1",
        SurfaceKind::Wall,
        0.5,
        DVec3::new(0.0, s.y, 0.0),
        s,
        1,
        -DVec3::Y,
    );
    let (lo, hi) = (BOX_MIN, BOX_MAX);
    let kind = || SurfaceKind::BoxFace { box_index: 0 };
    add(
        "box0-top",
        kind(),
        0.4,
        DVec3::new(lo.x, lo.y, hi.z),
        hi,
        2,
        DVec3::Z,
    );
    add(
        "box0-x0",
        kind(),
        0.4,
        lo,
        DVec3::new(lo.x, hi.y, hi.z),
        0,
        -DVec3::X,
    );
    add(
        "box0-x1",
        kind(),
        0.4,
        DVec3::new(hi.x, lo.y, lo.z),
        hi,
        0,
        DVec3::X,
    );
    add(
        "box0-y0",
        kind(),
        0.4,
        lo,
        DVec3::new(hi.x, lo.y, hi.z),
        1,
        -DVec3::Y,
    );
    add(
        "box0-y1",
        kind(),
        0.4,
        DVec3::new(lo.x, hi.y, lo.z),
        hi,
        1,
        DVec3::Y,
    );
    room
}

/// The unit ray through the centre of pixel (px, py), built from the camera definition alone
/// (vertical fov, z up, y down in the image).
fn camera_ray(camera: &Camera, w: u32, h: u32, px: u32, py: u32) -> DVec3 {
    let f = (camera.target - camera.eye).normalize();
    let r = f.cross(DVec3::Z).normalize();
    let u = r.cross(f);
    let t = (camera.fov_deg.to_radians() / 2.0).tan();
    let sx = (2.0 * (f64::from(px) + 0.5) / f64::from(w) - 1.0) * t * f64::from(w) / f64::from(h);
    let sy = (1.0 - 2.0 * (f64::from(py) + 0.5) / f64::from(h)) * t;
    (f + sx * r + sy * u).normalize()
}

/// The nearest face hit by the ray, the point, and its distance to the face's border (m).
fn ray_hit(faces: &[Face], eye: DVec3, dir: DVec3) -> Option<(Face, DVec3, f64)> {
    let mut best: Option<(f64, Face, DVec3, f64)> = None;
    for &face in faces {
        let t = (face.value - eye[face.axis]) / dir[face.axis];
        if t.is_nan() || t <= 1e-9 {
            continue;
        }
        let p = eye + t * dir;
        let margin = (0..3)
            .filter(|&k| k != face.axis)
            .map(|k| (p[k] - face.lo[k]).min(face.hi[k] - p[k]))
            .fold(f64::INFINITY, f64::min);
        if margin >= -1e-9 && best.is_none_or(|b| t < b.0) {
            best = Some((t, face, p, margin));
        }
    }
    best.map(|(_, f, p, m)| (f, p, m))
}

fn room_camera() -> Camera {
    Camera {
        eye: DVec3::new(0.5, 0.5, 1.6),
        target: DVec3::new(3.0, 2.0, 0.8),
        fov_deg: 75.0,
    }
}

/// Illuminance (lx) of an isotropic 800 cd point at (3, 2, 2.6) plus 40 lx ambient, per vertex.
fn lamp_illuminance(mesh: &PatchMesh, scale: f64) -> Vec<[f64; 3]> {
    let lamp = DVec3::new(3.0, 2.0, 2.6);
    mesh.positions
        .iter()
        .zip(&mesh.normals)
        .map(|(&p, &n)| {
            let d = lamp - p;
            let e = 800.0 * n.dot(d.normalize()).max(0.0) / d.length_squared() + 40.0;
            [scale * e; 3]
        })
        .collect()
}

fn out_dir(sub: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target").join(sub);
    std::fs::create_dir_all(&dir).expect("create output folder");
    dir
}

// ---------------------------------------------------------------------------------------------

#[test]
fn interpolation_is_perspective_correct_on_a_slanted_quad() {
    // A quad in the plane through (0, 2, 0) with normal (0, −1, 1)/√2, seen obliquely; the
    // attribute is the linear function f(p) = 2x − y + 3z + 1 of the world point.
    let f = |p: DVec3| 2.0 * p.x - p.y + 3.0 * p.z + 1.0;
    let corners = [
        DVec3::new(-2.0, 0.5, -1.5),
        DVec3::new(2.0, 0.5, -1.5),
        DVec3::new(2.0, 6.0, 4.0),
        DVec3::new(-2.0, 6.0, 4.0),
    ];
    let normal = DVec3::new(0.0, -1.0, 1.0).normalize();
    let mesh = PatchMesh {
        positions: corners.to_vec(),
        normals: vec![normal; 4],
        vertex_surface: vec![0; 4],
        patches: vec![Patch {
            vertices: [0, 1, 2, 3],
            n_vertices: 4,
            surface: 0,
            normal,
            area: 4.0 * 7.78,
            centroid: corners.iter().sum::<DVec3>() / 4.0,
        }],
    };
    let attrs: Vec<[f32; 3]> = corners.iter().map(|&p| [f(p) as f32; 3]).collect();
    let camera = Camera {
        eye: DVec3::new(0.3, -1.0, 0.8),
        target: DVec3::new(0.0, 3.0, 0.2),
        fov_deg: 60.0,
    };
    let (w, h) = (96, 72);
    let view = View::new(camera, w, h).unwrap();
    let raster = render_attributes(&mesh, &attrs, &view).unwrap();
    let (mut checked, mut worst, mut largest_value) = (0, 0.0f64, 0.0f64);
    for py in 0..h {
        for px in 0..w {
            let i = (py * w + px) as usize;
            if raster.ids[i] == BACKGROUND_ID {
                continue;
            }
            let dir = camera_ray(&camera, w, h, px, py);
            let t = (corners[0] - camera.eye).dot(normal) / dir.dot(normal);
            let expected = f(camera.eye + t * dir);
            worst = worst.max((f64::from(raster.pixels[i][1]) - expected).abs());
            largest_value = largest_value.max(expected.abs());
            checked += 1;
        }
    }
    assert!(checked > (w * h / 2) as usize, "quad covers {checked} pixels");
    assert!(worst < 1e-4 * largest_value.max(1.0), "worst error {worst}");
}

#[test]
fn eye_one_centimetre_from_a_wall_sees_a_closed_room() {
    let room = box_room();
    let attrs: Vec<[f32; 3]> = room
        .mesh
        .positions
        .iter()
        .map(|p| [p.x as f32, p.y as f32, p.z as f32])
        .collect();
    let eye = DVec3::new(0.01, 2.0, 1.5);
    for (target, only_wall_x0) in [
        (DVec3::new(6.0, 2.0, 1.2), false),  // away from the wall
        (DVec3::new(0.01, 4.0, 1.5), false), // along the wall
        (DVec3::new(0.01, 2.0, 3.0), false), // up, along the wall
        (DVec3::new(-1.0, 2.0, 1.5), true),  // into the wall
        (DVec3::new(-1.0, 2.3, 1.3), true),  // into the wall, obliquely
    ] {
        let camera = Camera {
            eye,
            target,
            fov_deg: 60.0,
        };
        let view = View::new(camera, 80, 60).unwrap();
        let raster = render_attributes(&room.mesh, &attrs, &view).unwrap();
        for (i, &id) in raster.ids.iter().enumerate() {
            assert!(
                (id as usize) < room.mesh.patches.len(),
                "target {target}: pixel {i} has id {id}"
            );
            let depth = raster.depth[i];
            assert!(depth > 0.0 && depth <= 1.0, "target {target}: depth {depth}");
            assert!(raster.pixels[i].iter().all(|a| a.is_finite()));
            if only_wall_x0 {
                assert_eq!(
                    room.surfaces[room.mesh.patches[id as usize].surface as usize].name,
                    "wall-x0"
                );
                // On the wall the attribute x is 0 (perspective-correct and unclamped).
                assert!(raster.pixels[i][0].abs() < 1e-4);
            }
        }
    }
}

#[test]
fn picking_recovers_the_analytic_point_patch_and_surface() {
    let room = box_room();
    let camera = room_camera();
    let (w, h) = (160, 120);
    let view = View::new(camera, w, h).unwrap();
    let attrs = vec![[1.0f32; 3]; room.mesh.n_vertices()];
    let frame = render(&room.mesh, &attrs, &view, &Photo::with_exposure(1.0)).unwrap();
    let mut seen = std::collections::BTreeSet::new();
    let mut worst = 0.0f64;
    for py in (0..h).step_by(5) {
        for px in (0..w).step_by(5) {
            let dir = camera_ray(&camera, w, h, px, py);
            let (face, expected, margin) = ray_hit(&room.faces, camera.eye, dir).expect("closed room");
            if margin < 0.02 {
                continue; // too close to an edge of a face to say which face the pixel shows
            }
            let got =
                pick(&frame, &view, &room.mesh, px, py).expect("inside the room every pixel shows a patch");
            assert_eq!(got.surface, face.surface, "pixel ({px}, {py})");
            let patch = &room.mesh.patches[got.patch as usize];
            assert_eq!(patch.surface, face.surface);
            assert_eq!(got.normal, patch.normal);
            let error = got.point.distance(expected);
            worst = worst.max(error);
            assert!(
                error < 0.5 * PATCH,
                "pixel ({px}, {py}): {} vs {expected}",
                got.point
            );
            let corners = patch
                .vertex_ids()
                .iter()
                .map(|&v| room.mesh.positions[v as usize]);
            let (lo, hi) = corners.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(l, hh), p| {
                (l.min(p), hh.max(p))
            });
            assert!(
                expected.cmpge(lo - 1e-3).all() && expected.cmple(hi + 1e-3).all(),
                "pixel ({px}, {py}): wrong patch"
            );
            let light = DVec3::new(3.0, 2.0, 2.6);
            let aim = aim_direction(light, got.point).unwrap();
            assert!((aim - (got.point - light) / (got.point - light).length()).length() < 1e-12);
            assert!((aim.length() - 1.0).abs() < 1e-12);
            seen.insert(
                room.surfaces[face.surface as usize]
                    .name
                    .split('-')
                    .next()
                    .unwrap_or("")
                    .to_owned(),
            );
        }
    }
    for kind in ["floor", "ceiling", "wall", "box0"] {
        assert!(seen.contains(kind), "no {kind} pixel tested; saw {seen:?}");
    }
    assert!(worst < 2e-3, "worst pick error {worst} m");
    assert_eq!(aim_direction(DVec3::ONE, DVec3::ONE), None);
}

#[test]
fn picking_the_background_or_outside_the_image_gives_none() {
    let room = box_room();
    // From outside the room, behind wall y0 (culled: we look in), the corners show nothing.
    let camera = Camera {
        eye: DVec3::new(3.0, -30.0, 1.5),
        target: DVec3::new(3.0, 2.0, 1.5),
        fov_deg: 40.0,
    };
    let view = View::new(camera, 64, 48).unwrap();
    let attrs = vec![[1.0f32; 3]; room.mesh.n_vertices()];
    let frame = render(&room.mesh, &attrs, &view, &Photo::with_exposure(1.0)).unwrap();
    assert_eq!(pick(&frame, &view, &room.mesh, 0, 0), None);
    assert_eq!(pick(&frame, &view, &room.mesh, 64, 10), None);
    let centre = pick(&frame, &view, &room.mesh, 32, 24).expect("the room is in the middle");
    // Wall y0 faces away and is culled: the centre ray meets the far wall y1 at y = 4.
    assert!((centre.point.y - 4.0).abs() < 1e-3, "{}", centre.point);
    assert_eq!(room.surfaces[centre.surface as usize].name, "wall-y1");
}

#[test]
fn parallel_rendering_is_deterministic() {
    let room = box_room();
    let view = View::new(room_camera(), 200, 150).unwrap();
    let attrs = vertex_attributes(
        DisplayMode::Photo,
        &room.mesh,
        &room.surfaces,
        &lamp_illuminance(&room.mesh, 1.0),
    )
    .unwrap();
    let shader = DisplayShader::fit(DisplayMode::Photo, &room.mesh, &attrs);
    let parallel = render(&room.mesh, &attrs, &view, &shader).unwrap();
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let serial = pool.install(|| render(&room.mesh, &attrs, &view, &shader).unwrap());
    assert_eq!(parallel, serial);
}

#[test]
fn rendering_into_a_used_frame_equals_a_fresh_render() {
    let room = box_room();
    let e = lamp_illuminance(&room.mesh, 1.0);
    let attrs = vertex_attributes(DisplayMode::Photo, &room.mesh, &room.surfaces, &e).unwrap();
    let shader = DisplayShader::fit(DisplayMode::Photo, &room.mesh, &attrs);
    let view = View::new(room_camera(), 120, 90).unwrap();
    let fresh = render(&room.mesh, &attrs, &view, &shader).unwrap();
    // A frame of another view and size, with overlays drawn on it: all of it must be replaced.
    let other = View::new(room_camera(), 50, 40).unwrap();
    let mut frame = render(
        &room.mesh,
        &vec![[9.0; 3]; room.mesh.n_vertices()],
        &other,
        &shader,
    )
    .unwrap();
    draw_crosshair(&mut frame.pixmap, 20, 20);
    render_into(&mut frame, &room.mesh, &attrs, &view, &shader).unwrap();
    assert_eq!(frame, fresh);
    // Same size, other content (a different camera and overlays): cleared and redrawn.
    let near_wall = Camera {
        eye: DVec3::new(0.5, 0.5, 1.0),
        ..room_camera()
    };
    render_into(
        &mut frame,
        &room.mesh,
        &attrs,
        &View::new(near_wall, 120, 90).unwrap(),
        &shader,
    )
    .unwrap();
    draw_crosshair(&mut frame.pixmap, 60, 45);
    assert_ne!(frame, fresh);
    render_into(&mut frame, &room.mesh, &attrs, &view, &shader).unwrap();
    assert_eq!(frame, fresh);
}

// ---------------------------------------------------------------------------------------------
// Display modes

#[test]
fn photo_attributes_are_luminance_rho_e_over_pi() {
    let room = box_room();
    let e = lamp_illuminance(&room.mesh, 1.0);
    let photo = vertex_attributes(DisplayMode::Photo, &room.mesh, &room.surfaces, &e).unwrap();
    let false_colour = vertex_attributes(DisplayMode::FalseColor, &room.mesh, &room.surfaces, &e).unwrap();
    for v in 0..room.mesh.n_vertices() {
        let rho = room.surfaces[room.mesh.vertex_surface[v] as usize].reflectance.0[0];
        assert!((f64::from(photo[v][0]) - rho * e[v][0] / PI).abs() < 1e-4 * e[v][0]);
        assert_eq!(f64::from(false_colour[v][2]), f64::from(e[v][2] as f32));
    }
    assert!(vertex_attributes(DisplayMode::Photo, &room.mesh, &room.surfaces, &e[1..]).is_err());
}

#[test]
fn a_uniform_luminance_scene_is_uniform_mid_grey() {
    let room = box_room();
    let e = vec![[250.0; 3]; room.mesh.n_vertices()];
    // A single reflectance so that luminance is uniform too.
    let surfaces: Vec<Surface> = room
        .surfaces
        .iter()
        .map(|s| Surface {
            reflectance: Reflectance::grey(0.5),
            ..s.clone()
        })
        .collect();
    let attrs = vertex_attributes(DisplayMode::Photo, &room.mesh, &surfaces, &e).unwrap();
    let shader = DisplayShader::fit(DisplayMode::Photo, &room.mesh, &attrs);
    let frame = render(
        &room.mesh,
        &attrs,
        &View::new(room_camera(), 64, 48).unwrap(),
        &shader,
    )
    .unwrap();
    // The rule: Reinhard x/(1+x) of the key-exposed luminance is 0.18, then sRGB: 118.
    let grey = (srgb_encode(0.18) * 255.0).round() as u8;
    assert_eq!(grey, 118);
    for px in frame.pixmap.data().chunks_exact(4) {
        assert_eq!(px, [grey, grey, grey, 255]);
    }
}

#[test]
fn exposure_normalises_a_hundredfold_scale_change() {
    let room = box_room();
    let view = View::new(room_camera(), 96, 72).unwrap();
    let render_at = |scale: f64| {
        let attrs = vertex_attributes(
            DisplayMode::Photo,
            &room.mesh,
            &room.surfaces,
            &lamp_illuminance(&room.mesh, scale),
        )
        .unwrap();
        render(
            &room.mesh,
            &attrs,
            &view,
            &DisplayShader::fit(DisplayMode::Photo, &room.mesh, &attrs),
        )
        .unwrap()
    };
    let reference = render_at(1.0);
    let mean = reference
        .pixmap
        .data()
        .chunks_exact(4)
        .map(|p| f64::from(p[1]))
        .sum::<f64>()
        / (96.0 * 72.0);
    assert!((70.0..190.0).contains(&mean), "mean green {mean}");
    let saturated = reference
        .pixmap
        .data()
        .chunks_exact(4)
        .filter(|p| p[1] == 255 || p[1] == 0)
        .count();
    assert!(saturated < 96 * 72 / 100, "{saturated} pixels blown out or black");
    for scale in [0.01, 100.0] {
        let scaled = render_at(scale);
        assert_eq!(
            count_differing(&reference.pixmap, &scaled.pixmap, 1),
            0,
            "scale {scale}"
        );
    }
    // A fixed exposure is not normalised: the same scale change darkens the picture.
    let attrs = vertex_attributes(
        DisplayMode::Photo,
        &room.mesh,
        &room.surfaces,
        &lamp_illuminance(&room.mesh, 1.0),
    )
    .unwrap();
    let fixed = Photo::auto(&room.mesh, &attrs);
    let dim: Vec<[f32; 3]> = attrs.iter().map(|a| a.map(|x| x * 0.01)).collect();
    let dark = render(&room.mesh, &dim, &view, &fixed).unwrap();
    assert!(count_differing(&reference.pixmap, &dark.pixmap, 1) > 96 * 72 / 2);
}

#[test]
fn false_colour_endpoints_are_the_ends_of_viridis() {
    let (bottom, top, middle) = ([0x44, 0x01, 0x54], [0xFD, 0xE7, 0x25], [0x21, 0x90, 0x8C]);
    assert_eq!((VIRIDIS[0], VIRIDIS[8], VIRIDIS[4]), (bottom, top, middle));
    let log = FalseColor::new(10.0, 1000.0, LuxScale::Log).unwrap();
    assert_eq!(log.shade([10.0; 3]), bottom);
    assert_eq!(log.shade([1000.0; 3]), top);
    assert_eq!(
        log.shade([100.0; 3]),
        middle,
        "100 lx is half way on a log 10–1000 lx scale"
    );
    assert_eq!(log.shade([1.0; 3]), bottom, "below the range clamps");
    assert_eq!(log.shade([5000.0; 3]), top, "above the range clamps");
    let linear = FalseColor::new(0.0, 500.0, LuxScale::Linear).unwrap();
    assert_eq!(linear.shade([250.0; 3]), middle);
    assert!(FalseColor::new(0.0, 500.0, LuxScale::Log).is_err());
    assert!(FalseColor::new(5.0, 5.0, LuxScale::Linear).is_err());

    // Fitted to a scene, the range is the vertices' lowest and highest lux.
    let room = box_room();
    let e = lamp_illuminance(&room.mesh, 1.0);
    let (lo, hi) = e
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(l, h), v| (l.min(v[0]), h.max(v[0])));
    let attrs = vertex_attributes(DisplayMode::FalseColor, &room.mesh, &room.surfaces, &e).unwrap();
    let fitted = FalseColor::fit(&attrs, LuxScale::Log);
    let (min_lx, max_lx) = fitted.range();
    assert!(
        (min_lx - lo).abs() < 1e-3 * lo && (max_lx - hi).abs() < 1e-3 * hi,
        "{min_lx}–{max_lx} vs {lo}–{hi}"
    );
    assert_eq!(fitted.shade([max_lx as f32; 3]), top);
}

#[test]
fn the_false_colour_table_is_within_one_level_of_the_exact_shade() {
    // Log scales of 1:10 and 1:1000, and a linear one from 0 (values below 1e-6 of its top are
    // shaded exactly); 40 000 values spread geometrically over and past each range, in grey and
    // in colour.
    let scales = [
        FalseColor::new(50.0, 500.0, LuxScale::Log).unwrap(),
        FalseColor::new(2.0, 2000.0, LuxScale::Log).unwrap(),
        FalseColor::new(0.0, 1000.0, LuxScale::Linear).unwrap(),
    ];
    for scale in scales {
        let table = FalseColorTable::new(&scale);
        let (lo, hi) = scale.range();
        // 1 024 entries per doubling over the span (from 1e-6 of the top for the linear scale).
        let doublings = (hi / lo.max(hi * 1e-6)).log2();
        assert!(
            (table.entries() as f64 - 1024.0 * doublings).abs() <= 1024.0,
            "{} entries for {doublings} doublings",
            table.entries()
        );
        let (from, to) = ((lo.max(1e-3) / 4.0).ln(), (hi * 4.0).ln());
        let mut same = 0;
        let n: u32 = 40_000;
        for k in 0..n {
            let y = (from + (to - from) * f64::from(k) / f64::from(n)).exp() as f32;
            for rgb in [[y; 3], [y * 1.2, y, y * 0.7]] {
                let (got, want) = (table.shade(rgb), scale.shade(rgb));
                let off = (0..3).map(|c| got[c].abs_diff(want[c])).max().unwrap();
                assert!(off <= 1, "{scale:?} at {rgb:?}: table {got:?}, exact {want:?}");
                same += u32::from(off == 0);
            }
        }
        assert!(
            same >= 2 * n * 9 / 10,
            "{scale:?}: only {same} of {} equal",
            2 * n
        );
        // Past the ends the table shades exactly: the ends of viridis.
        assert_eq!(table.shade([(hi * 2.0) as f32; 3]), VIRIDIS[8]);
        assert_eq!(table.shade([-1.0; 3]), VIRIDIS[0]);
        assert_eq!(table.shade([f32::NAN; 3]), VIRIDIS[0]);
    }
    // A narrow range (a fitted scale over a nearly uniform room) would need entries narrower
    // than 2⁻¹⁰ of the value: no table, every value shaded exactly.
    for scale in [
        FalseColor::new(480.0, 500.0, LuxScale::Log).unwrap(),
        FalseColor::new(480.0, 500.0, LuxScale::Linear).unwrap(),
    ] {
        let table = FalseColorTable::new(&scale);
        assert_eq!(table.entries(), 0, "{scale:?}");
        for k in 0..=2000 {
            let y = 470.0 + 0.02 * k as f32;
            assert_eq!(table.shade([y; 3]), scale.shade([y; 3]), "{scale:?} at {y}");
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Overlays

#[test]
fn light_markers_land_on_the_projected_pixel_and_respect_the_camera() {
    let room = box_room();
    let camera = room_camera();
    let (w, h) = (160, 120);
    let view = View::new(camera, w, h).unwrap();
    let attrs = vec![[0.05f32; 3]; room.mesh.n_vertices()];
    let base = render(&room.mesh, &attrs, &view, &Photo::with_exposure(1.0)).unwrap();
    let pixel_of = |p: DVec3| {
        // Independent projection: the ray from the eye through p, expressed on the image plane.
        let f = (camera.target - camera.eye).normalize();
        let r = f.cross(DVec3::Z).normalize();
        let u = r.cross(f);
        let d = p - camera.eye;
        let t = (camera.fov_deg.to_radians() / 2.0).tan();
        let (sx, sy) = (d.dot(r) / d.dot(f) / t, d.dot(u) / d.dot(f) / t);
        (
            (sx * f64::from(h) / 2.0 + f64::from(w) / 2.0) as u32,
            ((1.0 - sy) * f64::from(h) / 2.0) as u32,
        )
    };
    let rgb = |frame: &haiko::render::Frame, (x, y): (u32, u32)| {
        let i = ((y * w + x) * 4) as usize;
        [
            frame.pixmap.data()[i],
            frame.pixmap.data()[i + 1],
            frame.pixmap.data()[i + 2],
        ]
    };
    let visible = DVec3::new(3.0, 2.0, 2.6);
    let hidden = DVec3::new(3.0, 2.0, 0.3); // inside the box, seen through its top
    let behind = camera.eye - (camera.target - camera.eye);
    let marker = |position, selected| LightMarker {
        position,
        aim_target: DVec3::new(4.5, 3.0, 0.0),
        selected,
    };

    let mut frame = base.clone();
    draw_lights(&mut frame, &view, &[marker(visible, false)]);
    assert_eq!(rgb(&frame, pixel_of(visible)), haiko::render::overlay::LIGHT_RGB);

    let mut frame = base.clone();
    draw_lights(&mut frame, &view, &[marker(hidden, false)]);
    let dimmed = rgb(&frame, pixel_of(hidden));
    assert_ne!(
        dimmed,
        haiko::render::overlay::LIGHT_RGB,
        "an occluded light is dimmed"
    );
    assert_ne!(dimmed, rgb(&base, pixel_of(hidden)), "but still drawn");

    let mut frame = base.clone();
    draw_lights(&mut frame, &view, &[marker(behind, false)]);
    assert_eq!(frame, base, "a light behind the camera is not drawn");

    // The selected light's aim line passes over the projection of the segment's midpoint.
    let mut frame = base.clone();
    draw_lights(&mut frame, &view, &[marker(visible, true)]);
    let midpoint = pixel_of((visible + DVec3::new(4.5, 3.0, 0.0)) / 2.0);
    assert_ne!(rgb(&frame, midpoint), rgb(&base, midpoint));

    let mut frame = base.clone();
    draw_crosshair(&mut frame.pixmap, 80, 60);
    assert_eq!(
        rgb(&frame, (80, 60)),
        rgb(&base, (80, 60)),
        "the pointed-at pixel stays visible"
    );
    assert_eq!(rgb(&frame, (85, 60)), [255, 255, 255]);
    assert_eq!(rgb(&frame, (80, 54)), [255, 255, 255]);
    assert_eq!(rgb(&frame, (90, 60)), rgb(&base, (90, 60)), "arms end 8 px out");
}

// ---------------------------------------------------------------------------------------------
// Goldens and look images

fn golden() -> Golden {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    Golden::from_env(root.join("snapshots"), root.join("target/golden-diffs"))
}

#[test]
fn box_room_matches_its_goldens() {
    let room = box_room();
    let view = View::new(room_camera(), 160, 120).unwrap();
    let e = lamp_illuminance(&room.mesh, 1.0);
    for (mode, name) in [
        (DisplayMode::Photo, "box_room_photo"),
        (DisplayMode::FalseColor, "box_room_false_colour"),
    ] {
        let attrs = vertex_attributes(mode, &room.mesh, &room.surfaces, &e).unwrap();
        let frame = render(
            &room.mesh,
            &attrs,
            &view,
            &DisplayShader::fit(mode, &room.mesh, &attrs),
        )
        .unwrap();
        let tolerance = Tolerance {
            channel: 2,
            max_pixels: 8,
        };
        golden().check_image(name, &frame.pixmap, tolerance).unwrap();
        // Both modes draw the same patches: one exact ID golden.
        golden().check_ids("box_room", &frame.ids).unwrap();
    }
}

#[test]
fn the_golden_harness_detects_differences_and_writes_a_triptych() {
    let dir = tempfile::tempdir().unwrap();
    let update = Golden {
        reference_dir: dir.path().join("ref"),
        diff_dir: dir.path().join("diff"),
        update: true,
    };
    let compare = Golden {
        update: false,
        ..update.clone()
    };
    let room = box_room();
    let view = View::new(room_camera(), 40, 30).unwrap();
    let attrs = vec![[0.3f32; 3]; room.mesh.n_vertices()];
    let frame = render(&room.mesh, &attrs, &view, &Photo::with_exposure(1.0)).unwrap();
    update
        .check_image(
            "t",
            &frame.pixmap,
            Tolerance {
                channel: 0,
                max_pixels: 0,
            },
        )
        .unwrap();
    update.check_ids("t", &frame.ids).unwrap();
    compare
        .check_image(
            "t",
            &frame.pixmap,
            Tolerance {
                channel: 0,
                max_pixels: 0,
            },
        )
        .unwrap();
    compare.check_ids("t", &frame.ids).unwrap();

    let mut changed = frame.clone();
    for p in 0..3 {
        changed.pixmap.data_mut()[p * 4 * 7] ^= 0x10; // three pixels, red channel ±16
    }
    let loose = Tolerance {
        channel: 16,
        max_pixels: 0,
    };
    compare.check_image("t", &changed.pixmap, loose).unwrap();
    compare
        .check_image(
            "t",
            &changed.pixmap,
            Tolerance {
                channel: 15,
                max_pixels: 3,
            },
        )
        .unwrap();
    let err = compare
        .check_image(
            "t",
            &changed.pixmap,
            Tolerance {
                channel: 15,
                max_pixels: 2,
            },
        )
        .unwrap_err();
    assert!(err.to_string().contains("3 pixels differ"), "{err}");
    let triptych = tiny_skia::Pixmap::load_png(dir.path().join("diff/t.png")).unwrap();
    assert_eq!((triptych.width(), triptych.height()), (120, 30));
    assert_eq!(
        &triptych.data()[40 * 4..40 * 4 + 4],
        &[255, 0, 0, 255],
        "first changed pixel is red in the mask"
    );

    let mut ids = frame.ids.as_slice().to_vec();
    ids[5] = ids[5].wrapping_add(1);
    let other = haiko::render::IdBuffer::new(40, 30, ids).unwrap();
    assert!(compare.check_ids("t", &other).is_err());
    assert_eq!(ids_from_pixmap(&ids_to_pixmap(&other).unwrap()).unwrap(), other);
}

#[test]
fn write_look_images() {
    let room = box_room();
    let dir = out_dir("render-look");
    let e = lamp_illuminance(&room.mesh, 1.0);
    let view = View::new(room_camera(), 640, 480).unwrap();
    for (mode, name) in [
        (DisplayMode::Photo, "photo"),
        (DisplayMode::FalseColor, "false_colour"),
    ] {
        let attrs = vertex_attributes(mode, &room.mesh, &room.surfaces, &e).unwrap();
        let mut frame = render(
            &room.mesh,
            &attrs,
            &view,
            &DisplayShader::fit(mode, &room.mesh, &attrs),
        )
        .unwrap();
        let lights = [
            LightMarker {
                position: DVec3::new(3.0, 2.0, 2.6),
                aim_target: DVec3::new(4.5, 3.0, 0.0),
                selected: true,
            },
            LightMarker {
                position: DVec3::new(3.0, 2.0, 0.3),
                aim_target: DVec3::new(3.0, 2.0, 0.0),
                selected: false,
            },
        ];
        draw_lights(&mut frame, &view, &lights);
        draw_crosshair(&mut frame.pixmap, 400, 300);
        frame.pixmap.save_png(dir.join(format!("{name}.png"))).unwrap();
    }
    let attrs = vertex_attributes(DisplayMode::Photo, &room.mesh, &room.surfaces, &e).unwrap();
    let near_wall = Camera {
        eye: DVec3::new(0.01, 2.0, 1.5),
        target: DVec3::new(0.01, 4.0, 1.2),
        fov_deg: 60.0,
    };
    let frame = render(
        &room.mesh,
        &attrs,
        &View::new(near_wall, 320, 240).unwrap(),
        &Photo::auto(&room.mesh, &attrs),
    )
    .unwrap();
    frame.pixmap.save_png(dir.join("near_wall.png")).unwrap();
}

#[test]
fn bad_views_are_input_errors_not_panics() {
    let camera = room_camera();
    let bad = [
        View::new(camera, 0, 10),
        View::new(camera, 10, 20_000),
        View::new(
            Camera {
                fov_deg: 0.0,
                ..camera
            },
            10,
            10,
        ),
        View::new(
            Camera {
                fov_deg: 180.0,
                ..camera
            },
            10,
            10,
        ),
        View::new(
            Camera {
                fov_deg: f64::NAN,
                ..camera
            },
            10,
            10,
        ),
        View::new(
            Camera {
                target: camera.eye,
                ..camera
            },
            10,
            10,
        ),
        View::new(
            Camera {
                eye: DVec3::new(f64::INFINITY, 0.0, 0.0),
                ..camera
            },
            10,
            10,
        ),
        View::with_near(camera, 10, 10, 0.0),
    ];
    for (k, view) in bad.into_iter().enumerate() {
        let err = view.expect_err(&format!("case {k} must be rejected"));
        assert_eq!(err.exit_code(), 2, "case {k}: {err}");
    }
    // Looking straight down (forward parallel to z) is valid.
    let down = Camera {
        eye: DVec3::new(3.0, 2.0, 2.9),
        target: DVec3::new(3.0, 2.0, 0.0),
        fov_deg: 90.0,
    };
    let view = View::new(down, 40, 30).unwrap();
    let room = box_room();
    let raster = render_attributes(&room.mesh, &vec![[1.0; 3]; room.mesh.n_vertices()], &view).unwrap();
    assert!(raster.ids.iter().all(|&id| id != BACKGROUND_ID));
    assert!(
        render_attributes(&room.mesh, &[[1.0; 3]], &view).is_err(),
        "attributes must be one per vertex"
    );
}
