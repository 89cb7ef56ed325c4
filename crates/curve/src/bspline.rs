//! Clamped uniform cubic B-splines in 3-D: the smooth centerline the tube fit moves. A curve of
//! `n ≥ 4` control points has `n − 3` equal spans over the parameter `u ∈ [0, 1]`; it starts at
//! the first control point and ends at the last, tangent to the control polygon there. Each
//! point depends on four control points only, which keeps the fit's normal equations banded.

use nalgebra::{DMatrix, DVector};

use crate::polyline::CurveError;

/// Position and its first three derivatives with respect to a curve's parameter (units: the
/// curve's, per parameter unit to the power of the derivative's order).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Derivatives {
    /// Position.
    pub value: [f64; 3],
    /// First derivative.
    pub d1: [f64; 3],
    /// Second derivative.
    pub d2: [f64; 3],
    /// Third derivative.
    pub d3: [f64; 3],
}

/// The four basis functions that are non-zero at a parameter, and their derivatives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Basis {
    /// Index of the control point that `weights[·][0]` belongs to.
    pub first: usize,
    /// `weights[d][j]`: the `d`-th derivative (0–3) of the basis function of control point
    /// `first + j`.
    pub weights: [[f64; 4]; 4],
}

/// A clamped uniform cubic B-spline over `u ∈ [0, 1]` (continued along its end tangents
/// beyond).
#[derive(Debug, Clone, PartialEq)]
pub struct BSpline3 {
    control: Vec<[f64; 3]>,
    knots: Vec<f64>,
    /// Each span's cubic in the power basis of `t ∈ [0, 1]` across it: `pieces[s][k]` is the
    /// coefficient of `tᵏ` (per coordinate). Points and derivatives are read from these, at a
    /// few multiply-adds each, whatever the span; the basis weights serve Jacobians.
    pieces: Vec<[[f64; 3]; 4]>,
}

/// The uniform cubic B-spline's four basis functions at `t ∈ [0, 1]` across a span, and their
/// derivatives by `u` up to `ORDER` (`per_u` spans per unit of `u`); rows above are 0.
fn uniform_weights<const ORDER: usize>(t: f64, per_u: f64) -> [[f64; 4]; 4] {
    let (t2, s) = (t * t, 1.0 - t);
    let mut w = [[0.0; 4]; 4];
    w[0] = [
        s * s * s / 6.0,
        (3.0 * t2 * t - 6.0 * t2 + 4.0) / 6.0,
        (-3.0 * t2 * t + 3.0 * t2 + 3.0 * t + 1.0) / 6.0,
        t2 * t / 6.0,
    ];
    if ORDER >= 1 {
        w[1] = [
            -s * s / 2.0 * per_u,
            (1.5 * t2 - 2.0 * t) * per_u,
            (-1.5 * t2 + t + 0.5) * per_u,
            t2 / 2.0 * per_u,
        ];
    }
    if ORDER >= 2 {
        let k = per_u * per_u;
        w[2] = [s * k, (3.0 * t - 2.0) * k, (1.0 - 3.0 * t) * k, t * k];
    }
    if ORDER >= 3 {
        let k = per_u * per_u * per_u;
        w[3] = [-k, 3.0 * k, -3.0 * k, k];
    }
    w
}

impl BSpline3 {
    /// The curve of these control points (at least 4, all finite).
    pub fn new(control: Vec<[f64; 3]>) -> Result<Self, CurveError> {
        if control.len() < 4 {
            return Err(CurveError::Degenerate {
                points: control.len(),
                length: 0.0,
            });
        }
        if let Some(index) = control
            .iter()
            .position(|p| p.iter().any(|v| !v.is_finite()))
        {
            return Err(CurveError::NotFinite { index });
        }
        let spans = control.len() - 3;
        let mut knots = vec![0.0; 4];
        knots.extend((1..spans).map(|i| i as f64 / spans as f64));
        knots.extend([1.0; 4]);
        let mut curve = BSpline3 {
            control,
            knots,
            pieces: Vec::new(),
        };
        curve.pieces = curve.power_basis();
        Ok(curve)
    }

