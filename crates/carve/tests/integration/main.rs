//! The carving crate's integration tests, a module per concern. One test binary rather than one per file: the tests share one build and link,
//! and run side by side on every core.

mod common;

mod bands;
mod exact;
mod hierarchical;
mod middlebury;
