//! The scene: bundled rooms, meshing invariants against hand-computed values, OBJ import, and
//! one test per kind of bad room file.

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

use glam::DVec3;
use haiko::scene::mesher::{self, Geometry, TriangleSurface};
use haiko::scene::obj::{Placement, read_obj};
use haiko::scene::room_file::UpAxis;
use haiko::scene::{Aabb, PatchMesh, Reflectance, Scene, SurfaceKind, load};

const TOL: f64 = 1e-9;

fn rooms_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("rooms")
}

fn aabb(min: [f64; 3], max: [f64; 3]) -> Aabb {
    Aabb {
        min: DVec3::from_array(min),
        max: DVec3::from_array(max),
    }
}

/// Lays out and meshes a room with `boxes` at `size`, returning surface names and the mesh.
fn mesh_room(
    room: [f64; 3],
    boxes: &[Aabb],
    meshes: &[TriangleSurface],
    size: f64,
) -> (Vec<String>, PatchMesh) {
    let geometry = Geometry {
        room_size: DVec3::from_array(room),
        boxes,
        meshes,
    };
    let layout = mesher::layout(&geometry);
    let mesh = mesher::mesh(&geometry, &layout, size, 10_000_000).expect("within the vertex limit");
    (layout.into_iter().map(|s| s.name).collect(), mesh)
}

/// Total patch area per surface name.
fn area_by_surface(names: &[String], mesh: &PatchMesh) -> HashMap<String, f64> {
    let mut areas = HashMap::new();
    for p in &mesh.patches {
        *areas.entry(names[p.surface as usize].clone()).or_insert(0.0) += p.area;
    }
    areas
}

// ---------------------------------------------------------------- bundled rooms

fn check_bundled(file: &str, n_lights: usize) -> Scene {
    let scene = load(&rooms_dir().join(file)).unwrap_or_else(|e| panic!("{file}: {e}"));
    assert_eq!(scene.lights.len(), n_lights, "{file}");
    assert!(
        scene.fine.n_vertices() < 20_000,
        "{file}: {} fine vertices",
        scene.fine.n_vertices()
    );
    assert!(scene.coarse.patches.len() < scene.fine.patches.len(), "{file}");
    // Fine and coarse meshes cover the same surfaces with the same total area.
    let total = |m: &PatchMesh| m.patches.iter().map(|p| p.area).sum::<f64>();
    assert!(
        (total(&scene.fine) - total(&scene.coarse)).abs() < 1e-9 * total(&scene.fine),
        "{file}"
    );
    scene
}

#[test]
fn paper_room_loads_as_in_the_paper() {
    let scene = check_bundled("paper.toml", 2);
    assert_eq!(scene.room_size, DVec3::new(6.0, 4.0, 2.7));
    assert_eq!(scene.camera.eye, DVec3::new(0.5, 0.5, 1.6));
    assert!(scene.lights.iter().all(|l| l.order == Some(5)));
    // The centre light aims straight down at the floor centre.
    assert!((scene.lights[0].aim - DVec3::NEG_Z).length() < 1e-15);
    // 6 × 4 × 2.7 m at 0.1 m: floor and ceiling 61·41, walls 41·28 and 61·28 vertices each.
    assert_eq!(scene.fine.n_vertices(), 2 * 61 * 41 + 2 * 41 * 28 + 2 * 61 * 28);
}

#[test]
fn gallery_white_box_and_sculpture_rooms_load() {
    let gallery = check_bundled("gallery.toml", 4);
    assert!(
        gallery
            .surfaces
            .iter()
            .any(|s| s.name == "floor" && s.reflectance == Reflectance::grey(0.08))
    );
    let white = check_bundled("white-box.toml", 1);
    assert!(
        white
            .surfaces
            .iter()
            .all(|s| s.reflectance == Reflectance::grey(0.95))
    );
    let sculpture = check_bundled("sculpture.toml", 2);
    let names: Vec<&str> = sculpture.surfaces.iter().map(|s| s.name.as_str()).collect();
    assert!(
        names.contains(&"mesh0:plinth") && names.contains(&"mesh0:sculpture"),
        "{names:?}"
    );
    // The plinth is 0.6 × 0.6 × 1.0 m, centred at (2.5, 2.5) on the floor.
    let bounds = sculpture.mesh_bounds[0];
    assert!(
        (bounds.min - DVec3::new(2.2, 2.2, 0.0)).length() < 1e-6,
        "{bounds:?}"
    );
    assert!(
        (bounds.max - DVec3::new(2.8, 2.8, 1.6)).length() < 1e-6,
        "{bounds:?}"
    );
}