    /// Each span's cubic in the power basis across it (see [`BSpline3::pieces`]), from the
    /// position and derivatives at the span's start.
    fn power_basis(&self) -> Vec<[[f64; 3]; 4]> {
        let spans = self.control.len() - 3;
        let per_t = 1.0 / spans as f64;
        (0..spans)
            .map(|s| {
                let d = self.eval_basis(&self.basis(self.knots[3 + s]));
                // p(t) = value + d1·(t/S) + d2/2·(t/S)² + d3/6·(t/S)³ over the span.
                let scale = [1.0, per_t, per_t * per_t / 2.0, per_t * per_t * per_t / 6.0];
                let rows = [d.value, d.d1, d.d2, d.d3];
                std::array::from_fn(|k| rows[k].map(|v| v * scale[k]))
            })
            .collect()
    }

    /// The span holding `u ∈ [0, 1]` and where `u` lies across it, `t ∈ [0, 1]`.
    fn piece(&self, u: f64) -> (&[[f64; 3]; 4], f64) {
        let spans = self.pieces.len();
        let x = u * spans as f64;
        // Truncation is the floor here (x ≥ 0), and cheaper than `floor`.
        let s = (x as usize).min(spans - 1);
        (&self.pieces[s], x - s as f64)
    }

    /// Least-squares fit of `n_control` control points to `points` at parameters `params` (in
    /// `[0, 1]`), with a small penalty on the control polygon's second differences so that spans
    /// without data stay well defined.
    pub fn fit(params: &[f64], points: &[[f64; 3]], n_control: usize) -> Result<Self, CurveError> {
        let n = n_control.max(4);
        if params.len() != points.len() || points.len() < 2 {
            return Err(CurveError::Degenerate {
                points: points.len(),
                length: 0.0,
            });
        }
        let shape = BSpline3::new(vec![[0.0; 3]; n])?;
        let mut a = DMatrix::<f64>::zeros(n, n);
        let mut b = DMatrix::<f64>::zeros(n, 3);
        for (&u, p) in params.iter().zip(points) {
            let basis = shape.basis(u.clamp(0.0, 1.0));
            for j in 0..4 {
                let wj = basis.weights[0][j];
                for k in 0..4 {
                    a[(basis.first + j, basis.first + k)] += wj * basis.weights[0][k];
                }
                for c in 0..3 {
                    b[(basis.first + j, c)] += wj * p[c];
                }
            }
        }
        let penalty = 1e-6 * points.len() as f64 / n as f64;
        for k in 1..n - 1 {
            let d = [(k - 1, 1.0), (k, -2.0), (k + 1, 1.0)];
            for &(i, wi) in &d {
                for &(j, wj) in &d {
                    a[(i, j)] += penalty * wi * wj;
                }
            }
        }
        let chol = a.cholesky().ok_or(CurveError::Degenerate {
            points: points.len(),
            length: 0.0,
        })?;
        let x = chol.solve(&b);
        BSpline3::new((0..n).map(|i| [x[(i, 0)], x[(i, 1)], x[(i, 2)]]).collect())
    }

    /// The same curve run the other way: the point at `u` is this curve's at `1 − u`
    /// (the knots are uniform and clamped, so reversing the control points is exact).
    pub fn reversed(&self) -> BSpline3 {
        let mut control = self.control.clone();
        control.reverse();
        let mut curve = BSpline3 {
            control,
            knots: self.knots.clone(),
            pieces: Vec::new(),
        };
        curve.pieces = curve.power_basis();
        curve
    }

    /// The control points.
    pub fn control(&self) -> &[[f64; 3]] {
        &self.control
    }

    /// Moves every control point by `delta` (3 values per point, in order).
    pub fn displace(&mut self, delta: &DVector<f64>) {
        for (i, p) in self.control.iter_mut().enumerate() {
            for c in 0..3 {
                p[c] += delta[3 * i + c];
            }
        }
        self.pieces = self.power_basis();
    }

    /// The basis functions non-zero at `u` (clamped to `[0, 1]`) and their derivatives (de
    /// Boor's recurrence, as in Piegl and Tiller's *The NURBS Book*, A2.3).
    pub fn basis(&self, u: f64) -> Basis {
        self.basis_to::<3>(u)
    }

