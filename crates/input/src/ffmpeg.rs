//! The `ffmpeg` program as a decoder: one child process per camera writes raw RGB frames to a
//! pipe. Nothing is needed at build time; at run time a missing program gets a clear error.

use std::io::{BufRead, BufReader, ErrorKind, Read};
use std::process::{Child, ChildStderr, ChildStdout, Command, Stdio};
use std::sync::mpsc::{self, Receiver, Sender};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::{Duration, Instant};

use image::RgbImage;

use crate::InputError;

/// How to install ffmpeg, for error messages.
pub const FFMPEG_PACKAGE_HINT: &str = "Debian/Ubuntu: `apt install ffmpeg`; Fedora: `dnf install ffmpeg`; macOS: `brew install ffmpeg`";

/// True when the `ffmpeg` and `ffprobe` programs can be run.
pub fn ffmpeg_available() -> bool {
    ["ffmpeg", "ffprobe"].iter().all(|program| {
        Command::new(program)
            .arg("-version")
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    })
}

/// One camera's ffmpeg process and its frame pipe.
pub(crate) struct Decoder {
    camera: String,
    input: String,
    child: Child,
    stdout: ChildStdout,
    stderr: Arc<Mutex<String>>,
    /// Each frame's presentation time as ffmpeg's `showinfo` filter printed it (frame number,
    /// seconds), for a decoder started with [`Decoder::spawn_timed`].
    times: Option<Receiver<(u64, Option<f64>)>>,
    /// A later frame's time, read while an earlier one's was missing.
    ahead: Option<(u64, Option<f64>)>,
    size: (u32, u32),
    /// Frames read so far.
    pub(crate) frames: u64,
}

/// How long a frame's presentation time may trail its pixels: the filter prints it before the
/// frame is written to the pipe, so it is normally there first.
const TIME_WAIT: Duration = Duration::from_millis(250);

impl Decoder {
    /// Starts ffmpeg on `input_args` (everything before the output options), decoding to
    /// `size` RGB frames without scaling.
    pub(crate) fn spawn(
        camera: &str,
        input: &str,
        input_args: &[String],
        size: (u32, u32),
    ) -> Result<Self, InputError> {
        Decoder::start(camera, input, input_args, size, false)
    }

    /// As [`Decoder::spawn`], also reading each frame's presentation time
    /// ([`Decoder::read_timed`]): the stream's own timestamps kept as they are (`-copyts`,
    /// every frame passed through), so that cameras whose streams share a clock (devices of
    /// one machine, videos of one recording) can be paired by time.
    pub(crate) fn spawn_timed(
        camera: &str,
        input: &str,
        input_args: &[String],
        size: (u32, u32),
    ) -> Result<Self, InputError> {
        Decoder::start(camera, input, input_args, size, true)
    }

