//! Scene parser and validation on arbitrary bytes: never a panic, an abort or a hang;
//! every accepted scene satisfies the invariants the run relies on.
#![no_main]

use densepack::io::scene::{Method, Scene, MAX_PARTICLES};
use libfuzzer_sys::fuzz_target;
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(scene) = Scene::from_toml(text) else {
        return;
    };
    // What the run is promised by validation.
    assert!(scene.method == Method::Rsa || !scene.stages.is_empty());
    let volume = scene.container_volume();
    assert!(volume.is_finite() && volume > 0.0);
    for stage in &scene.stages {
        let _ = densepack::run::kernel_stage(stage, 1.0);
    }
    // Seeding sizes, when few enough to list cheaply (grading curves draw theirs).
    if let Some(count) = scene.particle_count() {
        assert!(count <= MAX_PARTICLES);
        if count <= 100_000 {
            let diameters = scene.true_diameters(&mut Xoshiro256PlusPlus::seed_from_u64(scene.seed));
            assert_eq!(diameters.len(), count);
            let scale = scene.seed_scale(&diameters);
            assert!(diameters
                .iter()
                .all(|d| (d * scale).is_finite() && d * scale > 0.0));
        }
    }
});
