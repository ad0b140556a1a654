//! Where a path given on a command line points: the working directory first, else the
//! repository the executable was built from.

use std::path::{Path, PathBuf};

/// `path` as given when it exists or is absolute; else the same relative path under the
/// repository this crate was built from, when that exists; else `path` unchanged (so the
/// error that follows names the path the user gave). Lets the executables find their
/// default files (`config/...`) from any folder of a clone.
pub fn resolve_path(path: &Path) -> PathBuf {
    if path.exists() || path.is_absolute() {
        return path.to_path_buf();
    }
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(path);
    if repo.exists() {
        repo
    } else {
        path.to_path_buf()
    }
}
