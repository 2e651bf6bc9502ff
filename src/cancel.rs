//! Cooperative cancellation: a flag another thread sets to stop a run.
//!
//! A run given a flag (`crate::run::RunOptions::cancel`) checks it where it checks its
//! wall-clock limit: every `CHECK_EVERY` (1000) events and at every time barrier of an EDMD
//! stage, at every candidate of random sequential addition (spheres and mixtures) and at
//! every step of the mixture relaxer; each of these is well under 10 ms of work. The `[jam]`
//! step checks it between its linear programs and at each iteration of the solver (one
//! sparse factorisation: under a second at 10³ spheres, about ten seconds at 10⁴). A check
//! is one relaxed atomic load. Setting the flag never yields a packing: the run
//! ends with `RunError::Cancelled`.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// The flag: `true` asks the run to stop. Shared between the run and whoever stops it.
pub type CancelFlag = Arc<AtomicBool>;

/// Whether `flag` is given and set (a relaxed load: the run stops at its next check, and
/// nothing else is synchronised through the flag).
#[inline]
pub fn is_set(flag: Option<&AtomicBool>) -> bool {
    flag.is_some_and(|f| f.load(Ordering::Relaxed))
}
