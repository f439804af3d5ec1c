//! Bad input through the real binary (docs/DECISIONS.md, "Bad input"): every class of the second
//! bad-input round gets exit code 2 and a one-line message naming the file and the place, never a
//! panic, a hang, a NaN or a quote of a file that is not what it claims to be.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use glam::DVec3;
use haiko::scene::points::{MAX_POINTS, parse_points};

/// What a run of the binary produced.
struct Run {
    code: Option<i32>,
    stdout: String,
    stderr: String,
}

/// Runs `haiko ARGS` in `dir` with a private bake cache; fails the test if it takes more than
/// 60 s (a hang on a FIFO or a device).
fn haiko(dir: &Path, args: &[&str]) -> Run {
    let mut command = Command::new(env!("CARGO_BIN_EXE_haiko"));
    command.args(args);
    run_in(dir, command, args)
}

/// Runs `haiko ARGS` as [`haiko`] does under `ulimit LIMIT` (`-f 1`: files of at most one
/// 512-byte block; `-v 4194304`: 4 GiB of address space), with SIGXFSZ ignored, so a write past
/// a file limit fails with EFBIG as on a full disk (without root or a small file system).
fn haiko_limited(dir: &Path, limit: &str, args: &[&str]) -> Run {
    let mut command = Command::new("sh");
    command
        .arg("-c")
        .arg(format!("trap '' XFSZ; ulimit {limit}; exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_haiko"))
        .args(args);
    run_in(dir, command, args)
}

fn run_in(dir: &Path, mut command: Command, args: &[&str]) -> Run {
    let out = dir.join(".stdout");
    let err = dir.join(".stderr");
    let mut child = command
        .current_dir(dir)
        .env("HAIKO_CACHE_DIR", dir.join(".cache"))
        .stdin(Stdio::null())
        .stdout(fs::File::create(&out).unwrap())
        .stderr(fs::File::create(&err).unwrap())
        .spawn()
        .expect("the binary runs");
    let deadline = Instant::now() + Duration::from_secs(60);
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if Instant::now() > deadline {
            child.kill().ok();
            child.wait().ok();
            panic!("haiko {args:?} hung");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    Run {
        code: status.code(),
        stdout: String::from_utf8_lossy(&fs::read(&out).unwrap()).into_owned(),
        stderr: String::from_utf8_lossy(&fs::read(&err).unwrap()).into_owned(),
    }
}

/// Asserts exit code 2 with one stderr line that names `file` and contains every one of `words`.
fn assert_bad_input(run: &Run, file: &str, words: &[&str]) {
    let err = &run.stderr;
    assert_eq!(run.code, Some(2), "stderr: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    assert!(err.contains(file), "names {file}: {err}");
    for w in words {
        assert!(err.contains(w), "{w:?} in: {err}");
    }
    assert!(!err.contains("panicked") && !err.contains('\u{1b}'), "{err}");
}

/// A black 4 × 4 × 3 m room with one isotropic 1000 cd light at (2, 2, 2.5).
const ROOM: &str = r#"version = 1
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
patch_size = 0.5
solver_patch_size = 1.0
"#;

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    fs::write(&path, text).unwrap();
    path
}

/// `ROOM` with `from` replaced by `to` (which must occur).
fn room_with(from: &str, to: &str) -> String {
    assert!(ROOM.contains(from), "{from}");
    ROOM.replacen(from, to, 1)
}

#[test]
fn arrays_of_the_wrong_length_name_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        (
            "size = [4.0, 4.0, 3.0]",
            "size = [4.0, 4.0, 3.0, 1.0]",
            "room.size",
            "line 3",
        ),
        (
            "position = [2.0, 2.0, 2.5]",
            "position = [2.0, 2.0, 2.5, 9]",
            "light[0].position",
            "line 10",
        ),
        (
            "position = [2.0, 2.0, 2.5]",
            "position = [2.0, 2.0]",
            "light[0].position",
            "line 10",
        ),
        (
            "lid = [[0, 1000], [180, 1000]]",
            "lid = [[0, 1000], [180, 1000, 5]]",
            "light[0].lid[1]",
            "line 11",
        ),
        (
            "lid = [[0, 1000], [180, 1000]]",
            "lid = [[0, 1000], [180]]",
            "light[0].lid[1]",
            "line 11",
        ),
        (
            "floor = 0.0",
            "floor = [0.1, 0.2]",
            "room.reflectance.floor",
            "line 5",
        ),
        (
            "lid = [[0, 1000], [180, 1000]]",
            "lid = [[0, 1000], [180, 1000]]\naim_dir = [0, 0, -1, 0]",
            "light[0].aim_dir",
            "line 12",
        ),
        (
            "lid = [[0, 1000], [180, 1000]]",
            "lid = [[0, 1000], [180, 1000]]\naim = [1, 1]",
            "light[0].aim",
            "line 12",
        ),
        (
            "lid = [[0, 1000], [180, 1000]]",
            "lid = [[0, 1000], [180, 1000]]\ncolor = [1, 1, 1, 1]",
            "light[0].color",
            "line 12",
        ),
        (
            "[[light]]",
            "[[box]]\nmin = [1, 1]\nmax = [2, 2, 1]\nreflectance = 0.2\n[[light]]",
            "box[0].min",
            "line 9",
        ),
        (
            "[settings]",
            "[camera]\neye = [0.5, 0.5, 1.6, 0.0]\ntarget = [2, 2, 1]\n[settings]",
            "camera.eye",
            "line 13",
        ),
        (
            "[settings]",
            "[[mesh]]\nfile = \"m.obj\"\ntranslate = [0, 0, 0, 0]\n[settings]",
            "mesh[0].translate",
            "line 14",
        ),
        (
            "solver_patch_size = 1.0",
            "solver_patch_size = 1.0\n[[surface]]\nmin = [1, 1, 0]\nmax = [2, 2]",
            "surface[0].min",
            "line 16",
        ),
        (
            "solver_patch_size = 1.0",
            "solver_patch_size = 1.0\n[[observer]]\neye = [1, 1, 1.2, 0]\nview_dir = [0, 1, 0]",
            "observer[0].eye",
            "line 16",
        ),
    ];
    for (from, to, field, line) in cases {
        write(dir.path(), "bad.toml", &room_with(from, to));
        let run = haiko(dir.path(), &["plan", "bad.toml"]);
        assert_bad_input(&run, "bad.toml", &[field, line]);
    }
}

