//! The iceoryx2 services of the closed loop, opened with the same QoS by every process:
//! `<prefix>/vehicle_state` and `<prefix>/trajectory` (publish-subscribe, each paired with
//! an event service of the same name so receivers block on a listener, not a busy loop).
//!
//! Both services keep their last sample as history for a late subscriber. On the trajectory
//! service that sample was planned for whoever published the state it starts from (for a
//! restarted tracker, its predecessor), so receivers check a plan's `from_run_id` and
//! `from_state_seq` before following it (`tracker::Ownership`).

use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;

use crate::msg::{Trajectory, VehicleState};

/// The iceoryx2 service flavour: inter-process, single-threaded ports.
pub type Svc = ipc::Service;

/// Any iceoryx2 failure, with the step that failed.
#[derive(Debug, thiserror::Error)]
#[error("iceoryx2: {step}: {msg}")]
pub struct IpcError {
    /// What was being done.
    pub step: &'static str,
    /// The underlying error.
    pub msg: String,
}

/// Wraps an iceoryx2 error with the step that failed.
pub fn ipc_err<E: core::fmt::Debug>(step: &'static str) -> impl FnOnce(E) -> IpcError {
    move |e| IpcError {
        step,
        msg: format!("{e:?}"),
    }
}

/// Default service-name prefix.
pub const DEFAULT_PREFIX: &str = "trajopt";

/// A node plus the port factories of both services.
pub struct Services {
    /// The process's node.
    pub node: Node<Svc>,
    state: iceoryx2::service::port_factory::publish_subscribe::PortFactory<Svc, VehicleState, ()>,
    state_ev: iceoryx2::service::port_factory::event::PortFactory<Svc>,
    traj: iceoryx2::service::port_factory::publish_subscribe::PortFactory<Svc, Trajectory, ()>,
    traj_ev: iceoryx2::service::port_factory::event::PortFactory<Svc>,
}

fn name(prefix: &str, topic: &str) -> Result<ServiceName, IpcError> {
    let full = format!("{prefix}/{topic}");
    ServiceName::new(&full).map_err(ipc_err("service name"))
}

/// Checks that `prefix` makes valid iceoryx2 service names for both topics, naming the
/// option and the reason when it does not (say, a prefix past the name length limit).
pub fn check_prefix(prefix: &str) -> Result<(), String> {
    for topic in ["vehicle_state", "trajectory"] {
        let full = format!("{prefix}/{topic}");
        if let Err(e) = ServiceName::new(&full) {
            return Err(format!(
                "--service-prefix {prefix:?} ({} bytes): \"{prefix}/{topic}\" is not a valid \
                 iceoryx2 service name ({e:?})",
                prefix.len()
            ));
        }
    }
    Ok(())
}

impl Services {
    /// Creates the node and opens (or creates) both services under `prefix`.
    pub fn open(prefix: &str, node_name: &str) -> Result<Self, IpcError> {
        set_log_level(LogLevel::Error);
        let nn = NodeName::new(node_name).map_err(ipc_err("node name"))?;
        let node = NodeBuilder::new()
            .name(&nn)
            .create::<Svc>()
            .map_err(ipc_err("create node"))?;
        let state_name = name(prefix, "vehicle_state")?;
        let traj_name = name(prefix, "trajectory")?;
        let state = node
            .service_builder(&state_name)
            .publish_subscribe::<VehicleState>()
            .history_size(1)
            .subscriber_max_buffer_size(8)
            .subscriber_max_borrowed_samples(2)
            .max_publishers(4)
            .max_subscribers(4)
            .max_nodes(8)
            .open_or_create()
            .map_err(ipc_err("open vehicle_state service"))?;
        let traj = node
            .service_builder(&traj_name)
            .publish_subscribe::<Trajectory>()
            .history_size(1)
            .subscriber_max_buffer_size(2)
            .subscriber_max_borrowed_samples(2)
            .max_publishers(2)
            .max_subscribers(4)
            .max_nodes(8)
            .open_or_create()
            .map_err(ipc_err("open trajectory service"))?;
        let state_ev = node
            .service_builder(&state_name)
            .event()
            .max_nodes(8)
            .max_notifiers(4)
            .max_listeners(4)
            .open_or_create()
            .map_err(ipc_err("open vehicle_state event"))?;
        let traj_ev = node
            .service_builder(&traj_name)
            .event()
            .max_nodes(8)
            .max_notifiers(4)
            .max_listeners(4)
            .open_or_create()
            .map_err(ipc_err("open trajectory event"))?;
        Ok(Self {
            node,
            state,
            state_ev,
            traj,
            traj_ev,
        })
    }

    /// Publisher of vehicle states.
    pub fn state_publisher(&self) -> Result<Publisher<Svc, VehicleState, ()>, IpcError> {
        self.state
            .publisher_builder()
            .max_loaned_samples(1)
            .create()
            .map_err(ipc_err("create state publisher"))
    }

