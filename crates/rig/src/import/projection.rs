//! Cameras from 3×4 projection matrices, `P ≅ K·[R | t]` (any scale and sign): the form most
//! tools exchange, without lens distortion. `P`'s left 3×3 block is split into an upper
//! triangular `K` with positive focal lengths and a rotation `R` (RQ decomposition); `P` is
//! negated first when that block's determinant is negative, so `R` is right-handed and the
//! scene lies in front of the camera; `t = K⁻¹·p₄`. OpenCV's model has no skew: a skew
//! moving no pixel of the image by more than [`MAX_SKEW_SHIFT_PX`] is dropped, a larger one
//! refused.
//!
//! Files: a text file of 12 numbers (3 rows of 4; commas, brackets and `;` ignored) is one
//! camera named after the file; a text file of `NAME: 12 numbers` lines (KITTI's `calib.txt`)
//! one camera per line — a line whose matrix is a rigid transform (`Tr_velo_to_cam`), not a
//! projection, is skipped; a NumPy `.npy` array of shape (3, 4) is one camera, (N, 3, 4) N
//! cameras `NAME0 …`.

use std::path::Path;

use flexshape_camera::nalgebra::{Matrix3, Matrix3x4, Vector3};
use flexshape_camera::{Camera, Distortion, Intrinsics, Pose};

use super::{Imported, Unit, camera_error, finite, npy, sanitize};
use crate::RigError;

/// Largest pixel shift anywhere in the image that dropping a projection's skew may cause.
pub const MAX_SKEW_SHIFT_PX: f64 = 0.05;

/// The camera of projection matrix `p` whose image is `width × height` pixels and whose
/// lengths are in `unit` (`path` and `field` name it in errors).
pub fn decompose(
    p: &Matrix3x4<f64>,
    width: u32,
    height: u32,
    unit: Unit,
    path: &Path,
    field: &str,
) -> Result<Camera, RigError> {
    for v in p.iter() {
        finite(path, field, *v)?;
    }
    let mut m: Matrix3<f64> = p.fixed_view::<3, 3>(0, 0).into_owned();
    let mut p4: Vector3<f64> = p.column(3).into_owned();
    let det = m.determinant();
    let scale = m.norm();
    if det.abs() <= 1e-12 * scale.powi(3) {
        return Err(RigError::field(
            path,
            field,
            "the left 3×3 block is singular: not a camera's projection matrix",
        ));
    }
    if det < 0.0 {
        m = -m;
        p4 = -p4;
    }
    let (k, r) = rq(&m);
    let s = k[(2, 2)];
    let k = k / s;
    let skew = k[(0, 1)];
    // Dropping the skew moves a pixel by skew · y, y its normalized height.
    let reach = (0.5 + k[(1, 2)].abs().max((height as f64 - 0.5 - k[(1, 2)]).abs())) / k[(1, 1)];
    if skew.abs() * reach > MAX_SKEW_SHIFT_PX {
        return Err(RigError::field(
            path,
            field,
            format!(
                "skew {skew:.3} px would move pixels by up to {:.2} px if dropped (OpenCV's model has none; at most {MAX_SKEW_SHIFT_PX} px)",
                skew.abs() * reach
            ),
        ));
    }
    let Some(k_inv) = k.try_inverse() else {
        return Err(RigError::field(path, field, "K is singular"));
    };
    let t = k_inv * p4 / s * unit.mm();
    let mut k_no_skew = k;
    k_no_skew[(0, 1)] = 0.0;
    let intrinsics = Intrinsics::from_matrix(width, height, &k_no_skew, Distortion::NONE)
        .map_err(|e| camera_error(path, field, e))?;
    let pose = Pose::from_matrix(&r, t).map_err(|e| camera_error(path, field, e))?;
    Ok(Camera::new(intrinsics, pose))
}

/// `m = K·R` with `K` upper triangular with a positive diagonal and `R` orthogonal (a rotation
/// when `det m > 0`).
fn rq(m: &Matrix3<f64>) -> (Matrix3<f64>, Matrix3<f64>) {
    // With J the row reversal, (J·m)ᵀ = Q·U gives m = (J·Uᵀ·J)·(J·Qᵀ), J·Uᵀ·J upper triangular.
    let j = Matrix3::new(0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0);
    let qr = (j * m).transpose().qr();
    let (q, u) = (qr.q(), qr.r());
    let mut k = j * u.transpose() * j;
    let mut r = j * q.transpose();
    for i in 0..3 {
        if k[(i, i)] < 0.0 {
            // K·D and D·R with D = diag(±1), D² = I.
            k.column_mut(i).neg_mut();
            r.row_mut(i).neg_mut();
        }
    }
    (k, r)
}

