//! End-to-end fault tests of the iceoryx2 closed loop: the processes are spawned
//! directly (`planner_proc`, `tracker_proc`, and the `inject_state` test helper) from the
//! test's target profile folder; build them first (`cargo build -p ipc --bins`, same
//! profile; `cargo test --workspace` does).
//!
//! Every test uses its own service prefix and kills its children when it fails (guard
//! `Drop`). The tests share one lock so two closed loops never compete for the cores.

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Serialises the tests of this file (each runs a closed loop on the shared cores).
static SERIAL: Mutex<()> = Mutex::new(());

fn serial() -> MutexGuard<'static, ()> {
    SERIAL
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

fn bin_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("test executable path");
    // target/<profile>/deps/faults-<hash> -> target/<profile>
    exe.parent()
        .and_then(|d| d.parent())
        .expect("target profile folder")
        .to_path_buf()
}

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn prefix(tag: &str) -> String {
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.subsec_nanos())
        .unwrap_or(0);
    format!("e2e-faults-{tag}-{}-{nanos}", std::process::id())
}

fn command(bin: &str) -> Command {
    let path = bin_dir().join(bin);
    assert!(
        path.is_file(),
        "{} missing: build with `cargo build -p ipc --bins` (same profile)",
        path.display()
    );
    let mut c = Command::new(path);
    c.current_dir(repo());
    c
}

/// A child process whose stderr is collected line by line (and watchable); killed on drop.
struct Proc {
    name: &'static str,
    child: Child,
    stdin: Option<ChildStdin>,
    lines: Receiver<String>,
    log: Arc<Mutex<String>>,
    stderr_thread: Option<JoinHandle<()>>,
}

