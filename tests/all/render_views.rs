//! What the preview draws besides the lit surfaces, and the numbers it writes: the false-colour
//! legend (ticks at the exact lux of the scale), isolux lines, the plan view (orientation,
//! what it sees, the work plane's exact direct light), luminaire symbols, the PFM file, and the
//! photo's highlight shoulder on a real spot pool.

use glam::DVec3;
use haiko::render::legend::{linear_levels, lux_label};
use haiko::render::plan::{ARROW_RGB, SYMBOL_RGB, aim_on_plane};
use haiko::render::shade::viridis;
use haiko::render::{
    DisplayShader, FalseColor, Frame, LuxScale, PixelLight, PixelLighting, PixelSurfaces, PlanLight,
    Projection, draw_isolux, draw_legend, draw_plan_lights, encode_pfm, luma_values, plan_view, round_levels,
    work_plane_mesh,
};
use haiko::scene::Aabb;
use haiko::transport::occlusion::Occluders;
use tiny_skia::Pixmap;

fn rgb(pixmap: &Pixmap, x: u32, y: u32) -> [u8; 3] {
    let p = pixmap.pixel(x, y).unwrap();
    [p.red(), p.green(), p.blue()]
}

fn black(w: u32, h: u32) -> Pixmap {
    let mut pixmap = Pixmap::new(w, h).unwrap();
    pixmap.fill(tiny_skia::Color::BLACK);
    pixmap
}

// ---------------------------------------------------------------------------------------------
// PFM

#[test]
fn pfm_bytes_have_the_header_little_endian_floats_and_rows_bottom_to_top() {
    // A 3 × 2 image, row-major from the top-left: top row 0.5, 1, 2; bottom row 3, −0.25, 1e6.
    let values = [0.5f32, 1.0, 2.0, 3.0, -0.25, 1e6];
    let bytes = encode_pfm(3, 2, &values).unwrap();
    let mut expected = b"Pf\n3 2\n-1.0\n".to_vec();
    // Bottom row first.
    for v in [3.0f32, -0.25, 1e6, 0.5, 1.0, 2.0] {
        expected.extend_from_slice(&v.to_le_bytes());
    }
    assert_eq!(bytes, expected);
    // 0.5 is 0x3F000000: little-endian puts the 0x3F byte last.
    assert_eq!(&bytes[12 + 12..12 + 16], &[0x00, 0x00, 0x00, 0x3F]);
    assert!(encode_pfm(3, 2, &values[..5]).is_err());
    // Grey light reads its value exactly; coloured light its Rec. 709 luma.
    assert_eq!(luma_values(&[[7.25; 3], [1.0, 0.0, 0.0]]), [7.25, 0.2126]);
}

// ---------------------------------------------------------------------------------------------
// Legend and isolux lines

