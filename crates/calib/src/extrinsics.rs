//! Cameras of a rig in one frame, from views of the board they saw at the same instant: each
//! shared view gives camera j's pose relative to camera i (`T_j · T_i⁻¹` of the two board
//! poses); the relative poses are averaged (rotations by their chordal mean, translations by
//! their mean) and chained from the reference camera, with the spread over views reported as a
//! consistency check.

use nalgebra::{Matrix3, Rotation3, Vector3};
use serde::Serialize;

use crate::CalibError;

/// Two shared views agree when their relative poses differ by at most this rotation, degrees…
pub const ROTATION_TOLERANCE_DEG: f64 = 2.0;

/// …and this translation, mm, or this share of the baseline, whichever is larger. (The real
/// 9×6 stereo pair in `../shared/data`: 15 views, spread 0.2° and 2.2 mm.)
pub const TRANSLATION_TOLERANCE_MM: f64 = 10.0;

/// See [`TRANSLATION_TOLERANCE_MM`].
pub const TRANSLATION_TOLERANCE_SHARE: f64 = 0.05;

/// A board pose in one camera: `x_cam = R·X_board + t` (mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoardPose {
    /// Rotation.
    pub rotation: Rotation3<f64>,
    /// Translation, mm.
    pub translation: Vector3<f64>,
}

/// One camera's pose relative to the reference camera, with its consistency.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RelativePose {
    /// `x_cam = R·x_ref + t`: rotation (rows) …
    pub rotation: [[f64; 3]; 3],
    /// … and translation, mm.
    pub translation: [f64; 3],
    /// Shared views it rests on.
    pub shared_views: usize,
    /// RMS deviation of the per-view rotations from the mean, degrees.
    pub rotation_spread_deg: f64,
    /// RMS deviation of the per-view translations from the mean, mm.
    pub translation_spread_mm: f64,
}

/// The pose of a camera relative to the reference from the board poses both saw in the same
/// views (`pairs`: reference's pose, this camera's pose). Refused when some views disagree
/// with the largest set of views that agree with one another ([`CalibError::SharedViews`]
/// names them): with two views that disagree, both.
pub fn relative_pose(pairs: &[(BoardPose, BoardPose)]) -> Result<RelativePose, CalibError> {
    if pairs.is_empty() {
        return Err(CalibError::Degenerate(
            "no view shows the board to both cameras at the same instant; take views both see (same file names)"
                .into(),
        ));
    }
    let each: Vec<(Rotation3<f64>, Vector3<f64>)> = pairs
        .iter()
        .map(|(a, b)| {
            let r = b.rotation * a.rotation.inverse();
            (r, b.translation - r * a.translation)
        })
        .collect();
    let agree = |a: &(Rotation3<f64>, Vector3<f64>), b: &(Rotation3<f64>, Vector3<f64>)| {
        let scale = a.1.norm().max(b.1.norm());
        a.0.angle_to(&b.0).to_degrees() <= ROTATION_TOLERANCE_DEG
            && (a.1 - b.1).norm()
                <= TRANSLATION_TOLERANCE_MM.max(TRANSLATION_TOLERANCE_SHARE * scale)
    };
    // The view most others agree with, and those.
    let best = (0..each.len())
        .max_by_key(|&i| each.iter().filter(|e| agree(&each[i], e)).count())
        .unwrap_or(0);
    let disagreeing: Vec<usize> = (0..each.len())
        .filter(|&i| !agree(&each[best], &each[i]))
        .collect();
    if !disagreeing.is_empty() {
        // Two views that disagree: nothing says which is right.
        let disagreeing = if each.len() == 2 {
            vec![0, 1]
        } else {
            disagreeing
        };
        let agreeing = each.len() - disagreeing.len();
        return Err(CalibError::SharedViews {
            agreeing,
            views: each.len(),
            disagreeing,
        });
    }
    // Chordal mean: the rotation nearest the sum of the matrices.
    let sum: Matrix3<f64> = each.iter().map(|(r, _)| *r.matrix()).sum();
    let svd = sum.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Err(CalibError::Degenerate("no mean rotation".into()));
    };
    let d = (u * v_t).determinant().signum();
    let mean = Rotation3::from_matrix_unchecked(
        u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * v_t,
    );
    let t = each.iter().map(|(_, t)| t).sum::<Vector3<f64>>() / each.len() as f64;
    let n = each.len() as f64;
    let rot_spread = (each
        .iter()
        .map(|(r, _)| r.angle_to(&mean).powi(2))
        .sum::<f64>()
        / n)
        .sqrt();
    let t_spread = (each
        .iter()
        .map(|(_, ti)| (ti - t).norm_squared())
        .sum::<f64>()
        / n)
        .sqrt();
    let m = mean.matrix();
    Ok(RelativePose {
        rotation: std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)])),
        translation: t.into(),
        shared_views: pairs.len(),
        rotation_spread_deg: rot_spread.to_degrees(),
        translation_spread_mm: t_spread,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pair of board poses that puts the second camera at `rvec`, `t` from the first.
    fn pair(board: f64, rvec: [f64; 3], t: [f64; 3]) -> (BoardPose, BoardPose) {
        let a = BoardPose {
            rotation: Rotation3::from_scaled_axis(Vector3::new(0.1 * board, 0.2, -0.1)),
            translation: Vector3::new(10.0 * board, -5.0, 500.0),
        };
        let r = Rotation3::from_scaled_axis(Vector3::from(rvec));
        let b = BoardPose {
            rotation: r * a.rotation,
            translation: r * a.translation + Vector3::from(t),
        };
        (a, b)
    }

    #[test]
    fn views_that_disagree_are_named() {
        let good = |k: f64| pair(k, [0.0, 0.5, 0.0], [-300.0, 0.0, 80.0]);
        let mut pairs: Vec<_> = (0..5).map(|k| good(k as f64)).collect();
        let rel = relative_pose(&pairs).unwrap();
        assert!(rel.rotation_spread_deg < 1e-9 && rel.translation_spread_mm < 1e-9);
        // A view from another instant: 20° and 150 mm off.
        pairs.push(pair(7.0, [0.0, 0.85, 0.0], [-150.0, 0.0, 80.0]));
        match relative_pose(&pairs) {
            Err(CalibError::SharedViews {
                disagreeing,
                agreeing,
                views,
            }) => assert_eq!((disagreeing, agreeing, views), (vec![5], 5, 6)),
            other => panic!("{other:?}"),
        }
        // Two views that disagree: nothing says which is right.
        match relative_pose(&pairs[4..]) {
            Err(CalibError::SharedViews { disagreeing, .. }) => assert_eq!(disagreeing, [0, 1]),
            other => panic!("{other:?}"),
        }
    }
}
