//! The error type of track file loading.

use std::path::{Path, PathBuf};

/// What went wrong while reading a track CSV file (a canonical profile or a raw
/// centerline).
///
/// Every variant names the file; the message says which CSV line or which parameter is at
/// fault and what was expected.
#[derive(Debug, thiserror::Error)]
pub enum TrackFileError {
    /// The file could not be read.
    #[error("{}: cannot read file: {source}", file.display())]
    Io {
        /// File that failed.
        file: PathBuf,
        /// Underlying I/O error.
        source: std::io::Error,
    },
    /// A CSV line is malformed or out of range (`line` is 1-based; 0 for the file as a whole).
    #[error("{}:{line}: {message}", file.display())]
    Csv {
        /// File that failed.
        file: PathBuf,
        /// 1-based line number (0: the whole file).
        line: usize,
        /// What is wrong with the line.
        message: String,
    },
    /// A parameter given with the file (such as the lap length) does not fit it.
    #[error("{}: {field} = {value}: {expected}", file.display())]
    Invalid {
        /// File that failed.
        file: PathBuf,
        /// Name of the parameter.
        field: String,
        /// The offending value.
        value: String,
        /// What was expected instead.
        expected: String,
    },
}

impl TrackFileError {
    /// Shorthand for [`TrackFileError::Csv`].
    pub(crate) fn csv(file: &Path, line: usize, message: impl Into<String>) -> Self {
        TrackFileError::Csv {
            file: file.to_path_buf(),
            line,
            message: message.into(),
        }
    }

    /// Shorthand for [`TrackFileError::Invalid`].
    pub(crate) fn invalid(
        file: &Path,
        field: impl Into<String>,
        value: impl std::fmt::Display,
        expected: impl Into<String>,
    ) -> Self {
        TrackFileError::Invalid {
            file: file.to_path_buf(),
            field: field.into(),
            value: value.to_string(),
            expected: expected.into(),
        }
    }
}
