//! The calibration crate's integration tests, a module per target and data set. One test binary rather than one per file: the tests share one build and link,
//! and run side by side on every core.

mod common;

mod charuco;
mod circles;
mod opencv_data;
mod simulated;
