//! Rigs, tracking a recording, tracking frames from the lab's own cameras, reading records.

use std::ops::ControlFlow;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

use flexshape_record::TrackRecord;
use flexshape_silhouette::BackgroundModel;
use flexshape_track::{CameraTimes, Pipeline, Recent, Recording};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyBool;

use crate::arrays::images_from;
use crate::record::PyRecord;
use crate::rig::PyRig;
use crate::{chain, fail, fail_with};

/// Follows the tube from frame to frame in the images of the lab's own cameras: each frame
/// starts from the newest right shape (no carving while it follows) and falls back to the
/// whole chain (silhouettes, carving, the hull's centerline, the fit) when that shape does not
/// explain the images.
#[pyclass(name = "Tracker", module = "flexshape")]
pub(crate) struct PyTracker {
    pipeline: Pipeline,
    recent: Recent,
    next_frame: u64,
}

#[pymethods]
impl PyTracker {
    /// A tracker for `rig`, with one background image per camera (the empty scene, `(height,
    /// width, 3)` `uint8` RGB, in the rig's order; `channels="bgr"` for OpenCV's images).
    /// `follow=False` runs the whole chain on every frame.
    #[new]
    #[pyo3(signature = (rig, backgrounds, follow = true, channels = "rgb"))]
    fn new(
        rig: &PyRig,
        backgrounds: Vec<Bound<'_, PyAny>>,
        follow: bool,
        channels: &str,
    ) -> PyResult<Self> {
        let images = images_from(backgrounds, "backgrounds", channels)?;
        if images.len() != rig.rig.cameras.len() {
            return Err(PyValueError::new_err(format!(
                "backgrounds: give one image per camera ({}), got {}",
                rig.rig.cameras.len(),
                images.len()
            )));
        }
        let models = BackgroundModel::each(&images).map_err(|e| fail(&e))?;
        let pipeline = Pipeline::new(&rig.rig, &models, &rig.rig.volume).map_err(|e| fail(&e))?;
        Self::with(pipeline, follow)
    }

    /// A tracker for the rig and backgrounds of a recording folder (as `flexshape simulate`
    /// or `flexshape capture` writes it).
    #[staticmethod]
    #[pyo3(signature = (path, follow = true))]
    fn from_recording(path: PathBuf, follow: bool) -> PyResult<Self> {
        let recording = Recording::open(&path).map_err(|e| fail(&e))?;
        Self::with(recording.pipeline().map_err(|e| fail(&e))?, follow)
    }

    /// One frame: one image per camera in the rig's order, each `(height, width, 3)` `uint8`
    /// RGB (`channels="bgr"`: OpenCV's order, as `cv2.imread` gives). `frame` numbers it (default: one more than the last). `captured_s`: when it was
    /// captured, seconds in any time base of yours (the record's `captured_s`); with
    /// `camera_captured_s`, each camera's own capture (same base, rig order) for cameras that are
    /// not triggered together: each is then held to the tube where it was at its capture and
    /// the shape is the tube at `captured_s` (default: the earliest camera's). Returns its record.
    #[pyo3(signature = (images, frame = None, captured_s = None, camera_captured_s = None, channels = "rgb"))]
    fn process(
        &mut self,
        py: Python<'_>,
        images: Vec<Bound<'_, PyAny>>,
        frame: Option<u64>,
        captured_s: Option<f64>,
        camera_captured_s: Option<Vec<f64>>,
        channels: &str,
    ) -> PyResult<PyRecord> {
        let images = images_from(images, "images", channels)?;
        let (at_s, camera_times) = self.times(captured_s, camera_captured_s)?;
        let n = frame.unwrap_or(self.next_frame);
        let (pipeline, recent) = (&self.pipeline, &mut self.recent);
        let record = py.detach(|| {
            let refs: Vec<&image::RgbImage> = images.iter().collect();
            let prior = recent.for_frame(n);
            let times = CameraTimes::of(at_s, camera_times.as_deref());
            let tracked = pipeline.process_after_at(&refs, prior.as_deref(), times.as_ref())?;
            recent.update(n, tracked.prior_at(at_s));
            let mut record = tracked.record(n);
            record.captured_s = at_s;
            record.captured_from = at_s.map(|_| flexshape_record::CapturedFrom::Given);
            record.camera_captured_s = camera_times.unwrap_or_default();
            Ok::<_, flexshape_track::TrackError>(record)
        });
        let record = record.map_err(|e| fail_with(format!("frame {n}: {}", chain(&e))))?;
        self.next_frame = n + 1;
        Ok(PyRecord::new(record))
    }