#[test]
fn legend_ticks_sit_at_the_exact_lux_values_of_the_scale() {
    for (scale, w, h) in [
        (FalseColor::new(20.0, 2000.0, LuxScale::Log).unwrap(), 320, 240),
        (FalseColor::new(0.0, 1000.0, LuxScale::Linear).unwrap(), 640, 480),
    ] {
        let mut pixmap = black(w, h);
        let legend = draw_legend(&mut pixmap, &scale).expect("room for a legend");
        let [left, top, right, bottom] = legend.bar;
        assert!(left < right && right <= w && top < bottom && bottom <= h);
        let (lo, hi) = scale.range();
        let span = f64::from(bottom - top);
        let ticked: Vec<f64> = legend.ticks.iter().map(|t| t.0).collect();
        let expected = match scale.scale() {
            LuxScale::Log => round_levels(lo, hi, ticked.len()),
            LuxScale::Linear => linear_levels(lo, hi, ticked.len()),
        };
        assert_eq!(ticked, expected, "the ticks are the round values of the range");
        assert!(ticked.len() >= 5, "{ticked:?}");
        for &(lux, row) in &legend.ticks {
            // The tick's row is the one holding the lux value's exact position on the bar.
            let exact_y = f64::from(bottom) - scale.position(lux) * span;
            assert!(
                f64::from(row) <= exact_y && exact_y <= f64::from(row) + 1.0,
                "{lux} lx: row {row}, exact y {exact_y}"
            );
            // The bar shows that position's colour in that row, and the mark is drawn beside it.
            let fraction = legend.fraction_of_row(row);
            assert!((fraction - scale.position(lux)).abs() <= 1.0 / span);
            assert_eq!(rgb(&pixmap, left + 1, row), viridis(fraction));
            assert_eq!(rgb(&pixmap, left - 1, row), [235, 235, 235], "{lux} lx tick mark");
        }
        // The bar runs from the bottom colour to the top colour.
        assert_eq!(
            rgb(&pixmap, left, bottom - 1),
            viridis(legend.fraction_of_row(bottom - 1))
        );
        assert_eq!(rgb(&pixmap, left, top), viridis(legend.fraction_of_row(top)));
        assert!(
            legend.fraction_of_row(bottom - 1) < 1.0 / span && legend.fraction_of_row(top) > 1.0 - 1.0 / span
        );
        // Labels: something was drawn left of every tick.
        for &(lux, row) in &legend.ticks {
            let label_right = left - 7 * legend.scale;
            let drawn = (0..label_right).any(|x| rgb(&pixmap, x, row) == [235, 235, 235]);
            assert!(drawn, "no label `{}` at row {row}", lux_label(lux));
        }
    }
    // Linear 0–1000 lx: 500 lx is half-way up the bar.
    let scale = FalseColor::new(0.0, 1000.0, LuxScale::Linear).unwrap();
    let legend = draw_legend(&mut black(640, 480), &scale).unwrap();
    let [_, top, _, bottom] = legend.bar;
    let half = legend
        .ticks
        .iter()
        .find(|t| t.0 == 500.0)
        .expect("a 500 lx tick")
        .1;
    assert_eq!(f64::from(half), (f64::from(top + bottom) / 2.0).floor());
    assert!(draw_legend(&mut black(40, 30), &scale).is_none(), "no room");
}

#[test]
fn isolux_lines_follow_the_level_crossings_on_one_surface_only() {
    // 60 × 20 pixels, lux = 10 · column; the right third is another surface with +5000 lx.
    let (w, h) = (60u32, 20u32);
    let lux: Vec<f32> = (0..w * h)
        .map(|i| {
            let x = i % w;
            10.0 * x as f32 + if x >= 40 { 5000.0 } else { 0.0 }
        })
        .collect();
    let surface = |i: usize| Some(u32::from(i as u32 % w >= 40));
    let mut pixmap = black(w, h);
    draw_isolux(&mut pixmap, &lux, surface, &[100.0, 200.0, 1000.0, 5300.0]);
    for y in 0..h {
        for x in 0..w {
            // 100 lx first reached at column 10, 200 at 20; 1000 lies in the jump between
            // the surfaces (no line); 5300 lx at column 70 − 40… = column 30 + 40 = 70: beyond.
            let on = x == 10 || x == 20 || x == 70;
            assert_eq!(rgb(&pixmap, x, y) == [255, 255, 255], on, "pixel ({x}, {y})");
        }
    }
    // Over bright pixels the line is black.
    let mut bright = Pixmap::new(w, h).unwrap();
    bright.fill(tiny_skia::Color::WHITE);
    draw_isolux(&mut bright, &lux, surface, &[100.0]);
    assert_eq!(rgb(&bright, 10, 5), [0, 0, 0]);
    assert_eq!(rgb(&bright, 11, 5), [255, 255, 255]);
}

// ---------------------------------------------------------------------------------------------
// Plan view

/// The spots-and-boxes room of `render_pixels`, as plain numbers: 6 × 4 × 3 m, a desk, a
/// cabinet, a shelf at 0.7–0.76 m.
fn boxes() -> Vec<Aabb> {
    vec![
        Aabb {
            min: DVec3::new(2.0, 1.2, 0.0),
            max: DVec3::new(3.2, 2.2, 0.8),
        },
        Aabb {
            min: DVec3::new(4.5, 2.8, 0.0),
            max: DVec3::new(5.0, 3.4, 1.8),
        },
        Aabb {
            min: DVec3::new(0.8, 2.6, 0.7),
            max: DVec3::new(1.8, 3.6, 0.76),
        },
    ]
}

