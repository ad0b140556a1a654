//! Cooperative shutdown: SIGINT/SIGTERM (via iceoryx2's handler) or end of stdin.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// A flag set when the parent closes our stdin (the orchestrator's stop request; also fires
/// when the parent dies, so no orphan keeps running).
#[derive(Debug, Clone, Default)]
pub struct StdinWatch {
    closed: Arc<AtomicBool>,
}

impl StdinWatch {
    /// Starts a thread that reads stdin until EOF and then sets the flag.
    pub fn start() -> Self {
        let w = Self::default();
        let flag = w.closed.clone();
        let spawned = std::thread::Builder::new()
            .name("stdin-watch".into())
            .spawn(move || {
                let mut buf = [0u8; 64];
                loop {
                    match std::io::Read::read(&mut std::io::stdin(), &mut buf) {
                        Ok(0) | Err(_) => break,
                        Ok(_) => {}
                    }
                }
                flag.store(true, Ordering::SeqCst);
            });
        if let Err(e) = spawned {
            crate::elog!("warning: cannot watch stdin: {e}");
        }
        w
    }

    /// A watch that never fires.
    pub fn disabled() -> Self {
        Self::default()
    }

    /// True once stdin reached EOF.
    pub fn closed(&self) -> bool {
        self.closed.load(Ordering::SeqCst)
    }
}