#[test]
fn office_loads_with_its_eulumdat_downlights() {
    let scene = check_bundled("office.toml", 6);
    // sample_09: 13 743 lm (the file's LORL × lamp flux), rotationally symmetric.
    for light in &scene.lights {
        let flux = light.curve.flux_lm();
        assert!((flux / 13743.0 - 1.0).abs() < 0.1, "{}: {flux} lm", light.name);
    }
    // No floor patch under the four desks or the cabinet.
    let floor = scene.surfaces.iter().position(|s| s.name == "floor").unwrap() as u32;
    for p in scene.fine.patches.iter().filter(|p| p.surface == floor) {
        assert!(
            !scene
                .boxes
                .iter()
                .any(|b| b.contains_strictly(p.centroid + DVec3::Z * 1e-6))
        );
    }
}

// ---------------------------------------------------------------- meshing

#[test]
fn empty_room_vertex_and_patch_counts_match_hand_count() {
    // 0.5 m: floor/ceiling 12 × 8 cells, walls x 8 × 6 (2.7/0.5 → 6), walls y 12 × 6.
    let (_, mesh) = mesh_room([6.0, 4.0, 2.7], &[], &[], 0.5);
    assert_eq!(mesh.n_vertices(), 2 * 13 * 9 + 2 * 9 * 7 + 2 * 13 * 7);
    assert_eq!(mesh.patches.len(), 2 * 96 + 2 * 48 + 2 * 72);
    // 0.3 m: 20 × 14, 14 × 9, 20 × 9 cells (2.7 / 0.3 is 9, not 9.000000000000002 → 10).
    let (_, mesh) = mesh_room([6.0, 4.0, 2.7], &[], &[], 0.3);
    assert_eq!(mesh.n_vertices(), 2 * 21 * 15 + 2 * 15 * 10 + 2 * 21 * 10);
    // 0.15 m: 40 × 27 cells (4 / 0.15 = 26.7 → 27), 27 × 18, 40 × 18.
    let (_, mesh) = mesh_room([6.0, 4.0, 2.7], &[], &[], 0.15);
    assert_eq!(mesh.n_vertices(), 2 * 41 * 28 + 2 * 28 * 19 + 2 * 41 * 19);
}

/// A desk on the floor, a cabinet against wall x0, a box hanging free, a box on the desk.
fn furnished() -> Vec<Aabb> {
    vec![
        aabb([2.5, 1.5, 0.0], [3.5, 2.5, 0.75]),
        aabb([0.0, 1.0, 0.0], [0.5, 3.0, 2.0]),
        aabb([4.0, 1.0, 1.0], [5.0, 2.0, 1.5]),
        aabb([2.8, 1.8, 0.75], [3.2, 2.2, 1.0]),
    ]
}

#[test]
fn patch_areas_per_surface_equal_the_analytic_areas() {
    let expected: HashMap<&str, f64> = HashMap::from([
        ("floor", 24.0 - 1.0 - 1.0), // minus desk and cabinet footprints
        ("ceiling", 24.0),
        ("wall-x0", 10.8 - 4.0), // minus the cabinet's back (2 m × 2 m)
        ("wall-x1", 10.8),
        ("wall-y0", 16.2),
        ("wall-y1", 16.2),
        ("box0-top", 1.0 - 0.16), // minus the box standing on it
        ("box0-x0", 0.75),
        ("box0-x1", 0.75),
        ("box0-y0", 0.75),
        ("box0-y1", 0.75),
        ("box1-x1", 4.0),
        ("box1-y0", 1.0),
        ("box1-y1", 1.0),
        ("box1-top", 1.0),
        ("box2-x0", 0.5),
        ("box2-x1", 0.5),
        ("box2-y0", 0.5),
        ("box2-y1", 0.5),
        ("box2-bottom", 1.0),
        ("box2-top", 1.0),
        ("box3-x0", 0.1),
        ("box3-x1", 0.1),
        ("box3-y0", 0.1),
        ("box3-y1", 0.1),
        ("box3-top", 0.16),
    ]);
    for size in [0.15, 0.5, 0.37] {
        let (names, mesh) = mesh_room([6.0, 4.0, 2.7], &furnished(), &[], size);
        // Hidden faces (on the floor, on the wall, on the desk) are not surfaces.
        let got: HashSet<&str> = names.iter().map(String::as_str).collect();
        assert_eq!(got, expected.keys().copied().collect(), "size {size}");
        let areas = area_by_surface(&names, &mesh);
        for (name, area) in &expected {
            assert!(
                (areas[*name] - area).abs() < TOL,
                "size {size}: {name} {} ≠ {area}",
                areas[*name]
            );
        }
    }
}