impl Proc {
    /// Spawns `cmd` with piped stdin/stdout/stderr.
    fn spawn(name: &'static str, mut cmd: Command) -> Self {
        let mut child = cmd
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap_or_else(|e| panic!("spawn {name}: {e}"));
        let stdin = child.stdin.take();
        let stderr = child.stderr.take().expect("piped stderr");
        let (tx, lines) = channel();
        let log = Arc::new(Mutex::new(String::new()));
        let log2 = log.clone();
        let stderr_thread = std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                if let Ok(mut l) = log2.lock() {
                    l.push_str(&line);
                    l.push('\n');
                }
                let _ = tx.send(line);
            }
        });
        Self {
            name,
            child,
            stdin,
            lines,
            log,
            stderr_thread: Some(stderr_thread),
        }
    }

    fn log(&self) -> String {
        self.log.lock().map(|l| l.clone()).unwrap_or_default()
    }

    /// Waits until a stderr line contains `needle`; panics (with the log) on timeout or exit.
    fn wait_line(&self, needle: &str, timeout: Duration) {
        let until = Instant::now() + timeout;
        loop {
            let left = until.saturating_duration_since(Instant::now());
            match self.lines.recv_timeout(left) {
                Ok(l) if l.contains(needle) => return,
                Ok(_) => {}
                Err(RecvTimeoutError::Timeout) => panic!(
                    "{}: no line containing {needle:?} within {timeout:?}; stderr:\n{}",
                    self.name,
                    self.log()
                ),
                Err(RecvTimeoutError::Disconnected) => panic!(
                    "{}: exited before printing {needle:?}; stderr:\n{}",
                    self.name,
                    self.log()
                ),
            }
        }
    }

    /// SIGKILL (the fault being tested), then reap.
    fn kill(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }

    /// Closes stdin (the processes' stop request when run with `--exit-on-stdin-eof`).
    fn close_stdin(&mut self) {
        self.stdin = None;
    }

    /// Waits for exit (killing after `timeout`); returns the JSON summary on stdout.
    fn finish(mut self, timeout: Duration) -> serde_json::Value {
        let until = Instant::now() + timeout;
        let status = loop {
            match self.child.try_wait() {
                Ok(Some(s)) => break s,
                Ok(None) if Instant::now() < until => std::thread::sleep(Duration::from_millis(20)),
                Ok(None) => {
                    self.kill();
                    panic!(
                        "{} did not exit within {timeout:?}; stderr:\n{}",
                        self.name,
                        self.log()
                    );
                }
                Err(e) => panic!("{}: wait: {e}", self.name),
            }
        };
        if let Some(t) = self.stderr_thread.take() {
            let _ = t.join();
        }
        let mut out = String::new();
        if let Some(mut o) = self.child.stdout.take() {
            let _ = std::io::Read::read_to_string(&mut o, &mut out);
        }
        assert!(
            status.success(),
            "{} failed ({status}); stderr:\n{}",
            self.name,
            self.log()
        );
        serde_json::from_str(out.trim()).unwrap_or_else(|e| {
            panic!(
                "{}: bad JSON ({e}): {out:?}; stderr:\n{}",
                self.name,
                self.log()
            )
        })
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        // No-op when already reaped; kills the process when a test failed half-way.
        if let Ok(None) = self.child.try_wait() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

fn planner(prefix: &str) -> Proc {
    let mut c = command("planner_proc");
    c.args(["--service-prefix", prefix, "--exit-on-stdin-eof"]);
    Proc::spawn("planner_proc", c)
}

fn tracker(prefix: &str, extra: &[&str]) -> Proc {
    let mut c = command("tracker_proc");
    c.args(["--service-prefix", prefix, "--exit-on-stdin-eof"])
        .args(["--first-plan-timeout-s", "60"])
        .args(extra);
    Proc::spawn("tracker_proc", c)
}

const START: Duration = Duration::from_secs(60);

/// The run id a tracker printed in its "up" line (`run id 0x...`).
fn run_id_in_log(log: &str) -> String {
    log.lines()
        .find_map(|l| {
            let rest = l.split("run id ").nth(1)?;
            Some(rest.split([',', ')']).next()?.to_string())
        })
        .unwrap_or_else(|| panic!("no run id in the log:\n{log}"))
}

/// (a) SIGKILL the tracker mid-drive and start a new one: the planner keeps running and
/// serves the new tracker, which drives its distance on fresh plans. The new tracker runs
/// under a new run id and never follows its predecessor's last plan (which the trajectory
/// service's history hands it): that plan is counted as foreign.
#[test]
fn tracker_restart_is_served_by_the_running_planner() {
    let _serial = serial();
    let p = prefix("restart");
    let mut plan = planner(&p);
    plan.wait_line("planner: up", START);

    let mut t1 = tracker(&p, &["--distance-m", "200", "--duration-s", "60"]);
    t1.wait_line("first plan", START);
    std::thread::sleep(Duration::from_millis(1000));
    t1.kill();
    let t1_run = run_id_in_log(&t1.log());

    // The planner must survive the dead peer.
    std::thread::sleep(Duration::from_millis(500));
    assert!(
        matches!(plan.child.try_wait(), Ok(None)),
        "planner exited after the tracker was killed; stderr:\n{}",
        plan.log()
    );

    let t2 = tracker(&p, &["--distance-m", "40", "--duration-s", "30"]);
    let t2_log = t2.log.clone();
    let s2 = t2.finish(Duration::from_secs(120));
    assert_eq!(s2["end_reason"], "distance reached", "{s2}");
    assert!(
        s2["laps_or_distance_m"].as_f64().unwrap_or(0.0) >= 40.0,
        "{s2}"
    );
    assert!(s2["plans_received"].as_u64().unwrap_or(0) >= 3, "{s2}");
    assert_eq!(s2["lane_kept"], true, "{s2}");
    assert_eq!(s2["stale"], false, "{s2}");
    // The predecessor's plan reached the new tracker and was refused as another run's.
    let t2_run = s2["run_id"].as_str().unwrap_or_default().to_string();
    assert!(
        t2_run.starts_with("0x") && t2_run != t1_run,
        "{t1_run} {s2}"
    );
    assert!(
        s2["plans_foreign_by_reason"]["run_id"]
            .as_u64()
            .unwrap_or(0)
            >= 1,
        "{s2}"
    );
    assert_eq!(s2["plans_foreign_by_reason"]["state_seq"], 0, "{s2}");
    let refused = format!("planned for run {t1_run}");
    let t2_log = t2_log.lock().map(|l| l.clone()).unwrap_or_default();
    assert!(
        t2_log.contains(&refused),
        "the new tracker never refused its predecessor's plan; stderr:\n{t2_log}"
    );

    plan.close_stdin();
    let sp = plan.finish(Duration::from_secs(30));
    // Planned for the first tracker, then for the second.
    assert_eq!(sp["state_run_switches"], 2, "{sp}");
    let t2_plans = s2["plans_received"].as_u64().unwrap_or(0);
    assert!(
        sp["plans_published"].as_u64().unwrap_or(0) > t2_plans,
        "planner published fewer plans than the two trackers received: {sp}\n{s2}"
    );
}

/// (b) SIGKILL the planner: the tracker holds the last plan, flags it stale after
/// `--stale-after-s` and brakes to a stop, then exits on its own.
#[test]
fn planner_death_makes_tracker_flag_stale_and_stop() {
    let _serial = serial();
    let p = prefix("stale");
    let mut plan = planner(&p);
    plan.wait_line("planner: up", START);
    let tr = tracker(
        &p,
        &[
            "--distance-m",
            "1000",
            "--duration-s",
            "60",
            "--stale-after-s",
            "0.5",
        ],
    );
    tr.wait_line("first plan", START);
    std::thread::sleep(Duration::from_millis(1000));
    plan.kill();
    tr.wait_line("is stale", Duration::from_secs(30));
    let s = tr.finish(Duration::from_secs(60));
    assert_eq!(s["stale"], true, "{s}");
    assert_eq!(s["stopped"], true, "{s}");
    assert_eq!(s["end_reason"], "stopped", "{s}");
    assert!(
        s["final_speed_mps"].as_f64().unwrap_or(f64::NAN) < 0.5,
        "{s}"
    );
    assert_eq!(s["lane_kept"], true, "{s}");
    assert!(s["stale_at_sim_s"].as_f64().is_some(), "{s}");
}

/// (c) States with NaN or absurd values (and wrong version/road) are counted by reason and
/// dropped, and a valid state outside the planner's domain (heading across the road) is
/// counted and not planned: the planner never solves from them, and still plans from the
/// next good state.
#[test]
fn bad_states_are_counted_and_never_planned_from() {
    let _serial = serial();
    let p = prefix("badstate");
    let mut plan = planner(&p);
    plan.wait_line("planner: up", START);
    let mut inj = command("inject_state");
    inj.args(["--service-prefix", &p])
        .args(["--send", "nan,range,version,road,sideways,good"])
        .args(["--gap-s", "0.5", "--wait-plan-s", "60"]);
    let inj = Proc::spawn("inject_state", inj).finish(Duration::from_secs(120));

    plan.close_stdin();
    let sp = plan.finish(Duration::from_secs(30));
    let by = &sp["states_rejected_by_reason"];
    assert_eq!(by["non_finite"], 1, "{sp}");
    assert_eq!(by["range"], 1, "{sp}");
    assert_eq!(by["version"], 1, "{sp}");
    assert_eq!(by["road"], 1, "{sp}");
    assert_eq!(sp["states_rejected"], 4, "{sp}");
    assert_eq!(sp["states_received"], 6, "{sp}");
    // The sideways state is a valid message outside the planner's domain: not planned.
    assert_eq!(sp["states_outside_domain"], 1, "{sp}");
    // Exactly one plan, from the good state (seq 1005): none from the bad ones.
    assert_eq!(sp["plans_published"], 1, "{sp}");
    assert_eq!(
        inj["plans_from_state_seq"],
        serde_json::json!([1005]),
        "{inj}"
    );
}

/// (d) Options that would hang a process or panic it (an endless wait, a plant step so
/// small the substep count overflows, an infinite sleep), that name a soft lane the road
/// cannot have, or that set a cap or scale out of its range, are refused before any IPC,
/// with exit code 2 and the option named.
#[test]
fn options_that_would_hang_or_panic_are_refused_by_name() {
    let cases: [(&str, &[&str], &str); 18] = [
        ("tracker_proc", &["--plant-dt-s", "1e-9"], "--plant-dt-s"),
        (
            "tracker_proc",
            &["--first-plan-timeout-s", "inf"],
            "--first-plan-timeout-s",
        ),
        (
            "tracker_proc",
            &["--first-plan-timeout-s", "NaN"],
            "--first-plan-timeout-s",
        ),
        ("tracker_proc", &["--time-scale", "1e9"], "--time-scale"),
        (
            "inject_state",
            &["--send", "good", "--gap-s", "inf"],
            "--gap-s",
        ),
        ("planner_proc", &["--rate-hz", "0"], "--rate-hz"),
        ("planner_proc", &["--warm-max-iter", "0"], "--warm-max-iter"),
        (
            "planner_proc",
            &["--min-path-scale", "0.95"],
            "--min-path-scale",
        ),
        (
            "planner_proc",
            &["--min-path-scale", "NaN"],
            "--min-path-scale",
        ),
        (
            "planner_proc",
            &["--friction-scale", "0.2"],
            "--friction-scale",
        ),
        (
            "planner_proc",
            &["--friction-scale", "NaN"],
            "--friction-scale",
        ),
        (
            "planner_proc",
            &["--relaxed-friction-scale", "1.5"],
            "--relaxed-friction-scale",
        ),
        (
            "planner_proc",
            &["--relaxed-friction-scale", "NaN"],
            "--relaxed-friction-scale",
        ),
        (
            "planner_proc",
            &["--soft-lane-m", "1", "--soft-lane-weight", "0"],
            "--soft-lane-weight",
        ),
        ("planner_proc", &["--soft-lane-m", "inf"], "--soft-lane-m"),
        ("planner_proc", &["--soft-lane-m=-1"], "--soft-lane-m"),
        ("planner_proc", &["--soft-lane-m", "NaN"], "--soft-lane-m"),
        (
            "planner_proc",
            &[
                "--scenario",
                "config/scenarios/collision_avoidance.toml",
                "--segment",
                "forgiving",
                "--soft-lane-m",
                "1",
            ],
            "--soft-lane-m",
        ),
    ];
    for (bin, args, option) in cases {
        let out = command(bin)
            .args(["--service-prefix", "trajopt_refused_options"])
            .args(args)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{bin} {args:?}: {err}");
        assert!(err.contains(option), "{bin} {args:?}: {err}");
    }
}

/// A second publisher run reusing the first one's seq values (as a restarted tracker does)
/// is planned, not taken for a state already planned; each run receives the other's plan
/// too (the service history hands the first run's plan to the second) and counts it as
/// foreign, never as its own.
#[test]
fn a_second_publisher_reusing_seq_values_is_planned() {
    let _serial = serial();
    let p = prefix("reuse");
    let mut plan = planner(&p);
    plan.wait_line("planner: up", START);
    let inject = || {
        let mut inj = command("inject_state");
        inj.args(["--service-prefix", &p])
            .args(["--send", "good"])
            .args(["--gap-s", "0.2", "--wait-plan-s", "60"]);
        Proc::spawn("inject_state", inj).finish(Duration::from_secs(120))
    };
    let first = inject();
    let second = inject();

    plan.close_stdin();
    let sp = plan.finish(Duration::from_secs(30));
    assert_ne!(first["run_id"], second["run_id"], "{first}\n{second}");
    assert_eq!(first["sent"][0]["seq"], second["sent"][0]["seq"]);
    for inj in [&first, &second] {
        assert_eq!(
            inj["plans_from_state_seq"],
            serde_json::json!([1000]),
            "{inj}"
        );
    }
    assert!(
        second["plans_foreign"].as_u64().unwrap_or(0) >= 1,
        "{second}"
    );
    assert_eq!(sp["plans_published"], 2, "{sp}");
    assert_eq!(sp["state_run_switches"], 2, "{sp}");
    assert_eq!(sp["states_rejected"], 0, "{sp}");
}

/// Starts `bin` with stdout and stderr pipes whose read ends are closed at once (a killed
/// `trajopt closed-loop` parent), lets it run, closes its stdin and waits for its exit
/// status: every write it makes returns EPIPE.
fn run_with_closed_output(bin: &str, prefix: &str, extra: &[&str]) -> std::process::ExitStatus {
    let mut c = command(bin);
    c.args(["--service-prefix", prefix, "--exit-on-stdin-eof"])
        .args(extra)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    let mut child = c.spawn().unwrap_or_else(|e| panic!("spawn {bin}: {e}"));
    drop(child.stdout.take());
    drop(child.stderr.take());
    // Long enough to load the files, open the services and log that it is up.
    std::thread::sleep(Duration::from_secs(2));
    drop(child.stdin.take());
    let until = Instant::now() + Duration::from_secs(60);
    loop {
        match child.try_wait() {
            Ok(Some(status)) => return status,
            Ok(None) if Instant::now() < until => std::thread::sleep(Duration::from_millis(50)),
            _ => {
                let _ = child.kill();
                let _ = child.wait();
                panic!("{bin} did not stop within 60 s of its stdin closing");
            }
        }
    }
}

/// With its parent gone (stdout and stderr pipes closed), a process logs into the void
/// and stops cleanly when asked: no panic (exit code 101) on a broken pipe.
#[test]
fn processes_stop_cleanly_when_their_output_pipes_are_closed() {
    let _serial = serial();
    let p = prefix("epipe");
    let planner = run_with_closed_output("planner_proc", &p, &[]);
    assert_ne!(
        planner.code(),
        Some(101),
        "planner_proc panicked: {planner}"
    );
    assert!(planner.success(), "planner_proc: {planner}");
    let tracker = run_with_closed_output("tracker_proc", &p, &["--first-plan-timeout-s", "60"]);
    assert_ne!(
        tracker.code(),
        Some(101),
        "tracker_proc panicked: {tracker}"
    );
    assert!(tracker.success(), "tracker_proc: {tracker}");
}
