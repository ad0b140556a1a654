//! `trajopt study paper`: every table and figure of the paper regenerated with this
//! project's solver, next to the paper's published numbers ([`published`]), as one
//! Markdown report with its figures.
//!
//! Each section runs one study of [`crate::study`] (or a solve with recorded iterates,
//! [`iterates`]) and renders a table whose columns pair "here" with "paper". The report
//! states the conditions that differ from the paper's (track, vehicle file, machine,
//! solver) in one line at the top, and how long the run took. `quick` trades repeats (one
//! solve per timing), the zero-guess iteration cap (the shipped 500 instead of the paper's
//! ~2000) and the barrier rules run over the 51 free starts (monotone and dampmpc only) for
//! a run of a few minutes; the iteration counts are the same in both modes.

pub mod iterates;
pub mod plots;
pub mod published;
mod sections_oval;
mod sections_segments;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::StudyError;
use crate::ip::Settings;
use crate::model::VehicleParams;

/// IPOPT's result on one case, as `bench/external/casadi_compare.py` reports it.
#[derive(Debug, Clone)]
pub struct ExternalRow {
    /// Case name (`oval`, `S01`...).
    pub case: String,
    /// IPOPT's return status.
    pub status: String,
    /// Iterations.
    pub iterations: Option<usize>,
    /// Median solve time \[ms\].
    pub median_ms: f64,
    /// MUMPS factorizations of one solve (None: not counted).
    pub factorizations: Option<usize>,
    /// Search directions by the number of factorizations each took, (count, directions),
    /// ascending (inertia corrections add factorizations).
    pub per_direction: Vec<(usize, usize)>,
}

/// Where the IPOPT column of Table III comes from.
#[derive(Debug, Clone)]
pub enum External {
    /// Rows of `bench/external/casadi_compare.py`, with a one-line description of the run.
    Rows(Vec<ExternalRow>, String),
    /// Why there are none (no Python environment with CasADi, or the run failed).
    Missing(String),
}

/// Inputs of the reproduction.
#[derive(Debug, Clone)]
pub struct PaperConfig {
    /// Minutes instead of the full repeats (see the module docs).
    pub quick: bool,
    /// The oval scenario file.
    pub oval: PathBuf,
    /// The ten segments S01-S10.
    pub segments: PathBuf,
    /// The 40 shifted starts (with the oval and S01-S10: the 51 free starts).
    pub shifted: PathBuf,
    /// The collision-avoidance scenarios (`forgiving`, `critical`).
    pub collision: PathBuf,
    /// The vehicle file (for the report) and its parameters.
    pub vehicle_file: String,
    /// Vehicle parameters.
    pub vehicle: VehicleParams,
    /// The solver file (for the report) and its settings (the pure-minimum-time file).
    pub solver_file: String,
    /// Solver settings.
    pub settings: Settings,
    /// Folder of the report's figures.
    pub out_dir: PathBuf,
    /// Path of `out_dir` relative to the report's folder, with a trailing `/` (empty when
    /// the report sits beside its figures): the prefix of every figure link.
    pub figure_prefix: String,
    /// Date, commit and CPU for the header.
    pub date: String,
    /// Code commit.
    pub commit: String,
    /// CPU model and logical core count.
    pub cpu: String,
    /// IPOPT's rows for Table III.
    pub external: External,
}

impl PaperConfig {
    /// Solves per timing: 1 with `quick`, else 5.
    pub fn repeat(&self) -> usize {
        if self.quick {
            1
        } else {
            5
        }
    }
}

/// A finished report.
#[derive(Debug, Clone)]
pub struct PaperReport {
    /// The Markdown text.
    pub markdown: String,
    /// Figures written (paths).
    pub figures: Vec<PathBuf>,
}

/// Runs every section; `progress` receives one line per step.
pub fn run(cfg: &PaperConfig, progress: &mut dyn FnMut(&str)) -> Result<PaperReport, StudyError> {
    let start = std::time::Instant::now();
    std::fs::create_dir_all(&cfg.out_dir).map_err(|e| StudyError::File {
        path: cfg.out_dir.display().to_string(),
        message: e.to_string(),
    })?;
    let mut figures = Vec::new();
    let mut body = String::new();
    progress("Table I / Fig. 4a: the nine integrators and the Gauss-Legendre 3 ground truth");
    body += &sections_oval::integrators(cfg, &mut figures, progress)?;
    progress("Fig. 3: stiffness along the oval's optimum");
    body += &sections_oval::stiffness(cfg, &mut figures)?;
    progress("initial infeasibility and Fig. 4b: the oval's iterates");
    body += &sections_oval::oval_iterates(cfg, &mut figures)?;
    progress("Table II and Fig. 5: segments S01-S10 from both guesses");
    body += &sections_segments::segments(cfg, &mut figures, progress)?;
    progress("Tables III and IV, inertia: barrier rules on the oval and the 51 free starts");
    body += &sections_segments::barrier(cfg, progress)?;
    progress("collision avoidance");
    body += &sections_segments::collision(cfg)?;
    let elapsed = start.elapsed().as_secs_f64();
    let markdown = format!("{}{body}", header(cfg, elapsed));
    Ok(PaperReport { markdown, figures })
}