#[test]
fn the_plan_view_puts_x_right_and_y_up_and_fits_the_footprint() {
    let size = DVec3::new(8.0, 6.0, 3.0);
    let view = plan_view(size, 400, 300).unwrap();
    assert!(matches!(view.projection(), Projection::Orthographic { .. }));
    // Footprint 8.64 × 6.64 m (margin 4 % of 8 m): at 4:3 the height decides, 300 px / 6.64 m.
    let px_per_m = 300.0 / 6.64;
    for (world, x, y) in [
        (DVec3::new(4.0, 3.0, 0.0), 200.0, 150.0),
        (
            DVec3::new(0.0, 0.0, 0.0),
            200.0 - 4.0 * px_per_m,
            150.0 + 3.0 * px_per_m,
        ),
        (
            DVec3::new(8.0, 6.0, 2.7),
            200.0 + 4.0 * px_per_m,
            150.0 - 3.0 * px_per_m,
        ),
    ] {
        let p = view.project(world).unwrap();
        assert!(
            (p.x - x).abs() < 1e-9 && (p.y - y).abs() < 1e-9,
            "{world}: {p} vs ({x}, {y})"
        );
        // Higher is nearer (reversed depth).
        assert!(view.project(world + DVec3::Z * 0.1).unwrap().z > p.z);
    }
    // Every pixel ray points straight down.
    let (origin, dir) = view.pixel_ray(17.5, 230.5);
    assert_eq!(dir, DVec3::new(0.0, 0.0, -1.0));
    assert!((origin.z - 4.0).abs() < 1e-9);
}

#[test]
fn from_above_the_plan_sees_floor_and_box_tops_never_ceiling_or_walls() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("room.toml");
    let mut text = String::from(
        "version = 1\nname = \"plan\"\n[room]\nsize = [6.0, 4.0, 3.0]\n[room.reflectance]\nfloor = 0.3\nwalls = 0.5\nceiling = 0.7\n",
    );
    for b in boxes() {
        text += &format!(
            "[[box]]\nmin = [{}, {}, {}]\nmax = [{}, {}, {}]\nreflectance = 0.4\n",
            b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z
        );
    }
    text += "[[light]]\nname = \"a\"\nposition = [3.0, 2.0, 2.9]\nlid = [[0, 1000], [90, 0]]\n";
    std::fs::write(&path, text).unwrap();
    let scene = haiko::scene::load(&path).unwrap();
    let view = plan_view(scene.room_size, 300, 200).unwrap();
    let mut frame = Frame::new(300, 200).unwrap();
    let surfaces = PixelSurfaces::build(&mut frame, &scene.fine, &scene.surfaces, &view).unwrap();
    let name = |i: usize| {
        surfaces
            .surface(i)
            .map(|s| scene.surfaces[s as usize].name.as_str())
    };
    let mut seen = std::collections::BTreeSet::new();
    for i in 0..surfaces.len() {
        let (x, y) = ((i % 300) as f64 + 0.5, (i / 300) as f64 + 0.5);
        let (origin, _) = view.pixel_ray(x, y);
        let within = |margin: f64| {
            origin.x > margin && origin.x < 6.0 - margin && origin.y > margin && origin.y < 4.0 - margin
        };
        let inside = within(0.01);
        match name(i) {
            Some(n) => {
                assert!(within(-1e-3), "pixel {i} outside the footprint sees {n}");
                assert!(n == "floor" || n.ends_with("-top"), "pixel {i} sees {n}");
                // The point is straight below the pixel.
                let p = surfaces.point(i).unwrap();
                assert!((p.x - origin.x).abs() < 1e-5 && (p.y - origin.y).abs() < 1e-5);
                seen.insert(n.to_string());
            }
            None => assert!(!inside, "pixel {i} inside the footprint sees nothing"),
        }
    }
    assert_eq!(
        seen.into_iter().collect::<Vec<_>>(),
        ["box0-top", "box1-top", "box2-top", "floor"]
    );
}

