//! Constant-curvature fits of a section of the curve (paper, Section V-B): non-linear least
//! squares for `[κx, κz]` (and by default the section frame's offset and tilt), the cost being
//! the distance between curve and arc at equal arc lengths, the arc's length being the
//! curve's. Also a two-piece (piecewise constant curvature) fit.

use flexshape_curve::{Frame, Section};
use flexshape_lsq::{Normal, NormalEquations, Settings, minimize_normal};
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
    one.solve();
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
    two.solve();
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

/// When the solver stops: once a step changes the cost or the parameters by less than 1e-10
/// of themselves (machine precision costs a third more steps for changes far below a
/// micrometre).
const SOLVER: Settings = Settings {
    max_iterations: 100,
    ftol: 1e-10,
    xtol: 1e-10,
};

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
    let (sin, versine, _) = trig(angle);
    on_arc([kx, kz], k, sin, versine)
}

/// The position on an arc of curvatures `[κx, κz]` (`k` their norm) where `sin θ` and
/// `1 − cos θ` are given.
fn on_arc([kx, kz]: [f64; 2], k: f64, sin: f64, versine: f64) -> Vector3<f64> {
    let side = versine / k;
    Vector3::new(-kz / k * side, sin / k, kx / k * side)
}

/// `sin θ`, `1 − cos θ` (as `2 sin²(θ/2)`, without the cancellation at small angles) and
/// `cos θ`, from one `sin_cos` of `θ/2` (a third of the trigonometry; libm's `sin` saves and
/// restores the rounding mode on every call).
fn trig(angle: f64) -> (f64, f64, f64) {
    let (s, c) = (0.5 * angle).sin_cos();
    (2.0 * s * c, 2.0 * s * s, (c - s) * (c + s))
}

/// [`local_position`] and its derivatives by `κx` and `κz`. With `θ = κu`,
/// `f = (1 − cos θ)/κ²` and `g = sin θ/κ` the position is `(−κz·f, g, κx·f)`; `f'(κ)/κ` and
/// `g'(κ)/κ` are taken from their series below θ = 0.05, where the closed forms cancel.
fn local_position_and_jacobian([kx, kz]: [f64; 2], u: f64) -> (Vector3<f64>, [Vector3<f64>; 2]) {
    let k = kx.hypot(kz);
    let angle = k * u;
    let (position, f, fk, gk) = if angle.abs() < 0.05 {
        let a2 = angle * angle;
        let u2 = u * u;
        (
            local_position([kx, kz], u),
            0.5 * u2 * (1.0 - a2 / 12.0 + a2 * a2 / 360.0),
            u2 * u2 * (-1.0 / 12.0 + a2 / 180.0 - a2 * a2 / 6720.0),
            u2 * u * (-1.0 / 3.0 + a2 / 30.0 - a2 * a2 / 840.0),
        )
    } else {
        let (sin, c1, cos) = trig(angle);
        let (k2, k3) = (k * k, k * k * k);
        (
            on_arc([kx, kz], k, sin, c1),
            c1 / k2,
            u * sin / k3 - 2.0 * c1 / (k2 * k2),
            u * cos / k2 - sin / k3,
        )
    };
    let d_kx = Vector3::new(-kz * fk * kx, gk * kx, f + kx * kx * fk);
    let d_kz = Vector3::new(-f - kz * kz * fk, gk * kz, kx * kz * fk);
    (position, [d_kx, d_kz])
}

/// How a piece's end frame moves with its curvatures `[κx, κz]`, in its base frame: the end's
/// position and its rotation matrix, each differentiated by each curvature.
type EndDerivatives = ([Vector3<f64>; 2], [Matrix3<f64>; 2]);

/// A constant-curvature piece of `length` (no strain).
fn section(length: f64, kappa: [f64; 2]) -> Section {
    Section {
        length,
        kappa,
        strain: 0.0,
    }
}

