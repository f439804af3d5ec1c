//! The bundled rooms through the `render` and `pick` commands: golden images per room and mode,
//! the exact ID buffer of the paper room, picking against an analytic ray–plane intersection,
//! and the built binary end to end (images written, JSON, bad-input exit codes).
//!
//! The reference images live in `snapshots/` and include the baked indirect light. When a change
//! is meant to alter them, look at the new pictures (diffs under `target/golden-diffs/`), then
//! regenerate with `HAIKO_UPDATE_SNAPSHOTS=1 cargo test --test all render_rooms`.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use glam::DVec3;
use haiko::cli::pick::{PickReport, Pixel, pick_pixel, to_json};
use haiko::render::DisplayMode;
use haiko::render::golden::{Golden, Tolerance, UPDATE_ENV};
use haiko::scene::{self, EngineChoice, Scene};
use haiko::session::{FrameSpec, MAX_SIDE_PX, Session, SessionOptions, ViewChoice};
use haiko::transport::bake::BakeOptions;
use haiko::transport::plan::PlanOptions;

/// Size of the room goldens, pixels.
const SNAPSHOT_SIZE: (u32, u32) = (160, 120);

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn room(name: &str) -> PathBuf {
    root().join("rooms").join(format!("{name}.toml"))
}

fn load(name: &str) -> Scene {
    scene::load(&room(name)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// A session on `scene` without a bake cache; `indirect` false for direct light only.
fn session(scene: Scene, indirect: bool) -> Session {
    let options = SessionOptions {
        indirect,
        ..SessionOptions::default()
    };
    Session::new(scene, options, &mut |_| {}).unwrap()
}

/// The room camera's frame at `size` in `mode`, with every light marked (none selected).
fn spec(size: (u32, u32), mode: DisplayMode) -> FrameSpec {
    FrameSpec::new(size, mode)
}

/// `haiko pick --direct-only` on `scene` (through a direct-light session, as the command does).
fn pick(
    scene: &Scene,
    width: u32,
    height: u32,
    pixel: Pixel,
    aim: Option<&str>,
) -> haiko::Result<PickReport> {
    pick_pixel(
        &mut session(scene.clone(), false),
        width,
        height,
        pixel,
        aim,
        true,
    )
}

fn golden() -> Golden {
    Golden::from_env(root().join("snapshots"), root().join("target/golden-diffs"))
}

fn regenerate_hint(e: impl std::fmt::Display) -> String {
    format!(
        "{e}\nIf the change is intended (e.g. the bake now adds indirect light), look at the images and \
         regenerate the references with {UPDATE_ENV}=1 cargo test --test all render_rooms"
    )
}

#[test]
fn every_bundled_room_matches_its_golden_images() {
    let mut rooms: Vec<String> = std::fs::read_dir(root().join("rooms"))
        .unwrap()
        .map(|entry| entry.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .map(|p| p.file_stem().unwrap().to_string_lossy().into_owned())
        .collect();
    rooms.sort();
    assert!(rooms.len() >= 5, "bundled rooms: {rooms:?}");
    let (width, height) = SNAPSHOT_SIZE;
    for name in &rooms {
        let mut session = session(load(name), true);
        for (mode, suffix) in [
            (DisplayMode::Photo, "photo"),
            (DisplayMode::FalseColor, "false_colour"),
        ] {
            let frame = session.render(&spec((width, height), mode)).unwrap();
            let tolerance = Tolerance {
                channel: 2,
                max_pixels: 16,
            };
            golden()
                .check_image(&format!("{name}_{suffix}"), &frame.pixmap, tolerance)
                .unwrap_or_else(|e| panic!("{}", regenerate_hint(e)));
        }
    }
}

/// The plan's footprint stands left of the legend: the room's right wall projects left of the
/// legend panel, its left wall near the left edge, and a plan without the legend (photo mode)
/// is centred on the footprint again.
#[test]
fn the_plan_footprint_stands_left_of_the_legend() {
    let mut session = session(load("office"), false);
    let size = (480, 360);
    let room = session.scene().room_size;
    let false_colour = FrameSpec {
        view: ViewChoice::Plan,
        ..spec(size, DisplayMode::FalseColor)
    };
    session.render(&false_colour).unwrap();
    let Some(haiko::render::DisplayShader::FalseColor(scale)) =
        session.fitted_shader(DisplayMode::FalseColor)
    else {
        panic!("a false-colour frame fits a lux range");
    };
    let legend = haiko::render::legend_width(size.0, size.1, &scale);
    assert!(legend > 40, "the legend takes {legend} px");
    let (_, view) = session.latest_frame().unwrap();
    let right = view.project(DVec3::new(room.x, 0.5 * room.y, 0.0)).unwrap().x;
    let left = view.project(DVec3::new(0.0, 0.5 * room.y, 0.0)).unwrap().x;
    let free_from = f64::from(size.0 - legend);
    assert!(
        right < free_from,
        "right wall at x = {right}, legend from {free_from}"
    );
    // The footprint (with its margin) fills the width left of the legend, or the height.
    let margin = haiko::render::plan::PLAN_MARGIN * room.x.max(room.y);
    let px_per_m = (right - left) / room.x;
    let used_w = (room.x + 2.0 * margin) * px_per_m;
    let used_h = (room.y + 2.0 * margin) * px_per_m;
    assert!(
        (used_w - free_from).abs() < 1.0 || (used_h - f64::from(size.1)).abs() < 1.0,
        "footprint {used_w} × {used_h} px in {free_from} × {} px",
        size.1
    );
    assert!(
        (left - margin * px_per_m).abs() < 1.0 || used_w < free_from,
        "left wall at {left}"
    );
    // Photo mode draws no legend: the footprint is centred in the whole image.
    session
        .render(&FrameSpec {
            view: ViewChoice::Plan,
            ..spec(size, DisplayMode::Photo)
        })
        .unwrap();
    let (_, view) = session.latest_frame().unwrap();
    let centre = view.project(DVec3::new(0.5 * room.x, 0.5 * room.y, 0.0)).unwrap();
    assert!((centre.x - 240.0).abs() < 0.5, "centre at {}", centre.x);
}

/// The work plane's plan shows what the numbers give at the same point of the plane (the
/// session's `illuminance_at`, which `haiko probe` and `haiko grid` use): direct light alone to
/// f32 rounding (both exact, shadows of the boxes included), and with the indirect light within
/// 2 % (the plan interpolates between the plane's vertices, 0.15 m apart, the indirect light
/// the numbers gather at the point itself), with either indirect engine: the office with the SH
/// basis forced and with its plan's hierarchical engine (links relaxed: 11 184 leaves), the paper
/// room with the engine's exact links.
#[test]
fn the_work_plane_plan_shows_the_work_plane_numbers() {
    for (room, indirect, engine) in [
        ("office", false, EngineChoice::Auto),
        ("office", true, EngineChoice::Basis),
        ("office", true, EngineChoice::Auto),
        ("paper", true, EngineChoice::Auto),
    ] {
        let options = SessionOptions {
            indirect,
            bake: BakeOptions {
                plan: PlanOptions {
                    engine,
                    ..PlanOptions::default()
                },
                ..BakeOptions::default()
            },
            ..SessionOptions::default()
        };
        let mut session = Session::new(load(room), options, &mut |_| {}).unwrap();
        assert_eq!(
            session.hierarchical().is_some(),
            indirect && engine == EngineChoice::Auto,
            "{room}: the plan's engine"
        );
        let height = haiko::session::work_plane_height(session.scene());
        assert_eq!(height, 0.8, "{room}: the design keeps the default work plane");
        let plan = FrameSpec {
            view: ViewChoice::WorkPlane,
            ..spec((320, 240), DisplayMode::FalseColor)
        };
        assert_plan_matches_numbers(&mut session, &plan, height, indirect, "as opened");
        // After edits the plane's indirect light is gathered again for the new state (the
        // gather's factors are kept): light 0 aimed at a wall, light 1 dimmed.
        let edits = [
            haiko::session::Command::Aim {
                light: 0,
                spec: haiko::scene::AimSpec::Direction(DVec3::new(1.0, 0.0, -0.3)),
            },
            haiko::session::Command::SetDimmer {
                light: 1,
                dimmer: 0.2,
            },
        ];
        for edit in edits {
            session.apply(edit).unwrap();
        }
        assert_plan_matches_numbers(&mut session, &plan, height, indirect, "after edits");
    }
}

/// At ≥ 25 pixels of the work-plane plan `plan`, the picked point is on the plane at `height`,
/// facing up, and its lux equals the session's numbers (`illuminance_at`, behind probe and grid):
/// to 1e-4 direct only, 2 % with indirect light (interpolated between the plane's vertices).
fn assert_plan_matches_numbers(
    session: &mut Session,
    plan: &FrameSpec,
    height: f64,
    indirect: bool,
    when: &str,
) {
    session.render(plan).unwrap();
    let mut checked = 0;
    for y in (20..240).step_by(29) {
        for x in (20..260).step_by(31) {
            // Cells inside boxes are left out of the plane.
            let Some(hit) = session.pick((x, y)) else {
                continue;
            };
            assert!((hit.point.z - height).abs() < 1e-6, "{hit:?}");
            assert!(hit.normal.z > 0.999, "the plane faces up: {hit:?}");
            let receiver = haiko::scene::Receiver {
                point: hit.point,
                normal: DVec3::Z,
            };
            let want = session
                .illuminance_at(&[receiver], !indirect, haiko::scene::DirectMode::Exact)
                .unwrap()[0];
            let tolerance = if indirect { 0.02 } else { 1e-4 };
            assert!(
                (hit.lux - want).abs() <= tolerance * want,
                "{when}, indirect {indirect}, pixel ({x}, {y}) at {}: plan {} lx, numbers {want} lx",
                hit.point,
                hit.lux
            );
            checked += 1;
        }
    }
    assert!(checked >= 25, "{when}: {checked} pixels on the plane");
}

/// The office in plan view, false colour with isolux lines and the legend, at a size where the
/// symbols and labels are legible.
#[test]
fn office_plan_view_with_isolux_and_legend_matches_its_golden() {
    let mut session = session(load("office"), true);
    let spec = FrameSpec {
        view: ViewChoice::Plan,
        isolux: true,
        ..spec((480, 360), DisplayMode::FalseColor)
    };
    let frame = session.render(&spec).unwrap();
    let tolerance = Tolerance {
        channel: 2,
        max_pixels: 64,
    };
    golden()
        .check_image("office_plan_isolux", &frame.pixmap, tolerance)
        .unwrap_or_else(|e| panic!("{}", regenerate_hint(e)));
}

#[test]
fn paper_room_id_buffer_matches_its_exact_golden() {
    let scene = load("paper");
    let mut session = session(scene.clone(), false);
    let frame = session
        .render(&spec(SNAPSHOT_SIZE, DisplayMode::FalseColor))
        .unwrap();
    // The camera is inside a closed room: every pixel shows a patch.
    assert!(
        frame
            .ids
            .as_slice()
            .iter()
            .all(|&id| (id as usize) < scene.fine.patches.len())
    );
    golden()
        .check_ids("paper", &frame.ids)
        .unwrap_or_else(|e| panic!("{}", regenerate_hint(e)));
}

// ---------------------------------------------------------------------------------------------
// Picking on the paper room (6 × 4 × 2.7 m, camera eye (0.5, 0.5, 1.6) → (3, 2, 0.8), 60°).

/// The ray through the centre of pixel (x, y), built from the room file's camera numbers here
/// (not through the renderer's matrices): unit direction, world frame.
fn pixel_ray(eye: DVec3, target: DVec3, fov_deg: f64, size: (u32, u32), pixel: (u32, u32)) -> DVec3 {
    let forward = (target - eye).normalize();
    let right = forward.cross(DVec3::Z).normalize();
    let up = right.cross(forward);
    let tan_half = (fov_deg.to_radians() / 2.0).tan();
    let aspect = f64::from(size.0) / f64::from(size.1);
    let sx = (2.0 * (f64::from(pixel.0) + 0.5) / f64::from(size.0) - 1.0) * tan_half * aspect;
    let sy = (1.0 - 2.0 * (f64::from(pixel.1) + 0.5) / f64::from(size.1)) * tan_half;
    (forward + sx * right + sy * up).normalize()
}

/// Where a ray from inside the box room (0,0,0)–`size` first meets a wall, floor or ceiling:
/// the surface name (as the scene names it), the point and the inward normal.
fn room_hit(size: DVec3, eye: DVec3, dir: DVec3) -> (&'static str, DVec3, DVec3) {
    let planes = [
        ("floor", 2, 0.0, DVec3::Z),
        ("ceiling", 2, size.z, -DVec3::Z),
        ("wall-x0", 0, 0.0, DVec3::X),
        ("wall-x1", 0, size.x, -DVec3::X),
        ("wall-y0", 1, 0.0, DVec3::Y),
        ("wall-y1", 1, size.y, -DVec3::Y),
    ];
    planes
        .into_iter()
        .filter(|&(_, axis, _, _)| dir[axis] != 0.0)
        .map(|(name, axis, at, normal)| (name, (at - eye[axis]) / dir[axis], normal))
        .filter(|&(_, t, _)| t > 0.0)
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(name, t, normal)| (name, eye + t * dir, normal))
        .unwrap()
}

#[test]
fn picks_on_the_paper_room_land_on_the_analytic_ray_plane_intersection() {
    let scene = load("paper");
    // The room file's numbers, written out independently of the loader.
    let (eye, target, fov_deg) = (DVec3::new(0.5, 0.5, 1.6), DVec3::new(3.0, 2.0, 0.8), 60.0);
    let room_size = DVec3::new(6.0, 4.0, 2.7);
    let accent = DVec3::new(5.7, 0.3, 2.6);
    let half_patch = 0.1 / 2.0;
    let size = (1024, 768);
    for (pixel, expected_surface) in [
        ((512, 700), "floor"),
        ((100, 300), "wall-y1"),
        ((600, 15), "ceiling"),
    ] {
        let dir = pixel_ray(eye, target, fov_deg, size, pixel);
        let (surface, analytic, normal) = room_hit(room_size, eye, dir);
        assert_eq!(
            surface, expected_surface,
            "the test's pixel {pixel:?} must see the {expected_surface}"
        );
        let report = pick(
            &scene,
            size.0,
            size.1,
            Pixel {
                x: pixel.0,
                y: pixel.1,
            },
            Some("accent"),
        )
        .unwrap();
        assert_eq!(report.surface, expected_surface, "pixel {pixel:?}");
        let error = report.point.distance(analytic);
        assert!(
            error < half_patch,
            "pixel {pixel:?}: picked {} vs analytic {analytic}",
            report.point
        );
        assert!(
            report.normal.distance(normal) < 1e-12,
            "pixel {pixel:?}: normal {}",
            report.normal
        );
        // The picked patch is the one under the point: the point lies in its bounding box (to
        // 0.1 mm: vertices are snapped to 1/256 pixel, a few µm at this distance).
        assert_in_patch_bounds(
            &scene.fine,
            report.patch,
            report.point,
            1e-4,
            &format!("pixel {pixel:?}"),
        );
        let aim = report.aim.unwrap();
        assert!((aim.length() - 1.0).abs() < 1e-12);
        assert!(
            aim.distance((report.point - accent).normalize()) < 1e-12,
            "aim {aim}"
        );
    }
}

/// `point` lies in the bounding box of patch `patch` of `mesh`, to `margin` (m).
fn assert_in_patch_bounds(
    mesh: &haiko::scene::model::PatchMesh,
    patch: u32,
    point: DVec3,
    margin: f64,
    what: &str,
) {
    let corners = mesh.patches[patch as usize]
        .vertex_ids()
        .iter()
        .map(|&v| mesh.positions[v as usize]);
    let (lo, hi) = corners.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
        (lo.min(p), hi.max(p))
    });
    assert!(
        point.cmpge(lo - margin).all() && point.cmple(hi + margin).all(),
        "{what}: {point} outside patch {patch} [{lo}, {hi}]"
    );
}

