//! Bands on the curve, and the axial strain between them.
//!
//! Bands that overlap along the curve are merged first (with the visibility rule a band's
//! surface can come out as separate patches). A band's centre is the mean axis parameter of its voxels (their projections onto the
//! curve), which the cross-section's shape cannot bias. A band that reaches past the
//! centerline's end (to within a voxel) is taken to end at the tip, and its far voxels are
//! not its own: the visual hull runs on past the tube's end, and a marked cap is band-coloured.
//! Its centre is placed halfway between its proximal edge (its 2nd-percentile voxel, less 2 %
//! of its length) and the tip, so it carries half the tip's error. (Placing it half a known
//! band width beyond the edge measured worse on the simulator: 0.67 mm against 0.54 mm.)

use flexshape_carve::{Band, Occupancy};
use flexshape_curve::Polyline;
use nalgebra::Point3;

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
    // Each band's voxels along the curve; bands overlapping along it (a band's visible surface
    // can fall into patches that do not touch) are one band.
    let mut groups: Vec<Vec<f64>> = bands
        .iter()
        .map(|band| {
            let mut s: Vec<f64> = band
                .voxels
                .iter()
                .filter_map(|v| occ.voxels.binary_search(v).ok())
                .map(|i| slices.voxel_s[i])
                .filter(|s| !s.is_nan())
                .collect();
            s.sort_by(f64::total_cmp);
            s
        })
        .filter(|s| !s.is_empty())
        .collect();
    groups.sort_by(|a, b| a[0].total_cmp(&b[0]));
    let mut merged: Vec<Vec<f64>> = Vec::new();
    for g in groups {
        match merged.last_mut() {
            Some(last) if g[0] <= last[last.len() - 1] + voxel => {
                last.extend(g);
                last.sort_by(f64::total_cmp);
            }
            _ => merged.push(g),
        }
    }
    let mut out: Vec<BandOnCurve> = merged
        .into_iter()
        .map(|s| {
            let pick = |q: f64| s[((s.len() - 1) as f64 * q).round() as usize];
            let (lo, hi) = (pick(0.02), pick(0.98));
            let at_tip = s[s.len() - 1] >= curve.tip_param() - voxel;
            // Voxel centres fill the band's length about uniformly: the 2nd percentile sits 2 %
            // of that length inside its proximal edge.
            let edge = lo - 0.02 * (hi - lo) / 0.96;
            let centre = if at_tip {
                (edge + curve.tip_param()) / 2.0
            } else {
                s.iter().sum::<f64>() / s.len() as f64
            };
            let arc = curve.arc_of(centre);
            BandOnCurve {
                arc_length: arc,
                position: curve.point_at(arc),
                extent: [curve.arc_of(lo), curve.arc_of(hi)],
                voxels: s.len(),
                at_tip,
            }
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

/// The hull record's bands (`hull_length` its curve's length) placed on a new curve's record:
/// each at its centre's nearest point on the new curve, except a band ending at the tip, which
/// keeps its distance from the tip (its centre was placed from the tip in the first place).
pub(crate) fn carried_over(
    bands: &[BandOnCurve],
    hull_length: f64,
    record: &crate::ShapeRecord,
) -> Vec<BandOnCurve> {
    let points = record.points.iter().map(|&p| Point3::from(p)).collect();
    let Ok(curve) = Polyline::new(points) else {
        return Vec::new();
    };
    let mut out: Vec<BandOnCurve> = bands
        .iter()
        .map(|b| {
            let arc = if b.at_tip {
                record.length - (hull_length - b.arc_length)
            } else {
                curve.closest(&Point3::from(b.position)).0
            }
            .clamp(0.0, record.length);
            let shift = arc - b.arc_length;
            BandOnCurve {
                arc_length: arc,
                position: curve.point_at(arc).into(),
                extent: b.extent.map(|e| (e + shift).clamp(0.0, record.length)),
                voxels: b.voxels,
                at_tip: b.at_tip,
            }
        })
        .collect();
    out.sort_by(|a, b| a.arc_length.total_cmp(&b.arc_length));
    out
}

/// Orients slices whose direction was only guessed by the bands, when `settings.tip_band` says
/// a band ends at the tip: the end that a band reaches (and the other does not) is the tip.
/// Returns whether that decided it.
pub(crate) fn orient(
    occ: &Occupancy,
    bands: &[Band],
    slices: &mut Slices,
    settings: &crate::ShapeSettings,
    voxel: f64,
) -> bool {
    if !settings.tip_band {
        return false;
    }
    let [lo, hi] = slices.s_range;
    let reach = 2.0 * voxel;
    let (mut at_lo, mut at_hi) = (false, false);
    for band in bands {
        for v in &band.voxels {
            let Ok(i) = occ.voxels.binary_search(v) else {
                continue;
            };
            let s = slices.voxel_s[i];
            at_lo |= s <= lo + reach;
            at_hi |= s >= hi - reach;
        }
    }
    match (at_lo, at_hi) {
        (false, true) => true,
        (true, false) => {
            crate::order::reverse(slices);
            slices.enters_volume = false;
            true
        }
        _ => false,
    }
}

/// Bands found on the curve itself (`CurveBand`, in its parameter) as the record's: centred
/// between their ends, or between the proximal end and the tip for one that runs into it.
pub(crate) fn on_curve(
    found: &[crate::CurveBand],
    curve: &Centerline,
    length: f64,
) -> Vec<BandOnCurve> {
    let mut out: Vec<BandOnCurve> = found
        .iter()
        .map(|b| {
            let lower = curve.arc_of(b.u[0]);
            let upper = if b.at_tip {
                length
            } else {
                curve.arc_of(b.u[1])
            };
            let arc = (lower + upper) / 2.0;
            BandOnCurve {
                arc_length: arc,
                position: curve.point_at(arc),
                extent: [lower, upper],
                voxels: 0,
                at_tip: b.at_tip,
            }
        })
        .collect();
    out.sort_by(|a, b| a.arc_length.total_cmp(&b.arc_length));
    out
}
