//! Edit → new preview pixmap (docs/BENCHMARKS.md: under 16 ms for the paper room on one core): one curve
//! edit (`Relighter::set_curve` with a changed control point) → `vertex_attributes` → shader fit
//! → `render` at 1024×768 → light overlays, for the paper and office rooms, on a 1-thread and a
//! 2-thread rayon pool. The stages are also benched alone to show where the time goes.
//!
//! `pixel_edit_1024x768` is the same edit with per-pixel exact direct light (docs/DECISIONS.md,
//! "Per-pixel direct light"; targets 16 ms paper, 33 ms office on one core): the baked relighter's
//! edit and indirect total → `PixelLighting::set_state` → `render_into` (light and shade in one pass) at
//! a fixed exposure → overlays. `pixel_camera_1024x768` is an orbit step (5° about the target):
//! new per-pixel surfaces, every light's shadow rays and direct light, shading (target 200 ms).
//!
//! On a shared machine wall time overstates the cost, so the 1-thread case is also measured in
//! CPU time of the pool's one thread (`…/1-thread-cpu`; Linux `/proc/thread-self/schedstat`,
//! which may lag by a scheduler tick per read — a few % of a criterion sample — and falls back
//! to wall time elsewhere).

use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use glam::DQuat;
use haiko::photometry::Curve;
use haiko::relight::Relighter;
use haiko::render::{
    DisplayMode, DisplayShader, Exposure, Frame, LightMarker, PixelLight, PixelLighting, PixelSurfaces, View,
    draw_lights, render, render_into, vertex_attributes,
};
use haiko::scene::{self, Camera, Scene};
use haiko::transport::bake::{BakeOptions, bake};
use haiko::transport::occlusion::Occluders;
use rayon::ThreadPool;

#[path = "common/cpu_time.rs"]
mod cpu_time;
use cpu_time::cpu_time_of;

const ROOMS: [&str; 2] = ["paper", "office"];
const THREADS: [usize; 2] = [1, 2];
const SIZE: (u32, u32) = (1024, 768);

fn configured() -> Criterion {
    Criterion::default()
        .sample_size(15)
        .measurement_time(Duration::from_secs(2))
        .warm_up_time(Duration::from_millis(300))
}

fn pool(threads: usize) -> ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a rayon pool")
}

fn load(name: &str) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("rooms")
        .join(format!("{name}.toml"));
    scene::load(&path).expect("a bundled room loads")
}

/// The room camera's view at `width × height`.
fn scene_view(scene: &Scene, width: u32, height: u32) -> haiko::Result<View> {
    View::new(scene.camera, width, height)
}

/// One marker per light, none selected (the aim line is not drawn).
fn light_markers(scene: &Scene) -> Vec<LightMarker> {
    scene
        .lights
        .iter()
        .map(|light| LightMarker {
            position: light.position,
            aim_target: light.position + light.aim,
            selected: false,
        })
        .collect()
}

/// Light 0's curve with its first control point scaled by `factor`.
fn edited_curve(curve: &Curve, factor: f64) -> Curve {
    let mut edited = curve.clone();
    let first = edited.intensities_cd()[0];
    edited
        .set_intensity(0, first * factor)
        .expect("a scaled positive intensity is valid");
    edited
}

/// One edit → pixmap: the whole path the editor runs per keystroke, redrawing into its frame.
fn edit_to_pixmap(scene: &Scene, relighter: &mut Relighter, curve: Curve, view: &View, frame: &mut Frame) {
    relighter.set_curve(0, curve);
    let attrs = vertex_attributes(
        DisplayMode::Photo,
        &scene.fine,
        &scene.surfaces,
        relighter.total(),
    )
    .expect("attributes match the mesh");
    let shader = DisplayShader::fit(DisplayMode::Photo, &scene.fine, &attrs);
    render_into(frame, &scene.fine, &attrs, view, &shader).expect("the mesh renders");
    draw_lights(frame, view, &light_markers(scene));
    black_box(&frame.pixmap);
}

fn relight_and_rasterise(c: &mut Criterion) {
    let mut group = c.benchmark_group("relight_rasterise_1024x768");
    for name in ROOMS {
        let scene = load(name);
        let view = scene_view(&scene, SIZE.0, SIZE.1).expect("a valid view");
        let mut relighter = Relighter::new(&scene);
        let base = relighter.light(0).curve.clone();
        let curves = [edited_curve(&base, 1.1), base];
        let mut frame = Frame::new(SIZE.0, SIZE.1).expect("a frame");
        for threads in THREADS {
            let pool = pool(threads);
            let id = BenchmarkId::new(name, format!("{threads}-thread"));
            let mut toggle = 0;
            group.bench_function(id, |b| {
                b.iter(|| {
                    toggle ^= 1;
                    pool.install(|| {
                        edit_to_pixmap(&scene, &mut relighter, curves[toggle].clone(), &view, &mut frame)
                    });
                })
            });
            if threads == 1 {
                group.bench_function(BenchmarkId::new(name, "1-thread-cpu"), |b| {
                    b.iter_custom(|iters| {
                        pool.install(|| {
                            cpu_time_of(iters, || {
                                toggle ^= 1;
                                edit_to_pixmap(
                                    &scene,
                                    &mut relighter,
                                    curves[toggle].clone(),
                                    &view,
                                    &mut frame,
                                );
                            })
                        })
                    })
                });
            }
        }
    }
    group.finish();
}

