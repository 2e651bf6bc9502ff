//! densepack: dense random packings of hard particles.
#![warn(missing_docs)]

pub mod geometry;
pub mod protocol;
pub mod queue;
