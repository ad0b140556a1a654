//! `inject_state`: test helper (fault injection, not part of the closed loop). Publishes a
//! sequence of vehicle states, some deliberately invalid, to a running `planner_proc`, and
//! reports which of them the planner planned from.
//!
//! `--send nan,range,version,road,sideways,good`: one state per entry (`nan`: e = NaN;
//! `range`: V = 1e6 m/s; `version`: wrong wire version; `road`: wrong road id; `sideways`:
//! a valid message heading 2 rad off the road, outside the planner's domain; `good`: a
//! valid cruise state). Between entries it waits `--gap-s` (long enough for the planner to have
//! solved, had it accepted the state). After the last entry it waits up to `--wait-plan-s`
//! for a trajectory planned from a good state. Like a tracker, it publishes under its own
//! run id (seqs 1000, 1001, ... in every run, so a second run reuses the first one's seqs)
//! and owns only the plans made from its states. Prints one JSON line: its run id, the seq
//! of each sent state, the `from_state_seq` of every trajectory received for this run, and
//! how many trajectories for other runs arrived. Exit 2 on bad input, 1 on IPC errors or
//! timeouts.

use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::Parser;
use ipc::msg::{new_run_id, VehicleState, MSG_VERSION};
use ipc::plant::Plant;
use ipc::road::Scenario;
use ipc::services::{publish_state, IpcError, Services};
use planner::model::ix;

#[allow(rustdoc::broken_intra_doc_links)] // clap prints these docs as --help: unit brackets stay unescaped
#[derive(Parser, Debug)]
#[command(
    name = "inject_state",
    about = "Test helper: publish (invalid) vehicle states to a running planner_proc"
)]
struct Cli {
    /// Scenario file (for the road id).
    #[arg(long, default_value = "config/scenarios/oval.toml")]
    scenario: std::path::PathBuf,
    /// Vehicle file.
    #[arg(long, default_value = "config/vehicles/lc500.toml")]
    vehicle: std::path::PathBuf,
    /// Solver settings file.
    #[arg(long, default_value = "config/solver.toml")]
    solver: std::path::PathBuf,
    /// iceoryx2 service-name prefix of the planner under test.
    #[arg(long)]
    service_prefix: String,
    /// Comma-separated states to send: nan, range, version, road, sideways, good.
    #[arg(long, value_delimiter = ',', required = true)]
    send: Vec<String>,
    /// Pause after each state [s].
    #[arg(long, default_value_t = 1.0)]
    gap_s: f64,
    /// Wait for the planner's state subscriber at most this long [s].
    #[arg(long, default_value_t = 30.0)]
    connect_timeout_s: f64,
    /// After the last state, wait this long for a plan from a good state [s].
    #[arg(long, default_value_t = 30.0)]
    wait_plan_s: f64,
}

#[derive(Debug, thiserror::Error)]
enum Error {
    #[error("{0}")]
    Setup(String),
    #[error(transparent)]
    Ipc(#[from] IpcError),
    #[error("{0}")]
    Timeout(String),
}

fn run(cli: &Cli) -> Result<serde_json::Value, Error> {
    let finite = [cli.gap_s, cli.connect_timeout_s, cli.wait_plan_s]
        .iter()
        .all(|t| t.is_finite());
    if !(finite && cli.gap_s >= 0.0 && cli.connect_timeout_s > 0.0 && cli.wait_plan_s >= 0.0) {
        return Err(Error::Setup(
            "--gap-s and --wait-plan-s must be finite and >= 0, --connect-timeout-s finite and > 0"
                .into(),
        ));
    }
    ipc::services::check_prefix(&cli.service_prefix).map_err(Error::Setup)?;
    let sc = Scenario::load(&cli.scenario, &cli.vehicle, &cli.solver)
        .map_err(|e| Error::Setup(e.to_string()))?;
    let good = Plant::cruise(sc.spec.vehicle, 15.0).x;
    let run_id = new_run_id();
    let mut msgs = Vec::with_capacity(cli.send.len());
    for (i, kind) in cli.send.iter().enumerate() {
        let seq = 1000 + i as u64;
        let mut m = VehicleState::new(sc.id, seq, 0, good).with_run_id(run_id);
        match kind.as_str() {
            "good" => {}
            "nan" => m.x[ix::E] = f64::NAN,
            "range" => m.x[ix::V] = 1.0e6,
            "version" => m.version = MSG_VERSION + 100,
            "road" => m.road_id = sc.id ^ 1,
            // A valid message the planner cannot plan from: heading across the road.
            "sideways" => m.x[ix::DPSI] = 2.0,
            other => {
                return Err(Error::Setup(format!(
                    "--send: unknown state kind {other:?}"
                )))
            }
        }
        msgs.push((kind.clone(), m));
    }

    let svc = Services::open(&cli.service_prefix, "inject_state")?;
    let publisher = svc.state_publisher()?;
    let notifier = svc.state_notifier()?;
    let sub = svc.traj_subscriber()?;
    let t0 = Instant::now();
    while svc.state_subscriber_count() == 0 {
        if t0.elapsed().as_secs_f64() > cli.connect_timeout_s {
            return Err(Error::Timeout(format!(
                "no state subscriber on {} within {} s",
                cli.service_prefix, cli.connect_timeout_s
            )));
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let mut from_seqs: Vec<u64> = Vec::new();
    let mut foreign = 0u64;
    let mut drain = |from: &mut Vec<u64>| -> Result<(), Error> {
        while let Some(s) = sub
            .receive()
            .map_err(ipc::services::ipc_err("receive trajectory"))?
        {
            if s.payload().is_no_plan() {
                // A notice that a cycle had nothing drivable: not a plan.
                continue;
            }
            if s.payload().from_run_id == run_id {
                from.push(s.payload().from_state_seq);
            } else {
                foreign += 1;
            }
        }
        Ok(())
    };
    let mut sent = Vec::new();
    for (kind, m) in &msgs {
        publish_state(&publisher, &notifier, *m)?;
        sent.push(serde_json::json!({ "kind": kind, "seq": m.seq }));
        let until = Instant::now() + Duration::from_secs_f64(cli.gap_s);
        while Instant::now() < until {
            drain(&mut from_seqs)?;
            std::thread::sleep(Duration::from_millis(10));
        }
    }
    let good_seqs: Vec<u64> = msgs
        .iter()
        .filter(|(k, _)| k == "good")
        .map(|(_, m)| m.seq)
        .collect();
    if !good_seqs.is_empty() {
        let until = Instant::now() + Duration::from_secs_f64(cli.wait_plan_s);
        while !from_seqs.iter().any(|s| good_seqs.contains(s)) && Instant::now() < until {
            drain(&mut from_seqs)?;
            std::thread::sleep(Duration::from_millis(10));
        }
    }
    drain(&mut from_seqs)?;
    Ok(serde_json::json!({
        "run_id": format!("{run_id:#018x}"),
        "sent": sent,
        "plans_from_state_seq": from_seqs,
        "plans_foreign": foreign,
    }))
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(&cli) {
        Ok(v) => match ipc::out::print_line(&v) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                ipc::elog!("inject_state: cannot write the report: {e}");
                ExitCode::from(1)
            }
        },
        Err(e) => {
            ipc::elog!("inject_state: error: {e}");
            match e {
                Error::Setup(_) => ExitCode::from(2),
                Error::Ipc(_) | Error::Timeout(_) => ExitCode::from(1),
            }
        }
    }
}
