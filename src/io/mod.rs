//! Files: scene descriptions in, packings out.

pub mod checkpoint;
pub mod export;
pub mod import;
pub mod packing;
pub mod record;
pub mod scene;
pub mod units;
