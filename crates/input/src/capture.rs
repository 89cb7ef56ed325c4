//! Capturing frame sets from live cameras into folders every other command reads: one folder
//! per camera, `OUT/<camera>/000000.png`, `000001.png`, … — the images of one set share a
//! file name — and `OUT/timestamps.csv` (`frame,seconds`: each set's capture time, seconds
//! since the Unix epoch). The same folders serve `calibrate --images cam0=OUT/cam0 …`
//! (chessboards), `background --images OUT/cam0` (the empty scene) and
//! `track --images cam0=OUT/cam0 …` (frames to track later).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use crate::{FrameImage, FrameSource, InputError};

/// What to capture.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CaptureOptions {
    /// Frame sets to write.
    pub sets: u64,
    /// Least time between two sets (0: every set the cameras deliver; a few seconds to move
    /// a chessboard between views).
    pub interval: Duration,
}

/// What a capture wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct CaptureReport {
    /// Frame sets written.
    pub sets: u64,
    /// Frame sets the cameras delivered that were not written (newer ones arrived first, or
    /// they came within the interval).
    pub dropped: u64,
    /// Whether the capture was stopped before `sets` were written (the stop flag, or the
    /// cameras' streams ended).
    pub stopped: bool,
}

/// The file of camera `camera`'s image of set `set` under `out`.
pub fn capture_path(out: &Path, camera: &str, set: u64) -> PathBuf {
    out.join(camera).join(format!("{set:06}.png"))
}

