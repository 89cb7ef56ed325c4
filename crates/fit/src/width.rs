//! Free outline widths ([`crate::OutlineWidth::Free`]): a mask drawn as a line a fixed number
//! of pixels wide, or a segmentation that grows or shrinks the tube, has boundaries whose
//! distance apart says nothing of the tube's radius or depth. Only the middle between the two
//! boundaries across the tube is its centerline's image. So each station's two side residuals
//! (predicted minus measured along each side's outward normal) are split into their half
//! difference — the middle's offset, which moves the tube — and their mean — how much narrower
//! the silhouette is than the tube's image there — which is taken out. A side whose partner
//! is not measured, and a cap, are read against the width its neighbours measured.
//!
//! Each pair then enters the fit as two rows of the middle's offset, ±: two boundaries' worth
//! of information on one middle (its noise is theirs over √2), as the two sides were.

use crate::outline::Part;
use crate::solve::Measured;

/// Along one camera's view of a tube, how much narrower its silhouette is than the tube's
/// image at each station where both sides were measured: pairs of centerline parameter and
/// pixels (negative: the silhouette is wider), by parameter.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct WidthProfile {
    stations: Vec<(f64, f64)>,
}

impl WidthProfile {
    /// The narrowing at parameter `u`, pixels: linear between stations, the nearest one's
    /// beyond them, 0 with none.
    pub(crate) fn at(&self, u: f64) -> f64 {
        let s = &self.stations;
        let (Some(first), Some(last)) = (s.first(), s.last()) else {
            return 0.0;
        };
        if u <= first.0 {
            return first.1;
        }
        if u >= last.0 {
            return last.1;
        }
        let k = s.partition_point(|p| p.0 <= u).clamp(1, s.len() - 1);
        let (a, b) = (s[k - 1], s[k]);
        let t = if b.0 > a.0 {
            (u - a.0) / (b.0 - a.0)
        } else {
            0.0
        };
        a.1 + (b.1 - a.1) * t
    }

    /// The profile a measured outline's samples carry ([`Measured::narrowing`]), pixels: that
    /// of their sides with a residual (all 0 when widths follow the tube).
    pub(crate) fn of(measured: &[Measured]) -> Self {
        let mut stations: Vec<(f64, f64)> = measured
            .iter()
            .filter(|m| m.residual.is_some() && matches!(m.point.part, Part::Side(_)))
            .map(|m| (m.point.u, m.narrowing))
            .collect();
        stations.sort_by(|x, y| x.0.total_cmp(&y.0));
        WidthProfile { stations }
    }

    /// The median narrowing over the stations, pixels (0 with none).
    pub(crate) fn median(&self) -> f64 {
        crate::median(self.stations.iter().map(|s| s.1))
    }
}

/// Rewrites one camera's measured outline so that only the middle between a station's two
/// sides places the tube (see the module's comment), and returns the widths taken out. A
/// side or cap left with no station to read its width against has no residual.
pub(crate) fn middles(measured: &mut [Measured]) -> WidthProfile {
    let mut stations = Vec::new();
    let mut paired = vec![false; measured.len()];
    for i in 0..measured.len().saturating_sub(1) {
        let (a, b) = (&measured[i].point, &measured[i + 1].point);
        let same_station = matches!((a.part, b.part), (Part::Side(_), Part::Side(_)))
            && a.u == b.u
            && a.which < 0.0
            && b.which > 0.0;
        if !same_station || paired[i] {
            continue;
        }
        let (Some(left), Some(right)) = (measured[i].residual, measured[i + 1].residual) else {
            continue;
        };
        let narrower = (left + right) / 2.0;
        let middle = (right - left) / 2.0;
        measured[i].residual = Some(-middle);
        measured[i + 1].residual = Some(middle);
        // The width is taken out, and with it what an unresolved rim adds to it.
        measured[i].rim = 0.0;
        measured[i + 1].rim = 0.0;
        measured[i].narrowing = narrower;
        measured[i + 1].narrowing = narrower;
        paired[i] = true;
        paired[i + 1] = true;
        stations.push((a.u, narrower));
    }
    stations.sort_by(|x, y| x.0.total_cmp(&y.0));
    let profile = WidthProfile {
        stations: smoothed(&stations),
    };
    for (m, &done) in measured.iter_mut().zip(&paired) {
        let u = match m.point.part {
            Part::Side(_) => m.point.u,
            Part::Cap(end) => end as f64,
        };
        m.narrowing = profile.at(u);
        if done {
            continue;
        }
        m.residual = match (m.residual, profile.stations.is_empty()) {
            (Some(r), false) => Some(r - m.narrowing),
            _ => None,
        };
    }
    profile
}

