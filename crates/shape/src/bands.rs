//! Bands on the curve, and the axial strain between them.
//!
//! A band's centre is the mean axis parameter of its voxels (their projections onto the
//! curve), which the cross-section's shape cannot bias. A band that reaches the cloud's far
//! end is different: the visual hull runs on past the tube's end and those voxels see band
//! colour, so its far edge is unknown. Its centre is placed halfway between its proximal edge
//! (its 2nd-percentile voxel, minus half a voxel) and the tip.

use flexshape_carve::{Band, Occupancy};

use crate::centerline::Centerline;
use crate::order::Slices;
use crate::record::{BandOnCurve, Compression};
use crate::settings::NominalSection;

/// The bands along the curve, proximal first.
pub(crate) fn locate(
    occ: &Occupancy,
    bands: &[Band],
    slices: &Slices,
    curve: &Centerline,
    voxel: f64,
) -> Vec<BandOnCurve> {
    let far = slices.s_range[1];
    let mut out: Vec<BandOnCurve> = bands
        .iter()
        .filter_map(|band| {
            let mut s: Vec<f64> = band
                .voxels
                .iter()
                .filter_map(|v| occ.voxels.binary_search(v).ok())
                .map(|i| slices.voxel_s[i])
                .filter(|s| !s.is_nan())
                .collect();
            if s.is_empty() {
                return None;
            }
            s.sort_by(f64::total_cmp);
            let pick = |q: f64| s[((s.len() - 1) as f64 * q).round() as usize];
            let (lo, hi) = (pick(0.02), pick(0.98));
            let at_tip = s[s.len() - 1] >= far - 1.5 * voxel;
            let centre = if at_tip {
                (lo - voxel / 2.0 + curve.tip_param()) / 2.0
            } else {
                s.iter().sum::<f64>() / s.len() as f64
            };
            let arc = curve.arc_of(centre);
            Some(BandOnCurve {
                arc_length: arc,
                position: curve.point_at(arc),
                extent: [curve.arc_of(lo), curve.arc_of(hi)],
                voxels: band.voxels.len(),
                at_tip,
            })
        })
        .collect();
    out.sort_by(|a, b| a.arc_length.total_cmp(&b.arc_length));
    out
}

/// Strain of each configured section whose end points were found.
pub(crate) fn compression(
    sections: &[NominalSection],
    bands: &[BandOnCurve],
    length: f64,
) -> Vec<Compression> {
    sections
        .iter()
        .filter_map(|sec| {
            let from = bands.get(sec.from_band)?.arc_length;
            let to = match sec.to_band {
                Some(b) => bands.get(b)?.arc_length,
                None => length,
            };
            let measured = to - from;
            Some(Compression {
                name: sec.name.clone(),
                length: measured,
                nominal: sec.nominal_mm,
                strain: 1.0 - measured / sec.nominal_mm,
            })
        })
        .collect()
}