#[test]
fn the_work_plane_is_lit_exactly_per_pixel_with_holes_where_boxes_cross_it() {
    let size = DVec3::new(6.0, 4.0, 3.0);
    let boxes = boxes();
    let height = 0.5;
    let (mesh, plane_surfaces) = work_plane_mesh(size, &boxes, height, 0.25).unwrap();
    let view = plan_view(size, 240, 160).unwrap();
    let mut frame = Frame::new(240, 160).unwrap();
    let surfaces = PixelSurfaces::build(&mut frame, &mesh, &plane_surfaces, &view).unwrap();
    // A downlight and a spot; the shelf (above the plane) and the boxes shade the plane.
    let lights = [
        (
            DVec3::new(1.5, 3.0, 2.9),
            DVec3::new(0.0, 0.0, -1.0),
            vec![(0.0, 2000.0), (60.0, 1500.0), (90.0, 0.0)],
        ),
        (
            DVec3::new(4.0, 1.0, 2.9),
            (DVec3::new(4.6, 3.1, 0.0) - DVec3::new(4.0, 1.0, 2.9)).normalize(),
            vec![(0.0, 9000.0), (25.0, 9000.0), (25.0, 0.0)],
        ),
    ];
    let pixel_lights = lights
        .iter()
        .map(|(position, aim, curve)| PixelLight {
            position: *position,
            radius_m: 0.0,
            state: haiko::photometry::LightState {
                curve: haiko::photometry::Curve::new(curve).unwrap(),
                aim: *aim,
                dimmer: 1.0,
                color: [1.0; 3],
            },
        })
        .collect();
    let occluders = Occluders::from_parts(&boxes, &[]);
    let lighting = PixelLighting::new(surfaces, pixel_lights, Some(&occluders));
    let mut direct = Vec::new();
    lighting.direct_into(&mut direct);
    let blocked = |p: DVec3, q: DVec3| {
        boxes.iter().any(|b| {
            let d = q - p;
            let (mut enter, mut exit): (f64, f64) = (1e-9, 1.0 - 1e-9);
            for a in 0..3 {
                let (t0, t1) = ((b.min[a] - p[a]) / d[a], (b.max[a] - p[a]) / d[a]);
                enter = enter.max(t0.min(t1));
                exit = exit.min(t0.max(t1));
            }
            enter < exit
        })
    };
    let (mut holes, mut pairs) = (0, Vec::new());
    for i in 0..lighting.surfaces().len() {
        let (x, y) = ((i % 240) as f64 + 0.5, (i / 240) as f64 + 0.5);
        let (origin, _) = view.pixel_ray(x, y);
        let p = DVec3::new(origin.x, origin.y, height);
        let in_room = p.x > 0.0 && p.x < size.x && p.y > 0.0 && p.y < size.y;
        let in_box = boxes.iter().any(|b| b.contains_strictly(p));
        if lighting.surfaces().patch(i).is_none() {
            holes += usize::from(in_box);
            assert!(
                !in_room || in_box || near_a_box_edge(&boxes, p),
                "pixel {i} at {p} has no plane"
            );
            continue;
        }
        assert!(in_room && !in_box, "pixel {i} at {p} is not on the plane");
        let exact: f64 = lights
            .iter()
            .map(|(q, aim, curve)| {
                let to = *q - p;
                let r2 = to.length_squared();
                if blocked(p, *q) {
                    return 0.0;
                }
                let gamma = aim.dot(-to.normalize()).clamp(-1.0, 1.0).acos().to_degrees();
                let intensity = haiko::photometry::Curve::new(curve).unwrap().eval_deg(gamma);
                intensity * (to.z / r2.sqrt()) / r2
            })
            .sum();
        pairs.push((f64::from(direct[i][0]), exact));
    }
    assert!(holes > 100, "the desk and cabinet cut holes: {holes}");
    assert!(pairs.len() > 20_000, "{} plane pixels", pairs.len());
    let max = pairs.iter().fold(0.0f64, |m, p| m.max(p.1));
    let mut rel: Vec<f64> = pairs
        .iter()
        .filter(|p| p.1 > 0.01 * max)
        .map(|p| (p.0 - p.1).abs() / p.1)
        .collect();
    rel.sort_by(f64::total_cmp);
    let off = pairs.iter().filter(|p| (p.0 - p.1).abs() > 0.05 * max).count();
    assert!(
        rel[rel.len() / 2] < 1e-5,
        "median relative error {}",
        rel[rel.len() / 2]
    );
    assert!(
        off * 200 < pairs.len(),
        "{off} of {} pixels off (spot and shadow edges)",
        pairs.len()
    );
    // The shelf above the plane casts the downlight's shadow: a dark patch right below it.
    let below_shelf = DVec3::new(1.3, 3.1, height);
    let pixel = view.project(below_shelf).unwrap();
    let i = pixel.y as usize * 240 + pixel.x as usize;
    let spot_alone = 0.0;
    assert_eq!(f64::from(direct[i][0]), spot_alone, "in the shelf's shadow");
}

