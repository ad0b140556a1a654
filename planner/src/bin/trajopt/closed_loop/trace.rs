//! The tracker's driven trace and plan log (`--trace-dir`: driven.csv, plans.csv), read
//! back for the figures and the deadline count, and the reference lap times of
//! config/reference/lap_times.toml.

use std::path::Path;

/// The drive: rows t, s, e, V, beta, dpsi.
pub struct Driven {
    pub rows: Vec<[f64; 6]>,
}

/// One plan the tracker received: car s on arrival, origin, grid, status, kind, solve time
/// and node speeds.
pub struct PlanLine {
    pub s_car: f64,
    pub s_origin: f64,
    pub ds: f64,
    pub status: u32,
    /// Kind sent (`planner::plan::choice::NO_PLAN_CODE`: a notice of no drivable plan,
    /// whose nodes are no plan).
    pub kind: u32,
    pub solve_time_s: f64,
    pub v: Vec<f64>,
}

fn numbers(line: &str) -> Option<Vec<f64>> {
    line.split(',').map(|f| f.trim().parse().ok()).collect()
}

/// Reads driven.csv and plans.csv of `dir` (rows that do not parse are skipped).
pub fn read(dir: &Path) -> Result<(Driven, Vec<PlanLine>), String> {
    let text = |name: &str| {
        std::fs::read_to_string(dir.join(name))
            .map_err(|e| format!("{}: {e}", dir.join(name).display()))
    };
    let rows = text("driven.csv")?
        .lines()
        .skip(1)
        .filter_map(numbers)
        // t, s, e, V, beta, dpsi (and, from trackers that log it, the plan's e).
        .filter_map(|v| <[f64; 6]>::try_from(v.get(..6)?).ok())
        .collect();
    let plans = text("plans.csv")?
        .lines()
        .skip(1)
        .filter_map(numbers)
        .filter(|v| v.len() > 6)
        .map(|v| PlanLine {
            s_car: v[0],
            s_origin: v[1],
            ds: v[2],
            status: v[3] as u32,
            kind: v[4] as u32,
            solve_time_s: v[5],
            // v0..vN, then e0..eN.
            v: v[6..6 + (v.len() - 6) / 2].to_vec(),
        })
        .collect();
    Ok((Driven { rows }, plans))
}

/// The reference lap time \[s\] and its edge margin \[m\] of `track` in `file`, if listed.
pub fn reference_lap(file: &Path, track: &str) -> Option<(f64, f64)> {
    let text = std::fs::read_to_string(file).ok()?;
    let t: toml::Table = toml::from_str(&text).ok()?;
    t.get("tracks")?.as_array()?.iter().find_map(|e| {
        if e.get("name")?.as_str()? != track {
            return None;
        }
        let num = |k: &str| {
            e.get(k)
                .and_then(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)))
        };
        Some((num("lap_time_s")?, num("edge_margin_m").unwrap_or(f64::NAN)))
    })
}
