//! The serde types of the three scenario schemas (`config/scenarios/README.md`): every key
//! optional here, so that a missing one is reported by name when it is validated.

use crate::config::tracks::TrackToml;
use serde::Deserialize;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(non_snake_case)]
pub(super) struct InitialStateToml {
    pub(super) mode: Option<String>,
    pub(super) s_m: Option<f64>,
    pub(super) t_s: Option<f64>,
    pub(super) V_mps: Option<f64>,
    pub(super) e_m: Option<f64>,
    pub(super) beta_rad: Option<f64>,
    pub(super) r_radps: Option<f64>,
    pub(super) dpsi_rad: Option<f64>,
    pub(super) V_wr_mps: Option<f64>,
    pub(super) dFz_N: Option<f64>,
}

impl InitialStateToml {
    /// The free initial state (`{ mode = "free" }`).
    pub(super) fn free() -> Self {
        InitialStateToml {
            mode: Some("free".to_string()),
            s_m: None,
            t_s: None,
            V_mps: None,
            e_m: None,
            beta_rad: None,
            r_radps: None,
            dpsi_rad: None,
            V_wr_mps: None,
            dFz_N: None,
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct SingleFile {
    pub(super) name: Option<String>,
    pub(super) objective: Option<String>,
    pub(super) geometry: Option<Geometry>,
    pub(super) horizon: Option<Horizon>,
    pub(super) track: Option<SingleTrack>,
    pub(super) bounds: Option<Bounds>,
    pub(super) options: Option<Options>,
    pub(super) initial_state: Option<InitialStateToml>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Geometry {
    pub(super) shape: Option<String>,
    pub(super) direction: Option<String>,
    pub(super) straight_length_m: Option<f64>,
    pub(super) radius_m: Option<f64>,
    pub(super) lap_length_m: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Horizon {
    pub(super) length_m: Option<f64>,
    pub(super) n_intervals: Option<i64>,
    pub(super) ds_m: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct SingleTrack {
    pub(super) kappa_pieces: Option<Vec<Vec<f64>>>,
    /// The same curvature sampled every 1 m; informational (the pieces are exact).
    #[allow(dead_code)]
    pub(super) profile_csv: Option<String>,
    pub(super) e_min_m: Option<f64>,
    pub(super) e_max_m: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Bounds {
    pub(super) v_min_mps: Option<f64>,
    pub(super) v_max_mps: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Options {
    pub(super) enforce_tire_saturation: Option<bool>,
    pub(super) steering_slew_weight: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct SegmentsFile {
    pub(super) defaults: Option<SegmentDefaults>,
    pub(super) tracks: Option<Vec<TrackToml>>,
    pub(super) segments: Option<Vec<SegmentToml>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct SegmentDefaults {
    pub(super) objective: Option<String>,
    pub(super) length_m: Option<f64>,
    pub(super) n_intervals: Option<i64>,
    pub(super) ds_m: Option<f64>,
    pub(super) v_min_mps: Option<f64>,
    pub(super) v_max_mps: Option<f64>,
    pub(super) edge_margin_m: Option<f64>,
    pub(super) enforce_tire_saturation: Option<bool>,
    pub(super) steering_slew_weight: Option<f64>,
    pub(super) initial_state: Option<InitialStateToml>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct SegmentToml {
    pub(super) name: Option<String>,
    pub(super) track: Option<String>,
    pub(super) profile_csv: Option<String>,
    pub(super) s_start_m: Option<f64>,
    pub(super) length_m: Option<f64>,
    pub(super) n_intervals: Option<i64>,
    pub(super) ds_m: Option<f64>,
    #[allow(dead_code)]
    pub(super) description: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ObstacleFile {
    pub(super) objective: Option<String>,
    pub(super) common: Option<ObstacleCommon>,
    pub(super) scenarios: Option<Vec<ObstacleScenario>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ObstacleCommon {
    pub(super) horizon_length_m: Option<f64>,
    pub(super) n_intervals: Option<i64>,
    pub(super) ds_m: Option<f64>,
    pub(super) kappa_1pm: Option<f64>,
    pub(super) road_e_min_m: Option<f64>,
    pub(super) road_e_max_m: Option<f64>,
    pub(super) v_min_mps: Option<f64>,
    pub(super) v_max_mps: Option<f64>,
    pub(super) enforce_tire_saturation: Option<bool>,
    pub(super) steering_slew_weight: Option<f64>,
    pub(super) initial_state: Option<InitialStateToml>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ObstacleScenario {
    pub(super) name: Option<String>,
    #[allow(dead_code)]
    pub(super) description: Option<String>,
    pub(super) bounds_override: Option<Vec<Vec<f64>>>,
    #[allow(dead_code)]
    pub(super) expected: Option<String>,
}
