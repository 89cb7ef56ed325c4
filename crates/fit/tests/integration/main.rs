//! The image fit's integration tests, a module per kind of scene. One test binary rather than one per file: the tests share one build and link,
//! and run side by side on every core.

mod common;

mod accuracy;
mod floating_base;
mod following;
mod hard_scenes;
mod lamp_shadows;
mod motion_blur;
mod selfcheck;
mod thin_tubes;
mod two_cameras;
