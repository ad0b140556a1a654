//! Clocks in nanoseconds: CLOCK_MONOTONIC, system-wide so stamps compare across
//! processes, and the calling thread's CPU time.

/// Current CLOCK_MONOTONIC time \[ns\] (0 if the clock is unavailable, which Linux never is).
pub fn monotonic_ns() -> u64 {
    clock_ns(libc::CLOCK_MONOTONIC)
}

/// CPU time the calling thread has run \[ns\] (CLOCK_THREAD_CPUTIME_ID; 0 if unavailable).
/// Against the wall clock it tells whether a slow stretch ran or waited for a CPU.
pub fn thread_cpu_ns() -> u64 {
    clock_ns(libc::CLOCK_THREAD_CPUTIME_ID)
}

/// The time of `clock` \[ns\] (0 if it is unavailable).
fn clock_ns(clock: libc::clockid_t) -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; clock_gettime only writes into it.
    let rc = unsafe { libc::clock_gettime(clock, &mut ts) };
    if rc != 0 {
        return 0;
    }
    (ts.tv_sec as u64)
        .saturating_mul(1_000_000_000)
        .saturating_add(ts.tv_nsec as u64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_thread_s_cpu_time_grows_while_it_computes_and_not_while_it_sleeps() {
        let t0 = thread_cpu_ns();
        let mut x = 1.0f64;
        let wall = std::time::Instant::now();
        while wall.elapsed() < std::time::Duration::from_millis(20) {
            x = std::hint::black_box((x * 1.000_001).sqrt() + 1.0);
        }
        let busy = thread_cpu_ns() - t0;
        let t1 = thread_cpu_ns();
        std::thread::sleep(std::time::Duration::from_millis(20));
        let idle = thread_cpu_ns() - t1;
        assert!(busy > 5_000_000, "busy {busy} ns (x = {x})");
        assert!(idle < busy / 2, "idle {idle} ns against busy {busy} ns");
    }
}