/// The stages alone on one thread (paper room): relight, attributes + fit, raster, overlays.
fn stages(c: &mut Criterion) {
    let scene = load("paper");
    let view = scene_view(&scene, SIZE.0, SIZE.1).expect("a valid view");
    let mut relighter = Relighter::new(&scene);
    let base = relighter.light(0).curve.clone();
    let curves = [edited_curve(&base, 1.1), base];
    let attrs = vertex_attributes(
        DisplayMode::Photo,
        &scene.fine,
        &scene.surfaces,
        relighter.total(),
    )
    .expect("attributes match the mesh");
    let shader = DisplayShader::fit(DisplayMode::Photo, &scene.fine, &attrs);
    let frame = render(&scene.fine, &attrs, &view, &shader).expect("the mesh renders");
    let markers = light_markers(&scene);
    let one = pool(1);
    let mut group = c.benchmark_group("paper_stages_1-thread");
    let mut toggle = 0;
    group.bench_function("set_curve", |b| {
        b.iter(|| {
            toggle ^= 1;
            one.install(|| relighter.set_curve(0, curves[toggle].clone()));
        })
    });
    group.bench_function("attributes_and_fit", |b| {
        b.iter(|| {
            one.install(|| {
                let a = vertex_attributes(
                    DisplayMode::Photo,
                    &scene.fine,
                    &scene.surfaces,
                    relighter.total(),
                )
                .expect("attributes match the mesh");
                black_box(DisplayShader::fit(DisplayMode::Photo, &scene.fine, &a))
            })
        })
    });
    let mut reused = Frame::new(SIZE.0, SIZE.1).expect("a frame");
    group.bench_function("render_into", |b| {
        b.iter(|| {
            one.install(|| render_into(&mut reused, &scene.fine, &attrs, &view, &shader).expect("renders"))
        })
    });
    group.bench_function("render", |b| {
        b.iter(|| one.install(|| render(&scene.fine, &attrs, &view, &shader).expect("the mesh renders")))
    });
    // Markers drawn over and over on one frame: the same work as on a fresh frame.
    let mut frame = frame;
    group.bench_function("overlays", |b| {
        b.iter(|| draw_lights(&mut frame, &view, &markers))
    });
    group.finish();
}

/// What the per-pixel preview of one room keeps between frames.
struct PixelPreview {
    scene: Scene,
    relighter: Relighter,
    lighting: PixelLighting,
    occluders: Option<Occluders>,
    frame: Frame,
    view: View,
    shader: DisplayShader,
    indirect: Vec<[f32; 3]>,
}

impl PixelPreview {
    fn new(name: &str) -> PixelPreview {
        let scene = load(name);
        let baked = bake(&scene, &BakeOptions::default(), &mut |_| {}).expect("the room bakes");
        let relighter = Relighter::with_bake(&scene, &baked);
        let view = scene_view(&scene, SIZE.0, SIZE.1).expect("a valid view");
        let mut frame = Frame::new(SIZE.0, SIZE.1).expect("a frame");
        let surfaces =
            PixelSurfaces::build(&mut frame, &scene.fine, &scene.surfaces, &view).expect("surfaces");
        let occluders = Occluders::of_scene(&scene);
        let lights = scene.lights.iter().map(PixelLight::from).collect();
        let lighting = PixelLighting::new(surfaces, lights, occluders.as_ref());
        let attrs = vertex_attributes(
            DisplayMode::Photo,
            &scene.fine,
            &scene.surfaces,
            relighter.total(),
        )
        .expect("attributes match the mesh");
        let shader =
            DisplayShader::Photo(Exposure::fixed_for(&scene.fine, &attrs).photo(&scene.fine, &attrs));
        PixelPreview {
            scene,
            relighter,
            lighting,
            occluders,
            frame,
            view,
            shader,
            indirect: Vec::new(),
        }
    }

    /// One curve edit of light 0 → new pixmap.
    fn edit(&mut self, curve: &Curve) {
        self.relighter.set_curve(0, curve.clone());
        self.relighter.indirect_into(&mut self.indirect);
        let mut state = self.lighting.light(0).state.clone();
        state.curve = curve.clone();
        self.lighting.set_state(0, state).expect("light 0 exists");
        self.shade();
    }

    /// A camera move → new pixmap.
    fn look(&mut self, camera: Camera) {
        self.view = View::new(camera, SIZE.0, SIZE.1).expect("a valid view");
        self.lighting
            .set_view(
                &mut self.frame,
                &self.scene.fine,
                &self.scene.surfaces,
                &self.view,
                self.occluders.as_ref(),
            )
            .expect("surfaces");
        self.relighter.indirect_into(&mut self.indirect);
        self.shade();
    }