fn near_a_box_edge(boxes: &[Aabb], p: DVec3) -> bool {
    boxes.iter().any(|b| {
        let grown = Aabb {
            min: b.min - DVec3::splat(0.05),
            max: b.max + DVec3::splat(0.05),
        };
        grown.contains_strictly(p)
    })
}

#[test]
fn luminaire_symbols_sit_on_the_lights_and_arrows_end_at_the_aim() {
    assert_eq!(
        aim_on_plane(
            DVec3::new(1.0, 1.0, 3.0),
            DVec3::new(1.0, 0.0, -1.0).normalize(),
            1.0
        ),
        Some(DVec3::new(3.0, 1.0, 1.0))
    );
    assert_eq!(aim_on_plane(DVec3::new(1.0, 1.0, 3.0), DVec3::X, 0.0), None);
    let size = DVec3::new(8.0, 6.0, 3.0);
    let view = plan_view(size, 400, 300).unwrap();
    let mut pixmap = black(400, 300);
    let down = PlanLight {
        name: "d1".into(),
        position: DVec3::new(2.0, 1.5, 2.4),
        aim: DVec3::new(0.0, 0.0, -1.0),
        selected: false,
    };
    let spot = PlanLight {
        name: "s".into(),
        position: DVec3::new(6.0, 4.5, 2.8),
        aim: DVec3::new(-1.0, -1.0, -1.4).normalize(),
        selected: true,
    };
    draw_plan_lights(&mut pixmap, &view, &[down.clone(), spot.clone()], 0.0);
    let at = |p: DVec3| {
        let q = view.project(p).unwrap();
        (q.x as u32, q.y as u32)
    };
    // A symbol pixel just off the centre (the cross runs through the centre).
    let (x, y) = at(down.position);
    assert_eq!(rgb(&pixmap, x + 2, y), SYMBOL_RGB);
    // The selected light is drawn white.
    let (x, y) = at(spot.position);
    assert_eq!(rgb(&pixmap, x + 3, y), [255, 255, 255]);
    // The arrow's tip: where the aim meets the floor, drawn in the arrow colour (anti-aliased
    // core within a pixel of the tip).
    let tip = aim_on_plane(spot.position, spot.aim, 0.0).unwrap();
    let (tx, ty) = at(tip);
    let near_tip = (tx - 1..=tx + 1).flat_map(|x| (ty - 1..=ty + 1).map(move |y| (x, y)));
    assert!(
        near_tip.clone().any(|(x, y)| {
            let c = rgb(&pixmap, x, y);
            c[2] > 200 && c[1] > 150 && c[0] < 80
        }),
        "no arrow colour {ARROW_RGB:?} at the tip ({tx}, {ty})"
    );
    // The straight-down light gets no arrow: nothing cyan beyond its symbol.
    let (x, y) = at(down.position);
    let cyan_near_down = (x.saturating_sub(30)..x + 30)
        .flat_map(|x| (y.saturating_sub(30)..y + 30).map(move |y| (x, y)))
        .any(|(x, y)| rgb(&pixmap, x, y) == ARROW_RGB);
    assert!(!cyan_near_down);
}

