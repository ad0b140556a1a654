//! What a drive shows, logged at every control step without allocating: lap times (the
//! car's unwrapped s crossing start_s + k lap), the CG's margin to the nearer lane edge,
//! the peak sideslip, the footprint's clearance of the obstacles (and the speed where it
//! first touched one), and the driven trace
//! and plan log for the figures (preallocated for the run's cap, written once at the end).

use std::path::Path;

use planner::model::{ix, NX};

use crate::msg::{Trajectory, HORIZON_N};
use crate::road::footprint::{
    clearance, footprint, obstacle_boxes, Quad, CAR_LENGTH_M, CAR_WIDTH_M,
};
use crate::road::ClosedRoad;

/// How far outside a lane edge the CG may go before the drive is over \[m\]: past it the
/// car has left the road (and the road frame's curvilinear coordinates lose their meaning
/// once the car is beyond a curve's centre), so the run ends as `left_track`.
pub const LEFT_TRACK_M: f64 = 3.0;

/// Period of the driven trace [s].
pub const TRACE_DT_S: f64 = 0.01;
/// Plans logged per second of the run's cap (twice the default 10 Hz, room for 20 Hz).
const PLANS_PER_S: f64 = 20.0;

/// One row of the driven trace: t, s, e, V, beta, dpsi, and the plan's e at the car (NaN
/// while the car drives without a plan).
pub type TraceRow = [f64; 7];

/// One logged plan: where the car was, the plan's origin and grid, its status and solve
/// time, and its node speeds and lateral offsets.
#[derive(Debug, Clone, Copy)]
pub struct PlanRow {
    /// Car's s when the plan arrived \[m\].
    pub s_car: f64,
    /// Plan origin s \[m\].
    pub s_origin: f64,
    /// Grid \[m\].
    pub ds: f64,
    /// Status code ([`crate::msg::status_code`]).
    pub status: u32,
    /// Kind of plan sent (`planner::plan::choice::PlanKind::code`: converged, best
    /// iterate, previous shifted).
    pub kind: u32,
    /// Solve time \[s\].
    pub solve_time_s: f64,
    /// Node speeds [m/s].
    pub v: [f64; HORIZON_N + 1],
    /// Node lateral offsets e \[m\].
    pub e: [f64; HORIZON_N + 1],
}

/// The drive's log; every field is updated in place.
#[derive(Debug)]
pub struct RunLog {
    start_s: f64,
    lap: f64,
    closed: bool,
    laps_wanted: usize,
    lap_end_t: Vec<f64>,
    min_edge_margin: f64,
    max_beta: f64,
    obstacles: Vec<Quad>,
    min_clearance: f64,
    /// The CG's speed and s where the footprint first overlapped an obstacle box.
    impact: Option<(f64, f64)>,
    trace: Vec<TraceRow>,
    next_trace_t: f64,
    plans: Vec<PlanRow>,
}

impl RunLog {
    /// A log for a drive from `start_s` of up to `laps` laps and `duration_s` simulated
    /// seconds on `road` (allocates the trace, plan log and obstacle boxes once).
    pub fn new(road: &ClosedRoad, start_s: f64, laps: usize, duration_s: f64) -> Self {
        let mut obstacles = Vec::new();
        for o in road.obstacles() {
            let (lo, hi) = road.edges(0.5 * (o.s_from + o.s_to));
            obstacles.extend(obstacle_boxes(o, lo, hi).into_iter().flatten());
        }
        let rows = (duration_s / TRACE_DT_S).ceil() as usize + 2;
        let plans = (duration_s * PLANS_PER_S).ceil() as usize + 2;
        Self {
            start_s,
            lap: road.lap(),
            closed: road.is_closed(),
            laps_wanted: laps,
            lap_end_t: Vec::with_capacity(laps + 1),
            min_edge_margin: f64::INFINITY,
            max_beta: 0.0,
            min_clearance: if obstacles.is_empty() {
                f64::NAN
            } else {
                f64::INFINITY
            },
            obstacles,
            impact: None,
            trace: Vec::with_capacity(rows),
            next_trace_t: 0.0,
            plans: Vec::with_capacity(plans),
        }
    }

