//! Work claims of the pipelined Riccati factorization. The helper thread and the sweep take
//! the assembly units in chunks, in sweep order, from one counter. The sweep assembles a
//! chunk itself when the helper has not claimed it yet, so a helper that starts late costs
//! the sweep the assembly time of the chunks it missed, not a wait for them (and a job the
//! helper never took is withdrawn at the end, [`crate::worker::Worker::join_or_skip`]). A
//! chunk the helper has claimed is waited for: a helper descheduled in the middle of one
//! still holds the sweep up. Which thread writes a unit does not change its bits.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use crate::worker::wait_until;

/// Units per chunk: one counter update and one flag per chunk. Publishing each unit on its
/// own would keep the progress cache line bouncing between the two cores while the sweep
/// polls it.
pub(super) const CHUNK: usize = 8;

/// How the sweep gets a chunk ([`Claims::acquire`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Acquired {
    /// The helper has written it.
    Ready,
    /// The helper had not claimed it: the caller owns it and writes it.
    Mine,
    /// The helper failed (its job panicked) before publishing it.
    Failed,
}

/// Chunk claims and completion flags, allocated once at setup.
#[derive(Debug)]
pub(super) struct Claims {
    /// Next chunk not claimed by either thread.
    next: AtomicUsize,
    /// Per chunk: written by the helper (never set for chunks the sweep took).
    done: Vec<AtomicBool>,
}

impl Claims {
    /// Claims for `units` units.
    pub(super) fn new(units: usize) -> Self {
        Self {
            next: AtomicUsize::new(0),
            done: (0..units.div_ceil(CHUNK))
                .map(|_| AtomicBool::new(false))
                .collect(),
        }
    }

    /// Number of chunks.
    pub(super) fn chunks(&self) -> usize {
        self.done.len()
    }

    /// Clears every claim before a factorization (the helper is not running).
    pub(super) fn reset(&mut self) {
        *self.next.get_mut() = 0;
        for d in &mut self.done {
            *d.get_mut() = false;
        }
    }

    /// Helper: claims the next chunk, or `None` when every chunk is taken.
    pub(super) fn claim(&self) -> Option<usize> {
        let c = self.next.fetch_add(1, Ordering::AcqRel);
        (c < self.chunks()).then_some(c)
    }

    /// Helper: chunk `c`, claimed by [`Self::claim`], is written.
    pub(super) fn publish(&self, c: usize) {
        self.done[c].store(true, Ordering::Release);
    }

    /// Sweep: chunk `c` is needed next (chunks are acquired in order, so every earlier
    /// chunk is written). Takes it if the helper has not claimed it, else waits for the
    /// helper to publish it or for `failed()`.
    pub(super) fn acquire(&self, c: usize, failed: impl Fn() -> bool) -> Acquired {
        // Plain loads first: while the helper is ahead, no write to the counter's line.
        if self.done[c].load(Ordering::Acquire) {
            return Acquired::Ready;
        }
        if self.next.load(Ordering::Acquire) == c
            && self
                .next
                .compare_exchange(c, c + 1, Ordering::AcqRel, Ordering::Acquire)
                .is_ok()
        {
            return Acquired::Mine;
        }
        wait_until(|| self.done[c].load(Ordering::Acquire) || failed());
        if self.done[c].load(Ordering::Acquire) {
            Acquired::Ready
        } else {
            Acquired::Failed
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sweep_takes_what_the_helper_has_not_claimed() {
        let mut c = Claims::new(3 * CHUNK + 1);
        assert_eq!(c.chunks(), 4);
        // Helper claims and publishes chunk 0; the sweep finds it ready.
        assert_eq!(c.claim(), Some(0));
        c.publish(0);
        assert_eq!(c.acquire(0, || false), Acquired::Ready);
        // Nobody claimed chunk 1: the sweep takes it, and the helper moves on to 2.
        assert_eq!(c.acquire(1, || false), Acquired::Mine);
        assert_eq!(c.claim(), Some(2));
        // Chunk 2 is the helper's: the sweep waits, here until the helper fails.
        assert_eq!(c.acquire(2, || true), Acquired::Failed);
        c.publish(2);
        assert_eq!(c.acquire(2, || false), Acquired::Ready);
        assert_eq!(c.acquire(3, || false), Acquired::Mine);
        assert_eq!(c.claim(), None);
        c.reset();
        assert_eq!(c.claim(), Some(0));
    }

    #[test]
    fn every_chunk_is_written_once_with_a_late_helper() {
        let units = 101;
        let mut c = Claims::new(units);
        for delay_us in [0u64, 200, 50_000] {
            c.reset();
            let owner: Vec<AtomicUsize> = (0..c.chunks()).map(|_| AtomicUsize::new(0)).collect();
            std::thread::scope(|s| {
                s.spawn(|| {
                    std::thread::sleep(std::time::Duration::from_micros(delay_us));
                    while let Some(k) = c.claim() {
                        owner[k].fetch_add(1, Ordering::Relaxed);
                        c.publish(k);
                    }
                });
                for k in 0..c.chunks() {
                    if c.acquire(k, || false) == Acquired::Mine {
                        owner[k].fetch_add(10, Ordering::Relaxed);
                    }
                    std::thread::sleep(std::time::Duration::from_micros(50));
                }
            });
            // Each chunk by exactly one thread (1: helper, 10: sweep).
            let who: Vec<usize> = owner.iter().map(|o| o.load(Ordering::Relaxed)).collect();
            assert!(who.iter().all(|&w| w == 1 || w == 10), "{who:?}");
            if delay_us == 50_000 {
                // The sweep does not wait for a helper that starts 50 ms late.
                assert_eq!(who[0], 10, "{who:?}");
            }
        }
    }
}