    /// As [`BSpline3::basis`], with derivatives up to `ORDER` only (those above are left 0):
    /// the value and tangent cost about a third of all three derivatives.
    pub fn basis_to<const ORDER: usize>(&self, u: f64) -> Basis {
        const P: usize = 3;
        let u = u.clamp(0.0, 1.0);
        let n = self.control.len();
        let k = &self.knots;
        let span = (P + k[P..n].partition_point(|&t| t <= u))
            .saturating_sub(1)
            .min(n - 1);
        // Away from the clamped ends the six knots that shape this span are evenly spaced,
        // and the basis is the uniform cubic's, in closed form.
        if span >= P + 2 && span + P <= n {
            return Basis {
                first: span - P,
                weights: uniform_weights::<ORDER>((u - k[span]) * (n - P) as f64, (n - P) as f64),
            };
        }
        self.de_boor_basis::<ORDER>(u, span)
    }

    /// The basis at `u` in span `span` by the general recurrence (The NURBS Book, A2.3).
    fn de_boor_basis<const ORDER: usize>(&self, u: f64, span: usize) -> Basis {
        const P: usize = 3;
        let order = ORDER.min(P) as isize;
        let k = &self.knots;
        let mut ndu = [[0.0f64; 4]; 4];
        let mut left = [0.0f64; 4];
        let mut right = [0.0f64; 4];
        ndu[0][0] = 1.0;
        for j in 1..=P {
            left[j] = u - k[span + 1 - j];
            right[j] = k[span + j] - u;
            let mut saved = 0.0;
            for r in 0..j {
                ndu[j][r] = right[r + 1] + left[j - r];
                let temp = ndu[r][j - 1] / ndu[j][r];
                ndu[r][j] = saved + right[r + 1] * temp;
                saved = left[j - r] * temp;
            }
            ndu[j][j] = saved;
        }
        let mut w = [[0.0f64; 4]; 4];
        for j in 0..=P {
            w[0][j] = ndu[j][P];
        }
        for r in 0..=P as isize {
            let mut a = [[0.0f64; 4]; 2];
            let (mut s1, mut s2) = (0usize, 1usize);
            a[0][0] = 1.0;
            for d in 1..=order {
                let mut sum = 0.0;
                let rk = r - d;
                let pk = P as isize - d;
                if r >= d {
                    a[s2][0] = a[s1][0] / ndu[(pk + 1) as usize][rk as usize];
                    sum = a[s2][0] * ndu[rk as usize][pk as usize];
                }
                let j1 = if rk >= -1 { 1 } else { -rk };
                let j2 = if r - 1 <= pk { d - 1 } else { P as isize - r };
                for j in j1..=j2 {
                    let (ju, rkj) = (j as usize, (rk + j) as usize);
                    a[s2][ju] = (a[s1][ju] - a[s1][ju - 1]) / ndu[(pk + 1) as usize][rkj];
                    sum += a[s2][ju] * ndu[rkj][pk as usize];
                }
                if r <= pk {
                    let du = d as usize;
                    a[s2][du] = -a[s1][du - 1] / ndu[(pk + 1) as usize][r as usize];
                    sum += a[s2][du] * ndu[r as usize][pk as usize];
                }
                w[d as usize][r as usize] = sum;
                std::mem::swap(&mut s1, &mut s2);
            }
        }
        let mut factor = P as f64;
        for (d, row) in w.iter_mut().enumerate().skip(1) {
            for v in row.iter_mut() {
                *v *= factor;
            }
            factor *= (P - d) as f64;
        }
        Basis {
            first: span - P,
            weights: w,
        }
    }

    /// Position and derivatives at `u`; beyond `[0, 1]` the curve goes on straight along its
    /// end tangent.
    pub fn eval(&self, u: f64) -> Derivatives {
        let at = self.eval_inside(u.clamp(0.0, 1.0));
        let du = u - u.clamp(0.0, 1.0);
        if du == 0.0 {
            return at;
        }
        Derivatives {
            value: std::array::from_fn(|c| at.value[c] + at.d1[c] * du),
            d1: at.d1,
            d2: [0.0; 3],
            d3: [0.0; 3],
        }
    }

    fn eval_inside(&self, u: f64) -> Derivatives {
        let (piece, t) = self.piece(u);
        let (value, d1) = self.value_and_d1(piece, t);
        let [_, _, c2, c3] = piece;
        let s = self.pieces.len() as f64;
        Derivatives {
            value,
            d1,
            d2: std::array::from_fn(|c| (6.0 * c3[c] * t + 2.0 * c2[c]) * s * s),
            d3: std::array::from_fn(|c| 6.0 * c3[c] * s * s * s),
        }
    }

