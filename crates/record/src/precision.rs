//! Numbers in the records to the precision that matters, not to the 17 digits a double
//! prints with: positions and lengths to 0.1 µm, unit vectors to 1e-7, curvatures to
//! 1e-9 /mm and strains to 1e-9 (a millionth of a typical 0.01 /mm, far below what stiffness
//! fits amplify to matter), durations to a microsecond; capture and processing times keep
//! every digit. A record shrinks to about half. Only what is written is
//! rounded; the values in memory keep every digit. Used as `#[serde(serialize_with)]`.

use serde::{Serialize, Serializer};

/// `x` rounded to `decimals` places (non-finite values as they are).
fn round(x: f64, decimals: i32) -> f64 {
    if !x.is_finite() {
        return x;
    }
    let scale = 10f64.powi(decimals);
    let r = (x * scale).round() / scale;
    // Beyond 2⁵³ / scale the product has no fraction left to round.
    if r.is_finite() { r } else { x }
}

fn rounded<S: Serializer, T: Serialize>(value: T, s: S) -> Result<S::Ok, S::Error> {
    value.serialize(s)
}

const MM: i32 = 4;
const UNIT: i32 = 7;
const PER_MM: i32 = 9;
const MS: i32 = 3;

/// A length or coordinate, mm.
pub(crate) fn mm<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
    rounded(round(*v, MM), s)
}

/// An optional length, mm.
pub(crate) fn mm_opt<S: Serializer>(v: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
    rounded(v.map(|x| round(x, MM)), s)
}

/// Lengths, mm.
pub(crate) fn mm_vec<S: Serializer>(v: &[f64], s: S) -> Result<S::Ok, S::Error> {
    s.collect_seq(v.iter().map(|&x| round(x, MM)))
}

/// Radius steps, their places and radii in mm.
pub(crate) fn steps<S: Serializer>(
    v: &[flexshape_curve::RadiusStep],
    s: S,
) -> Result<S::Ok, S::Error> {
    s.collect_seq(v.iter().map(|step| flexshape_curve::RadiusStep {
        from_tip_mm: round(step.from_tip_mm, MM),
        radius_mm: round(step.radius_mm, MM),
    }))
}

/// A point, mm.
pub(crate) fn point<S: Serializer>(v: &[f64; 3], s: S) -> Result<S::Ok, S::Error> {
    rounded(v.map(|x| round(x, MM)), s)
}

/// An optional point, mm.
pub(crate) fn point_opt<S: Serializer>(v: &Option<[f64; 3]>, s: S) -> Result<S::Ok, S::Error> {
    rounded(v.map(|p| p.map(|x| round(x, MM))), s)
}

/// Points, mm.
pub(crate) fn points<S: Serializer>(v: &[[f64; 3]], s: S) -> Result<S::Ok, S::Error> {
    s.collect_seq(v.iter().map(|p| p.map(|x| round(x, MM))))
}

/// A unit vector.
pub(crate) fn unit<S: Serializer>(v: &[f64; 3], s: S) -> Result<S::Ok, S::Error> {
    rounded(v.map(|x| round(x, UNIT)), s)
}

/// An optional unit vector.
pub(crate) fn unit_opt<S: Serializer>(v: &Option<[f64; 3]>, s: S) -> Result<S::Ok, S::Error> {
    rounded(v.map(|p| p.map(|x| round(x, UNIT))), s)
}

/// A curvature, 1/mm.
pub(crate) fn per_mm<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
    rounded(round(*v, PER_MM), s)
}

/// An optional curvature, 1/mm.
pub(crate) fn per_mm_opt<S: Serializer>(v: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
    rounded(v.map(|x| round(x, PER_MM)), s)
}

/// A dimensionless fraction (a strain).
pub(crate) fn fraction<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
    rounded(round(*v, PER_MM), s)
}

/// Curvatures, 1/mm.
pub(crate) fn per_mm_vec<S: Serializer>(v: &[f64], s: S) -> Result<S::Ok, S::Error> {
    s.collect_seq(v.iter().map(|&x| round(x, PER_MM)))
}

/// A duration, ms.
pub(crate) fn ms<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
    rounded(round(*v, MS), s)
}

/// An optional duration, ms.
pub(crate) fn ms_opt<S: Serializer>(v: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
    rounded(v.map(|x| round(x, MS)), s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Serialize)]
    struct Sample {
        #[serde(serialize_with = "points")]
        p: Vec<[f64; 3]>,
        #[serde(serialize_with = "per_mm_vec")]
        k: Vec<f64>,
        #[serde(serialize_with = "mm_opt")]
        none: Option<f64>,
    }

    #[test]
    fn written_numbers_keep_the_digits_that_matter() {
        let s = Sample {
            p: vec![[-127.99999999999925, 0.036572419876543, 1e-12]],
            k: vec![0.012345678912345, f64::NAN],
            none: None,
        };
        let text = serde_json::to_string(&s).unwrap();
        assert_eq!(
            text,
            r#"{"p":[[-128.0,0.0366,0.0]],"k":[0.012345679,null],"none":null}"#
        );
        // Far beyond any coordinate, still unchanged.
        assert_eq!(round(1e300, MM), 1e300);
    }
}
