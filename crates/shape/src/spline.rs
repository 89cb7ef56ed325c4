//! Cubic splines in 3-D over a scalar parameter (arc length, mm): the smoothing spline of
//! Reinsch (penalised least squares, solved as a pentadiagonal system) and the paper's two
//! smoothers (moving average, polynomial fit), all ending in one natural cubic spline so that
//! derivatives exist for every method.

use nalgebra::{DMatrix, DVector};

/// A natural cubic spline through `values` at strictly increasing `knots`, continued linearly
/// beyond its ends.
#[derive(Debug, Clone, PartialEq)]
pub struct CubicSpline3 {
    knots: Vec<f64>,
    values: Vec<[f64; 3]>,
    /// Second derivatives at the knots (zero at both ends).
    second: Vec<[f64; 3]>,
}

pub use flexshape_curve::Derivatives;

impl CubicSpline3 {
    /// The penalised least-squares spline minimising `Σ wᵢ‖yᵢ − g(xᵢ)‖² + λ ∫‖g''‖²` (`λ = 0`
    /// interpolates). Needs at least 3 knots, strictly increasing, and positive weights.
    pub fn smoothing(knots: &[f64], data: &[[f64; 3]], weights: &[f64], lambda: f64) -> Self {
        let n = knots.len();
        debug_assert!(n >= 3 && data.len() == n && weights.len() == n);
        let h: Vec<f64> = knots.windows(2).map(|w| w[1] - w[0]).collect();
        let m = n - 2;
        // Column j of Q (knot j + 1) has 1/h_j, −1/h_j − 1/h_{j+1}, 1/h_{j+1} at rows j..j+2.
        let q = |j: usize| [1.0 / h[j], -1.0 / h[j] - 1.0 / h[j + 1], 1.0 / h[j + 1]];
        // A = R + λ Qᵀ W⁻¹ Q, symmetric pentadiagonal: diagonal, first and second off-diagonal.
        let mut a0 = vec![0.0; m];
        let mut a1 = vec![0.0; m.saturating_sub(1)];
        let mut a2 = vec![0.0; m.saturating_sub(2)];
        for j in 0..m {
            let qj = q(j);
            a0[j] = (h[j] + h[j + 1]) / 3.0
                + lambda * (0..3).map(|r| qj[r] * qj[r] / weights[j + r]).sum::<f64>();
            if j + 1 < m {
                let qk = q(j + 1);
                // Rows j+1 and j+2 are shared.
                a1[j] = h[j + 1] / 6.0
                    + lambda * (qj[1] * qk[0] / weights[j + 1] + qj[2] * qk[1] / weights[j + 2]);
            }
            if j + 2 < m {
                let qk = q(j + 2);
                a2[j] = lambda * qj[2] * qk[0] / weights[j + 2];
            }
        }
        let chol = BandCholesky::new(&a0, &a1, &a2);
        let mut values = data.to_vec();
        let mut second = vec![[0.0; 3]; n];
        for c in 0..3 {
            let b: Vec<f64> = (0..m)
                .map(|j| {
                    (data[j + 2][c] - data[j + 1][c]) / h[j + 1]
                        - (data[j + 1][c] - data[j][c]) / h[j]
                })
                .collect();
            let gamma = chol.solve(&b);
            for (j, &g) in gamma.iter().enumerate() {
                second[j + 1][c] = g;
                let qj = q(j);
                for r in 0..3 {
                    values[j + r][c] -= lambda * qj[r] * g / weights[j + r];
                }
            }
        }
        CubicSpline3 {
            knots: knots.to_vec(),
            values,
            second,
        }
    }

    /// The natural interpolating spline.
    pub fn interpolating(knots: &[f64], data: &[[f64; 3]]) -> Self {
        Self::smoothing(knots, data, &vec![1.0; knots.len()], 0.0)
    }

    /// First and last knot.
    pub fn domain(&self) -> (f64, f64) {
        (self.knots[0], self.knots[self.knots.len() - 1])
    }