#[test]
fn numbers_out_of_range_name_the_field_and_the_limit() {
    let dir = tempfile::tempdir().unwrap();
    let light = "lid = [[0, 1000], [180, 1000]]";
    let cases = [
        (
            "size = [4.0, 4.0, 3.0]",
            "size = [1e-6, 1e-6, 1e-6]".to_string(),
            "room.size",
            "0.1 m",
        ),
        (
            "size = [4.0, 4.0, 3.0]",
            "size = [4.0, 1e5, 3.0]".to_string(),
            "room.size",
            "1000 m",
        ),
        (
            light,
            "lid = [[0, 1e160], [180, 1000]]".to_string(),
            "light[0].lid",
            "1e9",
        ),
        (
            light,
            format!("{light}\ndimmer = 1e308"),
            "light[0].dimmer",
            "≤ 100",
        ),
        (
            light,
            format!("{light}\ncolor = [1e308, 1, 1]"),
            "light[0].color",
            "0 to 100",
        ),
        (
            light,
            format!("{light}\nradius = 1e308"),
            "light[0].radius",
            "≤ 10",
        ),
        (
            light,
            format!("{light}\naim = [1e308, 0, 0]"),
            "light[0].aim",
            "±1e6",
        ),
        (light, format!("{light}\norder = 151"), "light[0].order", "150"),
        (
            "patch_size = 0.5",
            "patch_size = 1e-9".to_string(),
            "settings.patch_size",
            "≥ 0.001",
        ),
        (
            "patch_size = 0.5",
            "patch_size = 1e300".to_string(),
            "settings.patch_size",
            "≤ 1000",
        ),
        (
            "patch_size = 0.5",
            "patch_size = 0.5\ntolerance = 1e-300".to_string(),
            "settings.tolerance",
            "1e-9",
        ),
        (
            "[settings]",
            "[camera]\neye = [0.5, 0.5, 1.6]\ntarget = [2, 2, 1]\nfov_deg = 1e-300\n[settings]".to_string(),
            "camera.fov_deg",
            "≥ 1",
        ),
        (
            light,
            format!("{light}\nluminous_size = 1e308"),
            "light[0].luminous_size",
            "100 m",
        ),
        (
            "solver_patch_size = 1.0",
            "solver_patch_size = 1.0\n[[surface]]\nspacing = 1e-9".to_string(),
            "surface[0].spacing",
            "≥ 0.001",
        ),
        (
            "solver_patch_size = 1.0",
            "solver_patch_size = 1.0\n[[surface]]\ntarget_lux = 1e308".to_string(),
            "surface[0].target_lux",
            "≤ 1000000",
        ),
    ];
    for (from, to, field, limit) in cases {
        write(dir.path(), "bad.toml", &room_with(from, &to));
        let run = haiko(dir.path(), &["plan", "bad.toml"]);
        assert_bad_input(&run, "bad.toml", &[field, limit, "line "]);
    }
}

/// `haiko probe ROOM --points P --direct-only` for one receiver; returns the lux.
fn probe_one(dir: &Path, room: &str, point: [f64; 3], normal: [f64; 3]) -> f64 {
    write(dir, "room.toml", room);
    let [x, y, z] = point;
    let [a, b, c] = normal;
    write(
        dir,
        "p.csv",
        &format!("x,y,z,nx,ny,nz\n{x},{y},{z},{a},{b},{c}\n"),
    );
    let run = haiko(dir, &["probe", "room.toml", "--points", "p.csv", "--direct-only"]);
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    let row = run.stdout.lines().nth(1).expect("a row");
    row.rsplit(',').next().unwrap().parse().unwrap()
}

#[test]
fn extreme_values_that_are_allowed_stay_finite() {
    let dir = tempfile::tempdir().unwrap();
    // The largest curve, dimmer and colour at once: 1e9 cd × 100 × 100 at 2.5 m straight above.
    let room = room_with(
        "lid = [[0, 1000], [180, 1000]]",
        "lid = [[0, 1e9], [180, 1e9]]\ndimmer = 100\ncolor = [100, 100, 100]",
    );
    let lux = probe_one(dir.path(), &room, [2.0, 2.0, 0.0], [0.0, 0.0, 1.0]);
    let expected = 1e9 * 100.0 * 100.0 / 2.5f64.powi(2);
    assert!((lux / expected - 1.0).abs() < 1e-9, "{lux} vs {expected}");
    // A huge aim direction is a direction: the same as [1, 1, 0].
    let sideways = room_with(
        "lid = [[0, 1000], [180, 1000]]",
        "lid = [[0, 1000], [90, 1000], [90, 0]]\naim_dir = [1e308, 1e308, 0]",
    );
    let wall = probe_one(dir.path(), &sideways, [4.0, 4.0, 2.5], [-1.0, -1.0, 0.0]);
    assert!(
        (wall - 1000.0 / 8.0).abs() < 1e-6,
        "{wall}: 1000 cd on axis at 2√2 m"
    );
    let unit = sideways.replace("[1e308, 1e308, 0]", "[1, 1, 0]");
    assert_eq!(
        probe_one(dir.path(), &unit, [4.0, 4.0, 2.5], [-1.0, -1.0, 0.0]),
        wall
    );
    let run = haiko(dir.path(), &["plan", "room.toml", "--json"]);
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    assert!(
        !run.stdout.contains("NaN") && !run.stdout.contains("inf"),
        "{}",
        run.stdout
    );
}

#[test]
fn a_small_room_is_lit_and_a_tiny_one_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    // 10 cm cube, 1 cd isotropic 9 cm above the floor's centre: E = 1 / 0.09² lx.
    let room = ROOM
        .replace("size = [4.0, 4.0, 3.0]", "size = [0.1, 0.1, 0.1]")
        .replace("position = [2.0, 2.0, 2.5]", "position = [0.05, 0.05, 0.09]")
        .replace("lid = [[0, 1000], [180, 1000]]", "lid = [[0, 1], [180, 1]]")
        .replace(
            "patch_size = 0.5\nsolver_patch_size = 1.0",
            "patch_size = 0.01\nsolver_patch_size = 0.02",
        );
    let lux = probe_one(dir.path(), &room, [0.05, 0.05, 0.0], [0.0, 0.0, 1.0]);
    assert!((lux - 1.0 / 0.0081).abs() < 1e-6, "{lux}");
    let micro = room.replace("size = [0.1, 0.1, 0.1]", "size = [1e-6, 1e-6, 1e-6]");
    write(dir.path(), "micro.toml", &micro);
    let run = haiko(
        dir.path(),
        &["grid", "micro.toml", "--height", "0", "--spacing", "1e-7"],
    );
    assert_bad_input(&run, "micro.toml", &["room.size", "from 0.1 m to 1000 m"]);
}