// ---------------------------------------------------------------------------------------------
// The photo's highlight shoulder on a real spot pool

#[test]
fn a_spot_pool_keeps_its_gradient_in_the_photo() {
    // A 12° spot 1.7 m from a wall (ρ 0.7): its pool's luminance (≈ 70–120 cd/m²) lies 5.5–6.5
    // stops above a key of 1.5 cd/m², where Reinhard is nearly flat white.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("room.toml");
    std::fs::write(
        &path,
        "version = 1\nname = \"pool\"\n[room]\nsize = [4.0, 4.0, 3.0]\n[room.reflectance]\nfloor = 0.2\nwalls = 0.7\nceiling = 0.7\n\
         [[light]]\nname = \"spot\"\nposition = [2.0, 2.3, 2.8]\naim = [2.0, 4.0, 1.5]\nlid = [[0, 2500], [12, 2500], [12, 0], [90, 0]]\n\
         [camera]\neye = [2.0, 0.5, 1.5]\ntarget = [2.0, 4.0, 1.5]\nfov_deg = 50\n",
    )
    .unwrap();
    let scene = haiko::scene::load(&path).unwrap();
    let view = haiko::render::View::new(scene.camera, 320, 240).unwrap();
    let mut frame = Frame::new(320, 240).unwrap();
    let surfaces = PixelSurfaces::build(&mut frame, &scene.fine, &scene.surfaces, &view).unwrap();
    let lighting = PixelLighting::new(
        surfaces,
        scene.lights.iter().map(PixelLight::from).collect(),
        None,
    );
    let mut lux = Vec::new();
    lighting
        .illuminance_into(&vec![[0.0; 3]; scene.fine.n_vertices()], &mut lux)
        .unwrap();
    let key_cd_m2 = 1.5;
    let photo = haiko::render::Photo::with_ev100(haiko::render::exposure::ev100_of_key(key_cd_m2));
    lighting
        .render_into(
            &mut frame,
            Some(&vec![[0.0; 3]; scene.fine.n_vertices()]),
            &DisplayShader::Photo(photo),
            None,
        )
        .unwrap();
    let in_pool: Vec<usize> = (0..lux.len()).filter(|&i| lux[i][1] > 0.0).collect();
    assert!(in_pool.len() > 2000, "the pool covers {} pixels", in_pool.len());
    let stops: Vec<f64> = in_pool
        .iter()
        .map(|&i| (f64::from(lux[i][1]) * 0.7 / std::f64::consts::PI / key_cd_m2).log2())
        .collect();
    let (lo, hi) = stops
        .iter()
        .fold((f64::MAX, 0.0f64), |(a, b), &s| (a.min(s), b.max(s)));
    assert!(
        lo > 5.0 && hi < 7.0,
        "the pool spans {lo:.2}–{hi:.2} stops above the key"
    );
    let shown: std::collections::BTreeSet<u8> =
        in_pool.iter().map(|&i| frame.pixmap.pixels()[i].red()).collect();
    let reinhard: std::collections::BTreeSet<u8> = in_pool
        .iter()
        .map(|&i| {
            let x = f64::from(lux[i][1]) * 0.7 / std::f64::consts::PI * photo.exposure();
            (haiko::render::shade::srgb_encode(x / (1.0 + x)) * 255.0).round() as u8
        })
        .collect();
    println!("pool levels: {shown:?}; Reinhard would show {reinhard:?}");
    assert!(!shown.contains(&255), "nothing clips to white");
    assert!(
        2 * shown.len() >= 5 * reinhard.len(),
        "{} levels against Reinhard's {}",
        shown.len(),
        reinhard.len()
    );
}
