//! `hybrid`: a physically based path tracer for COLLADA scenes whose
//! acceleration layer has two real backends, an in-house SAH BVH and Embree.
//!
//! - [`geom`]: boxes, rays, hits, rounding bounds, random numbers, warps.
//! - [`simd`]: the CPU's instruction sets as tokens, and lanes of sixteen.
//! - [`scene`]: the scene model and the COLLADA loader.
//! - [`accel`]: the accelerator trait and its backends (native BVH, Embree,
//!   brute force).
//! - [`render`]: camera, sampling, materials, lights, integrators and film.
//! - [`parity`]: the cross-backend agreement and numerical-stability suite.
//! - [`report`]: the performance comparison report.
//! - [`bench`]: exported ray sets and their replay on every backend.
//! - [`cli`]: the command-line front end.
//! - [`choice`]: one spelling for every named option value.
//! - [`text`]: text set into images (captions, legends).
//! - [`input`]: how user files are read (regular files, caps, quoting).

// `!(x > 0.0)` is how this crate refuses NaN together with the values out
// of range; the `partial_cmp` form the lint asks for hides that.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// Every unsafe operation sits in an `unsafe` block with its own SAFETY
// note, also inside `unsafe fn`s.
#![deny(unsafe_op_in_unsafe_fn)]
// ... and clippy (in CI, `-D warnings`) holds every unsafe block and
// `unsafe impl` to one.
#![warn(clippy::undocumented_unsafe_blocks)]

pub mod accel;
pub mod bench;
pub mod choice;
pub mod cli;
pub mod geom;
pub mod input;
pub mod measure;
pub mod parity;
pub mod render;
pub mod report;
pub mod scene;
pub mod simd;
pub mod text;