/// Stations on either side whose widths a station's is the median of.
const NEIGHBOURS: usize = 10;

/// Each station's width the median over it and its [`NEIGHBOURS`] on either side (20 mm at
/// the default spacing): one station's width is two boundaries' noise (a binary mask places
/// each to within half a pixel), and a cap placed by the last station's alone left tips of
/// exact binary masks on the 640 × 480 rig up to 0.36 mm off (0.30 with the median over 11,
/// 0.24–0.30 with the widths taken for the tube's).
fn smoothed(stations: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut window = Vec::with_capacity(2 * NEIGHBOURS + 1);
    (0..stations.len())
        .map(|i| {
            let lo = i.saturating_sub(NEIGHBOURS);
            let hi = (i + NEIGHBOURS + 1).min(stations.len());
            window.clear();
            window.extend(stations[lo..hi].iter().map(|s| s.1));
            window.sort_by(f64::total_cmp);
            (stations[i].0, window[window.len() / 2])
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solve::made_up::{sample, side};

    #[test]
    fn a_pair_keeps_its_middle_and_the_rest_read_their_neighbours_width() {
        // Stations every 0.1 from 0.1 to 0.7, the silhouette 3 px narrower each side than the
        // tube's image (at 0.3 its middle 0.5 px toward side +1: its residual 0.5 less) but
        // at 0.6, 1 px wider (one station's noise, which the median leaves out). Then a lone
        // side between stations, a station with one side unmeasured, and the tip's cap.
        let mut m = Vec::new();
        for k in 1..=7 {
            let u = k as f64 / 10.0;
            let (left, right) = match k {
                3 => (3.5, 2.5),
                6 => (-1.0, -1.0),
                _ => (3.0, 3.0),
            };
            m.push(side(u, -1.0, Some(left)));
            m.push(side(u, 1.0, Some(right)));
        }
        m.push(side(0.75, 1.0, Some(2.7)));
        m.push(sample(Part::Cap(1), 1.0, 0.0, Some(2.8)));
        m.push(side(0.8, -1.0, None));
        m.push(side(0.8, 1.0, Some(3.3)));
        let profile = middles(&mut m);
        let r: Vec<Option<f64>> = m.iter().map(|m| m.residual).collect();
        let close = |a: Option<f64>, b: f64| a.is_some_and(|a| (a - b).abs() < 1e-12);
        assert!(close(r[4], 0.5) && close(r[5], -0.5), "{r:?}");
        assert!(close(r[10], 0.0) && close(r[11], 0.0), "{r:?}");
        assert!(close(r[0], 0.0) && close(r[13], 0.0), "{r:?}");
        // The lone side and the cap read the width around them (3 px, the wider station
        // outvoted); so does the station's measured side beyond the last full one.
        assert!(
            close(r[14], -0.3) && close(r[15], -0.2) && close(r[17], 0.3),
            "{r:?}"
        );
        assert_eq!(r[16], None);
        assert!(profile.stations.iter().all(|s| s.1 == 3.0), "{profile:?}");
        assert!((profile.median() - 3.0).abs() < 1e-12);
        // The samples carry it: the profile read back from them interpolates as the first.
        let again = WidthProfile::of(&m);
        for u in [0.1, 0.3, 0.5, 0.7, 0.9] {
            assert!((again.at(u) - profile.at(u)).abs() < 1e-12, "{u}");
        }
    }

    #[test]
    fn with_no_station_nothing_is_read() {
        let mut m = vec![
            side(0.5, 1.0, Some(0.2)),
            sample(Part::Cap(0), 0.0, 0.0, Some(0.1)),
        ];
        let profile = middles(&mut m);
        assert!(m.iter().all(|m| m.residual.is_none()));
        assert_eq!(profile.at(0.3), 0.0);
    }
}