    fn shade(&mut self) {
        self.lighting
            .render_into(&mut self.frame, Some(&self.indirect), &self.shader, None)
            .expect("one indirect value per vertex, a frame of the surfaces' size");
        draw_lights(&mut self.frame, &self.view, &light_markers(&self.scene));
        black_box(&self.frame.pixmap);
    }
}

/// The camera orbited by `yaw_deg` about the vertical through its target.
fn orbited(camera: &Camera, yaw_deg: f64) -> Camera {
    let offset = DQuat::from_rotation_z(yaw_deg.to_radians()) * (camera.eye - camera.target);
    Camera {
        eye: camera.target + offset,
        ..*camera
    }
}

fn pixel_edit(c: &mut Criterion) {
    let mut group = c.benchmark_group("pixel_edit_1024x768");
    for name in ROOMS {
        let mut preview = PixelPreview::new(name);
        let base = preview.relighter.light(0).curve.clone();
        let curves = [edited_curve(&base, 1.1), base];
        let mut toggle = 0;
        for threads in THREADS {
            let pool = pool(threads);
            group.bench_function(BenchmarkId::new(name, format!("{threads}-thread")), |b| {
                b.iter(|| {
                    toggle ^= 1;
                    pool.install(|| preview.edit(&curves[toggle]));
                })
            });
            if threads == 1 {
                group.bench_function(BenchmarkId::new(name, "1-thread-cpu"), |b| {
                    b.iter_custom(|iters| {
                        pool.install(|| {
                            cpu_time_of(iters, || {
                                toggle ^= 1;
                                preview.edit(&curves[toggle]);
                            })
                        })
                    })
                });
            }
        }
        let (shared, per_light) = preview.lighting.memory_per_pixel();
        println!(
            "{name}: per-pixel memory {shared} B shared + {per_light} B per light ({} lights)",
            preview.lighting.n_lights()
        );
    }
    group.finish();
}

fn pixel_camera(c: &mut Criterion) {
    let mut group = c.benchmark_group("pixel_camera_1024x768");
    group.sample_size(10);
    for name in ["paper", "office", "sculpture"] {
        let mut preview = PixelPreview::new(name);
        let cameras = [orbited(&preview.scene.camera, 5.0), preview.scene.camera];
        let mut toggle = 0;
        for threads in THREADS {
            let pool = pool(threads);
            group.bench_function(BenchmarkId::new(name, format!("{threads}-thread")), |b| {
                b.iter(|| {
                    toggle ^= 1;
                    pool.install(|| preview.look(cameras[toggle]));
                })
            });
        }
    }
    group.finish();
}

/// The per-pixel stages alone on one thread (office): the relighter's edit, its indirect total,
/// the per-pixel state change, the fused light-and-shade pass; and for a camera move the
/// surfaces alone and the whole `set_view` (surfaces, shadow rays, direct light of every light).
fn pixel_stages(c: &mut Criterion) {
    let mut preview = PixelPreview::new("office");
    let base = preview.relighter.light(0).curve.clone();
    let curves = [edited_curve(&base, 1.1), base];
    preview.edit(&curves[0]);
    let one = pool(1);
    let mut group = c.benchmark_group("pixel_stages_office_1-thread");
    let mut toggle = 0;
    group.bench_function("relighter_set_curve", |b| {
        b.iter(|| {
            toggle ^= 1;
            one.install(|| preview.relighter.set_curve(0, curves[toggle].clone()));
        })
    });
    group.bench_function("indirect_into", |b| {
        b.iter(|| one.install(|| preview.relighter.indirect_into(&mut preview.indirect)))
    });
    group.bench_function("set_state_curve", |b| {
        b.iter(|| {
            toggle ^= 1;
            let mut state = preview.lighting.light(0).state.clone();
            state.curve = curves[toggle].clone();
            one.install(|| preview.lighting.set_state(0, state).expect("light 0"));
        })
    });
    group.bench_function("render_into", |b| {
        b.iter(|| {
            one.install(|| {
                preview
                    .lighting
                    .render_into(&mut preview.frame, Some(&preview.indirect), &preview.shader, None)
                    .expect("sizes match")
            })
        })
    });
    let markers = light_markers(&preview.scene);
    group.bench_function("overlays", |b| {
        b.iter(|| draw_lights(&mut preview.frame, &preview.view, &markers))
    });
    group.sample_size(10);
    let view = preview.view;
    group.bench_function("surfaces_rebuild", |b| {
        b.iter(|| {
            one.install(|| {
                black_box(
                    PixelSurfaces::build(
                        &mut preview.frame,
                        &preview.scene.fine,
                        &preview.scene.surfaces,
                        &view,
                    )
                    .expect("surfaces"),
                )
            })
        })
    });
    group.bench_function("set_view", |b| {
        b.iter(|| {
            one.install(|| {
                preview
                    .lighting
                    .set_view(
                        &mut preview.frame,
                        &preview.scene.fine,
                        &preview.scene.surfaces,
                        &view,
                        preview.occluders.as_ref(),
                    )
                    .expect("surfaces")
            })
        })
    });
    group.finish();
}

criterion_group! {
    name = benches;
    config = configured();
    targets = pixel_edit, pixel_camera, pixel_stages, relight_and_rasterise, stages
}
criterion_main!(benches);
