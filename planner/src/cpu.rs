//! CPU feature detection for the kernels compiled twice (baseline x86-64 and AVX2): the
//! Riccati factorization and the model derivatives. Both copies give the same bits (Rust
//! never contracts a * b + c into an FMA; wider vectors only compute independent entries),
//! so the choice changes speed only, never results or recordings.

/// The CPU runs AVX2 code (checked once at setup; never on the hot path). The environment
/// variable `PLANNER_SIMD=off` selects the baseline copies instead: same results, and tools
/// that cannot decode every AVX2 instruction (valgrind 3.19) can then run a whole solve.
pub fn avx2_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::env::var_os("PLANNER_SIMD").is_none_or(|v| v != "off")
            && std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// The CPU's model name and logical core count, e.g. "AMD EPYC 7B13, 2 logical cores"
/// (from `/proc/cpuinfo` on Linux; "unknown CPU" where it cannot be read). For reports.
pub fn model_name() -> String {
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    let model = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".to_string());
    format!("{model}, {cores} logical cores")
}
