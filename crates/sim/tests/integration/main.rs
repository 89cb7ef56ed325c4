//! The simulator's integration tests. One test binary rather than one per file: the tests share one build and link,
//! and run side by side on every core.

mod recording;
mod simulator;
