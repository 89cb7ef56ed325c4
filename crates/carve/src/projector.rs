//! The single-voxel test both carvers share: a camera flattened into plain numbers so that a
//! voxel centre's pixel costs a few dozen flops (no Jacobian, no error values, no libm calls).

use flexshape_camera::{Camera, Distortion};

/// One camera, ready to map voxel centres to mask bit addresses. Agrees with
/// [`Camera::project`] followed by [`flexshape_camera::Intrinsics::pixel_index`] (same
/// formulas; the tests check it).
#[derive(Debug, Clone)]
pub(crate) struct VoxelProjector {
    /// World → camera rotation, row-major.
    pub r: [[f64; 3]; 3],
    /// World → camera translation, mm.
    pub t: [f64; 3],
    pub fx: f64,
    pub fy: f64,
    pub cx: f64,
    pub cy: f64,
    /// k1, k2, k3 (numerator) and k4, k5, k6 (denominator) of the radial factor.
    num: [f64; 3],
    den: [f64; 3],
    tangential: [f64; 2],
    prism: [f64; 4],
    /// The lens model these coefficients come from.
    pub distortion: Distortion,
    /// Whether any distortion coefficient is non-zero (zero ones give the same result faster).
    distorted: bool,
    /// Whether k4, k5 or k6 is non-zero (else the radial factor has no denominator).
    rational: bool,
    /// Squared normalized radius up to which the lens model is one-to-one.
    pub valid_r2: f64,
    pub width: f64,
    pub height: f64,
    /// Bits per mask row (64 × words per row).
    row_bits: usize,
}

