//! Golden results: every shipped scenario, solved with both objectives, gives the committed
//! status, iteration count and solution bits.
//!
//! The digest is FNV-1a over the bits of the solver's primal vector x and multipliers y, so
//! any change to the arithmetic of the model, the transcription, the solver or the guess
//! shows up here. A deliberate numerical change updates `tests/golden/results.csv` in the
//! same commit and says why: run
//! `TRAJOPT_GOLDEN_WRITE=1 cargo test -p planner --test golden` and commit the file.
//!
//! The bits hold on x86-64 machines with AVX2 and FMA (faer chooses fused multiply-adds at
//! run time, see `docs/replay.md`); elsewhere the test compares only statuses and iteration
//! counts.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use planner::config::{load_scenario, load_solver, load_vehicle, shipped_solver_file};
use planner::guess::GuessKind;
use planner::plan::Planner;
use planner::HORIZON;

fn config() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../config")
}

fn golden_file() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden/results.csv")
}

/// One case: scenario file, selection, tire saturation override, guess.
struct Case {
    name: &'static str,
    file: &'static str,
    select: Option<&'static str>,
    saturation: Option<bool>,
    guess: GuessKind,
}

fn cases() -> Vec<Case> {
    let mut v = vec![Case {
        name: "oval",
        file: "oval.toml",
        select: None,
        saturation: None,
        guess: GuessKind::Equilibrium,
    }];
    const SEGMENTS: [&str; 10] = [
        "S01", "S02", "S03", "S04", "S05", "S06", "S07", "S08", "S09", "S10",
    ];
    for s in SEGMENTS {
        v.push(Case {
            name: s,
            file: "segments.toml",
            select: Some(s),
            saturation: None,
            guess: GuessKind::Equilibrium,
        });
    }
    v.push(Case {
        name: "forgiving",
        file: "collision_avoidance.toml",
        select: Some("forgiving"),
        saturation: None,
        guess: GuessKind::Equilibrium,
    });
    v.push(Case {
        name: "critical",
        file: "collision_avoidance.toml",
        select: Some("critical"),
        saturation: None,
        guess: GuessKind::Equilibrium,
    });
    // Infeasible: exercises restoration and the infeasibility exit.
    v.push(Case {
        name: "critical_saturation",
        file: "collision_avoidance.toml",
        select: Some("critical"),
        saturation: Some(true),
        guess: GuessKind::Equilibrium,
    });
    // The zero guess starts far outside the feasible set.
    v.push(Case {
        name: "oval_zero_guess",
        file: "oval.toml",
        select: None,
        saturation: None,
        guess: GuessKind::Zero,
    });
    v
}

/// FNV-1a over the bytes of the given floats' bit patterns.
fn fnv1a(parts: &[&[f64]]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for part in parts {
        for v in part.iter() {
            for b in v.to_bits().to_le_bytes() {
                h ^= u64::from(b);
                h = h.wrapping_mul(0x0000_0100_0000_01b3);
            }
        }
    }
    h
}

/// One result line: `case,objective,status,iterations,digest`.
fn solve_line(case: &Case, weight: f64) -> String {
    let root = config();
    let vehicle = load_vehicle(&root.join("vehicles/lc500.toml")).expect("vehicle");
    let mut spec = load_scenario(
        &root.join("scenarios").join(case.file),
        case.select,
        vehicle,
    )
    .expect("scenario");
    if let Some(s) = case.saturation {
        spec.enforce_tire_saturation = s;
    }
    spec.steering_slew_weight = weight;
    let settings = load_solver(&root.join(shipped_solver_file(weight))).expect("solver file");
    let mut p = Planner::<HORIZON>::new(spec, settings).expect("planner");
    let info = p.solve(case.guess);
    let digest = fnv1a(&[p.solver().x(), p.solver().y()]);
    let objective = if weight == 0.0 { "min_time" } else { "planner" };
    format!(
        "{},{},{},{},{:016x}",
        case.name,
        objective,
        info.status.name(),
        info.iterations,
        digest
    )
}

/// True on the machines whose bits the golden file holds (x86-64 with AVX2 and FMA).
fn bits_comparable() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

#[test]
fn every_shipped_scenario_gives_the_committed_iterations_and_bits() {
    let mut actual = String::from("case,objective,status,iterations,digest\n");
    for case in cases() {
        for weight in [1.0, 0.0] {
            let _ = writeln!(actual, "{}", solve_line(&case, weight));
        }
    }
    if std::env::var_os("TRAJOPT_GOLDEN_WRITE").is_some() {
        let path = golden_file();
        std::fs::create_dir_all(path.parent().expect("parent")).expect("golden dir");
        std::fs::write(&path, &actual).expect("write golden file");
        return;
    }
    let expected = std::fs::read_to_string(golden_file()).expect("golden file");
    let strip = |line: &str| -> String {
        if bits_comparable() {
            line.to_string()
        } else {
            line.rsplit_once(',')
                .map_or(line, |(head, _)| head)
                .to_string()
        }
    };
    let diff: Vec<String> = expected
        .lines()
        .zip(actual.lines())
        .filter(|(e, a)| strip(e) != strip(a))
        .map(|(e, a)| format!("  expected {e}\n  actual   {a}"))
        .collect();
    assert_eq!(
        expected.lines().count(),
        actual.lines().count(),
        "case list changed:\n{actual}"
    );
    assert!(
        diff.is_empty(),
        "{} results moved:\n{}\nfull table:\n{actual}",
        diff.len(),
        diff.join("\n")
    );
}
