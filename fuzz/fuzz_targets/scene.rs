//! Scene parser and validation on arbitrary bytes: never a panic, an abort or a hang;
//! every accepted scene satisfies the invariants the run relies on.
#![no_main]

use densepack::io::scene::{Scene, MAX_PARTICLES};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(scene) = Scene::from_toml(text) else {
        return;
    };
    // What the run is promised by validation.
    assert!(!scene.stages.is_empty());
    let volume = scene.container_volume();
    assert!(volume.is_finite() && volume > 0.0);
    assert!(scene.particle_count() <= MAX_PARTICLES);
    for stage in &scene.stages {
        let _ = stage.to_stage();
    }
    // Seeding sizes, when few enough to list cheaply.
    if scene.particle_count() <= 100_000 {
        let diameters = scene.seeding_diameters();
        assert_eq!(diameters.len(), scene.particle_count());
        assert!(diameters.iter().all(|d| d.is_finite() && *d > 0.0));
    }
});
