//! The paper's model experiment end to end through the binary: the simulator poses the catheter
//! by the tendon model (`simulate --model`), the sensing chain tracks it (`track`), and the
//! tensionless estimation recovers the stiffnesses (`model fit`).

use crate::common;

use common::{fails, run};

use std::path::Path;

/// The paper's catheter with polymer tendons (Kt = 1500 N per unit strain): stiff steel
/// tendons (the template's 14,000) make the estimate 15–26× as sensitive to curvature errors
/// (see `sensitivity` in the report) and the same sensing then gives Kx within 6 %.
fn params(dir: &Path) -> String {
    let template = run(&["model", "template"]);
    let path = dir.join("params.toml");
    std::fs::write(
        &path,
        template.replace("stiffness = 14000.0", "stiffness = 1500.0"),
    )
    .unwrap();
    path.to_str().unwrap().to_string()
}

#[test]
fn simulated_experiment_recovers_the_stiffnesses() {
    let dir = tempfile::tempdir().unwrap();
    let params = params(dir.path());
    let rec = dir.path().join("rec");
    let rec = rec.to_str().unwrap();
    run(&["simulate", "--out", rec, "--model", &params]);
    assert!(Path::new(rec).join("commands/000000.json").is_file());
    let shapes = dir.path().join("shapes.jsonl");
    let shapes = shapes.to_str().unwrap();
    run(&["track", rec, "--out", shapes]);
    let plots = dir.path().join("plots");
    let frame = dir.path().join("frame.json");
    let frame = frame.to_str().unwrap();
    let report: serde_json::Value = serde_json::from_str(&run(&[
        "model",
        "fit",
        "--params",
        &params,
        "--data",
        shapes,
        "--json",
        "--plots",
        plots.to_str().unwrap(),
        "--save-frame",
        frame,
    ]))
    .unwrap();
    // Fig. 10: sensed against model, drawn and not blank.
    let img = image::open(plots.join("model_vs_sensed.png"))
        .unwrap()
        .to_rgb8();
    let inked = img.pixels().filter(|p| p.0 != [255, 255, 255]).count();
    assert!(
        inked * 20 > (img.width() * img.height()) as usize,
        "{inked}"
    );
    println!("{report:#}");
    let get = |key: &str, i: usize| report[key][i].as_f64().unwrap();
    assert_eq!(report["observations"], 30);
    assert_eq!(report["registration_poses"], 4);
    assert_eq!(report["reference_pose"], true);
    assert!(report["skipped"].as_array().unwrap().is_empty());
    assert!(
        report["held"].as_array().unwrap().is_empty(),
        "every stiffness estimated"
    );
    // Bending stiffnesses within 1 % (measured with the tube fitted to the images: −0.05 %,
    // −0.04 %; from the hull's centerline: −0.8 %, −0.4 %).
    for j in 0..2 {
        let error = get("estimated", j) / get("nominal", j) - 1.0;
        assert!(error.abs() < 0.01, "K[{j}] off by {:.2} %", 100.0 * error);
    }
    // Ka0 from the bending base's retreat over L0 = 1000 mm (measured −3.3 %; from the hull
    // −6 %: the base band's position bias against a 4 mm compression, amplified 2.3×).
    let error = get("estimated", 2) / get("nominal", 2) - 1.0;
    assert!(error.abs() < 0.06, "Ka0 off by {:.1} %", 100.0 * error);
    // Ka1 rests on a 0.4 mm compression of the 155 mm bending section measured between its
    // bands: the bands' spacing is biased by 0.05 mm (strain +0.0003 on the simulated sweep,
    // `crates/fit/tests/accuracy.rs`), which takes Ka1 14 % low (measured −14 %).
    let error = get("estimated", 3) / get("nominal", 3) - 1.0;
    assert!(error.abs() < 0.2, "Ka1 off by {:.1} %", 100.0 * error);
    // The intervals count the sensing's bias as well as the poses' scatter: the truth lies
    // within two of them for every stiffness, and those over 10 % are said to be.
    for j in 0..4 {
        let (est, total) = (get("estimated", j), get("total_error", j));
        println!("K[{j}] {est:.1} ± {total:.1} (truth {})", get("nominal", j));
        assert!((est - get("nominal", j)).abs() <= 2.0 * total, "K[{j}]");
        let said = report["undetermined"]
            .as_array()
            .unwrap()
            .iter()
            .any(|h| h["parameter"] == ["Kx", "Kz", "Ka0", "Ka1"][j]);
        assert_eq!(said, total > 0.1 * est, "K[{j}]");
    }
    // The fitted model predicts the tips within 0.5 % of L1 (measured 0.09 %; the paper's
    // Table I: 4.8 %).
    assert!(get("tip_error_percent", 1) < 0.5);
    joint_within_its_intervals(&report);
    assert!(get("registration_residual_deg", 0) < 1.0);
    assert!(get("registration_residual_deg", 1) < 0.5);

    // A known frame instead of registration poses (a lab's fixed base): the same estimate
    // from the records without them.
    let unregistered = dir.path().join("unregistered.jsonl");
    let text = std::fs::read_to_string(shapes).unwrap();
    let kept: Vec<&str> = text
        .lines()
        .filter(|l| !l.contains(r#""role":"register""#))
        .collect();
    assert!(kept.len() > 25);
    std::fs::write(&unregistered, kept.join("\n") + "\n").unwrap();
    let known: serde_json::Value = serde_json::from_str(&run(&[
        "model",
        "fit",
        "--params",
        &params,
        "--data",
        unregistered.to_str().unwrap(),
        "--frame",
        frame,
        "--json",
    ]))
    .unwrap();
    assert_eq!(known["registration_poses"], 0);
    assert_eq!(known["reference_pose"], true);
    for j in 0..2 {
        let (a, b) = (get("estimated", j), known["estimated"][j].as_f64().unwrap());
        assert!(
            (a / b - 1.0).abs() < 0.005,
            "K[{j}] {a} vs {b} with the known frame"
        );
    }
    let e = fails(&[
        "model", "fit", "--params", &params, "--data", shapes, "--frame", shapes,
    ]);
    assert!(e.contains("not a model frame"), "{e}");

    // Records without displacements, and the actuators' log beside them (a lab's recording):
    // the same estimate.
    let (mut csv, mut bare) = (String::from("frame,y0,y1,y2,y3\n"), String::new());
    for line in text.lines() {
        let mut v: serde_json::Value = serde_json::from_str(line).unwrap();
        if let Some(y) = v
            .get("tendon_displacements")
            .and_then(|y| y.as_array())
            .cloned()
        {
            let ys: Vec<String> = y.iter().map(|x| x.to_string()).collect();
            csv += &format!("{},{}\n", v["frame"], ys.join(","));
            v.as_object_mut().unwrap().remove("tendon_displacements");
        }
        bare += &(v.to_string() + "\n");
    }
    let (csv_path, bare_path) = (dir.path().join("y.csv"), dir.path().join("bare.jsonl"));
    std::fs::write(&csv_path, csv).unwrap();
    std::fs::write(&bare_path, bare).unwrap();
    let logged: serde_json::Value = serde_json::from_str(&run(&[
        "model",
        "fit",
        "--params",
        &params,
        "--data",
        bare_path.to_str().unwrap(),
        "--displacements",
        csv_path.to_str().unwrap(),
        "--json",
    ]))
    .unwrap();
    assert_eq!(logged["estimated"], report["estimated"]);
    let e = fails(&[
        "model",
        "fit",
        "--params",
        &params,
        "--data",
        bare_path.to_str().unwrap(),
    ]);
    assert!(e.contains("--displacements"), "{e}");
    std::fs::write(&csv_path, "frame,y0\n0,1\n").unwrap();
    let e = fails(&[
        "model",
        "fit",
        "--params",
        &params,
        "--data",
        bare_path.to_str().unwrap(),
        "--displacements",
        csv_path.to_str().unwrap(),
    ]);
    assert!(e.contains("y.csv line 2") && e.contains("4 tendons"), "{e}");

    // With the saved model frame, tracking reports κx, κz as the model defines them: the
    // simulator's truth (it posed the catheter by the model's q).
    let with_frame = dir.path().join("with_frame.jsonl");
    run(&[
        "track",
        rec,
        "--out",
        with_frame.to_str().unwrap(),
        "--model-frame",
        frame,
    ]);
    let (mut checked, mut worst) = (0, 0.0f64);
    for line in std::fs::read_to_string(&with_frame).unwrap().lines() {
        let record: serde_json::Value = serde_json::from_str(line).unwrap();
        let (Some(fit), Some(n)) = (record.get("arc_fit"), record["frame"].as_u64()) else {
            continue;
        };
        let truth: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(Path::new(rec).join(format!("truth/{n:06}.json"))).unwrap(),
        )
        .unwrap();
        let k = |v: &serde_json::Value| v.as_f64().unwrap();
        let (kx, kz) = (k(&truth["kappa"][0]), k(&truth["kappa"][1]));
        if kx.hypot(kz) < 1e-3 || fit.is_null() {
            continue;
        }
        let error = (k(&fit["kappa_x"]) - kx).hypot(k(&fit["kappa_z"]) - kz);
        assert!(
            error < 0.03 * kx.hypot(kz),
            "frame {n}: κ ({}, {}) vs truth ({kx}, {kz})",
            fit["kappa_x"],
            fit["kappa_z"]
        );
        worst = worst.max(error / kx.hypot(kz));
        checked += 1;
    }
    println!(
        "κx, κz in the model frame: worst {:.2} % of κ over {checked} frames",
        worst * 100.0
    );
    assert!(checked >= 25, "{checked} bent frames checked");
    // A file that is not a rotation is refused by name.
    let bad = dir.path().join("bad.json");
    std::fs::write(&bad, r#"{"rotation": [[1,0,0],[0,1,0],[0,0,-1]]}"#).unwrap();
    let e = fails(&[
        "track",
        rec,
        "--out",
        "-",
        "--model-frame",
        bad.to_str().unwrap(),
    ]);
    assert!(e.contains("bad.json") && e.contains("reflection"), "{e}");
}

#[test]
fn fit_input_errors_name_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let params = params(dir.path());
    let data = dir.path().join("data.jsonl");
    let fit = |contents: &str| {
        std::fs::write(&data, contents).unwrap();
        fails(&[
            "model",
            "fit",
            "--params",
            &params,
            "--data",
            data.to_str().unwrap(),
        ])
    };
    // Records without commands.
    let t = fit("{\"summary\": {}}\n");
    assert!(t.contains("tendon_displacements"), "{t}");
    // Three displacements for a four-tendon model: the line and frame are named.
    let record = r#"{"frame":7,"status":"ok","centerline":[],"tip":null,"tip_direction":null,"arc_length":0,"bands":[],"arc_fit":null,"voxels":0,"timings_ms":{"silhouettes":0,"carve":0,"bands":0,"shape":0},"tendon_displacements":[1,2,3]}"#;
    let t = fit(&format!("{record}\n"));
    assert!(
        t.contains("line 1") && t.contains("frame 7") && t.contains("4 tendons"),
        "{t}"
    );
    // Not JSON.
    let t = fit("garbage\n");
    assert!(t.contains("line 1: not JSON"), "{t}");
    // A folder that is not a recording: said so, with what else `--data` takes.
    let t = fails(&[
        "model",
        "fit",
        "--params",
        &params,
        "--data",
        dir.path().to_str().unwrap(),
    ]);
    assert!(
        t.contains("read as a recording") && t.contains("JSON Lines"),
        "{t}"
    );
}

/// Stiff steel tendons (the template's, 40× the bending stiffness): the same sensing now
/// determines the bending stiffnesses (measured within 0.3 %, ±2.5 % with the sensing) but not
/// the axial ones (their compressions amplified 3–17×): the report says so, naming what poses
/// would help, and its intervals still hold the truth.
#[test]
fn stiff_tendons_leave_the_axial_stiffnesses_undetermined_and_say_so() {
    let dir = tempfile::tempdir().unwrap();
    let params = dir.path().join("params.toml");
    std::fs::write(&params, run(&["model", "template"])).unwrap();
    let params = params.to_str().unwrap();
    let rec = dir.path().join("rec");
    let rec = rec.to_str().unwrap();
    run(&["simulate", "--out", rec, "--model", params]);
    let shapes = dir.path().join("shapes.jsonl");
    let shapes = shapes.to_str().unwrap();
    run(&["track", rec, "--out", shapes]);
    let report: serde_json::Value = serde_json::from_str(&run(&[
        "model", "fit", "--params", params, "--data", shapes, "--json",
    ]))
    .unwrap();
    let get = |key: &str, j: usize| report[key][j].as_f64().unwrap();
    let undetermined: Vec<&str> = report["undetermined"]
        .as_array()
        .unwrap()
        .iter()
        .map(|h| h["parameter"].as_str().unwrap())
        .collect();
    assert_eq!(undetermined, ["Ka0", "Ka1"]);
    for j in 0..4 {
        let (est, total, truth) = (
            get("estimated", j),
            get("total_error", j),
            get("nominal", j),
        );
        println!("K[{j}] {est:.1} ± {total:.1} (truth {truth})");
        assert!((est - truth).abs() <= 2.0 * total, "K[{j}]");
    }
    joint_within_its_intervals(&report);
    // The whole workflow in one command: the recording folder tracked by `model fit` itself
    // (the records in memory at full precision, the file's rounded: the same to 0.1 %).
    let direct: serde_json::Value = serde_json::from_str(&run(&[
        "model", "fit", "--params", params, "--data", rec, "--json",
    ]))
    .unwrap();
    assert_eq!(direct["observations"], report["observations"]);
    for j in 0..4 {
        let (a, b) = (
            get("estimated", j),
            direct["estimated"][j].as_f64().unwrap(),
        );
        assert!(
            (a / b - 1.0).abs() < 1e-3,
            "K[{j}] {a} from the file, {b} from the folder"
        );
    }
    // And the text report says what would determine them.
    let text = run(&["model", "fit", "--params", params, "--data", shapes]);
    assert!(
        text.contains("Ka1 not determined to 10 %")
            && text.contains("add poses with all tendons pulled"),
        "{text}"
    );
}

/// The joint (output-error) identification beside the two-step one: the truth within twice
/// its interval (scatter and sensing bias) for every stiffness, those over 10 % said to be,
/// and the tips within 1 % of L1 (the issue's target).
fn joint_within_its_intervals(report: &serde_json::Value) {
    let joint = &report["joint"];
    assert!(joint.get("refused").is_none(), "{joint:#}");
    let get = |key: &str, j: usize| joint[key][j].as_f64().unwrap();
    for j in 0..4 {
        let (est, total, truth) = (
            get("estimated", j),
            get("total_error", j),
            report["nominal"][j].as_f64().unwrap(),
        );
        println!("joint K[{j}] {est:.1} ± {total:.1} (truth {truth})");
        assert!((est - truth).abs() <= 2.0 * total, "joint K[{j}]");
        let said = joint["held"]
            .as_array()
            .unwrap()
            .iter()
            .any(|h| h["parameter"] == ["Kx", "Kz", "Ka0", "Ka1"][j]);
        assert_eq!(said, total > 0.1 * est, "joint K[{j}]");
    }
    assert!(get("tip_error_percent", 1) < 1.0);
    assert!(joint["registration_change_deg"].as_f64().unwrap() < 0.5);
}

/// `model plan` predicts the intervals a run will report: the template catheter (steel
/// tendons) leaves Ka0 and Ka1 undetermined at the paper's preload and names the preload that
/// would do; simulated at 0.032 and fitted, each stiffness's interval is the one predicted
/// (measured: Ka0 ±14 % and Ka1 ±14 % both ways).
#[test]
fn the_plan_predicts_the_intervals_a_run_reports() {
    let dir = tempfile::tempdir().unwrap();
    let params = dir.path().join("params.toml");
    std::fs::write(&params, run(&["model", "template"])).unwrap();
    let params = params.to_str().unwrap();
    let plan: serde_json::Value =
        serde_json::from_str(&run(&["model", "plan", "--params", params, "--json"])).unwrap();
    println!("{plan:#}");
    let candidates = plan["candidates"].as_array().unwrap();
    let preloads: Vec<f64> = candidates
        .iter()
        .map(|c| c["preload"].as_f64().unwrap())
        .collect();
    assert_eq!(preloads, [0.002, 0.004, 0.008, 0.016, 0.02]);
    assert_eq!(plan["determined_from"][0], 0.002);
    for j in 2..4 {
        assert!(plan["determined_from"][j].is_null(), "{j}");
        let needed = plan["needed"][j].as_f64().unwrap();
        assert!((0.03..0.06).contains(&needed), "{j}: {needed}");
    }
    // The same plan at 0.032, then the run.
    let plan: serde_json::Value = serde_json::from_str(&run(&[
        "model",
        "plan",
        "--params",
        params,
        "--max-strain",
        "0.032",
        "--json",
    ]))
    .unwrap();
    let predicted = &plan["candidates"][4]["relative_error"];
    assert_eq!(plan["candidates"][4]["preload"], 0.032);
    let rec = dir.path().join("rec");
    let rec = rec.to_str().unwrap();
    run(&[
        "simulate",
        "--out",
        rec,
        "--model",
        params,
        "--preload",
        "0.032",
    ]);
    let shapes = dir.path().join("shapes.jsonl");
    let shapes = shapes.to_str().unwrap();
    run(&["track", rec, "--out", shapes]);
    let report: serde_json::Value = serde_json::from_str(&run(&[
        "model", "fit", "--params", params, "--data", shapes, "--json",
    ]))
    .unwrap();
    for j in 0..4 {
        let (est, total, truth) = (
            report["estimated"][j].as_f64().unwrap(),
            report["total_error"][j].as_f64().unwrap(),
            report["nominal"][j].as_f64().unwrap(),
        );
        let (got, want) = (total / est, predicted[j].as_f64().unwrap());
        println!(
            "K[{j}] {est:.1} ± {:.1} %, predicted ±{:.1} % (truth {truth})",
            got * 100.0,
            want * 100.0
        );
        assert!((got / want - 1.0).abs() < 0.2, "K[{j}]");
        assert!((est - truth).abs() <= 2.0 * total, "K[{j}]");
    }
}

/// The issue's coverage target over seeds: the template catheter (steel tendons) simulated
/// with six seeds (noise, texture), tracked and fitted. In every run and for both estimates
/// (two-step and joint) Kx, Kz are within 5 % and every stiffness's truth lies within twice
/// its interval, or the stiffness is said to be undetermined and still within twice it; the
/// model's tips within 1 % of L1. Measured: Kx, Kz within 0.4 %; Ka0 −23…−26 %, Ka1
/// −30…−35 %, at most 0.4 σ of their (wide, undetermined) intervals; tips ≤ 0.06 %.
#[test]
fn intervals_cover_the_truth_over_seeds() {
    let dir = tempfile::tempdir().unwrap();
    let params = dir.path().join("params.toml");
    std::fs::write(&params, run(&["model", "template"])).unwrap();
    let params = params.to_str().unwrap();
    let mut covered = [0usize; 2];
    let seeds = 2..8;
    for seed in seeds.clone() {
        let rec = dir.path().join(format!("rec{seed}"));
        let rec = rec.to_str().unwrap();
        let seed = seed.to_string();
        run(&["simulate", "--out", rec, "--model", params, "--seed", &seed]);
        let shapes = dir.path().join(format!("shapes{seed}.jsonl"));
        let shapes = shapes.to_str().unwrap();
        run(&["track", rec, "--out", shapes]);
        let report: serde_json::Value = serde_json::from_str(&run(&[
            "model", "fit", "--params", params, "--data", shapes, "--json",
        ]))
        .unwrap();
        for (k, (fit, undetermined)) in [
            (&report, &report["undetermined"]),
            (&report["joint"], &report["joint"]["held"]),
        ]
        .into_iter()
        .enumerate()
        {
            let mut all = true;
            for j in 0..4 {
                let (est, total, truth) = (
                    fit["estimated"][j].as_f64().unwrap(),
                    fit["total_error"][j].as_f64().unwrap(),
                    report["nominal"][j].as_f64().unwrap(),
                );
                let said = undetermined
                    .as_array()
                    .unwrap()
                    .iter()
                    .any(|h| h["parameter"] == ["Kx", "Kz", "Ka0", "Ka1"][j]);
                println!(
                    "seed {seed} {}: K[{j}] {:+.1} % ± {:.1} %{}",
                    ["two-step", "joint"][k],
                    100.0 * (est / truth - 1.0),
                    100.0 * total / est,
                    if said { " (undetermined)" } else { "" }
                );
                if j < 2 {
                    assert!((est / truth - 1.0).abs() < 0.05, "seed {seed}: K[{j}]");
                }
                all &= (est - truth).abs() <= 2.0 * total;
            }
            covered[k] += usize::from(all);
        }
        let tips = report["joint"]["tip_error_percent"][1].as_f64().unwrap();
        assert!(tips < 1.0, "seed {seed}: tips {tips} %");
        assert!(report["tip_error_percent"][1].as_f64().unwrap() < 1.0);
    }
    let runs = seeds.len();
    println!(
        "covered: two-step {}/{runs}, joint {}/{runs}",
        covered[0], covered[1]
    );
    for c in covered {
        assert!(10 * c >= 9 * runs, "{covered:?} of {runs}");
    }
}

/// `model steer`: the closed loop through the binary — the template catheter 25 % stiffer about
/// x and 20 % softer about z than its file says, steered to two targets (measured: within
/// 0.08 mm; Kx, Kz learnt within 0.5 %).
#[test]
fn steer_reaches_the_targets_and_learns_the_stiffnesses() {
    let dir = tempfile::tempdir().unwrap();
    let params = dir.path().join("params.toml");
    std::fs::write(&params, run(&["model", "template"])).unwrap();
    let params = params.to_str().unwrap();
    let plots = dir.path().join("plots");
    let out = run(&[
        "model",
        "steer",
        "--params",
        params,
        "--targets",
        "2",
        "--steps",
        "6",
        "--json",
        "--plots",
        plots.to_str().unwrap(),
    ]);
    let img = image::open(plots.join("steer.png")).unwrap().to_rgb8();
    let inked = img.pixels().filter(|p| p.0 != [255, 255, 255]).count();
    assert!(
        inked * 50 > (img.width() * img.height()) as usize,
        "{inked}"
    );
    assert!(plots.join("steer.svg").is_file());
    let lines: Vec<serde_json::Value> = out
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 13, "12 frames and the summary");
    let summary = &lines[12];
    println!("{summary:#}");
    assert!(summary["worst_final_true_error_mm"].as_f64().unwrap() < 1.0);
    for j in 0..2 {
        let (got, want) = (
            summary["learnt_stiffness"][j].as_f64().unwrap(),
            summary["true_stiffness"][j].as_f64().unwrap(),
        );
        assert!((got / want - 1.0).abs() < 0.05, "K[{j}] {got} vs {want}");
    }
    let e = fails(&[
        "model",
        "steer",
        "--params",
        params,
        "--stiffness-error",
        "25",
    ]);
    assert!(e.contains("--stiffness-error"), "{e}");
}
