//! Fixed-size `#[repr(C)]` messages sent zero-copy over iceoryx2, and their validation.
//!
//! Every message starts with [`MSG_VERSION`] and carries the [`RoadId`] of the scenario
//! both processes loaded, a sequence number and a CLOCK_MONOTONIC publish stamp (the
//! clock is system-wide, so the receiver can compute the one-way latency).
//!
//! Plans belong to their requester: a [`VehicleState`] carries the [`RunId`] of the tracker
//! run that published it, and a [`Trajectory`] the run id and seq of the state it was
//! planned from, so a tracker recognises its own plans (`docs/ipc-ownership.md`).

use iceoryx2::prelude::ZeroCopySend;
use planner::ip::Status;
use planner::model::{ix, NU, NX};
pub use planner::plan::choice::{kind_name, PlanKind};

/// Wire version of every message in this module; bump on any layout change.
pub const MSG_VERSION: u32 = 3;
/// [`Trajectory::kind`] of a notice that a cycle found no drivable plan: its solve ended
/// past convergence with a best iterate beyond the drivable violation, and no previous plan
/// can be shifted to the car (the first cycle, or the car past the previous plan's reach).
/// A notice is never driven: its nodes hold the measured state it answers (s and t running
/// at that speed, controls zero); `status`, `iterations` and `max_violation` are the
/// failed solve's. Among obstacles the tracker brakes to a stop in its lane on it; on a
/// closed road it holds its plan until the plan is stale.
pub const KIND_NO_PLAN: u32 = planner::plan::choice::NO_PLAN_CODE;
/// Horizon intervals N carried by a [`Trajectory`]: the planner's [`planner::HORIZON`].
pub const HORIZON_N: usize = planner::HORIZON;

/// Identifies the road (scenario) a message belongs to: FNV-1a of the scenario file bytes.
pub type RoadId = u64;

/// FNV-1a 64-bit hash (road ids).
pub fn fnv1a(bytes: &[u8]) -> RoadId {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

/// Identifies one run of a state publisher (a tracker process from start to exit); 0 names
/// no run, and no tracker follows a plan made from a state with run id 0.
pub type RunId = u64;

/// A fresh, non-zero [`RunId`]: the standard library's randomly keyed SipHash over the
/// process id, CLOCK_MONOTONIC and the wall clock, so two runs (a tracker and its
/// restarted successor, or two trackers started at once) draw different ids.
pub fn new_run_id() -> RunId {
    use std::hash::{BuildHasher, Hasher};
    let mut h = std::collections::hash_map::RandomState::new().build_hasher();
    h.write_u32(std::process::id());
    h.write_u64(crate::clock::monotonic_ns());
    let wall = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos())
        .unwrap_or(0);
    h.write_u128(wall);
    match h.finish() {
        0 => 1,
        id => id,
    }
}

/// [`VehicleState::flags`]: the tracker's plan is older than its stale limit.
pub const FLAG_STALE: u32 = 1;
/// [`VehicleState::flags`]: the vehicle has braked to a stop.
pub const FLAG_STOPPED: u32 = 2;
/// [`VehicleState::flags`]: the plant simulation is running (a first plan arrived).
pub const FLAG_RUNNING: u32 = 4;
/// [`VehicleState::flags`]: plan from this state now (lockstep: the tracker's simulation
/// waits for the answer; `docs/closed-loop.md`, "Lockstep").
pub const FLAG_PLAN_NOW: u32 = 8;

/// Measured vehicle state published by the tracker (the plant's full model state).
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("trajopt::VehicleState")]
#[repr(C)]
pub struct VehicleState {
    /// Must equal [`MSG_VERSION`].
    pub version: u32,
    /// Bit set of `FLAG_*`.
    pub flags: u32,
    /// Sequence number, +1 per published state.
    pub seq: u64,
    /// Road the state is on.
    pub road_id: RoadId,
    /// Run of the publishing tracker ([`new_run_id`]; 0: no run).
    pub run_id: RunId,
    /// CLOCK_MONOTONIC at publish \[ns\].
    pub stamp_ns: u64,
    /// [r, V, beta, V_wr, dFz, e, dpsi, s, t] (order of `planner::model::ix`); s is the
    /// unwrapped track arc length \[m\] and t the simulation time \[s\].
    pub x: [f64; NX],
}

