//! The one error type of configuration and track loading.

use std::path::PathBuf;

/// What went wrong while reading a vehicle, scenario, track index or track CSV file.
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

    /// Shorthand for [`ConfigError::Csv`].
    pub(crate) fn csv(file: &std::path::Path, line: usize, message: impl Into<String>) -> Self {
        ConfigError::Csv {
            file: file.to_path_buf(),
            line,
            message: message.into(),
        }
    }
}
