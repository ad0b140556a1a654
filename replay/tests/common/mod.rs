//! Shared fixture: a small recording of the oval drive (two 10 Hz plans).

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use replay::oval::{record_oval, OvalOptions};

/// Repository root.
pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A fresh temporary folder for one test.
pub fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("replay-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Records `plans` plans of the oval drive to `out`.
pub fn record(out: &Path, plans: usize) {
    let opts = OvalOptions {
        scenario: repo().join("config/scenarios/oval.toml"),
        vehicle: repo().join("config/vehicles/lc500.toml"),
        solver: repo().join("config/solver.toml"),
        plans,
        rate_hz: 10.0,
        out: out.to_path_buf(),
        warm_start: false,
        saturation_at_end: true,
        mu_match: planner::ip::MuMatch::DEFAULT,
        cold_guess: planner::guess::GuessKind::Equilibrium,
    };
    let s = record_oval(&opts, |_, _, _| {}).unwrap();
    assert_eq!(s.stats.inputs, plans as u64);
    assert_eq!(s.stats.outputs, plans as u64);
    assert_eq!(s.stats.dropped, 0);
}

/// The bytes of a valid two-plan recording (recorded once per test binary).
pub fn valid_bytes() -> &'static [u8] {
    static BYTES: OnceLock<Vec<u8>> = OnceLock::new();
    BYTES.get_or_init(|| {
        let d = temp_dir("fixture");
        let f = d.join("two.mcap");
        record(&f, 2);
        let b = std::fs::read(&f).unwrap();
        let _ = std::fs::remove_dir_all(&d);
        b
    })
}
