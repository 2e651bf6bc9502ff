//! Files: scene descriptions in, packings out.

pub mod checkpoint;
pub mod packing;
pub mod scene;
