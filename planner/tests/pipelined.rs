//! The pipelined Riccati factorization (`threads = 2`): the same bits as one thread, and a
//! solve after setup allocates nothing on either thread. The counting allocator here is
//! process-wide (the helper thread's allocations count too), so this binary holds one test:
//! no other test allocates while it measures.

use std::alloc::{GlobalAlloc, Layout, System};
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use planner::config::{load_scenario, load_solver, load_vehicle};
use planner::guess::GuessKind;
use planner::ip::Status;
use planner::plan::Planner;

struct Counting;

static COUNTING: AtomicBool = AtomicBool::new(false);
static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

// SAFETY: forwards to the system allocator; the counter is a side effect only.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if COUNTING.load(Ordering::Relaxed) {
            ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        }
        System.alloc(layout)
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if COUNTING.load(Ordering::Relaxed) {
            ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        }
        System.alloc_zeroed(layout)
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if COUNTING.load(Ordering::Relaxed) {
            ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        }
        System.realloc(ptr, layout, new_size)
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout)
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Allocations (any thread) while `f` runs.
fn allocations(f: impl FnOnce()) -> usize {
    let before = ALLOCATIONS.load(Ordering::SeqCst);
    COUNTING.store(true, Ordering::SeqCst);
    f();
    COUNTING.store(false, Ordering::SeqCst);
    ALLOCATIONS.load(Ordering::SeqCst) - before
}

fn planner(segment: Option<&str>, threads: usize) -> Planner<100> {
    let root = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config"));
    let vehicle = load_vehicle(&root.join("vehicles/lc500.toml")).unwrap();
    let scenario = match segment {
        Some(_) => "scenarios/segments.toml",
        None => "scenarios/oval.toml",
    };
    let spec = load_scenario(&root.join(scenario), segment, vehicle).unwrap();
    let mut settings = load_solver(&root.join("solver.toml")).unwrap();
    settings.threads = threads;
    Planner::<100>::new(spec, settings).unwrap()
}

fn bits(p: &Planner<100>) -> (Vec<u64>, Vec<u64>) {
    let s = p.solver();
    (
        s.x().iter().map(|v| v.to_bits()).collect(),
        s.y().iter().map(|v| v.to_bits()).collect(),
    )
}

#[test]
fn pipelined_solves_equal_one_thread_bit_for_bit_and_allocate_nothing() {
    // S07 takes the most inertia corrections of the ten segments (early-stopped sweeps
    // cancel the helper mid-factorization).
    for segment in [None, Some("S07")] {
        let mut one = planner(segment, 1);
        let mut two = planner(segment, 2);
        // The comparison has teeth only if the second planner really pipelines.
        assert!(one.solver().kkt().worker().is_none());
        assert!(
            two.solver().kkt().worker().is_some(),
            "threads = 2 not pipelined"
        );
        let a = one.solve(GuessKind::Equilibrium);
        let b = two.solve(GuessKind::Equilibrium);
        assert_eq!(a.status, Status::Optimal, "{segment:?}");
        assert_eq!(
            (a.status, a.iterations, a.factorizations),
            (b.status, b.iterations, b.factorizations),
            "{segment:?}"
        );
        assert!(
            a.factorizations > a.iterations,
            "no inertia correction exercised"
        );
        assert!(bits(&one) == bits(&two), "{segment:?}: iterates differ");
        // After the warm-up solve above, a solve allocates nothing on either thread.
        let mut status = None;
        let n = allocations(|| status = Some(two.solve(GuessKind::Equilibrium).status));
        assert_eq!(n, 0, "{segment:?}: {n} allocations in a pipelined solve");
        assert_eq!(status, Some(Status::Optimal));
    }
    // The counter sees allocations (the test can fail).
    assert!(allocations(|| drop(std::hint::black_box(vec![1u8; 16]))) > 0);
}