#[test]
fn devices_fifos_and_directories_are_refused_without_reading() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(d, "room.toml", ROOM);
    let fifo = d.join("fifo.toml");
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    std::os::unix::fs::symlink("/dev/zero", d.join("zero.ies")).unwrap();
    std::os::unix::fs::symlink("/dev/urandom", d.join("random.ldt")).unwrap();
    std::os::unix::fs::symlink("/dev/zero", d.join("zero.csv")).unwrap();
    fs::create_dir(d.join("dir.toml")).unwrap();
    let run = haiko(d, &["plan", "fifo.toml"]);
    assert_bad_input(&run, "fifo.toml", &["FIFO (named pipe), not a regular file"]);
    let run = haiko(d, &["plan", "dir.toml"]);
    assert_bad_input(&run, "dir.toml", &["directory"]);
    let run = haiko(d, &["plan", "/dev/zero"]);
    assert_bad_input(&run, "/dev/zero", &["character device"]);
    let run = haiko(d, &["lid", "zero.ies"]);
    assert_bad_input(&run, "zero.ies", &["character device"]);
    let run = haiko(d, &["lid", "random.ldt"]);
    assert_bad_input(&run, "random.ldt", &["character device"]);
    let run = haiko(
        d,
        &["probe", "room.toml", "--points", "zero.csv", "--direct-only"],
    );
    assert_bad_input(&run, "zero.csv", &["character device"]);
    let fifo_points = d.join("fifo.csv");
    assert!(
        Command::new("mkfifo")
            .arg(&fifo_points)
            .status()
            .unwrap()
            .success()
    );
    let run = haiko(
        d,
        &["probe", "room.toml", "--points", "fifo.csv", "--direct-only"],
    );
    assert_bad_input(&run, "fifo.csv", &["FIFO"]);
    // Through a room: the light's file is a device.
    write(
        d,
        "lit.toml",
        &room_with("lid = [[0, 1000], [180, 1000]]", "lid_file = \"zero.ies\""),
    );
    let run = haiko(d, &["plan", "lit.toml"]);
    assert_bad_input(
        &run,
        "lit.toml",
        &["light[0].lid_file", "`zero.ies`", "character device"],
    );
}

#[test]
fn oversized_files_are_refused_by_kind() {
    let dir = tempfile::tempdir().unwrap();
    let big = dir.path().join("big.toml");
    let file = fs::File::create(&big).unwrap();
    file.set_len(16 * 1024 * 1024 + 1).unwrap();
    let run = haiko(dir.path(), &["plan", "big.toml"]);
    assert_bad_input(
        &run,
        "big.toml",
        &["is 16777217 bytes; a room file may be at most 16 MiB"],
    );
}

#[test]
fn files_that_are_not_what_their_name_says_are_never_quoted() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let secret = "root:x:0:0:SECRET-PASSWORD-LINE:/root:/bin/bash\n";
    let passwd = write(d, "passwd", &secret.repeat(40));
    for name in ["p.ies", "p.ldt"] {
        std::os::unix::fs::symlink(&passwd, d.join(name)).unwrap();
        let run = haiko(d, &["lid", name]);
        assert_bad_input(&run, name, &[]);
        assert!(
            !run.stderr.contains("SECRET") && !run.stderr.contains("root:x"),
            "{}",
            run.stderr
        );
    }
    // Through a room, with an absolute path too.
    let absolute = d.join("p.ldt");
    for lid_file in ["p.ies", absolute.to_str().unwrap()] {
        write(
            d,
            "room.toml",
            &room_with(
                "lid = [[0, 1000], [180, 1000]]",
                &format!("lid_file = \"{lid_file}\""),
            ),
        );
        let run = haiko(d, &["plan", "room.toml"]);
        assert_bad_input(&run, "room.toml", &["light[0].lid_file"]);
        assert!(!run.stderr.contains("SECRET"), "{}", run.stderr);
    }
    // A points file that is not one.
    write(d, "room.toml", ROOM);
    let run = haiko(d, &["probe", "room.toml", "--points", "passwd", "--direct-only"]);
    assert!(!run.stderr.contains("SECRET"), "{}", run.stderr);
    // After recognition only the offending token, at most 24 characters.
    let ies = fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/ies/isotropic.ies"))
        .unwrap();
    write(
        d,
        "long.ies",
        &ies.replacen("TILT=NONE", "TILT=NONE\nABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789", 1),
    );
    let run = haiko(d, &["lid", "long.ies"]);
    assert_bad_input(&run, "long.ies", &["`ABCDEFGHIJKLMNOPQRSTUVWX…` is not a number"]);
}

#[test]
fn names_with_control_characters_stay_on_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let twice = |name: &str| {
        ROOM.replace("name = \"iso\"", &format!("name = \"{name}\""))
            + &format!("[[light]]\nname = \"{name}\"\nposition = [1.0, 1.0, 2.0]\nlid = [[0, 1], [90, 0]]\n")
    };
    for (name, shown) in [
        ("a\\nb", "a\\nb"),
        ("red\\u001b[31m", "red\\u{1b}[31m"),
        ("x\\u202ey", "x\\u{202e}y"),
    ] {
        write(dir.path(), "dup.toml", &twice(name));
        let run = haiko(dir.path(), &["plan", "dup.toml"]);
        assert_bad_input(&run, "dup.toml", &["light[1].name", shown]);
        assert!(!run.stderr.contains('\u{202e}'), "{}", run.stderr);
    }
}

/// A room with one `[[mesh]]` of `obj` (z up) whose MTL is `mtl`.
fn obj_room(dir: &Path, obj: &str, mtl: &str) -> Run {
    write(dir, "m.obj", obj);
    write(dir, "m.mtl", mtl);
    write(
        dir,
        "room.toml",
        &room_with("[settings]", "[[mesh]]\nfile = \"m.obj\"\nup = \"z\"\n[settings]"),
    );
    haiko(dir, &["plan", "room.toml"])
}

const QUAD: &str = "mtllib m.mtl\nusemtl a\nv 1 1 1\nv 3 1 1\nv 3 3 1\nv 1 3 1\nf 1 2 3 4\n";