/// The cameras of a projection-matrix file (see the module docs), each `width × height`
/// pixels, lengths in `unit`. Also returns the names of `NAME:` lines skipped as rigid
/// transforms.
pub fn read(
    path: &Path,
    width: u32,
    height: u32,
    unit: Unit,
) -> Result<(Vec<Imported>, Vec<String>), RigError> {
    let stem = sanitize(path.file_stem().and_then(|s| s.to_str()).unwrap_or("cam"));
    let bytes = crate::files::read_bytes(path, crate::files::MAX_TEXT_BYTES, "projection file")?;
    let camera = |values: &[f64], field: &str| {
        let p = Matrix3x4::from_row_slice(values);
        decompose(&p, width, height, unit, path, field)
    };
    if path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("npy"))
    {
        let a = npy::parse(path, &bytes)?;
        return match a.shape.as_slice() {
            [3, 4] => Ok((
                vec![Imported {
                    name: stem,
                    camera: camera(&a.data, "P")?,
                }],
                Vec::new(),
            )),
            [n, 3, 4] => {
                let cams = (0..*n)
                    .map(|i| {
                        Ok(Imported {
                            name: format!("{stem}{i}"),
                            camera: camera(&a.data[12 * i..12 * i + 12], &format!("P[{i}]"))?,
                        })
                    })
                    .collect::<Result<_, RigError>>()?;
                Ok((cams, Vec::new()))
            }
            other => Err(RigError::field(
                path,
                "shape",
                format!("{other:?}: a projection matrix is (3, 4), N of them (N, 3, 4)"),
            )),
        };
    }
    let text = String::from_utf8_lossy(&bytes);
    let named: Vec<(&str, &str)> = text
        .lines()
        .filter_map(|l| l.split_once(':'))
        .map(|(n, v)| (n.trim(), v))
        .filter(|(n, _)| !n.is_empty() && !n.contains(char::is_whitespace))
        .collect();
    if named.is_empty() {
        let values = numbers(path, &text, "P")?;
        if values.len() != 12 {
            return Err(RigError::field(
                path,
                "P",
                format!(
                    "{} numbers: a projection matrix has 12 (3 rows of 4), or give NAME: lines of 12",
                    values.len()
                ),
            ));
        }
        let camera = camera(&values, "P")?;
        return Ok((vec![Imported { name: stem, camera }], Vec::new()));
    }
    let (mut cams, mut skipped) = (Vec::new(), Vec::new());
    for (name, rest) in named {
        let values = numbers(path, rest, name)?;
        if values.len() != 12 {
            skipped.push(format!("{name} ({} numbers, not 12)", values.len()));
            continue;
        }
        // A NaN compares false and passed for a rigid transform: skipped, not refused.
        for v in &values {
            finite(path, name, *v)?;
        }
        let m = Matrix3x4::from_row_slice(&values);
        let block = m.fixed_view::<3, 3>(0, 0);
        if (block * block.transpose() - Matrix3::identity()).amax() < 1e-3 {
            skipped.push(format!("{name} (a rigid transform, not a projection)"));
            continue;
        }
        cams.push(Imported {
            name: sanitize(name),
            camera: camera(&values, name)?,
        });
    }
    if cams.is_empty() {
        return Err(RigError::field(
            path,
            "P",
            format!(
                "no projection matrix among the lines ({})",
                skipped.join(", ")
            ),
        ));
    }
    Ok((cams, skipped))
}

