//! Centerline curves shared by the simulator, shape estimation and the manipulator model.
//!
//! - [`BSpline3`]: a clamped uniform cubic B-spline, the smooth centerline the tube fit moves.
//! - [`Polyline`]: a densely sampled 3-D curve with cumulative arc length (mm).
//! - [`Section`] and [`SectionChain`]: piecewise constant-curvature curves in the paper's
//!   convention (local axis along +y; curvatures κx, κz about the local x and z axes, 1/mm;
//!   axial strain ε, compression positive), with closed-form frames.
//! - [`RadiusStep`]: where a tube steps down in diameter toward its tip.

mod bspline;
mod polyline;
mod radius;
mod section;

pub use bspline::{BSpline3, Basis, Derivatives};
pub use polyline::{CurveError, Polyline};
pub use radius::{ProfileError, RadiusStep, check_steps, radius_at, section_at};
pub use section::{Frame, Section, SectionChain};