/// The piece (of `bases`, from [`Problem::bases`]) that arc length `u` falls in.
fn piece_at(bases: &[(Frame, f64)], u: f64) -> usize {
    bases.iter().rposition(|b| u >= b.1).unwrap_or(0)
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

    /// Each piece's base frame and where it starts along the section, mm.
    fn bases(&self, p: &DVector<f64>) -> Vec<(Frame, f64)> {
        let mut bases = Vec::with_capacity(self.lengths.len());
        let (mut frame, mut start) = (self.base_of(p), 0.0);
        for (i, &length) in self.lengths.iter().enumerate() {
            bases.push((frame, start));
            frame = frame.compose(&section(length, [p[2 * i], p[2 * i + 1]]).local_frame(length));
            start += length;
        }
        bases
    }

    fn residuals_of(&self, p: &DVector<f64>) -> DVector<f64> {
        let bases = self.bases(p);
        let mut r = DVector::zeros(3 * self.data.len());
        for (n, (u, x)) in self.data.iter().enumerate() {
            let i = piece_at(&bases, *u);
            let (base, from) = &bases[i];
            let m =
                base.position + base.rotation * local_position([p[2 * i], p[2 * i + 1]], u - from);
            for c in 0..3 {
                r[3 * n + c] = m[c] - x[c];
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

impl Problem<'_> {
    /// Fits the parameters from where they are.
    fn solve(&mut self) {
        if let Some(solution) = minimize_normal(&*self, self.params.clone(), &SOLVER) {
            self.params = solution.x;
        }
    }

    /// The residuals at `p` and their Jacobian (rows: residuals, columns: parameters). A point
    /// of piece `i` moves with its own curvatures through its place in the piece, and with an
    /// earlier piece's through that piece's end frame (position in closed form, rotation by
    /// central differences of a 3×3 matrix); the base moves the whole section rigidly.
    fn residuals_and_jacobian(&self, p: &DVector<f64>) -> (DVector<f64>, DMatrix<f64>) {
        let pieces = 2 * self.lengths.len();
        let kappa = |i: usize| [p[2 * i], p[2 * i + 1]];
        let bases = self.bases(p);
        // Per piece: its end frame's derivatives by its curvatures (position, rotation) in
        // its base frame.
        let ends: Vec<EndDerivatives> = self
            .lengths
            .iter()
            .enumerate()
            .map(|(i, &length)| {
                let (_, d_end) = local_position_and_jacobian(kappa(i), length);
                let d_turn = std::array::from_fn(|c| {
                    let h = 1e-6;
                    let (mut up, mut down) = (kappa(i), kappa(i));
                    up[c] += h;
                    down[c] -= h;
                    let turn = |k| section(length, k).local_frame(length).rotation;
                    (turn(up).matrix() - turn(down).matrix()) / (2.0 * h)
                });
                (d_end, d_turn)
            })
            .collect();
        let axes = self.frame.rotation.matrix();
        let tilt_of = |p: &DVector<f64>| {
            Rotation3::from_scaled_axis(Vector3::new(p[pieces], 0.0, p[pieces + 1]))
        };
        let turned: Vec<Matrix3<f64>> = if self.free_base {
            let tilt = tilt_of(p);
            (0..2)
                .map(|t| {
                    let h = 1e-7;
                    let mut moved = p.clone();
                    moved[pieces + t] += h;
                    axes * (tilt_of(&moved).matrix() - tilt.matrix()) / h
                })
                .collect()
        } else {
            Vec::new()
        };
        let base = bases[0].0;
        let to_base = base.rotation.inverse();
        let mut r = DVector::zeros(3 * self.data.len());
        let mut j = DMatrix::zeros(3 * self.data.len(), p.len());
        for (n, (u, x)) in self.data.iter().enumerate() {
            let i = piece_at(&bases, *u);
            let (frame, from) = &bases[i];
            let (local, d_local) = local_position_and_jacobian(kappa(i), u - from);
            let m = frame.position + frame.rotation * local;
            let mut column = |c: usize, v: Vector3<f64>| {
                for row in 0..3 {
                    j[(3 * n + row, c)] = v[row];
                }
            };
            for (c, d) in d_local.iter().enumerate() {
                column(2 * i + c, frame.rotation * d);
            }
            for (e, ((earlier, _), (d_end, d_turn))) in bases[..i].iter().zip(&ends).enumerate() {
                // The point in the frame at the end of piece `e`.
                let (next, _) = &bases[e + 1];
                let rest = next.rotation.inverse() * (m - next.position);
                for c in 0..2 {
                    column(2 * e + c, earlier.rotation * (d_end[c] + d_turn[c] * rest));
                }
            }
            if self.free_base {
                let in_base = to_base * (m - base.position);
                for (t, d) in turned.iter().enumerate() {
                    column(pieces + t, d * in_base);
                }
                for o in 0..3 {
                    column(pieces + 2 + o, axes.column(o).into_owned());
                }
            }
            for row in 0..3 {
                r[3 * n + row] = m[row] - x[row];
            }
        }
        (r, j)
    }
}

impl NormalEquations for Problem<'_> {
    fn cost(&self, x: &DVector<f64>) -> Option<f64> {
        Some(0.5 * self.residuals_of(x).norm_squared())
    }

    fn normal(&self, x: &DVector<f64>) -> Option<Normal> {
        let (r, j) = self.residuals_and_jacobian(x);
        Some(Normal {
            jtj: j.tr_mul(&j),
            jtr: j.tr_mul(&r),
            cost: 0.5 * r.norm_squared(),
        })
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

    /// The analytic Jacobian matches central differences of the residuals for every
    /// parameter: one piece and two, tilted base, straight, gently and strongly bent.
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
            for kappa in [[0.01, -0.004], [1e-6, 2e-6], [0.0, 0.0], [-0.03, 0.02]] {
                let kappas: Vec<f64> = (0..lengths.len())
                    .flat_map(|i| [kappa[0] * (1.0 + i as f64), kappa[1] - 0.002 * i as f64])
                    .collect();
                let problem = Problem::new(&data, frame, lengths.clone(), true, &kappas);
                let mut p = problem.params.clone();
                let k = p.len();
                (p[k - 5], p[k - 4], p[k - 3], p[k - 2], p[k - 1]) = (0.05, -0.08, 0.4, -0.2, 0.3);
                let (at, j) = problem.residuals_and_jacobian(&p);
                assert!((&at - problem.residuals_of(&p)).amax() < 1e-12);
                for c in 0..k {
                    let h = 1e-6;
                    let (mut up, mut down) = (p.clone(), p.clone());
                    up[c] += h;
                    down[c] -= h;
                    let column =
                        (problem.residuals_of(&up) - problem.residuals_of(&down)) / (2.0 * h);
                    let err = (j.column(c) - &column).amax();
                    assert!(
                        err < 1e-5 * column.amax().max(1.0),
                        "{lengths:?} {kappa:?} column {c}: {err}"
                    );
                }
            }
        }
    }

    /// The series branch of the derivatives joins the closed form at θ = 0.05.
    #[test]
    fn the_curvature_derivatives_are_continuous_at_the_series_switch() {
        let u = 100.0;
        for dir in [[1.0, 0.0], [0.6, -0.8]] {
            let k = |a: f64| [dir[0] * a / u, dir[1] * a / u];
            let (_, below) = local_position_and_jacobian(k(0.05 - 1e-9), u);
            let (_, above) = local_position_and_jacobian(k(0.05 + 1e-9), u);
            for c in 0..2 {
                assert!((below[c] - above[c]).norm() < 1e-6 * below[c].norm().max(1.0));
            }
        }
    }
}
