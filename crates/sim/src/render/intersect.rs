//! Ray intersection with the scene's primitives (capsules and spheres) and segment distances.
//! All in one frame (the camera's); ray directions are unit vectors.

use flexshape_camera::nalgebra::Vector3;

/// One capsule of a tube: the swept sphere of radius `radius` along `a → b`, whose arc lengths
/// along the tube's centerline are `s_a`, `s_b`. Every ray the renderer casts starts at the
/// camera centre (the origin of the capsule's frame), so what does not depend on the ray's
/// direction is computed once here rather than for each of the ~17 rays of a pixel.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Capsule {
    pub a: Vector3<f64>,
    pub b: Vector3<f64>,
    pub radius: f64,
    pub s_a: f64,
    pub s_b: f64,
    pub tube: usize,
    /// `b − a`.
    ba: Vector3<f64>,
    /// The origin seen from `a`: `−a`.
    oa: Vector3<f64>,
    /// The origin seen from `b`: `−b`.
    ob: Vector3<f64>,
    /// `|ba|²`.
    baba: f64,
    /// `ba · oa`.
    baoa: f64,
    /// The cylinder's ray-independent term `|ba|²·|oa|² − (ba·oa)² − r²·|ba|²`.
    qc: f64,
    /// The end spheres' ray-independent terms `|oa|² − r²`, `|ob|² − r²`.
    end_c: [f64; 2],
}

impl Capsule {
    pub fn new(
        a: Vector3<f64>,
        b: Vector3<f64>,
        radius: f64,
        s_a: f64,
        s_b: f64,
        tube: usize,
    ) -> Capsule {
        let origin = Vector3::zeros();
        let ba = b - a;
        let oa = origin - a;
        let ob = origin - b;
        let baba = ba.norm_squared();
        let baoa = ba.dot(&oa);
        let r2 = radius * radius;
        Capsule {
            a,
            b,
            radius,
            s_a,
            s_b,
            tube,
            ba,
            oa,
            ob,
            baba,
            baoa,
            qc: baba * oa.norm_squared() - baoa * baoa - r2 * baba,
            end_c: [oa.norm_squared() - r2, ob.norm_squared() - r2],
        }
    }
}

/// Nearest positive hit distance of the ray `o + t·d` with a sphere.
pub(crate) fn ray_sphere(
    o: &Vector3<f64>,
    d: &Vector3<f64>,
    c: &Vector3<f64>,
    r: f64,
) -> Option<f64> {
    let oc = o - c;
    sphere_hit(d.dot(&oc), oc.norm_squared() - r * r)
}

/// The nearest positive root of `t² + 2·b·t + c = 0` (a unit ray `o + t·d` and a sphere, with
/// `b = d·(o − centre)` and `c = |o − centre|² − r²`).
#[inline]
fn sphere_hit(b: f64, c: f64) -> Option<f64> {
    let h = b * b - c;
    if h < 0.0 {
        return None;
    }
    let t = -b - h.sqrt();
    (t > 0.0).then_some(t)
}

/// Nearest positive hit distance of the ray `t·d` from the origin with a capsule.
///
/// The ray is first intersected with the infinite cylinder around the axis; if it enters the
/// cylinder beside the segment the hit is on the body, otherwise it can only enter through the
/// end sphere on that side (a ray that misses the infinite cylinder misses the capsule).
#[inline]
pub(crate) fn ray_capsule(d: &Vector3<f64>, cap: &Capsule) -> Option<f64> {
    let bard = cap.ba.dot(d);
    let rdoa = d.dot(&cap.oa);
    let qa = cap.baba - bard * bard;
    if qa <= 1e-12 * cap.baba {
        // Ray parallel to the axis: only the end spheres can be entered first.
        let ta = sphere_hit(rdoa, cap.end_c[0]);
        let tb = sphere_hit(d.dot(&cap.ob), cap.end_c[1]);
        return match (ta, tb) {
            (Some(x), Some(y)) => Some(x.min(y)),
            (x, y) => x.or(y),
        };
    }
    let qb = cap.baba * rdoa - cap.baoa * bard;
    let h = qb * qb - qa * cap.qc;
    if h < 0.0 {
        return None;
    }
    let t = (-qb - h.sqrt()) / qa;
    let y = cap.baoa + t * bard;
    if y > 0.0 && y < cap.baba {
        return (t > 0.0).then_some(t);
    }
    if y <= 0.0 {
        sphere_hit(rdoa, cap.end_c[0])
    } else {
        sphere_hit(d.dot(&cap.ob), cap.end_c[1])
    }
}