#[test]
fn short_mtl_colour_lines_are_errors_or_grey_never_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let run = obj_room(dir.path(), QUAD, "newmtl a\nKd 0.5\n");
    assert_eq!(
        run.code,
        Some(0),
        "one Kd value is grey (MTL spec): {}",
        run.stderr
    );
    for line in ["Kd", "Kd 0.5 0.5", "Kd 0.5 0.5 x"] {
        let run = obj_room(dir.path(), QUAD, &format!("newmtl a\n{line}\n"));
        assert_bad_input(
            &run,
            "room.toml",
            &["mesh[0].file", "`m.obj`", "m.mtl: line 2", "`Kd` needs three"],
        );
    }
    for line in ["Ka 0.5", "Ka", "Ks 0.5 0.5", "Ke", "Ke 1"] {
        let run = obj_room(dir.path(), QUAD, &format!("newmtl a\n{line}\nKd 0.5 0.5 0.5\n"));
        assert_eq!(run.code, Some(0), "{line} is ignored: {}", run.stderr);
    }
    let run = obj_room(dir.path(), &QUAD.replace("f 1 2 3 4", "f 1 2 3 9"), "newmtl a\n");
    assert_bad_input(&run, "room.toml", &["`m.obj`: line 7: face 1 refers to vertex 9"]);
}

#[test]
fn an_obj_too_large_for_any_patch_size_is_told_to_simplify() {
    let dir = tempfile::tempdir().unwrap();
    // 200 × 200 quads = 80 000 triangles per file; nine copies may need 9 · 3 · 80 000 > 2 000 000
    // vertices whatever the patch size.
    let n = 200;
    let mut obj = String::new();
    for j in 0..=n {
        for i in 0..=n {
            obj.push_str(&format!(
                "v {} {} 0.5\n",
                1.0 + i as f64 / n as f64,
                1.0 + j as f64 / n as f64
            ));
        }
    }
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i + 1;
            obj.push_str(&format!("f {a} {} {} {}\n", a + 1, a + n + 2, a + n + 1));
        }
    }
    write(dir.path(), "grid.obj", &obj);
    // Stacked 0.1 m apart (the same faces twice would be refused as coincident).
    let meshes: String = (0..9)
        .map(|k| {
            format!(
                "[[mesh]]\nfile = \"grid.obj\"\nup = \"z\"\ntranslate = [0, 0, {}]\n",
                0.1 * f64::from(k)
            )
        })
        .collect();
    write(
        dir.path(),
        "room.toml",
        &room_with("[settings]", &format!("{meshes}[settings]")),
    );
    let run = haiko(dir.path(), &["plan", "room.toml"]);
    assert_bad_input(
        &run,
        "room.toml",
        &["720000 triangles", "at any patch size", "simplify the OBJ"],
    );
    assert!(!run.stderr.contains("larger patch_size"), "{}", run.stderr);
}

#[test]
fn lights_on_box_tops_and_obj_faces_are_mounted() {
    let dir = tempfile::tempdir().unwrap();
    // An uplight (0–90°, aimed up) standing on a box top and one on an OBJ quad at z = 1.
    let room = room_with(
        "[[light]]",
        "[[box]]\nmin = [0.5, 0.5, 0.0]\nmax = [1.5, 1.5, 0.8]\nreflectance = 0.3\n\
         [[mesh]]\nfile = \"m.obj\"\nup = \"z\"\n\
         [[light]]\nname = \"on box\"\nposition = [1.0, 1.0, 0.8]\naim_dir = [0, 0, 1]\nlid = [[0, 100], [90, 0]]\n\
         [[light]]\nname = \"on obj\"\nposition = [2.0, 2.0, 1.0]\naim_dir = [0, 0, 1]\nlid = [[0, 100], [90, 0]]\n\
         [[light]]",
    );
    write(
        dir.path(),
        "m.obj",
        "v 1.6 1.6 1\nv 3 1.6 1\nv 3 3 1\nv 1.6 3 1\nf 1 2 3 4\n",
    );
    write(dir.path(), "room.toml", &room);
    let run = haiko(dir.path(), &["plan", "room.toml", "--json"]);
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    let plan: serde_json::Value = serde_json::from_str(&run.stdout).unwrap();
    let lights = plan["lights"].as_array().unwrap();
    for (i, surface) in [(0, "box0-top"), (1, "mesh0:")] {
        assert_eq!(
            lights[i]["mask"],
            serde_json::json!([0.0, 0.0, 1.0]),
            "{}",
            lights[i]
        );
        let reason = lights[i]["mask_reason"].as_str().unwrap();
        assert!(
            reason.contains("mounted 0.00 m") && reason.contains(surface),
            "{reason}"
        );
    }
    assert_eq!(
        lights[2]["mask"],
        serde_json::Value::Null,
        "the ceiling light hangs 0.5 m low"
    );
    // A light on a slanted OBJ face inside the OBJ's bounds is accepted and mounted too.
    write(
        dir.path(),
        "m.obj",
        "v 1 1 1\nv 3 1 1\nv 3 3 2\nv 1 3 2\nf 1 2 3 4\n",
    );
    let slanted = room.replace(
        "position = [2.0, 2.0, 1.0]\naim_dir = [0, 0, 1]",
        "position = [2.0, 2.0, 1.5]\naim_dir = [0, -1, 2]",
    );
    write(dir.path(), "room.toml", &slanted);
    let run = haiko(dir.path(), &["plan", "room.toml", "--json"]);
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    let plan: serde_json::Value = serde_json::from_str(&run.stdout).unwrap();
    let mask = plan["lights"][1]["mask"].as_array().expect("masked").clone();
    let n: Vec<f64> = mask.iter().map(|v| v.as_f64().unwrap()).collect();
    let expected = DVec3::new(0.0, -1.0, 2.0).normalize();
    assert!(
        (DVec3::new(n[0], n[1], n[2]) - expected).length() < 1e-12,
        "{n:?}"
    );
}

#[test]
fn points_files_have_a_row_limit() {
    let mut text = String::from("x,y,z,nx,ny,nz\n");
    text.push_str(&"1,1,1,0,0,1\n".repeat(MAX_POINTS));
    assert_eq!(
        parse_points(&text, Path::new("p.csv"), DVec3::splat(3.0))
            .unwrap()
            .len(),
        MAX_POINTS
    );
    text.push_str("1,1,1,0,0,1\n");
    let e = parse_points(&text, Path::new("p.csv"), DVec3::splat(3.0))
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        format!(
            "p.csv: line {}: more than 1000000 points; split the file",
            MAX_POINTS + 2
        )
    );
}

