//! Illuminance at fixed receivers through the session (`illuminance_at`, watches, design
//! numbers) against the transport's reference gather and fresh evaluations after every kind of
//! edit, and the commands built on it — `check`, `glare`, `pick` (with `lux`) and `report` —
//! through the real binary, agreeing with `probe` at the same points.

use std::path::{Path, PathBuf};
use std::process::{Command as Process, Output};

use glam::DVec3;
use haiko::photometry::Curve;
use haiko::scene::{self, AimSpec, DirectMode, Receiver, Scene};
use haiko::session::{Command, Session, SessionOptions, WindowChoice};
use haiko::transport::bake::BakeOptions;
use haiko::transport::cache::BakeCache;
use haiko::transport::gather::illuminance_at_receivers;
use haiko::transport::plan::{EngineChoice, PlanOptions};

/// A small grey room with a desk (a box that shadows and reflects) and two lights, quick to
/// bake; desks as task areas and two observers.
const ROOM: &str = r#"version = 1
name = "Numbers"
[room]
size = [4.0, 3.0, 2.8]
[room.reflectance]
floor = 0.3
walls = 0.6
ceiling = 0.8

[[box]]
min = [1.0, 1.0, 0.0]
max = [2.2, 1.8, 0.72]
reflectance = 0.45

[[light]]
name = "a"
position = [1.2, 1.5, 2.5]
lid = [[0, 900], [30, 820], [60, 400], [90, 40], [120, 0]]
luminous_size = 0.3
[[light]]
name = "b"
position = [3.0, 1.5, 2.5]
aim = [3.0, 1.0, 0.0]
lid = [[0, 1200], [25, 1000], [50, 300], [70, 0]]
dimmer = 0.8
luminous_size = [0.4, 0.2]

[[surface]]
name = "desk"
height = 0.72
min = [1.0, 1.0]
max = [2.2, 1.8]
task = "office-writing"

[[surface]]
name = "work plane"

[[observer]]
name = "east chair"
eye = [3.6, 1.5, 1.2]
view_dir = [-1.0, 0.0, 0.0]

[[observer]]
name = "south chair"
eye = [2.0, 0.3, 1.2]
view_dir = [0.0, 1.0, 0.0]

[settings]
patch_size = 0.25
solver_patch_size = 0.5
"#;

fn write_room(dir: &Path) -> PathBuf {
    let path = dir.join("numbers.toml");
    std::fs::write(&path, ROOM).unwrap();
    path
}

/// A session with a bake cache in `cache` and the indirect engine `engine`.
fn cached_session(scene: Scene, cache: &Path, engine: EngineChoice) -> Session {
    let options = SessionOptions {
        bake: BakeOptions {
            cache: Some(BakeCache::in_dir(cache)),
            plan: PlanOptions {
                engine,
                ..PlanOptions::default()
            },
            ..BakeOptions::default()
        },
        indirect: true,
        ..SessionOptions::default()
    };
    Session::new(scene, options, &mut |_| {}).expect("the room bakes")
}

/// Receivers on the floor, the desk top, a wall and in the air, facing different ways.
fn receivers() -> Vec<Receiver> {
    let at = |p: [f64; 3], n: [f64; 3]| Receiver {
        point: DVec3::from_array(p),
        normal: DVec3::from_array(n).normalize(),
    };
    vec![
        at([0.5, 0.5, 0.0], [0.0, 0.0, 1.0]),
        at([1.6, 1.4, 0.72], [0.0, 0.0, 1.0]),
        at([1.6, 0.6, 0.0], [0.0, 0.0, 1.0]),
        at([2.4, 1.4, 0.3], [0.0, 0.0, 1.0]),
        at([0.0, 1.5, 1.4], [1.0, 0.0, 0.0]),
        at([3.5, 2.5, 1.0], [-1.0, -1.0, 0.5]),
        at([2.0, 1.5, 2.8], [0.0, 0.0, -1.0]),
    ]
}