    /// Position and derivatives at parameter `x` (linear beyond the ends).
    pub fn eval(&self, x: f64) -> Derivatives {
        let n = self.knots.len();
        let (x0, x1) = self.domain();
        if x < x0 || x > x1 {
            let end = if x < x0 { 0 } else { n - 1 };
            let at = self.eval(self.knots[end]);
            let dx = x - self.knots[end];
            return Derivatives {
                value: std::array::from_fn(|c| at.value[c] + at.d1[c] * dx),
                d1: at.d1,
                d2: [0.0; 3],
                d3: [0.0; 3],
            };
        }
        let i = match self.knots.partition_point(|&k| k <= x) {
            0 => 0,
            p => (p - 1).min(n - 2),
        };
        let h = self.knots[i + 1] - self.knots[i];
        let t = x - self.knots[i];
        let mut out = Derivatives {
            value: [0.0; 3],
            d1: [0.0; 3],
            d2: [0.0; 3],
            d3: [0.0; 3],
        };
        for c in 0..3 {
            let (g0, g1) = (self.values[i][c], self.values[i + 1][c]);
            let (s0, s1) = (self.second[i][c], self.second[i + 1][c]);
            let b = (g1 - g0) / h - h * (2.0 * s0 + s1) / 6.0;
            let cc = s0 / 2.0;
            let d = (s1 - s0) / (6.0 * h);
            out.value[c] = g0 + t * (b + t * (cc + t * d));
            out.d1[c] = b + t * (2.0 * cc + 3.0 * d * t);
            out.d2[c] = 2.0 * cc + 6.0 * d * t;
            out.d3[c] = 6.0 * d;
        }
        out
    }
}

/// Cholesky factor of a symmetric positive definite matrix with two off-diagonals.
struct BandCholesky {
    d: Vec<f64>,
    l1: Vec<f64>,
    l2: Vec<f64>,
}

impl BandCholesky {
    fn new(a0: &[f64], a1: &[f64], a2: &[f64]) -> Self {
        let m = a0.len();
        let (mut d, mut l1, mut l2) = (vec![0.0; m], vec![0.0; m], vec![0.0; m]);
        for i in 0..m {
            if i >= 2 {
                l2[i] = a2[i - 2] / d[i - 2];
            }
            if i >= 1 {
                let shared = if i >= 2 { l2[i] * l1[i - 1] } else { 0.0 };
                l1[i] = (a1[i - 1] - shared) / d[i - 1];
            }
            d[i] = (a0[i] - l1[i] * l1[i] - l2[i] * l2[i]).max(1e-300).sqrt();
        }
        BandCholesky { d, l1, l2 }
    }

    fn solve(&self, b: &[f64]) -> Vec<f64> {
        let m = b.len();
        let mut y = vec![0.0; m];
        for i in 0..m {
            let mut v = b[i];
            if i >= 1 {
                v -= self.l1[i] * y[i - 1];
            }
            if i >= 2 {
                v -= self.l2[i] * y[i - 2];
            }
            y[i] = v / self.d[i];
        }
        for i in (0..m).rev() {
            let mut v = y[i];
            if i + 1 < m {
                v -= self.l1[i + 1] * y[i + 1];
            }
            if i + 2 < m {
                v -= self.l2[i + 2] * y[i + 2];
            }
            y[i] = v / self.d[i];
        }
        y
    }
}

/// The paper's moving average: each point replaced by the mean of the `window` points centred
/// on it (the window shrinks symmetrically at the ends, so the ends stay put).
pub fn moving_average(data: &[[f64; 3]], window: usize) -> Vec<[f64; 3]> {
    let half = window / 2;
    let n = data.len();
    (0..n)
        .map(|i| {
            let r = half.min(i).min(n - 1 - i);
            let slice = &data[i - r..=i + r];
            let k = slice.len() as f64;
            std::array::from_fn(|c| slice.iter().map(|p| p[c]).sum::<f64>() / k)
        })
        .collect()
}

/// The paper's alternative: a least-squares polynomial of `degree` in the parameter, per
/// coordinate (Chebyshev basis over the parameter range, for conditioning), evaluated at the
/// knots.
pub fn polynomial_fit(knots: &[f64], data: &[[f64; 3]], degree: usize) -> Vec<[f64; 3]> {
    let n = knots.len();
    let degree = degree.min(n.saturating_sub(1));
    let (a, b) = (knots[0], knots[n - 1]);
    let t = |x: f64| (2.0 * x - a - b) / (b - a).max(f64::MIN_POSITIVE);
    let basis = DMatrix::from_fn(n, degree + 1, |i, k| chebyshev(k, t(knots[i])));
    let svd = basis.clone().svd(true, true);
    let mut out = vec![[0.0; 3]; n];
    for c in 0..3 {
        let y = DVector::from_iterator(n, data.iter().map(|p| p[c]));
        let coef = svd
            .solve(&y, 1e-12)
            .unwrap_or_else(|_| DVector::zeros(degree + 1));
        let fit = &basis * coef;
        for i in 0..n {
            out[i][c] = fit[i];
        }
    }
    out
}