#[test]
fn no_floor_patch_overlaps_a_box_standing_on_the_floor() {
    let boxes = furnished();
    let (names, mesh) = mesh_room([6.0, 4.0, 2.7], &boxes, &[], 0.15);
    let mut floor_patches = 0;
    for p in mesh
        .patches
        .iter()
        .filter(|p| names[p.surface as usize] == "floor")
    {
        floor_patches += 1;
        let (lo, hi) = p
            .vertex_ids()
            .iter()
            .map(|&v| mesh.positions[v as usize])
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), q| {
                (lo.min(q), hi.max(q))
            });
        for b in &boxes[..2] {
            let overlap_x = lo.x < b.max.x - TOL && hi.x > b.min.x + TOL;
            let overlap_y = lo.y < b.max.y - TOL && hi.y > b.min.y + TOL;
            assert!(
                !(overlap_x && overlap_y),
                "floor patch {lo} – {hi} under box {b:?}"
            );
        }
    }
    assert!(floor_patches > 0);
}

#[test]
fn normals_face_into_the_room_and_out_of_boxes() {
    let boxes = furnished();
    let (names, mesh) = mesh_room([6.0, 4.0, 2.7], &boxes, &[], 0.5);
    let room = aabb([0.0; 3], [6.0, 4.0, 2.7]);
    let expected_room_normals = [
        ("floor", DVec3::Z),
        ("ceiling", DVec3::NEG_Z),
        ("wall-x0", DVec3::X),
        ("wall-x1", DVec3::NEG_X),
        ("wall-y0", DVec3::Y),
        ("wall-y1", DVec3::NEG_Y),
    ];
    for p in &mesh.patches {
        let name = &names[p.surface as usize];
        let ahead = p.centroid + 1e-3 * p.normal;
        let behind = p.centroid - 1e-3 * p.normal;
        assert!(room.contains_strictly(ahead), "{name}: {ahead}");
        if let Some((_, n)) = expected_room_normals.iter().find(|(s, _)| s == name) {
            assert_eq!(p.normal, *n, "{name}");
        } else {
            let index: usize = name[3..name.find('-').unwrap()].parse().unwrap();
            assert!(
                boxes[index].contains_strictly(behind),
                "{name}: {behind} not inside its box"
            );
            assert!(!boxes[index].contains_strictly(ahead), "{name}");
        }
    }
}

#[test]
fn patches_are_planar_counter_clockwise_and_consistent() {
    let obj = TriangleSurface {
        name: "mesh0:tilted".into(),
        mesh_index: 0,
        positions: vec![
            DVec3::new(1.0, 1.0, 0.5),
            DVec3::new(2.0, 1.2, 0.7),
            DVec3::new(1.3, 2.1, 1.4),
        ],
        triangles: vec![[0, 1, 2]],
    };
    let (_, mesh) = mesh_room([6.0, 4.0, 2.7], &furnished(), &[obj], 0.3);
    for p in &mesh.patches {
        let v: Vec<DVec3> = p
            .vertex_ids()
            .iter()
            .map(|&i| mesh.positions[i as usize])
            .collect();
        // Signed area vector (shoelace / Newell): points along the normal, its length is the area.
        let mut twice_area = DVec3::ZERO;
        for k in 1..v.len() - 1 {
            twice_area += (v[k] - v[0]).cross(v[k + 1] - v[0]);
        }
        assert!((twice_area * 0.5 - p.normal * p.area).length() < 1e-12, "{p:?}");
        assert!((p.normal.length() - 1.0).abs() < 1e-12);
        for q in &v {
            assert!((*q - v[0]).dot(p.normal).abs() < 1e-12, "not planar: {p:?}");
        }
        let centroid = v.iter().copied().sum::<DVec3>() / v.len() as f64;
        assert!((centroid - p.centroid).length() < 1e-12);
        for &i in p.vertex_ids() {
            assert_eq!(mesh.vertex_surface[i as usize], p.surface);
            assert!((mesh.normals[i as usize] - p.normal).length() < 1e-12);
        }
    }
}

#[test]
fn floor_and_wall_have_distinct_vertices_with_equal_positions_at_their_edge() {
    let (names, mesh) = mesh_room([6.0, 4.0, 2.7], &[], &[], 0.5);
    let surface = |name: &str| names.iter().position(|n| n == name).unwrap() as u32;
    let (floor, wall) = (surface("floor"), surface("wall-y0"));
    let on_edge = |s: u32| -> Vec<(u32, DVec3)> {
        (0..mesh.n_vertices() as u32)
            .filter(|&i| mesh.vertex_surface[i as usize] == s)
            .map(|i| (i, mesh.positions[i as usize]))
            .filter(|(_, p)| p.y == 0.0 && p.z == 0.0)
            .collect()
    };
    let (floor_edge, wall_edge) = (on_edge(floor), on_edge(wall));
    assert_eq!(floor_edge.len(), 13); // x = 0, 0.5, …, 6
    let mut floor_x: Vec<f64> = floor_edge.iter().map(|(_, p)| p.x).collect();
    let mut wall_x: Vec<f64> = wall_edge.iter().map(|(_, p)| p.x).collect();
    floor_x.sort_by(f64::total_cmp);
    wall_x.sort_by(f64::total_cmp);
    assert_eq!(floor_x, wall_x);
    let floor_ids: HashSet<u32> = floor_edge.iter().map(|(i, _)| *i).collect();
    assert!(wall_edge.iter().all(|(i, _)| !floor_ids.contains(i)));
    // Within a surface each position is one vertex.
    for s in 0..names.len() as u32 {
        let positions: Vec<[u64; 3]> = (0..mesh.n_vertices())
            .filter(|&i| mesh.vertex_surface[i] == s)
            .map(|i| mesh.positions[i].to_array().map(f64::to_bits))
            .collect();
        let unique: HashSet<[u64; 3]> = positions.iter().copied().collect();
        assert_eq!(unique.len(), positions.len(), "{}", names[s as usize]);
    }
}