/// `ROOM` with grey walls (so there is interreflection and a bake cache entry).
fn grey_room() -> String {
    room_with("walls = 0.0", "walls = 0.5")
}

fn render_args<'a>(room: &'a str, output: &'a str) -> [&'a str; 8] {
    ["render", room, "-o", output, "--width", "160", "--height", "120"]
}

#[test]
fn outputs_that_are_inputs_are_refused_and_left_alone() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let ies = fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/ies/isotropic.ies"))
        .unwrap();
    write(d, "lamp.ies", &ies);
    let room = room_with("lid = [[0, 1000], [180, 1000]]", "lid_file = \"lamp.ies\"");
    write(d, "room.toml", &room);
    std::os::unix::fs::symlink("room.toml", d.join("soft.png")).unwrap();
    fs::hard_link(d.join("room.toml"), d.join("hard.png")).unwrap();
    for (output, input) in [
        ("room.toml", "room.toml"),
        ("soft.png", "room.toml"),
        ("hard.png", "room.toml"),
        ("lamp.ies", "lamp.ies"),
    ] {
        let run = haiko(d, &render_args("room.toml", output));
        assert_bad_input(
            &run,
            output,
            &["is the input file", input, "never overwrites an input"],
        );
    }
    // The report is an output too.
    for output in ["room.toml", "hard.png", "lamp.ies"] {
        let run = haiko(
            d,
            &[
                "report",
                "room.toml",
                "-o",
                output,
                "--width",
                "64",
                "--height",
                "48",
            ],
        );
        assert_bad_input(&run, output, &["is the input file", "never overwrites an input"]);
    }
    assert_eq!(fs::read_to_string(d.join("room.toml")).unwrap(), room);
    assert_eq!(fs::read_to_string(d.join("lamp.ies")).unwrap(), ies);
    // An OBJ and its MTL are inputs too.
    write(d, "m.obj", QUAD);
    write(d, "m.mtl", "newmtl a\nKd 0.5 0.5 0.5\n");
    write(
        d,
        "mesh.toml",
        &room_with("[settings]", "[[mesh]]\nfile = \"m.obj\"\nup = \"z\"\n[settings]"),
    );
    for output in ["m.obj", "m.mtl"] {
        let run = haiko(d, &render_args("mesh.toml", output));
        assert_bad_input(&run, output, &["is the input file", "never overwrites an input"]);
    }
    assert_eq!(fs::read_to_string(d.join("m.obj")).unwrap(), QUAD);
    // A new output is written (a PNG), through a temporary file that does not stay.
    let run = haiko(d, &render_args("room.toml", "out.png"));
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    assert_eq!(&fs::read(d.join("out.png")).unwrap()[..8], b"\x89PNG\r\n\x1a\n");
    let temporaries: Vec<_> = fs::read_dir(d)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().contains("haiko-tmp"))
        .collect();
    assert!(temporaries.is_empty(), "{temporaries:?}");
}

#[test]
fn a_failed_image_write_keeps_the_old_image_and_exits_1() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(d, "room.toml", ROOM);
    write(d, "out.png", "the previous image");
    // One block of 512 bytes: the 160 × 120 PNG (several kB) cannot be written.
    let run = haiko_limited(d, "-f 1", &render_args("room.toml", "out.png"));
    assert_eq!(run.code, Some(1), "an I/O failure is exit 1: {}", run.stderr);
    assert_eq!(run.stderr.trim_end().lines().count(), 1, "{}", run.stderr);
    assert!(
        run.stderr.contains("cannot write out.png")
            && run.stderr.contains("the previous file, if any, is unchanged"),
        "{}",
        run.stderr
    );
    assert_eq!(
        fs::read_to_string(d.join("out.png")).unwrap(),
        "the previous image"
    );
    let names: Vec<String> = fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !n.starts_with(".std") && n != ".cache")
        .collect();
    let mut names = names;
    names.sort();
    assert_eq!(names, ["out.png", "room.toml"], "no temporary file left");
}

#[test]
fn a_tiny_grid_spacing_is_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "room.toml", ROOM);
    for spacing in ["1e-9", "1e-300", "5e-324"] {
        let run = haiko(
            dir.path(),
            &["grid", "room.toml", "--height", "0.8", "--spacing", spacing],
        );
        assert_bad_input(
            &run,
            "--spacing",
            &[
                "points, more than 4000000",
                "choose a spacing of at least 0.003 m",
            ],
        );
        assert!(!run.stderr.contains("furniture"), "{}", run.stderr);
    }
    // At that spacing the grid fits: 4 m / 0.003 m + 1 = 1334 points per axis (margin 1.5 mm).
    let run = haiko(
        dir.path(),
        &[
            "grid",
            "room.toml",
            "--height",
            "0.8",
            "--spacing",
            "0.003",
            "--direct-only",
        ],
    );
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    assert!(run.stdout.contains("1333 × 1333 points"), "{}", run.stdout);
}

#[test]
fn names_are_escaped_wherever_they_are_printed() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let room = ROOM.replace("name = \"iso\"", "name = \"red\\u001b[31m\\nx\"");
    write(d, "room.toml", &room);
    let shown = "red\\u{1b}[31m\\nx";
    let run = haiko(d, &["plan", "room.toml"]);
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    assert!(run.stdout.contains(&format!("light {shown}")), "{}", run.stdout);
    let run = haiko(d, &["bake", "room.toml"]);
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    assert!(run.stdout.contains(shown), "{}", run.stdout);
    let source = "room.toml#red\u{1b}[31m\nx";
    let run = haiko(d, &["lid", source]);
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    assert!(
        run.stdout.starts_with(&format!("room.toml#{shown}\n")),
        "{}",
        run.stdout
    );
    let run = haiko(
        d,
        &[
            "pick",
            "room.toml",
            "--pixel",
            "80,100",
            "--width",
            "160",
            "--height",
            "120",
            "--aim",
            "red\u{1b}[31m\nx",
        ],
    );
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    assert!(run.stdout.contains(&format!("(light {shown})")), "{}", run.stdout);
    for out in [&run.stdout, &run.stderr] {
        assert!(!out.contains('\u{1b}'), "{out}");
    }
}

