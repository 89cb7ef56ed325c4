//! `flexshape demo`: the whole system on the built-in simulated rig.
//!
//! Each frame of the simulated sweep goes through the sensing chain — silhouettes → voxel
//! carving → marker bands → shape (centerline spline, tip, band positions, circular-arc fit) —
//! and the demo reports each stage against the simulator's ground truth.

use std::ops::ControlFlow;
use std::time::Instant;

use anyhow::Context;
use flexshape_camera::nalgebra::Point3;
use flexshape_curve::Polyline;
use flexshape_shape::{ShapeRecord, Status};
use flexshape_silhouette::{BackgroundModel, BitMask};
use flexshape_sim::{SimFrame, Simulator};
use flexshape_track::Pipeline;

use crate::cli::DemoArgs;
use crate::interrupt::Interrupt;

/// The sensing chain, set up once for the simulated rig.
struct Stages {
    pipeline: Pipeline,
}

/// One frame measured against its truth.
struct Measured {
    /// Silhouette IoU against the exact mask, per camera.
    iou: Vec<f64>,
    /// Occupied voxels.
    voxels: usize,
    /// Share of the truth centerline samples inside the volume that lie in occupied voxels.
    hull_covers: f64,
    /// The shape and its errors against truth.
    shape: ShapeRecord,
    errors: Option<ShapeErrors>,
    silhouette_ms: f64,
    carve_ms: f64,
    shape_ms: f64,
}

/// A shape against the simulator's truth, mm (curvature relative).
struct ShapeErrors {
    /// RMS distance from the true centerline samples in the volume to the estimated curve.
    centerline_rms: f64,
    tip: f64,
    /// Worst distance from a true band centre to the nearest estimated one.
    band: f64,
    /// Estimated and true curvature of the bending section, 1/mm.
    curvature: Option<(f64, f64)>,
}

impl Stages {
    fn new(sim: &Simulator) -> anyhow::Result<Self> {
        let backgrounds = sim
            .backgrounds()
            .iter()
            .map(|bg| BackgroundModel::from_frames(std::slice::from_ref(bg)))
            .collect::<Result<Vec<_>, _>>()
            .context("cannot model the simulated backgrounds")?;
        let rig = sim.rig();
        // The simulated rig's `[processing.shape]` describes its catheter (bands, sections).
        let pipeline = Pipeline::new(rig, &backgrounds, &rig.volume)
            .context("cannot set up the sensing chain")?;
        Ok(Stages { pipeline })
    }

    fn measure(&self, frame: &SimFrame) -> anyhow::Result<Measured> {
        let n = frame.truth.frame;
        let images: Vec<_> = frame.views.iter().map(|v| &v.image).collect();
        let tracked = self
            .pipeline
            .process(&images)
            .with_context(|| format!("frame {n}"))?;
        let iou = tracked
            .silhouettes
            .iter()
            .zip(&frame.views)
            .map(|(s, v)| s.object.iou(&BitMask::from_gray(&v.mask)))
            .collect();
        let (occupancy, shape, timings) = (tracked.occupancy, tracked.shape, tracked.timings);
        let volume = self.pipeline.volume();
        let inside: Vec<Point3<f64>> = frame
            .truth
            .centerline
            .iter()
            .map(|p| Point3::from(*p))
            .filter(|p| volume.contains(p))
            .collect();
        let covered = inside
            .iter()
            .filter(|p| occupancy.contains_point(p))
            .count();
        let errors = shape_errors(frame, &shape, &inside);
        Ok(Measured {
            iou,
            voxels: occupancy.len(),
            hull_covers: covered as f64 / inside.len().max(1) as f64,
            shape,
            errors,
            silhouette_ms: timings.silhouettes,
            carve_ms: timings.carve + timings.bands,
            shape_ms: timings.shape,
        })
    }
}

