//! Subcommands of the `densepack` binary that live outside `main.rs`.

pub mod analyse;
pub mod bench;
pub mod export;
pub mod init;
pub mod plot;
pub mod progress;
pub mod take;
pub mod verify;
