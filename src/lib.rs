//! densepack: dense random packings of hard particles.
#![warn(missing_docs)]

pub mod analysis;
pub mod bench;
pub mod boundary;
pub mod geometry;
pub mod io;
pub mod kernel;
pub mod protocol;
pub mod queue;
pub mod run;
pub mod shape;
pub mod spatial;
pub mod verify;
