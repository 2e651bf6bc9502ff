//! Packing reader and the independent verification on arbitrary bytes: never a panic, an
//! abort or a hang, whatever a file claims.
#![no_main]

use densepack::io::packing::Packing;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(packing) = Packing::from_json(text, "fuzz") else {
        return;
    };
    let report = densepack::verify::verify(&packing);
    assert_eq!(report.particles, packing.particles.len());
    assert!(report.violations.len() <= report.violation_count);
});
