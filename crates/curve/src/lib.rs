//! Centerline curves shared by the simulator, shape estimation and the manipulator model.
//!
//! - [`BSpline3`]: a clamped uniform cubic B-spline, the smooth centerline the tube fit moves.
//! - [`Polyline`]: a densely sampled 3-D curve with cumulative arc length (mm).
//! - [`Section`] and [`SectionChain`]: piecewise constant-curvature curves in the paper's
//!   convention (local axis along +y; curvatures κx, κz about the local x and z axes, 1/mm;
//!   axial strain ε, compression positive), with closed-form frames.
//! - [`RadiusStep`]: where a tube steps down in diameter toward its tip.
//!
//! ```
//! use flexshape_curve::{Polyline, Section};
//!
//! // A 100 mm section bent to a quarter circle (κx = π/200 1/mm), uncompressed.
//! let quarter = Section { length: 100.0, kappa: [std::f64::consts::PI / 200.0, 0.0], strain: 0.0 };
//! let tip = quarter.local_frame(quarter.arc_length());
//! // Its tangent (local +y at the base) has turned by 90°.
//! assert!((tip.rotation * nalgebra::Vector3::y()).y.abs() < 1e-12);
//! // Sampled densely, the curve has the section's length.
//! let points = (0..=1000).map(|i| quarter.local_frame(i as f64 * 0.1).position).collect();
//! let curve = Polyline::new(points)?;
//! assert!((curve.length() - 100.0).abs() < 1e-3);
//! # Ok::<(), flexshape_curve::CurveError>(())
//! ```

mod bspline;
mod polyline;
mod radius;
mod section;

pub use bspline::{BSpline3, Basis, Derivatives};
pub use polyline::{CurveError, Polyline};
pub use radius::{ProfileError, RadiusStep, check_steps, radius_at, section_at};
pub use section::{Frame, Section, SectionChain};
