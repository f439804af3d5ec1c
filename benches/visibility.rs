//! Shadow rays: Haiko's `transport::occlusion::Occluders` (boxes by slab tests, triangles in an
//! obvhs BVH2) against the raw obvhs BVH2 on the same triangles and rays — the sculpture room's OBJ
//! triangles seen from its light, one ray per fine vertex of the room. Shows what the wrapper
//! costs; the first run of this bench measured Haiko's former own f64 BVH at 3.17 ms against
//! obvhs's 1.36 ms, which is why triangles now go to obvhs.

use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use glam::{DVec3, Vec3A};
use haiko::scene::{SurfaceKind, load};
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

criterion_group!(benches, visibility);
criterion_main!(benches);
