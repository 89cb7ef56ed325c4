//! Reads the JSON Lines records `flexshape track` writes, as they come (a file, or a live run
//! piped in), and prints each frame's tip and curvature; the summary line at the end is told
//! apart.
//!
//! ```text
//! flexshape track /tmp/rec --out - | cargo run --release -p flexshape-track --example read_stream
//! ```

use std::io::BufRead;

use flexshape_record::{TrackLine, parse_line};

fn main() {
    if let Err(e) = track() {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

fn track() -> Result<(), Box<dyn std::error::Error>> {
    for (n, line) in std::io::stdin().lock().lines().enumerate() {
        match parse_line(&line?).map_err(|e| format!("line {}: {e}", n + 1))? {
            Some(TrackLine::Record(r)) => println!(
                "frame {}: {} tip {:?} mm, curvature {:?} 1/mm",
                r.frame,
                r.status,
                r.tip,
                r.arc_fit.map(|f| f.curvature)
            ),
            Some(TrackLine::Summary(s)) => println!(
                "end of the run: {} frames, {} ok, {:.1} frames/s",
                s.frames, s.ok, s.fps
            ),
            None => {}
        }
    }
    Ok(())
}
