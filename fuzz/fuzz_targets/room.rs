//! Room file text: parse and validate (`scene::load::check`), then mesh when the mesh stays
//! small. Files the room names resolve under a directory that does not exist.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;

/// Meshing is only tried below this many vertices (the loader's estimate refuses larger).
const MAX_FUZZ_VERTICES: usize = 20_000;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let path = Path::new("/nonexistent-haiko-fuzz/room.toml");
    let Ok(room) = haiko::scene::load::check(path, text) else {
        return;
    };
    for light in room.lights() {
        assert!(light.position.is_finite() && light.aim.is_finite());
        assert!((light.aim.length() - 1.0).abs() < 1e-9, "unit aim");
        assert!(light.dimmer.is_finite() && light.color.iter().all(|c| c.is_finite()));
        assert!(light.curve.flux_lm().is_finite() && light.curve.norm_squared().is_finite());
    }
    if let Ok(scene) = room.mesh(MAX_FUZZ_VERTICES) {
        for mesh in [&scene.fine, &scene.coarse] {
            assert!(mesh.positions.iter().all(|p| p.is_finite()));
            assert!(mesh.patches.iter().all(|p| p.area.is_finite() && p.area > 0.0));
        }
    }
});