// ---------------------------------------------------------------- OBJ

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn obj_y_up_becomes_z_up_then_scale_then_translate() {
    let dir = tempfile::tempdir().unwrap();
    let obj = write(
        dir.path(),
        "tri.obj",
        "v 0.1 0.2 -0.3\nv 0.5 0.2 -0.3\nv 0.1 0.6 -0.3\nf 1 2 3\n",
    );
    let placement = Placement {
        up: UpAxis::Y,
        scale: 2.0,
        translate: DVec3::new(1.0, 1.0, 0.0),
    };
    let surfaces = read_obj(&obj, 0, &placement).unwrap().surfaces;
    assert_eq!(surfaces.len(), 1);
    let s = &surfaces[0].geometry;
    // (x, y, z) → (x, −z, y), ×2, + (1, 1, 0).
    let expected = [[1.2, 1.6, 0.4], [2.0, 1.6, 0.4], [1.2, 1.6, 1.2]];
    let got: Vec<DVec3> = s.triangles[0].iter().map(|&i| s.positions[i as usize]).collect();
    for (g, e) in got.iter().zip(expected) {
        assert!((*g - DVec3::from_array(e)).length() < 1e-6, "{g} vs {e:?}");
    }
    // No material: grey 0.5.
    assert_eq!(surfaces[0].reflectance, Reflectance::grey(0.5));
    // z up keeps the coordinates.
    let keep = Placement {
        up: UpAxis::Z,
        scale: 1.0,
        translate: DVec3::ZERO,
    };
    let s = &read_obj(&obj, 0, &keep).unwrap().surfaces[0].geometry;
    assert!((s.positions[s.triangles[0][0] as usize] - DVec3::new(0.1, 0.2, -0.3)).length() < 1e-6);
}

#[test]
fn mtl_kd_becomes_the_surface_reflectance() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "m.mtl",
        "newmtl stone\nKd 0.3 0.3 0.3\nnewmtl brass\nKd 0.6 0.4 0.2\n",
    );
    let obj = "mtllib m.mtl\nv 1 0 -1\nv 2 0 -1\nv 1 1 -1\nv 1 0 -2\nv 2 0 -2\nv 1 1 -2\nv 1 0 -3\nv 2 0 -3\nv 1 1 -3\n\
               o c\nf 7 8 9\no a\nusemtl stone\nf 1 2 3\no b\nusemtl brass\nf 4 5 6\n";
    // `c` comes before any `usemtl` (a material stays active across `o` lines, as in OBJ).
    write(dir.path(), "m.obj", obj);
    let room = write(
        dir.path(),
        "room.toml",
        "version = 1\n[room]\nsize = [4, 4, 3]\n[room.reflectance]\nfloor = 0.2\nwalls = 0.5\nceiling = 0.7\n\
         [[mesh]]\nfile = \"m.obj\"\n",
    );
    let scene = load(&room).unwrap();
    let by_name: HashMap<&str, Reflectance> = scene
        .surfaces
        .iter()
        .map(|s| (s.name.as_str(), s.reflectance))
        .collect();
    assert_eq!(by_name["mesh0:a"], Reflectance::grey(0.3));
    assert!(by_name["mesh0:a"].is_grey());
    assert_eq!(by_name["mesh0:b"], Reflectance([0.6, 0.4, 0.2]));
    assert!(!by_name["mesh0:b"].is_grey());
    assert_eq!(by_name["mesh0:c"], Reflectance::grey(0.5));
    let kind = &scene.surfaces.iter().find(|s| s.name == "mesh0:c").unwrap().kind;
    assert_eq!(*kind, SurfaceKind::Mesh { mesh_index: 0 });
}