/// One planned trajectory on the s grid s_k = k ds of the horizon starting at `s_origin`.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("trajopt::Trajectory")]
#[repr(C)]
pub struct Trajectory {
    /// Must equal [`MSG_VERSION`].
    pub version: u32,
    /// Solver status code ([`status_code`]) of the cycle's solve; `kind` says what the
    /// cycle sent.
    pub status: u32,
    /// Sequence number, +1 per published plan.
    pub seq: u64,
    /// Road the plan is on.
    pub road_id: RoadId,
    /// CLOCK_MONOTONIC at publish \[ns\].
    pub stamp_ns: u64,
    /// `run_id` of the vehicle state this plan starts from (the plan's owner).
    pub from_run_id: RunId,
    /// `seq` of the vehicle state this plan starts from.
    pub from_state_seq: u64,
    /// `stamp_ns` of that vehicle state.
    pub from_state_stamp_ns: u64,
    /// Interior-point iterations.
    pub iterations: u32,
    /// 1 when warm-started from the previous plan shifted in s, 0 for the equilibrium guess.
    pub warm_started: u32,
    /// What kind of plan this is ([`PlanKind::code`]: 0 converged, 1 best iterate, 2 the
    /// previous plan shifted to the car's s; [`kind_name`]; or [`KIND_NO_PLAN`], a notice
    /// that the cycle has nothing drivable). For a shifted previous plan, `status` and
    /// `iterations` are this cycle's solve's, the trajectory and `max_violation` the
    /// previous plan's.
    pub kind: u32,
    /// Cycles since the trajectory was solved: 0, or how many cycles ago the plan a
    /// shifted previous plan repeats was solved.
    pub age_cycles: u32,
    /// Max constraint violation of the solve that produced the trajectory (scaled NLP
    /// units; `planner::plan::choice::DRIVABLE_VIOLATION` bounds a best iterate's).
    pub max_violation: f64,
    /// Wall time of the planning cycle (road window, guess, solve) \[s\].
    pub solve_time_s: f64,
    /// Track arc length of node 0 \[m\] (unwrapped, as in the vehicle state).
    pub s_origin: f64,
    /// Simulation time of node 0 \[s\].
    pub t_origin: f64,
    /// Node spacing \[m\].
    pub ds: f64,
    /// The measured state the plan starts from (s and t as measured).
    pub x_from: [f64; NX],
    /// Planned states x_0..x_N (s and t relative to node 0).
    pub x: [[f64; NX]; HORIZON_N + 1],
    /// Planned controls u_0..u_{N-1}; u_k holds on [s_k, s_k+1).
    pub u: [[f64; NU]; HORIZON_N],
}

/// Wire code of a solver status.
pub fn status_code(s: Status) -> u32 {
    match s {
        Status::Optimal => 0,
        Status::Acceptable => 1,
        Status::IterationLimit => 2,
        Status::TimeLimit => 3,
        Status::LocallyInfeasible => 4,
        Status::NumericalFailure => 5,
        Status::InvalidInput => 6,
    }
}

/// Solver status name of a wire code (`None` for an unknown code).
pub fn status_name(code: u32) -> Option<&'static str> {
    const NAMES: [Status; 7] = [
        Status::Optimal,
        Status::Acceptable,
        Status::IterationLimit,
        Status::TimeLimit,
        Status::LocallyInfeasible,
        Status::NumericalFailure,
        Status::InvalidInput,
    ];
    NAMES.get(code as usize).map(|s| s.name())
}