/// The numbers of `text`, separated by white space, commas or `;`, brackets ignored.
fn numbers(path: &Path, text: &str, field: &str) -> Result<Vec<f64>, RigError> {
    text.split(|c: char| c.is_whitespace() || matches!(c, ',' | ';' | '[' | ']' | '(' | ')'))
        .filter(|s| !s.is_empty())
        .map(|s| {
            s.parse::<f64>()
                .map_err(|_| RigError::field(path, field, format!("`{s}` is not a number")))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use flexshape_camera::nalgebra::Point3;

    use super::*;

    fn camera() -> Camera {
        let intrinsics =
            Intrinsics::new(640, 480, 812.5, 790.0, 331.2, 245.7, Distortion::NONE).unwrap();
        let pose = Pose::from_rvec_tvec(
            Vector3::new(0.3, -1.1, 0.2),
            Vector3::new(-40.0, 25.0, 610.0),
        );
        Camera::new(intrinsics, pose)
    }

    fn projection(c: &Camera) -> Matrix3x4<f64> {
        let mut rt = Matrix3x4::zeros();
        rt.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(c.pose.rotation.matrix());
        rt.set_column(3, &c.pose.translation);
        c.intrinsics.matrix() * rt
    }

    #[test]
    fn recovers_k_r_t_from_p_at_any_scale_and_sign() {
        let c = camera();
        for s in [1.0, -0.003, 250.0] {
            let p = projection(&c) * s;
            let got = decompose(&p, 640, 480, Unit::Millimetre, Path::new("p.txt"), "P").unwrap();
            let i = &got.intrinsics;
            assert!(
                (i.fx - 812.5).abs() < 1e-9 && (i.fy - 790.0).abs() < 1e-9,
                "{i:?}"
            );
            assert!((i.cx - 331.2).abs() < 1e-9 && (i.cy - 245.7).abs() < 1e-9);
            let dr = got.pose.rotation.matrix() - c.pose.rotation.matrix();
            assert!(dr.amax() < 1e-12, "{dr}");
            assert!((got.pose.translation - c.pose.translation).norm() < 1e-9);
            let x = Point3::new(30.0, -20.0, 40.0);
            let d = got.project(&x).unwrap().pixel - c.project(&x).unwrap().pixel;
            assert!(d.norm() < 1e-9);
        }
        // Metres: the translation in millimetres.
        let mut p = projection(&c);
        p.set_column(3, &(p.column(3) / 1000.0));
        let got = decompose(&p, 640, 480, Unit::Metre, Path::new("p.txt"), "P").unwrap();
        assert!((got.pose.translation - c.pose.translation).norm() < 1e-9);
    }

    #[test]
    fn refuses_a_singular_matrix_and_a_large_skew() {
        let e = decompose(
            &Matrix3x4::zeros(),
            640,
            480,
            Unit::Millimetre,
            Path::new("z.txt"),
            "P",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("z.txt") && e.contains("singular"), "{e}");
        let c = camera();
        let mut k = c.intrinsics.matrix();
        k[(0, 1)] = 2.0;
        let mut rt = Matrix3x4::zeros();
        rt.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(c.pose.rotation.matrix());
        rt.set_column(3, &c.pose.translation);
        let e = decompose(
            &(k * rt),
            640,
            480,
            Unit::Millimetre,
            Path::new("s.txt"),
            "P",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("skew"), "{e}");
    }

    #[test]
    fn reads_plain_and_named_line_files() {
        let dir = tempfile::tempdir().unwrap();
        let p = projection(&camera());
        let row = |r: usize| {
            (0..4)
                .map(|c| format!("{:.17e}", p[(r, c)]))
                .collect::<Vec<_>>()
                .join(" ")
        };
        let plain = dir.path().join("left cam.txt");
        std::fs::write(&plain, format!("[{}\n {}\n {}]\n", row(0), row(1), row(2))).unwrap();
        let (cams, _) = read(&plain, 640, 480, Unit::Millimetre).unwrap();
        assert_eq!(cams.len(), 1);
        assert_eq!(cams[0].name, "left_cam");
        let kitti = dir.path().join("calib.txt");
        let all = format!("{} {} {}", row(0), row(1), row(2));
        std::fs::write(
            &kitti,
            format!(
                "P0: {all}\nP1: {all}\nR0_rect: 1 0 0 0 1 0 0 0 1\nTr_velo_to_cam: 0 -1 0 0.1 0 0 -1 0.2 1 0 0 0.3\n"
            ),
        )
        .unwrap();
        let (cams, skipped) = read(&kitti, 640, 480, Unit::Metre).unwrap();
        assert_eq!(
            cams.iter().map(|c| c.name.as_str()).collect::<Vec<_>>(),
            ["P0", "P1"]
        );
        assert_eq!(skipped.len(), 2, "{skipped:?}");
        std::fs::write(&plain, "1 2 3\n").unwrap();
        let e = read(&plain, 640, 480, Unit::Millimetre)
            .unwrap_err()
            .to_string();
        assert!(e.contains("3 numbers"), "{e}");
        // A line holding a NaN is an error naming it, not "a rigid transform" passed over.
        std::fs::write(
            &kitti,
            format!("P0: {all}\nTr: 0 -1 0 0.1 0 0 -1 0.2 1 0 0 nan\n"),
        )
        .unwrap();
        let e = read(&kitti, 640, 480, Unit::Metre).unwrap_err().to_string();
        assert!(
            e.contains("Tr") && e.contains("NaN is not a finite number"),
            "{e}"
        );
    }
}
