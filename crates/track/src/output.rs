//! Where `flexshape track` writes: JSON Lines records (a file or standard output), optional
//! CSV rows and PLY clouds, each flushed as its frame is done. Outputs never replace an input,
//! and an existing file is replaced only when asked.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use flexshape_carve::PlyEncoding;
use serde::Serialize;

use flexshape_record::{SummaryLine, TrackRecord};

use crate::{Processed, TrackError};

macro_rules! out_err {
    ($($t:tt)*) => { TrackError::Output(format!($($t)*)) };
}

/// The outputs of a run, as `flexshape track`'s options name them.
#[derive(Debug, Clone)]
pub struct SinkSpec {
    /// The JSON Lines file (`-`: standard output).
    pub out: PathBuf,
    /// A CSV file of one row per record.
    pub csv: Option<PathBuf>,
    /// A folder for each frame's cloud, `NNNNNN.ply`.
    pub ply: Option<PathBuf>,
    /// How the clouds are encoded.
    pub ply_encoding: PlyEncoding,
    /// The MCAP file (written by its own sink; named here so that it is refused with the
    /// rest, before any output is created).
    pub mcap: Option<PathBuf>,
    /// Replace existing outputs.
    pub overwrite: bool,
}

impl SinkSpec {
    /// Every output with the option that names it.
    pub fn named(&self) -> Vec<(&'static str, &Path)> {
        let mut named = vec![("--out", self.out.as_path())];
        named.extend(self.csv.as_deref().map(|p| ("--csv", p)));
        named.extend(self.ply.as_deref().map(|p| ("--ply", p)));
        named.extend(self.mcap.as_deref().map(|p| ("--mcap", p)));
        named
    }
}

/// Whether output `path` is `input` or lies inside it: compared as canonical paths (an
/// output that does not exist yet by its folder's), and, for an output that exists, by file
/// identity — a hard link to an input, or to a file inside an input folder, is that input
/// whatever its path.
pub fn within(path: &Path, input: &Path) -> bool {
    if path == Path::new("-") {
        return false;
    }
    let Ok(input) = input.canonicalize() else {
        return false;
    };
    let canonical = canonical_output(path);
    canonical.is_some_and(|c| c == input || (input.is_dir() && c.starts_with(&input)))
        || linked_into(path, &input)
}

/// `path` canonical, or for a path that does not exist yet its nearest existing folder's
/// canonical path joined with the rest (folders an output would create).
fn canonical_output(path: &Path) -> Option<PathBuf> {
    if let Ok(c) = path.canonicalize() {
        return Some(c);
    }
    let mut rest = Vec::new();
    let mut at = path;
    loop {
        rest.push(at.file_name()?);
        at = match at.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
        if let Ok(c) = at.canonicalize() {
            return Some(rest.iter().rev().fold(c, |acc, name| acc.join(name)));
        }
    }
}

/// Whether two paths name one file: the same canonical path, or (both existing) the same
/// file by identity.
pub fn same_file(a: &Path, b: &Path) -> bool {
    if a == Path::new("-") || b == Path::new("-") {
        return a == b;
    }
    let same_path = canonical_output(a).is_some_and(|c| Some(c) == canonical_output(b));
    same_path || identity(a).is_some_and(|i| Some(i) == identity(b))
}

/// Files looked at, at most, for a hard link of an output inside an input folder.
const MAX_LINK_SCAN: usize = 200_000;

/// Whether existing file `path` is hard-linked to `input` or to a file inside folder
/// `input` (only asked of files with more than one link; the folder walked to
/// [`MAX_LINK_SCAN`] entries).
fn linked_into(path: &Path, input: &Path) -> bool {
    let Some(id) = identity(path).filter(|_| links(path) > 1) else {
        return false;
    };
    if !input.is_dir() {
        return identity(input) == Some(id);
    }
    let mut pending = vec![input.to_path_buf()];
    let mut seen = 0;
    while let Some(dir) = pending.pop() {
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for entry in entries.flatten() {
            seen += 1;
            if seen > MAX_LINK_SCAN {
                return false;
            }
            let Ok(kind) = entry.file_type() else {
                continue;
            };
            if kind.is_dir() {
                pending.push(entry.path());
            } else if kind.is_file() && identity(&entry.path()) == Some(id) {
                return true;
            }
        }
    }
    false
}

/// A file's identity: its device and inode (where the system has them; elsewhere none, and
/// paths alone decide).
#[cfg(unix)]
fn identity(path: &Path) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
}

#[cfg(not(unix))]
fn identity(_path: &Path) -> Option<(u64, u64)> {
    None
}

/// How many names the file at `path` has (1 where the system does not tell).
#[cfg(unix)]
fn links(path: &Path) -> u64 {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata(path).map_or(1, |m| m.nlink())
}

