//! The command line as a user runs it: the real binary, exit codes, one-line errors, and the
//! numbers of `lid`, `probe`, `grid`, `plan` and `bake` against independent expectations.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use glam::DVec3;
use haiko::photometry::read_lid_file;
use haiko::relight::Relighter;
use haiko::scene::{DirectMode, load};
use haiko::transport::direct::{Receiver, polygon_flux};
use haiko::transport::gather::illuminance_at_receivers;

fn repo(relative: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(relative)
}

/// Runs `haiko ARGS` with a private bake cache.
fn haiko(cache: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_haiko"))
        .args(args)
        .env("HAIKO_CACHE_DIR", cache)
        .output()
        .expect("the binary runs")
}

/// `rooms/paper.toml` copied into `dir` with the SH basis engine forced (`indirect = "basis"`):
/// the engine the bake cache serves.
fn paper_with_basis(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(repo("rooms/paper.toml")).unwrap();
    assert!(text.contains("[settings]\n"));
    let path = dir.join("paper.toml");
    std::fs::write(
        &path,
        text.replace("[settings]\n", "[settings]\nindirect = \"basis\"\n"),
    )
    .unwrap();
    path
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Asserts a bad-input failure: exit code 2, one stderr line naming `file`, no panic trace.
fn assert_bad_input(o: &Output, file: &str) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(2), "stderr: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    assert!(err.contains(file), "names {file}: {err}");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn lid_json_reports_a_real_file() {
    let cache = tempfile::tempdir().unwrap();
    let file = repo("tests/data/ldt/sample_05.ldt");
    let o = haiko(
        cache.path(),
        &["lid", file.to_str().unwrap(), "--order", "8", "--json"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    let lid = read_lid_file(&file).unwrap();
    let flux = v["flux_lm"].as_f64().unwrap();
    assert!((flux - lid.curve.flux_lm()).abs() < 1e-9 * flux);
    assert!((v["peak_cd"].as_f64().unwrap() - lid.curve.peak_cd()).abs() < 1e-9);
    assert_eq!(
        v["asymmetry"].as_f64(),
        Some(0.0),
        "sample_05 is rotationally symmetric"
    );
    let weights = v["weights"].as_array().unwrap();
    assert_eq!(weights.len(), 9);
    // Φ = 4π w_0.
    assert!((4.0 * std::f64::consts::PI * weights[0].as_f64().unwrap() / flux - 1.0).abs() < 1e-12);
    let orders = v["orders"].as_array().unwrap();
    assert_eq!(orders.len(), 9);
    for (n, row) in orders.iter().enumerate() {
        assert_eq!(row["order"].as_u64(), Some(n as u64));
        for key in [
            "rel_l2_error",
            "max_abs_error_cd",
            "min_cd",
            "fit_exact_us",
            "fit_rectangle_us",
            "edit_us",
        ] {
            assert!(row[key].as_f64().is_some_and(f64::is_finite), "{key} in row {n}");
        }
    }
    assert!(v["order"].as_u64().is_some());
}

#[test]
fn lid_text_table_and_room_light_source() {
    let cache = tempfile::tempdir().unwrap();
    let source = format!("{}#accent", repo("rooms/paper.toml").display());
    let o = haiko(cache.path(), &["lid", &source, "--order", "5"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(text.contains("flux") && text.contains("order"), "{text}");
    assert_eq!(
        text.lines()
            .filter(|l| l.trim_start().chars().next().is_some_and(|c| c.is_ascii_digit()))
            .count(),
        6
    );
    let missing = format!("{}#nope", repo("rooms/paper.toml").display());
    let o = haiko(cache.path(), &["lid", &missing]);
    assert_bad_input(&o, "paper.toml");
    assert!(stderr(&o).contains("centre"), "lists the lights: {}", stderr(&o));
}

#[test]
fn lid_rejects_malformed_files_with_exit_code_2() {
    let cache = tempfile::tempdir().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let good = std::fs::read_to_string(repo("tests/data/ies/isotropic.ies")).unwrap();
    let cases: Vec<(&str, Vec<u8>)> = vec![
        ("empty.ies", Vec::new()),
        (
            "garbage.ldt",
            (0..2000u32).map(|i| (i * 7919 % 251) as u8).collect(),
        ),
        ("truncated.ies", good.as_bytes()[..good.len() * 2 / 3].to_vec()),
        (
            "nan.ies",
            good.replace("100 100 100 100 100", "100 NaN 100 100 100")
                .into_bytes(),
        ),
        (
            "tiltfile.ies",
            good.replace("TILT=NONE", "TILT=lamp.tlt").into_bytes(),
        ),
        ("negative.ies", {
            let mut lines: Vec<&str> = good.lines().collect();
            let last = lines.len() - 1;
            let neg = format!("-{}", lines[last].trim());
            lines[last] = &neg;
            lines.join("\n").into_bytes()
        }),
        ("unknown.txt", good.clone().into_bytes()),
    ];
    for (name, bytes) in cases {
        assert!(
            name == "empty.ies" || bytes != good.as_bytes() || name == "unknown.txt",
            "{name} must differ"
        );
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        let o = haiko(cache.path(), &["lid", path.to_str().unwrap()]);
        assert_bad_input(&o, name);
    }
    let o = haiko(
        cache.path(),
        &["lid", dir.path().join("missing.ies").to_str().unwrap()],
    );
    assert_bad_input(&o, "missing.ies");
}

/// A black 4 × 4 × 3 m room (no reflections) with one isotropic 1000 cd source at (2, 2, 2.5).
const BLACK_ROOM: &str = r#"version = 1
[room]
size = [4.0, 4.0, 3.0]
[room.reflectance]
floor = 0.0
walls = 0.0
ceiling = 0.0
[[light]]
name = "iso"
position = [2.0, 2.0, 2.5]
lid = [[0, 1000], [180, 1000]]
[settings]
patch_size = 0.25
solver_patch_size = 0.5
"#;

#[test]
fn grid_statistics_match_a_hand_computation() {
    let cache = tempfile::tempdir().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let room = dir.path().join("black.toml");
    std::fs::write(&room, BLACK_ROOM).unwrap();
    // Work plane 0.5 m: h = 2 m below the source; points at 0.5, 1.5, 2.5, 3.5 on both axes.
    let coords = [0.5, 1.5, 2.5, 3.5];
    let lux: Vec<f64> = coords
        .iter()
        .flat_map(|&x| coords.iter().map(move |&y| (x, y)))
        .map(|(x, y): (f64, f64)| {
            let d2 = (x - 2.0).powi(2) + (y - 2.0).powi(2);
            1000.0 * 2.0 / (4.0 + d2).powf(1.5)
        })
        .collect();
    let avg = lux.iter().sum::<f64>() / 16.0;
    let min = lux.iter().copied().fold(f64::INFINITY, f64::min);
    let max = lux.iter().copied().fold(0.0, f64::max);
    for extra in [&["--direct-only"][..], &[][..]] {
        let mut args = vec![
            "grid",
            room.to_str().unwrap(),
            "--height",
            "0.5",
            "--spacing",
            "1",
            "--margin",
            "0.5",
            "--json",
        ];
        args.extend_from_slice(extra);
        let o = haiko(cache.path(), &args);
        assert!(o.status.success(), "{}", stderr(&o));
        let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
        assert_eq!(v["points"].as_u64(), Some(16));
        for (key, want) in [("e_avg", avg), ("e_min", min), ("e_max", max), ("u0", min / avg)] {
            let got = v[key].as_f64().unwrap();
            assert!(
                (got - want).abs() < 1e-9 * want,
                "{key} {extra:?}: {got} vs {want}"
            );
        }
        assert_eq!(v["grid"].as_array().unwrap().len(), 16);
    }
}

#[test]
fn probe_agrees_with_vertex_values_and_keeps_the_row_order() {
    let scene = load(&repo("rooms/office.toml")).unwrap();
    let relit = Relighter::new(&scene);
    let ids: Vec<usize> = (0..scene.fine.n_vertices()).step_by(97).collect();
    let receivers: Vec<Receiver> = ids
        .iter()
        .map(|&v| Receiver {
            point: scene.fine.positions[v],
            normal: scene.fine.normals[v],
        })
        .collect();
    let probed = illuminance_at_receivers(&scene, None, DirectMode::Exact, &receivers);
    let mut lit = 0;
    for (&v, e) in ids.iter().zip(&probed) {
        // Grey lights: the luminance weight of white is 1, so lux = any channel.
        let vertex = relit.total()[v][1];
        assert!(
            (e - vertex).abs() <= 1e-9 * vertex.max(1.0),
            "vertex {v}: probe {e} vs vertex {vertex}"
        );
        lit += usize::from(vertex > 0.0);
    }
    assert!(lit > ids.len() / 2);
}

#[test]
fn probe_csv_through_the_binary_and_its_bad_inputs() {
    let cache = tempfile::tempdir().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let room = dir.path().join("black.toml");
    std::fs::write(&room, BLACK_ROOM).unwrap();
    let points = dir.path().join("pts.csv");
    std::fs::write(
        &points,
        "x,y,z,nx,ny,nz\n2,2,0.5,0,0,1\n3,2,0.5,0,0,2\n2,2,2.9,0,0,-1\n",
    )
    .unwrap();
    let o = haiko(
        cache.path(),
        &[
            "probe",
            room.to_str().unwrap(),
            "--points",
            points.to_str().unwrap(),
            "--direct-only",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    let rows: Vec<Vec<f64>> = out
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|f| f.parse().unwrap()).collect())
        .collect();
    assert_eq!(out.lines().next(), Some("x,y,z,nx,ny,nz,lux"));
    assert_eq!(rows.len(), 3);
    let want = [1000.0 / 4.0, 1000.0 * 2.0 / 5f64.powf(1.5), 1000.0 / 0.16];
    for (row, w) in rows.iter().zip(want) {
        assert!((row[6] - w).abs() < 1e-5 * w, "{row:?} vs {w}");
    }
    assert!((rows[1][5] - 1.0).abs() < 1e-12, "normals are normalised");
    for (name, text, place) in [
        ("empty.csv", "", ""),
        ("header-only.csv", "x,y,z,nx,ny,nz\n", ""),
        ("five.csv", "x,y,z,nx,ny,nz\n1,1,1,0,0\n", "line 2"),
        ("word.csv", "x,y,z,nx,ny,nz\n1,1,one,0,0,1\n", "line 2"),
        ("header.csv", "x,y,z\n1,1,1\n", "line 1"),
        ("zero-normal.csv", "x,y,z,nx,ny,nz\n1,1,1,0,0,0\n", "line 2"),
    ] {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        let o = haiko(
            cache.path(),
            &[
                "probe",
                room.to_str().unwrap(),
                "--points",
                path.to_str().unwrap(),
                "--direct-only",
            ],
        );
        assert_bad_input(&o, name);
        assert!(stderr(&o).contains(place), "{name}: {}", stderr(&o));
    }
}

#[test]
fn a_box_casts_a_shadow_from_the_light_it_blocks() {
    let dir = tempfile::tempdir().unwrap();
    let room = dir.path().join("shadow.toml");
    std::fs::write(
        &room,
        r#"version = 1
[room]
size = [4.0, 4.0, 3.0]
[room.reflectance]
floor = 0.0
walls = 0.0
ceiling = 0.0
[[box]]
min = [1.5, 1.5, 0.0]
max = [2.5, 2.5, 1.0]
reflectance = 0.0
[[light]]
name = "over"
position = [2.0, 2.0, 2.5]
lid = [[0, 1000], [180, 1000]]
[[light]]
name = "side"
position = [3.8, 0.2, 2.9]
lid = [[0, 500], [180, 500]]
"#,
    )
    .unwrap();
    let scene = load(&room).unwrap();
    // The shadow edge of the overhead light on the floor: the box top's edge at x = 2.5 seen from
    // (2, 2, 2.5) lands at x = 2 + 0.5 · 2.5/1.5 = 2.8333 (along y = 2).
    let at = |x: f64| Receiver {
        point: DVec3::new(x, 2.0, 0.0),
        normal: DVec3::Z,
    };
    let inside = illuminance_at_receivers(&scene, None, DirectMode::Exact, &[at(2.80)]);
    let outside = illuminance_at_receivers(&scene, None, DirectMode::Exact, &[at(2.87)]);
    let side_only = |p: DVec3| {
        let d = DVec3::new(3.8, 0.2, 2.9) - p;
        500.0 * d.z / d.length().powi(3)
    };
    assert!(
        (inside[0] - side_only(at(2.80).point)).abs() < 1e-9,
        "in the shadow only the side light remains"
    );
    let over = 1000.0 * 2.5 / (2.5f64 * 2.5 + 0.87 * 0.87).powf(1.5);
    assert!(
        (outside[0] - side_only(at(2.87).point) - over).abs() < 1e-9,
        "outside the shadow both lights"
    );
}

#[test]
fn area_integrated_direct_light_equals_the_flux_in_a_closed_room() {
    // A light 5 cm from a wall: patch-averaged (solid-angle) direct light keeps the flux exact
    // where a centre sample would not.
    let dir = tempfile::tempdir().unwrap();
    let room = dir.path().join("closed.toml");
    std::fs::write(
        &room,
        BLACK_ROOM
            .replace(
                "position = [2.0, 2.0, 2.5]",
                "position = [0.05, 1.3, 1.7]\naim_dir = [1, 0.2, -0.4]",
            )
            .replace(
                "lid = [[0, 1000], [180, 1000]]",
                "lid = [[0, 1200], [25, 1100], [50, 400], [80, 100], [120, 0]]",
            ),
    )
    .unwrap();
    let scene = load(&room).unwrap();
    let light = &scene.lights[0];
    let total: f64 = scene
        .fine
        .patches
        .iter()
        .map(|p| {
            let poly: Vec<DVec3> = p
                .vertex_ids()
                .iter()
                .map(|&v| scene.fine.positions[v as usize])
                .collect();
            polygon_flux(light.position, light.radius, &poly, p.normal, |d| {
                light.curve.eval_rad(light.aim.dot(d).clamp(-1.0, 1.0).acos())
            })
        })
        .sum();
    let phi = light.curve.flux_lm();
    assert!((total / phi - 1.0).abs() < 0.005, "Σ flux {total} vs Φ {phi}");
}

/// What loading repaired reaches the user of every command: `haiko plan` writes it on standard
/// error (its standard output stays the plan) and lists it in `--json`.
#[test]
fn plan_writes_what_loading_repaired() {
    let cache = tempfile::tempdir().unwrap();
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("flat.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\n",
    )
    .unwrap();
    let room = dir.path().join("room.toml");
    std::fs::write(
        &room,
        "version = 1\n[room]\nsize = [4.0, 3.0, 2.5]\n[room.reflectance]\nfloor = 0.2\nwalls = 0.5\n\
         ceiling = 0.7\n[[mesh]]\nfile = \"flat.obj\"\ntranslate = [0.5, 0.5, 0.5]\nup = \"z\"\n\
         [[light]]\nname = \"a\"\nposition = [2.0, 1.5, 2.4]\nlid = [[0, 100], [90, 0]]\n",
    )
    .unwrap();
    let note = "mesh[0]: OBJ `flat.obj`: 1 degenerate face (area below 1e-12 m² after placement) \
                left out: face 2 (line 6)";
    let o = haiko(cache.path(), &["plan", room.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stderr(&o), format!("haiko: note: {note}\n"));
    assert!(!stdout(&o).contains("note"), "{}", stdout(&o));
    let o = haiko(cache.path(), &["plan", room.to_str().unwrap(), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(v["notes"], serde_json::json!([note]));
}

#[test]
fn plan_and_bake_commands_report_their_decisions() {
    let cache = tempfile::tempdir().unwrap();
    let rooms = tempfile::tempdir().unwrap();
    let o = haiko(
        cache.path(),
        &["plan", repo("rooms/paper.toml").to_str().unwrap(), "--json"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(v["visibility"]["on"], false);
    assert_eq!(v["interreflection"]["on"], true);
    assert_eq!(v["channels"], 1);
    assert_eq!(v["lights"].as_array().unwrap().len(), 2);
    assert_eq!(v["hierarchical"]["on"], true);
    // Both lamps hang 0.1 m under the ceiling (one sentence each); the accent light, 0.3 m from
    // two walls, also grades the room's edges next to it (one sentence); their horizon, 0.1 m
    // under the ceiling, darkens the walls just under it, so the walls' top edges are graded
    // where they light the wall (one sentence): 15 pieces where the light bends, and since the
    // twenty-second round 4 more where it rises steeply from the dark top beside the ceiling
    // the lamps leave dark.
    let notes: Vec<&str> = v["refinement"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| n.as_str().unwrap())
        .collect();
    assert_eq!(notes.len(), 4, "{notes:?}");
    for name in ["centre", "accent"] {
        let near = format!("refined near light {name}: 0.10 m from the ceiling");
        assert!(notes.iter().any(|n| n.starts_with(&near)), "{notes:?}");
    }
    assert!(
        notes
            .iter()
            .any(|n| n.starts_with("graded along 3 contact edges")),
        "{notes:?}"
    );
    assert!(
        notes
            .iter()
            .any(|n| n.starts_with("graded along 19 pieces of the room's edges where the light next to them")),
        "{notes:?}"
    );
    // The text says the same, and that no SH basis is baked for the hierarchical engine.
    let o = haiko(
        cache.path(),
        &["plan", repo("rooms/paper.toml").to_str().unwrap()],
    );
    let text = stdout(&o);
    assert!(text.contains("hierarchical     on   1811 leaves"), "{text}");
    assert!(
        text.contains("1811 solver leaves; no SH basis is baked"),
        "{text}"
    );
    assert!(!text.contains("basis columns in all"), "{text}");
    let paper = paper_with_basis(rooms.path());
    for run in 0..2 {
        let o = haiko(cache.path(), &["bake", paper.to_str().unwrap()]);
        assert!(o.status.success(), "{}", stderr(&o));
        let out = stdout(&o);
        assert!(out.contains("certified") || run == 1, "{out}");
        assert!(out.contains("from the cache") == (run == 1), "run {run}: {out}");
        assert!(out.contains("memory:") && out.contains("time:"), "{out}");
    }
}

/// `haiko cache` lists what a bake left (one entry per light of the paper room, with sizes) and
/// `haiko cache clear` removes it.
#[test]
fn cache_lists_and_clears_the_bake_entries() {
    let cache = tempfile::tempdir().unwrap();
    let rooms = tempfile::tempdir().unwrap();
    let paper = paper_with_basis(rooms.path());
    let o = haiko(cache.path(), &["cache"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains(": 0 entries"), "{}", stdout(&o));
    assert!(
        haiko(cache.path(), &["bake", paper.to_str().unwrap()])
            .status
            .success()
    );
    let o = haiko(cache.path(), &["cache", "list"]);
    let listed = stdout(&o);
    assert!(listed.contains(": 2 entries"), "{listed}");
    assert_eq!(
        listed.lines().filter(|l| l.contains(".bake")).count(),
        2,
        "{listed}"
    );
    let o = haiko(cache.path(), &["cache", "clear"]);
    assert!(stdout(&o).contains("removed 2 entries"), "{}", stdout(&o));
    let left = std::fs::read_dir(cache.path()).unwrap().count();
    assert_eq!(left, 0, "nothing left in the cache directory");
}

#[test]
fn bad_room_files_fail_before_anything_else() {
    let cache = tempfile::tempdir().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let room = dir.path().join("bad.toml");
    std::fs::write(&room, BLACK_ROOM.replace("walls = 0.0", "walls = 0.99")).unwrap();
    for cmd in [
        &["plan"][..],
        &["bake"][..],
        &["grid", "--height", "1", "--spacing", "1"][..],
    ] {
        let mut args = vec![cmd[0], room.to_str().unwrap()];
        args.extend_from_slice(&cmd[1..]);
        let o = haiko(cache.path(), &args);
        assert_bad_input(&o, "bad.toml");
        assert!(stderr(&o).contains("line"), "{}", stderr(&o));
    }
}

/// `haiko bake --json` on the paper room (the hierarchical engine): leaf, node and link counts
/// above zero, more leaves than coarse patches (the lamps 0.1 m under the ceiling refine it),
/// balancing that met its rows and columns, memory parts that sum to the total, stage times and
/// the four per-edit costs measured (finite, positive); a second bake reads the operator from
/// the cache with the same counts. A room whose light hangs far from every surface, with nothing on the floor, gets no
/// refinement: `haiko plan` prints no refinement line and its JSON lists none.
#[test]
fn bake_json_reports_the_engine_and_a_plain_room_needs_no_refinement() {
    let cache = tempfile::tempdir().unwrap();
    let o = haiko(
        cache.path(),
        &["bake", repo("rooms/paper.toml").to_str().unwrap(), "--json"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(v["engine"], "hierarchical");
    let count = |k: &str| v[k].as_u64().unwrap_or_else(|| panic!("{k}: {v}"));
    assert!(
        count("leaves") > count("coarse_patches") && count("coarse_patches") > 0,
        "{v}"
    );
    assert!(count("nodes") >= count("leaves") && count("links") > 0, "{v}");
    // The paper room is closed: balancing meets rows and columns, to 1e-7 (hierarchy::BALANCE_DEFECT).
    let sweeps = v["balancing"]["sweeps"].as_u64().unwrap();
    let defect = v["balancing"]["defect"].as_f64().unwrap();
    assert!((1..200).contains(&sweeps) && (0.0..1e-7).contains(&defect), "{v}");
    let memory = v["memory_bytes"].as_object().unwrap();
    let parts: u64 = ["operator", "node_geometry", "lights", "interpolation"]
        .iter()
        .map(|k| memory[*k].as_u64().unwrap())
        .sum();
    assert!(memory.values().all(|b| b.as_u64().unwrap() > 0), "{v}");
    assert_eq!(parts, memory["total"].as_u64().unwrap());
    for stage in ["plan", "refine", "links", "balance", "direct_caches", "solve"] {
        let t = v["time_s"][stage].as_f64().unwrap();
        assert!(t.is_finite() && t >= 0.0, "{stage}: {t}");
    }
    for edit in [
        "curve",
        "point",
        "point_again",
        "aim",
        "dimmer",
        "move",
        "aim_estimate",
        "estimate_build",
        "aim_prepare",
        "aim_prepared",
    ] {
        let t = v["edit_s"][edit].as_f64().unwrap();
        assert!(t.is_finite() && t > 0.0, "{edit}: {t}");
    }
    // The editor's estimate of the re-aim is closer to its solve than the values before it.
    let (estimated, unestimated) = (
        v["aim_estimate_error"]["estimated"].as_f64().unwrap(),
        v["aim_estimate_error"]["unestimated"].as_f64().unwrap(),
    );
    assert!(estimated < 0.5 * unestimated, "{estimated} vs {unestimated}");
    // Against each vertex's total illuminance too, the largest and the median difference.
    let of_total = |key: &str| v["aim_estimate_error"][key].as_f64().unwrap();
    let (worst, median, before) = (
        of_total("estimated_of_total"),
        of_total("estimated_of_total_median"),
        of_total("unestimated_of_total"),
    );
    assert!(
        0.0 < median && median <= worst && worst < before,
        "{median} {worst} {before}"
    );
    // The operator was built and cached; the second bake reads it, with the same counts.
    assert_eq!(v["operator"], "built and cached", "{v}");
    let o = haiko(
        cache.path(),
        &["bake", repo("rooms/paper.toml").to_str().unwrap(), "--json"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let again: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(again["operator"], "from the cache", "{again}");
    for k in ["leaves", "nodes", "links", "rays", "balancing"] {
        assert_eq!(again[k], v[k], "{k}");
    }
    assert_eq!(again["time_s"]["balance"], 0.0);
    let dir = tempfile::tempdir().unwrap();
    let room = dir.path().join("plain.toml");
    std::fs::write(
        &room,
        "version = 1\n[room]\nsize = [4.0, 4.0, 3.0]\n[room.reflectance]\nfloor = 0.2\nwalls = 0.5\n\
         ceiling = 0.7\n[[light]]\nname = \"l\"\nposition = [2.0, 2.0, 1.5]\nlid = [[0, 1000], [180, 1000]]\n",
    )
    .unwrap();
    let o = haiko(cache.path(), &["plan", room.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(
        text.contains("hierarchical     on ") && !text.contains("refinement"),
        "{text}"
    );
    let o = haiko(cache.path(), &["plan", room.to_str().unwrap(), "--json"]);
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(v["refinement"].as_array().unwrap().len(), 0, "{v}");
    assert_eq!(v["leaves"], v["coarse_patches"]);
}