/// Title, provenance and the one line of differing conditions.
fn header(cfg: &PaperConfig, elapsed: f64) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# The paper, reproduced\n");
    let _ = writeln!(
        s,
        "Generated by `trajopt study paper{}` on {} at commit `{}`, {}; the run took {:.0} s \
         (the IPOPT column's run not included: Table III says how long it took).\n",
        if cfg.quick { " --quick" } else { "" },
        cfg.date,
        cfg.commit,
        cfg.cpu,
        elapsed
    );
    let _ = writeln!(
        s,
        "Figures: `{}` (not committed; the command writes them), linked relative to this file.\n",
        cfg.out_dir.display()
    );
    let _ = writeln!(
        s,
        "**Conditions that differ from the paper's:** tracks `{}` / `{}` (the paper's 260 m oval \
         and its ten 250 m segments, rebuilt from its data), vehicle `{}`, this project's \
         interior-point solver (`{}`, barrier rule `{}`; the paper: KNITRO, IPOPT, SNOPT through \
         CasADi in MATLAB), machine {} (the paper's: {}).\n",
        cfg.oval.display(),
        cfg.segments.display(),
        cfg.vehicle_file,
        cfg.solver_file,
        cfg.settings.barrier.name(),
        cfg.cpu,
        published::MACHINE
    );
    let _ = writeln!(
        s,
        "Every problem is the paper's pure minimum time (eq. 3, steering-slew weight 0), \
         implicit Euler, N = 100, free initial state, unless a section says otherwise. Times are \
         wall-clock on a shared machine and move between runs; iteration counts are \
         deterministic.{}\n",
        if cfg.quick {
            " `--quick`: one solve per timing, zero-guess cap 500 iterations, and only the \
             monotone and dampmpc rules over the 51 starts."
        } else {
            ""
        }
    );
    s
}

/// Markdown cell of an optional value.
pub(crate) fn cell<T: std::fmt::Display>(v: Option<T>) -> String {
    v.map_or_else(|| "NS".to_string(), |x| x.to_string())
}

/// The Markdown link target of figure `p`, relative to the report.
pub(crate) fn link(cfg: &PaperConfig, p: &Path) -> String {
    let name = p.file_name().map_or_else(
        || p.display().to_string(),
        |f| f.to_string_lossy().into_owned(),
    );
    format!("{}{name}", cfg.figure_prefix)
}

/// `to` relative to the folder `from` (both relative to the same working directory or
/// both absolute), as a link prefix ending in `/`, or empty when they are the same folder.
pub fn relative_prefix(from: &Path, to: &Path) -> String {
    use std::path::Component;
    let norm = |p: &Path| -> Vec<String> {
        p.components()
            .filter(|c| !matches!(c, Component::CurDir))
            .map(|c| c.as_os_str().to_string_lossy().into_owned())
            .collect()
    };
    let (a, b) = (norm(from), norm(to));
    let common = a.iter().zip(&b).take_while(|(x, y)| x == y).count();
    let mut parts: Vec<String> = vec!["..".to_string(); a.len() - common];
    parts.extend(b[common..].iter().cloned());
    if parts.is_empty() {
        String::new()
    } else {
        format!("{}/", parts.join("/"))
    }
}

/// A UTC date `YYYY-MM-DD HH:MM UTC` from seconds since the Unix epoch (proleptic
/// Gregorian calendar, days to civil date after Hinnant).
pub fn utc_date(unix_s: u64) -> String {
    let days = (unix_s / 86_400) as i64;
    let (h, m) = ((unix_s % 86_400) / 3600, (unix_s % 3600) / 60);
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let mo = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(mo <= 2);
    format!("{y:04}-{mo:02}-{d:02} {h:02}:{m:02} UTC")
}

#[cfg(test)]
mod tests {
    use super::utc_date;

    #[test]
    fn a_figure_folder_is_linked_relative_to_the_report() {
        use std::path::Path;
        assert_eq!(
            super::relative_prefix(Path::new("out/paper"), Path::new("out/paper")),
            ""
        );
        assert_eq!(
            super::relative_prefix(Path::new("docs"), Path::new("out/paper")),
            "../out/paper/"
        );
        assert_eq!(
            super::relative_prefix(Path::new("./out"), Path::new("out/paper")),
            "paper/"
        );
    }

    #[test]
    fn the_utc_date_of_known_instants_matches_the_calendar() {
        assert_eq!(utc_date(0), "1970-01-01 00:00 UTC");
        assert_eq!(utc_date(951_782_400), "2000-02-29 00:00 UTC");
        assert_eq!(utc_date(1_795_819_500), "2026-11-27 22:45 UTC");
    }
}