    /// Position and first derivative by `u` at `t` across a span's cubic (Horner's rule).
    fn value_and_d1(&self, [c0, c1, c2, c3]: &[[f64; 3]; 4], t: f64) -> ([f64; 3], [f64; 3]) {
        let s = self.pieces.len() as f64;
        (
            std::array::from_fn(|c| ((c3[c] * t + c2[c]) * t + c1[c]) * t + c0[c]),
            std::array::from_fn(|c| ((3.0 * c3[c] * t + 2.0 * c2[c]) * t + c1[c]) * s),
        )
    }

    /// Position and first derivative at `u` (continued straight beyond `[0, 1]`, as
    /// [`BSpline3::eval`]), at about half its cost.
    pub fn point_and_d1(&self, u: f64) -> ([f64; 3], [f64; 3]) {
        let inside = u.clamp(0.0, 1.0);
        let (piece, t) = self.piece(inside);
        let (value, d1) = self.value_and_d1(piece, t);
        let du = u - inside;
        (std::array::from_fn(|c| value[c] + d1[c] * du), d1)
    }

    /// Position and derivatives where `basis` was taken (from [`BSpline3::basis`] of this
    /// curve or another with as many control points).
    pub fn eval_basis(&self, b: &Basis) -> Derivatives {
        let mut out = [[0.0f64; 3]; 4];
        for (d, row) in out.iter_mut().enumerate() {
            for j in 0..4 {
                let p = self.control[b.first + j];
                for c in 0..3 {
                    row[c] += b.weights[d][j] * p[c];
                }
            }
        }
        Derivatives {
            value: out[0],
            d1: out[1],
            d2: out[2],
            d3: out[3],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_reversed_curve_runs_through_the_same_points_the_other_way() {
        let curve = BSpline3::new(
            (0..9)
                .map(|i| [i as f64, (i as f64).cos(), 0.1 * (i * i) as f64])
                .collect(),
        )
        .unwrap();
        let back = curve.reversed();
        for i in 0..=200 {
            let u = i as f64 / 200.0;
            let (a, b) = (curve.eval(u), back.eval(1.0 - u));
            for c in 0..3 {
                assert!((a.value[c] - b.value[c]).abs() < 1e-12, "u {u}");
                // The tangent turns round.
                assert!((a.d1[c] + b.d1[c]).abs() < 1e-9, "u {u}");
            }
        }
    }

    #[test]
    fn the_closed_form_away_from_the_ends_is_the_recurrence() {
        let curve = BSpline3::new(
            (0..12)
                .map(|i| [i as f64, (i as f64).sin(), 0.3 * i as f64])
                .collect(),
        )
        .unwrap();
        let n = curve.control.len();
        let mut fast = 0;
        for i in 0..=1000 {
            let u = i as f64 / 1000.0;
            let span = (3 + curve.knots[3..n].partition_point(|&t| t <= u))
                .saturating_sub(1)
                .min(n - 1);
            let (a, b) = (curve.basis(u), curve.de_boor_basis::<3>(u, span));
            assert_eq!(a.first, b.first, "u {u}");
            for d in 0..4 {
                for j in 0..4 {
                    let scale = 1.0 + b.weights[d][j].abs();
                    assert!(
                        (a.weights[d][j] - b.weights[d][j]).abs() < 1e-9 * scale,
                        "u {u}, d {d}, j {j}: {} vs {}",
                        a.weights[d][j],
                        b.weights[d][j]
                    );
                }
            }
            let one = curve.basis_to::<1>(u);
            assert!(one.weights[2] == [0.0; 4] && one.weights[3] == [0.0; 4]);
            fast += usize::from((5..=n - 3).contains(&span));
        }
        // 5 of the 9 spans are evenly knotted.
        assert!((540..=570).contains(&fast), "{fast}");
    }

    /// Points and derivatives read from the spans' power basis are those of the basis
    /// weights, in the clamped end spans as in the even ones, and after the curve is moved.
    #[test]
    fn the_power_basis_gives_the_basis_weights_curve() {
        let mut c = wavy();
        for moved in [false, true] {
            if moved {
                let n = 3 * c.control().len();
                c.displace(&DVector::from_fn(n, |i, _| (i as f64 * 0.7).cos()));
            }
            for i in 0..=997 {
                let u = i as f64 / 997.0;
                let (fast, slow) = (c.eval(u), c.eval_basis(&c.basis(u)));
                let rows = |d: &Derivatives| [d.value, d.d1, d.d2, d.d3];
                for (k, (a, b)) in rows(&fast).iter().zip(rows(&slow)).enumerate() {
                    for j in 0..3 {
                        let scale = 1.0 + b[j].abs();
                        assert!(
                            (a[j] - b[j]).abs() < 1e-9 * scale,
                            "moved {moved}, u {u}, derivative {k}: {} vs {}",
                            a[j],
                            b[j]
                        );
                    }
                }
            }
        }
    }

    fn wavy() -> BSpline3 {
        BSpline3::new(
            (0..9)
                .map(|i| {
                    let t = i as f64;
                    [10.0 * t, 5.0 * (t * 0.7).sin(), 3.0 * (t * 0.4).cos()]
                })
                .collect(),
        )
        .unwrap()
    }

    #[test]
    fn value_and_tangent_alone_match_the_full_evaluation() {
        let c = wavy();
        for i in -10..=110 {
            let u = i as f64 / 100.0;
            let full = c.basis(u);
            let short = c.basis_to::<1>(u);
            assert_eq!(short.first, full.first);
            assert_eq!(short.weights[..2], full.weights[..2], "u {u}");
            assert_eq!(short.weights[2..], [[0.0; 4]; 2]);
            let e = c.eval(u);
            assert_eq!(c.point_and_d1(u), (e.value, e.d1), "u {u}");
        }
    }

    #[test]
    fn basis_sums_to_one_and_interpolates_the_ends() {
        let c = wavy();
        for i in 0..=100 {
            let b = c.basis(i as f64 / 100.0);
            assert!((b.weights[0].iter().sum::<f64>() - 1.0).abs() < 1e-12);
            for d in 1..4 {
                assert!(b.weights[d].iter().sum::<f64>().abs() < 1e-9, "{d}");
            }
        }
        assert_eq!(c.eval(0.0).value, c.control()[0]);
        let end = c.eval(1.0).value;
        let last = c.control()[8];
        assert!((0..3).all(|k| (end[k] - last[k]).abs() < 1e-12));
    }

    #[test]
    fn derivatives_match_finite_differences() {
        let c = wavy();
        let h = 1e-5;
        for i in 1..50 {
            let u = i as f64 / 50.0 + 0.003;
            let (a, b, m) = (c.eval(u - h), c.eval(u + h), c.eval(u));
            for k in 0..3 {
                let fd1 = (b.value[k] - a.value[k]) / (2.0 * h);
                let fd2 = (b.d1[k] - a.d1[k]) / (2.0 * h);
                let fd3 = (b.d2[k] - a.d2[k]) / (2.0 * h);
                assert!((fd1 - m.d1[k]).abs() < 1e-5 * (1.0 + m.d1[k].abs()));
                assert!((fd2 - m.d2[k]).abs() < 1e-4 * (1.0 + m.d2[k].abs()));
                assert!((fd3 - m.d3[k]).abs() < 1e-3 * (1.0 + m.d3[k].abs()));
            }
        }
    }

    #[test]
    fn fit_reproduces_a_curve_it_can_represent() {
        let c = wavy();
        let params: Vec<f64> = (0..=400).map(|i| i as f64 / 400.0).collect();
        let points: Vec<[f64; 3]> = params.iter().map(|&u| c.eval(u).value).collect();
        let f = BSpline3::fit(&params, &points, 9).unwrap();
        for (a, b) in f.control().iter().zip(c.control()) {
            assert!((0..3).all(|k| (a[k] - b[k]).abs() < 1e-3), "{a:?} {b:?}");
        }
    }

    #[test]
    fn continues_straight_beyond_its_ends() {
        let c = wavy();
        let e = c.eval(1.0);
        let past = c.eval(1.1).value;
        for (k, p) in past.iter().enumerate() {
            assert!((p - (e.value[k] + 0.1 * e.d1[k])).abs() < 1e-12);
        }
        assert!(BSpline3::new(vec![[0.0; 3]; 3]).is_err());
    }
}