#[test]
fn pick_rejects_bad_pixels_sizes_and_lights() {
    let scene = load("paper");
    let at = |x, y| Pixel { x, y };
    let cases = [
        (
            pick(&scene, 320, 240, at(320, 10), None),
            "outside the 320×240 image",
        ),
        (
            pick(&scene, 320, 240, at(10, 240), None),
            "outside the 320×240 image",
        ),
        (pick(&scene, 0, 240, at(0, 0), None), "--width"),
        (pick(&scene, 320, MAX_SIDE_PX + 1, at(0, 0), None), "--height"),
        (
            pick(&scene, 320, 240, at(10, 10), Some("spot")),
            "lights: centre, accent",
        ),
    ];
    for (k, (result, needle)) in cases.into_iter().enumerate() {
        let err = result.expect_err(&format!("case {k} must fail"));
        assert_eq!(err.exit_code(), 2, "case {k}: {err}");
        assert!(
            err.to_string().contains(needle),
            "case {k}: `{err}` lacks `{needle}`"
        );
    }
    for text in ["", "3", "3,", "-1,2", "1.5,2", "a,b", "1,2,3"] {
        assert!(text.parse::<Pixel>().is_err(), "`{text}` must not parse");
    }
    assert_eq!(" 7, 9".parse::<Pixel>(), Ok(at(7, 9)));
}

