//! The error type of configuration loading.

use crate::track::TrackFileError;
use std::path::PathBuf;

/// What went wrong while reading a vehicle, scenario or track index file, or a track CSV
/// file one of them names.
///
/// Every variant names the file; the message says which field (dotted TOML path such as
/// `chassis.m`) or which CSV line is at fault and what was expected.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("{}: cannot read file: {source}", file.display())]
    Io {
        /// File that failed.
        file: PathBuf,
        /// Underlying I/O error.
        source: std::io::Error,
    },
    /// The file is not valid TOML or does not match the schema (toml's message keeps line and column).
    #[error("{}: {message}", file.display())]
    Toml {
        /// File that failed.
        file: PathBuf,
        /// toml's message, with line and column.
        message: String,
    },
    /// A required key is absent.
    #[error("{}: {field}: missing (required)", file.display())]
    Missing {
        /// File that failed.
        file: PathBuf,
        /// Dotted TOML path of the missing key.
        field: String,
    },
    /// A key is present but its value is not acceptable.
    #[error("{}: {field} = {value}: {expected}", file.display())]
    Invalid {
        /// File that failed.
        file: PathBuf,
        /// Dotted TOML path of the key.
        field: String,
        /// The offending value as written.
        value: String,
        /// What was expected instead.
        expected: String,
    },
    /// A track CSV file named by the configuration is malformed or does not fit it.
    #[error(transparent)]
    Track(#[from] TrackFileError),
    /// The selection names no entry of a multi-entry file, or none was given where one is needed.
    #[error("{}: {message}; available: {}", file.display(), available.join(", "))]
    Selection {
        /// File that failed.
        file: PathBuf,
        /// What is wrong with the selection.
        message: String,
        /// Names that can be selected.
        available: Vec<String>,
    },
}

impl ConfigError {
    /// Shorthand for [`ConfigError::Invalid`].
    pub(crate) fn invalid(
        file: &std::path::Path,
        field: impl Into<String>,
        value: impl std::fmt::Display,
        expected: impl Into<String>,
    ) -> Self {
        ConfigError::Invalid {
            file: file.to_path_buf(),
            field: field.into(),
            value: value.to_string(),
            expected: expected.into(),
        }
    }
}