    /// Subscriber of vehicle states.
    pub fn state_subscriber(&self) -> Result<Subscriber<Svc, VehicleState, ()>, IpcError> {
        self.state
            .subscriber_builder()
            .buffer_size(8)
            .create()
            .map_err(ipc_err("create state subscriber"))
    }

    /// Publisher of trajectories.
    pub fn traj_publisher(&self) -> Result<Publisher<Svc, Trajectory, ()>, IpcError> {
        self.traj
            .publisher_builder()
            .max_loaned_samples(1)
            .create()
            .map_err(ipc_err("create trajectory publisher"))
    }

    /// Subscriber of trajectories.
    pub fn traj_subscriber(&self) -> Result<Subscriber<Svc, Trajectory, ()>, IpcError> {
        self.traj
            .subscriber_builder()
            .buffer_size(2)
            .create()
            .map_err(ipc_err("create trajectory subscriber"))
    }

    /// Notifier that wakes state listeners.
    pub fn state_notifier(&self) -> Result<Notifier<Svc>, IpcError> {
        self.state_ev
            .notifier_builder()
            .create()
            .map_err(ipc_err("create state notifier"))
    }

    /// Listener woken by new states.
    pub fn state_listener(&self) -> Result<Listener<Svc>, IpcError> {
        self.state_ev
            .listener_builder()
            .create()
            .map_err(ipc_err("create state listener"))
    }

    /// Notifier that wakes trajectory listeners.
    pub fn traj_notifier(&self) -> Result<Notifier<Svc>, IpcError> {
        self.traj_ev
            .notifier_builder()
            .create()
            .map_err(ipc_err("create trajectory notifier"))
    }

    /// Listener woken by new trajectories.
    pub fn traj_listener(&self) -> Result<Listener<Svc>, IpcError> {
        self.traj_ev
            .listener_builder()
            .create()
            .map_err(ipc_err("create trajectory listener"))
    }

    /// Number of vehicle-state subscribers currently connected (all processes).
    pub fn state_subscriber_count(&self) -> usize {
        self.state.dynamic_config().number_of_subscribers()
    }

    /// True when SIGINT/SIGTERM was received (iceoryx2's signal handler).
    pub fn termination_requested(&self) -> bool {
        self.node.wait(core::time::Duration::ZERO).is_err()
    }
}

/// Waits until `listener` has an event or `timeout` has passed, then takes every pending
/// event. Allocates nothing: iceoryx2 0.9.3's own `timed_wait_one`/`timed_wait_all` on the
/// unix-datagram event listener format an error message on every call (one 160-byte
/// allocation per wait, `ipc/tests/hot_path_alloc.rs`), so this polls the listener's file
/// descriptor and then drains it without blocking. A signal interrupting the wait returns
/// `Ok` (the caller checks for termination).
pub fn wait_events(
    listener: &Listener<Svc>,
    timeout: core::time::Duration,
) -> Result<(), IpcError> {
    // SAFETY: the descriptor stays owned by `listener`, which outlives this call; poll only
    // reads it.
    let fd = unsafe { listener.file_descriptor().native_handle() };
    let mut pfd = libc::pollfd {
        fd,
        events: libc::POLLIN,
        revents: 0,
    };
    let ts = libc::timespec {
        tv_sec: timeout.as_secs().min(i32::MAX as u64) as libc::time_t,
        tv_nsec: timeout.subsec_nanos() as libc::c_long,
    };
    // SAFETY: one valid pollfd and a valid timespec for the duration of the call; no
    // signal mask is changed (null).
    let r = unsafe { libc::ppoll(&mut pfd, 1, &ts, core::ptr::null()) };
    if r < 0 {
        let err = std::io::Error::last_os_error();
        if err.kind() != std::io::ErrorKind::Interrupted {
            return Err(IpcError {
                step: "wait for events",
                msg: err.to_string(),
            });
        }
        return Ok(());
    }
    listener
        .try_wait_all(|_| {})
        .map_err(ipc_err("take pending events"))
}

/// Publishes a vehicle state (stamped now) and wakes listeners. Allocates nothing.
pub fn publish_state(
    publisher: &Publisher<Svc, VehicleState, ()>,
    notifier: &Notifier<Svc>,
    mut msg: VehicleState,
) -> Result<(), IpcError> {
    msg.stamp_ns = crate::clock::monotonic_ns();
    publisher
        .send_copy(msg)
        .map_err(ipc_err("send vehicle state"))?;
    notifier.notify().map_err(ipc_err("notify vehicle state"))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::check_prefix;

    #[test]
    fn a_service_prefix_past_the_name_limit_is_refused_naming_the_option() {
        assert!(check_prefix("trajopt_test").is_ok());
        let long = "x".repeat(300);
        let e = check_prefix(&long).unwrap_err();
        assert!(e.starts_with("--service-prefix"), "{e}");
        assert!(e.contains("300 bytes"), "{e}");
    }
}