#[test]
fn subdivision_keeps_the_area_and_shares_edge_vertices() {
    // One right triangle with 2 m legs: longest edge 2√2 = 2.83 m; at 0.3 m that needs 16
    // segments per edge (8 give 0.354 m) → 16² = 256 triangles, (17 · 18) / 2 = 153 vertices.
    let triangle = TriangleSurface {
        name: "mesh0:t".into(),
        mesh_index: 0,
        positions: vec![
            DVec3::new(1.0, 1.0, 1.0),
            DVec3::new(3.0, 1.0, 1.0),
            DVec3::new(1.0, 3.0, 1.0),
        ],
        triangles: vec![[0, 1, 2]],
    };
    let (names, mesh) = mesh_room([4.0, 4.0, 3.0], &[], std::slice::from_ref(&triangle), 0.3);
    let patches: Vec<_> = mesh
        .patches
        .iter()
        .filter(|p| names[p.surface as usize] == "mesh0:t")
        .collect();
    assert_eq!(patches.len(), 256);
    assert!((patches.iter().map(|p| p.area).sum::<f64>() - 2.0).abs() < 1e-12);
    for p in &patches {
        let v: Vec<DVec3> = p
            .vertex_ids()
            .iter()
            .map(|&i| mesh.positions[i as usize])
            .collect();
        for k in 0..3 {
            assert!(v[k].distance(v[(k + 1) % 3]) <= 0.3);
        }
        assert_eq!(p.normal, DVec3::Z);
    }
    let n_obj_vertices = mesh
        .vertex_surface
        .iter()
        .filter(|&&s| names[s as usize] == "mesh0:t")
        .count();
    assert_eq!(n_obj_vertices, 153);
    // A 1 m square as two triangles: √2 / 0.3 → 8 segments; the two 45-vertex triangles share
    // the 9 vertices of their diagonal: a 9 × 9 grid.
    let square = TriangleSurface {
        name: "mesh0:sq".into(),
        mesh_index: 0,
        positions: vec![
            DVec3::new(1.0, 1.0, 1.0),
            DVec3::new(2.0, 1.0, 1.0),
            DVec3::new(2.0, 2.0, 1.0),
            DVec3::new(1.0, 2.0, 1.0),
        ],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
    };
    let (names, mesh) = mesh_room([4.0, 4.0, 3.0], &[], &[square], 0.3);
    let n = mesh
        .vertex_surface
        .iter()
        .filter(|&&s| names[s as usize] == "mesh0:sq")
        .count();
    assert_eq!(n, 81);
}

// ---------------------------------------------------------------- bad input

const GOOD_ROOM: &str = "version = 1
[room]
size = [4.0, 3.0, 2.5]
[room.reflectance]
floor = 0.2
walls = 0.5
ceiling = 0.7

[[light]]
name = \"a\"
position = [2.0, 1.5, 2.4]
lid = [[0, 100], [90, 0]]
";

/// Loads `text` as `bad.toml` in a temp dir (with `extra` files) and returns the error.
fn load_error(text: &str, extra: &[(&str, &str)]) -> String {
    let dir = tempfile::tempdir().unwrap();
    for (name, content) in extra {
        write(dir.path(), name, content);
    }
    let path = write(dir.path(), "bad.toml", text);
    let err = match load(&path) {
        Ok(_) => panic!("loaded:\n{text}"),
        Err(e) => e,
    };
    assert_eq!(err.exit_code(), 2, "{err}");
    let message = err.to_string();
    assert!(message.contains("bad.toml"), "{message}");
    assert!(message.contains("line"), "{message}");
    assert!(!message.contains('\n'), "not one line: {message}");
    message
}

#[test]
fn the_good_room_used_by_the_bad_input_tests_loads() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load(&write(dir.path(), "good.toml", GOOD_ROOM)).unwrap();
    assert_eq!(scene.lights[0].aim, DVec3::NEG_Z); // default aim_dir
    assert_eq!(scene.name, "good");
    // Default camera: 10 % into the room from the (0, 0) corner, eye height 1.6 m, looking at
    // the room centre.
    assert!((scene.camera.eye - DVec3::new(0.4, 0.3, 1.6)).length() < 1e-12);
    assert!((scene.camera.target - DVec3::new(2.0, 1.5, 1.25)).length() < 1e-12);
    assert_eq!(scene.camera.fov_deg, 60.0);
    assert_eq!(scene.settings, haiko::scene::Settings::default());
}

#[test]
fn syntax_error_is_located() {
    let m = load_error(&GOOD_ROOM.replace("floor = 0.2", "floor = = 0.2"), &[]);
    assert!(m.contains("line 5"), "{m}");
}

#[test]
fn unknown_field_is_rejected() {
    let m = load_error(&GOOD_ROOM.replace("floor = 0.2", "floor = 0.2\nflor = 0.3"), &[]);
    assert!(m.contains("flor") && m.contains("line 6"), "{m}");
}

#[test]
fn wrong_type_is_rejected() {
    let m = load_error(
        &GOOD_ROOM.replace("size = [4.0, 3.0, 2.5]", "size = \"big\""),
        &[],
    );
    assert!(m.contains("line 3"), "{m}");
}