impl VoxelProjector {
    pub fn new(cam: &Camera) -> Self {
        let m = cam.pose.rotation.matrix();
        let k = &cam.intrinsics;
        let d = k.distortion;
        let distorted = d
            .radial
            .iter()
            .chain(&d.rational)
            .chain(&d.tangential)
            .chain(&d.prism)
            .any(|&c| c != 0.0);
        VoxelProjector {
            r: std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)])),
            t: [
                cam.pose.translation.x,
                cam.pose.translation.y,
                cam.pose.translation.z,
            ],
            fx: k.fx,
            fy: k.fy,
            cx: k.cx,
            cy: k.cy,
            num: d.radial,
            den: d.rational,
            tangential: d.tangential,
            prism: d.prism,
            distortion: d,
            distorted,
            rational: d.rational.iter().any(|&c| c != 0.0),
            valid_r2: k.valid_radius() * k.valid_radius(),
            width: k.width as f64,
            height: k.height as f64,
            row_bits: 64 * (k.width as usize).div_ceil(64),
        }
    }

    /// Bits per mask row: a bit address is `row_bits · y + x`.
    pub fn row_bits(&self) -> usize {
        self.row_bits
    }

    /// Camera-frame coordinates of a world point, mm.
    #[inline]
    pub fn to_camera(&self, p: [f64; 3]) -> [f64; 3] {
        let r = &self.r;
        std::array::from_fn(|i| r[i][0] * p[0] + r[i][1] * p[1] + r[i][2] * p[2] + self.t[i])
    }

    /// Bit address ([`flexshape_silhouette::BitMask::bit_address`]) of the pixel holding the
    /// world point `p`, or `None` when the camera does not see it (behind, beyond the lens
    /// fold, or off the image).
    #[inline]
    pub fn bit_address(&self, p: [f64; 3]) -> Option<u32> {
        let (seen, address) = self.address(p);
        seen.then_some(address)
    }

    /// Whether the camera sees `p`, and if so the bit address of its pixel (0 otherwise).
    /// Branch-free, so that a block of voxels can be projected in one straight loop; every
    /// caller goes through here, so all carvers agree to the last bit.
    #[inline(always)]
    pub fn address(&self, p: [f64; 3]) -> (bool, u32) {
        let c = self.to_camera(p);
        let iz = 1.0 / c[2];
        let (x, y) = (c[0] * iz, c[1] * iz);
        let r2 = x * x + y * y;
        let (xd, yd) = if self.distorted {
            self.distort(x, y, r2)
        } else {
            (x, y)
        };
        let u = self.fx * xd + self.cx + 0.5;
        let v = self.fy * yd + self.cy + 0.5;
        // Comparisons are false for NaN, so NaN depths and coordinates are unseen.
        let seen = (c[2] > 0.0)
            & (r2 <= self.valid_r2)
            & (u >= 0.0)
            & (v >= 0.0)
            & (u < self.width)
            & (v < self.height);
        // u, v ≥ 0 when seen, so truncation is the floor (and needs no libm call).
        let address = self
            .row_bits
            .wrapping_mul(v as usize)
            .wrapping_add(u as usize) as u32;
        (seen, if seen { address } else { 0 })
    }

    /// OpenCV's distortion of the normalized point `(x, y)` with `r2 = x² + y²`.
    #[inline]
    fn distort(&self, x: f64, y: f64, r2: f64) -> (f64, f64) {
        let [k1, k2, k3] = self.num;
        let [k4, k5, k6] = self.den;
        let [p1, p2] = self.tangential;
        let [s1, s2, s3, s4] = self.prism;
        let num = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
        let g = if self.rational {
            num / (1.0 + r2 * (k4 + r2 * (k5 + r2 * k6)))
        } else {
            num
        };
        let xd = x * g + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x) + r2 * (s1 + s2 * r2);
        let yd = y * g + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y + r2 * (s3 + s4 * r2);
        (xd, yd)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use flexshape_camera::nalgebra::{Point3, Vector3};
    use flexshape_camera::{Intrinsics, Pose};
    use rand::rngs::Xoshiro256PlusPlus;
    use rand::{RngExt, SeedableRng};

    /// Same pixel as the camera crate's projection for points away from pixel borders.
    #[test]
    fn agrees_with_camera_projection() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(7);
        let lenses = [
            Distortion::default(),
            Distortion::from_opencv(&[-0.3, 0.12, 0.001, -0.002, -0.02]).unwrap(),
            Distortion::from_opencv(&[0.2, -0.1, 0.0, 0.0, 0.01, 0.3, -0.05, 0.02]).unwrap(),
        ];
        for d in lenses {
            let k = Intrinsics::new(640, 480, 700.0, 720.0, 330.0, 235.0, d).unwrap();
            let pose = Pose::look_at(
                Point3::new(400.0, -300.0, 250.0),
                Point3::origin(),
                Vector3::z(),
            );
            let cam = Camera::new(k, pose);
            let proj = VoxelProjector::new(&cam);
            let mut seen = 0;
            for _ in 0..20_000 {
                let p = Point3::new(
                    rng.random_range(-400.0..400.0),
                    rng.random_range(-400.0..400.0),
                    rng.random_range(-400.0..400.0),
                );
                let expected = cam.project(&p).ok().and_then(|pr| {
                    let px = pr.pixel;
                    let frac =
                        |a: f64| (a + 0.5 - (a + 0.5).floor()).min((a + 0.5).ceil() - a - 0.5);
                    // Skip points within 1e-6 px of a pixel border: rounding may differ there.
                    (frac(px.x) > 1e-6 && frac(px.y) > 1e-6).then_some(())?;
                    let (x, y) = cam.intrinsics.pixel_index(px)?;
                    Some(Some(64 * 10 * y + x))
                });
                if let Some(e) = expected {
                    assert_eq!(proj.bit_address([p.x, p.y, p.z]), e, "{p:?}");
                    seen += 1;
                } else if cam.project(&p).is_err() {
                    assert_eq!(proj.bit_address([p.x, p.y, p.z]), None, "{p:?}");
                }
            }
            assert!(seen > 2000, "only {seen} points in view");
        }
    }
}
