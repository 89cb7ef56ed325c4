//! `flexshape track` on a simulated recording, checked against its ground truth.

mod common;

use common::flexshape;

use flexshape_camera::nalgebra::Point3;
use flexshape_curve::Polyline;
use flexshape_recording::RecordingReader;
use serde_json::Value;

#[test]
fn tracks_a_simulated_recording_within_the_shape_targets_and_survives_a_corrupt_frame() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    let o = flexshape(&["simulate", "--out", rec.to_str().unwrap(), "--frames", "5"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // Frame 3 of cam1 is cut short on disk.
    let broken = rec.join("frames/cam1/000003.png");
    let bytes = std::fs::read(&broken).unwrap();
    std::fs::write(&broken, &bytes[..bytes.len() / 2]).unwrap();
    let out = dir.path().join("shapes.jsonl");
    let o = flexshape(&[
        "track",
        rec.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(
        stderr.contains("frame 000003") && stderr.contains("000003.png"),
        "{stderr}"
    );
    let lines: Vec<Value> = std::fs::read_to_string(&out)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 6, "five frames and a summary");
    let reader = RecordingReader::open(&rec).unwrap();
    let volume = reader.rig().volume;
    for (n, rec) in lines[..5].iter().enumerate() {
        assert_eq!(rec["frame"], n as u64);
        if n == 3 {
            assert_eq!(rec["status"], "error");
            assert!(rec["reason"].as_str().unwrap().contains("cam1"), "{rec}");
            continue;
        }
        assert_eq!(rec["status"], "ok", "{rec}");
        let truth = reader.read_truth(n as u64).unwrap().unwrap();
        let points: Vec<Point3<f64>> = rec["centerline"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| {
                Point3::new(
                    p[0].as_f64().unwrap(),
                    p[1].as_f64().unwrap(),
                    p[2].as_f64().unwrap(),
                )
            })
            .collect();
        // ≤ 1 mm spacing, as the format promises.
        assert!(
            points
                .windows(2)
                .all(|w| (w[1] - w[0]).norm() <= 1.0 + 1e-9)
        );
        let curve = Polyline::new(points).unwrap();
        let d2: Vec<f64> = truth
            .centerline
            .iter()
            .map(|&p| Point3::from(p))
            .filter(|p| volume.contains(p))
            .map(|p| curve.closest(&p).1.powi(2))
            .collect();
        let rms = (d2.iter().sum::<f64>() / d2.len() as f64).sqrt();
        let tip = rec["tip"].as_array().unwrap();
        let tip = Point3::new(
            tip[0].as_f64().unwrap(),
            tip[1].as_f64().unwrap(),
            tip[2].as_f64().unwrap(),
        );
        let tip_error = (tip - Point3::from(truth.tip)).norm();
        assert!(rms <= 0.3, "frame {n}: centerline rms {rms:.3} mm");
        assert!(tip_error <= 1.0, "frame {n}: tip {tip_error:.2} mm");
        assert_eq!(rec["bands"].as_array().unwrap().len(), 2, "frame {n}");
        assert!(rec["arc_fit"]["curvature"].as_f64().unwrap() > 0.0);
    }
    let summary = &lines[5]["summary"];
    assert_eq!(summary["frames"], 5);
    assert_eq!(summary["ok"], 4);
    assert_eq!(summary["errors"], 1);
    assert_eq!(summary["stages"].as_array().unwrap().len(), 4);
}

#[test]
fn track_reports_missing_input_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let o = flexshape(&["track", dir.path().join("nothing").to_str().unwrap()]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("nothing"));
    let rec = dir.path().join("rec");
    assert!(
        flexshape(&["simulate", "--out", rec.to_str().unwrap(), "--frames", "1"])
            .status
            .success()
    );
    std::fs::remove_file(rec.join("background/cam2.png")).unwrap();
    let o = flexshape(&[
        "track",
        rec.to_str().unwrap(),
        "--out",
        dir.path().join("x.jsonl").to_str().unwrap(),
    ]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && e.contains("cam2") && e.contains("flexshape background"),
        "{e}"
    );
    let o = flexshape(&["track", rec.to_str().unwrap(), "--volume", "1,2,3"]);
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("six numbers"));
}
