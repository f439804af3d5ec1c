//! Shadow rays: Haiko's `transport::occlusion::Occluders` (boxes by slab tests, triangles in an
//! obvhs BVH2) against the raw obvhs BVH2 on the same triangles and rays — the sculpture room's OBJ
//! triangles seen from its light, one ray per fine vertex of the room. Shows what the wrapper
//! costs; the first run of this bench measured Haiko's former own f64 BVH at 3.17 ms against
//! obvhs's 1.36 ms, which is why triangles now go to obvhs.
//!
//! The open-plan floor's 40 desks seen from one of its downlights, one ray per fine vertex:
//! the boxes through `transport::box_bvh::BoxBvh` against the slab test of every box in turn
//! (docs/DECISIONS.md "Shadow rays against many boxes").

use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use glam::{DVec3, Vec3A};
use haiko::scene::{SurfaceKind, load};
use haiko::transport::box_bvh::{BoxBvh, slab};
use haiko::transport::occlusion::Occluders;
use obvhs::{BvhBuildParams, bvh2::builder::build_bvh2_from_tris, ray::Ray, triangle::Triangle};

fn setup() -> (Vec<[DVec3; 3]>, DVec3, Vec<DVec3>) {
    let scene =
        load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("rooms/sculpture.toml")).expect("bundled room");
    let mesh = &scene.fine;
    let triangles: Vec<[DVec3; 3]> = mesh
        .triangles()
        .filter(|(_, pid)| {
            matches!(
                scene.surfaces[mesh.patches[*pid as usize].surface as usize].kind,
                SurfaceKind::Mesh { .. }
            )
        })
        .map(|(v, _)| v.map(|i| mesh.positions[i as usize]))
        .collect();
    (triangles, scene.lights[0].position, mesh.positions.clone())
}

fn visibility(c: &mut Criterion) {
    let (triangles, light, targets) = setup();
    let ours = Occluders::from_parts(&[], &triangles);
    let tris: Vec<Triangle> = triangles
        .iter()
        .map(|t| Triangle {
            v0: t[0].as_vec3a(),
            v1: t[1].as_vec3a(),
            v2: t[2].as_vec3a(),
        })
        .collect();
    let theirs = build_bvh2_from_tris(&tris, BvhBuildParams::medium_build(), &mut Duration::default());
    let obvhs_blocked = |to: DVec3| {
        let d = to - light;
        let len = d.length() as f32;
        let ray = Ray::new(
            light.as_vec3a(),
            Vec3A::from((d / d.length()).as_vec3()),
            1e-4,
            len - 1e-4,
        );
        !theirs.ray_traverse_miss(ray, |r, id| {
            tris[theirs.primitive_indices[id] as usize].intersect(r)
        })
    };
    let agree = targets
        .iter()
        .filter(|&&t| ours.blocked(light, t) == obvhs_blocked(t))
        .count();
    let blocked = targets.iter().filter(|&&t| ours.blocked(light, t)).count();
    println!(
        "{} triangles, {} rays: {} blocked; obvhs agrees on {} ({:.3} %)",
        triangles.len(),
        targets.len(),
        blocked,
        agree,
        100.0 * agree as f64 / targets.len() as f64
    );
    let mut group = c.benchmark_group("shadow_rays_sculpture");
    group.sample_size(20).measurement_time(Duration::from_secs(3));
    group.bench_function("haiko_occluders", |b| {
        b.iter(|| {
            targets
                .iter()
                .filter(|&&t| ours.blocked(light, black_box(t)))
                .count()
        })
    });
    group.bench_function("obvhs_bvh2_f32", |b| {
        b.iter(|| targets.iter().filter(|&&t| obvhs_blocked(black_box(t))).count())
    });
    group.finish();
}

fn many_boxes(c: &mut Criterion) {
    let scene = load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/rooms/open-plan.toml"))
        .expect("bench room");
    let light = scene.lights[20].position;
    let targets = &scene.fine.positions;
    let bvh = BoxBvh::new(&scene.boxes);
    let (t0, t1) = (1e-7, 1.0 - 1e-7);
    let one_by_one = |to: DVec3| {
        let inv_d = (to - light).recip();
        scene.boxes.iter().any(|b| slab(b, light, inv_d, t0, t1))
    };
    let through_tree = |to: DVec3| bvh.blocked(light, (to - light).recip(), t0, t1);
    let blocked = targets.iter().filter(|&&t| one_by_one(t)).count();
    let agree = targets
        .iter()
        .filter(|&&t| one_by_one(t) == through_tree(t))
        .count();
    println!(
        "{} boxes, {} rays: {blocked} blocked; the tree agrees on {agree}",
        scene.boxes.len(),
        targets.len()
    );
    let mut group = c.benchmark_group("shadow_rays_open_plan");
    group.sample_size(20).measurement_time(Duration::from_secs(3));
    group.bench_function("box_by_box", |b| {
        b.iter(|| targets.iter().filter(|&&t| one_by_one(black_box(t))).count())
    });
    group.bench_function("box_bvh", |b| {
        b.iter(|| targets.iter().filter(|&&t| through_tree(black_box(t))).count())
    });
    group.finish();
}

criterion_group!(benches, visibility, many_boxes);
criterion_main!(benches);