/// The shape's errors against truth (`None` without a shape).
fn shape_errors(
    frame: &SimFrame,
    shape: &ShapeRecord,
    inside: &[Point3<f64>],
) -> Option<ShapeErrors> {
    if shape.points.len() < 2 {
        return None;
    }
    let curve = Polyline::new(shape.points.iter().map(|&p| Point3::from(p)).collect()).ok()?;
    let sum2: f64 = inside.iter().map(|p| curve.closest(p).1.powi(2)).sum();
    let truth = &frame.truth;
    let band = truth
        .bands
        .iter()
        .map(|b| Point3::from(b.position))
        .filter(|p| inside.iter().any(|q| (q - p).norm() < 1.0))
        .map(|p| {
            shape
                .bands
                .iter()
                .map(|b| (Point3::from(b.position) - p).norm())
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max);
    let curvature = match (truth.kappa, &shape.arc_fit) {
        (Some([kx, kz]), Some(fit)) => Some((fit.curvature, kx.hypot(kz))),
        _ => None,
    };
    Some(ShapeErrors {
        centerline_rms: (sum2 / inside.len().max(1) as f64).sqrt(),
        tip: (Point3::from(shape.tip) - Point3::from(truth.tip)).norm(),
        band,
        curvature,
    })
}

/// Worst figures over the frames so far.
#[derive(Default)]
struct Worst {
    iou: f64,
    cover: f64,
    ok: usize,
    rms: f64,
    tip: f64,
    band: f64,
    curvature: f64,
    seen: bool,
}

impl Worst {
    fn add(&mut self, m: &Measured) {
        if !self.seen {
            (self.iou, self.cover, self.seen) = (1.0, 1.0, true);
        }
        self.iou = m.iou.iter().copied().fold(self.iou, f64::min);
        self.cover = self.cover.min(m.hull_covers);
        if m.shape.status == Status::Ok {
            self.ok += 1;
        }
        if let Some(e) = &m.errors {
            self.rms = self.rms.max(e.centerline_rms);
            self.tip = self.tip.max(e.tip);
            self.band = self.band.max(e.band);
            if let Some((fit, truth)) = e.curvature
                && truth >= 1.0 / 200.0
            {
                self.curvature = self.curvature.max((fit / truth - 1.0).abs());
            }
        }
    }
}

/// A short word for a status without a shape.
fn status_text(status: &Status) -> String {
    match status {
        Status::Ok => "ok".into(),
        Status::NoObject { .. } => "no object".into(),
        Status::Ambiguous { .. } => "ambiguous".into(),
        Status::LeavesVolume => "leaves volume".into(),
        Status::BandsMissing { found, expected } => format!("{found}/{expected} bands"),
    }
}

pub fn run(args: &DemoArgs) -> anyhow::Result<()> {
    let stop = Interrupt::install();
    let setup = Instant::now();
    let sim =
        Simulator::new(super::sim_config(&args.sim)).context("cannot set up the simulated rig")?;
    let stages = Stages::new(&sim)?;
    let setup_ms = setup.elapsed().as_secs_f64() * 1e3;
    let c = sim.config();
    let v = &sim.rig().volume;
    println!(
        "flexshape demo: simulated rig of {} cameras at {}×{}, volume {}×{}×{} voxels of {} mm, catheter r = {} mm with a {} mm bending section",
        c.rig.cameras,
        c.rig.width,
        c.rig.height,
        v.dims[0],
        v.dims[1],
        v.dims[2],
        v.voxel_size[0],
        c.catheter.radius,
        c.catheter.bend_length
    );
    println!(
        "stages: simulator → silhouettes → voxel carving → marker bands → shape (centerline, tip, bands, arc fit); errors against the simulator's truth"
    );
    println!("set up in {setup_ms:.0} ms\n");
    let names: Vec<&str> = sim.rig().cameras.iter().map(|c| c.name.as_str()).collect();
    let iou_header = format!("silhouette IoU ({})", names.join("/"));
    println!(
        "{:>5} {:>6} {:>7}  {:<w$}  {:>6} {:>6} {:>6} {:>7} {:>6} {:>7} {:>13}  {:>6} {:>6} {:>6} {:>7}",
        "frame",
        "bend°",
        "plane°",
        iou_header,
        "voxels",
        "hull⊇",
        "bands",
        "rms mm",
        "tip mm",
        "band mm",
        "κ fit/true 1/m",
        "sil ms",
        "carve",
        "shape",
        "render",
        w = iou_header.len()
    );
    let mut render_ms = Vec::new();
    let mut worst = Worst::default();
    let (mut sil_total, mut carve_total, mut shape_total) = (0.0, 0.0, 0.0);
    let mut failure = None;
    let mut last = Instant::now();
    let mut report = |frame: &SimFrame| {
        let ms = last.elapsed().as_secs_f64() * 1e3;
        render_ms.push(ms);
        let m = match stages.measure(frame) {
            Ok(m) => m,
            Err(e) => {
                failure = Some(e);
                return ControlFlow::Break(());
            }
        };
        worst.add(&m);
        sil_total += m.silhouette_ms;
        carve_total += m.carve_ms;
        shape_total += m.shape_ms;
        let truth = &frame.truth;
        let [kx, kz] = truth.kappa.unwrap_or([0.0, 0.0]);
        let [_, e1] = truth.eps.unwrap_or([0.0, 0.0]);
        let ious: Vec<String> = m.iou.iter().map(|i| format!("{i:.3}")).collect();
        let errors = match &m.errors {
            Some(e) => format!(
                "{:>7.3} {:>6.2} {:>7.2} {:>13}",
                e.centerline_rms,
                e.tip,
                e.band,
                e.curvature
                    .map(|(fit, t)| format!("{:.2}/{:.2}", fit * 1e3, t * 1e3))
                    .unwrap_or_else(|| "-".into())
            ),
            None => format!("{:>36}", status_text(&m.shape.status)),
        };
        println!(
            "{:>5} {:>6.1} {:>7.1}  {:<w$}  {:>6} {:>5.1}% {:>6} {errors}  {:>6.2} {:>6.2} {:>6.2} {ms:>7.1}",
            truth.frame,
            (kx.hypot(kz) * c.catheter.bend_length * (1.0 - e1)).to_degrees(),
            kz.atan2(kx).to_degrees(),
            ious.join("/"),
            m.voxels,
            m.hull_covers * 100.0,
            m.shape.bands.len(),
            m.silhouette_ms,
            m.carve_ms,
            m.shape_ms,
            w = iou_header.len(),
        );
        last = Instant::now();
        if stop.requested() {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    };
    let poses = sim.sweep(args.frames);
    match &args.out {
        Some(dir) => {
            let written = sim
                .write_recording(dir, &poses, false, &mut report)
                .with_context(|| format!("cannot write the recording to {}", dir.display()))?;
            println!("\nwrote {written} frames to {}", dir.display());
        }
        None => {
            for (i, pose) in poses.iter().enumerate() {
                let frame = sim
                    .render(i as u64, pose)
                    .with_context(|| format!("frame {i}"))?;
                if report(&frame).is_break() {
                    break;
                }
            }
        }
    }
    if let Some(e) = failure {
        return Err(e);
    }
    let n = render_ms.len();
    if n == 0 {
        return Ok(());
    }
    println!(
        "\n{n} frames: silhouette IoU ≥ {:.4}; the carved hull holds {:.1} % of the true centerline at worst",
        worst.iou,
        worst.cover * 100.0
    );
    println!(
        "shape: {} of {n} frames ok; worst centerline rms {:.3} mm, tip {:.2} mm, band centre {:.2} mm, arc-fit curvature {:.2} %",
        worst.ok,
        worst.rms,
        worst.tip,
        worst.band,
        worst.curvature * 100.0
    );
    println!(
        "per frame on average: silhouettes {:.2} ms, carving + bands {:.2} ms, shape {:.2} ms (timed inside the demo loop; `cargo bench` gives steady figures)",
        sil_total / n as f64,
        carve_total / n as f64,
        shape_total / n as f64
    );
    render_ms.sort_by(f64::total_cmp);
    let mean = render_ms.iter().sum::<f64>() / n as f64;
    println!(
        "simulating {} cameras takes {mean:.1} ms per frame on average (median {:.1} ms){}",
        names.len(),
        render_ms[n / 2],
        if args.out.is_some() {
            ", including writing PNGs"
        } else {
            ""
        }
    );
    Ok(())
}
