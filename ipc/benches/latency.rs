//! One-way publish-to-receive latency of a `Trajectory` (9.4 KB, zero-copy) between two
//! processes over iceoryx2 (`cargo bench -p ipc --bench latency`).
//!
//! The bench process spawns itself as an echo process (env `TRAJOPT_LATENCY_ECHO=<prefix>`).
//! Per iteration the bench publishes a vehicle state (the request); the echo process wakes
//! on its state listener, writes a trajectory into a loaned sample, stamps it with
//! CLOCK_MONOTONIC right before `send` and notifies; the bench wakes on its trajectory
//! listener, receives, and takes the one-way time as now - stamp (the clock is system-wide).
//! This is the planner -> tracker path of the closed loop, event wake-up included. Criterion
//! reports the mean/median of that one-way time; p50/p99/max over all iterations are printed
//! at the end. Needs only /dev/shm (iceoryx2's default); no other setting.

use std::process::{Child, Command};
use std::time::{Duration, Instant};

use criterion::{criterion_group, Criterion};
use ipc::clock::monotonic_ns;
use ipc::msg::{Trajectory, VehicleState, MSG_VERSION};
use ipc::services::{ipc_err, publish_state, wait_events, IpcError, Services};
use ipc::stats::Latency;
use planner::model::NX;

const ECHO_ENV: &str = "TRAJOPT_LATENCY_ECHO";
/// `VehicleState::flags` value that stops the echo process.
const STOP: u32 = u32::MAX;

fn template() -> Box<Trajectory> {
    let mut t = Box::new(Trajectory {
        version: MSG_VERSION,
        iterations: 20,
        solve_time_s: 0.05,
        ds: 2.6,
        ..Trajectory::zeroed()
    });
    for (k, x) in t.x.iter_mut().enumerate() {
        x[1] = 15.0 + k as f64 * 0.01;
    }
    t
}

/// The echo process: one trajectory per received state, until a STOP state.
fn echo(prefix: &str) -> Result<(), IpcError> {
    let svc = Services::open(prefix, "latency_echo")?;
    let sub = svc.state_subscriber()?;
    let listener = svc.state_listener()?;
    let publisher = svc.traj_publisher()?;
    let notifier = svc.traj_notifier()?;
    let tmpl = template();
    let started = Instant::now();
    loop {
        wait_events(&listener, Duration::from_millis(100))?;
        while let Some(s) = sub.receive().map_err(ipc_err("receive state"))? {
            let st: &VehicleState = s.payload();
            if st.flags == STOP {
                return Ok(());
            }
            let sample = publisher.loan_uninit().map_err(ipc_err("loan"))?;
            let mut sample = sample.write_payload(*tmpl);
            let p = sample.payload_mut();
            p.seq = st.seq;
            p.from_state_seq = st.seq;
            p.stamp_ns = monotonic_ns();
            sample.send().map_err(ipc_err("send trajectory"))?;
            notifier.notify().map_err(ipc_err("notify"))?;
        }
        // Orphan guard: the bench died without stopping us.
        if started.elapsed() > Duration::from_secs(600) || svc.termination_requested() {
            return Ok(());
        }
    }
}

/// Kills the echo process if the bench panics.
struct EchoGuard(Child);

impl Drop for EchoGuard {
    fn drop(&mut self) {
        if let Ok(None) = self.0.try_wait() {
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }
}

fn bench_latency(c: &mut Criterion) {
    let prefix = format!("bench-latency-{}", std::process::id());
    let exe = std::env::current_exe().expect("bench executable path");
    let child = Command::new(exe)
        .env(ECHO_ENV, &prefix)
        .spawn()
        .expect("spawn echo process");
    let mut guard = EchoGuard(child);
    let svc = Services::open(&prefix, "latency_bench").expect("open services");
    let publisher = svc.state_publisher().expect("state publisher");
    let notifier = svc.state_notifier().expect("state notifier");
    let sub = svc.traj_subscriber().expect("trajectory subscriber");
    let listener = svc.traj_listener().expect("trajectory listener");
    let t0 = Instant::now();
    while svc.state_subscriber_count() == 0 {
        assert!(
            t0.elapsed() < Duration::from_secs(30),
            "echo process did not connect"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    let mut seq = 0u64;
    let mut hist = Latency::new();
    let mut one = |hist: &mut Latency| -> Duration {
        seq += 1;
        publish_state(
            &publisher,
            &notifier,
            VehicleState::new(0, seq, 0, [0.0; NX]),
        )
        .expect("publish request");
        let deadline = Instant::now() + Duration::from_secs(5);
        loop {
            if let Some(s) = sub.receive().expect("receive trajectory") {
                let now = monotonic_ns();
                let m: &Trajectory = s.payload();
                if m.seq != seq {
                    continue; // a late answer to an earlier request
                }
                let ns = now.saturating_sub(m.stamp_ns);
                hist.record_ns(ns);
                return Duration::from_nanos(ns);
            }
            assert!(Instant::now() < deadline, "no trajectory within 5 s");
            wait_events(&listener, Duration::from_secs(5)).expect("wait for trajectory");
        }
    };
    c.bench_function("ipc_trajectory_one_way", |b| {
        b.iter_custom(|iters| (0..iters).map(|_| one(&mut hist)).sum())
    });
    let us = |q: f64| hist.quantile_ns(q) as f64 * 1e-3;
    println!(
        "ipc_trajectory_one_way: {} samples, p50 {:.1} us, p90 {:.1} us, p99 {:.1} us, p99.9 {:.1} us, max {:.1} us",
        hist.count(),
        us(0.5),
        us(0.9),
        us(0.99),
        us(0.999),
        hist.max_ns() as f64 * 1e-3
    );
    let _ = publish_state(
        &publisher,
        &notifier,
        VehicleState::new(0, 0, STOP, [0.0; NX]),
    );
    let until = Instant::now() + Duration::from_secs(5);
    while Instant::now() < until {
        if let Ok(Some(_)) = guard.0.try_wait() {
            break;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(50)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(5));
    targets = bench_latency
}

fn main() {
    if let Ok(prefix) = std::env::var(ECHO_ENV) {
        if let Err(e) = echo(&prefix) {
            eprintln!("latency echo: {e}");
            std::process::exit(1);
        }
        return;
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