/// A copy of the paper room with the camera outside, looking away from the room.
fn room_looking_away(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(room("paper")).unwrap();
    let camera = text.find("[camera]").unwrap();
    let path = dir.join("away.toml");
    let away = "[camera]\neye = [-1.0, 2.0, 1.5]\ntarget = [-5.0, 2.0, 1.5]\nfov_deg = 60\n";
    std::fs::write(&path, format!("{}{away}", &text[..camera])).unwrap();
    path
}

#[test]
fn picking_the_background_is_an_input_error() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene::load(&room_looking_away(dir.path())).unwrap();
    let err = pick(&scene, 64, 48, Pixel { x: 32, y: 24 }, None).unwrap_err();
    assert_eq!(err.exit_code(), 2);
    assert!(
        err.to_string().contains("nothing at pixel 32,24 (background)"),
        "{err}"
    );
}

#[test]
fn pick_json_has_the_documented_shape() {
    let scene = load("paper");
    let report = pick(&scene, 1024, 768, Pixel { x: 512, y: 700 }, None).unwrap();
    let json = to_json(&report).unwrap();
    assert!(json.starts_with(&format!(
        "{{\"patch\": {}, \"surface\": \"floor\", \"point\": [",
        report.patch
    )));
    assert!(!json.contains("aim"), "{json}");
    let value: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(value["normal"], serde_json::json!([0.0, 0.0, 1.0]));
    assert_eq!(value["point"][2].as_f64().unwrap(), report.point.z);
}

