//! Files: scene descriptions in, packings out.

pub mod packing;
pub mod scene;
