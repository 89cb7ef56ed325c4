//! Cameras from the Middlebury multi-view stereo `*_par.txt` format (Seitz et al.): a line
//! with the number of views, then one line per view,
//! `image.png k11 k12 k13 k21 k22 k23 k31 k32 k33 r11 … r33 t1 t2 t3`, the projection being
//! `K·[R t]` with `x_cam = R·X + t` (OpenCV's convention) and no lens distortion. The image
//! size is not in the file and the lengths are in the data set's unit (metres for the
//! Middlebury sets), so both are arguments.

use std::path::Path;

use flexshape_camera::nalgebra::{Matrix3, Vector3};
use flexshape_camera::{Camera, Distortion, Intrinsics, Pose};

use crate::RigError;

/// One view of a `*_par.txt` file.
#[derive(Debug, Clone)]
pub struct ParView {
    /// The image file name as written in the file.
    pub image: String,
    /// The camera, its translation scaled to millimetres.
    pub camera: Camera,
}

/// Reads a `*_par.txt` file whose images are `width × height` and whose lengths are
/// `mm_per_unit` millimetres (1000 for metres).
pub fn read_par(
    path: &Path,
    width: u32,
    height: u32,
    mm_per_unit: f64,
) -> Result<Vec<ParView>, RigError> {
    let text = crate::files::read_text(path, "Middlebury file").map_err(RigError::from)?;
    parse_par(path, &text, width, height, mm_per_unit)
}

/// Parses the text of a `*_par.txt` file (`path` names it in errors).
pub fn parse_par(
    path: &Path,
    text: &str,
    width: u32,
    height: u32,
    mm_per_unit: f64,
) -> Result<Vec<ParView>, RigError> {
    if !(mm_per_unit.is_finite() && mm_per_unit > 0.0) {
        return Err(RigError::field(
            path,
            "mm_per_unit",
            format!("{mm_per_unit} must be a positive number (1000 for metres)"),
        ));
    }
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let count: usize = match lines.next() {
        Some((_, l)) => l.trim().parse().map_err(|_| {
            RigError::field(path, "line 1", format!("`{l}` is not the number of views"))
        })?,
        None => return Err(RigError::field(path, "line 1", "the file is empty")),
    };
    // The count is the file's word: room is made for the views that follow, not for it.
    let mut views = Vec::new();
    for (n, line) in lines {
        let field = format!("line {}", n + 1);
        let mut words = line.split_whitespace();
        let image = words.next().unwrap_or_default().to_string();
        let numbers: Vec<f64> = words
            .map(|w| w.parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|e| RigError::field(path, &field, format!("not a number: {e}")))?;
        if numbers.len() != 21 {
            return Err(RigError::field(
                path,
                &field,
                format!(
                    "expected an image name and 21 numbers (K, R, t), found {}",
                    numbers.len()
                ),
            ));
        }
        let k = Matrix3::from_row_slice(&numbers[0..9]);
        let r = Matrix3::from_row_slice(&numbers[9..18]);
        let t = Vector3::new(numbers[18], numbers[19], numbers[20]) * mm_per_unit;
        let bad = |what: &str, e: flexshape_camera::CameraError| {
            RigError::field(path, &field, format!("{what}: {e}"))
        };
        if k[(2, 0)] != 0.0 || k[(2, 1)] != 0.0 || k[(2, 2)] != 1.0 {
            return Err(RigError::field(
                path,
                &field,
                "the last row of K must be 0 0 1",
            ));
        }
        let intrinsics = Intrinsics::from_matrix(width, height, &k, Distortion::default())
            .map_err(|e| bad("K", e))?;
        let pose = Pose::from_matrix(&nearest_orthonormal(&r), t).map_err(|e| bad("R", e))?;
        views.push(ParView {
            image,
            camera: Camera::new(intrinsics, pose),
        });
    }
    if views.len() != count {
        return Err(RigError::field(
            path,
            "line 1",
            format!("announces {count} views but {} follow", views.len()),
        ));
    }
    Ok(views)
}

/// The published rotations are orthonormal to about 1e-6 only (dinoSparseRing: ‖RᵀR − I‖ up
/// to 1.4e-6, beyond [`Pose::from_matrix`]'s tolerance): those within 1e-4 are replaced by the
/// nearest orthonormal matrix (`U·Vᵀ` of their SVD); others are left for `from_matrix` to
/// reject.
fn nearest_orthonormal(r: &Matrix3<f64>) -> Matrix3<f64> {
    if (r.transpose() * r - Matrix3::identity()).amax() > 1e-4 {
        return *r;
    }
    let svd = r.svd(true, true);
    match (svd.u, svd.v_t) {
        (Some(u), Some(v_t)) => u * v_t,
        _ => *r,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use flexshape_camera::nalgebra::Point3;

    const TWO: &str = "2
a.png 1000 0 320 0 1010 240 0 0 1 1 0 0 0 1 0 0 0 1 0.01 -0.02 0.5
b.png 1000 0 320 0 1010 240 0 0 1 0 1 0 -1 0 0 0 0 1 0 0 0.6
";

    #[test]
    fn reads_views_in_millimetres() {
        let views = parse_par(Path::new("x_par.txt"), TWO, 640, 480, 1000.0).unwrap();
        assert_eq!(views.len(), 2);
        assert_eq!(views[1].image, "b.png");
        let cam = &views[0].camera;
        assert_eq!(cam.intrinsics.fy, 1010.0);
        assert_eq!(cam.pose.translation, Vector3::new(10.0, -20.0, 500.0));
        // The world origin projects to K·t / t_z.
        let p = cam.project(&Point3::origin()).unwrap().pixel;
        assert!((p.x - (320.0 + 1000.0 * 10.0 / 500.0)).abs() < 1e-9);
        assert!((p.y - (240.0 - 1010.0 * 20.0 / 500.0)).abs() < 1e-9);
    }

    #[test]
    fn errors_name_the_line() {
        let p = Path::new("x_par.txt");
        let short = TWO.replace(" 0.6\n", "\n");
        let e = parse_par(p, &short, 640, 480, 1000.0).unwrap_err();
        assert!(e.to_string().contains("line 3") && e.to_string().contains("found 20"));
        let e = parse_par(p, &TWO.replace("2\n", "3\n"), 640, 480, 1000.0).unwrap_err();
        assert!(e.to_string().contains("announces 3 views but 2"));
        // A count of 10¹⁸ panicked on the allocation made for it ("capacity overflow").
        for huge in ["1000000000000000000\n", "18446744073709551615\n"] {
            let e = parse_par(p, &TWO.replace("2\n", huge), 640, 480, 1000.0).unwrap_err();
            assert!(e.to_string().contains("views but 2"), "{e}");
        }
        let reflected = TWO.replace("0 1 0 -1 0 0 0 0 1", "0 1 0 1 0 0 0 0 1");
        let e = parse_par(p, &reflected, 640, 480, 1000.0).unwrap_err();
        assert!(
            e.to_string().contains("line 3") && e.to_string().contains("R"),
            "{e}"
        );
        assert!(parse_par(p, "", 640, 480, 1000.0).is_err());
        // Slightly off orthonormal, as published rotations are: accepted and repaired.
        let rough = TWO.replace("0 1 0 -1 0 0 0 0 1", "0 1.000002 0 -1 0 0 0 0 1");
        let r = parse_par(p, &rough, 640, 480, 1000.0).unwrap()[1]
            .camera
            .pose
            .rotation;
        assert!((r.matrix().transpose() * r.matrix() - Matrix3::identity()).amax() < 1e-12);
        assert!(parse_par(p, TWO, 640, 480, 0.0).is_err());
    }
}
