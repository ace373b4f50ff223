//! Which SIMD code the CPU may run, as a value that proves it.
//!
//! [`Avx2`] can only be made by [`Avx2::detect`], which asks the CPU at run
//! time (`is_x86_feature_detected!`). Every function compiled with
//! `#[target_feature(enable = "avx2,fma")]` takes one, so safe code cannot
//! reach AVX2 instructions on a CPU without them: the token is the proof
//! each `unsafe` call site relies on. Without it the portable scalar code
//! runs; nothing is compiled for the build machine only.

/// Proof that this CPU runs AVX2 and FMA instructions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Avx2 {
    _detected: (),
}

impl Avx2 {
    /// `Some` when the CPU has AVX2 and FMA.
    pub fn detect() -> Option<Avx2> {
        #[cfg(target_arch = "x86_64")]
        {
            if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") {
                return Some(Avx2 { _detected: () });
            }
        }
        None
    }
}
