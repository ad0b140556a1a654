//! A persistent helper thread that runs one borrowed job beside the caller (a fork-join of
//! two), allocation-free once started: the hot path never spawns a thread or boxes a job.
//! With `threads = 2` (`config/solver.toml`) one worker is shared ([`SharedWorker`]) by the
//! pipelined Riccati factorization and the stage-parallel Hessian evaluation.
//!
//! Between jobs the helper spins for [`SPIN`] and then parks, so a solve (a job every few
//! hundred microseconds) keeps it awake and an idle planner leaves the core alone.

use std::cell::UnsafeCell;
use std::hint::spin_loop;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::thread::{self, JoinHandle, Thread};
use std::time::{Duration, Instant};

/// How long the idle helper polls for the next job before it parks. Waking a parked thread
/// costs tens of microseconds on a VM, but a helper that spins through the caller's
/// single-threaded phases slows them down (shared clock or core resources): a shorter spin
/// makes each join pay a wake-up, a longer one slows the back-solves and the line search.
pub const SPIN: Duration = Duration::from_micros(100);

const IDLE: u32 = 0;
const READY: u32 = 1;
const DONE: u32 = 2;
const EXIT: u32 = 3;
/// The helper took the job from the slot (READY -> RUNNING): the caller waits for DONE.
const RUNNING: u32 = 4;

/// A job whose lifetime was erased by [`Worker::join`], which does not return before the
/// helper has finished with it (or, in [`Worker::join_or_skip`], has withdrawn it untaken).
type JobPtr = *mut (dyn FnMut() + Send);

struct Shared {
    state: AtomicU32,
    job: UnsafeCell<Option<JobPtr>>,
    panicked: AtomicBool,
}

// SAFETY: `job` is written by the caller only while the state is IDLE and read by the helper
// only after it observed READY (release/acquire on `state`); the job itself is `Send` and
// runs on the helper alone.
unsafe impl Sync for Shared {}
// SAFETY: as above; the pointer is only dereferenced under that protocol.
unsafe impl Send for Shared {}

/// One worker shared by the parts of a solver that fork work to it (they run one after
/// the other, never at once, so the lock is always free).
pub type SharedWorker = Arc<Mutex<Worker>>;

/// Starts a worker to be shared (allocates; call at setup).
pub fn shared() -> std::io::Result<SharedWorker> {
    Ok(Arc::new(Mutex::new(Worker::start()?)))
}

/// Locks a shared worker (a job that panicked poisons nothing that matters: the slot and
/// state are reset by then).
pub fn lock(w: &SharedWorker) -> MutexGuard<'_, Worker> {
    w.lock().unwrap_or_else(PoisonError::into_inner)
}

/// The helper thread and its job slot.
pub struct Worker {
    shared: Arc<Shared>,
    thread: Thread,
    handle: Option<JoinHandle<()>>,
}

impl std::fmt::Debug for Worker {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Worker")
            .field("thread", &self.thread.name())
            .finish()
    }
}

impl Worker {
    /// Starts the helper thread (allocates; call at setup).
    pub fn start() -> std::io::Result<Self> {
        let shared = Arc::new(Shared {
            state: AtomicU32::new(IDLE),
            job: UnsafeCell::new(None),
            panicked: AtomicBool::new(false),
        });
        let theirs = Arc::clone(&shared);
        let handle = thread::Builder::new()
            .name("planner-helper".into())
            .spawn(move || helper_loop(&theirs))?;
        let thread = handle.thread().clone();
        Ok(Self {
            shared,
            thread,
            handle: Some(handle),
        })
    }

    /// Runs `job` on the helper thread and `main` on this one, and returns `main`'s result
    /// once both are done (also when `main` panics: the helper is waited for first). A panic
    /// in `job` is raised here after both finished.
    pub fn join<R>(&mut self, job: &mut (dyn FnMut() + Send), main: impl FnOnce() -> R) -> R {
        self.run(job, main, false)
    }