/// Closest point on segment `a → b` to `p`, as the parameter in `[0, 1]`.
pub(crate) fn closest_on_segment(p: &Vector3<f64>, a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    let ab = b - a;
    let l2 = ab.norm_squared();
    if l2 == 0.0 {
        return 0.0;
    }
    ((p - a).dot(&ab) / l2).clamp(0.0, 1.0)
}

/// Distance between segments `p0 → p1` and `q0 → q1`, and the parameter on the first.
pub(crate) fn segment_distance(
    p0: &Vector3<f64>,
    p1: &Vector3<f64>,
    q0: &Vector3<f64>,
    q1: &Vector3<f64>,
) -> (f64, f64) {
    let u = p1 - p0;
    let v = q1 - q0;
    let w = p0 - q0;
    let a = u.norm_squared();
    let b = u.dot(&v);
    let c = v.norm_squared();
    let d = u.dot(&w);
    let e = v.dot(&w);
    let den = a * c - b * b;
    // Parameter on the first segment for the infinite lines, then clamp and re-solve.
    let mut s = if den > 1e-12 * a * c {
        ((b * e - c * d) / den).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let t = if c > 0.0 {
        ((b * s + e) / c).clamp(0.0, 1.0)
    } else {
        0.0
    };
    if a > 0.0 {
        s = ((b * t - d) / a).clamp(0.0, 1.0);
    }
    ((p0 + u * s - (q0 + v * t)).norm(), s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cap(a: [f64; 3], b: [f64; 3], r: f64) -> Capsule {
        Capsule::new(Vector3::from(a), Vector3::from(b), r, 0.0, 1.0, 0)
    }

    #[test]
    fn capsule_body_caps_and_misses() {
        let c = cap([-10.0, 0.0, 100.0], [10.0, 0.0, 100.0], 3.0);
        // Straight at the body: hits the near surface.
        let t = ray_capsule(&Vector3::z(), &c).unwrap();
        assert!((t - 97.0).abs() < 1e-12);
        // Beyond the end but within the end sphere.
        let d = Vector3::new(12.0, 0.0, 100.0).normalize();
        let t = ray_capsule(&d, &c).unwrap();
        let p = d * t;
        assert!(((p - c.b).norm() - 3.0).abs() < 1e-9);
        // Past the sphere: miss.
        let d = Vector3::new(13.5, 0.0, 100.0).normalize();
        assert!(ray_capsule(&d, &c).is_none());
        // Along the axis.
        let c2 = cap([0.0, 0.0, 50.0], [0.0, 0.0, 80.0], 2.0);
        assert!((ray_capsule(&Vector3::z(), &c2).unwrap() - 48.0).abs() < 1e-12);
        // Behind the ray origin: miss.
        assert!(ray_capsule(&-Vector3::z(), &c).is_none());
    }

    #[test]
    fn segment_distance_cases() {
        let z = |x, y, zz| Vector3::new(x, y, zz);
        let (d, s) = segment_distance(
            &z(0.0, 0.0, 0.0),
            &z(10.0, 0.0, 0.0),
            &z(5.0, -5.0, 2.0),
            &z(5.0, 5.0, 2.0),
        );
        assert!((d - 2.0).abs() < 1e-12 && (s - 0.5).abs() < 1e-12);
        let (d, _) = segment_distance(
            &z(0.0, 0.0, 0.0),
            &z(1.0, 0.0, 0.0),
            &z(3.0, 0.0, 0.0),
            &z(4.0, 0.0, 0.0),
        );
        assert!((d - 2.0).abs() < 1e-12);
        let (d, _) = segment_distance(
            &z(0.0, 0.0, 0.0),
            &z(10.0, 0.0, 0.0),
            &z(0.0, 1.0, 0.0),
            &z(10.0, 1.0, 0.0),
        );
        assert!((d - 1.0).abs() < 1e-12);
    }
}