#[cfg(not(unix))]
fn links(_path: &Path) -> u64 {
    1
}

/// Refuses outputs (`-`, standard output, excepted) that exist, unless `overwrite`, naming
/// up to three of them.
pub fn refuse_existing<P: AsRef<Path>>(
    outputs: impl IntoIterator<Item = P>,
    overwrite: bool,
) -> Result<(), TrackError> {
    if overwrite {
        return Ok(());
    }
    let existing: Vec<String> = outputs
        .into_iter()
        .filter(|p| p.as_ref() != Path::new("-") && p.as_ref().exists())
        .map(|p| p.as_ref().display().to_string())
        .collect();
    let (it, verb) = match existing.len() {
        0 => return Ok(()),
        1 => ("it", "exists"),
        _ => ("them", "exist"),
    };
    let more = match existing.len() {
        n if n > 3 => format!(" and {} more", n - 3),
        _ => String::new(),
    };
    Err(out_err!(
        "{}{more} already {verb}: give --overwrite to replace {it}, or write elsewhere",
        existing[..existing.len().min(3)].join(", ")
    ))
}

/// Refuses two outputs of one run (`(option, path)`) that name one file (by path or, both
/// existing, by identity): one would overwrite the other's lines.
pub fn refuse_shared(outputs: &[(&str, &Path)]) -> Result<(), TrackError> {
    for (i, (a, pa)) in outputs.iter().enumerate() {
        for (b, pb) in &outputs[i + 1..] {
            if same_file(pa, pb) {
                if *pa == Path::new("-") {
                    return Err(out_err!(
                        "{a} - and {b} - would both write to standard output: give one of them a file"
                    ));
                }
                return Err(out_err!(
                    "{a} and {b} name the same file {}: give each output its own",
                    pa.display()
                ));
            }
        }
    }
    Ok(())
}

/// Refuses any of `outputs` that is one of `inputs` or lies inside one (by path or by file
/// identity: a hard link is its target, see [`within`]).
pub fn refuse_inputs<P: AsRef<Path>>(
    outputs: impl IntoIterator<Item = P>,
    inputs: &[PathBuf],
) -> Result<(), TrackError> {
    for output in outputs {
        let output = output.as_ref();
        if let Some(input) = inputs.iter().find(|i| within(output, i)) {
            return Err(out_err!(
                "{} {} {}: write the output elsewhere",
                output.display(),
                if input.is_dir() {
                    "is inside the input folder"
                } else {
                    "is the input"
                },
                input.display()
            ));
        }
    }
    Ok(())
}

/// Where records go: the JSON Lines stream, and optionally CSV rows and PLY clouds.
pub struct Sinks {
    out: Output,
    csv: Option<Output>,
    ply: Option<(PathBuf, PlyEncoding)>,
}

/// The CSV file's header (`flexshape track --csv`): one row per record.
pub const CSV_HEADER: &str = "frame,image,status,tip_x,tip_y,tip_z,tip_dx,tip_dy,tip_dz,arc_length_mm,curvature_per_mm,bands,voxels,latency_ms,silhouettes_ms,carve_ms,bands_ms,shape_ms,captured_s";

impl Sinks {
    /// Opens the outputs, refusing first any that is (or lies in) one of `inputs`, two that
    /// name one file, and existing ones without `overwrite` — the MCAP file too, which its own
    /// sink then creates.
    pub fn open(args: &SinkSpec, inputs: &[PathBuf]) -> Result<Self, TrackError> {
        let named = args.named();
        refuse_inputs(named.iter().map(|(_, p)| p), inputs)?;
        refuse_shared(&named)?;
        // Every file refused before any is created: a refused run leaves nothing behind to
        // block the next. (The PLY folder may exist; its clouds are asked about below.)
        let files = named.iter().filter(|(o, _)| *o != "--ply").map(|(_, p)| p);
        refuse_existing(files, args.overwrite)?;
        let out = Output::open(&args.out, args.overwrite)?;
        let csv = match &args.csv {
            Some(path) => {
                let mut csv = Output::open(path, args.overwrite)?;
                csv.line(CSV_HEADER)?;
                Some(csv)
            }
            None => None,
        };
        if let Some(dir) = &args.ply {
            let clouds = std::fs::read_dir(dir).map_or(0, |entries| {
                entries
                    .filter_map(Result::ok)
                    .filter(|e| e.path().extension().is_some_and(|x| x == "ply"))
                    .count()
            });
            if clouds > 0 && !args.overwrite {
                return Err(out_err!(
                    "{} already holds {clouds} PLY clouds: give --overwrite to replace them, or another --ply folder",
                    dir.display()
                ));
            }
            std::fs::create_dir_all(dir).map_err(|e| {
                TrackError::Output(format!(
                    "cannot create the PLY folder {}: {e}",
                    dir.display()
                ))
            })?;
        }
        Ok(Sinks {
            out,
            csv,
            ply: args.ply.clone().map(|dir| (dir, args.ply_encoding)),
        })
    }

