//! `flexshape simulate`: write a simulated recording with a progress bar.

use std::ops::ControlFlow;
use std::time::Instant;

use anyhow::Context;
use flexshape_calib::Pattern;
use flexshape_model::{ExperimentPlan, Role};
use flexshape_recording::PoseRole;
use flexshape_sim::{
    BoardRenderer, CatheterPose, PrintedBoard, PrintedMarkers, PrintedPattern, Simulator,
    calibration_views,
};
use indicatif::{ProgressBar, ProgressStyle};

use crate::cli::{ChessboardsArgs, SimulateArgs, SimulateWhat};
use crate::interrupt::Interrupt;

pub fn run(args: &SimulateArgs) -> anyhow::Result<()> {
    if let Some(SimulateWhat::Chessboards(a)) = &args.what {
        return chessboards(a);
    }
    let Some(out) = &args.out else {
        anyhow::bail!("give the folder to write the recording to with --out DIR");
    };
    let stop = Interrupt::install();
    let mut config = super::sim_config(&args.sim);
    let experiment = match &args.model {
        None => None,
        Some(path) => {
            anyhow::ensure!(
                args.preload.is_finite() && args.preload > 0.0 && args.preload <= 0.5,
                "--preload {}: give a compression strain above 0 and at most 0.5",
                args.preload
            );
            let model = super::model::load(path)?;
            config.catheter = flexshape_steer::catheter_for(&config.catheter, model.params());
            let plan = ExperimentPlan {
                poses: args.poses,
                preload_strain: args.preload,
                ..ExperimentPlan::default()
            };
            Some(
                flexshape_model::experiment(&model, &plan)
                    .with_context(|| format!("{}: cannot plan the experiment", path.display()))?,
            )
        }
    };
    if let Some(hz) = args.motion {
        anyhow::ensure!(
            hz.is_finite() && hz > 0.0,
            "--motion must be a positive number of frames per second"
        );
    }
    let sim = Simulator::new(config).context("cannot set up the simulated rig")?;
    let (poses, commands) = match &experiment {
        None => match args.motion {
            Some(hz) => (sim.motion(args.frames, hz), Vec::new()),
            None => (sim.sweep(args.frames), Vec::new()),
        },
        Some(e) => {
            let catheter = &sim.config().catheter;
            e.iter()
                .map(|c| {
                    let q = c.q;
                    let pose = CatheterPose::arc(catheter, [q[0], q[1]], [q[2], q[3]], 0.0);
                    let role = match c.role {
                        Role::Reference => PoseRole::Reference,
                        Role::Register => PoseRole::Register,
                        Role::Pose => PoseRole::Pose,
                    };
                    (pose, (c.y.iter().copied().collect(), role))
                })
                .unzip()
        }
    };
    let frames = poses.len();
    let bar = ProgressBar::new(frames as u64).with_style(
        ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} frames, {per_sec}, eta {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar.set_message(format!("simulating into {}", out.display()));
    let start = Instant::now();
    let written = sim
        .write_commanded_recording(out, &poses, &commands, args.overwrite, |_| {
            bar.inc(1);
            if stop.requested() {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        })
        .with_context(|| format!("cannot write the recording to {}", out.display()))?;
    bar.finish_and_clear();
    if let Some(hz) = args.motion {
        // Filmed at `hz`: frame n at n / hz seconds.
        let times: Vec<(u64, f64)> = (0..written).map(|n| (n, n as f64 / hz)).collect();
        flexshape_recording::RecordingWriter::reopen(out)
            .write_timestamps(&times)
            .with_context(|| format!("cannot write the timestamps of {}", out.display()))?;
    }
    let cams = sim.rig().cameras.len();
    println!(
        "wrote {written} frames × {cams} cameras to {} in {:.1} s{}",
        out.display(),
        start.elapsed().as_secs_f64(),
        if (written as usize) < frames {
            " (stopped early by Ctrl-C; every written frame is whole)"
        } else {
            ""
        }
    );
    println!(
        "  layout: docs/formats.md; check its rig with: flexshape rig check {}",
        out.join("rig.toml").display()
    );
    Ok(())
}

/// `flexshape simulate chessboards`.
fn chessboards(args: &ChessboardsArgs) -> anyhow::Result<()> {
    let parsed =
        flexshape_calib::Board::from_spec(&args.board, args.square, args.marker, &args.dictionary)
            .map_err(|e| anyhow::anyhow!("--board/--square: {e}"))?;
    let pattern = match parsed.pattern {
        Pattern::Chessboard => PrintedPattern::Chessboard,
        Pattern::Charuco(m) => PrintedPattern::Charuco(
            PrintedMarkers::new(m.side, m.dictionary)
                .with_context(|| format!("--dictionary {}: not known", m.dictionary))?,
        ),
        // Dots half as wide as the distance to their nearest neighbour.
        Pattern::Circles { asymmetric } => PrintedPattern::Circles {
            asymmetric,
            diameter: parsed.square * if asymmetric { 0.7 } else { 0.5 },
        },
    };
    let board = PrintedBoard {
        cols: parsed.cols,
        rows: parsed.rows,
        square: parsed.square,
        pattern,
    };
    let config = super::sim_config(&args.sim);
    let rig = config
        .rig
        .rig()
        .context("cannot set up the simulated rig")?;
    let cameras: Vec<_> = rig.cameras.iter().map(|c| c.camera.clone()).collect();
    let views = calibration_views(&cameras, &board, args.own, args.shared, args.sim.seed);
    let renderers = cameras
        .iter()
        .map(|c| BoardRenderer::new(c).context("a camera's lens cannot be inverted over its image"))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let total: usize = views.iter().map(|v| v.cameras.len()).sum();
    let bar = ProgressBar::new(total as u64);
    for (i, view) in views.iter().enumerate() {
        for &k in &view.cameras {
            let name = &rig.cameras[k].name;
            let dir = args.out.join("images").join(name);
            std::fs::create_dir_all(&dir)
                .with_context(|| format!("cannot create {}", dir.display()))?;
            let img = renderers[k].render(
                &board,
                &view.pose,
                args.sim.noise,
                args.sim.seed ^ (i as u64 * 31 + k as u64),
            );
            let path = dir.join(format!("{}.png", view.name));
            img.save(&path)
                .with_context(|| format!("cannot write {}", path.display()))?;
            bar.inc(1);
        }
    }
    bar.finish_and_clear();
    let truth = args.out.join("truth").join("rig.toml");
    rig.save(&truth)
        .with_context(|| format!("cannot write {}", truth.display()))?;
    // The board poses (board → world: x_world = R·x_board + t, mm), per image name.
    let boards: Vec<serde_json::Value> = views
        .iter()
        .map(|v| {
            let m = v.pose.rotation.to_rotation_matrix();
            let rows: Vec<Vec<f64>> = (0..3).map(|r| (0..3).map(|c| m[(r, c)]).collect()).collect();
            serde_json::json!({
                "image": v.name,
                "rotation": rows,
                "translation": v.pose.translation.vector.as_slice(),
                "cameras": v.cameras.iter().map(|&k| rig.cameras[k].name.clone()).collect::<Vec<_>>(),
            })
        })
        .collect();
    let boards_path = args.out.join("truth").join("boards.json");
    std::fs::write(&boards_path, serde_json::to_string_pretty(&boards)?)
        .with_context(|| format!("cannot write {}", boards_path.display()))?;
    println!(
        "wrote {total} images of a {} board ({} mm squares) to {} and the true rig to {}",
        args.board,
        args.square,
        args.out.join("images").display(),
        truth.display()
    );
    let images: Vec<String> = rig
        .cameras
        .iter()
        .map(|c| {
            format!(
                "--images {}={}",
                c.name,
                args.out.join("images").join(&c.name).display()
            )
        })
        .collect();
    let markers = args
        .marker
        .map(|m| format!(" --marker {m} --dictionary {}", args.dictionary))
        .unwrap_or_default();
    println!(
        "  calibrate with: flexshape calibrate --board {} --square {}{markers} {} --out {}",
        args.board,
        args.square,
        images.join(" "),
        args.out.join("calibration").display()
    );
    Ok(())
}
