//! The demo's printed lines: what the rig is, one table row per frame (headless), a status
//! line every few seconds (live), and the run against truth and its speed at the end.

use std::time::Duration;

use flexshape_record::{TrackRecord, TrackSummary};
use flexshape_track::{Processed, Tally};

use super::{Demo, DemoFigures, ShapeErrors};

/// The per-frame table's header (see [`Demo::table_row`]).
pub fn table_header() -> String {
    format!(
        "{:>5} {:>6} {:>7}  {:>6} {:>6} {:>5}  {:>7} {:>6} {:>7} {:>13}  {:>6} {:>6} {:>6} {:>6} {:>6}",
        "frame",
        "bend°",
        "plane°",
        "voxels",
        "hull⊇",
        "bands",
        "rms mm",
        "tip mm",
        "band mm",
        "κ fit/true 1/m",
        "sil ms",
        "carve",
        "bands",
        "shape",
        "fit",
    )
}

impl Demo {
    /// Two lines on the rig and the chain, and how long setting up took.
    pub fn introduction(&self, setup: Duration) -> String {
        let c = self.simulator().config();
        let v = &self.simulator().rig().volume;
        format!(
            "flexshape demo: simulated rig of {} cameras at {}×{}, volume {}×{}×{} voxels of {} mm; catheter r = {} mm with a {} mm bending section, driven by the tendon model\n\
             stages: model → simulator → silhouettes → voxel carving → marker bands → hull shape → tube fitted to every camera's outline and checked against the images (centerline, tip, bands, arc fit); errors against the simulator's truth\n\
             set up in {:.0} ms\n",
            c.rig.cameras,
            c.rig.width,
            c.rig.height,
            v.dims[0],
            v.dims[1],
            v.dims[2],
            v.voxel_size[0],
            c.catheter.radius,
            c.catheter.bend_length,
            setup.as_secs_f64() * 1e3
        )
    }

    /// One frame's row of the table: the commanded bend, what was measured against truth
    /// (or the status and why, without a shape), and per-stage times.
    pub fn table_row(
        &self,
        p: &Processed,
        record: &TrackRecord,
        errors: Option<&ShapeErrors>,
    ) -> String {
        let bend_length = self.simulator().config().catheter.bend_length;
        let (bend, plane) = match &p.truth {
            Some(t) => {
                let [kx, kz] = t.kappa.unwrap_or([0.0, 0.0]);
                let [_, e1] = t.eps.unwrap_or([0.0, 0.0]);
                (
                    (kx.hypot(kz) * bend_length * (1.0 - e1)).to_degrees(),
                    kz.atan2(kx).to_degrees(),
                )
            }
            None => (f64::NAN, f64::NAN),
        };
        let why = || {
            format!(
                "{}{}",
                record.status,
                record
                    .reason
                    .as_deref()
                    .map(|r| format!(": {r}"))
                    .unwrap_or_default()
            )
        };
        let measured = match errors {
            Some(e) => format!(
                "{:>5.1}% {:>5}  {:>7.3} {:>6.2} {:>7.2} {:>13}",
                e.hull_covers * 100.0,
                record.bands.len(),
                e.centerline_rms,
                e.tip,
                e.band,
                e.curvature
                    .map(|(fit, t)| format!("{:.2}/{:.2}", fit * 1e3, t * 1e3))
                    .unwrap_or_else(|| "-".into())
            ),
            None => format!("{:>44}", why()),
        };
        let t = record.timings_ms;
        format!(
            "{:>5} {bend:>6.1} {plane:>7.1}  {:>6} {measured}  {:>6.2} {:>6.2} {:>6.2} {:>6.2} {:>6.2}{}",
            record.frame,
            record.voxels,
            t.silhouettes,
            t.carve,
            t.bands,
            t.shape,
            t.fit,
            match (errors, record.status.as_str()) {
                (Some(_), "ok") | (None, _) => String::new(),
                (Some(_), status) =>
                    format!("  {status}: {}", record.reason.as_deref().unwrap_or("")),
            }
        )
    }

    /// The run's speed: the chain per frame and per stage, and what `threads` workers kept up
    /// with (`headless`: frames rendered on demand on the same cores).
    pub fn speed_line(
        &self,
        summary: &TrackSummary,
        figures: &DemoFigures,
        threads: usize,
        headless: bool,
    ) -> String {
        let chain = DemoFigures::median(&figures.chain_ms);
        format!(
            "speed: the chain takes {chain:.2} ms per frame (median; {}), {:.0} frames/s per worker; {threads} worker{} tracked {:.1} frames/s{}{}",
            summary
                .stages
                .iter()
                .map(|s| format!("{} {:.2}", s.stage, s.median_ms))
                .collect::<Vec<_>>()
                .join(", "),
            1e3 / chain.max(1e-9),
            if threads == 1 { "" } else { "s" },
            summary.fps,
            if headless {
                format!(
                    " while rendering the simulated cameras ({:.1} ms per frame) on the same cores",
                    self.rig.render_ms()
                )
            } else {
                " (sharing the cores with the simulated cameras' rendering)".to_string()
            },
            match (&summary.latency_ms, headless) {
                (Some(l), false) => format!(
                    "; latency {:.1} ms median, {:.1} ms p95; {} frames dropped",
                    l.median_ms, l.p95_ms, summary.dropped
                ),
                _ => String::new(),
            }
        )
    }
}

impl DemoFigures {
    /// The run against truth: centerline, tip, bands, curvature, hull coverage.
    pub fn truth_line(&self, summary: &TrackSummary) -> String {
        format!(
            "{} frames, {} ok; against truth over {} frames: centerline rms median {:.3} mm, worst {:.3} mm; tip median {:.2} mm, worst {:.2} mm; band centre worst {:.2} mm; arc-fit curvature worst {:.2} %; the carved hull holds ≥ {:.1} % of the true centerline",
            summary.frames,
            summary.ok,
            self.rms.len(),
            DemoFigures::median(&self.rms),
            DemoFigures::worst(&self.rms),
            DemoFigures::median(&self.tip),
            DemoFigures::worst(&self.tip),
            self.band,
            self.curvature * 100.0,
            self.cover.unwrap_or(0.0) * 100.0,
        )
    }

    /// A live status line: the frame, what the run kept up with so far, and its errors.
    pub fn status_line(
        &self,
        p: &Processed,
        tally: &Tally,
        errors: Option<&ShapeErrors>,
    ) -> String {
        format!(
            "frame {:>6}: {:.1} frames/s tracked, {} dropped, latency {:.1} ms; centerline rms {:.3} mm (worst so far {:.3}), tip {:.2} mm",
            p.frame,
            tally.frames() as f64 / tally.seconds(),
            p.dropped,
            p.latency_ms,
            errors.map_or(f64::NAN, |e| e.centerline_rms),
            DemoFigures::worst(&self.rms),
            errors.map_or(f64::NAN, |e| e.tip),
        )
    }
}
