//! `flexshape model steer`: the closed loop on the simulated rig (library:
//! `flexshape_steer::steer`).

use std::collections::VecDeque;
use std::ops::ControlFlow;
use std::time::Instant;

use anyhow::{Context, ensure};
use flexshape_record::TrackRecord;
use flexshape_sim::SimConfig;
use flexshape_steer::{
    SteerFrame, SteerSettings, SteerStep, SteerSummary, reachable_targets, steer_with_frames,
};
use flexshape_track::Processed;
use flexshape_viewer::{Steering, SteeringSample};

use super::live::LiveOutputs;
use crate::cli::ModelSteerArgs;
use crate::commands::viewer::{Live, start_at};
use crate::interrupt::Interrupt;

pub fn run(args: &ModelSteerArgs) -> anyhow::Result<()> {
    let nominal = super::model::load(&args.params)?.params().clone();
    let errors = stiffness_errors(&args.stiffness_error)?;
    ensure!(
        (1..=100).contains(&args.targets),
        "--targets {}: give 1 to 100",
        args.targets
    );
    ensure!(
        (1..=1000).contains(&args.steps),
        "--steps {}: give 1 to 1000",
        args.steps
    );
    let mut truth = nominal.clone();
    truth.stiffness.kx *= 1.0 + errors[0] / 100.0;
    truth.stiffness.kz *= 1.0 + errors[1] / 100.0;
    let settings = SteerSettings {
        steps_per_target: args.steps,
        ..SteerSettings::default()
    };
    let targets = reachable_targets(&truth, args.targets, settings.control.preload_strain)
        .context("cannot find targets the catheter reaches")?;
    let rig = SimConfig::default()
        .rig
        .rig()
        .context("cannot set up the simulated rig")?;
    let live_outputs = LiveOutputs::start(&args.live, args.viewer.allow_remote, &rig)?;
    let stop = Interrupt::install();
    if !args.json {
        println!("{}", SteerStep::table_header());
    }
    let true_stiffness = [truth.stiffness.kx, truth.stiffness.kz];
    let mut frames = Frames {
        args,
        stop: &stop,
        live: None,
        live_outputs,
        history: VecDeque::new(),
        targets: targets.len(),
        true_stiffness,
    };
    let (steps, learnt) = steer_with_frames(
        &SimConfig::default(),
        &truth,
        &nominal,
        &targets,
        &settings,
        |s, seen| frames.take(s, seen),
    )
    .context("the closed loop stopped")?;
    frames.live_outputs.finish();
    ensure!(
        args.viewer.viewer.is_none() || frames.live.is_some() || steps.is_empty(),
        "the viewer could not start"
    );
    if let Some(dir) = &args.plots {
        flexshape_steer::figure(dir, &steps, true_stiffness)?;
    }
    let summary = SteerSummary::of(&steps, targets.len(), learnt, &truth, &nominal);
    if args.json {
        println!("{}", serde_json::to_string(&summary)?);
    } else {
        println!("\n{summary}");
    }
    super::viewer::linger(frames.live.as_ref(), &args.viewer, &stop);
    Ok(())
}

/// `--stiffness-error KX,KZ`: two percentages above −90.
fn stiffness_errors(given: &str) -> anyhow::Result<Vec<f64>> {
    given
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<Result<Vec<_>, _>>()
        .ok()
        .filter(|v| v.len() == 2 && v.iter().all(|e| e.is_finite() && *e > -90.0 && *e < 900.0))
        .with_context(|| {
            format!("--stiffness-error {given}: give two percentages KX,KZ above -90, e.g. 25,-20")
        })
}

/// What happens to each frame of the loop: shown in the viewer (started on the first frame,
/// when asked for), printed as a row or a JSON line.
struct Frames<'a> {
    args: &'a ModelSteerArgs,
    stop: &'a Interrupt,
    live: Option<Live>,
    /// `--foxglove` and `--ros2`.
    live_outputs: LiveOutputs,
    history: VecDeque<SteeringSample>,
    targets: usize,
    true_stiffness: [f64; 2],
}

impl Frames<'_> {
    fn take(&mut self, s: &SteerStep, seen: SteerFrame<'_>) -> ControlFlow<()> {
        if let Some(addr) = &self.args.viewer.viewer
            && self.live.is_none()
        {
            match start_at(addr, self.args.viewer.allow_remote, seen.pipeline) {
                Ok(l) => self.live = Some(l),
                Err(e) => {
                    eprintln!("{e:#}");
                    return ControlFlow::Break(());
                }
            }
        }
        let (processed, record) = processed(s, seen);
        self.live_outputs.publish(&record, &processed);
        if let Some(l) = &mut self.live {
            let steering = steering_of(s, &mut self.history, self.targets, self.true_stiffness);
            l.publish_steering(processed, record, steering);
        }
        if self.args.json {
            if let Ok(line) = serde_json::to_string(s) {
                println!("{line}");
            }
        } else {
            println!("{}", s.row());
        }
        if self.stop.requested() {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    }
}

/// The closed loop's state for the viewer, with `step` added to the run's `history`.
fn steering_of(
    step: &SteerStep,
    history: &mut VecDeque<SteeringSample>,
    targets: usize,
    true_stiffness: [f64; 2],
) -> Steering {
    history.push_back(SteeringSample {
        frame: step.frame,
        target_index: step.target_index,
        sensed_error_mm: step.sensed_error_mm,
        true_error_mm: Some(step.true_error_mm),
        commanded_kappa: step.commanded_kappa,
        sensed_kappa: step.sensed_kappa,
    });
    while history.len() > Steering::HISTORY {
        history.pop_front();
    }
    Steering {
        target: step.target_world,
        target_index: step.target_index,
        targets,
        stiffness: [step.stiffness[0], step.stiffness[1]],
        true_stiffness: Some(true_stiffness),
        history: history.iter().cloned().collect(),
    }
}

/// One frame of the loop as a tracked frame, with its record.
fn processed(step: &SteerStep, seen: SteerFrame<'_>) -> (Processed, TrackRecord) {
    let SteerFrame {
        images,
        tracked,
        record,
        ..
    } = seen;
    let processed = Processed {
        frame: step.frame,
        name: None,
        command: None,
        truth: None,
        warnings: Vec::new(),
        images,
        latency_ms: tracked.timings.total(),
        result: Ok(tracked),
        captured: Instant::now(),
        dropped: 0,
        capture_time: None,
        camera_times: None,
        processed_s: None,
    };
    (processed, record)
}