#[test]
fn a_fifo_named_like_a_cache_file_is_never_opened() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // The SH basis engine: the one the bake cache serves.
    write(
        d,
        "room.toml",
        &grey_room().replacen("[settings]\n", "[settings]\nindirect = \"basis\"\n", 1),
    );
    write(d, "p.csv", "x,y,z,nx,ny,nz\n2,2,0,0,0,1\n");
    let first = haiko(d, &["probe", "room.toml", "--points", "p.csv"]);
    assert_eq!(first.code, Some(0), "{}", first.stderr);
    let entries: Vec<PathBuf> = fs::read_dir(d.join(".cache"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "bake"))
        .collect();
    assert!(!entries.is_empty(), "the bake was cached");
    for entry in &entries {
        fs::remove_file(entry).unwrap();
        assert!(Command::new("mkfifo").arg(entry).status().unwrap().success());
    }
    // Neither command blocks on the FIFO (the helper fails a run after 60 s): the entry is
    // invalid, the bake is redone and cached again as a regular file, the answer unchanged.
    let again = haiko(d, &["probe", "room.toml", "--points", "p.csv"]);
    assert_eq!(again.code, Some(0), "{}", again.stderr);
    assert!(
        again.stderr.contains("FIFO (named pipe), not a regular file"),
        "{}",
        again.stderr
    );
    assert_eq!(again.stdout, first.stdout);
    for entry in &entries {
        assert!(fs::metadata(entry).unwrap().is_file(), "{entry:?} rewritten");
        fs::remove_file(entry).unwrap();
        assert!(Command::new("mkfifo").arg(entry).status().unwrap().success());
    }
    let run = haiko(d, &render_args("room.toml", "out.png"));
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    assert!(run.stderr.contains("FIFO"), "{}", run.stderr);
}

/// An 80 × 80 × 4 m hall with grey surfaces and 0.15 m solver patches: about 580 000, more leaves
/// than the hierarchical engine takes (250 000), so the SH basis is baked and its dense form
/// factors alone would take 1.6 TB. (At the default 0.5 m it is 56 000 leaves for the
/// hierarchical engine, about 0.3 GB before its links.)
const HALL: &str = r#"version = 1
[room]
size = [80.0, 80.0, 4.0]
[room.reflectance]
floor = 0.2
walls = 0.5
ceiling = 0.7
[[light]]
name = "high bay"
position = [40.0, 40.0, 3.9]
lid = [[0, 10000], [90, 0]]
[settings]
solver_patch_size = 0.15
"#;

#[test]
fn a_hall_too_large_for_memory_is_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(d, "hall.toml", HALL);
    write(d, "p.csv", "x,y,z,nx,ny,nz\n40,40,0,0,0,1\n");
    // The default limit: half the memory the process may have; under a 4 GiB address space
    // (the bad-input corpus's cap) that is 2 GiB on any machine.
    let run = haiko_limited(d, "-v 4194304", &["bake", "hall.toml"]);
    assert!(
        run.stdout.is_empty(),
        "refused before the plan is printed: {}",
        run.stdout
    );
    assert_bad_input(
        &run,
        "hall.toml",
        &[
            "needs about 1",
            " TB of memory (form factors ",
            "more than the limit of 2.15 GB (half the memory available to Haiko",
            "`settings.solver_patch_size`",
            "`--max-memory`",
        ],
    );
    let editor = haiko_limited(d, "-v 4194304", &["edit", "hall.toml"]);
    assert_bad_input(&editor, "hall.toml", &["more than the limit of 2.15 GB"]);
    assert!(!editor.stdout.contains('\u{1b}'), "the terminal was never taken");
    let limited: [&[&str]; 4] = [
        &["bake", "hall.toml"],
        &[
            "render",
            "hall.toml",
            "-o",
            "hall.png",
            "--width",
            "64",
            "--height",
            "48",
        ],
        &["probe", "hall.toml", "--points", "p.csv"],
        &["grid", "hall.toml", "--height", "0.8", "--spacing", "1"],
    ];
    for args in limited {
        let args = [args, &["--max-memory", "4G"]].concat();
        let run = haiko(d, &args);
        assert_bad_input(
            &run,
            "hall.toml",
            &["more than the limit of 4.29 GB (--max-memory)"],
        );
    }
    assert!(!d.join("hall.png").exists());
    // `plan` shows the estimate against the limit, and refuses nothing.
    let run = haiko(d, &["plan", "hall.toml", "--max-memory", "4G"]);
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    assert!(
        run.stdout.contains("budget: about 1")
            && run
                .stdout
                .contains("ABOVE (the commands that simulate will refuse) the limit of 4.29 GB"),
        "{}",
        run.stdout
    );
}

#[test]
fn a_small_room_runs_within_a_given_budget_and_not_within_a_tiny_one() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(d, "room.toml", &grey_room());
    write(d, "p.csv", "x,y,z,nx,ny,nz\n2,2,0,0,0,1\n");
    let commands: [&[&str]; 5] = [
        &["bake", "room.toml"],
        &[
            "render",
            "room.toml",
            "-o",
            "out.png",
            "--width",
            "64",
            "--height",
            "48",
        ],
        &["probe", "room.toml", "--points", "p.csv"],
        &["grid", "room.toml", "--height", "0.8", "--spacing", "1"],
        &[
            "pick",
            "room.toml",
            "--pixel",
            "32,40",
            "--width",
            "64",
            "--height",
            "48",
        ],
    ];
    for args in commands {
        let run = haiko(d, &[args, &["--max-memory", "64G"]].concat());
        assert_eq!(run.code, Some(0), "{args:?}: {}", run.stderr);
        let run = haiko(d, &[args, &["--max-memory", "1K"]].concat());
        assert_bad_input(
            &run,
            "room.toml",
            &["more than the limit of 1.02 kB (--max-memory)"],
        );
    }
    let run = haiko(d, &["plan", "room.toml", "--max-memory", "64G"]);
    assert!(
        run.stdout.contains("within the limit of 68.7 GB (--max-memory)"),
        "{}",
        run.stdout
    );
    let run = haiko(d, &["plan", "room.toml", "--json", "--max-memory", "1K"]);
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    let plan: serde_json::Value = serde_json::from_str(&run.stdout).unwrap();
    let budget = &plan["budget"];
    assert_eq!(budget["limit_bytes"], 1024);
    assert_eq!(budget["limit_from"], "--max-memory");
    assert_eq!(budget["within"], false);
    let parts = [
        "form_factor_bytes",
        "basis_bytes",
        "engine_bytes",
        "relight_bytes",
    ]
    .map(|k| budget[k].as_u64().unwrap());
    assert_eq!(
        budget["estimate_bytes"].as_u64().unwrap(),
        parts.iter().sum::<u64>()
    );
    // The hierarchical engine: no dense form factors and no basis; per leaf 512 B of geometry,
    // per leaf and light a direct-light cache of 4 608 B and 24 B of solved values; the links
    // get what is left of the limit, 48 B each (none of 1 kB here).
    assert_eq!(plan["hierarchical"]["on"], true);
    let leaves = plan["leaves"].as_u64().unwrap();
    assert!(leaves > 0);
    assert_eq!(parts[..2], [0, 0]);
    assert_eq!(parts[2], leaves * (512 + 4608 + 24));
    assert_eq!(budget["max_links"], 0);
    // With room for 100 links, the engine stops building at the 101st and says so (a cached
    // operator would be read whatever its links: the cache goes first).
    fs::remove_dir_all(d.join(".cache")).unwrap();
    let limit = format!("{}", parts.iter().sum::<u64>() + 100 * 48);
    let run = haiko(
        d,
        &["probe", "room.toml", "--points", "p.csv", "--max-memory", &limit],
    );
    assert_eq!(run.code, Some(2), "{}", run.stderr);
    let last = run.stderr.trim_end().lines().last().unwrap_or_default();
    assert!(
        last.starts_with("haiko: room.toml: the interreflection engine needs more than 100 links on its")
            && last.contains("raise `settings.solver_patch_size`"),
        "after the progress line: {}",
        run.stderr
    );
    let run = haiko(d, &["bake", "room.toml", "--max-memory", "12Q"]);
    assert_eq!(run.code, Some(2), "{}", run.stderr);
    assert!(
        run.stderr.contains("`12Q` is not a memory size"),
        "{}",
        run.stderr
    );
}

