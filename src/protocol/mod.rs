//! Protocols that drive or seed the kernel: random sequential addition, the grading-curve
//! take phase; and the sphere + cylinder mixtures (RSA and the time-driven relaxer).

pub mod mixture;
pub mod rsa;
pub mod slp;
pub mod take_phase;
