//! `flexshape silhouettes`: one frame's silhouettes and fitted tube, reported and optionally
//! drawn — from a recording or any input `track` takes.

use anyhow::{Context, bail};
use flexshape_lab::inspect::Inspection;
use flexshape_recording::RecordingReader;

use super::frames;
use crate::cli::SilhouettesArgs;

pub fn run(args: &SilhouettesArgs) -> anyhow::Result<()> {
    let mut input = frames::open_input(&args.frames)?;
    let volume = frames::volume(&input.rig.volume, &args.frames)?;
    let pipeline = input
        .pipeline(&volume)
        .with_context(|| format!("cannot set up tracking for {}", input.rig_name))?;
    let set = pick_frame(input.source.as_mut(), args)?;
    let (frame, name) = (set.frame, set.name.clone());
    let (images, warnings) = pipeline.load(set.images).map_err(|e| anyhow::anyhow!(e))?;
    for w in warnings {
        eprintln!("warning: {w}");
    }
    println!(
        "frame {frame:06}{}",
        name.map(|n| format!(" ({n})")).unwrap_or_default()
    );
    let truth = match &args.frames.recording {
        Some(r) => {
            let reader = RecordingReader::open(r)?;
            (0..images.len())
                .map(|i| reader.read_truth_mask(i, frame))
                .collect::<Result<Vec<_>, _>>()?
        }
        None => Vec::new(),
    };
    let inspection = Inspection::of(
        &pipeline,
        &input.rig,
        &images,
        frame,
        &truth,
        input.backgrounds.as_deref(),
    )
    .with_context(|| format!("frame {frame:06}"))?;
    print!("{inspection}");
    if let Some(out) = &args.out {
        inspection.write_images(&pipeline, &images, out)?;
        println!("debug images written to {}", out.display());
    }
    Ok(())
}

/// The frame asked for: by number in a recording, by position elsewhere.
fn pick_frame(
    source: &mut dyn flexshape_input::FrameSource,
    args: &SilhouettesArgs,
) -> anyhow::Result<flexshape_input::FrameSet> {
    let numbered = args.frames.recording.is_some();
    let mut position = 0u64;
    loop {
        let Some(next) = source.next_frame() else {
            bail!(
                "the input has no frame {:06} ({} frames{})",
                args.frame,
                position,
                if numbered { "" } else { ", counted from 0" }
            );
        };
        let set = next.with_context(|| format!("frame {position}"))?;
        let wanted = if numbered { set.frame } else { position };
        position += 1;
        if wanted == args.frame {
            return Ok(set);
        }
    }
}
