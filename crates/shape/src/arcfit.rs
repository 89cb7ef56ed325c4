//! Constant-curvature fits of a section of the curve (paper, Section V-B): non-linear least
//! squares for `[κx, κz]` (and by default the section frame's offset and tilt), the cost being
//! the distance between curve and arc at equal arc lengths, the arc's length being the
//! curve's. Also a two-piece (piecewise constant curvature) fit.

use flexshape_curve::{Frame, Section};
use flexshape_lsq::{LevenbergMarquardt, Residuals, minimize};
use nalgebra::{DMatrix, DVector, Matrix3, Point3, Rotation3, Vector3};

use crate::centerline::Centerline;
use crate::order::dot;
use crate::record::{ArcFit, TwoSectionFit};
use crate::settings::ArcFitSettings;

/// Spacing of the data points compared with the arc, mm.
const DATA_STEP: f64 = 4.0;

/// Fits the curve from arc length `start` to the tip; `None` when the section is shorter than
/// 5 mm.
pub(crate) fn fit(curve: &Centerline, start: f64, settings: &ArcFitSettings) -> Option<ArcFit> {
    let length = curve.length() - start;
    if length < 5.0 {
        return None;
    }
    let n = (length / DATA_STEP).ceil() as usize;
    let data: Vec<(f64, [f64; 3])> = (0..=n)
        .map(|i| {
            let u = length * i as f64 / n as f64;
            (u, curve.point_at(start + u))
        })
        .collect();
    let s0 = curve.sample(start);
    let frame = section_frame(s0.point, s0.tangent, settings.reference_axis);
    let kappa0 = chord_curvature(&frame, data[data.len() - 1].1, length);
    let mut one = Problem::new(&data, frame, vec![length], settings.free_base, &kappa0);
    // The residuals report the fit's quality whatever the termination reason.
    one.params = minimize(&one, one.params.clone(), solver()).x;
    let base = one.base();
    let kappa = [one.params[0], one.params[1]];
    let (mean, max) = one.residual_stats();
    let split = length * settings.two_section_split;
    let mut init = kappa.to_vec();
    init.extend_from_slice(&kappa);
    let mut two = Problem::new(
        &data,
        frame,
        vec![split, length - split],
        settings.free_base,
        &init,
    );
    two.params = minimize(&two, two.params.clone(), solver()).x;
    let (mean2, max2) = two.residual_stats();
    let curvature = kappa[0].hypot(kappa[1]);
    let axes = base.rotation.matrix();
    Some(ArcFit {
        start_arc: start,
        length,
        kappa,
        curvature,
        plane_angle: (kappa[0]).atan2(-kappa[1]),
        origin: [base.position.x, base.position.y, base.position.z],
        axes: std::array::from_fn(|c| std::array::from_fn(|r| axes[(r, c)])),
        residual_mean: mean,
        residual_max: max,
        residual_percent: 100.0 * mean / length,
        two_section: Some(TwoSectionFit {
            split,
            kappa: [
                [two.params[0], two.params[1]],
                [two.params[2], two.params[3]],
            ],
            residual_mean: mean2,
            residual_max: max2,
        }),
    })
}

/// The solver: converged once a step changes the cost or the parameters by less than 1e-10
/// of themselves (the library's default asks for machine precision, which costs a third more
/// steps for changes far below a micrometre).
fn solver() -> LevenbergMarquardt<f64> {
    LevenbergMarquardt::new().with_ftol(1e-10).with_xtol(1e-10)
}

/// The section frame at a curve point: y along the tangent, x the reference direction made
/// perpendicular to it (world z if the reference is nearly along the tangent), z = x × y.
pub fn section_frame(origin: [f64; 3], tangent: [f64; 3], reference: [f64; 3]) -> Frame {
    let y = Vector3::from(tangent).normalize();
    let mut r = Vector3::from(reference).normalize();
    if r.cross(&y).norm() < 1e-3 {
        r = if y.z.abs() < 0.9 {
            Vector3::z()
        } else {
            Vector3::x()
        };
    }
    let x = (r - y * r.dot(&y)).normalize();
    let z = x.cross(&y);
    Frame {
        position: Point3::from(origin),
        rotation: Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x, y, z])),
    }
}

