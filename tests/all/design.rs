//! Design numbers: the room file's `[[surface]]`, `[[observer]]`, `maintenance_factor` and
//! `luminous_size` (defaults, presets, one test per kind of bad input with its place), the
//! photometric files' luminous areas and C-plane spread, the metrics of whole scenes against
//! closed-form values, the luminaire schedule and the HTML report.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use glam::{DVec2, DVec3};
use haiko::metrics::SurfaceResult;
use haiko::metrics::evaluate::{eye_receivers, glare_with};
use haiko::metrics::{SourceStatus, UgrStatus, luminaire_schedule};
use haiko::photometry::{LuminousShape, read_lid_file};
use haiko::render::shade::{FalseColor, LuxScale};
use haiko::report::{ReportImage, ReportInput, base64, html};
use haiko::scene::design::{Placement, RoomSurface, TaskPreset};
use haiko::scene::{Scene, load};
use haiko::session::{Session, SessionOptions};
use haiko::transport::occlusion::Occluders;
use haiko::transport::visibility::Visibility;

fn data(relative: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(relative)
}

fn rooms_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("rooms")
}

const ROOM: &str = "version = 1
[room]
size = [8.0, 6.0, 3.0]
[room.reflectance]
floor = 0.2
walls = 0.5
ceiling = 0.7

[[box]]
min = [2.0, 1.2, 0.0]
max = [3.6, 2.0, 0.75]
reflectance = 0.4

[[light]]
name = \"a\"
position = [4.0, 3.0, 2.8]
lid = [[0, 1000], [90, 0]]
";

/// The surfaces' numbers by direct light only (no bake), through the session.
fn direct_surfaces(scene: Scene) -> Vec<SurfaceResult> {
    let options = SessionOptions {
        indirect: false,
        ..SessionOptions::default()
    };
    Session::new(scene, options, &mut |_| {})
        .unwrap()
        .design_numbers()
        .surfaces
}

