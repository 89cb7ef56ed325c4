//! `timestamps.csv` and `timestamps/<cam>.csv`: a capture time per frame, seconds since the
//! Unix epoch (UTC) or the input's own time base, as `frame,seconds` lines after a header.
//! One line format for every writer (a recording written at once, a capture streamed) and one
//! reader.

use std::collections::BTreeMap;
use std::path::Path;

use crate::RecordingError;

/// The header line.
pub const HEADER: &str = "frame,seconds";

/// One frame's line (without its newline): every digit of the time kept.
pub fn line(frame: u64, seconds: f64) -> String {
    format!("{frame},{seconds:?}")
}

/// A whole file's text: the header, then a line per frame.
pub(crate) fn text(times: &[(u64, f64)]) -> String {
    let mut text = format!("{HEADER}\n");
    for &(frame, t) in times {
        text.push_str(&line(frame, t));
        text.push('\n');
    }
    text
}

/// The `frame,seconds` lines of a timestamps file (a header line and `#` comments skipped), or
/// an empty map when there is none.
pub(crate) fn read(path: &Path) -> Result<BTreeMap<u64, f64>, RecordingError> {
    let mut out = BTreeMap::new();
    if !path.exists() {
        return Ok(out);
    }
    let text = flexshape_rig::files::read_text(path, "timestamps file").map_err(|e| {
        RecordingError::Layout {
            path: path.to_path_buf(),
            problem: e.reason(),
        }
    })?;
    for (number, line, fields) in flexshape_rig::files::csv_lines(&text) {
        if number == 1 && line.starts_with("frame") {
            continue;
        }
        let parsed = match fields[..] {
            [f, t] => f.parse::<u64>().ok().zip(t.parse::<f64>().ok()),
            _ => None,
        };
        match parsed {
            Some((frame, t)) if t.is_finite() => {
                out.insert(frame, t);
            }
            _ => {
                return Err(RecordingError::Layout {
                    path: path.to_path_buf(),
                    problem: format!("line {number}: `{line}` is not `frame,seconds`"),
                });
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn what_is_written_is_read_back_to_the_last_digit_and_a_bad_line_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("timestamps.csv");
        let times = [
            (0, 1_764_700_000.125),
            (1, 1_764_700_000.0 + 1.0 / 3.0),
            (7, 0.1 + 0.2),
        ];
        std::fs::write(&path, text(&times)).unwrap();
        let read = read(&path).unwrap();
        assert_eq!(read.into_iter().collect::<Vec<_>>(), times);
        // Comments and blank lines are skipped; a line that is not `frame,seconds` is named.
        std::fs::write(&path, "frame,seconds\n# a comment\n\n3, 1.5\n4,soon\n").unwrap();
        let e = super::read(&path).unwrap_err().to_string();
        assert!(e.contains("line 5: `4,soon` is not `frame,seconds`"), "{e}");
        assert!(
            super::read(&dir.path().join("none.csv"))
                .unwrap()
                .is_empty()
        );
    }
}
