//! hybrid's test suite, in one binary so the release build links once.
//! Tests that need `../shared/scenes` (or `HYBRID_SCENES`) fail loudly under
//! CI when it is missing and skip with a printed reason elsewhere.

mod common;

mod batches;
mod bvh;
mod camera;
mod cli;
mod embree_backend;
mod hostile;
mod hostile_inputs;
mod hostile_round4;

mod environment;
mod integrators;
mod loader;
mod mitsuba;
mod parity;
mod report;
mod series;
mod spheres;
mod split;
mod terminator;
