//! Which SIMD code the CPU may run, as a value that proves it.
//!
//! [`Avx2`] can only be made by [`Avx2::detect`], which asks the CPU at run
//! time (`is_x86_feature_detected!`). Every function compiled with
//! `#[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]` takes
//! one, so safe code cannot reach those instructions on a CPU without
//! them: the token is the proof each `unsafe` call site relies on. Every
//! CPU with AVX2 has the bit-counting ones; the kernels use them for the
//! hit masks (`count_ones`, `leading_zeros`), which otherwise compile to
//! multiply and shift sequences. Without it the portable scalar code
//! runs; nothing is compiled for the build machine only.

/// Proof that this CPU runs AVX2, FMA, POPCNT, LZCNT and BMI1/2
/// instructions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Avx2 {
    _detected: (),
}

impl Avx2 {
    /// `Some` when the CPU has all of them.
    pub fn detect() -> Option<Avx2> {
        #[cfg(target_arch = "x86_64")]
        {
            if is_x86_feature_detected!("avx2")
                && is_x86_feature_detected!("fma")
                && is_x86_feature_detected!("popcnt")
                && is_x86_feature_detected!("lzcnt")
                && is_x86_feature_detected!("bmi1")
                && is_x86_feature_detected!("bmi2")
            {
                return Some(Avx2 { _detected: () });
            }
        }
        None
    }
}

/// Proof that this CPU runs AVX-512 (foundation) besides everything
/// [`Avx2`] proves: the sixteen-ray packet kernels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Avx512 {
    _detected: (),
}

impl Avx512 {
    /// `Some` when the CPU has AVX-512F and the [`Avx2`] set.
    pub fn detect() -> Option<Avx512> {
        #[cfg(target_arch = "x86_64")]
        {
            if Avx2::detect().is_some() && is_x86_feature_detected!("avx512f") {
                return Some(Avx512 { _detected: () });
            }
        }
        None
    }
}
