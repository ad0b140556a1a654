//! `trajopt study paper`: [`planner::study::paper`], every table and figure of the paper
//! next to its published numbers in one Markdown report; progress on stderr when stderr is
//! a terminal. The IPOPT column of Table III comes from `bench/external/casadi_compare.py`
//! when a Python with CasADi is present (`.venv/bin/python`, else `python3`).

use std::io::IsTerminal as _;
use std::path::{Path, PathBuf};
use std::process::Command;

use planner::config::{load_solver, load_vehicle};
use planner::study::paper::{self, External, ExternalRow, PaperConfig};

use crate::out::{errln, outln};
use crate::paths::{resolve, solver_file};

#[derive(clap::Args, Debug)]
pub struct StudyPaperArgs {
    /// Folder of the report's figures (and of the report unless --report is given).
    #[arg(long, default_value = "out/paper")]
    out_dir: PathBuf,
    /// The report file (default: report.md in the figures folder); figure links are
    /// relative to it.
    #[arg(long)]
    report: Option<PathBuf>,
    /// A few minutes: one solve per timing, the shipped zero-guess cap, two barrier rules
    /// over the 51 starts, IPOPT without JIT.
    #[arg(long)]
    quick: bool,
    /// Vehicle file.
    #[arg(long, default_value = "config/vehicles/lc500.toml")]
    vehicle: PathBuf,
    /// Solver settings file (default: config/solver_min_time.toml, the pure minimum time).
    #[arg(long)]
    solver: Option<PathBuf>,
    /// Do not run bench/external (IPOPT) even when its Python environment is present.
    #[arg(long)]
    no_external: bool,
}

/// Runs the reproduction and writes the report.
pub fn run(a: StudyPaperArgs) -> Result<(), String> {
    let vehicle = load_vehicle(&resolve(&a.vehicle)).map_err(|e| e.to_string())?;
    let solver = solver_file(&a.solver, 0.0);
    let settings = load_solver(&solver).map_err(|e| e.to_string())?;
    let report = a
        .report
        .clone()
        .unwrap_or_else(|| a.out_dir.join("report.md"));
    let report_dir = report.parent().unwrap_or(Path::new("")).to_path_buf();
    for dir in [&a.out_dir, &report_dir] {
        if !dir.as_os_str().is_empty() {
            std::fs::create_dir_all(dir)
                .map_err(|e| format!("{}: cannot create: {e}", dir.display()))?;
        }
    }
    let tty = std::io::stderr().is_terminal();
    let mut progress = |line: &str| {
        if tty {
            errln!("{line}");
        }
    };
    let external = if a.no_external {
        External::Missing("--no-external".into())
    } else {
        progress("Table III: IPOPT through bench/external/casadi_compare.py");
        ipopt_rows(a.quick)
    };
    let unix = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let cfg = PaperConfig {
        quick: a.quick,
        oval: PathBuf::from("config/scenarios/oval.toml"),
        segments: PathBuf::from("config/scenarios/segments.toml"),
        shifted: PathBuf::from("config/scenarios/segments_shifted.toml"),
        collision: PathBuf::from("config/scenarios/collision_avoidance.toml"),
        vehicle_file: a.vehicle.display().to_string(),
        vehicle,
        solver_file: solver.display().to_string(),
        settings,
        out_dir: a.out_dir.clone(),
        figure_prefix: paper::relative_prefix(&report_dir, &a.out_dir),
        date: paper::utc_date(unix),
        commit: commit(),
        cpu: planner::cpu::model_name(),
        external,
    };
    let cfg = PaperConfig {
        oval: resolve(&cfg.oval),
        segments: resolve(&cfg.segments),
        shifted: resolve(&cfg.shifted),
        collision: resolve(&cfg.collision),
        ..cfg
    };
    let done = paper::run(&cfg, &mut progress).map_err(|e| e.to_string())?;
    planner::io::write_atomic(&report, |w| {
        std::io::Write::write_all(w, done.markdown.as_bytes())
    })
    .map_err(|e| format!("{}: {e}", report.display()))?;
    outln!(
        "wrote {} ({} figures in {})",
        report.display(),
        done.figures.len(),
        a.out_dir.display()
    );
    Ok(())
}