/// Two closed unit cubes stacked at x, y 1..2: z 0.2..1.2 and 1.2..2.2, faces turned out.
const STACKED_CUBES: &str = "\
o a\nv 1 1 0.2\nv 2 1 0.2\nv 2 2 0.2\nv 1 2 0.2\nv 1 1 1.2\nv 2 1 1.2\nv 2 2 1.2\nv 1 2 1.2\n\
f 1 4 3 2\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\nf 5 6 7 8\n\
o b\nv 1 1 1.2\nv 2 1 1.2\nv 2 2 1.2\nv 1 2 1.2\nv 1 1 2.2\nv 2 1 2.2\nv 2 2 2.2\nv 1 2 2.2\n\
f 9 12 11 10\nf 9 10 14 13\nf 10 11 15 14\nf 11 12 16 15\nf 12 9 13 16\nf 13 14 15 16\n";

#[test]
fn lights_closed_in_by_furniture_are_refused_and_lights_on_free_faces_kept() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Two boxes side by side, touching at x = 2; the light on the face they share.
    let boxes = |gap: f64| {
        format!(
            "[[box]]\nmin = [1.5, 1.5, 0.0]\nmax = [2.0, 2.5, 1.0]\nreflectance = 0.4\n\
             [[box]]\nmin = [{}, 1.5, 0.0]\nmax = [2.5, 2.5, 1.0]\nreflectance = 0.4\n[[light]]",
            2.0 + gap
        )
    };
    let between = room_with("position = [2.0, 2.0, 2.5]", "position = [2.0, 2.0, 0.5]");
    write(d, "room.toml", &between.replacen("[[light]]", &boxes(0.0), 1));
    let run = haiko(d, &["plan", "room.toml"]);
    assert_bad_input(
        &run,
        "room.toml",
        &["light[0].position", "close it in on every side", "line 18"],
    );
    // 1 mm apart the light stands in a free slot; on the top face of one box it is mounted.
    write(d, "room.toml", &between.replacen("[[light]]", &boxes(0.001), 1));
    let run = haiko(d, &["plan", "room.toml"]);
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    let on_top = room_with("position = [2.0, 2.0, 2.5]", "position = [2.0, 2.0, 1.0]");
    write(d, "room.toml", &on_top.replacen("[[light]]", &boxes(0.0), 1));
    let run = haiko(d, &["plan", "room.toml"]);
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    // Two closed OBJ cubes stacked: on the face they share it is refused (it lit the cubes'
    // outer faces from within), on the upper cube's top it is kept.
    write(d, "m.obj", STACKED_CUBES);
    let cubes = |z: f64| {
        room_with(
            "position = [2.0, 2.0, 2.5]",
            &format!("position = [1.5, 1.5, {z}]"),
        )
        .replacen(
            "[settings]",
            "[[mesh]]\nfile = \"m.obj\"\nup = \"z\"\n[settings]",
            1,
        )
    };
    write(d, "room.toml", &cubes(1.2));
    let run = haiko(d, &["plan", "room.toml"]);
    assert_bad_input(
        &run,
        "room.toml",
        &["light[0].position", "close it in on every side"],
    );
    write(d, "room.toml", &cubes(2.2));
    let run = haiko(d, &["plan", "room.toml"]);
    assert_eq!(run.code, Some(0), "{}", run.stderr);
}

#[test]
fn obj_faces_given_twice_the_same_way_are_refused_naming_the_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let square = "v 1 1 1\nv 3 1 1\nv 3 3 1\nv 1 3 1\n";
    let run = obj_room(d, &format!("{square}f 1 2 3 4\nf 1 2 3 4\n"), "");
    assert_bad_input(
        &run,
        "room.toml",
        &["mesh[0]", "appears twice in that mesh", "remove the copy"],
    );
    // The same OBJ listed twice.
    write(d, "m.obj", &format!("{square}f 1 2 3 4\n"));
    let mesh = "[[mesh]]\nfile = \"m.obj\"\nup = \"z\"\n";
    write(
        d,
        "room.toml",
        &room_with("[settings]", &format!("{mesh}{mesh}[settings]")),
    );
    let run = haiko(d, &["plan", "room.toml"]);
    assert_bad_input(&run, "room.toml", &["mesh[1]", "in mesh[0] too"]);
    // A two-sided sheet (the same face turned both ways) is no copy, and its interreflection
    // solves: with black walls, the ceiling above a 0.5 grey sheet under the light gets the
    // light its top reflects, as from the one-sided sheet (the underside faces the black floor).
    write(
        d,
        "m.obj",
        &format!("mtllib m.mtl\nusemtl a\n{square}f 1 2 3 4\nf 4 3 2 1\n"),
    );
    write(d, "m.mtl", "newmtl a\nKd 0.5 0.5 0.5\n");
    write(d, "p.csv", "x,y,z,nx,ny,nz\n2,2,3,0,0,-1\n");
    write(
        d,
        "room.toml",
        &room_with("[settings]", &format!("{mesh}[settings]")),
    );
    let run = haiko(d, &["probe", "room.toml", "--points", "p.csv"]);
    write(
        d,
        "m.obj",
        &format!("mtllib m.mtl\nusemtl a\n{square}f 1 2 3 4\n"),
    );
    let run_single = haiko(d, &["probe", "room.toml", "--points", "p.csv"]);
    for run in [&run, &run_single] {
        assert_eq!(run.code, Some(0), "{}", run.stderr);
    }
    let lux = |run: &Run| -> f64 {
        let row = run.stdout.lines().nth(1).expect("a row");
        row.rsplit(',').next().unwrap().parse().unwrap()
    };
    assert!(lux(&run) > 1.0, "{}", run.stdout);
    assert!(
        (lux(&run) / lux(&run_single) - 1.0).abs() < 1e-3,
        "{} against {}",
        run.stdout,
        run_single.stdout
    );
}