/// Why a received message was dropped.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum Invalid {
    /// Sender speaks another wire version.
    #[error("unknown message version {got} (this build speaks version {MSG_VERSION})")]
    Version {
        /// Version in the message.
        got: u32,
    },
    /// The message belongs to another road/scenario.
    #[error("road id {got:#018x} does not match this road {expected:#018x}")]
    Road {
        /// Road id in the message.
        got: RoadId,
        /// Road id of this process.
        expected: RoadId,
    },
    /// A value is NaN or infinite.
    #[error("{field} is not finite")]
    NonFinite {
        /// Field name.
        field: &'static str,
    },
    /// A value is outside its physical range.
    #[error("{field} = {value} outside the physical range [{min}, {max}]")]
    Range {
        /// Field name.
        field: &'static str,
        /// Offending value.
        value: f64,
        /// Lower limit.
        min: f64,
        /// Upper limit.
        max: f64,
    },
    /// Unknown solver status code.
    #[error("unknown solver status code {0}")]
    Status(u32),
    /// Unknown plan-kind code.
    #[error("unknown plan kind code {0}")]
    Kind(u32),
    /// An entry of a plan's node is NaN or infinite.
    #[error("plan node {node}: {field} is not finite")]
    NodeNonFinite {
        /// Node index.
        node: usize,
        /// State or control name.
        field: &'static str,
    },
    /// A state of a plan's node is outside its physical range.
    #[error("plan node {node}: {field} = {value} outside the physical range [{min}, {max}]")]
    NodeRange {
        /// Node index.
        node: usize,
        /// State name.
        field: &'static str,
        /// Offending value.
        value: f64,
        /// Lower limit.
        min: f64,
        /// Upper limit.
        max: f64,
    },
}

/// Names of the control entries (order of `iu`).
pub const CONTROL_NAMES: [&str; NU] = ["delta", "T_comb", "T_bf"];

/// Physical ranges of the state entries (order of `ix`), used to drop absurd states.
pub const STATE_RANGES: [(&str, f64, f64); NX] = [
    ("r", -5.0, 5.0),
    ("V", 0.0, 100.0),
    ("beta", -1.5, 1.5),
    ("V_wr", -5.0, 150.0),
    ("dFz", -3.0e4, 3.0e4),
    ("e", -20.0, 20.0),
    ("dpsi", -std::f64::consts::PI, std::f64::consts::PI),
    ("s", -1.0e7, 1.0e7),
    ("t", -1.0, 1.0e7),
];

fn check_header(version: u32, road: RoadId, expected: RoadId) -> Result<(), Invalid> {
    if version != MSG_VERSION {
        return Err(Invalid::Version { got: version });
    }
    if road != expected {
        return Err(Invalid::Road {
            got: road,
            expected,
        });
    }
    Ok(())
}

fn check_state(x: &[f64; NX]) -> Result<(), Invalid> {
    for (v, &(field, min, max)) in x.iter().zip(STATE_RANGES.iter()) {
        if !v.is_finite() {
            return Err(Invalid::NonFinite { field });
        }
        if *v < min || *v > max {
            return Err(Invalid::Range {
                field,
                value: *v,
                min,
                max,
            });
        }
    }
    Ok(())
}

impl VehicleState {
    /// A state message for `road_id` with run id 0 (no run: set one with
    /// [`Self::with_run_id`]); the stamp is set at publish.
    pub fn new(road_id: RoadId, seq: u64, flags: u32, x: [f64; NX]) -> Self {
        Self {
            version: MSG_VERSION,
            flags,
            seq,
            road_id,
            run_id: 0,
            stamp_ns: 0,
            x,
        }
    }

    /// The same state, published by run `run_id`.
    pub fn with_run_id(self, run_id: RunId) -> Self {
        Self { run_id, ..self }
    }

    /// Checks version, road, finiteness and physical ranges; allocates nothing.
    pub fn validate(&self, road: RoadId) -> Result<(), Invalid> {
        check_header(self.version, self.road_id, road)?;
        check_state(&self.x)
    }

    /// Speed V [m/s].
    pub fn speed(&self) -> f64 {
        self.x[ix::V]
    }
}

