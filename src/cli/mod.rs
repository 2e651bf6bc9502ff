//! Subcommands of the `densepack` binary that live outside `main.rs`.

// First: its printing macros serve every module after it.
#[macro_use]
pub mod out;

pub mod analyse;
pub mod bench;
pub mod ensemble;
pub mod export;
pub mod import;
pub mod init;
pub mod paths;
pub mod plot;
pub mod progress;
pub mod studies;
pub mod take;
pub mod verify;
