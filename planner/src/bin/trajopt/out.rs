//! Standard output of `trajopt`: every write goes through the core library's
//! [`planner::io::print_stdout`] (the [`outln!`] and [`out!`] macros), which turns a failed
//! write into an error instead of a panic. A reader that went away (a closed pipe, as with
//! `trajopt ... | head`) ends the program quietly with success, like the standard Unix tools;
//! a stream that cannot take the bytes (a full disk) is an error, reported on stderr with
//! exit code 2. Diagnostics go to stderr through [`errln!`] and [`err!`], which ignore a
//! failing stderr.

pub(crate) use planner::{err, errln, out, outln};