    /// Logs the plant state after one control step, with the plan's lateral offset
    /// `e_plan` at the car (NaN without a plan). Allocates nothing.
    pub fn step(&mut self, x: &[f64; NX], road: &ClosedRoad, e_plan: f64) {
        let s = x[ix::S];
        let (lo, hi) = road.edges(s);
        let e = x[ix::E];
        self.min_edge_margin = self.min_edge_margin.min((e - lo).min(hi - e));
        self.max_beta = self.max_beta.max(x[ix::BETA].abs());
        let done = self.lap_end_t.len();
        if done < self.lap_end_t.capacity() && s >= self.start_s + (done + 1) as f64 * self.lap {
            self.lap_end_t.push(x[ix::T]);
        }
        if !self.obstacles.is_empty() {
            let car = footprint(s, e, x[ix::DPSI] - x[ix::BETA], CAR_LENGTH_M, CAR_WIDTH_M);
            for b in &self.obstacles {
                let c = clearance(&car, b);
                self.min_clearance = self.min_clearance.min(c);
                if c < 0.0 && self.impact.is_none() {
                    self.impact = Some((x[ix::V], s));
                }
            }
        }
        if x[ix::T] + 1e-9 >= self.next_trace_t && self.trace.len() < self.trace.capacity() {
            self.trace
                .push([x[ix::T], s, e, x[ix::V], x[ix::BETA], x[ix::DPSI], e_plan]);
            self.next_trace_t += TRACE_DT_S;
        }
    }

    /// Logs a plan the tracker took, arriving with the car at `s_car`. Allocates nothing.
    pub fn plan(&mut self, m: &Trajectory, s_car: f64) {
        if self.plans.len() < self.plans.capacity() {
            let mut v = [0.0; HORIZON_N + 1];
            let mut e = [0.0; HORIZON_N + 1];
            for k in 0..=HORIZON_N {
                v[k] = m.x[k][ix::V];
                e[k] = m.x[k][ix::E];
            }
            self.plans.push(PlanRow {
                s_car,
                s_origin: m.s_origin,
                ds: m.ds,
                status: m.status,
                kind: m.kind,
                solve_time_s: m.solve_time_s,
                v,
                e,
            });
        }
    }

    /// Lap times \[s\] of the laps completed (the first from t = 0).
    pub fn lap_times(&self) -> Vec<f64> {
        let mut prev = 0.0;
        self.lap_end_t
            .iter()
            .map(|&t| {
                let d = t - prev;
                prev = t;
                d
            })
            .collect()
    }

    /// True once the car's CG has been more than `LEFT_TRACK_M` outside a lane edge.
    pub fn left_track(&self) -> bool {
        self.min_edge_margin < -LEFT_TRACK_M
    }

    /// True once the wanted laps are driven.
    pub fn laps_done(&self) -> bool {
        self.lap_end_t.len() >= self.laps_wanted
    }

    /// The log's figures as JSON fields (merged into the tracker's report).
    pub fn json(&self) -> serde_json::Value {
        let finite = |v: f64| {
            if v.is_finite() {
                serde_json::json!(v)
            } else {
                serde_json::Value::Null
            }
        };
        let cleared = if self.obstacles.is_empty() {
            serde_json::Value::Null
        } else {
            serde_json::json!(self.min_clearance > 0.0)
        };
        serde_json::json!({
            "start_s_m": self.start_s,
            "lap_length_m": self.lap,
            "closed_road": self.closed,
            "lap_times_s": self.lap_times(),
            "laps_completed": self.lap_end_t.len(),
            "min_edge_margin_m": finite(self.min_edge_margin),
            "lane_kept": self.min_edge_margin >= 0.0,
            "max_sideslip_rad": self.max_beta,
            "obstacles_cleared": cleared,
            "min_obstacle_clearance_m": finite(self.min_clearance),
            "impact_speed_mps": self.impact.map(|(v, _)| v),
            "impact_s_m": self.impact.map(|(_, s)| s),
            "footprint_length_m": CAR_LENGTH_M,
            "footprint_width_m": CAR_WIDTH_M,
            "trace_rows": self.trace.len(),
            "plans_logged": self.plans.len(),
        })
    }

    /// Writes `driven.csv` (t, s, e, V, beta, dpsi and the plan's e every 10 ms) and
    /// `plans.csv` (one row per plan taken: car s, origin, grid, status, kind sent, solve
    /// time, node speeds v0..v100, node lateral offsets e0..e100) into `dir`, each file
    /// whole or not at all.
    pub fn write(&self, dir: &Path) -> Result<(), String> {
        use std::io::Write;
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        planner::io::write_atomic(&dir.join("driven.csv"), |w| {
            writeln!(w, "t_s,s_m,e_m,v_mps,beta_rad,dpsi_rad,e_plan_m")?;
            for r in &self.trace {
                writeln!(
                    w,
                    "{},{},{},{},{},{},{}",
                    r[0], r[1], r[2], r[3], r[4], r[5], r[6]
                )?;
            }
            Ok(())
        })
        .map_err(|e| e.to_string())?;
        planner::io::write_atomic(&dir.join("plans.csv"), |w| {
            write!(w, "s_car_m,s_origin_m,ds_m,status,kind,solve_time_s")?;
            for k in 0..=HORIZON_N {
                write!(w, ",v{k}")?;
            }
            for k in 0..=HORIZON_N {
                write!(w, ",e{k}")?;
            }
            writeln!(w)?;
            for p in &self.plans {
                write!(
                    w,
                    "{},{},{},{},{},{}",
                    p.s_car, p.s_origin, p.ds, p.status, p.kind, p.solve_time_s
                )?;
                for v in p.v.iter().chain(&p.e) {
                    write!(w, ",{v}")?;
                }
                writeln!(w)?;
            }
            Ok(())
        })
        .map_err(|e| e.to_string())
    }
}