/// `got` equals `want` to `tol` of the largest value.
fn assert_close(got: &[f64], want: &[f64], tol: f64, what: &str) {
    assert_eq!(got.len(), want.len(), "{what}");
    let peak = want.iter().fold(0.0_f64, |m, &x| m.max(x.abs()));
    assert!(peak > 0.0, "{what}: lit");
    for (k, (g, w)) in got.iter().zip(want).enumerate() {
        assert!((g - w).abs() <= tol * peak, "{what}: receiver {k}: {g} vs {w}");
    }
}

#[test]
fn probe_points_equal_the_transport_reference_gather() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene::load(&write_room(dir.path())).unwrap();
    // The transport's reference gather is the SH basis engine's.
    let mut session = cached_session(scene.clone(), dir.path(), EngineChoice::Basis);
    let bake = session.bake().cloned().expect("a bake");
    let rx = receivers();
    for mode in [DirectMode::Exact, DirectMode::Basis] {
        let got = session.illuminance_at(&rx, false, mode).unwrap();
        let want = illuminance_at_receivers(&scene, Some(&bake), mode, &rx);
        assert_close(&got, &want, 1e-12, &format!("{mode:?}"));
    }
    let direct = session.illuminance_at(&rx, true, DirectMode::Exact).unwrap();
    let want = illuminance_at_receivers(&scene, None, DirectMode::Exact, &rx);
    assert_close(&direct, &want, 1e-12, "direct only");
    // A grey room: the interreflected light adds to the direct light at every receiver.
    let with = session.illuminance_at(&rx, false, DirectMode::Exact).unwrap();
    assert!(
        with.iter().zip(&direct).all(|(w, d)| w > d),
        "interreflection adds light"
    );
}

/// After every kind of edit the watched points equal a fresh evaluation of the edited lights.
#[test]
fn watched_points_follow_every_kind_of_edit() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene::load(&write_room(dir.path())).unwrap();
    let mut session = cached_session(scene, dir.path(), EngineChoice::Auto);
    let rx = receivers();
    let id = session.watch(rx.clone());
    let before = session.watched(id).unwrap().lux().to_vec();
    let fresh = session.illuminance_at(&rx, false, DirectMode::Exact).unwrap();
    assert_close(&before, &fresh, 1e-12, "initial");

    let mut copy = session.lights()[1].clone();
    copy.name = "b copy".into();
    copy.position = DVec3::new(3.0, 2.4, 2.5);
    let edits = [
        Command::SetDimmer {
            light: 0,
            dimmer: 0.5,
        },
        Command::SetIntensity {
            light: 0,
            point: 1,
            candela: 1000.0,
        },
        Command::SetGamma {
            light: 1,
            point: 1,
            gamma_deg: 35.0,
        },
        Command::SetCurve {
            light: 1,
            curve: Curve::new(&[(0.0, 500.0), (80.0, 500.0), (90.0, 0.0)]).unwrap(),
        },
        Command::Aim {
            light: 0,
            spec: AimSpec::Target(DVec3::new(0.5, 0.5, 0.0)),
        },
        Command::SetWindow {
            light: 0,
            window: WindowChoice::Hann,
        },
        Command::Move {
            light: 0,
            position: DVec3::new(0.8, 2.2, 2.4),
        },
        Command::Insert {
            at: 2,
            light: Box::new(copy),
        },
        Command::Remove { light: 1 },
    ];
    for command in edits {
        let what = format!("{command:?}");
        session.apply(command).unwrap();
        session.run_bake_jobs(&mut |_| {}).unwrap();
        let watched = session.watched(id).unwrap().lux().to_vec();
        let fresh = session.illuminance_at(&rx, false, DirectMode::Exact).unwrap();
        assert_close(&watched, &fresh, 1e-12, &what);
    }
    session.unwatch(id);
    assert!(session.watched(id).is_none());
}

