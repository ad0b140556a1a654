//! `trajopt` on streams and files that fail: a full stdout (`/dev/full`) is an error with
//! exit code 2 and no panic, a closed pipe ends quietly with success, and an output file
//! that cannot be written is an error naming it, with nothing left under its name.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

fn trajopt() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_trajopt"));
    c.current_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/.."));
    c
}

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("trajopt-streams-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs `args` with stdout on `/dev/full`.
fn to_dev_full(args: &[&str]) -> Output {
    let full = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/full")
        .expect("/dev/full");
    trajopt()
        .args(args)
        .stdout(Stdio::from(full))
        .stderr(Stdio::piped())
        .output()
        .unwrap()
}

/// Runs `args` with stdout a pipe whose read end is closed before the child writes.
fn to_closed_pipe(args: &[&str]) -> Output {
    let mut child = trajopt()
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    child.wait_with_output().unwrap()
}

fn assert_full_stdout_is_an_error(out: &Output) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(
        err.contains("standard output") && err.contains("No space left on device"),
        "{err}"
    );
}

/// The files of `dir` whose name starts with a dot (the temporary files of atomic writes).
fn temporaries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect()
}

#[test]
fn a_full_stdout_is_an_error_with_exit_2_for_solve_json() {
    assert_full_stdout_is_an_error(&to_dev_full(&["solve", "--json", "--no-output"]));
}

#[test]
fn a_full_stdout_is_an_error_with_exit_2_for_guess_json_and_text() {
    assert_full_stdout_is_an_error(&to_dev_full(&["guess", "--json"]));
    assert_full_stdout_is_an_error(&to_dev_full(&["guess"]));
}

#[test]
fn a_closed_stdout_ends_quietly_with_success() {
    for args in [
        &["guess", "--json"][..],
        &["guess"][..],
        &["solve", "--no-output"][..],
    ] {
        let out = to_closed_pipe(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
}

#[test]
fn an_output_file_that_cannot_be_written_is_an_error_naming_it() {
    // A directory where the CSV should go: the rename onto it fails.
    let d = temp_dir("csv-dir");
    std::fs::create_dir(d.join("oval.csv")).unwrap();
    let out = trajopt()
        .args(["solve", "--out-dir"])
        .arg(&d)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(err.contains("oval.csv: cannot write"), "{err}");
    assert!(d.join("oval.csv").is_dir());
    assert!(!d.join("oval.png").exists(), "{err}");
    assert!(temporaries(&d).is_empty(), "{:?}", temporaries(&d));
    let _ = std::fs::remove_dir_all(&d);

    // A directory where the figure should go: the figure is an error, not a warning.
    let d = temp_dir("png-dir");
    std::fs::create_dir(d.join("oval.png")).unwrap();
    let out = trajopt()
        .args(["solve", "--out-dir"])
        .arg(&d)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("oval.png: cannot write"), "{err}");
    assert!(d.join("oval.png").is_dir());
    assert!(temporaries(&d).is_empty(), "{:?}", temporaries(&d));
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn an_out_dir_under_a_file_is_an_error_naming_it() {
    let d = temp_dir("file-as-dir");
    let file = d.join("plain");
    std::fs::write(&file, "not a folder").unwrap();
    let out = trajopt()
        .args(["solve", "--out-dir"])
        .arg(file.join("out"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("plain/out: cannot create"), "{err}");
    let _ = std::fs::remove_dir_all(&d);
}

/// A read-only output folder (skipped where the test runs with the rights to write into
/// it anyway, as root does).
#[test]
fn a_read_only_out_dir_is_an_error_and_leaves_no_file() {
    use std::os::unix::fs::PermissionsExt;
    let d = temp_dir("read-only");
    let ro = d.join("ro");
    std::fs::create_dir(&ro).unwrap();
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o555)).unwrap();
    if std::fs::write(ro.join("probe"), "x").is_ok() {
        let _ = std::fs::remove_dir_all(&d);
        return;
    }
    let out = trajopt()
        .args(["solve", "--out-dir"])
        .arg(&ro)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("oval.csv: cannot write") && err.contains("Permission denied"),
        "{err}"
    );
    assert_eq!(std::fs::read_dir(&ro).unwrap().count(), 0);
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o755)).unwrap();
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_recording_that_cannot_take_its_final_name_is_an_error() {
    let d = temp_dir("record-dir");
    let mcap = d.join("run.mcap");
    std::fs::create_dir(&mcap).unwrap();
    let out = trajopt()
        .args(["solve", "--no-output", "--record"])
        .arg(&mcap)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("run.mcap"), "{err}");
    assert!(mcap.is_dir());
    let _ = std::fs::remove_dir_all(&d);
}

/// A long command piped into a reader that stops after one line (`trajopt study segments |
/// head -1`) ends quietly with success, and a piped stderr gets no progress bar.
#[test]
fn a_study_piped_into_head_ends_quietly_with_success_and_no_progress_bar() {
    let dir = temp_dir("study-head");
    let mut child = trajopt()
        .args(["study", "segments", "--repeat", "1", "--no-output"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdout = child.stdout.take().unwrap();
    let mut first = [0u8; 16];
    std::io::Read::read_exact(&mut stdout, &mut first).unwrap();
    drop(stdout);
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(
        !err.contains("study segments ["),
        "progress bar on a pipe: {err}"
    );
    assert!(first.starts_with(b"Table II"));
    let _ = std::fs::remove_dir_all(&dir);
}