impl Trajectory {
    /// True for a notice that the cycle had nothing drivable ([`KIND_NO_PLAN`]).
    pub fn is_no_plan(&self) -> bool {
        self.kind == KIND_NO_PLAN
    }

    /// Every field zero (version 0: not a valid plan until filled in).
    pub fn zeroed() -> Self {
        Self {
            version: 0,
            status: 0,
            seq: 0,
            road_id: 0,
            stamp_ns: 0,
            from_run_id: 0,
            from_state_seq: 0,
            from_state_stamp_ns: 0,
            iterations: 0,
            warm_started: 0,
            kind: 0,
            age_cycles: 0,
            max_violation: 0.0,
            solve_time_s: 0.0,
            s_origin: 0.0,
            t_origin: 0.0,
            ds: 0.0,
            x_from: [0.0; NX],
            x: [[0.0; NX]; HORIZON_N + 1],
            u: [[0.0; NU]; HORIZON_N],
        }
    }

    /// Checks version, road, status code, that every number is finite and every state
    /// (the plan's nodes and `x_from`) within [`STATE_RANGES`]; errors name the node and
    /// entry. Allocates nothing.
    pub fn validate(&self, road: RoadId) -> Result<(), Invalid> {
        check_header(self.version, self.road_id, road)?;
        if status_name(self.status).is_none() {
            return Err(Invalid::Status(self.status));
        }
        if kind_name(self.kind).is_none() && self.kind != KIND_NO_PLAN {
            return Err(Invalid::Kind(self.kind));
        }
        for (field, v) in [
            ("max_violation", self.max_violation),
            ("ds", self.ds),
            ("s_origin", self.s_origin),
            ("t_origin", self.t_origin),
            ("solve_time_s", self.solve_time_s),
        ] {
            if !v.is_finite() {
                return Err(Invalid::NonFinite { field });
            }
        }
        if !(self.ds > 0.0 && self.ds < 100.0) {
            return Err(Invalid::Range {
                field: "ds",
                value: self.ds,
                min: 0.0,
                max: 100.0,
            });
        }
        check_state(&self.x_from)?;
        for (node, x) in self.x.iter().enumerate() {
            check_state(x).map_err(|e| match e {
                Invalid::NonFinite { field } => Invalid::NodeNonFinite { node, field },
                Invalid::Range {
                    field,
                    value,
                    min,
                    max,
                } => Invalid::NodeRange {
                    node,
                    field,
                    value,
                    min,
                    max,
                },
                other => other,
            })?;
        }
        for (node, u) in self.u.iter().enumerate() {
            if let Some(i) = u.iter().position(|v| !v.is_finite()) {
                return Err(Invalid::NodeNonFinite {
                    node,
                    field: CONTROL_NAMES[i],
                });
            }
        }
        Ok(())
    }

    /// [`Self::validate`], and the node spacing must be this road's `ds` (to 1e-9
    /// relative): a plan on another grid would be tracked over the wrong horizon.
    pub fn validate_for(&self, road: RoadId, ds: f64) -> Result<(), Invalid> {
        self.validate(road)?;
        if (self.ds - ds).abs() > 1e-9 * ds.abs() {
            return Err(Invalid::Range {
                field: "ds",
                value: self.ds,
                min: ds,
                max: ds,
            });
        }
        Ok(())
    }