    /// Writes the run's last line, its summary.
    pub fn finish(&mut self, summary: &SummaryLine) -> Result<(), TrackError> {
        self.out.write(summary)
    }

    /// Writes a frame's record (and CSV row, and PLY cloud), flushed.
    pub fn write(&mut self, record: &TrackRecord, p: &Processed) -> Result<(), TrackError> {
        // The cloud first (written whole, then renamed into place), so that a record never
        // names a cloud that is not there.
        if let (Some((dir, encoding)), Ok(t)) = (&self.ply, &p.result) {
            let path = dir.join(format!("{:06}.ply", record.frame));
            t.occupancy
                .to_cloud_with_bands(&t.bands)
                .write_ply(&path, *encoding)
                .map_err(|e| TrackError::Output(format!("cannot write {}: {e}", path.display())))?;
        }
        self.out.write(record)?;
        if let Some(csv) = &mut self.csv {
            csv.line(&csv_row(record))?;
        }
        Ok(())
    }
}

/// A record as a row of the CSV file (see [`CSV_HEADER`]).
pub fn csv_row(r: &TrackRecord) -> String {
    let opt3 = |v: Option<[f64; 3]>| match v {
        Some([x, y, z]) => format!("{x:.4},{y:.4},{z:.4}"),
        None => ",,".into(),
    };
    let t = r.timings_ms;
    format!(
        "{},{},{},{},{},{:.4},{},{},{},{},{:.3},{:.3},{:.3},{:.3},{}",
        r.frame,
        r.image.as_deref().unwrap_or("").replace(',', ";"),
        r.status,
        opt3(r.tip),
        opt3(r.tip_direction),
        r.arc_length,
        r.arc_fit
            .as_ref()
            .map(|f| format!("{:.7}", f.curvature))
            .unwrap_or_default(),
        r.bands.len(),
        r.voxels,
        r.latency_ms.map(|l| format!("{l:.3}")).unwrap_or_default(),
        t.silhouettes,
        t.carve,
        t.bands,
        t.shape,
        r.captured_s.map(|s| format!("{s:.6}")).unwrap_or_default()
    )
}

/// A line sink: a file or standard output, flushed after every line.
pub struct Output {
    name: String,
    sink: Box<dyn Write>,
}

impl Output {
    /// Opens `path` (`-`: standard output) for writing; an existing file only with
    /// `overwrite`; locked while written.
    pub fn open(path: &Path, overwrite: bool) -> Result<Self, TrackError> {
        if path == Path::new("-") {
            return Ok(Output {
                name: "standard output".into(),
                sink: Box::new(std::io::stdout().lock()),
            });
        }
        if path.is_dir() {
            return Err(out_err!("{} is a folder; give a file name", path.display()));
        }
        // Without --overwrite the file must be new (created atomically, so two runs cannot both
        // take it); either way it is locked while written, so a second run on it stops.
        let file = if overwrite {
            File::options()
                .write(true)
                .create(true)
                .truncate(false)
                .open(path)
        } else {
            File::options().write(true).create_new(true).open(path)
        }
        .map_err(|e| match e.kind() {
            std::io::ErrorKind::AlreadyExists => out_err!(
                "{} already exists: give --overwrite to replace it, or another file",
                path.display()
            ),
            _ => out_err!("cannot create {}: {e}", path.display()),
        })?;
        if file.try_lock().is_err() {
            return Err(out_err!(
                "{} is being written by another process (another `flexshape track`?): give another file",
                path.display()
            ));
        }
        file.set_len(0)
            .map_err(|e| out_err!("cannot empty {}: {e}", path.display()))?;
        Ok(Output {
            name: path.display().to_string(),
            sink: Box::new(BufWriter::new(file)),
        })
    }

    /// Writes `record` as one JSON line, flushed.
    pub fn write(&mut self, record: &impl Serialize) -> Result<(), TrackError> {
        let line =
            serde_json::to_string(record).map_err(|e| out_err!("cannot encode a record: {e}"))?;
        self.line(&line)
    }

    /// Writes one line, flushed.
    pub fn line(&mut self, line: &str) -> Result<(), TrackError> {
        self.sink
            .write_all(line.as_bytes())
            .and_then(|_| self.sink.write_all(b"\n"))
            .and_then(|_| self.sink.flush())
            .map_err(|e| out_err!("cannot write to {}: {e}", self.name))
    }
}