    /// Forgets the frames seen so far: the next frame starts from its own hull.
    fn reset(&mut self) {
        self.recent = Recent::new(&self.pipeline);
    }

    /// Whether frames may start from an earlier frame's shape (the fit's tracking is on and
    /// at least two cameras see the tube).
    #[getter]
    fn follows(&self) -> bool {
        self.pipeline.tracks()
    }
}

impl PyTracker {
    /// `process`'s `captured_s` and `camera_captured_s` checked: finite, one per camera; the
    /// frame's time defaults to the earliest camera's.
    fn times(
        &self,
        time: Option<f64>,
        camera_times: Option<Vec<f64>>,
    ) -> PyResult<(Option<f64>, Option<Vec<f64>>)> {
        if let Some(t) = time.filter(|t| !t.is_finite()) {
            return Err(PyValueError::new_err(format!(
                "captured_s={t}: give the frame's capture time in seconds"
            )));
        }
        let Some(each) = camera_times else {
            return Ok((time, None));
        };
        let cameras = self.pipeline.camera_names().len();
        if each.len() != cameras || each.iter().any(|t| !t.is_finite()) {
            return Err(PyValueError::new_err(format!(
                "camera_captured_s={each:?}: give each camera's capture time in seconds, one per camera ({cameras}), in the rig's order"
            )));
        }
        let earliest = each.iter().copied().fold(f64::INFINITY, f64::min);
        Ok((Some(time.unwrap_or(earliest)), Some(each)))
    }

    fn with(pipeline: Pipeline, follow: bool) -> PyResult<Self> {
        let pipeline = pipeline.following(follow).map_err(|e| fail(&e))?;
        Ok(PyTracker {
            recent: Recent::new(&pipeline),
            pipeline,
            next_frame: 0,
        })
    }
}

/// Tracks a recording folder as `flexshape track REC` does, on `threads` threads, and returns
/// its records in frame order. `on_record(record)` (optional) sees each as it comes; returning
/// False stops early. Ctrl-C stops too (raising KeyboardInterrupt); a frame that cannot be read
/// ends the run with an error naming it.
#[pyfunction]
#[pyo3(signature = (recording, threads = 2, on_record = None))]
pub(crate) fn track(
    py: Python<'_>,
    recording: PathBuf,
    threads: usize,
    on_record: Option<Bound<'_, PyAny>>,
) -> PyResult<Vec<PyRecord>> {
    let mut opened = Recording::open(&recording).map_err(|e| fail(&e))?;
    let pipeline = opened.pipeline().map_err(|e| fail(&e))?;
    let callback = on_record.map(Bound::unbind);
    let stop = AtomicBool::new(false);
    let mut records = Vec::new();
    let mut raised: Option<PyErr> = None;
    let end = py.detach(|| {
        flexshape_track::run(&mut opened.source, &pipeline, threads, &stop, |processed| {
            let record = processed.record();
            let go_on = Python::attach(|py| -> PyResult<bool> {
                py.check_signals()?;
                let Some(cb) = &callback else {
                    return Ok(true);
                };
                let answer = cb.call1(py, (PyRecord::new(record.clone()),))?;
                // Only False stops: None (no return) goes on.
                let answer = answer.bind(py);
                Ok(!answer.is_instance_of::<PyBool>() || answer.extract::<bool>()?)
            });
            records.push(record);
            match go_on {
                Ok(true) => ControlFlow::Continue(()),
                Ok(false) => ControlFlow::Break(()),
                Err(e) => {
                    raised = Some(e);
                    stop.store(true, Ordering::Relaxed);
                    ControlFlow::Break(())
                }
            }
        })
    });
    if let Some(e) = raised {
        return Err(e);
    }
    if let Some(broke) = input_broke(&recording, end) {
        return Err(fail_with(broke));
    }
    Ok(records.into_iter().map(PyRecord::new).collect())
}