    /// As [`Self::join`], for a job that `main` can do without: if the helper has not
    /// taken the job when `main` returns, the job is withdrawn and never runs, and this
    /// returns without waiting for the helper to wake up (a parked or descheduled helper
    /// then costs nothing). A job the helper has taken is waited for as in `join`.
    pub fn join_or_skip<R>(
        &mut self,
        job: &mut (dyn FnMut() + Send),
        main: impl FnOnce() -> R,
    ) -> R {
        self.run(job, main, true)
    }

    fn run<R>(
        &mut self,
        job: &mut (dyn FnMut() + Send),
        main: impl FnOnce() -> R,
        skippable: bool,
    ) -> R {
        // SAFETY: only the lifetime is erased; `Wait` below does not let this function
        // return or unwind before the helper reports DONE, after which it never touches
        // the job again, or before a skippable job is withdrawn untaken (READY -> IDLE,
        // after which the helper cannot take it).
        let ptr: JobPtr = unsafe {
            std::mem::transmute::<&mut (dyn FnMut() + Send), &'static mut (dyn FnMut() + Send)>(job)
        };
        // SAFETY: the state is IDLE (every join waits for DONE and resets it), so the
        // helper does not read the slot now.
        unsafe { *self.shared.job.get() = Some(ptr) };
        self.shared.state.store(READY, Ordering::Release);
        self.thread.unpark();
        let out = {
            let _wait = Wait {
                shared: &self.shared,
                skippable,
            };
            main()
        };
        if self.shared.panicked.swap(false, Ordering::Relaxed) {
            panic!("the helper thread's job panicked");
        }
        out
    }
}

/// Waits for the helper's DONE on drop, then marks the slot IDLE; with `skippable`, first
/// withdraws a job the helper has not taken (READY -> IDLE).
struct Wait<'a> {
    shared: &'a Shared,
    skippable: bool,
}

impl Drop for Wait<'_> {
    fn drop(&mut self) {
        let s = self.shared;
        if self.skippable
            && s.state
                .compare_exchange(READY, IDLE, Ordering::AcqRel, Ordering::Acquire)
                .is_ok()
        {
            // SAFETY: the helper reads the slot only after it wins READY -> RUNNING, which
            // it no longer can; the next join writes the slot before publishing READY.
            unsafe { *s.job.get() = None };
            return;
        }
        wait_until(|| s.state.load(Ordering::Acquire) == DONE);
        if thread::panicking() {
            // The caller's panic wins; a job panic of this join must not leak into the next.
            s.panicked.store(false, Ordering::Relaxed);
        }
        s.state.store(IDLE, Ordering::Relaxed);
    }
}

/// Spins until `ready()` holds, yielding now and then in case the thread that makes it
/// hold was descheduled (the two threads share the machine with others).
#[inline]
pub fn wait_until(mut ready: impl FnMut() -> bool) {
    let mut spins = 0u32;
    while !ready() {
        spins = spins.wrapping_add(1);
        if spins.is_multiple_of(1024) {
            thread::yield_now();
        } else {
            spin_loop();
        }
    }
}

impl Drop for Worker {
    fn drop(&mut self) {
        self.shared.state.store(EXIT, Ordering::Release);
        self.thread.unpark();
        if let Some(h) = self.handle.take() {
            // The helper only exits through EXIT; a join error would be a panic outside a
            // job, which cannot happen.
            let _ = h.join();
        }
    }
}