// ---------------------------------------------------------------------------------------------
// The built binary.

fn haiko(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_haiko"))
        .args(args)
        .env(
            "HAIKO_CACHE_DIR",
            std::env::temp_dir().join("haiko-test-bake-cache"),
        )
        .output()
        .unwrap()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

#[test]
fn render_command_writes_a_png_of_the_asked_size_and_reports_stages() {
    let dir = tempfile::tempdir().unwrap();
    let paper = room("paper");
    for (mode, needle) in [("photo", "exposure"), ("false-color", "lux range")] {
        let out = dir.path().join(format!("{mode}.png"));
        let run = haiko(&[
            "render",
            paper.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--width",
            "200",
            "--height",
            "150",
            "--mode",
            mode,
        ]);
        let stdout = text(&run.stdout);
        assert!(run.status.success(), "{mode}: {}", text(&run.stderr));
        let image = tiny_skia::Pixmap::load_png(&out).unwrap();
        assert_eq!((image.width(), image.height()), (200, 150));
        for stage in [
            "load+mesh",
            "bake",
            "relight",
            "raster",
            "overlays",
            "png",
            needle,
        ] {
            assert!(stdout.contains(stage), "{mode}: no `{stage}` in {stdout}");
        }
    }
    // The default size.
    let out = dir.path().join("default.png");
    let run = haiko(&["render", paper.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert!(run.status.success(), "{}", text(&run.stderr));
    let image = tiny_skia::Pixmap::load_png(&out).unwrap();
    assert_eq!((image.width(), image.height()), (1024, 768));
}

#[test]
fn pick_command_prints_parseable_json_with_the_aim() {
    let paper = room("paper");
    let run = haiko(&[
        "pick",
        paper.to_str().unwrap(),
        "--pixel",
        "512,700",
        "--json",
        "--aim",
        "centre",
    ]);
    assert!(run.status.success(), "{}", text(&run.stderr));
    let value: serde_json::Value = serde_json::from_str(text(&run.stdout).trim()).unwrap();
    assert_eq!(value["surface"], "floor");
    let v = |key: &str| {
        let a = value[key].as_array().unwrap_or_else(|| panic!("{key} missing"));
        DVec3::new(
            a[0].as_f64().unwrap(),
            a[1].as_f64().unwrap(),
            a[2].as_f64().unwrap(),
        )
    };
    let (point, normal, aim) = (v("point"), v("normal"), v("aim"));
    assert!(point.z.abs() < 1e-4, "on the floor: {point}");
    assert_eq!(normal, DVec3::Z);
    assert!(
        aim.distance((point - DVec3::new(3.0, 2.0, 2.6)).normalize()) < 1e-12,
        "aim {aim}"
    );
    assert!(value["patch"].as_u64().is_some());
}

#[test]
fn bad_render_and_pick_input_exits_2_with_a_message() {
    let dir = tempfile::tempdir().unwrap();
    let paper = room("paper");
    let paper = paper.to_str().unwrap();
    let out = dir.path().join("x.png");
    let out = out.to_str().unwrap();
    let away = room_looking_away(dir.path());
    let cases: [(Vec<&str>, &str); 10] = [
        (vec!["render", paper, "-o", out, "--width", "0"], "--width"),
        (vec!["render", paper, "-o", out, "--exposure", "bright"], "bright"),
        (vec!["render", paper, "-o", out, "--view", "top"], "top"),
        (vec!["render", paper, "-o", out, "--height", "8193"], "--height"),
        (vec!["render", paper, "-o", out, "--mode", "sepia"], "sepia"),
        (
            vec!["pick", paper, "--pixel", "1024,0"],
            "outside the 1024×768 image",
        ),
        (
            vec!["pick", paper, "--pixel", "10,10", "--width", "9000"],
            "--width",
        ),
        (vec!["pick", paper, "--pixel", "ten,10"], "ten,10"),
        (
            vec!["pick", paper, "--pixel", "10,10", "--aim", "nope"],
            "lights: centre, accent",
        ),
        (
            vec!["pick", away.to_str().unwrap(), "--pixel", "5,5"],
            "nothing at pixel 5,5 (background)",
        ),
    ];
    for (args, needle) in cases {
        let run = haiko(&args);
        let stderr = text(&run.stderr);
        assert_eq!(run.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(needle), "{args:?}: `{stderr}` lacks `{needle}`");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    }
    assert!(!Path::new(out).exists(), "no image is written on bad input");
}

/// Every pixel of the office's room view (boxes, shelves, desks seen edge-on), picked: the point
/// lies on the picked patch (its plane to 1 nm, inside its corners' bounds), and the direct
/// light there — the lux under the editor's cursor, from the same shadow rays as `haiko probe`
/// — is what the pixel shows. The point unprojected from the f32 depth alone lies a few µm off
/// the surface, inside the box behind a box face for half of them, where the shadow ray starts
/// inside the box and finds 0 lx: 7 % of this view's pixels before picks were moved onto
/// their patch.
#[test]
fn every_picked_office_pixel_lies_on_its_patch_and_reads_the_probe_value() {
    let mut session = session(load("office"), false);
    let size = (240u32, 180u32);
    session.render(&spec(size, DisplayMode::FalseColor)).unwrap();
    let fine = load("office").fine;
    let (mut picked, mut differ) = (0, Vec::new());
    for y in 0..size.1 {
        for x in 0..size.0 {
            let Some(hit) = session.pick((x, y)) else { continue };
            picked += 1;
            let patch = &fine.patches[hit.patch as usize];
            let corners: Vec<DVec3> = patch
                .vertex_ids()
                .iter()
                .map(|&v| fine.positions[v as usize])
                .collect();
            assert!(
                (hit.point - corners[0]).dot(patch.normal).abs() < 1e-9,
                "({x}, {y}): {} off patch {}'s plane",
                hit.point,
                hit.patch
            );
            assert_in_patch_bounds(&fine, hit.patch, hit.point, 1e-9, &format!("({x}, {y})"));
            let receiver = haiko::scene::Receiver {
                point: hit.point,
                normal: hit.normal,
            };
            let probed = session
                .illuminance_at(&[receiver], true, haiko::scene::DirectMode::Exact)
                .unwrap()[0];
            if (hit.lux - probed).abs() > 0.05 * probed.max(1.0) {
                differ.push(((x, y), hit.point, hit.lux, probed));
            }
        }
    }
    // The view is full of surfaces; a pixel on a shadow line or a box corner may differ.
    assert!(picked > 40_000, "{picked} pixels picked");
    assert!(
        differ.len() * 1000 <= picked,
        "{} of {picked} pixels differ from the probe by > 5 %, e.g. {:?}",
        differ.len(),
        &differ[..differ.len().min(5)]
    );
}