/// Tracks a recording folder as `flexshape track REC` does, on `threads` threads, yielding
/// each record in frame order as soon as it is made (the frames after it are tracked
/// meanwhile): `for record in flexshape.iter_track("rec"): ...`. Breaking out of the loop (or
/// `close()`) stops the tracking; a frame that cannot be read ends the iteration with an error
/// naming it; Ctrl-C raises KeyboardInterrupt.
#[pyfunction]
#[pyo3(signature = (recording, threads = 2))]
pub(crate) fn iter_track(recording: PathBuf, threads: usize) -> PyResult<PyTrackIter> {
    if threads == 0 {
        return Err(PyValueError::new_err("threads=0: give 1 or more"));
    }
    let mut opened = Recording::open(&recording).map_err(|e| fail(&e))?;
    let pipeline = opened.pipeline().map_err(|e| fail(&e))?;
    let stop = Arc::new(AtomicBool::new(false));
    // A few records ahead at most: the consumer sets the pace.
    let (sender, records) = std::sync::mpsc::sync_channel(2 * threads);
    let stopping = stop.clone();
    let path = recording.clone();
    let worker = std::thread::Builder::new()
        .name("flexshape-track".into())
        .spawn(move || {
            let end =
                flexshape_track::run(&mut opened.source, &pipeline, threads, &stopping, |p| {
                    match sender.send(p.record()) {
                        Ok(()) => ControlFlow::Continue(()),
                        // The iterator is gone: nobody reads on.
                        Err(_) => ControlFlow::Break(()),
                    }
                });
            input_broke(&path, end)
        })
        .map_err(|e| fail_with(format!("cannot start tracking: {e}")))?;
    Ok(PyTrackIter {
        records: Some(Mutex::new(records)),
        stop,
        worker: Some(worker),
    })
}

/// The records of [`iter_track`], as they come.
#[pyclass(name = "TrackIter", module = "flexshape")]
pub(crate) struct PyTrackIter {
    /// Behind a lock so that waiting for the next one can release the interpreter.
    records: Option<Mutex<std::sync::mpsc::Receiver<TrackRecord>>>,
    stop: Arc<AtomicBool>,
    /// The tracking thread; its answer is why the input broke, if it did.
    worker: Option<std::thread::JoinHandle<Option<String>>>,
}

#[pymethods]
impl PyTrackIter {
    fn __iter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    fn __next__(&mut self, py: Python<'_>) -> PyResult<Option<PyRecord>> {
        use std::sync::mpsc::RecvTimeoutError;
        loop {
            let Some(records) = &self.records else {
                return Ok(None);
            };
            let got = py.detach(|| match records.lock() {
                Ok(r) => r.recv_timeout(std::time::Duration::from_millis(100)),
                Err(_) => Err(RecvTimeoutError::Disconnected),
            });
            match got {
                Ok(record) => return Ok(Some(PyRecord::new(record))),
                Err(RecvTimeoutError::Timeout) => {
                    if let Err(e) = py.check_signals() {
                        self.finish(py);
                        return Err(e);
                    }
                }
                Err(RecvTimeoutError::Disconnected) => {
                    return match self.finish(py) {
                        Some(broke) => Err(fail_with(broke)),
                        None => Ok(None),
                    };
                }
            }
        }
    }

    /// Stops the tracking (the frames in flight are dropped) and waits for it to end.
    fn close(&mut self, py: Python<'_>) {
        self.finish(py);
    }
}

impl PyTrackIter {
    /// Stops and joins the tracking thread; why the input broke, if it did.
    fn finish(&mut self, py: Python<'_>) -> Option<String> {
        py.detach(|| self.halt())
    }

    /// Stops and joins the tracking thread (once; later calls say nothing).
    fn halt(&mut self) -> Option<String> {
        self.stop.store(true, Ordering::Relaxed);
        // Dropping the receiver lets a tracking thread blocked on a full queue end.
        self.records = None;
        self.worker.take()?.join().ok().flatten()
    }
}

impl Drop for PyTrackIter {
    fn drop(&mut self) {
        self.halt();
    }
}

/// Why a run's input broke, naming the recording and how far it got (`None`: it did not).
fn input_broke(recording: &std::path::Path, end: flexshape_track::RunEnd) -> Option<String> {
    let e = end.input_error?;
    Some(format!(
        "{} after {} frames: {}",
        recording.display(),
        end.frames,
        chain(&e)
    ))
}

/// The records of a JSON Lines file written by `flexshape track` (or `demo --jsonl`), in
/// order; a malformed line is an error naming it.
#[pyfunction]
pub(crate) fn read_records(path: PathBuf) -> PyResult<Vec<PyRecord>> {
    let records = flexshape_record::read_records(&path).map_err(|e| fail(&e))?;
    Ok(records.into_iter().map(|(_, r)| PyRecord::new(r)).collect())
}
