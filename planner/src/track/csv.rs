//! A minimal numeric CSV reader with line numbers (no quoting: the track files need none).

use super::TrackFileError;
use std::path::Path;

/// One data row: its 1-based line number in the file and its `N` values (all finite).
pub(crate) struct Row<const N: usize> {
    /// 1-based line number.
    pub line: usize,
    /// The values, in column order.
    pub values: [f64; N],
}

/// Reads a CSV of `N` finite numbers per row.
///
/// Blank lines and lines starting with `#` are skipped. With `header`, the first other
/// line must name exactly `columns`; without it every other line is data.
pub(crate) fn read_rows<const N: usize>(
    file: &Path,
    columns: &[&str; N],
    header: bool,
) -> Result<Vec<Row<N>>, TrackFileError> {
    let text = std::fs::read_to_string(file).map_err(|source| TrackFileError::Io {
        file: file.to_path_buf(),
        source,
    })?;
    let mut rows = Vec::new();
    let mut need_header = header;
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let trimmed = raw.trim_start_matches('\u{feff}').trim();
        if trimmed.is_empty() || trimmed.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = trimmed.split(',').map(str::trim).collect();
        if need_header {
            if fields.as_slice() != columns.as_slice() {
                return Err(TrackFileError::csv(
                    file,
                    line,
                    format!("header must be `{}`, found `{trimmed}`", columns.join(",")),
                ));
            }
            need_header = false;
            continue;
        }
        if fields.len() != N {
            return Err(TrackFileError::csv(
                file,
                line,
                format!(
                    "expected {N} columns ({}), found {}",
                    columns.join(","),
                    fields.len()
                ),
            ));
        }
        let mut values = [0.0; N];
        for (k, (v, name)) in values.iter_mut().zip(columns).enumerate() {
            let x: f64 = fields[k].parse().map_err(|_| {
                TrackFileError::csv(
                    file,
                    line,
                    format!("{name} = `{}`: not a number", fields[k]),
                )
            })?;
            if !x.is_finite() {
                return Err(TrackFileError::csv(
                    file,
                    line,
                    format!("{name} = {x}: must be finite"),
                ));
            }
            *v = x;
        }
        rows.push(Row { line, values });
    }
    if need_header {
        return Err(TrackFileError::csv(
            file,
            0,
            format!("empty file: expected the header `{}`", columns.join(",")),
        ));
    }
    if rows.is_empty() {
        return Err(TrackFileError::csv(file, 0, "no data rows"));
    }
    Ok(rows)
}
