//! The track crate's integration tests, a module per concern. One test binary rather than one per file: the tests share one build and link,
//! and run side by side on every core.

mod common;

mod backdrops;
mod examples;
mod fuzz;
mod occluders;
mod open;
mod pipeline;
mod runner;
mod settings;
mod shadows;
mod steps;
mod tracking;
