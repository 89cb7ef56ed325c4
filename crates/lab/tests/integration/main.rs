//! The lab crate's integration tests, a module per workflow (one test binary: one build and
//! link).

mod bench;
mod carve;
mod common;
mod demo;
mod refine;
mod soak;