/// One light in a black room: halving its dimmer halves the light at every watched point
/// (no interreflection to blur it), and the numbers are the inverse-square law.
#[test]
fn a_dimmer_edit_scales_the_watched_light_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let text = "version = 1
[room]
size = [3.0, 3.0, 3.0]
[room.reflectance]
floor = 0.0
walls = 0.0
ceiling = 0.0
[[light]]
name = \"iso\"
position = [1.5, 1.5, 2.0]
lid = [[0, 1000], [180, 1000]]
";
    let path = dir.path().join("black.toml");
    std::fs::write(&path, text).unwrap();
    let mut session = cached_session(scene::load(&path).unwrap(), dir.path(), EngineChoice::Auto);
    // Straight below at 2 m: 1000/4 = 250 lx; 1 m aside: 1000·2/5^1.5 = 178.885 lx.
    let rx = vec![
        Receiver {
            point: DVec3::new(1.5, 1.5, 0.0),
            normal: DVec3::Z,
        },
        Receiver {
            point: DVec3::new(2.5, 1.5, 0.0),
            normal: DVec3::Z,
        },
    ];
    let id = session.watch(rx);
    let lux = session.watched(id).unwrap().lux().to_vec();
    assert!(
        (lux[0] - 250.0).abs() < 1e-9 && (lux[1] - 2000.0 / 5f64.powf(1.5)).abs() < 1e-9,
        "{lux:?}"
    );
    session
        .apply(Command::SetDimmer {
            light: 0,
            dimmer: 0.24,
        })
        .unwrap();
    let dimmed = session.watched(id).unwrap().lux().to_vec();
    assert!((dimmed[0] - 60.0).abs() < 1e-9, "{dimmed:?}");
    assert!((dimmed[1] - 0.24 * lux[1]).abs() < 1e-9, "{dimmed:?}");
}