    /// Horizon length N ds \[m\].
    pub fn length(&self) -> f64 {
        self.ds * HORIZON_N as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn good() -> VehicleState {
        VehicleState::new(7, 1, 0, [0.0, 15.0, 0.0, 15.0, 0.0, 0.0, 0.0, 3.0, 1.0])
    }

    #[test]
    fn state_validation() {
        assert_eq!(good().validate(7), Ok(()));
        let mut m = good();
        m.version = 99;
        assert_eq!(m.validate(7), Err(Invalid::Version { got: 99 }));
        assert!(matches!(good().validate(8), Err(Invalid::Road { .. })));
        let mut m = good();
        m.x[ix::E] = f64::NAN;
        assert_eq!(m.validate(7), Err(Invalid::NonFinite { field: "e" }));
        let mut m = good();
        m.x[ix::V] = 1.0e6;
        assert!(matches!(
            m.validate(7),
            Err(Invalid::Range { field: "V", .. })
        ));
    }

    fn good_plan() -> Box<Trajectory> {
        let x = [0.0, 15.0, 0.0, 15.0, 0.0, 0.0, 0.0, 3.0, 1.0];
        Box::new(Trajectory {
            version: MSG_VERSION,
            status: status_code(Status::Optimal),
            seq: 1,
            road_id: 7,
            stamp_ns: 0,
            from_run_id: 3,
            from_state_seq: 1,
            from_state_stamp_ns: 0,
            iterations: 40,
            warm_started: 0,
            kind: PlanKind::Converged.code(),
            age_cycles: 0,
            max_violation: 1e-9,
            solve_time_s: 0.02,
            s_origin: 100.0,
            t_origin: 5.0,
            ds: 2.5,
            x_from: x,
            x: [x; HORIZON_N + 1],
            u: [[0.0; NU]; HORIZON_N],
        })
    }

    #[test]
    fn plan_validation_names_node_and_entry() {
        assert_eq!(good_plan().validate(7), Ok(()));
        let mut m = good_plan();
        m.status = 999;
        assert_eq!(m.validate(7), Err(Invalid::Status(999)));
        let mut m = good_plan();
        m.kind = KIND_NO_PLAN;
        assert_eq!(m.validate(7), Ok(()));
        m.kind = 4;
        assert_eq!(m.validate(7), Err(Invalid::Kind(4)));
        let mut m = good_plan();
        m.max_violation = f64::NAN;
        assert_eq!(
            m.validate(7),
            Err(Invalid::NonFinite {
                field: "max_violation"
            })
        );
        let mut m = good_plan();
        m.x[17][ix::BETA] = f64::NAN;
        assert_eq!(
            m.validate(7),
            Err(Invalid::NodeNonFinite {
                node: 17,
                field: "beta"
            })
        );
        let mut m = good_plan();
        m.x[42][ix::V] = 500.0;
        let e = m.validate(7).unwrap_err();
        assert!(matches!(
            e,
            Invalid::NodeRange {
                node: 42,
                field: "V",
                ..
            }
        ));
        assert!(e.to_string().contains("plan node 42: V = 500"), "{e}");
        let mut m = good_plan();
        m.u[99][2] = f64::INFINITY;
        assert_eq!(
            m.validate(7),
            Err(Invalid::NodeNonFinite {
                node: 99,
                field: "T_bf"
            })
        );
        let mut m = good_plan();
        m.x_from[ix::E] = 50.0;
        assert!(matches!(
            m.validate(7),
            Err(Invalid::Range { field: "e", .. })
        ));
        let mut m = good_plan();
        m.ds = 0.0;
        assert!(matches!(
            m.validate(7),
            Err(Invalid::Range { field: "ds", .. })
        ));
        // The grid must be the receiver's.
        assert_eq!(good_plan().validate_for(7, 2.5), Ok(()));
        assert!(matches!(
            good_plan().validate_for(7, 2.0),
            Err(Invalid::Range { field: "ds", .. })
        ));
    }

    #[test]
    fn run_ids_are_non_zero_and_differ_between_draws() {
        let a = new_run_id();
        let b = new_run_id();
        assert_ne!(a, 0);
        assert_ne!(b, 0);
        assert_ne!(a, b);
        assert_eq!(good().run_id, 0);
        assert_eq!(good().with_run_id(a).run_id, a);
    }

    #[test]
    fn status_codes_round_trip() {
        for s in [Status::Optimal, Status::TimeLimit, Status::InvalidInput] {
            assert_eq!(status_name(status_code(s)), Some(s.name()));
        }
        assert_eq!(status_name(42), None);
    }
}
