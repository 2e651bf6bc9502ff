//! Printing that never panics: `println!` panics when stdout is a closed pipe
//! (`densepack verify P | head`), `eprintln!` when stderr is.
//!
//! A closed pipe is not an error: the reader has what it wanted, and the command finishes
//! its work (a run still writes its packing) and exits with its usual code. Any other
//! failure to write stdout (a full disk behind a redirection) is remembered and turns a
//! successful exit into exit 1 ([`finish`]), so a truncated report never passes for a whole
//! one. Failures to write stderr are dropped: there is nowhere left to report them.

use std::io::Write;
use std::process::ExitCode;
use std::sync::OnceLock;

/// The first failure to write stdout other than a closed pipe.
static STDOUT_FAILURE: OnceLock<String> = OnceLock::new();

/// Writes to stdout (see the module documentation for errors).
pub fn stdout(args: std::fmt::Arguments) {
    let mut out = std::io::stdout().lock();
    if let Err(e) = out.write_fmt(args).and_then(|()| out.flush()) {
        if e.kind() != std::io::ErrorKind::BrokenPipe {
            let _ = STDOUT_FAILURE.set(e.to_string());
        }
    }
}

/// Writes to stderr, ignoring failures.
pub fn stderr(args: std::fmt::Arguments) {
    let _ = std::io::stderr().lock().write_fmt(args);
}

/// The exit code of a command that ended with `code`: exit 1 instead of success if stdout
/// could not be written (other than a closed pipe).
pub fn finish(code: ExitCode) -> ExitCode {
    match STDOUT_FAILURE.get() {
        Some(e) => {
            stderr(format_args!("error: writing to stdout: {e}\n"));
            if code == ExitCode::SUCCESS {
                ExitCode::from(1)
            } else {
                code
            }
        }
        None => code,
    }
}

/// `print!` that never panics ([`stdout`]).
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::cli::out::stdout(format_args!($($arg)*))
    };
}

/// `println!` that never panics ([`stdout`]).
macro_rules! outln {
    () => {
        $crate::cli::out::stdout(format_args!("\n"))
    };
    ($($arg:tt)*) => {
        $crate::cli::out::stdout(format_args!("{}\n", format_args!($($arg)*)))
    };
}

/// `eprintln!` that never panics ([`stderr`]).
macro_rules! errln {
    ($($arg:tt)*) => {
        $crate::cli::out::stderr(format_args!("{}\n", format_args!($($arg)*)))
    };
}

/// `eprint!` that never panics ([`stderr`]).
#[allow(unused_macros)]
macro_rules! err {
    ($($arg:tt)*) => {
        $crate::cli::out::stderr(format_args!($($arg)*))
    };
}
