//! The closed loop's figures of merit, lifted from both processes' reports to the top of
//! the summary: laps and lap times, the lane margin, tracking and sideslip, the planner's
//! plans and cycle times, the deadline misses (plans whose solve took longer than the
//! replanning period, counted over the plans the tracker received), the swerve's obstacle
//! clearance and outcome, the reference lap time, and the figures.

use std::path::{Path, PathBuf};

use serde_json::{json, Value};

use super::road::RoadMap;
use super::{trace, ClosedLoopArgs};
use crate::out::errln;
use crate::paths::resolve;

/// Removes a folder when dropped (the tracker's trace).
pub struct RemoveOnDrop(pub PathBuf);

impl Drop for RemoveOnDrop {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Adds the lap, margin, planner, obstacle, reference and figure fields to `obj`.
pub fn extend(args: &ClosedLoopArgs, map: &RoadMap, trace_dir: &Path, obj: &mut Value) {
    let t = obj["tracker"].clone();
    let p = obj["planner"].clone();
    let name = args.road.name(&args.scenario);
    let period = 1.0 / args.rate_hz;
    let (deadline_misses, figures) = match trace::read(trace_dir) {
        Ok((driven, plans)) => {
            let misses = plans.iter().filter(|l| l.solve_time_s > period).count();
            let figs = match super::figures::draw(
                &args.road.out_dir,
                &name,
                map,
                &driven,
                &plans,
                period,
                args.road.start_s,
            ) {
                Ok(f) => json!(f),
                Err(e) => {
                    errln!("closed-loop: figures not drawn: {e}");
                    Value::Null
                }
            };
            (json!(misses), figs)
        }
        Err(e) => {
            errln!("closed-loop: no driven trace ({e}); no figures, deadline misses unknown");
            (Value::Null, Value::Null)
        }
    };
    let reference = trace::reference_lap(
        &resolve(Path::new("config/reference/lap_times.toml")),
        &name,
    );
    let o = obj.as_object_mut().expect("the summary is an object");
    let tf = |k: &str| t.get(k).cloned().unwrap_or(Value::Null);
    let pf = |k: &str| p.get(k).cloned().unwrap_or(Value::Null);
    for k in [
        "lap_times_s",
        "laps_completed",
        "lane_kept",
        "min_edge_margin_m",
        "max_sideslip_rad",
        "outcome",
        "obstacles_cleared",
        "min_obstacle_clearance_m",
        "impact_speed_mps",
        "impact_s_m",
        "start_state",
        "start_s_m",
    ] {
        o.insert(k.into(), tf(k));
    }
    o.insert("track".into(), json!(name));
    o.insert("lane_margin_m".into(), json!(args.road.margin()));
    o.insert("soft_lane_m".into(), json!(args.soft_lane()));
    o.insert(
        "end_speed_envelope".into(),
        json!(args.end_speed_envelope()),
    );
    o.insert("plans_published".into(), pf("plans_published"));
    o.insert("plans_not_converged".into(), pf("not_converged"));
    o.insert("no_plan_notices".into(), pf("no_plan_notices"));
    o.insert("deadline_misses".into(), deadline_misses);
    for k in [
        "cycle_ms_p50",
        "cycle_ms_p99",
        "cycle_ms_max",
        "cycles_past_budget",
        "cycles_past_budget_off_cpu",
    ] {
        o.insert(k.into(), pf(k));
    }
    let mismatch = t.get("mismatch").cloned().unwrap_or(json!("none"));
    o.insert("mismatch".into(), mismatch);
    o.insert(
        "reference_lap_time_s".into(),
        reference.map_or(Value::Null, |r| json!(r.0)),
    );
    o.insert(
        "reference_edge_margin_m".into(),
        reference.map_or(Value::Null, |r| json!(r.1)),
    );
    o.insert(
        "plant_reference_lap_time_s".into(),
        plant_reference(&t, &name).map_or(Value::Null, |r| json!(r.0)),
    );
    o.insert("figures".into(), figures);
}

/// The minimum lap \[s\] and edge margin \[m\] of the car the loop drives when that is not
/// the planner's: under the shipped `default` mismatch with the planner's vehicle file, the
/// entry of `config/reference/lap_times_plant_default.toml` (docs/lap-reference.md, "The
/// plant's car"). `None` without a mismatch, for a user's mismatch or plant vehicle file,
/// or for a track without an entry.
fn plant_reference(tracker: &Value, track: &str) -> Option<(f64, f64)> {
    if tracker["mismatch"].as_str() != Some("default") || !tracker["plant_vehicle"].is_null() {
        return None;
    }
    trace::reference_lap(
        &resolve(Path::new("config/reference/lap_times_plant_default.toml")),
        track,
    )
}

/// The second line of the human summary: laps against the reference, margins, outcome.
pub fn text(obj: &Value) -> String {
    let laps: Vec<String> = obj["lap_times_s"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(Value::as_f64)
                .map(|t| format!("{t:.2}"))
                .collect()
        })
        .unwrap_or_default();
    let reference = match obj["reference_lap_time_s"].as_f64() {
        Some(r) => format!(
            "reference {r:.2} s (edge margin {} m)",
            obj["reference_edge_margin_m"]
        ),
        None => "no reference".to_string(),
    };
    let reference = match obj["plant_reference_lap_time_s"].as_f64() {
        Some(r) => format!("{reference}, the plant's car {r:.2} s"),
        None => reference,
    };
    let num = |k: &str| obj[k].as_f64().unwrap_or(f64::NAN);
    format!(
        "{}: {} laps completed, lap times [{}] s, {reference}; min edge margin {:.2} m, max sideslip {:.3} rad; \
         {} plans ({} not converged, {} past the period), cycle p50 {:.1} ms p99 {:.1} ms max {:.1} ms; \
         outcome {}{}",
        obj["track"].as_str().unwrap_or("?"),
        obj["laps_completed"],
        laps.join(", "),
        num("min_edge_margin_m"),
        num("max_sideslip_rad"),
        obj["plans_published"],
        obj["plans_not_converged"],
        obj["deadline_misses"],
        num("cycle_ms_p50"),
        num("cycle_ms_p99"),
        num("cycle_ms_max"),
        obj["outcome"].as_str().unwrap_or("?"),
        match (
            obj["min_obstacle_clearance_m"].as_f64(),
            obj["impact_speed_mps"].as_f64(),
        ) {
            (Some(c), Some(v)) => format!(
                ", obstacle clearance {c:.2} m, first contact at {v:.1} m/s (s = {:.1} m)",
                num("impact_s_m")
            ),
            (Some(c), None) => format!(", obstacle clearance {c:.2} m"),
            _ => String::new(),
        }
    )
}