fn chebyshev(k: usize, t: f64) -> f64 {
    let (mut a, mut b) = (1.0, t);
    match k {
        0 => a,
        _ => {
            for _ in 1..k {
                (a, b) = (b, 2.0 * t * b - a);
            }
            b
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolating_spline_reproduces_knots_and_cubics_exactly() {
        let knots: Vec<f64> = (0..12)
            .map(|i| i as f64 * 1.3 + (i % 3) as f64 * 0.2)
            .collect();
        // A straight line with a natural spline is exact; the knot values always are.
        let line: Vec<[f64; 3]> = knots.iter().map(|&x| [2.0 * x + 1.0, -x, 0.5]).collect();
        let s = CubicSpline3::interpolating(&knots, &line);
        for x in [0.1, 3.3, 7.77, 14.0] {
            let d = s.eval(x);
            assert!((d.value[0] - (2.0 * x + 1.0)).abs() < 1e-12);
            assert!((d.d1[1] + 1.0).abs() < 1e-12 && d.d2[0].abs() < 1e-12);
        }
        let wave: Vec<[f64; 3]> = knots.iter().map(|&x| [x.sin(), x.cos(), x * x]).collect();
        let s = CubicSpline3::interpolating(&knots, &wave);
        for (x, w) in knots.iter().zip(&wave) {
            let v = s.eval(*x).value;
            assert!((0..3).all(|c| (v[c] - w[c]).abs() < 1e-12));
        }
    }

    #[test]
    fn smoothing_removes_noise_and_keeps_smooth_shapes() {
        let knots: Vec<f64> = (0..200).map(|i| i as f64).collect();
        let truth = |x: f64| {
            [
                60.0 * (x / 60.0).sin(),
                60.0 * (1.0 - (x / 60.0).cos()),
                0.0,
            ]
        };
        // Deterministic pseudo-noise of ±0.3.
        let noisy: Vec<[f64; 3]> = knots
            .iter()
            .map(|&x| {
                let e = ((x * 12.9898).sin() * 43758.5453).rem_euclid(1.0) - 0.5;
                let t = truth(x);
                [t[0] + 0.6 * e, t[1] - 0.6 * e, 0.6 * e]
            })
            .collect();
        let s = CubicSpline3::smoothing(&knots, &noisy, &vec![1.0; 200], 5f64.powi(4));
        let rms = |f: &dyn Fn(f64) -> [f64; 3]| {
            (knots[10..190]
                .iter()
                .map(|&x| {
                    let (a, b) = (f(x), truth(x));
                    (0..3).map(|c| (a[c] - b[c]).powi(2)).sum::<f64>()
                })
                .sum::<f64>()
                / 180.0)
                .sqrt()
        };
        let raw = rms(&|x| noisy[x as usize]);
        let smooth = rms(&|x| s.eval(x).value);
        assert!(smooth < raw / 3.0, "raw {raw:.3}, smoothed {smooth:.3}");
        // Mean curvature of the smoothed curve over its middle: 1/60 within 2 %.
        let norm = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        let kappa = (20..180)
            .map(|x| {
                let d = s.eval(x as f64);
                let cross = [
                    d.d1[1] * d.d2[2] - d.d1[2] * d.d2[1],
                    d.d1[2] * d.d2[0] - d.d1[0] * d.d2[2],
                    d.d1[0] * d.d2[1] - d.d1[1] * d.d2[0],
                ];
                norm(cross) / norm(d.d1).powi(3)
            })
            .sum::<f64>()
            / 160.0;
        assert!((kappa * 60.0 - 1.0).abs() < 0.02, "κ = {kappa}");
    }

    #[test]
    fn paper_smoothers() {
        let knots: Vec<f64> = (0..50).map(|i| i as f64).collect();
        let quad: Vec<[f64; 3]> = knots.iter().map(|&x| [x * x, 1.0 - x, 3.0]).collect();
        let fit = polynomial_fit(&knots, &quad, 3);
        assert!(
            fit.iter()
                .zip(&quad)
                .all(|(a, b)| (0..3).all(|c| (a[c] - b[c]).abs() < 1e-8))
        );
        let avg = moving_average(&quad, 5);
        // Linear coordinates are unchanged by a symmetric mean; ends are kept.
        assert!(
            avg.iter()
                .zip(&quad)
                .all(|(a, b)| (a[1] - b[1]).abs() < 1e-12)
        );
        assert_eq!(avg[0], quad[0]);
        assert!((avg[10][0] - (100.0 + 2.0)).abs() < 1e-9); // mean of x² over 8..=12
    }
}
