//! IES LM-63 bytes, as `read_lid_file` would see them.
#![no_main]

use std::path::Path;

use haiko::photometry::{MAX_INTENSITY_CD, parse_lid_bytes, write_ies};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(lid) = parse_lid_bytes(Path::new("fuzz.ies"), data) else {
        return;
    };
    assert!(lid.asymmetry.is_finite() && lid.asymmetry >= 0.0);
    assert!(lid.curve.intensities_cd().iter().all(|&cd| (0.0..=MAX_INTENSITY_CD).contains(&cd)));
    assert!(lid.curve.flux_lm().is_finite());
    // What Haiko writes it reads back to the same curve.
    let written = write_ies(&lid.curve, &lid.luminaire);
    let again = parse_lid_bytes(Path::new("again.ies"), written.as_bytes()).expect("written IES reads");
    assert_eq!(again.curve, lid.curve);
});
