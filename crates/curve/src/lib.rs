//! Centerline curves shared by the simulator, shape estimation and the manipulator model.
//!
//! - [`BSpline3`]: a clamped uniform cubic B-spline, the smooth centerline the tube fit moves.
//! - [`Polyline`]: a densely sampled 3-D curve with cumulative arc length (mm).
//! - [`Section`] and [`SectionChain`]: piecewise constant-curvature curves in the paper's
//!   convention (local axis along +y; curvatures κx, κz about the local x and z axes, 1/mm;
//!   axial strain ε, compression positive), with closed-form frames.

mod bspline;
mod polyline;
mod section;

pub use bspline::{BSpline3, Basis, Derivatives};
pub use polyline::{CurveError, Polyline};
pub use section::{Frame, Section, SectionChain};
