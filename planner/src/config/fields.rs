//! Reading a TOML file into serde types and checking single values, with errors that name
//! the file and the dotted field.

use super::ConfigError;
use serde::de::DeserializeOwned;
use std::path::Path;

/// Reads a whole file, mapping I/O errors to [`ConfigError::Io`].
pub(crate) fn read_text(file: &Path) -> Result<String, ConfigError> {
    std::fs::read_to_string(file).map_err(|source| ConfigError::Io {
        file: file.to_path_buf(),
        source,
    })
}

/// Deserializes TOML text; toml's message (line, column, snippet) is kept.
pub(crate) fn parse_toml<T: DeserializeOwned>(file: &Path, text: &str) -> Result<T, ConfigError> {
    toml::from_str(text).map_err(|e| ConfigError::Toml {
        file: file.to_path_buf(),
        message: e.to_string().trim_end().to_string(),
    })
}

/// Checks on values of one file; every error names `file` and the dotted field.
#[derive(Clone, Copy)]
pub(crate) struct Fields<'a> {
    /// The file the values come from.
    pub file: &'a Path,
    /// The interval count a horizon must have (the planner's compiled-in N), if any.
    pub horizon: Option<usize>,
}

impl<'a> Fields<'a> {
    /// Creates the checker for `file`.
    pub fn new(file: &'a Path) -> Self {
        Fields {
            file,
            horizon: None,
        }
    }

    /// The value, or [`ConfigError::Missing`].
    pub fn req<T>(&self, v: Option<T>, field: &str) -> Result<T, ConfigError> {
        v.ok_or_else(|| ConfigError::Missing {
            file: self.file.to_path_buf(),
            field: field.to_string(),
        })
    }

    /// [`ConfigError::Invalid`] for this file.
    pub fn invalid(
        &self,
        field: &str,
        value: impl std::fmt::Display,
        expected: impl Into<String>,
    ) -> ConfigError {
        ConfigError::invalid(self.file, field, value, expected)
    }

    /// A present, finite number.
    pub fn num(&self, v: Option<f64>, field: &str) -> Result<f64, ConfigError> {
        let x = self.req(v, field)?;
        if x.is_finite() {
            Ok(x)
        } else {
            Err(self.invalid(field, x, "must be a finite number"))
        }
    }

    /// A present, finite, strictly positive number.
    pub fn pos(&self, v: Option<f64>, field: &str) -> Result<f64, ConfigError> {
        let x = self.num(v, field)?;
        if x > 0.0 {
            Ok(x)
        } else {
            Err(self.invalid(field, x, "must be positive"))
        }
    }

    /// A present, finite, non-negative number.
    pub fn non_neg(&self, v: Option<f64>, field: &str) -> Result<f64, ConfigError> {
        let x = self.num(v, field)?;
        if x >= 0.0 {
            Ok(x)
        } else {
            Err(self.invalid(field, x, "must be >= 0"))
        }
    }

    /// A present integer in 1..=1_000_000 (an interval count; the cap guards allocations).
    pub fn count(&self, v: Option<i64>, field: &str) -> Result<usize, ConfigError> {
        let n = self.req(v, field)?;
        usize::try_from(n)
            .ok()
            .filter(|n| (1..=1_000_000).contains(n))
            .ok_or_else(|| self.invalid(field, n, "must be an integer >= 1 (at most 1000000)"))
    }

    /// A present string equal to one of `allowed`.
    pub fn one_of(
        &self,
        v: Option<&str>,
        field: &str,
        allowed: &[&str],
    ) -> Result<usize, ConfigError> {
        let s = self.req(v, field)?;
        allowed.iter().position(|a| *a == s).ok_or_else(|| {
            let list: Vec<String> = allowed.iter().map(|a| format!("\"{a}\"")).collect();
            self.invalid(
                field,
                format!("\"{s}\""),
                format!("must be one of {}", list.join(", ")),
            )
        })
    }
}
