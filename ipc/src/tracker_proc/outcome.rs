//! The drive's outcome in one word, from how it ended and what the log saw.

use super::TrackerLoop;

/// How the drive ended, in one word (`outcome` of the report): a stop for want of a
/// feasible plan before the end, else the obstacles' verdict, else whether the drive was
/// completed.
pub(super) fn outcome(tl: &TrackerLoop, end_reason: &str) -> &'static str {
    let reached = end_reason == "distance reached";
    let log = tl.log.json();
    if tl.no_feasible_plan && !reached {
        let in_lane = log["lane_kept"].as_bool() == Some(true);
        return if tl.car.plant.stopped && in_lane {
            "stopped_in_lane_no_feasible_plan"
        } else if tl.car.plant.stopped {
            "stopped_off_lane_no_feasible_plan"
        } else {
            "braking_no_feasible_plan"
        };
    }
    if !tl.sc.road.obstacles().is_empty() {
        return match log["obstacles_cleared"].as_bool() {
            Some(false) => "collided",
            _ if reached => "cleared",
            _ => "not_reached",
        };
    }
    if reached {
        "completed"
    } else if end_reason == "left the track" {
        "left_track"
    } else if tl.ever_stale {
        "stopped_stale_plan"
    } else {
        "not_completed"
    }
}