#[test]
fn reflectance_at_098_is_rejected_with_the_reason() {
    let m = load_error(&GOOD_ROOM.replace("walls = 0.5", "walls = 0.98"), &[]);
    assert!(
        m.contains("line 6, column 9 (room.reflectance.walls)") && m.contains("singular"),
        "{m}"
    );
}

#[test]
fn negative_reflectance_is_rejected() {
    let m = load_error(
        &GOOD_ROOM.replace("ceiling = 0.7", "ceiling = [0.7, -0.1, 0.7]"),
        &[],
    );
    assert!(
        m.contains("line 7") && m.contains("room.reflectance.ceiling"),
        "{m}"
    );
}

#[test]
fn nan_is_rejected() {
    let m = load_error(&GOOD_ROOM.replace("[2.0, 1.5, 2.4]", "[2.0, nan, 2.4]"), &[]);
    assert!(m.contains("line 11, column 12 (light[0].position)"), "{m}");
}

#[test]
fn light_outside_the_room_is_rejected() {
    let m = load_error(&GOOD_ROOM.replace("[2.0, 1.5, 2.4]", "[2.0, 1.5, 2.6]"), &[]);
    assert!(
        m.contains("light[0].position") && m.contains("inside the room"),
        "{m}"
    );
}

#[test]
fn light_inside_a_box_is_rejected() {
    let text =
        format!("{GOOD_ROOM}[[box]]\nmin = [1.5, 1.0, 2.0]\nmax = [2.5, 2.0, 2.5]\nreflectance = 0.3\n");
    let m = load_error(&text, &[]);
    assert!(m.contains("light[0].position") && m.contains("box[0]"), "{m}");
}

/// A wedge (a ramp rising from x = 1 to 1 m at x = 3): a light over its slope lies inside the
/// wedge's bounds but outside it, and loads; one under the slope is refused, naming the mesh,
/// whichever way the wedge's faces turn.
#[test]
fn a_light_inside_an_obj_is_refused_and_one_only_in_its_bounds_is_not() {
    let wedge = "v 1 1 0\nv 3 1 0\nv 3 2 0\nv 1 2 0\nv 3 1 1\nv 3 2 1\n\
                 f 1 4 3 2\nf 2 3 6 5\nf 1 5 6 4\nf 1 2 5\nf 4 6 3\n";
    let reversed = "v 1 1 0\nv 3 1 0\nv 3 2 0\nv 1 2 0\nv 3 1 1\nv 3 2 1\n\
                    f 2 3 4 1\nf 5 6 3 2\nf 4 6 5 1\nf 5 2 1\nf 3 6 4\n";
    let room = |position: &str| {
        format!(
            "{GOOD_ROOM}[[light]]\nname = \"b\"\nposition = {position}\nlid = [[0, 100], [90, 0]]\n\
             [[mesh]]\nfile = \"wedge.obj\"\nup = \"z\"\n"
        )
    };
    for obj in [wedge, reversed] {
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), "wedge.obj", obj);
        let over = write(dir.path(), "over.toml", &room("[1.5, 1.5, 0.8]"));
        let scene = load(&over).unwrap_or_else(|e| panic!("over the slope: {e}"));
        assert_eq!(scene.lights[1].position, DVec3::new(1.5, 1.5, 0.8));
        let m = load_error(&room("[2.8, 1.5, 0.3]"), &[("wedge.obj", obj)]);
        assert!(
            m.contains("light[1].position") && m.contains("inside mesh[0]"),
            "{m}"
        );
    }
}

#[test]
fn missing_obj_names_the_path_written_and_resolved() {
    let m = load_error(&format!("{GOOD_ROOM}[[mesh]]\nfile = \"no/such.obj\"\n"), &[]);
    assert!(
        m.contains("`no/such.obj`") && m.contains("resolved to") && m.contains("mesh[0].file"),
        "{m}"
    );
}

#[test]
fn missing_lid_file_names_the_path_written_and_resolved() {
    let text = GOOD_ROOM.replace("lid = [[0, 100], [90, 0]]", "lid_file = \"nowhere.ldt\"");
    let m = load_error(&text, &[]);
    assert!(
        m.contains("`nowhere.ldt`") && m.contains("resolved to") && m.contains("light[0].lid_file"),
        "{m}"
    );
}

