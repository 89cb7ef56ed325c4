//! The demo as a library: the model-driven catheter on the simulated rig, tracked frame by
//! frame and measured against the simulator's truth.

use std::ops::ControlFlow;
use std::sync::atomic::AtomicBool;

use flexshape_lab::demo::{Demo, DemoFigures};
use flexshape_model::{ManipulatorParams, Model};
use flexshape_track::Processed;

#[test]
fn the_demo_tracks_the_sweep_within_a_tenth_of_a_millimetre() {
    let model = Model::new(ManipulatorParams::paper_like()).unwrap();
    let out = tempfile::tempdir().unwrap();
    let demo = Demo::new(
        flexshape_sim::SimConfig::default(),
        model,
        Some(&out.path().join("rec")),
        2,
    )
    .unwrap();
    let mut source = demo.on_demand(Some(4), 2.0);
    let mut figures = DemoFigures::default();
    let mut statuses = Vec::new();
    let end = flexshape_track::run(
        &mut source,
        &demo.pipeline,
        1,
        &AtomicBool::new(false),
        |p: Processed| {
            let record = p.record().with_model_frame(&demo.model_frame);
            statuses.push(record.status.to_string());
            // The simulator built the catheter in the model's frame: κx, κz are reported, as
            // the model defines them.
            let fit = record.arc_fit.as_ref().expect("an arc fit");
            let truth = p
                .truth
                .as_ref()
                .and_then(|t| t.kappa)
                .expect("true curvatures");
            for (sensed, truth) in [fit.kappa_x, fit.kappa_z].into_iter().zip(truth) {
                let sensed = sensed.expect("κ in the model frame");
                assert!((sensed - truth).abs() < 1e-4, "{sensed} vs {truth} 1/mm");
            }
            figures.add(&demo.errors(&p).expect("truth and a shape"));
            ControlFlow::Continue(())
        },
    );
    assert!(end.input_error.is_none());
    assert_eq!(statuses, ["ok"; 4]);
    assert!(DemoFigures::worst(&figures.rms) < 0.1, "{:?}", figures.rms);
    assert!(DemoFigures::worst(&figures.tip) < 0.3, "{:?}", figures.tip);
    assert!(demo.rig.render_ms() > 0.0);
    // Every rendered frame was written with its command and truth.
    let reader = flexshape_recording::RecordingReader::open(&out.path().join("rec")).unwrap();
    assert_eq!(reader.frames().len(), 4);
}
