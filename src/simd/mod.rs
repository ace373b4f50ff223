//! What the CPU may run, and the lanes that run it: the layer both the
//! accelerators and the renderer build their SIMD code on.
//!
//! - [`cpu`]: instruction-set levels and the tokens ([`cpu::Avx2`],
//!   [`cpu::Avx512`]) that prove the CPU runs them, made only by runtime
//!   detection;
//! - [`lanes`]: sixteen floats side by side ([`lanes::F16`]) and the pass
//!   macro that compiles one body for AVX-512, for AVX2 and as its scalar
//!   twin, the three giving the same bits.
//!
//! It imports only [`crate::geom`] (the polynomials the lanes' sine and
//! cosine share with the scalar ones).

pub mod cpu;
pub mod lanes;
