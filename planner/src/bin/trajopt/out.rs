//! Standard output of `trajopt`: every write goes through [`print()`] (the [`outln!`] and
//! [`out!`] macros), which turns a failed write into an error instead of a panic. A reader
//! that went away (a closed pipe, as with `trajopt ... | head`) ends the program quietly
//! with success, like the standard Unix tools; a stream that cannot take the bytes (a full
//! disk) is an error, reported on stderr with exit code 2. Diagnostics go to stderr through
//! [`errln!`] and [`err!`], which ignore a failing stderr.

/// Writes `args` to stdout; exits with success when stdout is a closed pipe, and returns
/// the error (naming the stream and the operating system's reason) when the write fails
/// otherwise.
pub fn print(args: std::fmt::Arguments) -> Result<(), String> {
    match planner::io::write_stdout(args) {
        Ok(()) => Ok(()),
        Err(e) if planner::io::is_closed(&e) => std::process::exit(0),
        Err(e) => Err(format!("standard output: cannot write: {e}")),
    }
}

/// `print!` to stdout through [`print()`]; returns its error from the enclosing function.
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::out::print(format_args!($($arg)*))?
    };
}

/// `println!` to stdout through [`print()`]; returns its error from the enclosing function.
macro_rules! outln {
    ($($arg:tt)*) => {
        $crate::out::print(format_args!("{}\n", format_args!($($arg)*)))?
    };
}

/// `eprint!` through [`planner::io::write_stderr`]: a failing stderr is ignored, not a
/// panic.
macro_rules! err {
    ($($arg:tt)*) => {
        planner::io::write_stderr(format_args!($($arg)*))
    };
}

/// `eprintln!` through [`planner::io::write_stderr`]: a failing stderr is ignored, not a
/// panic.
macro_rules! errln {
    ($($arg:tt)*) => {
        planner::io::write_stderr(format_args!("{}\n", format_args!($($arg)*)))
    };
}

pub(crate) use {err, errln, out, outln};