fn helper_loop(s: &Shared) {
    loop {
        let idle_since = Instant::now();
        let mut polls = 0u32;
        loop {
            match s.state.load(Ordering::Acquire) {
                // Taken only if the caller has not withdrawn it meanwhile (`join_or_skip`).
                READY
                    if s.state
                        .compare_exchange(READY, RUNNING, Ordering::AcqRel, Ordering::Acquire)
                        .is_ok() =>
                {
                    break
                }
                EXIT => return,
                _ => {}
            }
            polls = polls.wrapping_add(1);
            if polls.is_multiple_of(256) && idle_since.elapsed() > SPIN {
                // An unpark between the check above and this call makes it return at once.
                thread::park();
            } else {
                spin_loop();
            }
        }
        // SAFETY: READY was taken (READY -> RUNNING, acquire) after the caller wrote the slot.
        let job = unsafe { (*s.job.get()).take() };
        if let Some(job) = job {
            // SAFETY: the caller is blocked in `join` until DONE, so the job is alive, and
            // nothing else uses it meanwhile.
            let ran = catch_unwind(AssertUnwindSafe(|| unsafe { (*job)() }));
            if ran.is_err() {
                s.panicked.store(true, Ordering::Relaxed);
            }
        }
        s.state.store(DONE, Ordering::Release);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::AtomicUsize;

    #[test]
    fn runs_the_job_beside_the_caller_many_times() {
        let mut w = Worker::start().expect("spawn");
        let hits = AtomicUsize::new(0);
        for i in 0..1000 {
            let seen = w.join(
                &mut || {
                    hits.fetch_add(1, Ordering::Relaxed);
                },
                || i,
            );
            assert_eq!(seen, i);
        }
        assert_eq!(hits.load(Ordering::Relaxed), 1000);
    }

    #[test]
    fn the_caller_can_wait_on_the_helpers_progress() {
        let mut w = Worker::start().expect("spawn");
        let done = AtomicUsize::new(0);
        let sum = w.join(
            &mut || {
                for i in 1..=100 {
                    done.store(i, Ordering::Release);
                }
            },
            || {
                let mut sum = 0;
                for need in 1..=100 {
                    while done.load(Ordering::Acquire) < need {
                        spin_loop();
                    }
                    sum += need;
                }
                sum
            },
        );
        assert_eq!(sum, 5050);
    }

    #[test]
    fn a_panicking_job_is_reported_to_the_caller_and_the_worker_survives() {
        let mut w = Worker::start().expect("spawn");
        let r = catch_unwind(AssertUnwindSafe(|| w.join(&mut || panic!("job"), || 1)));
        assert!(r.is_err());
        assert_eq!(w.join(&mut || {}, || 2), 2);
    }

    #[test]
    fn a_skippable_job_runs_at_most_once_and_never_after_the_join() {
        let mut w = Worker::start().expect("spawn");
        let runs = AtomicUsize::new(0);
        let mut last = 0;
        for i in 0..2000 {
            // Let the helper park now and then: a parked helper wakes too late to take the
            // job, which is then withdrawn.
            if i % 200 == 0 {
                std::thread::sleep(SPIN * 4);
            }
            // A withdrawn job must not run after its join returned.
            assert_eq!(runs.load(Ordering::Relaxed), last);
            w.join_or_skip(
                &mut || {
                    runs.fetch_add(1, Ordering::Relaxed);
                },
                || (),
            );
            let now = runs.load(Ordering::Relaxed);
            assert!(now - last <= 1);
            last = now;
        }
        std::thread::sleep(SPIN * 4);
        assert_eq!(runs.load(Ordering::Relaxed), last);
        assert!(last < 2000, "no job was withdrawn");
        // The worker still runs plain joins.
        let hit = AtomicBool::new(false);
        w.join(&mut || hit.store(true, Ordering::Relaxed), || ());
        assert!(hit.load(Ordering::Relaxed));
    }

    #[test]
    fn an_idle_helper_parks_and_wakes_up() {
        let mut w = Worker::start().expect("spawn");
        std::thread::sleep(SPIN * 4);
        let hit = AtomicBool::new(false);
        w.join(&mut || hit.store(true, Ordering::Relaxed), || ());
        assert!(hit.load(Ordering::Relaxed));
    }
}