/// Writes `options.sets` frame sets of `source` (one image per camera, named by `names` in
/// the source's order) under `out`, at least `options.interval` apart; calls `written` with
/// each set's number once its files and timestamp are on disk. Stops early, keeping what was
/// written, when `stop` is set or the source ends. `out` must not hold a camera folder
/// already (nothing is overwritten).
pub fn capture(
    source: &mut dyn FrameSource,
    names: &[String],
    out: &Path,
    options: &CaptureOptions,
    stop: &AtomicBool,
    mut written: impl FnMut(u64),
) -> Result<CaptureReport, InputError> {
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| InputError::Io { path, source }
    };
    for name in names {
        let dir = out.join(name);
        if dir.exists() {
            return Err(InputError::Cameras(format!(
                "{} exists already: capture into a new folder (nothing is overwritten)",
                dir.display()
            )));
        }
    }
    let stamps_path = out.join("timestamps.csv");
    // Made when the first set is in hand: a source that fails first leaves nothing behind
    // to block the next try.
    let mut stamps: Option<std::fs::File> = None;
    let mut report = CaptureReport {
        sets: 0,
        dropped: 0,
        stopped: false,
    };
    let mut last: Option<Instant> = None;
    while report.sets < options.sets {
        if stop.load(Ordering::Relaxed) {
            report.stopped = true;
            break;
        }
        let Some(next) = source.next_frame() else {
            report.stopped = true;
            break;
        };
        let set = match next {
            Ok(set) => set,
            Err(e) if e.ends_input() => return Err(e),
            // A frame the cameras garbled: the next one will do.
            Err(_) => {
                report.dropped += 1;
                continue;
            }
        };
        if last.is_some_and(|t| set.captured.duration_since(t) < options.interval) {
            report.dropped += 1;
            continue;
        }
        if set.images.len() != names.len() {
            return Err(InputError::Cameras(format!(
                "the cameras delivered {} images for {} names",
                set.images.len(),
                names.len()
            )));
        }
        let stamps = match &mut stamps {
            Some(file) => file,
            None => {
                for name in names {
                    let dir = out.join(name);
                    std::fs::create_dir_all(&dir).map_err(io(&dir))?;
                }
                let mut file = std::fs::File::create_new(&stamps_path).map_err(io(&stamps_path))?;
                writeln!(file, "{}", flexshape_recording::timestamps::HEADER)
                    .map_err(io(&stamps_path))?;
                stamps.insert(file)
            }
        };
        let number = report.sets;
        for (name, image) in names.iter().zip(set.images) {
            let path = capture_path(out, name, number);
            match image {
                FrameImage::Decoded(image) => {
                    image.save(&path).map_err(|e| InputError::Decode {
                        path: path.clone(),
                        message: format!("cannot write the image: {e}"),
                    })?
                }
                FrameImage::File(from) => {
                    std::fs::copy(&from, &path).map_err(io(&path))?;
                }
            }
        }
        // A set without a capture time has no line: a reader takes a missing frame for one
        // whose time is not known.
        if let Some(t) = set.capture_time {
            writeln!(
                stamps,
                "{}",
                flexshape_recording::timestamps::line(number, t.seconds)
            )
            .map_err(io(&stamps_path))?;
        }
        stamps.flush().map_err(io(&stamps_path))?;
        last = Some(set.captured);
        report.sets += 1;
        written(number);
    }
    report.dropped += source.dropped();
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::FrameSet;
    use image::RgbImage;

    /// Sets of two cameras, one every `gap`, then the end.
    struct Steady {
        left: u64,
        gap: Duration,
        clock: Instant,
    }

    impl FrameSource for Steady {
        fn next_frame(&mut self) -> Option<Result<FrameSet, InputError>> {
            if self.left == 0 {
                return None;
            }
            self.left -= 1;
            self.clock += self.gap;
            let image = |v: u8| FrameImage::Decoded(RgbImage::from_pixel(4, 3, image::Rgb([v; 3])));
            let mut set = FrameSet::new(0, vec![image(10), image(200)]);
            set.captured = self.clock;
            Some(Ok(set))
        }
    }

    fn names() -> Vec<String> {
        vec!["left".into(), "right".into()]
    }

    #[test]
    fn writes_one_file_per_camera_and_set_at_most_as_often_as_asked() {
        let dir = tempfile::tempdir().unwrap();
        let mut source = Steady {
            left: 10,
            gap: Duration::from_millis(100),
            clock: Instant::now(),
        };
        let options = CaptureOptions {
            sets: 3,
            interval: Duration::from_millis(250),
        };
        let mut seen = Vec::new();
        let report = capture(
            &mut source,
            &names(),
            dir.path(),
            &options,
            &AtomicBool::new(false),
            |n| seen.push(n),
        )
        .unwrap();
        assert_eq!(seen, [0, 1, 2]);
        assert_eq!((report.sets, report.stopped), (3, false));
        // Sets at 0.1, 0.4 and 0.7 s taken; the two between each skipped.
        assert_eq!(report.dropped, 4);
        for n in 0..3 {
            let left = image::open(capture_path(dir.path(), "left", n)).unwrap();
            assert_eq!(left.to_rgb8().get_pixel(0, 0).0, [10; 3]);
            assert!(capture_path(dir.path(), "right", n).is_file());
        }
        assert!(!capture_path(dir.path(), "left", 3).exists());
        let stamps = std::fs::read_to_string(dir.path().join("timestamps.csv")).unwrap();
        // This source gives no capture times: the header alone (a line `N,` would be one no
        // reader takes).
        assert_eq!(stamps, "frame,seconds\n");
        // Nothing is overwritten: a second capture into the same folder is refused.
        let again = capture(
            &mut source,
            &names(),
            dir.path(),
            &options,
            &AtomicBool::new(false),
            |_| {},
        );
        assert!(again.unwrap_err().to_string().contains("exists already"));
    }

    #[test]
    fn a_stop_or_the_end_of_the_streams_keeps_what_was_written() {
        let dir = tempfile::tempdir().unwrap();
        let mut source = Steady {
            left: 2,
            gap: Duration::from_millis(10),
            clock: Instant::now(),
        };
        let options = CaptureOptions {
            sets: 5,
            interval: Duration::ZERO,
        };
        let stop = AtomicBool::new(false);
        let report = capture(&mut source, &names(), dir.path(), &options, &stop, |_| {}).unwrap();
        assert_eq!((report.sets, report.stopped), (2, true));
        let dir = tempfile::tempdir().unwrap();
        stop.store(true, Ordering::Relaxed);
        let report = capture(&mut source, &names(), dir.path(), &options, &stop, |_| {}).unwrap();
        assert_eq!((report.sets, report.stopped), (0, true));
        // Stopped before any set: nothing is left behind to block the next try.
        assert!(!dir.path().join("timestamps.csv").exists());
        assert!(!dir.path().join("left").exists());
    }

    /// A source that fails before its first set (a camera that sends nothing) left empty
    /// camera folders that refused every retry ("exists already").
    #[test]
    fn a_source_failing_at_once_leaves_the_folder_free_for_a_retry() {
        struct Silent;
        impl FrameSource for Silent {
            fn next_frame(&mut self) -> Option<Result<FrameSet, InputError>> {
                Some(Err(InputError::Silent {
                    camera: "right".into(),
                    waited_s: 10,
                }))
            }
        }
        let dir = tempfile::tempdir().unwrap();
        let options = CaptureOptions {
            sets: 2,
            interval: Duration::ZERO,
        };
        let stop = AtomicBool::new(false);
        let e = capture(&mut Silent, &names(), dir.path(), &options, &stop, |_| {}).unwrap_err();
        assert!(
            e.to_string().contains("camera `right` sent no new frame"),
            "{e}"
        );
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        let mut source = Steady {
            left: 2,
            gap: Duration::from_millis(10),
            clock: Instant::now(),
        };
        let report = capture(&mut source, &names(), dir.path(), &options, &stop, |_| {}).unwrap();
        assert_eq!(report.sets, 2);
    }
}
