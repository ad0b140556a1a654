//! CPU feature detection for the kernels compiled twice (baseline x86-64 and AVX2): the
//! Riccati factorization and the model derivatives. Both copies give the same bits (Rust
//! never contracts a * b + c into an FMA; wider vectors only compute independent entries),
//! so the choice changes speed only, never results or recordings.

/// The CPU runs AVX2 code (checked once at setup; never on the hot path).
pub fn avx2_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}