/// `[κx, κz]` of the arc of `length` from `frame` through `end` (world): the chord makes half
/// the bending angle with the tangent.
fn chord_curvature(frame: &Frame, end: [f64; 3], length: f64) -> [f64; 2] {
    let local = frame.rotation.inverse() * (Vector3::from(end) - frame.position.coords);
    let side = local.x.hypot(local.z);
    if side < 1e-9 {
        return [0.0, 0.0];
    }
    let kappa = 2.0 * side.atan2(local.y) / length;
    // The bend direction is (−κz, κx)/κ in the x–z plane.
    [kappa * local.z / side, -kappa * local.x / side]
}

/// Position at arc length `u` along a constant-curvature piece, in its base frame: the same
/// geometry as [`Section::local_frame`] (tested), without building the rotation.
fn local_position([kx, kz]: [f64; 2], u: f64) -> Vector3<f64> {
    let k = kx.hypot(kz);
    let angle = k * u;
    if angle.abs() < 1e-4 {
        let along = u * (1.0 - angle * angle / 6.0);
        let side = 0.5 * u * u * (1.0 - angle * angle / 12.0);
        return Vector3::new(-kz * side, along, kx * side);
    }
    // 1 − cos θ = 2 sin²(θ/2), without the cancellation at small angles.
    let sin = angle.sin();
    let side = 2.0 * (angle / 2.0).sin().powi(2) / k;
    Vector3::new(-kz / k * side, sin / k, kx / k * side)
}

/// Least squares over `[κ per piece…, tilt x, tilt z, offset x, y, z]`.
struct Problem<'a> {
    data: &'a [(f64, [f64; 3])],
    frame: Frame,
    lengths: Vec<f64>,
    free_base: bool,
    params: DVector<f64>,
}

impl<'a> Problem<'a> {
    fn new(
        data: &'a [(f64, [f64; 3])],
        frame: Frame,
        lengths: Vec<f64>,
        free_base: bool,
        kappa: &[f64],
    ) -> Self {
        let mut p = kappa.to_vec();
        if free_base {
            p.extend_from_slice(&[0.0; 5]);
        }
        Problem {
            data,
            frame,
            lengths,
            free_base,
            params: DVector::from_vec(p),
        }
    }

    fn base_of(&self, p: &DVector<f64>) -> Frame {
        if !self.free_base {
            return self.frame;
        }
        let k = 2 * self.lengths.len();
        let tilt = Rotation3::from_scaled_axis(Vector3::new(p[k], 0.0, p[k + 1]));
        let offset = Vector3::new(p[k + 2], p[k + 3], p[k + 4]);
        Frame {
            position: self.frame.position + self.frame.rotation * offset,
            rotation: self.frame.rotation * tilt,
        }
    }

    fn base(&self) -> Frame {
        self.base_of(&self.params)
    }

    fn residuals_of(&self, p: &DVector<f64>) -> DVector<f64> {
        // Base frame of each piece, and where it starts along the section.
        let mut bases = Vec::with_capacity(self.lengths.len());
        let (mut frame, mut start) = (self.base_of(p), 0.0);
        for (i, &length) in self.lengths.iter().enumerate() {
            bases.push((frame, start, [p[2 * i], p[2 * i + 1]]));
            let piece = Section {
                length,
                kappa: [p[2 * i], p[2 * i + 1]],
                strain: 0.0,
            };
            frame = frame.compose(&piece.local_frame(length));
            start += length;
        }
        let mut r = DVector::zeros(3 * self.data.len());
        for (i, (u, x)) in self.data.iter().enumerate() {
            let (base, from, kappa) = bases
                .iter()
                .rev()
                .find(|b| *u >= b.1)
                .copied()
                .unwrap_or(bases[0]);
            let m = base.position + base.rotation * local_position(kappa, u - from);
            for c in 0..3 {
                r[3 * i + c] = m[c] - x[c];
            }
        }
        r
    }

    /// Mean and largest distance between curve and arc, mm.
    fn residual_stats(&self) -> (f64, f64) {
        let r = self.residuals_of(&self.params);
        let d: Vec<f64> = r
            .as_slice()
            .chunks_exact(3)
            .map(|v| dot([v[0], v[1], v[2]], [v[0], v[1], v[2]]).sqrt())
            .collect();
        let mean = d.iter().sum::<f64>() / d.len() as f64;
        (mean, d.iter().copied().fold(0.0, f64::max))
    }
}

