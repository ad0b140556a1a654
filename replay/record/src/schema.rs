//! Topics, schema names and the `ros2msg` schema texts of the recorded channels.

/// MCAP profile of a recording: ROS 2 (schemas in `ros2msg`, messages in CDR with its
/// encapsulation header), so ROS 2 bag readers accept the file.
pub const PROFILE: &str = "ros2";
/// Topic of the planner inputs.
pub const INPUT_TOPIC: &str = "/planner/input";
/// Topic of the planner outputs.
pub const OUTPUT_TOPIC: &str = "/planner/output";
/// Topic of the warm starts (one per warm-started input, same seq).
pub const WARM_TOPIC: &str = "/planner/warm_start";
/// Schema name of [`crate::PlanWarmStart`].
pub const PLAN_WARM_NAME: &str = "trajopt_msgs/msg/PlanWarmStart";
/// Schema name of [`crate::PlanInput`].
pub const PLAN_INPUT_NAME: &str = "trajopt_msgs/msg/PlanInput";
/// Schema name of [`crate::PlanOutput`].
pub const PLAN_OUTPUT_NAME: &str = "trajopt_msgs/msg/PlanOutput";
/// Schema encoding of both channels.
pub const SCHEMA_ENCODING: &str = "ros2msg";
/// Message encoding of both channels.
pub const MESSAGE_ENCODING: &str = "cdr";

/// `ros2msg` text of [`crate::PlanInput`] (field order = CDR order).
pub const PLAN_INPUT_MSG: &str = "\
# Everything one planner solve acted on. Doubles are stored bit-exactly (CDR float64).
uint64 seq
uint64 stamp_ns
string scenario
string guess
uint32 n_intervals
float64 length_m
float64 v_min_mps
float64 v_max_mps
# speed upper bound at the last node [m/s] (inf: v_max_mps alone)
float64 v_end_max_mps
# weight of the objective's steering-slew term [1/s] (0: pure minimum time)
float64 steering_slew_weight
# weight of leaving the soft lane bounds [s/m^2] (0: no soft lane)
float64 soft_lane_weight
bool enforce_tire_saturation
# tire saturation rows also at the last node (x_N, u_{N-1})
bool saturation_at_end
bool initial_state_fixed
# initial vehicle state [r, V, beta, V_wr, dFz, e, dpsi, s, t]
float64[9] x0
# road at the N+1 nodes
float64[] kappa
float64[] e_min
float64[] e_max
# soft lane bounds at the N+1 nodes (empty without a soft lane)
float64[] soft_e_min
float64[] soft_e_max
# m l a b h_cg i_z g r_w i_w c_f c_r mu c_l delta_max t_comb_max t_comb_min t_bf_min t_bf_max
# v_wr_min delta_rate_max t_comb_rate_max t_bf_rate_max eps_sigma eps_sat fmax_floor_frac
float64[25] vehicle
# tol constr_viol_tol dual_inf_tol compl_inf_tol acceptable_tol acceptable_constr_viol_tol
# max_iter max_time_s max_backtracks max_inertia_corrections max_ls_failures
# max_restoration_steps barrier globalization mu_floor_factor mu_init mu_min bound_push
# bound_frac bound_relax tau_min armijo second_order_correction penalty_init delta_w_init
# delta_w_max delta_c_min infeas_stat_tol mu_max_decrease mu_linear_decrease
# mu_superlinear_power barrier_tol_factor delta_w_decrease max_refactorizations kkt
float64[35] settings
# FNV-1a 64 of the bits of vehicle and settings
uint64 config_hash
string settings_json
";

/// `ros2msg` text of [`crate::PlanOutput`] (field order = CDR order).
pub const PLAN_OUTPUT_MSG: &str = "\
# What one planner solve produced; one float64[] per state and control over the nodes.
uint64 seq
uint64 stamp_ns
string status
uint32 iterations
float64 objective
float64 max_violation
float64 t_final_s
uint32 factorizations
uint32 evaluations
float64 time_evaluation_s
float64 time_factorization_s
float64 time_solve_s
float64 time_line_search_s
float64 time_total_s
float64[] r
float64[] v
float64[] beta
float64[] v_wr
float64[] dfz
float64[] e
float64[] dpsi
float64[] s
float64[] t
float64[] delta
float64[] t_comb
float64[] t_bf
";

/// `ros2msg` text of [`crate::PlanWarmStart`] (field order = CDR order).
pub const PLAN_WARM_MSG: &str = "\
# Where a warm-started planner solve started, beyond its PlanInput (input guess `warm`).
uint64 seq
uint64 stamp_ns
# how far the window moved since the previous plan [m]; the guess below is shifted
float64 shift_m
# iterations before the warm solve falls back (2^64-1: the solver's cap)
uint64 warm_max_iter
float64 mu_floor
# how the first barrier parameter is matched to the start: mean, or geometric (the factor
# times the geometric mean of the complementarity products)
string mu_match
float64 mu_match_factor
# guess of the fall-back solve
string cold_guess
# primal guess, one float64[] per state (N+1 nodes) and control (N intervals)
float64[] r
float64[] v
float64[] beta
float64[] v_wr
float64[] dfz
float64[] e
float64[] dpsi
float64[] s
float64[] t
float64[] delta
float64[] t_comb
float64[] t_bf
# multipliers: rows (m), lower and upper bounds (n variables, then m rows)
float64[] y
float64[] zl
float64[] zu
";

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{CONTROL_LEN, SETTINGS_LEN, STATE_LEN, VEHICLE_LEN};

    /// The schema text must declare the array lengths the codec writes.
    #[test]
    fn schema_array_lengths_match_the_codec() {
        assert!(PLAN_INPUT_MSG.contains(&format!("float64[{SETTINGS_LEN}] settings")));
        assert!(PLAN_INPUT_MSG.contains(&format!("float64[{VEHICLE_LEN}]")));
        let _ = (STATE_LEN, CONTROL_LEN);
    }
}
