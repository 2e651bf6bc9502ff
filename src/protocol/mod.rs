//! Protocols that drive or seed the kernel: random sequential addition, the grading-curve
//! take phase.

pub mod rsa;
pub mod take_phase;
