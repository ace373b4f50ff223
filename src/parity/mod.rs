//! The parity suite: the same rays through every backend, compared hit by
//! hit ([`rays`] makes the ray sets).

pub mod rays;
