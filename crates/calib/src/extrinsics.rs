//! Cameras of a rig in one frame, from views of the board they saw at the same instant: each
//! shared view gives camera j's pose relative to camera i (`T_j · T_i⁻¹` of the two board
//! poses); the relative poses are averaged (rotations by their chordal mean, translations by
//! their mean) and chained from the reference camera, with the spread over views reported as a
//! consistency check.

use flexshape_camera::angle_between;
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

/// A board pose in one camera: `x_cam = R·X_board + t` (mm); flexshape's one rigid
/// transform.
pub type BoardPose = flexshape_camera::Pose;

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

/// A camera's pose relative to another: rotation and translation.
type Relative = (Rotation3<f64>, Vector3<f64>);

/// The second camera's pose relative to the first from one board both saw (`a` in the first,
/// `b` in the second).
fn relative(a: &BoardPose, b: &BoardPose) -> Relative {
    let r = b.rotation * a.rotation.inverse();
    (r, b.translation - r * a.translation)
}

/// Whether two relative poses agree within the tolerances.
fn agree(a: &Relative, b: &Relative) -> bool {
    let scale = a.1.norm().max(b.1.norm());
    angle_between(&a.0, &b.0).to_degrees() <= ROTATION_TOLERANCE_DEG
        && (a.1 - b.1).norm() <= TRANSLATION_TOLERANCE_MM.max(TRANSLATION_TOLERANCE_SHARE * scale)
}

/// For a board that looks the same turned half a turn (`half_turn`, see [`crate::Board::half_turn`]),
/// which shared views the second camera labelled the other way round: each view's second pose
/// is taken as detected or turned, whichever agrees with the relative pose that the most views
/// allow either way. `pairs` as for [`relative_pose`].
pub fn half_turned_views(pairs: &[(BoardPose, BoardPose)], half_turn: &BoardPose) -> Vec<bool> {
    let both: Vec<[Relative; 2]> = pairs
        .iter()
        .map(|(a, b)| [relative(a, b), relative(a, &b.then(half_turn))])
        .collect();
    let support = |h: &Relative| {
        both.iter()
            .filter(|e| agree(h, &e[0]) || agree(h, &e[1]))
            .count()
    };
    let Some(best) = both.iter().flatten().max_by_key(|h| support(h)).copied() else {
        return Vec::new();
    };
    both.iter()
        .map(|e| !agree(&best, &e[0]) && agree(&best, &e[1]))
        .collect()
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
    let each: Vec<Relative> = pairs.iter().map(|(a, b)| relative(a, b)).collect();

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
        .map(|(r, _)| angle_between(r, &mean).powi(2))
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

    /// A symmetric board labelled the other way round by the second camera in two of five
    /// views: exactly those are found, and turned they agree.
    #[test]
    fn half_turned_views_are_found() {
        let board = crate::Board::from_spec("circles:7x5", 20.0, None, "").unwrap();
        let h = board.half_turn().unwrap();
        let mut pairs: Vec<_> = (0..5)
            .map(|k| pair(k as f64, [0.0, 0.5, 0.0], [-300.0, 0.0, 80.0]))
            .collect();
        for i in [1, 3] {
            pairs[i].1 = pairs[i].1.then(&h);
        }
        assert!(relative_pose(&pairs).is_err());
        let turned = half_turned_views(&pairs, &h);
        assert_eq!(turned, [false, true, false, true, false]);
        for (p, t) in pairs.iter_mut().zip(&turned) {
            if *t {
                p.1 = p.1.then(&h);
            }
        }
        let rel = relative_pose(&pairs).unwrap();
        assert!(
            rel.rotation_spread_deg < 1e-6 && rel.translation_spread_mm < 1e-6,
            "{rel:?}"
        );
        // Turning twice is no turn.
        let twice = h.then(&h);
        assert!(twice.rotation.angle() < 1e-12 && twice.translation.norm() < 1e-9);
        // Boards that tell their ends apart have no half turn.
        for spec in ["9x6", "acircles:4x11"] {
            assert!(
                crate::Board::from_spec(spec, 20.0, None, "")
                    .unwrap()
                    .half_turn()
                    .is_none()
            );
        }
    }
}