/// The code commit (`git rev-parse --short HEAD`, with `+changes` when the tree differs),
/// or "unknown" outside a git checkout.
fn commit() -> String {
    let git = |args: &[&str]| {
        Command::new("git")
            .args(args)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
    };
    match git(&["rev-parse", "--short", "HEAD"]) {
        Some(h) => {
            let dirty = git(&["status", "--porcelain", "--untracked-files=no"])
                .is_some_and(|s| !s.is_empty());
            if dirty {
                format!("{h}+changes")
            } else {
                h
            }
        }
        None => "unknown".into(),
    }
}

/// A Python that imports CasADi: `.venv/bin/python`, else `python3`.
fn python_with_casadi() -> Option<String> {
    [".venv/bin/python", "python3"].into_iter().find_map(|py| {
        Command::new(py)
            .args(["-c", "import casadi"])
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|_| py.to_string())
    })
}

/// `{"k": directions, ...}` of `casadi_compare.py` as ascending (k, directions) pairs.
fn per_direction(v: &serde_json::Value) -> Vec<(usize, usize)> {
    let mut out: Vec<(usize, usize)> = v
        .as_object()
        .map(|m| {
            m.iter()
                .filter_map(|(k, n)| Some((k.parse().ok()?, n.as_u64()? as usize)))
                .collect()
        })
        .unwrap_or_default();
    out.sort_unstable();
    out
}

/// IPOPT (adaptive mu, pure minimum time) on S01-S10 through `casadi_compare.py`, with
/// its factorizations counted.
fn ipopt_rows(quick: bool) -> External {
    let Some(py) = python_with_casadi() else {
        return External::Missing(
            "no Python with CasADi: neither .venv/bin/python nor python3 imports casadi; see \
             docs/performance.md, \"Against IPOPT and FATROP\""
                .into(),
        );
    };
    let Ok(me) = std::env::current_exe() else {
        return External::Missing("cannot locate this trajopt binary".into());
    };
    let cases = (1..=10)
        .map(|i| format!("S{i:02}"))
        .collect::<Vec<_>>()
        .join(",");
    let t0 = std::time::Instant::now();
    let mut cmd = Command::new(&py);
    cmd.arg("bench/external/casadi_compare.py")
        .args(["--trajopt", &me.display().to_string(), "--cases", &cases])
        .args([
            "--solvers",
            "ipopt",
            "--mu-strategy",
            "adaptive",
            "--steering-slew-weight",
            "0",
        ])
        .args(["--repeat", if quick { "1" } else { "5" }])
        .arg("--count-factorizations");
    if quick {
        cmd.arg("--no-jit");
    }
    let out = match cmd.output() {
        Ok(o) if o.status.success() => o,
        Ok(o) => {
            let err = String::from_utf8_lossy(&o.stderr);
            let last = err.lines().last().unwrap_or("").to_string();
            return External::Missing(format!("casadi_compare.py failed: {last}"));
        }
        Err(e) => return External::Missing(format!("{py}: {e}")),
    };
    let Ok(v) = serde_json::from_slice::<serde_json::Value>(&out.stdout) else {
        return External::Missing("casadi_compare.py printed no JSON".into());
    };
    let rows = v["results"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter(|r| r["solver"] == "ipopt")
                .map(|r| ExternalRow {
                    case: r["case"].as_str().unwrap_or("-").to_string(),
                    status: r["status"].as_str().unwrap_or("-").to_string(),
                    iterations: r["iterations"].as_u64().map(|i| i as usize),
                    median_ms: r["solve_ms_median"].as_f64().unwrap_or(f64::NAN),
                    factorizations: r["factorizations"].as_u64().map(|f| f as usize),
                    per_direction: per_direction(&r["factorizations_per_direction"]),
                })
                .collect()
        })
        .unwrap_or_default();
    let what = format!(
        "{py}, IPOPT mu_strategy adaptive, MUMPS, CasADi {}, median of {}; this run took \
         {:.0} s before the report's own",
        if quick {
            "interpreted (--no-jit)"
        } else {
            "JIT"
        },
        if quick { 1 } else { 5 },
        t0.elapsed().as_secs_f64()
    );
    External::Rows(rows, what)
}
