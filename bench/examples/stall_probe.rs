//! How long a fixed piece of work takes on this machine when it runs like a planning
//! cycle: a chunk of pure arithmetic calibrated to C ms, started every 100 ms, K times.
//! The work is the same every time, so anything past C ms is the machine's (the
//! operating system, other processes, a virtual machine's host): the floor under any
//! cycle-time figure measured here. Usage: stall_probe [C ms, default 10] [K, default 300]

use std::hint::black_box;
use std::io::Write;
use std::time::{Duration, Instant};

/// One unit of work: a thousand dependent floating-point additions.
fn unit(acc: f64) -> f64 {
    let mut x = acc;
    for i in 0..1000 {
        x = black_box(x + i as f64 * 1e-9);
    }
    x
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let refuse = |what: &str| -> ! {
        eprintln!("stall_probe: {what} (usage: stall_probe [C ms in (0, 100)] [K >= 1])");
        std::process::exit(2)
    };
    let chunk_ms: f64 = match args.get(1) {
        None => 10.0,
        Some(a) => a
            .parse()
            .unwrap_or_else(|_| refuse(&format!("the chunk {a:?} is not a number"))),
    };
    let count: usize = match args.get(2) {
        None => 300,
        Some(a) => a
            .parse()
            .unwrap_or_else(|_| refuse(&format!("the count {a:?} is not a whole number"))),
    };
    if !(chunk_ms > 0.0 && chunk_ms < 100.0) {
        refuse(&format!("the chunk {chunk_ms} ms is not in (0, 100) ms"));
    }
    if count == 0 {
        refuse("the count must be at least 1");
    }
    // Calibrate: units that take chunk_ms, the median of five tries.
    let mut acc = 0.0;
    let mut tries = [0u64; 5];
    for t in tries.iter_mut() {
        let start = Instant::now();
        let mut units = 0u64;
        while start.elapsed().as_secs_f64() * 1e3 < chunk_ms {
            acc = unit(acc);
            units += 1;
        }
        *t = units;
    }
    tries.sort_unstable();
    let units = tries[2];
    let mut times = Vec::with_capacity(count);
    let period = Duration::from_millis(100);
    let mut next = Instant::now() + period;
    for _ in 0..count {
        std::thread::sleep(next.saturating_duration_since(Instant::now()));
        next += period;
        let start = Instant::now();
        for _ in 0..units {
            acc = unit(acc);
        }
        times.push(start.elapsed().as_secs_f64() * 1e3);
    }
    black_box(acc);
    let mut sorted = times.clone();
    sorted.sort_by(f64::total_cmp);
    let q = |p: f64| sorted[((sorted.len() - 1) as f64 * p).round() as usize];
    let over = |d: f64| times.iter().filter(|&&t| t > chunk_ms + d).count();
    // A closed stdout ends the probe quietly instead of panicking.
    let _ = writeln!(
        std::io::stdout(),
        "chunk {chunk_ms} ms x {count}: p50 {:.2} p99 {:.2} max {:.2} ms; over +2 ms: {}, over +5 ms: {}",
        q(0.5),
        q(0.99),
        sorted[sorted.len() - 1],
        over(2.0),
        over(5.0)
    );
}
