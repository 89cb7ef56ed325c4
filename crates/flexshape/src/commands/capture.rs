//! `flexshape capture`: frame sets from live cameras into one folder per camera.

use std::time::Duration;

use anyhow::Context;
use flexshape_input::{CaptureOptions, LiveSource, capture, capture_path, probe_size};

use crate::cli::CaptureArgs;
use crate::interrupt::Interrupt;

pub fn run(args: &CaptureArgs) -> anyhow::Result<()> {
    let mut cameras = Vec::with_capacity(args.camera.len());
    for (name, input) in &args.camera {
        if cameras.iter().any(|(n, _, _)| n == name) {
            anyhow::bail!("camera `{name}` is given twice: give each camera once");
        }
        let input = input.display().to_string();
        let size = match args.size {
            Some(size) => size,
            None => probe_size(name, &input)
                .with_context(|| format!("cannot tell the image size of camera `{name}`"))?,
        };
        cameras.push((name.clone(), input, size));
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let names: Vec<String> = cameras.iter().map(|(n, _, _)| n.clone()).collect();
    let mut source = LiveSource::open(&cameras)?;
    let interrupt = Interrupt::install();
    let options = CaptureOptions {
        sets: args.sets,
        interval: Duration::from_secs_f64(args.interval),
    };
    eprintln!(
        "capturing {} set(s) of {} camera(s) into {} (Ctrl-C stops, keeping what was written)",
        args.sets,
        names.len(),
        args.out.display()
    );
    let report = capture(
        &mut source,
        &names,
        &args.out,
        &options,
        interrupt.flag(),
        |n| {
            eprintln!(
                "set {}/{}: {}",
                n + 1,
                args.sets,
                capture_path(&args.out, &names[0], n).display()
            )
        },
    )?;
    println!(
        "{} set(s) written to {} ({} per camera: {}), {} skipped{}",
        report.sets,
        args.out.display(),
        report.sets,
        names.join(", "),
        report.dropped,
        if report.stopped {
            " — stopped before all were taken"
        } else {
            ""
        }
    );
    if report.sets == 0 {
        anyhow::bail!("no frame set was captured");
    }
    Ok(())
}
