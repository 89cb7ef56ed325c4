//! Empty: a build script lets `[build-dependencies]` ask for the host crates' features.
fn main() {}