    fn start(
        camera: &str,
        input: &str,
        input_args: &[String],
        size: (u32, u32),
        timed: bool,
    ) -> Result<Self, InputError> {
        check_size(camera, input, size)?;
        let mut command = Command::new("ffmpeg");
        command.args(["-nostdin", "-hide_banner", "-nostats", "-loglevel"]);
        if timed {
            // The filter prints each frame's time at the `info` level; every line is tagged
            // with its level so that only errors reach a message.
            command.arg("level+info").arg("-copyts");
        } else {
            command.arg("error");
        }
        command.args(input_args);
        if timed {
            command.args(["-vf", showinfo(), "-vsync", "passthrough"]);
        }
        let mut child = command
            .args(["-an", "-f", "rawvideo", "-pix_fmt", "rgb24", "-"])
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| spawn_error(e, camera, input))?;
        let (Some(stdout), Some(err_pipe)) = (child.stdout.take(), child.stderr.take()) else {
            return Err(InputError::Ffmpeg {
                camera: camera.into(),
                input: input.into(),
                message: "ffmpeg's output pipes could not be opened".into(),
            });
        };
        // ffmpeg's messages are drained on a thread so a chatty stream never blocks it.
        let stderr = Arc::new(Mutex::new(String::new()));
        let sink = stderr.clone();
        let (send, times) = mpsc::channel();
        std::thread::spawn(move || drain(err_pipe, &sink, timed.then_some(send)));
        Ok(Decoder {
            camera: camera.into(),
            input: input.into(),
            child,
            stdout,
            stderr,
            times: timed.then_some(times),
            ahead: None,
            size,
            frames: 0,
        })
    }

    /// The camera's name.
    pub(crate) fn camera(&self) -> &str {
        &self.camera
    }

    /// The next frame; `None` when the stream ended cleanly.
    fn read(&mut self) -> Result<Option<RgbImage>, InputError> {
        let (w, h) = self.size;
        let mut data = vec![0u8; w as usize * h as usize * 3];
        let mut filled = 0;
        while filled < data.len() {
            match self.stdout.read(&mut data[filled..]) {
                Ok(0) => break,
                Ok(n) => filled += n,
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) => return Err(self.failure(format!("reading its output failed: {e}"))),
            }
        }
        if filled == 0 {
            let status = self.child.wait();
            return match status {
                Ok(s) if s.success() => Ok(None),
                Ok(s) => Err(self.failure(format!("ffmpeg exited with {s}"))),
                Err(e) => Err(self.failure(format!("cannot wait for ffmpeg: {e}"))),
            };
        }
        if filled < data.len() {
            return Err(self.failure(format!(
                "the stream ended inside frame {} ({filled} of {} bytes)",
                self.frames,
                data.len()
            )));
        }
        self.frames += 1;
        RgbImage::from_raw(w, h, data)
            .map(Some)
            .ok_or_else(|| self.failure("frame buffer of the wrong size".into()))
    }

    /// The next frame and its presentation time, seconds in the stream's own time base
    /// (`None` when the stream gave none, or for a decoder not started timed); `None` when
    /// the stream ended cleanly.
    pub(crate) fn read_timed(&mut self) -> Result<Option<(RgbImage, Option<f64>)>, InputError> {
        let Some(image) = self.read()? else {
            return Ok(None);
        };
        let n = self.frames - 1;
        let Some(times) = &self.times else {
            return Ok(Some((image, None)));
        };
        if let Some((k, t)) = self.ahead.filter(|(k, _)| *k >= n) {
            // A later frame's time, read while this one's was missing.
            self.ahead = (k > n).then_some((k, t));
            return Ok(Some((image, if k == n { t } else { None })));
        }
        let until = Instant::now() + TIME_WAIT;
        loop {
            match times.recv_timeout(until.saturating_duration_since(Instant::now())) {
                Ok((k, t)) if k == n => return Ok(Some((image, t))),
                Ok((k, t)) if k > n => {
                    self.ahead = Some((k, t));
                    return Ok(Some((image, None)));
                }
                Ok(_) => {}
                // An ffmpeg that does not print the times (or has stopped): wait no more, or
                // every frame would wait for it.
                Err(_) => {
                    self.times = None;
                    return Ok(Some((image, None)));
                }
            }
        }
    }

    /// An error with what ffmpeg printed.
    fn failure(&self, what: String) -> InputError {
        // Give the drain thread a moment to collect ffmpeg's last words.
        std::thread::sleep(std::time::Duration::from_millis(50));
        let said = self
            .stderr
            .lock()
            .map(|s| s.trim().to_string())
            .unwrap_or_default();
        InputError::Ffmpeg {
            camera: self.camera.clone(),
            input: self.input.clone(),
            message: if said.is_empty() {
                what
            } else {
                format!("{what}: {said}")
            },
        }
    }
}

impl Drop for Decoder {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Collects ffmpeg's messages into `sink` (at most 16 kB), handing each frame's presentation
/// time to `times` when given (then only error-level lines are kept as messages).
fn drain(pipe: ChildStderr, sink: &Mutex<String>, times: Option<Sender<(u64, Option<f64>)>>) {
    let mut lines = BufReader::new(pipe);
    let mut line = Vec::new();
    loop {
        line.clear();
        match lines.read_until(b'\n', &mut line) {
            Ok(0) | Err(_) => return,
            Ok(_) => {}
        }
        let text = String::from_utf8_lossy(&line);
        if let Some(times) = &times {
            if let Some(frame) = frame_time(&text) {
                // The reader may have gone; the process ends with it.
                let _ = times.send(frame);
                continue;
            }
            if !["[error]", "[fatal]", "[panic]"]
                .iter()
                .any(|l| text.contains(l))
            {
                continue;
            }
        }
        if let Ok(mut kept) = sink.lock()
            && kept.len() < 16_384
        {
            kept.push_str(&text);
        }
    }
}

/// A frame's number and presentation time from a line of ffmpeg's `showinfo` filter
/// (`[Parsed_showinfo_0 @ …] [info] n:   3 pts:  12 pts_time:0.12 …`); the time is `None`
/// when the frame had none (`NOPTS`).
fn frame_time(line: &str) -> Option<(u64, Option<f64>)> {
    if !line.contains("Parsed_showinfo") {
        return None;
    }
    let value = |key: &str| {
        let at = line.find(key)? + key.len();
        line[at..].split_whitespace().next()
    };
    let n = value(" n:")?.parse().ok()?;
    let time = value("pts_time:")?;
    Some((n, time.parse().ok().filter(|t: &f64| t.is_finite())))
}

/// The `showinfo` filter without its per-frame checksums where this ffmpeg can leave them
/// out (5.0 and later): they cost a pass over every frame.
fn showinfo() -> &'static str {
    static FILTER: OnceLock<&'static str> = OnceLock::new();
    FILTER.get_or_init(|| {
        let help = Command::new("ffmpeg")
            .args(["-hide_banner", "-h", "filter=showinfo"])
            .stdin(Stdio::null())
            .output();
        match help {
            Ok(o) if String::from_utf8_lossy(&o.stdout).contains("checksum") => {
                "showinfo=checksum=0"
            }
            _ => "showinfo",
        }
    })
}

