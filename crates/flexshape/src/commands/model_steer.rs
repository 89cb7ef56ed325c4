//! `flexshape model steer`: the closed loop on the simulated rig (library:
//! `flexshape_steer::steer`).

use std::collections::VecDeque;
use std::ops::ControlFlow;
use std::time::{Duration, Instant};

use anyhow::{Context, ensure};
use flexshape_sim::SimConfig;
use flexshape_steer::{SteerFrame, SteerSettings, SteerStep, reachable_targets, steer_with_frames};
use flexshape_track::Processed;
use flexshape_viewer::{Steering, SteeringSample};

use crate::cli::ModelSteerArgs;
use crate::commands::viewer::{Live, start_at};
use crate::interrupt::Interrupt;

pub fn run(args: &ModelSteerArgs) -> anyhow::Result<()> {
    let model = super::model::load(&args.params)?;
    let errors: Vec<f64> = args
        .stiffness_error
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .ok()
        .filter(|v: &Vec<f64>| {
            v.len() == 2 && v.iter().all(|e| e.is_finite() && *e > -90.0 && *e < 900.0)
        })
        .with_context(|| {
            format!(
                "--stiffness-error {}: give two percentages KX,KZ above -90, e.g. 25,-20",
                args.stiffness_error
            )
        })?;
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
    let nominal = model.params().clone();
    let mut truth = nominal.clone();
    truth.stiffness.kx *= 1.0 + errors[0] / 100.0;
    truth.stiffness.kz *= 1.0 + errors[1] / 100.0;
    let settings = SteerSettings {
        steps_per_target: args.steps,
        ..SteerSettings::default()
    };
    let targets = reachable_targets(&truth, args.targets, settings.control.preload_strain)
        .context("cannot find targets the catheter reaches")?;
    let stop = Interrupt::install();
    if !args.json {
        println!(
            "{:>5} {:>6} {:>14} {:>10} {:>10} {:>10} {:>10}",
            "frame", "target", "status", "sensed mm", "true mm", "Kx used", "Kz used"
        );
    }
    let true_stiffness = [truth.stiffness.kx, truth.stiffness.kz];
    let mut live: Option<Live> = None;
    let mut history: VecDeque<SteeringSample> = VecDeque::new();
    let (steps, learnt) = steer_with_frames(
        &SimConfig::default(),
        &truth,
        &nominal,
        &targets,
        &settings,
        |s, seen| {
            if let Some(addr) = &args.viewer.viewer {
                if live.is_none() {
                    match start_at(addr, args.viewer.allow_remote, seen.pipeline) {
                        Ok(l) => live = Some(l),
                        Err(e) => {
                            eprintln!("{e:#}");
                            return ControlFlow::Break(());
                        }
                    }
                }
                if let Some(l) = &mut live {
                    let steering = steering_of(s, &mut history, targets.len(), true_stiffness);
                    show(l, s, seen, steering);
                }
            }
            if args.json {
                if let Ok(line) = serde_json::to_string(s) {
                    println!("{line}");
                }
            } else {
                println!(
                    "{:>5} {:>6} {:>14} {:>10} {:>10.3} {:>10.1} {:>10.1}",
                    s.frame,
                    s.target_index,
                    s.status,
                    s.sensed_error_mm.map_or("—".into(), |e| format!("{e:.3}")),
                    s.true_error_mm,
                    s.stiffness[0],
                    s.stiffness[1]
                );
            }
            if stop.requested() {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        },
    )
    .context("the closed loop stopped")?;
    ensure!(
        args.viewer.viewer.is_none() || live.is_some() || steps.is_empty(),
        "the viewer could not start"
    );
    if let Some(dir) = &args.plots {
        figures(dir, &steps, [truth.stiffness.kx, truth.stiffness.kz])?;
    }
    let finals: Vec<f64> = (0..targets.len())
        .filter_map(|t| steps.iter().rfind(|s| s.target_index == t))
        .map(|s| s.true_error_mm)
        .collect();
    let worst = finals.iter().copied().fold(0.0, f64::max);
    let summary = serde_json::json!({
        "frames": steps.len(),
        "final_true_error_mm": finals,
        "worst_final_true_error_mm": worst,
        "true_stiffness": [truth.stiffness.kx, truth.stiffness.kz],
        "learnt_stiffness": learnt.map(|k| [k.kx, k.kz]),
    });
    if args.json {
        println!("{summary}");
    } else {
        println!(
            "\n{} frames; tip at the end of each target within {worst:.3} mm of it (true tip); \
             Kx, Kz learnt online: {} (truth {:.1}, {:.1}; the file said {:.1}, {:.1})",
            steps.len(),
            learnt.map_or("not yet".into(), |k| format!("{:.1}, {:.1}", k.kx, k.kz)),
            truth.stiffness.kx,
            truth.stiffness.kz,
            nominal.stiffness.kx,
            nominal.stiffness.kz
        );
    }
    if let Some(l) = &live {
        eprintln!("viewer: the last frame stays at {} until Ctrl-C", l.url());
        while !stop.requested() {
            std::thread::sleep(Duration::from_millis(100));
        }
    }
    Ok(())
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

/// Hands one frame of the loop to the viewer.
fn show(live: &mut Live, step: &SteerStep, seen: SteerFrame<'_>, steering: Steering) {
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
        processed_s: None,
    };
    live.publish_steering(processed, record, steering);
}

/// The tip's error over the frames (sensed and true, log scale), the curvature the
/// controller's model expected of each command against the sensed one, and the stiffnesses
/// the controller used, relative to the truth.
fn figures(
    dir: &std::path::Path,
    steps: &[flexshape_steer::SteerStep],
    truth: [f64; 2],
) -> anyhow::Result<()> {
    use flexshape_plot::{PALETTE, TimePanel, TimeSeries, timelines};
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let line =
        |label: &str, k: usize, value: &dyn Fn(&flexshape_steer::SteerStep) -> f64| TimeSeries {
            label: label.into(),
            points: steps.iter().map(|s| (s.frame as f64, value(s))).collect(),
            colour: PALETTE[k],
        };
    let panels = [
        TimePanel {
            y_label: "tip error (mm)".into(),
            series: vec![
                line("sensed", 0, &|s| s.sensed_error_mm.unwrap_or(f64::NAN)),
                line("true", 1, &|s| s.true_error_mm),
            ],
            log: true,
        },
        TimePanel {
            y_label: "curvature |κ| (1/m)".into(),
            series: vec![
                line("commanded (model)", 4, &|s| {
                    1000.0 * s.commanded_kappa[0].hypot(s.commanded_kappa[1])
                }),
                line("sensed", 5, &|s| {
                    s.sensed_kappa
                        .map_or(f64::NAN, |k| 1000.0 * k[0].hypot(k[1]))
                }),
            ],
            log: false,
        },
        TimePanel {
            y_label: "stiffness used − truth (%)".into(),
            series: vec![
                line("Kx", 2, &|s| 100.0 * (s.stiffness[0] / truth[0] - 1.0)),
                line("Kz", 3, &|s| 100.0 * (s.stiffness[1] / truth[1] - 1.0)),
            ],
            log: false,
        },
    ];
    timelines(
        "Closed loop: the tip steered to targets, the stiffnesses learnt online",
        "frame",
        &panels,
        &dir.join("steer"),
    )?;
    Ok(())
}
