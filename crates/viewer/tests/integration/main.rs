//! The viewer's integration tests, a module per concern. One test binary rather than one per file: the tests share one build and link,
//! and run side by side on every core.

mod common;

mod limits;
mod newest;
mod origin;
mod steering;