fn write_room(dir: &Path, text: &str) -> PathBuf {
    let path = dir.join("design.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// Loads `ROOM` + `extra` and returns the error message (one line, exit code 2, naming the file).
fn design_error(extra: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let text = format!("{ROOM}{extra}");
    let err = match load(&write_room(dir.path(), &text)) {
        Ok(_) => panic!("loaded:\n{extra}"),
        Err(e) => e,
    };
    assert_eq!(err.exit_code(), 2, "{err}");
    let message = err.to_string();
    assert!(
        message.contains("design.toml") && !message.contains('\n'),
        "{message}"
    );
    message
}

#[test]
fn office_gets_the_default_design_and_its_ldt_luminous_disc() {
    let scene = load(&rooms_dir().join("office.toml")).unwrap();
    let d = &scene.design;
    assert!(d.default_surfaces && d.default_observers);
    assert_eq!(d.maintenance_factor, 0.8);
    assert_eq!(d.surfaces.len(), 1);
    assert_eq!(
        d.surfaces[0].placement,
        Placement::Horizontal {
            height_m: 0.8,
            min: DVec2::new(0.5, 0.5),
            max: DVec2::new(7.5, 5.5)
        }
    );
    // The cabinet stands in the middle of the x = 0 wall: that default observer is dropped.
    let names: Vec<&str> = d.observers.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(names, vec!["wall-y0 middle", "wall-x1 middle", "wall-y1 middle"]);
    assert_eq!(
        d.dropped_observers,
        vec!["wall-x0 middle (the eye is inside box[4])".to_string()]
    );
    // sample_09.ldt: luminous area 662 mm, width 0 → a disc Ø 0.662 m.
    for light in &scene.lights {
        assert_eq!(
            light.luminous,
            Some(LuminousShape::Ellipse {
                length_m: 0.662,
                width_m: 0.662,
                side_height_m: 0.0
            })
        );
    }
}

#[test]
fn surfaces_observers_and_luminous_sizes_load() {
    let dir = tempfile::tempdir().unwrap();
    let text = format!(
        "{ROOM}luminous_size = [0.6, 0.3, 0.05]
[[light]]
name = \"b\"
position = [6.0, 3.0, 2.8]
lid = [[0, 1000], [90, 0]]
luminous_size = 0.2

[settings]
maintenance_factor = 0.67

[[surface]]
name = \"desk\"
height = 0.75
min = [2.0, 1.2]
max = [3.6, 2.0]
task = \"office-writing\"
target_u0 = 0.7

[[surface]]
on = \"walls\"
margin = 0.1
task = \"walls\"
spacing = 0.5

[[surface]]
target_lux = 300
target_g2 = 0.4

[[observer]]
name = \"desk chair\"
eye = [2.8, 0.6, 1.2]
view_dir = [0.0, 2.0, 0.0]
ugr_limit = 22
"
    );
    let scene = load(&write_room(dir.path(), &text)).unwrap();
    let d = &scene.design;
    assert_eq!(d.maintenance_factor, 0.67);
    assert!(!d.default_surfaces && !d.default_observers);
    let desk = &d.surfaces[0];
    assert_eq!(desk.name, "desk");
    assert_eq!(desk.task.map(|t| t.name), Some("office-writing"));
    // The preset's 500 lx and UGR 19 stay; the file's U0 replaces the preset's 0.6.
    assert_eq!(desk.targets.maintained_lux, Some(500.0));
    assert_eq!(desk.targets.u0, Some(0.7));
    assert_eq!(desk.targets.ugr_limit, Some(19.0));
    let walls = &d.surfaces[1];
    assert_eq!(walls.name, "walls");
    assert_eq!(
        walls.placement,
        Placement::Room {
            surfaces: RoomSurface::WALLS.to_vec(),
            margin_m: 0.1
        }
    );
    assert_eq!(walls.max_cell_m, Some(0.5));
    assert_eq!(walls.targets, TaskPreset::find("walls").unwrap().targets);
    // Without min/max a horizontal surface covers the room without the 0.5 m band, at 0.8 m.
    let plane = &d.surfaces[2];
    assert_eq!(plane.name, "surface[2]");
    assert_eq!(
        plane.placement,
        Placement::Horizontal {
            height_m: 0.8,
            min: DVec2::new(0.5, 0.5),
            max: DVec2::new(7.5, 5.5)
        }
    );
    assert_eq!(
        (plane.targets.maintained_lux, plane.targets.g2),
        (Some(300.0), Some(0.4))
    );
    let o = &d.observers[0];
    assert_eq!(
        (o.name.as_str(), o.view, o.ugr_limit),
        ("desk chair", DVec3::Y, Some(22.0))
    );
    assert_eq!(
        scene.lights[0].luminous,
        Some(LuminousShape::Rectangle {
            length_m: 0.6,
            width_m: 0.3,
            side_heights_m: [0.05; 4]
        })
    );
    assert_eq!(
        scene.lights[1].luminous,
        Some(LuminousShape::Ellipse {
            length_m: 0.2,
            width_m: 0.2,
            side_height_m: 0.0
        })
    );
}

#[test]
fn unknown_task_names_the_presets() {
    let m = design_error("[[surface]]\ntask = \"office\"\n");
    assert!(m.contains("line 19, column 8 (surface[0].task)"), "{m}");
    assert!(
        m.contains("unknown task `office`") && m.contains("office-writing"),
        "{m}"
    );
}

#[test]
fn surface_height_outside_the_room_is_rejected() {
    let m = design_error("[[surface]]\nheight = 3.0\n");
    assert!(
        m.contains("line 19, column 10 (surface[0].height)") && m.contains("below the ceiling"),
        "{m}"
    );
}

#[test]
fn min_without_max_and_margin_with_a_rectangle_are_rejected() {
    let m = design_error("[[surface]]\nmin = [1.0, 1.0]\n");
    assert!(
        m.contains("surface[0]") && m.contains("both `min` and `max`"),
        "{m}"
    );
    let m = design_error("[[surface]]\nmin = [1.0, 1.0]\nmax = [2.0, 2.0]\nmargin = 0.5\n");
    assert!(m.contains("line 21, column 10 (surface[0].margin)"), "{m}");
    let m = design_error("[[surface]]\nmin = [1.0, 1.0]\nmax = [9.0, 2.0]\n");
    assert!(
        m.contains("(surface[0].min)") && m.contains("inside the room"),
        "{m}"
    );
    let m = design_error("[[surface]]\nmin = [2.0, 1.0]\nmax = [1.0, 2.0]\n");
    assert!(m.contains("(surface[0].max)") && m.contains("exceed min"), "{m}");
}

#[test]
fn room_surface_names_and_their_exclusions_are_checked() {
    let m = design_error("[[surface]]\non = \"roof\"\n");
    assert!(
        m.contains("(surface[0].on)") && m.contains("unknown room surface `roof`"),
        "{m}"
    );
    let m = design_error("[[surface]]\non = \"floor\"\nheight = 0.8\n");
    assert!(
        m.contains("(surface[0].height)") && m.contains("horizontal surface"),
        "{m}"
    );
    let m = design_error("[[surface]]\non = \"walls\"\nmargin = 1.5\n");
    assert!(m.contains("(surface[0].margin)") && m.contains("3 m edge"), "{m}");
}

#[test]
fn targets_out_of_range_are_rejected() {
    let m = design_error("[[surface]]\ntarget_u0 = 1.5\n");
    assert!(
        m.contains("line 19, column 13 (surface[0].target_u0)") && m.contains("> 0 and ≤ 1"),
        "{m}"
    );
    let m = design_error("[[surface]]\ntarget_lux = -5\n");
    assert!(m.contains("(surface[0].target_lux)"), "{m}");
    let m = design_error("[[surface]]\ntarget_ugr = 45\n");
    assert!(
        m.contains("(surface[0].target_ugr)") && m.contains("> 0 and ≤ 40"),
        "{m}"
    );
    let m = design_error("[settings]\nmaintenance_factor = 1.2\n");
    assert!(
        m.contains("line 19, column 22 (settings.maintenance_factor)"),
        "{m}"
    );
}

#[test]
fn a_spacing_that_makes_millions_of_points_is_rejected() {
    let m = design_error("[[surface]]\nspacing = 0.001\n");
    assert!(
        m.contains("(surface[0].spacing)") && m.contains("use a larger spacing"),
        "{m}"
    );
}

#[test]
fn observers_must_look_horizontally_from_inside_the_room() {
    let m = design_error("[[observer]]\neye = [1.0, 1.0, 1.2]\nview_dir = [0.0, 1.0, -0.2]\n");
    assert!(
        m.contains("line 20, column 12 (observer[0].view_dir)") && m.contains("horizontal"),
        "{m}"
    );
    let m = design_error("[[observer]]\neye = [9.0, 1.0, 1.2]\nview_dir = [0.0, 1.0, 0.0]\n");
    assert!(
        m.contains("(observer[0].eye)") && m.contains("inside the room"),
        "{m}"
    );
    let m = design_error("[[observer]]\neye = [3.0, 1.5, 0.5]\nview_dir = [0.0, 1.0, 0.0]\n");
    assert!(m.contains("(observer[0].eye)") && m.contains("box[0]"), "{m}");
    let m = design_error("[[observer]]\neye = [3.0, 0.5, 1.2]\n");
    assert!(m.contains("view_dir"), "{m}");
}

#[test]
fn luminous_size_needs_one_to_three_positive_numbers() {
    let m = design_error("luminous_size = [0.6]\n");
    assert!(
        m.contains("line 18, column 17 (light[0].luminous_size)") && m.contains("1 numbers"),
        "{m}"
    );
    let m = design_error("luminous_size = [0.6, 0.0]\n");
    assert!(m.contains("must be > 0"), "{m}");
    let m = design_error("luminous_size = \"big\"\n");
    assert!(m.contains("luminous size"), "{m}");
}

#[test]
fn photometric_files_carry_their_luminous_area() {
    // relative.ies: units 2 (metres), width 0.1, length 0.1, height 0.05: a box with luminous sides.
    let ies = read_lid_file(&data("ies/relative.ies")).unwrap();
    assert_eq!(
        ies.luminous,
        Some(LuminousShape::Rectangle {
            length_m: 0.1,
            width_m: 0.1,
            side_heights_m: [0.05; 4]
        })
    );
    // A point source (0 0 0) has none.
    assert_eq!(read_lid_file(&data("ies/isotropic.ies")).unwrap().luminous, None);
    // sample_01.ldt: luminous area 1480 × 63 mm, heights 0.
    let ldt = read_lid_file(&data("ldt/sample_01.ldt")).unwrap();
    assert_eq!(
        ldt.luminous,
        Some(LuminousShape::Rectangle {
            length_m: 1.48,
            width_m: 0.063,
            side_heights_m: [0.0; 4]
        })
    );
}

#[test]
fn c_plane_spread_brackets_the_average() {
    // quadrant.ies: planes I0(γ)(1 + 0.2 cos 2C), I0 = 1000, 800, 500, 100 cd.
    let lid = read_lid_file(&data("ies/quadrant.ies")).unwrap();
    assert_eq!(lid.spread.min_cd, vec![800.0, 640.0, 400.0, 80.0]);
    let max: Vec<f64> = lid
        .spread
        .max_cd
        .iter()
        .map(|v| (v * 1e9).round() / 1e9)
        .collect();
    assert_eq!(max, vec![1200.0, 960.0, 600.0, 120.0]);
    assert!(lid.warns_asymmetry()); // asymmetry 0.2 > 0.1
    // An axially symmetric file has no spread and no warning.
    let sym = read_lid_file(&data("ies/isotropic.ies")).unwrap();
    assert_eq!(sym.spread.min_cd, sym.curve.intensities_cd());
    assert_eq!(sym.spread.max_cd, sym.curve.intensities_cd());
    assert!(!sym.warns_asymmetry());
}

/// A black room (ρ = 0) with an isotropic 1000 cd light at (0.5, 1, 2.8) and a 3 × 1 m task
/// area at 0.8 m with 1 m cells: points at x = 0.5, 1.5, 2.5 (y = 1), h = 2 m below the light.
#[test]
fn task_area_statistics_match_the_inverse_square_law() {
    let dir = tempfile::tempdir().unwrap();
    let text = "version = 1
[room]
size = [3.0, 2.0, 3.0]
[room.reflectance]
floor = 0.0
walls = 0.0
ceiling = 0.0
[[light]]
name = \"iso\"
position = [0.5, 1.0, 2.8]
lid = [[0, 1000], [180, 1000]]
[[surface]]
name = \"strip\"
height = 0.8
min = [0.0, 0.5]
max = [3.0, 1.5]
spacing = 1.0
target_lux = 150
target_u0 = 0.5
";
    let scene = load(&write_room(dir.path(), text)).unwrap();
    let results = direct_surfaces(scene);
    let r = &results[0];
    // E = I h / (d² + h²)^1.5: d = 0 → 2000/8 = 250; d = 1 → 2000/5^1.5 = 178.885;
    // d = 2 → 2000/8^1.5 = 88.388 lx.
    let expected = [250.0, 2000.0 / 5f64.powf(1.5), 2000.0 / 8f64.powf(1.5)];
    for (e, x) in r.lux.iter().zip(expected) {
        assert!((e - x).abs() < 1e-9, "{e} vs {x}");
    }
    // Mean new 172.424 lx; maintained (0.8) Ē = 137.939, E_min = 70.711, E_max = 200;
    // U0 = 88.388 / 172.424 = 0.51262; g2 = 88.388 / 250 = 0.353553.
    let s = r.stats.unwrap();
    let mean = expected.iter().sum::<f64>() / 3.0;
    assert!((s.e_avg - 0.8 * mean).abs() < 1e-9 && (s.e_avg - 137.939).abs() < 1e-3);
    assert!((s.e_min - 70.711).abs() < 1e-3 && (s.e_max - 200.0).abs() < 1e-9);
    assert!((s.u0 - 0.51262).abs() < 1e-5 && (s.g2 - 0.353553).abs() < 1e-6);
    let c = r.check.unwrap();
    assert_eq!(
        (c.e_avg.pass, c.u0.pass, c.pass()),
        (Some(false), Some(true), Some(false))
    );
}

#[test]
fn office_glare_components_reproduce_each_ugr() {
    // Without a bake, give every eye 100 lx of indirect light; the reported components must
    // give back each observer's UGR through the CIE 117 formula.
    let scene = load(&rooms_dir().join("office.toml")).unwrap();
    let eyes = eye_receivers(&scene);
    let occluders = Occluders::of_scene(&scene);
    let glare = glare_with(
        &scene,
        &vec![100.0; eyes.len()],
        occluders.as_ref().map(|o| o as &dyn Visibility),
    );
    assert_eq!(glare.len(), 3);
    for g in &glare {
        assert_eq!(g.status, UgrStatus::Rated, "{}", g.name);
        assert!((g.background_luminance - 100.0 / PI).abs() < 1e-12);
        let sum: f64 = g
            .sources
            .iter()
            .filter(|s| s.status == SourceStatus::Counted)
            .map(|s| s.luminance * s.luminance * s.solid_angle_sr / (s.position_index * s.position_index))
            .sum();
        let again = 8.0 * (0.25 / g.background_luminance * sum).log10();
        assert!(
            (again - g.ugr.unwrap()).abs() < 0.1,
            "{}: {again} vs {:?}",
            g.name,
            g.ugr
        );
        // Lights above a seated eye at the wall are in front of it or behind it, never below.
        assert!(
            g.sources
                .iter()
                .all(|s| s.status != SourceStatus::AtOrBelowEyeLevel)
        );
    }
    // From the middle of the y = 0 wall (eye 1.2 m, looking +y) the near row (y = 1.5: 1.5 m
    // ahead, 1.2 m up, H/R = 0.8) is in view.
    let front = &glare[0];
    assert_eq!(front.name, "wall-y0 middle");
    let d21 = front.sources.iter().find(|s| s.name == "d21").unwrap();
    assert_eq!(d21.status, SourceStatus::Counted);
    assert!((d21.r_m - 1.5).abs() < 1e-12 && (d21.h_m - 1.2).abs() < 1e-12);
}

#[test]
fn office_schedule_groups_the_six_downlights() {
    let scene = load(&rooms_dir().join("office.toml")).unwrap();
    let rows = luminaire_schedule(&scene);
    assert_eq!(rows.len(), 1);
    let row = &rows[0];
    assert_eq!(row.count, 6);
    assert_eq!(row.names, vec!["d11", "d21", "d31", "d12", "d22", "d32"]);
    assert_eq!(row.file.as_deref(), Some("office-downlight.ldt"));
    assert_eq!(row.flux_lm, scene.lights[0].curve.flux_lm());
    assert!((row.dimmed_flux_lm - 0.35 * row.flux_lm).abs() < 1e-9);
    assert_eq!(row.positions[4], [4.0, 4.5, 2.4]);
    assert_eq!(row.luminous.as_deref(), Some("Ø 0.662 m"));
}

/// A 3 × 2 PNG, for the report.
fn tiny_png() -> Vec<u8> {
    let image = image::RgbImage::from_pixel(3, 2, image::Rgb([200, 120, 40]));
    let mut bytes = Vec::new();
    image
        .write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
        .unwrap();
    bytes
}

#[test]
fn report_embeds_images_and_tables_for_a4() {
    let mut scene = load(&rooms_dir().join("office.toml")).unwrap();
    scene.design.surfaces[0].name = "work <plane> & desks".into();
    scene.design.surfaces[0].targets.maintained_lux = Some(500.0);
    let eyes = eye_receivers(&scene);
    let observers = glare_with(&scene, &vec![100.0; eyes.len()], None);
    let schedule = luminaire_schedule(&scene);
    let surfaces = direct_surfaces(scene.clone());
    let png = tiny_png();
    let images = [
        ReportImage {
            caption: "Plan with isolux lines",
            png: &png,
        },
        ReportImage {
            caption: "False colour",
            png: &png,
        },
    ];
    let accuracy = [("SH order".to_string(), "automatic (5 % L2)".to_string())];
    let notes = ["Direct light only in this test.".to_string()];
    let legend = FalseColor::new(10.0, 1000.0, LuxScale::Log).unwrap();
    let text = html(&ReportInput {
        title: "Office",
        room_file: "rooms/office.toml",
        images: &images,
        legend: Some(legend),
        surfaces: &surfaces,
        observers: &observers,
        schedule: &schedule,
        maintenance_factor: scene.design.maintenance_factor,
        accuracy: &accuracy,
        notes: &notes,
    });
    assert!(text.starts_with("<!DOCTYPE html>"));
    assert!(text.contains("@page { size: A4 portrait"));
    // Both images, embedded; nothing external, no scripts.
    let uri = format!("data:image/png;base64,{}", base64::encode(&png));
    assert_eq!(text.matches(&uri).count(), 2);
    assert!(!text.contains("<script") && !text.contains("http://") && !text.contains("https://"));
    // The surface row: escaped name, its grid, maintained mean against 500 lx.
    let s = surfaces[0].stats.unwrap();
    assert!(text.contains("work &lt;plane&gt; &amp; desks"), "name escaped");
    assert!(text.contains("54 points: 9×6 cells of 0.78×0.83 m"));
    assert!(text.contains(&format!("{:.0}", s.e_avg)) && text.contains("≥ 500"));
    assert!(text.contains(&format!("{:.2}", s.u0)));
    // One glare row per observer with its UGR to one decimal.
    for o in &observers {
        assert!(text.contains(&o.name));
        assert!(text.contains(&format!("{:.1}", o.ugr.unwrap())));
    }
    // The schedule and the settings.
    assert!(text.contains("d11, d21, d31, d12, d22, d32") && text.contains("office-downlight.ldt"));
    assert!(text.contains("35.0 %"));
    assert!(text.contains("<th>Maintenance factor</th><td class=\"n\">0.80</td>"));
    assert!(text.contains("<th>SH order</th><td>automatic (5 % L2)</td>"));
    // The legend runs from 10 to 1000 lx (log): ticks 10, 25, 63, 158, 398, 1000.
    assert!(text.contains(
        "<span>10</span><span>25</span><span>63</span><span>158</span><span>398</span><span>1000</span>"
    ));
    assert!(text.contains("Direct light only in this test."));
}