/// The width and height of the first video stream of `input` (a file or URL).
pub fn probe_size(camera: &str, input: &str) -> Result<(u32, u32), InputError> {
    let out = Command::new("ffprobe")
        .args(["-v", "error", "-select_streams", "v:0"])
        .args(["-show_entries", "stream=width,height", "-of", "csv=p=0"])
        .arg(input)
        .stdin(Stdio::null())
        .output()
        .map_err(|e| spawn_error(e, camera, input))?;
    let text = String::from_utf8_lossy(&out.stdout);
    let parsed = text
        .trim()
        .split_once(',')
        .and_then(|(w, h)| Some((w.trim().parse().ok()?, h.trim().parse().ok()?)));
    match (out.status.success(), parsed) {
        (true, Some(size)) => check_size(camera, input, size).map(|()| size),
        _ => Err(InputError::Ffmpeg {
            camera: camera.into(),
            input: input.into(),
            message: format!(
                "no video stream found ({})",
                String::from_utf8_lossy(&out.stderr).trim()
            ),
        }),
    }
}

/// Refuses a frame size no image of the rig can have (a stream that reports 0×0 sends no
/// frame to wait for; 100000×100000 asked for a 30 GB frame), before any frame is made room
/// for: 1 to [`flexshape_rig::files::MAX_IMAGE_SIDE`] pixels a side, as for image files.
fn check_size(camera: &str, input: &str, (w, h): (u32, u32)) -> Result<(), InputError> {
    let side = 1..=flexshape_rig::files::MAX_IMAGE_SIDE;
    if side.contains(&w) && side.contains(&h) {
        return Ok(());
    }
    Err(InputError::Ffmpeg {
        camera: camera.into(),
        input: input.into(),
        message: format!(
            "frames of {w}×{h} pixels: a camera's are 1 to {} pixels a side",
            flexshape_rig::files::MAX_IMAGE_SIDE
        ),
    })
}

fn spawn_error(e: std::io::Error, camera: &str, input: &str) -> InputError {
    if e.kind() == ErrorKind::NotFound {
        InputError::FfmpegMissing {
            what: format!("camera `{camera}`'s {input}"),
        }
    } else {
        InputError::Ffmpeg {
            camera: camera.into(),
            input: input.into(),
            message: format!("cannot start ffmpeg: {e}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn showinfo_lines_give_the_frame_and_its_time() {
        let line = "[Parsed_showinfo_0 @ 0x55d0c1c0] [info] n:  12 pts:   1536 pts_time:0.12    duration:    128 duration_time:0.01 pos: 4096 fmt:rgb24 sar:1/1 s:64x48 i:P iskey:1 type:I";
        assert_eq!(frame_time(line), Some((12, Some(0.12))));
        let none = "[Parsed_showinfo_0 @ 0x1] [info] n:   0 pts:NOPTS pts_time:NOPTS duration:0";
        assert_eq!(frame_time(none), Some((0, None)));
        let config =
            "[Parsed_showinfo_0 @ 0x1] [info] config in time_base: 1/12800, frame_rate: 25/1";
        assert_eq!(frame_time(config), None);
        assert_eq!(frame_time("[error] n: 3 pts_time:0.5"), None);
    }

    /// A stream's reported size is bounded before a frame is made room for: 0×0 waited for
    /// ever, 100000×100000 aborted on a 30 GB allocation.
    #[test]
    fn sizes_no_camera_has_are_refused_before_any_frame() {
        for size in [(0, 0), (640, 0), (100_000, 100_000), (16_385, 10)] {
            let e = check_size("cam0", "/dev/video9", size)
                .unwrap_err()
                .to_string();
            assert!(
                e.contains("cam0") && e.contains(&format!("{}×{}", size.0, size.1)),
                "{e}"
            );
            // ffmpeg is never started for it (whether or not it is installed).
            match Decoder::spawn("cam0", "/dev/video9", &[], size) {
                Err(e) => assert!(e.to_string().contains("pixels a side"), "{e}"),
                Ok(_) => panic!("{size:?}: ffmpeg started"),
            }
        }
        assert!(check_size("cam0", "x", (640, 480)).is_ok());
        assert!(check_size("cam0", "x", (16_384, 16_384)).is_ok());
    }
}
