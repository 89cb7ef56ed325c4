//! The entries of a banded problem's covariance that local quantities need, without the whole
//! inverse.
//!
//! A curve's control points each touch a few neighbours in the normal equations `H`, so `H`
//! is banded apart from a few trailing parameters shared by all (a radius). Its inverse is
//! dense, but the covariance of a point on the curve needs only the entries near the
//! diagonal. Takahashi's recursion gives the inverse's entries wherever the Cholesky factor may
//! be non-zero, from the last row up, in `O(n·b·(b + t))` for bandwidth `b` and `t` trailing
//! rows, against `O(n³)` for the whole inverse.

use nalgebra::{DMatrix, Dyn, linalg::Cholesky};

/// The inverse of a symmetric positive definite `h` (by its Cholesky factor `chol`), exact
/// within `band` of the diagonal and in the last `tail` rows and columns; zero elsewhere.
/// When the factor has a non-zero entry outside that pattern (`h` is not banded so), the
/// whole inverse.
pub fn banded_inverse(chol: &Cholesky<f64, Dyn>, band: usize, tail: usize) -> DMatrix<f64> {
    let l = chol.l_dirty();
    let n = l.nrows();
    let dense_from = n.saturating_sub(tail);
    // Whether (i, j), j ≥ i, lies in the pattern.
    let kept = |i: usize, j: usize| j - i <= band || j >= dense_from;
    let outside = (0..n).any(|j| (j + 1..n).any(|i| !kept(j, i) && l[(i, j)] != 0.0));
    if outside {
        return chol.inverse();
    }
    // Z = H⁻¹ = L⁻ᵀ L⁻¹ satisfies Z L = L⁻ᵀ, whose lower part above the diagonal is zero:
    // Z_ij = (δ_ij / L_ii − Σ_{k>i} L_ki Z_kj) / L_ii for j ≥ i, with L_ki non-zero only in
    // the pattern, which is closed under the recursion.
    let mut z = DMatrix::<f64>::zeros(n, n);
    for i in (0..n).rev() {
        let lii = l[(i, i)];
        let below: Vec<usize> = (i + 1..n).filter(|&k| kept(i, k)).collect();
        for j in (i..n).rev().filter(|&j| kept(i, j)) {
            let sum: f64 = below.iter().map(|&k| l[(k, i)] * z[(k, j)]).sum();
            let v = (if i == j { 1.0 / lii } else { 0.0 } - sum) / lii;
            z[(i, j)] = v;
            z[(j, i)] = v;
        }
    }
    z
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A random symmetric positive definite matrix, banded with bandwidth `b` apart from its
    /// last `t` rows and columns.
    fn banded(n: usize, b: usize, t: usize, seed: u64) -> DMatrix<f64> {
        let mut state = seed;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        // J with rows touching b+1 consecutive columns and the tail: JᵀJ has that pattern.
        let rows = 3 * n;
        let mut j = DMatrix::<f64>::zeros(rows, n);
        for r in 0..rows {
            let first = (r * (n - t)) / rows;
            for c in first..(first + b + 1).min(n - t) {
                j[(r, c)] = next();
            }
            for c in n - t..n {
                j[(r, c)] = next();
            }
        }
        j.transpose() * &j + DMatrix::identity(n, n) * 1e-3
    }

    #[test]
    fn the_band_and_tail_equal_the_whole_inverse_there() {
        for (n, b, t, seed) in [(40, 11, 1, 1), (61, 11, 3, 2), (12, 2, 0, 3), (9, 20, 2, 4)] {
            let h = banded(n, b, t, seed);
            let full = h.clone().try_inverse().unwrap();
            let chol = h.cholesky().unwrap();
            let z = banded_inverse(&chol, b, t);
            let scale = full.amax();
            for i in 0..n {
                for j in 0..n {
                    if j.abs_diff(i) <= b || i.max(j) >= n - t {
                        assert!(
                            (z[(i, j)] - full[(i, j)]).abs() < 1e-9 * scale,
                            "n {n} b {b} t {t}: ({i}, {j}) {} against {}",
                            z[(i, j)],
                            full[(i, j)]
                        );
                    } else {
                        assert_eq!(z[(i, j)], 0.0, "({i}, {j}) outside the pattern");
                    }
                }
            }
        }
    }

    #[test]
    fn a_matrix_wider_than_the_band_gets_the_whole_inverse() {
        let h = banded(30, 8, 1, 5);
        let full = h.clone().try_inverse().unwrap();
        // Asked for a band of 2 on a matrix of bandwidth 8: outside the pattern, so whole.
        let z = banded_inverse(&h.cholesky().unwrap(), 2, 1);
        assert!((z - &full).amax() < 1e-9 * full.amax());
    }
}
