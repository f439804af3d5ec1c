//! An OBJ and its material library: the input is the OBJ's bytes, a NUL byte, then the MTL's
//! bytes (returned for every `mtllib`).
#![no_main]

use std::path::Path;

use glam::DVec3;
use haiko::scene::obj::{Placement, parse_obj};
use haiko::scene::room_file::UpAxis;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let (obj, mtl) = match data.iter().position(|&b| b == 0) {
        Some(at) => (&data[..at], &data[at + 1..]),
        None => (data, &[][..]),
    };
    let placement = Placement {
        up: UpAxis::Y,
        scale: 1.0,
        translate: DVec3::ZERO,
    };
    let read_mtl = |_: &Path| Ok(mtl.to_vec());
    let Ok(surfaces) = parse_obj(Path::new("fuzz/m.obj"), obj, 0, &placement, &read_mtl) else {
        return;
    };
    for s in &surfaces {
        let g = &s.geometry;
        assert!(g.positions.iter().all(|p| p.is_finite()));
        assert!(g.triangles.iter().flatten().all(|&i| (i as usize) < g.positions.len()));
        assert!(s.reflectance.0.iter().all(|r| (0.0..0.98).contains(r)));
    }
});
