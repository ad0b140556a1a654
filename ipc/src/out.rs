//! Writes to the process's standard streams that never panic.
//!
//! The processes run as children of `trajopt closed-loop`, which reads their stdout and
//! stderr through pipes. Rust ignores SIGPIPE, so once the parent is gone a write returns
//! `EPIPE` (`BrokenPipe`), and `println!`/`eprintln!` would panic on it. A log line on
//! stderr has nowhere else to go, so its failure is ignored; the final JSON line on stdout
//! treats a closed pipe as a quiet end (nobody is left to read it).

use std::fmt::{Arguments, Display};
use std::io;

use planner::io::{is_closed, write_stderr, write_stdout};

/// Writes one line to stderr, ignoring a failed write.
pub fn log_line(args: Arguments<'_>) {
    write_stderr(format_args!("{args}\n"));
}

/// `eprintln!` through [`log_line`]: formats one stderr line and never panics.
#[macro_export]
macro_rules! elog {
    ($($arg:tt)*) => {
        $crate::out::log_line(format_args!($($arg)*))
    };
}

/// Writes `line` and a newline to stdout and flushes it. A closed stdout (`BrokenPipe`)
/// is a quiet end and returns `Ok`; other write errors are returned.
pub fn print_line(line: &dyn Display) -> io::Result<()> {
    match write_stdout(format_args!("{line}\n")) {
        Err(e) if is_closed(&e) => Ok(()),
        r => r,
    }
}