#[test]
fn design_numbers_are_the_probe_values_at_the_grid_points() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene::load(&write_room(dir.path())).unwrap();
    let mut session = cached_session(scene, dir.path(), EngineChoice::Auto);
    for round in 0..2 {
        let numbers = session.design_numbers();
        assert_eq!(numbers.surfaces.len(), 2);
        for s in &numbers.surfaces {
            let probe = session
                .illuminance_at(&s.grid.receivers, false, DirectMode::Exact)
                .unwrap();
            assert_close(&s.lux, &probe, 1e-12, &s.grid.name);
            let stats = s.stats.unwrap();
            let mean = probe.iter().sum::<f64>() / probe.len() as f64;
            assert!((stats.e_avg - 0.8 * mean).abs() < 1e-9 * mean, "{}", s.grid.name);
        }
        // The desk: 1.2 × 0.8 m, the longer edge not twice the shorter, so d = 1.2 m and
        // p = 0.2 × 5^log10(1.2) = 0.2272 m: 1.2 / 0.2272 = 5.28 → 5 cells of 0.24 m, then
        // 0.8 / 0.24 = 3.33 → 3 cells: 15 points.
        assert_eq!(numbers.surfaces[0].grid.receivers.len(), 15);
        assert_eq!(numbers.observers.len(), 2);
        if round == 0 {
            session
                .apply(Command::SetDimmer {
                    light: 1,
                    dimmer: 0.3,
                })
                .unwrap();
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The built binary.

fn haiko(cache: &Path, args: &[&str]) -> Output {
    Process::new(env!("CARGO_BIN_EXE_haiko"))
        .args(args)
        .env("HAIKO_CACHE_DIR", cache)
        .output()
        .expect("the binary runs")
}

fn ok_stdout(o: &Output) -> String {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn json(o: &Output) -> serde_json::Value {
    serde_json::from_str(&ok_stdout(o)).expect("JSON")
}

fn vec3(v: &serde_json::Value) -> [f64; 3] {
    let a = v.as_array().expect("an array");
    [0, 1, 2].map(|k| a[k].as_f64().expect("a number"))
}

/// `haiko probe` at `points` (point, normal): the lux column.
fn probe(cache: &Path, room: &Path, points: &[([f64; 3], [f64; 3])]) -> Vec<f64> {
    let mut csv = String::from("x,y,z,nx,ny,nz\n");
    for (p, n) in points {
        csv.push_str(&format!(
            "{:?},{:?},{:?},{:?},{:?},{:?}\n",
            p[0], p[1], p[2], n[0], n[1], n[2]
        ));
    }
    let file = room.with_extension("points.csv");
    std::fs::write(&file, csv).unwrap();
    let out = ok_stdout(&haiko(
        cache,
        &[
            "probe",
            room.to_str().unwrap(),
            "--points",
            file.to_str().unwrap(),
        ],
    ));
    out.lines()
        .skip(1)
        .map(|l| l.rsplit(',').next().unwrap().parse().unwrap())
        .collect()
}

#[test]
fn check_json_agrees_with_probe_and_its_own_statistics() {
    let dir = tempfile::tempdir().unwrap();
    let room = write_room(dir.path());
    let v = json(&haiko(dir.path(), &["check", room.to_str().unwrap(), "--json"]));
    assert_eq!(v["maintenance_factor"], 0.8);
    let surfaces = v["surfaces"].as_array().unwrap();
    assert_eq!(surfaces[0]["name"], "desk");
    assert_eq!(surfaces[0]["task"], "office-writing");
    for s in surfaces {
        let points: Vec<([f64; 3], [f64; 3])> = s["points_lux"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| (vec3(&p["point"]), vec3(&p["normal"])))
            .collect();
        let lux: Vec<f64> = s["points_lux"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| p["lux"].as_f64().unwrap())
            .collect();
        assert_eq!(points.len(), s["points"].as_u64().unwrap() as usize);
        // probe prints 6 decimals.
        let probed = probe(dir.path(), &room, &points);
        for (a, b) in lux.iter().zip(&probed) {
            assert!((a - b).abs() < 1e-6 + 1e-12 * a, "{}: {a} vs {b}", s["name"]);
        }
        let n = lux.len() as f64;
        let mean = lux.iter().sum::<f64>() / n;
        let min = lux.iter().copied().fold(f64::INFINITY, f64::min);
        let max = lux.iter().copied().fold(0.0, f64::max);
        let stats = &s["stats"];
        let close = |key: &str, want: f64| {
            let got = stats[key].as_f64().unwrap();
            assert!(
                (got - want).abs() < 1e-9 * want.max(1.0),
                "{key}: {got} vs {want}"
            );
        };
        close("e_avg", 0.8 * mean);
        close("e_min", 0.8 * min);
        close("e_max", 0.8 * max);
        close("u0", min / mean);
        close("g2", min / max);
        // The verdict follows from the targets: the desk's preset asks 500 lx and U0 0.6.
        if s["name"] == "desk" {
            let e = 0.8 * mean;
            assert_eq!(s["check"]["e_avg"]["target"], 500.0);
            assert_eq!(s["check"]["e_avg"]["pass"], e >= 500.0);
            assert_eq!(s["check"]["u0"]["pass"], min / mean >= 0.6);
        }
    }
    // The text table shows the same mean, rounded.
    let text = ok_stdout(&haiko(dir.path(), &["check", room.to_str().unwrap()]));
    let desk_mean = surfaces[0]["stats"]["e_avg"].as_f64().unwrap();
    let row = text.lines().find(|l| l.starts_with("desk ")).unwrap();
    assert!(row.contains(&format!("{desk_mean:.0}")), "{row}");
    assert!(text.contains("maintenance factor 0.80"), "{text}");
}

#[test]
fn glare_json_components_reproduce_each_ugr() {
    let dir = tempfile::tempdir().unwrap();
    let room = write_room(dir.path());
    let v = json(&haiko(dir.path(), &["glare", room.to_str().unwrap(), "--json"]));
    let observers = v["observers"].as_array().unwrap();
    assert_eq!(observers.len(), 2);
    let mut rated = 0;
    for o in observers {
        let lb = o["background_luminance"].as_f64().unwrap();
        // L_b = E_ind / π, with E_ind the gathered indirect light at the eye (> 0: a grey room).
        let e_ind = o["indirect_lux"].as_f64().unwrap();
        assert!(e_ind > 0.0 && (lb - e_ind / std::f64::consts::PI).abs() < 1e-12 * lb);
        let mut sum = 0.0;
        for s in o["sources"].as_array().unwrap() {
            if s["status"] != "counted" {
                continue;
            }
            let (l, omega, p) = (
                s["luminance"].as_f64().unwrap(),
                s["solid_angle_sr"].as_f64().unwrap(),
                s["position_index"].as_f64().unwrap(),
            );
            // Each term is L² ω / p², and L = I / A_p.
            let term = l * l * omega / (p * p);
            assert!((term - s["term"].as_f64().unwrap()).abs() <= 1e-9 * term);
            let area = s["projected_area_m2"].as_f64().unwrap();
            assert!((l * area - s["intensity_cd"].as_f64().unwrap()).abs() < 1e-9 * l * area);
            sum += term;
        }
        if let Some(ugr) = o["ugr"].as_f64() {
            rated += 1;
            let again = 8.0 * (0.25 / lb * sum).log10();
            assert!((again - ugr).abs() < 0.1, "{}: {again} vs {ugr}", o["name"]);
            assert!((again - ugr).abs() < 1e-9, "exactly the formula");
        }
    }
    assert!(rated >= 1, "at least one observer sees a luminaire");
    let text = ok_stdout(&haiko(dir.path(), &["glare", room.to_str().unwrap()]));
    assert!(text.contains("east chair") && text.contains("L_b"), "{text}");
}

#[test]
fn pick_json_lux_is_the_probe_value_at_the_picked_point() {
    let dir = tempfile::tempdir().unwrap();
    let room = write_room(dir.path());
    let room_arg = room.to_str().unwrap();
    for pixel in ["512,700", "300,400"] {
        let v = json(&haiko(
            dir.path(),
            &["pick", room_arg, "--pixel", pixel, "--json"],
        ));
        let (point, normal) = (vec3(&v["point"]), vec3(&v["normal"]));
        let lux = v["lux"].as_f64().unwrap();
        let probed = probe(dir.path(), &room, &[(point, normal)])[0];
        assert!(
            lux > 0.0 && (lux - probed).abs() < 1e-6,
            "{pixel}: {lux} vs {probed}"
        );
    }
    let v = json(&haiko(
        dir.path(),
        &["pick", room_arg, "--pixel", "512,700", "--json", "--direct-only"],
    ));
    let direct = v["lux"].as_f64().unwrap();
    let both = json(&haiko(
        dir.path(),
        &["pick", room_arg, "--pixel", "512,700", "--json"],
    ))["lux"]
        .as_f64()
        .unwrap();
    assert!(direct < both, "indirect light adds to {direct}");
}

#[test]
fn report_command_writes_one_self_contained_file() {
    let dir = tempfile::tempdir().unwrap();
    let room = write_room(dir.path());
    let out = dir.path().join("report.html");
    let stdout = ok_stdout(&haiko(
        dir.path(),
        &[
            "report",
            room.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--width",
            "300",
            "--height",
            "200",
        ],
    ));
    assert!(stdout.contains("report written to"), "{stdout}");
    let html = std::fs::read_to_string(&out).unwrap();
    assert_eq!(html.matches("src=\"data:image/png;base64,").count(), 3);
    assert!(!html.contains("<script") && !html.contains("http://") && !html.contains("https://"));
    for needle in [
        "Lighting report: Numbers",
        "Plan: new illuminance in false colour",
        "<h2>Calculation surfaces</h2>",
        "desk: maintained illuminance at the grid points (lx)",
        "<h2>Glare (UGR, CIE 117)</h2>",
        "east chair",
        "<h2>Luminaire schedule</h2>",
        "Indirect engine refinement",
        "False colour, new illuminance",
    ] {
        assert!(html.contains(needle), "no `{needle}`");
    }
    // The desk's mean in the table is `haiko check`'s.
    let v = json(&haiko(dir.path(), &["check", room.to_str().unwrap(), "--json"]));
    let mean = v["surfaces"][0]["stats"]["e_avg"].as_f64().unwrap();
    assert!(
        html.contains(&format!("<td class=\"n\">{mean:.0}")),
        "desk mean {mean:.0}"
    );
}
