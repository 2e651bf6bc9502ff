//! densepack: dense random packings of hard particles.
//!
//! Event-driven molecular dynamics of growing hard spheres and ellipsoids
//! (Lubachevsky–Stillinger), random sequential addition, sphere + cylinder mixtures and
//! grading curves for concrete and composite mesostructures. The `densepack` binary reads a
//! scene file (TOML, described in `docs/scenes.md`); the library runs the same scenes from
//! Rust:
//!
//! - [`io::scene::Scene`] parses and validates a scene ([`io::scene::Scene::from_toml`]);
//! - [`run::run_scene`] seeds, runs the stages and checks the result independently
//!   ([`run::RunOutcome`]: the packing, a report per stage, the verification);
//!   [`run::run`] runs any scene ([`io::scene::AnyScene`], mixtures too) with
//!   [`run::RunOptions`]: checkpoints, a cancel flag another thread may set
//!   ([`cancel`]), observers;
//! - [`io::scene::AnyScene::with_values`] and [`io::scene::AnyScene::with_seed`] change a
//!   scene without editing its file; [`ensemble`] runs one realisation per seed into a
//!   directory with a resumable `summary.csv`;
//! - [`verify::verify`] checks any [`io::packing::Packing`] for overlaps and gaps;
//! - [`io::export`] writes it for meshing, visualisation or voxel solvers.
//!
//! Same scene, seed and version give the same particles bit for bit.
//!
//! The default feature `cli` builds the `densepack` binary and its dependencies (clap,
//! indicatif, plotters, cpu-time); the library needs none of them:
//! `densepack = { version = "0.7", default-features = false }`.
//!
//! # Example
//!
//! Three hundred equal spheres seeded at packing fraction 0.3 in a periodic cube and grown to
//! 0.55 (the goal is met exactly); the check at the end is independent of the library's:
//!
//! ```
//! use densepack::io::packing::ParticleRecord;
//! use densepack::io::scene::Scene;
//!
//! let scene = Scene::from_toml(
//!     r#"
//!     seed = 7
//!     [container]
//!     type = "box"
//!     size = [8.1, 8.1, 8.1]
//!     periodic = [true, true, true]
//!     [particles]
//!     count = 300
//!     diameter = 1.0
//!     packing_fraction = 0.3
//!     [[stage]]
//!     growth = "relative"
//!     rate = 0.1
//!     until = { packing_fraction = 0.55 }
//!     "#,
//! )?;
//! let outcome = densepack::run::run_scene(&scene, &mut |_stage, _report| {})?;
//! assert!(outcome.verification.ok());
//!
//! // The packing fraction and the absence of overlaps, recomputed from the records.
//! let edge = 8.1_f64;
//! let spheres: Vec<([f64; 3], f64)> = outcome
//!     .packing
//!     .particles
//!     .iter()
//!     .map(|p| match p {
//!         ParticleRecord::Sphere(s) => (s.center, s.radius),
//!         _ => unreachable!("the scene holds spheres only"),
//!     })
//!     .collect();
//! assert_eq!(spheres.len(), 300);
//! let volume: f64 = spheres
//!     .iter()
//!     .map(|(_, r)| 4.0 / 3.0 * std::f64::consts::PI * r.powi(3))
//!     .sum();
//! assert!((volume / edge.powi(3) - 0.55).abs() < 1e-9);
//! for (i, (a, ra)) in spheres.iter().enumerate() {
//!     for (b, rb) in &spheres[i + 1..] {
//!         let d2: f64 = (0..3)
//!             .map(|k| {
//!                 let d = a[k] - b[k];
//!                 let d = d - edge * (d / edge).round(); // minimum image
//!                 d * d
//!             })
//!             .sum();
//!         assert!(d2.sqrt() >= (ra + rb) * (1.0 - 1e-9));
//!     }
//! }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! `examples/pack_verify_export.rs` packs, verifies and exports through the same API.
#![warn(missing_docs)]

pub mod analysis;
pub mod boundary;
pub mod cancel;
pub mod ensemble;
pub mod geometry;
pub mod io;
pub mod kernel;
pub mod memory;
pub mod protocol;
pub mod queue;
pub mod run;
pub mod shape;
pub mod spatial;
pub mod tuning;
pub mod verify;

/// Hints the processor to load the cache lines of `value` (a no-op where there is no
/// prefetch instruction). Written here: no maintained crate offers a portable prefetch.
///
/// One hint per 64 bytes from the start, plus one for the last byte unless no value of `T`
/// can straddle a line: a value that does not start on a line boundary touches one line
/// more than its size suggests, except when its alignment divides 64 and its size is at
/// most its alignment (a 32-byte record aligned to 32 lies in one line). The count is a
/// compile-time constant, so the hints unroll without a branch (counting the lines the
/// address actually touches costs a data-dependent loop per partner).
#[inline(always)]
pub(crate) fn prefetch<T>(value: &T) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        let start = value as *const T as *const i8;
        let size = std::mem::size_of::<T>();
        let mut offset = 0;
        while offset < size {
            // SAFETY: prefetching never faults, and the address lies inside `value`.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(start.wrapping_add(offset)) };
            offset += 64;
        }
        let align = std::mem::align_of::<T>();
        let may_straddle = !(align.is_multiple_of(64) || (64 % align == 0 && size <= align));
        if may_straddle {
            let last = start.wrapping_add(size.saturating_sub(1));
            // SAFETY: as above.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(last) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = value;
}
