//! The sensed point of a frame for the accuracy experiment.

use flexshape_record::TrackRecord;
use nalgebra::Vector3;

/// Which point of a tracked frame is the sensed point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Extraction {
    /// The tip (the centerline's end: a ball-ended stylus's ball centre).
    Tip,
    /// The centre of band `k` (0 = most proximal).
    Band(usize),
    /// The centerline point furthest along a world direction.
    Extreme(Vector3<f64>),
}

impl std::str::FromStr for Extraction {
    type Err = String;

    /// `tip`, `band:K` or `extreme:X,Y,Z`.
    fn from_str(s: &str) -> Result<Self, String> {
        let bad =
            || format!("`{s}`: use tip, band:K (K = 0 for the most proximal) or extreme:X,Y,Z");
        match s.split_once(':') {
            None if s == "tip" => Ok(Extraction::Tip),
            Some(("band", k)) => k.trim().parse().map(Extraction::Band).map_err(|_| bad()),
            Some(("extreme", d)) => {
                let v: Vec<f64> = d
                    .split(',')
                    .map(|x| x.trim().parse::<f64>())
                    .collect::<Result<_, _>>()
                    .map_err(|_| bad())?;
                let v = match v[..] {
                    [x, y, z] => Vector3::new(x, y, z),
                    _ => return Err(bad()),
                };
                if v.norm().is_nan() || v.norm() <= 0.0 {
                    return Err(bad());
                }
                Ok(Extraction::Extreme(v.normalize()))
            }
            _ => Err(bad()),
        }
    }
}

/// The point `how` picks from `record`, or why there is none.
pub fn extract(record: &TrackRecord, how: Extraction) -> Result<[f64; 3], String> {
    if record.centerline.is_empty() {
        return Err(format!(
            "frame {}: no shape (status {})",
            record.frame, record.status
        ));
    }
    match how {
        Extraction::Tip => record
            .tip
            .ok_or_else(|| format!("frame {}: no tip", record.frame)),
        Extraction::Band(k) => record.bands.get(k).map(|b| b.position).ok_or_else(|| {
            format!(
                "frame {}: band {k} asked for, {} found",
                record.frame,
                record.bands.len()
            )
        }),
        Extraction::Extreme(d) => Ok(*record
            .centerline
            .iter()
            .max_by(|a, b| {
                Vector3::from(**a)
                    .dot(&d)
                    .total_cmp(&Vector3::from(**b).dot(&d))
            })
            .unwrap_or(&record.centerline[0])),
    }
}
