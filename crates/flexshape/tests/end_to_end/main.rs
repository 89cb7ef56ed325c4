//! The `flexshape` binary end to end, a module per command. One test binary rather than one
//! per file: the tests share one build and link, and run side by side on every core (several
//! of them mostly wait on a browser, ffmpeg or a camera played in real time).

mod common;

mod architecture;
mod calibrate;
mod capture;
mod carve;
mod cli;
mod live;
mod model_fit;
mod rig_refine;
mod schema;
mod track;
mod validate;
mod viewer;
