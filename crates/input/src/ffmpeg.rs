//! The `ffmpeg` program as a decoder: one child process per camera writes raw RGB frames to a
//! pipe. Nothing is needed at build time; at run time a missing program gets a clear error.

use std::io::{ErrorKind, Read};
use std::process::{Child, ChildStdout, Command, Stdio};
use std::sync::{Arc, Mutex};

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
    size: (u32, u32),
    /// Frames read so far.
    pub(crate) frames: u64,
}

impl Decoder {
    /// Starts ffmpeg on `input_args` (everything before the output options), decoding to
    /// `size` RGB frames without scaling.
    pub(crate) fn spawn(
        camera: &str,
        input: &str,
        input_args: &[String],
        size: (u32, u32),
    ) -> Result<Self, InputError> {
        check_size(camera, input, size)?;
        let mut child = Command::new("ffmpeg")
            .args(["-nostdin", "-hide_banner", "-loglevel", "error"])
            .args(input_args)
            .args(["-an", "-f", "rawvideo", "-pix_fmt", "rgb24", "-"])
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| spawn_error(e, camera, input))?;
        let (Some(stdout), Some(mut err_pipe)) = (child.stdout.take(), child.stderr.take()) else {
            return Err(InputError::Ffmpeg {
                camera: camera.into(),
                input: input.into(),
                message: "ffmpeg's output pipes could not be opened".into(),
            });
        };
        // ffmpeg's messages are drained on a thread so a chatty stream never blocks it.
        let stderr = Arc::new(Mutex::new(String::new()));
        let sink = stderr.clone();
        std::thread::spawn(move || {
            let mut buf = [0u8; 4096];
            while let Ok(n) = err_pipe.read(&mut buf) {
                if n == 0 {
                    break;
                }
                if let Ok(mut text) = sink.lock()
                    && text.len() < 16_384
                {
                    text.push_str(&String::from_utf8_lossy(&buf[..n]));
                }
            }
        });
        Ok(Decoder {
            camera: camera.into(),
            input: input.into(),
            child,
            stdout,
            stderr,
            size,
            frames: 0,
        })
    }

    /// The camera's name.
    pub(crate) fn camera(&self) -> &str {
        &self.camera
    }

    /// The next frame; `None` when the stream ended cleanly.
    pub(crate) fn read(&mut self) -> Result<Option<RgbImage>, InputError> {
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
