//! The JSON Lines records `flexshape track` writes, read back.

use std::path::Path;

use crate::{RecordError, SummaryLine, TrackRecord, TrackSummary};

/// One line of what `flexshape track` writes.
#[derive(Debug, Clone, PartialEq)]
pub enum TrackLine {
    /// A frame's record.
    Record(Box<TrackRecord>),
    /// The run's summary (the last line).
    Summary(Box<TrackSummary>),
}

/// One line of a JSON Lines tracking output: a record, the summary, or `None` for a blank
/// line; else what is wrong with it.
pub fn parse_line(line: &str) -> Result<Option<TrackLine>, String> {
    let Some(value) = json_of(line)? else {
        return Ok(None);
    };
    if value.get("summary").is_some() {
        let s: SummaryLine =
            serde_json::from_value(value).map_err(|e| format!("not a summary ({e})"))?;
        return Ok(Some(TrackLine::Summary(Box::new(s.summary))));
    }
    record_of(value).map(|r| Some(TrackLine::Record(Box::new(r))))
}

/// The tracking records of a JSON Lines file (as `flexshape track` writes it) with their line
/// numbers; summary lines (whatever they hold) and blank lines are skipped.
pub fn read_records(path: &Path) -> Result<Vec<(usize, TrackRecord)>, RecordError> {
    let bad = |line: Option<usize>, problem: String| RecordError::Records {
        path: path.to_path_buf(),
        line,
        problem,
    };
    // Not opened unless a regular file: a FIFO blocks the open, a device reads for ever.
    let meta = std::fs::metadata(path).map_err(|e| bad(None, e.to_string()))?;
    if !meta.is_file() {
        return Err(bad(
            None,
            "not a regular file (a folder, device, FIFO or socket): give a `flexshape track` JSON Lines file".into(),
        ));
    }
    let text = std::fs::read_to_string(path).map_err(|e| bad(None, e.to_string()))?;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let value = json_of(line).map_err(|e| bad(Some(i + 1), e))?;
        if let Some(value) = value.filter(|v| v.get("summary").is_none()) {
            out.push((i + 1, record_of(value).map_err(|e| bad(Some(i + 1), e))?));
        }
    }
    Ok(out)
}

/// A line's JSON, `None` for a blank line.
fn json_of(line: &str) -> Result<Option<serde_json::Value>, String> {
    if line.trim().is_empty() {
        return Ok(None);
    }
    serde_json::from_str(line)
        .map(Some)
        .map_err(|e| format!("not JSON ({e})"))
}

fn record_of(value: serde_json::Value) -> Result<TrackRecord, String> {
    serde_json::from_value(value).map_err(|e| format!("not a tracking record ({e})"))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `flexshape view /dev/zero` read 1.9 GB before running out of memory, and a FIFO held
    /// the open for ever: neither is opened.
    #[cfg(unix)]
    #[test]
    fn records_are_read_from_regular_files_only() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("fifo");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        let mut paths = vec![
            Path::new("/dev/zero").to_path_buf(),
            dir.path().to_path_buf(),
        ];
        if made.is_ok_and(|s| s.success()) {
            paths.push(fifo);
        }
        for path in paths {
            let e = read_records(&path).unwrap_err().to_string();
            assert!(e.contains("not a regular file"), "{}: {e}", path.display());
        }
    }
}
