//! `replay` on streams and files that fail: a full stdout (`/dev/full`) is an error with
//! exit code 2 and no panic, a closed pipe ends quietly with success, and an output file
//! that cannot be written is an error naming it, with nothing left under its name.

mod common;

use std::path::Path;
use std::process::{Command, Output, Stdio};

fn replay() -> Command {
    Command::new(env!("CARGO_BIN_EXE_replay"))
}

/// A two-plan recording in `dir`.
fn fixture(dir: &Path) -> std::path::PathBuf {
    let f = dir.join("two.mcap");
    std::fs::write(&f, common::valid_bytes()).unwrap();
    f
}

fn dev_full() -> Stdio {
    Stdio::from(
        std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .expect("/dev/full"),
    )
}

fn assert_error_naming(out: &Output, what: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(err.contains(what), "{err}");
}

#[test]
fn a_full_stdout_is_an_error_with_exit_2_for_info() {
    let d = common::temp_dir("streams-full");
    let f = fixture(&d);
    for json in [true, false] {
        let mut c = replay();
        c.arg("info").arg(&f);
        if json {
            c.arg("--json");
        }
        let out = c.stdout(dev_full()).output().unwrap();
        assert_error_naming(
            &out,
            "standard output: cannot write: No space left on device",
        );
    }
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_closed_stdout_ends_quietly_with_success() {
    let d = common::temp_dir("streams-closed");
    let f = fixture(&d);
    for json in [true, false] {
        let mut c = replay();
        c.arg("info").arg(&f);
        if json {
            c.arg("--json");
        }
        let mut child = c
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        drop(child.stdout.take());
        let out = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_plot_that_cannot_be_written_is_an_error_naming_it() {
    let d = common::temp_dir("streams-plot");
    let f = fixture(&d);
    let png = d.join("latency.png");
    std::fs::create_dir(&png).unwrap();
    let out = replay()
        .arg("run")
        .arg(&f)
        .args(["--budget-ms", "10000", "--plot"])
        .arg(&png)
        .output()
        .unwrap();
    assert_error_naming(&out, "latency.png: figure not written: cannot write");
    assert!(png.is_dir());
    let names: Vec<_> = std::fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 2, "no temporary file left: {names:?}");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_recovered_file_that_cannot_be_written_is_an_error_naming_it() {
    let d = common::temp_dir("streams-recover");
    let f = fixture(&d);
    let clean = d.join("clean.mcap");
    std::fs::create_dir(&clean).unwrap();
    let out = replay()
        .arg("recover")
        .arg(&f)
        .arg(&clean)
        .output()
        .unwrap();
    assert_error_naming(&out, "clean.mcap");
    assert!(clean.is_dir());
    assert_eq!(std::fs::read_dir(&d).unwrap().count(), 2);
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_recording_under_a_file_is_an_error_naming_it() {
    let d = common::temp_dir("streams-record");
    let plain = d.join("plain");
    std::fs::write(&plain, "not a folder").unwrap();
    let out = replay()
        .args(["record-oval", "--plans", "1", "--out"])
        .arg(plain.join("drive.mcap"))
        .output()
        .unwrap();
    assert_error_naming(&out, "plain");
    let _ = std::fs::remove_dir_all(&d);
}
