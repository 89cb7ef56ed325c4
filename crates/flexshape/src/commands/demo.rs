//! `flexshape demo`: the whole system on the built-in simulated rig.
//!
//! Each frame of the simulated sweep goes through the sensing stages built so far (today:
//! silhouettes), and the demo reports them against the simulator's ground truth; each stage
//! joins the loop as it lands (carving and shape estimation next).

use std::ops::ControlFlow;
use std::time::Instant;

use anyhow::Context;
use flexshape_silhouette::{BackgroundModel, BitMask, SilhouetteSettings, Silhouetter};
use flexshape_sim::{SimFrame, Simulator};

use crate::cli::DemoArgs;
use crate::interrupt::Interrupt;

pub fn run(args: &DemoArgs) -> anyhow::Result<()> {
    let stop = Interrupt::install();
    let config = super::sim_config(&args.sim);
    let setup = Instant::now();
    let sim = Simulator::new(config).context("cannot set up the simulated rig")?;
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
        "stages in this build: simulator → silhouettes (carving and shape estimation are not built yet)"
    );
    println!("rig set up in {setup_ms:.0} ms\n");
    let silhouetters = sim
        .backgrounds()
        .iter()
        .zip(&sim.rig().cameras)
        .map(|(bg, cam)| {
            let model = BackgroundModel::from_frames(std::slice::from_ref(bg))?;
            Silhouetter::new(
                &model,
                SilhouetteSettings::from_processing(&sim.rig().processing, &cam.name)?,
            )
        })
        .collect::<Result<Vec<_>, _>>()
        .context("cannot set up the silhouette stage")?;
    let names: Vec<&str> = sim.rig().cameras.iter().map(|c| c.name.as_str()).collect();
    let pixels_header = format!("silhouette IoU ({})", names.join("/"));
    println!(
        "{:>5} {:>6} {:>7} {:>26} {:>8} {:>7}  {}  {:>6} {:>9}",
        "frame",
        "bend°",
        "plane°",
        "tip x, y, z (mm)",
        "arc mm",
        "ε1 %",
        pixels_header,
        "sil ms",
        "render ms"
    );
    let mut render_ms = Vec::new();
    let mut sil_ms = Vec::new();
    let mut worst_iou: f64 = 1.0;
    let mut last = Instant::now();
    let mut report = |frame: &SimFrame| {
        let ms = last.elapsed().as_secs_f64() * 1e3;
        render_ms.push(ms);
        let t = Instant::now();
        let silhouettes: Vec<_> = silhouetters
            .iter()
            .zip(&frame.views)
            .map(|(s, v)| s.process(&v.image))
            .collect();
        let s_ms = t.elapsed().as_secs_f64() * 1e3;
        sil_ms.push(s_ms);
        let truth = &frame.truth;
        let [kx, kz] = truth.kappa.unwrap_or([0.0, 0.0]);
        let [_, e1] = truth.eps.unwrap_or([0.0, 0.0]);
        let arc = c.catheter.bend_length * (1.0 - e1);
        let pixels: Vec<String> = silhouettes
            .iter()
            .zip(&frame.views)
            .map(|(s, v)| match s {
                Ok(s) => {
                    let iou = s.object.iou(&BitMask::from_gray(&v.mask));
                    worst_iou = worst_iou.min(iou);
                    format!("{iou:.3}")
                }
                Err(e) => format!("error: {e}"),
            })
            .collect();
        let [x, y, z] = truth.tip;
        println!(
            "{:>5} {:>6.1} {:>7.1} {:>26} {:>8.1} {:>7.2}  {:<w$}  {s_ms:>6.2} {ms:>9.1}",
            truth.frame,
            (kx.hypot(kz) * arc).to_degrees(),
            kz.atan2(kx).to_degrees(),
            format!("{x:.1}, {y:.1}, {z:.1}"),
            arc,
            e1 * 100.0,
            pixels.join("/"),
            w = pixels_header.len(),
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
    if !sil_ms.is_empty() {
        let mean = sil_ms.iter().sum::<f64>() / sil_ms.len() as f64;
        println!(
            "\nsilhouettes: worst IoU against the exact masks {worst_iou:.4}; {mean:.2} ms per frame for {} cameras (one thread, timed inside the demo loop; `cargo bench -p flexshape-silhouette` gives steady figures)",
            names.len()
        );
    }
    if !render_ms.is_empty() {
        render_ms.sort_by(f64::total_cmp);
        let mean = render_ms.iter().sum::<f64>() / render_ms.len() as f64;
        println!(
            "\n{} frames: simulating {} cameras takes {mean:.1} ms per frame on average (median {:.1} ms, {:.1} frames/s){}",
            render_ms.len(),
            names.len(),
            render_ms[render_ms.len() / 2],
            1e3 / mean,
            if args.out.is_some() {
                ", including writing PNGs"
            } else {
                ""
            }
        );
    }
    Ok(())
}
