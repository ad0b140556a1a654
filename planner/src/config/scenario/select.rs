//! Entries of multi-entry files: the names of an array of tables and the one selected.

use crate::config::fields::Fields;
use crate::config::ConfigError;

/// Entry names of an array of tables, each required and unique.
pub(super) fn names(
    f: Fields<'_>,
    names: impl Iterator<Item = Option<String>>,
    array: &str,
) -> Result<Vec<String>, ConfigError> {
    let mut out: Vec<String> = Vec::new();
    for (i, n) in names.enumerate() {
        let n = f.req(n, &format!("{array}[{i}].name"))?;
        if out.contains(&n) {
            return Err(f.invalid(
                &format!("{array}[{i}].name"),
                format!("\"{n}\""),
                "duplicate name",
            ));
        }
        out.push(n);
    }
    if out.is_empty() {
        return Err(f.invalid(array, "[]", "needs at least one entry"));
    }
    Ok(out)
}

/// The selected entry of an array of named tables (`array`, entries called `what`), with
/// its name; names must be present and unique.
pub(super) fn pick<T>(
    f: Fields<'_>,
    entries: Vec<T>,
    name_of: impl Fn(&T) -> Option<String>,
    array: &str,
    what: &str,
    select: Option<&str>,
) -> Result<(String, T), ConfigError> {
    let available = names(f, entries.iter().map(name_of), array)?;
    let idx = select_index(f, &available, select, what)?;
    let entry = entries
        .into_iter()
        .nth(idx)
        .ok_or_else(|| f.invalid(array, idx, "index out of range"))?;
    Ok((available[idx].clone(), entry))
}

/// Index of the selected entry among `available`.
fn select_index(
    f: Fields<'_>,
    available: &[String],
    select: Option<&str>,
    what: &str,
) -> Result<usize, ConfigError> {
    let err = |message: String| ConfigError::Selection {
        file: f.file.to_path_buf(),
        message,
        available: available.to_vec(),
    };
    match select {
        Some(s) => available
            .iter()
            .position(|a| a == s)
            .ok_or_else(|| err(format!("no {what} named \"{s}\""))),
        None if available.len() == 1 => Ok(0),
        None => Err(err(format!(
            "the file holds {} {what}s: select one by name",
            available.len()
        ))),
    }
}