/// Adds the log's figures, the outcome and the start state's origin to the tracker's report
/// (the log's `lane_kept` replaces the report's).
pub fn finish_report(report: &mut serde_json::Value, log: &RunLog, outcome: &str, start: &str) {
    if let (Some(obj), serde_json::Value::Object(extra)) = (report.as_object_mut(), log.json()) {
        obj.extend(extra);
        obj.insert("outcome".into(), outcome.into());
        obj.insert("start_state".into(), start.into());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn laps_are_timed_where_the_unwrapped_s_passes_the_start_plus_whole_laps() {
        let road = ClosedRoad::new(vec![(0.0, 0.0)], 100.0, -4.0, 4.0);
        let mut log = RunLog::new(&road, 90.0, 2, 60.0);
        let mut x = [0.0; NX];
        x[ix::V] = 10.0;
        // 10 m/s from s = 90: laps end at s = 190 (t = 10) and 290 (t = 20).
        for i in 0..=2500 {
            x[ix::T] = i as f64 * 0.01;
            x[ix::S] = 90.0 + 10.0 * x[ix::T];
            x[ix::E] = 3.0;
            log.step(&x, &road, 0.0);
        }
        let laps = log.lap_times();
        assert_eq!(laps.len(), 2);
        assert!(
            (laps[0] - 10.0).abs() < 0.011 && (laps[1] - 10.0).abs() < 0.011,
            "{laps:?}"
        );
        assert!(log.laps_done());
        assert!((log.json()["min_edge_margin_m"].as_f64().unwrap() - 1.0).abs() < 1e-12);
    }

    /// A car braking in its lane from 20 m/s at 5 m/s^2 into an obstacle that fills the
    /// lane from s = 30 m: the first contact is logged where the body's front reaches the
    /// box, at the speed the car has there.
    #[test]
    fn the_first_contact_with_an_obstacle_is_logged_with_the_speed_there() {
        use planner::track::BoundsOverride;
        let obstacle = BoundsOverride {
            s_from: 30.0,
            s_to: 35.0,
            e_min: 1.0,
            e_max: 3.5,
        };
        let road = ClosedRoad::open(100.0, 0.0, -3.5, 3.5, vec![obstacle]);
        let mut log = RunLog::new(&road, 0.0, 1, 10.0);
        let (v0, a, dt) = (20.0, 5.0, 0.001);
        let mut x = [0.0; NX];
        for i in 0..4000 {
            let t = i as f64 * dt;
            x[ix::T] = t;
            x[ix::V] = (v0 - a * t).max(0.0);
            x[ix::S] = if x[ix::V] > 0.0 {
                v0 * t - 0.5 * a * t * t
            } else {
                v0 * v0 / (2.0 * a)
            };
            log.step(&x, &road, 0.0);
        }
        let j = log.json();
        assert_eq!(j["obstacles_cleared"], false, "{j}");
        let (v, s) = (
            j["impact_speed_mps"].as_f64().unwrap(),
            j["impact_s_m"].as_f64().unwrap(),
        );
        // Contact when the front (half a body length ahead of the CG) reaches s = 30 m.
        let s_contact = 30.0 - 0.5 * CAR_LENGTH_M;
        assert!(
            (s - s_contact).abs() < 0.05,
            "contact at s = {s}, want {s_contact}"
        );
        let v_contact = (v0 * v0 - 2.0 * a * s_contact).sqrt();
        assert!(
            (v - v_contact).abs() < 0.02,
            "contact at {v} m/s, want {v_contact}"
        );
    }

    #[test]
    fn a_drive_clear_of_the_obstacles_logs_no_contact() {
        use planner::track::BoundsOverride;
        let obstacle = BoundsOverride {
            s_from: 30.0,
            s_to: 35.0,
            e_min: -3.5,
            e_max: -1.0,
        };
        let road = ClosedRoad::open(100.0, 0.0, -3.5, 3.5, vec![obstacle]);
        let mut log = RunLog::new(&road, 0.0, 1, 10.0);
        let mut x = [0.0; NX];
        x[ix::V] = 20.0;
        x[ix::E] = -2.0;
        for i in 0..3000 {
            x[ix::T] = i as f64 * 0.001;
            x[ix::S] = 20.0 * x[ix::T];
            log.step(&x, &road, 0.0);
        }
        let j = log.json();
        assert_eq!(j["obstacles_cleared"], true, "{j}");
        assert!(j["impact_speed_mps"].is_null(), "{j}");
    }
}
