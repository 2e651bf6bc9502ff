//! Subcommands of the `densepack` binary that live outside `main.rs`.

pub mod export;