/// A degenerate OBJ face (a catalogue model's sliver) is left out with a note naming the mesh,
/// the file, the face and its line; an OBJ with nothing else is refused.
#[test]
fn degenerate_obj_faces_are_left_out_with_a_note_naming_them() {
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\nf 2 4 1\n";
    let text = format!("{GOOD_ROOM}[[mesh]]\nfile = \"flat.obj\"\ntranslate = [0.5, 0.5, 0.0]\nup = \"z\"\n");
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "flat.obj", obj);
    let scene = load(&write(dir.path(), "room.toml", &text)).unwrap();
    assert_eq!(
        scene.notes,
        [
            "mesh[0]: OBJ `flat.obj`: 2 degenerate faces (area below 1e-12 m² after placement) left \
          out: face 2 (line 6), face 3 (line 7)"
        ]
    );
    let meshes: Vec<_> = scene
        .surfaces
        .iter()
        .filter(|s| s.name.starts_with("mesh0:"))
        .collect();
    assert_eq!(meshes.len(), 1);
    // The corner only the left-out faces use (2, 0, 0) does not widen the mesh's bounds.
    assert_eq!(scene.mesh_bounds[0].max, DVec3::new(1.5, 1.5, 0.0));
    // Only the one real triangle (0.5 m²) was meshed.
    let area: f64 = scene
        .fine
        .patches
        .iter()
        .filter(|p| scene.surfaces[p.surface as usize].name.starts_with("mesh0:"))
        .map(|p| p.area)
        .sum();
    assert!((area - 0.5).abs() < 1e-9, "{area}");
    let nothing_else = "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n";
    let m = load_error(&text, &[("flat.obj", nothing_else)]);
    assert!(
        m.contains("flat.obj") && m.contains("no faces of nonzero area"),
        "{m}"
    );
}

/// A model of many planes (a curved surface cut into facets) is named in the plan's engine
/// decision with the number of planes its leaves lie in — each a planar tree under the model's
/// volume clusters, its facets linked one by one with those near — and a model of few planes
/// is not.
#[test]
fn the_plan_says_when_an_obj_lies_in_many_planes() {
    // A cone of `sides` facets on a floating base (z = 0 in the OBJ, lifted 0.2 m), apex up.
    let cone = |sides: usize| -> String {
        let mut obj = String::from("v 0 0 1\n");
        for k in 0..sides {
            let a = 2.0 * std::f64::consts::PI * k as f64 / sides as f64;
            obj += &format!("v {} {} 0\n", 0.5 * a.cos(), 0.5 * a.sin());
        }
        for k in 0..sides {
            obj += &format!("f 1 {} {}\n", 2 + k, 2 + (k + 1) % sides);
        }
        let base: Vec<String> = (0..sides).rev().map(|k| (2 + k).to_string()).collect();
        obj + &format!("f {}\n", base.join(" "))
    };
    let text = format!("{GOOD_ROOM}[[mesh]]\nfile = \"cone.obj\"\ntranslate = [2.0, 1.5, 0.2]\nup = \"z\"\n");
    let reason = |sides: usize| {
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), "cone.obj", &cone(sides));
        let scene = load(&write(dir.path(), "room.toml", &text)).unwrap();
        assert!(scene.notes.is_empty(), "{:?}", scene.notes);
        let plan = haiko::transport::plan::plan(&scene, haiko::transport::plan::PlanOptions::default());
        assert!(plan.hierarchical.on);
        plan.hierarchical.reason
    };
    let many = reason(1200);
    assert!(
        many.contains("the OBJ surfaces lie in 1201 planes (curved models)"),
        "{many}"
    );
    let few = reason(12);
    assert!(!few.contains("planes"), "{few}");
}

