//! Output files and standard output that fail loudly and never leave half a file.
//!
//! A file is written whole or not at all: [`write_atomic`] writes a temporary file beside
//! the destination ([`temp_path`], same folder and so the same file system), flushes and
//! syncs it, and renames it over the destination; on any failure it removes the temporary
//! file and returns a [`WriteError`] that names the destination and the operating system's
//! reason (e.g. "No space left on device (os error 28)"). A reader of the destination sees
//! the old file or the complete new one, never a truncated one.
//!
//! Standard output is written with [`write_stdout`], which flushes after every write so a
//! failure surfaces at the write that caused it; [`is_closed`] tells a reader that went
//! away (a closed pipe, as with `| head`) from a stream that cannot take the bytes (a full
//! disk). Diagnostics go to standard error with [`write_stderr`], which never fails.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Why an output file could not be written (the file under its final name).
#[derive(Debug, thiserror::Error)]
#[error("{}: cannot write: {source}", path.display())]
pub struct WriteError {
    /// The destination.
    pub path: PathBuf,
    /// The operating system's reason.
    pub source: std::io::Error,
}

/// The temporary file [`write_atomic`] writes for `path`: hidden, in the same folder, named
/// after the destination and this process, and ending in the destination's extension (an
/// encoder chosen by extension picks the right format).
pub fn temp_path(path: &Path) -> PathBuf {
    let stem = path
        .file_stem()
        .map_or_else(|| "output".into(), |n| n.to_string_lossy().into_owned());
    let name = match path.extension() {
        Some(ext) => format!(
            ".{stem}.{}.tmp.{}",
            std::process::id(),
            ext.to_string_lossy()
        ),
        None => format!(".{stem}.{}.tmp", std::process::id()),
    };
    path.with_file_name(name)
}

/// Writes `path` atomically: `write` fills a buffered temporary file ([`temp_path`]), which
/// is flushed, synced to the disk and renamed to `path`. On failure the temporary file is
/// removed and `path` is left as it was.
pub fn write_atomic<F>(path: &Path, write: F) -> Result<(), WriteError>
where
    F: FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
{
    let tmp = temp_path(path);
    let result = File::create(&tmp).and_then(|file| {
        let mut w = BufWriter::new(file);
        write(&mut w)?;
        let file = w.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()
    });
    let result = result.and_then(|()| std::fs::rename(&tmp, path));
    result.map_err(|source| {
        let _ = std::fs::remove_file(&tmp);
        WriteError {
            path: path.to_path_buf(),
            source,
        }
    })
}

/// Writes `args` to standard output and flushes it.
pub fn write_stdout(args: std::fmt::Arguments) -> std::io::Result<()> {
    let mut out = std::io::stdout().lock();
    out.write_fmt(args)?;
    out.flush()
}

/// Writes `args` to standard error and flushes it; a failure is dropped, as there is no
/// stream left to report it on (a diagnostic never turns into a panic or an exit code).
pub fn write_stderr(args: std::fmt::Arguments) {
    let mut err = std::io::stderr().lock();
    let _ = err.write_fmt(args).and_then(|()| err.flush());
}

/// Whether a write failed because its reader went away (a closed pipe): the output is no
/// longer wanted, which is not a failure of the program.
pub fn is_closed(e: &std::io::Error) -> bool {
    e.kind() == std::io::ErrorKind::BrokenPipe
}

/// Writes `args` to standard output for a command-line program (the [`out!`](crate::out)
/// and [`outln!`](crate::outln) macros): a reader that went away (a closed pipe, as with
/// `trajopt ... | head`) ends the program quietly with success, like the standard Unix
/// tools; any other failure (a full disk) is returned as an error naming the stream and the
/// operating system's reason, for the program to report with exit code 2.
pub fn print_stdout(args: std::fmt::Arguments) -> Result<(), String> {
    match write_stdout(args) {
        Ok(()) => Ok(()),
        Err(e) if is_closed(&e) => std::process::exit(0),
        Err(e) => Err(format!("standard output: cannot write: {e}")),
    }
}

/// `print!` through [`io::print_stdout`](crate::io::print_stdout); returns its error from
/// the enclosing function (which returns `Result<_, String>`).
#[macro_export]
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::io::print_stdout(format_args!($($arg)*))?
    };
}

/// `println!` through [`io::print_stdout`](crate::io::print_stdout); returns its error from
/// the enclosing function (which returns `Result<_, String>`).
#[macro_export]
macro_rules! outln {
    ($($arg:tt)*) => {
        $crate::io::print_stdout(format_args!("{}\n", format_args!($($arg)*)))?
    };
}

/// `eprint!` through [`io::write_stderr`](crate::io::write_stderr): a failing stderr is
/// ignored, not a panic.
#[macro_export]
macro_rules! err {
    ($($arg:tt)*) => {
        $crate::io::write_stderr(format_args!($($arg)*))
    };
}

/// `eprintln!` through [`io::write_stderr`](crate::io::write_stderr): a failing stderr is
/// ignored, not a panic.
#[macro_export]
macro_rules! errln {
    ($($arg:tt)*) => {
        $crate::io::write_stderr(format_args!("{}\n", format_args!($($arg)*)))
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp_dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("planner-io-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn a_complete_write_replaces_the_file_and_leaves_no_temporary() {
        let d = temp_dir("complete");
        let f = d.join("a.csv");
        std::fs::write(&f, "old").unwrap();
        write_atomic(&f, |w| w.write_all(b"new")).unwrap();
        assert_eq!(std::fs::read_to_string(&f).unwrap(), "new");
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 1);
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn a_failed_write_keeps_the_old_file_and_names_the_destination() {
        let d = temp_dir("failed");
        let f = d.join("a.csv");
        std::fs::write(&f, "old").unwrap();
        let e = write_atomic(&f, |w| {
            w.write_all(b"half")?;
            Err(std::io::Error::other("disk gone"))
        })
        .unwrap_err();
        assert!(e.to_string().starts_with(&f.display().to_string()), "{e}");
        assert!(e.to_string().contains("disk gone"), "{e}");
        assert_eq!(std::fs::read_to_string(&f).unwrap(), "old");
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 1);
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn the_temporary_file_keeps_the_extension_and_the_folder() {
        let t = temp_path(Path::new("out/oval.png"));
        assert_eq!(t.parent(), Some(Path::new("out")));
        assert_eq!(t.extension().and_then(|e| e.to_str()), Some("png"));
        assert!(t
            .file_name()
            .unwrap()
            .to_string_lossy()
            .starts_with(".oval."));
    }
}
