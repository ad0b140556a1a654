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