/// A closed solid wound inside out (every face clockwise seen from outside: no light could ever
/// reach one) is turned outwards, with a note: the room then lights exactly as with the solid
/// written the right way round.
#[test]
fn an_inside_out_closed_solid_lights_the_room_as_the_right_way_round() {
    // A 0.6 m cube standing on the floor, faces counter-clockwise seen from outside, and the
    // same with every face reversed.
    let corners =
        "v 0 0 0\nv 0.6 0 0\nv 0.6 0.6 0\nv 0 0.6 0\nv 0 0 0.6\nv 0.6 0 0.6\nv 0.6 0.6 0.6\nv 0 0.6 0.6\n";
    let outward = ["1 4 3 2", "5 6 7 8", "1 2 6 5", "2 3 7 6", "3 4 8 7", "4 1 5 8"];
    let faces = |reverse: bool| -> String {
        outward
            .iter()
            .map(|f| {
                let mut ids: Vec<&str> = f.split(' ').collect();
                if reverse {
                    ids.reverse();
                }
                format!("f {}\n", ids.join(" "))
            })
            .collect()
    };
    let text = format!("{GOOD_ROOM}[[mesh]]\nfile = \"cube.obj\"\ntranslate = [1.0, 0.8, 0.0]\nup = \"z\"\n");
    let load_cube = |faces: String| {
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), "cube.obj", &format!("o cube\n{corners}{faces}"));
        load(&write(dir.path(), "room.toml", &text)).unwrap()
    };
    let right = load_cube(faces(false));
    let turned = load_cube(faces(true));
    assert!(right.notes.is_empty(), "{:?}", right.notes);
    assert_eq!(
        turned.notes,
        [
            "mesh[0]: OBJ `cube.obj`: 1 closed solid whose faces all turned into the solid \
             instead of out of it turned round (object `cube`)"
        ]
    );
    // The cube's top, its side facing the light and the floor beside it: the same light.
    let receivers = [
        (DVec3::new(1.3, 1.1, 0.6), DVec3::Z),
        (DVec3::new(1.6, 1.1, 0.3), DVec3::X),
        (DVec3::new(1.8, 1.1, 0.0), DVec3::Z),
    ]
    .map(|(point, normal)| haiko::scene::Receiver { point, normal });
    let lux = |scene: haiko::scene::Scene| {
        let mut session =
            haiko::session::Session::new(scene, haiko::session::SessionOptions::default(), &mut |_| {})
                .unwrap();
        session
            .illuminance_at(&receivers, false, haiko::scene::DirectMode::Exact)
            .unwrap()
    };
    let (right, turned) = (lux(right), lux(turned));
    assert!(right.iter().all(|&e| e > 1.0), "{right:?}");
    // Reversed quads split along their other diagonal, so the two meshes differ in where their
    // triangles' edges lie: the indirect light differs at the solve's tolerance (3e-6 when
    // written), the direct light not at all.
    for (r, t) in right.iter().zip(&turned) {
        assert!((r - t).abs() <= 1e-4 * r, "{right:?} vs {turned:?}");
    }
}

#[test]
fn duplicate_light_name_is_rejected() {
    let text =
        format!("{GOOD_ROOM}[[light]]\nname = \"a\"\nposition = [1.0, 1.0, 2.0]\nlid = [[0, 5], [90, 0]]\n");
    let m = load_error(&text, &[]);
    assert!(
        m.contains("line 14") && m.contains("light[1].name") && m.contains("light[0]"),
        "{m}"
    );
}

#[test]
fn decreasing_gamma_is_rejected_naming_the_point() {
    let text = GOOD_ROOM.replace("[[0, 100], [90, 0]]", "[[0, 100], [50, 80], [40, 0]]");
    let m = load_error(&text, &[]);
    assert!(m.contains("light[0].lid") && m.contains("point 2"), "{m}");
}

#[test]
fn version_2_is_rejected() {
    let m = load_error(&GOOD_ROOM.replace("version = 1", "version = 2"), &[]);
    assert!(
        m.contains("line 1, column 11 (version)") && m.contains("version 2"),
        "{m}"
    );
}

#[test]
fn light_without_a_curve_is_rejected() {
    let m = load_error(&GOOD_ROOM.replace("lid = [[0, 100], [90, 0]]", ""), &[]);
    assert!(m.contains("light[0]") && m.contains("needs a curve"), "{m}");
}

#[test]
fn aim_and_aim_dir_together_or_a_zero_aim_dir_are_rejected() {
    let both = GOOD_ROOM.replace("lid = ", "aim = [1, 1, 0]\naim_dir = [0, 0, -1]\nlid = ");
    let m = load_error(&both, &[]);
    assert!(
        m.contains("line 13") && m.contains("light[0].aim_dir") && m.contains("not both"),
        "{m}"
    );
    let m = load_error(&GOOD_ROOM.replace("lid = ", "aim_dir = [0, 0, 0]\nlid = "), &[]);
    assert!(m.contains("light[0].aim_dir") && m.contains("zero"), "{m}");
    let m = load_error(&GOOD_ROOM.replace("lid = ", "aim = [2.0, 1.5, 2.4]\nlid = "), &[]);
    assert!(m.contains("light[0].aim") && m.contains("own position"), "{m}");
}

#[test]
fn settings_out_of_range_are_rejected() {
    let m = load_error(&format!("{GOOD_ROOM}[settings]\ntolerance = 0.6\n"), &[]);
    assert!(m.contains("settings.tolerance"), "{m}");
    let m = load_error(&format!("{GOOD_ROOM}[settings]\nsolver_patch_size = 0\n"), &[]);
    assert!(m.contains("settings.solver_patch_size"), "{m}");
    let m = load_error(&GOOD_ROOM.replace("lid = ", "order = 151\nlid = "), &[]);
    assert!(m.contains("light[0].order") && m.contains("150"), "{m}");
}

#[test]
fn too_fine_a_patch_size_is_refused_before_meshing() {
    // 1 mm patches: the floor alone would have 4001 · 3001 ≈ 12 million vertices.
    let m = load_error(&format!("{GOOD_ROOM}[settings]\npatch_size = 0.001\n"), &[]);
    assert!(
        m.contains("settings.patch_size") && m.contains("larger patch_size"),
        "{m}"
    );
}
