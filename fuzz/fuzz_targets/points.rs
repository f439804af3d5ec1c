//! A `probe` points file.
#![no_main]

use std::path::Path;

use haiko::scene::points::parse_points;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(points) = parse_points(text, Path::new("fuzz.csv")) else {
        return;
    };
    for p in points {
        assert!(p.point.is_finite());
        assert!((p.normal.length() - 1.0).abs() < 1e-12, "unit normal {:?}", p.normal);
    }
});
