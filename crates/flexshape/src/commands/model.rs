//! `flexshape model`: the tendon-driven manipulator model from the command line.

use std::path::Path;

use anyhow::{Context, bail};
use flexshape_model::nalgebra_types::{DVector, Vector4};
use flexshape_model::{Forward, ManipulatorParams, Model};

use crate::cli::ModelArgs;

pub fn template() -> anyhow::Result<()> {
    let text = toml::to_string_pretty(&ManipulatorParams::paper_like())
        .context("cannot write the template")?;
    println!(
        "# flexshape manipulator model: lengths mm, forces N, Kx/Kz N·mm², Ka/Kt N per unit strain"
    );
    print!("{text}");
    Ok(())
}

pub fn load(path: &Path) -> anyhow::Result<Model> {
    Ok(flexshape_lab::identify::load_model(path)?)
}

/// The model frame `flexshape model fit --save-frame` wrote.
pub fn load_frame(path: &Path) -> anyhow::Result<flexshape_record::ModelFrame> {
    Ok(flexshape_lab::identify::load_model_frame(path)?)
}

/// The input rows: `--values` or the CSV file's lines, each a list of numbers.
fn rows(args: &ModelArgs) -> anyhow::Result<Vec<(String, Vec<f64>)>> {
    let parse = |place: String, line: &str| -> anyhow::Result<(String, Vec<f64>)> {
        let v = line
            .split(',')
            .map(|x| x.trim().parse::<f64>())
            .collect::<Result<Vec<_>, _>>()
            .with_context(|| format!("{place}: `{line}` is not a list of numbers"))?;
        Ok((place, v))
    };
    match (&args.values, &args.csv) {
        (Some(v), None) => Ok(vec![parse("--values".into(), v)?]),
        (None, Some(path)) => {
            // Bounded, and regular files only (a FIFO or /dev/zero was read without end).
            let text = flexshape_rig::files::read_text(path, "CSV file")?;
            flexshape_rig::files::csv_lines(&text)
                .map(|(n, line, _)| parse(format!("{} line {n}", path.display()), line))
                .collect()
        }
        _ => bail!("give the input with --values or --csv"),
    }
}

pub fn forward(args: &ModelArgs) -> anyhow::Result<()> {
    let model = load(&args.params)?;
    let n = model.params().tendons.len();
    let csv = args.csv.is_some();
    if csv {
        println!("{}", Forward::csv_header(n));
    }
    for (place, y) in rows(args)? {
        if y.len() != n {
            bail!(
                "{place}: {} displacements for a model with {n} tendons",
                y.len()
            );
        }
        let f = model
            .forward(&DVector::from_vec(y))
            .with_context(|| place.clone())?;
        if csv {
            println!("{}", f.csv_row());
        } else {
            println!("{f}");
        }
    }
    Ok(())
}

pub fn inverse(args: &ModelArgs) -> anyhow::Result<()> {
    let model = load(&args.params)?;
    let n = model.params().tendons.len();
    let csv = args.csv.is_some();
    if csv {
        let y: Vec<String> = (0..n).map(|i| format!("y{i}_mm")).collect();
        println!("{}", y.join(","));
    }
    for (place, q) in rows(args)? {
        if !(3..=4).contains(&q.len()) {
            bail!("{place}: give κx, κz, ε0 (and optionally ε1, which follows from ε0)");
        }
        let y = model
            .inverse(&Vector4::new(
                q[0],
                q[1],
                q[2],
                q.get(3).copied().unwrap_or(0.0),
            ))
            .with_context(|| place.clone())?;
        let y: Vec<String> = y.iter().map(|v| format!("{v:.6}")).collect();
        if csv {
            println!("{}", y.join(","));
        } else {
            println!("tendon displacements (mm): {}", y.join(", "));
        }
    }
    Ok(())
}

/// The sensing accuracy of `bias` with tips and bases placed to `position_mm`, each value
/// checked against its range (the option named when it is outside).
pub fn sensing_accuracy(
    bias: &crate::cli::SensingBiasArgs,
    position_mm: f64,
) -> anyhow::Result<flexshape_model::SensingAccuracy> {
    for (name, v, hi) in [
        ("--curvature-accuracy", bias.curvature_accuracy, 100.0),
        ("--strain-accuracy", bias.strain_accuracy, 1.0),
        ("--position-accuracy", position_mm, 100.0),
    ] {
        if !(v.is_finite() && (0.0..=hi).contains(&v)) {
            bail!("{name} {v}: give a value from 0 to {hi}");
        }
    }
    Ok(flexshape_model::SensingAccuracy {
        curvature_share: bias.curvature_accuracy / 100.0,
        strain: bias.strain_accuracy,
        position_mm,
    })
}