#[test]
fn probe_points_outside_the_room_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(d, "room.toml", ROOM);
    write(d, "p.csv", "x,y,z,nx,ny,nz\n2,2,0,0,0,1\n-500,-500,-500,0,0,1\n");
    let run = haiko(d, &["probe", "room.toml", "--points", "p.csv", "--direct-only"]);
    assert_bad_input(
        &run,
        "p.csv",
        &[
            "line 3",
            "[-500.0, -500.0, -500.0] is outside the room",
            "[4.0, 4.0, 3.0]",
        ],
    );
}

#[test]
fn command_line_numbers_are_named_as_written_and_printed_short() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(d, "room.toml", ROOM);
    // No --margin given: the spacing is the culprit.
    let run = haiko(d, &["grid", "room.toml", "--height", "0.8", "--spacing", "5"]);
    assert_bad_input(&run, "--spacing", &["5.0 m", "4.0 m", "default margin"]);
    assert!(!run.stderr.contains("--margin"), "{}", run.stderr);
    for (flag, value) in [("--height", "1e308"), ("--spacing", "1e-320")] {
        let mut args = vec!["grid", "room.toml", "--height", "0.8", "--spacing", "0.5"];
        let at = args.iter().position(|a| *a == flag).unwrap() + 1;
        args[at] = value;
        let run = haiko(d, &args);
        assert_bad_input(&run, flag, &[value]);
        assert!(run.stderr.len() < 160, "{}", run.stderr);
    }
    // Cells far too large for an image: --font is named, with the size they make.
    let run = haiko(
        d,
        &[
            "render",
            "room.toml",
            "--terminal",
            "sixel",
            "--font",
            "1000x1000",
        ],
    );
    assert_bad_input(&run, "--font", &["1000x1000 px cells", "more than 8192 a side"]);
}

#[test]
fn lid_reports_the_brightest_curves_and_refuses_angles_closer_than_a_micro_degree() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(
        d,
        "room.toml",
        &room_with("lid = [[0, 1000], [180, 1000]]", "lid = [[0, 1e9], [90, 0]]"),
    );
    let run = haiko(d, &["lid", "room.toml#iso", "--json"]);
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    let report: serde_json::Value = serde_json::from_str(&run.stdout).unwrap();
    assert_eq!(report["peak_cd"].as_f64(), Some(1e9));
    // Φ of a linear fall from I₀ at 0° to 0 at 90°: 2π I₀ ∫₀^{π/2} (1 − 2γ/π) sin γ dγ
    // = 2π I₀ (1 − 2/π).
    let flux = 2.0 * std::f64::consts::PI * 1e9 * (1.0 - 2.0 / std::f64::consts::PI);
    assert!((report["flux_lm"].as_f64().unwrap() / flux - 1.0).abs() < 1e-12);
    write(
        d,
        "room.toml",
        &room_with("lid = [[0, 1000], [180, 1000]]", "lid = [[0, 1000], [1e-320, 0]]"),
    );
    for command in ["lid", "plan"] {
        let source = if command == "lid" {
            "room.toml#iso"
        } else {
            "room.toml"
        };
        let run = haiko(d, &[command, source]);
        assert_bad_input(
            &run,
            "room.toml",
            &[
                "light[0].lid",
                "point 1: angle 1e-320° is within 1e-6° of",
                "same angle twice",
            ],
        );
    }
}

#[test]
fn lid_says_when_no_order_up_to_its_cap_meets_the_target() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A 500 cd spot cut off hard at 30°, and the same curve falling off over 30–60°.
    for (lid, capped) in [
        ("[[0, 500], [30, 500], [30, 0], [90, 0]]", true),
        ("[[0, 500], [30, 500], [60, 0]]", false),
    ] {
        write(
            d,
            "room.toml",
            &room_with("lid = [[0, 1000], [180, 1000]]", &format!("lid = {lid}")),
        );
        let run = haiko(
            d,
            &[
                "lid",
                "room.toml#iso",
                "--window",
                "none",
                "--order",
                "60",
                "--json",
            ],
        );
        assert_eq!(run.code, Some(0), "{}", run.stderr);
        let report: serde_json::Value = serde_json::from_str(&run.stdout).unwrap();
        let order = report["order"].as_u64().unwrap() as usize;
        let error = report["order_rel_l2_error"].as_f64().unwrap();
        let row = &report["orders"][order];
        let tabulated = row["rel_l2_error"].as_f64().unwrap();
        assert!(
            (tabulated / error - 1.0).abs() < 1e-9,
            "row {order}: {tabulated} against {error}"
        );
        let above = |n: usize| report["orders"][n]["rel_l2_error"].as_f64().unwrap() > 0.05;
        if capped {
            assert_eq!(order, 60);
            assert!(error > 0.05, "{error}");
        } else {
            assert!(
                order < 60 && error <= 0.05 && above(order - 1),
                "{order}: {error}"
            );
        }
        let run = haiko(d, &["lid", "room.toml#iso", "--order", "2"]);
        assert_eq!(run.code, Some(0), "{}", run.stderr);
        let heading = run.stdout.lines().nth(1).unwrap().to_string();
        let percent = format!("relative L2 {:.1} %", error * 100.0);
        let expected = if capped {
            format!("order capped at 60: {percent} misses the 5 % target")
        } else {
            format!("chosen order {order} ({percent} ≤ 5 %)")
        };
        assert!(
            heading.ends_with(&expected) || heading.contains(&expected),
            "{heading}"
        );
    }
}