impl Residuals for Problem<'_> {
    fn residuals(&self, x: &DVector<f64>) -> Option<DVector<f64>> {
        Some(self.residuals_of(x))
    }

    fn jacobian(&self, x: &DVector<f64>) -> Option<DMatrix<f64>> {
        let n = x.len();
        let at = self.residuals_of(x);
        let mut j = DMatrix::zeros(at.len(), n);
        // The curvatures: forward differences (the model is smooth, and LM needs no more
        // precision).
        let pieces = 2 * self.lengths.len();
        for k in 0..pieces {
            let h = 1e-7 * x[k].abs().max(1e-2);
            let mut moved = x.clone();
            moved[k] += h;
            j.set_column(k, &((self.residuals_of(&moved) - &at) / h));
        }
        if !self.free_base {
            return Some(j);
        }
        // The base moves the whole section rigidly: an offset moves every point by the
        // section frame's axis; a tilt turns every point's place in the tilted base frame.
        let base = self.base_of(x);
        let axes = self.frame.rotation.matrix();
        let tilt_of = |p: &DVector<f64>| {
            Rotation3::from_scaled_axis(Vector3::new(p[pieces], 0.0, p[pieces + 1]))
        };
        let tilt = tilt_of(x);
        let turned: Vec<Matrix3<f64>> = (0..2)
            .map(|t| {
                let h = 1e-7;
                let mut moved = x.clone();
                moved[pieces + t] += h;
                axes * (tilt_of(&moved).matrix() - tilt.matrix()) / h
            })
            .collect();
        let to_base = base.rotation.inverse();
        for (i, (_, x)) in self.data.iter().enumerate() {
            let m = Vector3::new(at[3 * i], at[3 * i + 1], at[3 * i + 2]) + Vector3::from(*x);
            let local = to_base * (m - base.position.coords);
            for (t, d) in turned.iter().enumerate() {
                let v = d * local;
                for c in 0..3 {
                    j[(3 * i + c, pieces + t)] = v[c];
                }
            }
            for o in 0..3 {
                for c in 0..3 {
                    j[(3 * i + c, pieces + 2 + o)] = axes[(c, o)];
                }
            }
        }
        Some(j)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn local_position_matches_the_section_model() {
        for kappa in [
            [0.0, 0.0],
            [0.02, 0.0],
            [0.0, -0.015],
            [0.011, 0.007],
            [1e-7, 2e-7],
        ] {
            for u in [0.0, 3.0, 40.0, 150.0] {
                let section = Section {
                    length: 160.0,
                    kappa,
                    strain: 0.0,
                };
                let expected = section.local_frame(u).position.coords;
                assert!(
                    (local_position(kappa, u) - expected).norm() < 1e-9,
                    "{kappa:?} {u}"
                );
            }
        }
    }

    /// The Jacobian (differences for the curvatures, the rigid base's columns in closed form)
    /// matches forward differences of every parameter, one piece and two, tilted and not.
    #[test]
    fn the_jacobian_matches_differences_of_the_residuals() {
        let data: Vec<(f64, [f64; 3])> = (0..=40)
            .map(|i| {
                let u = 2.0 * i as f64;
                let p = local_position([0.012, -0.004], u);
                (u, [p.x + 3.0, p.y - 1.0, p.z + 0.5 * (u * 0.1).sin()])
            })
            .collect();
        let frame = section_frame([1.0, 2.0, 3.0], [0.1, 1.0, 0.2], [0.0, 0.0, 1.0]);
        for lengths in [vec![80.0], vec![30.0, 50.0]] {
            let kappa = vec![0.01; 2 * lengths.len()];
            let problem = Problem::new(&data, frame, lengths, true, &kappa);
            let mut p = problem.params.clone();
            let k = p.len();
            (p[k - 5], p[k - 4], p[k - 3], p[k - 2], p[k - 1]) = (0.05, -0.08, 0.4, -0.2, 0.3);
            let j = problem.jacobian(&p).unwrap();
            let at = problem.residuals(&p).unwrap();
            for c in 0..k {
                let h = 1e-6;
                let mut moved = p.clone();
                moved[c] += h;
                let column = (problem.residuals_of(&moved) - &at) / h;
                let err = (j.column(c) - &column).amax();
                assert!(err < 1e-4 * column.amax().max(1.0), "column {c}: {err}");
            }
        }
    }
}
