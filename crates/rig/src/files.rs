//! Reading what a user names, boundedly: a path that is not a regular file (a FIFO, a device
//! such as `/dev/zero`, a folder) is refused before it is opened, text files larger than
//! [`MAX_TEXT_BYTES`] are refused, and an image's size is read from its header and checked
//! before any pixel is decoded.

use std::io::Read;
use std::path::Path;

use image::{DynamicImage, ImageReader, Limits};

/// Largest text file read (camera, rig, calibration and point files): 64 MiB.
pub const MAX_TEXT_BYTES: u64 = 64 << 20;

/// Largest image side decoded, pixels.
pub const MAX_IMAGE_SIDE: u32 = 16_384;

/// Extensions of the image files flexshape reads (the formats its `image` build decodes).
pub const IMAGE_EXTENSIONS: [&str; 3] = ["png", "jpg", "jpeg"];

/// Whether `path` names an image flexshape reads, by its extension (any case).
pub fn is_image_path(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| IMAGE_EXTENSIONS.iter().any(|x| e.eq_ignore_ascii_case(x)))
}

/// The images in a folder (by [`is_image_path`]), sorted by name.
pub fn images_in(dir: &Path) -> std::io::Result<Vec<std::path::PathBuf>> {
    let mut files: Vec<std::path::PathBuf> = std::fs::read_dir(dir)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| is_image_path(p))
        .collect();
    files.sort();
    Ok(files)
}

/// Why a file could not be read.
#[derive(Debug, thiserror::Error)]
pub enum FileError {
    /// Not a regular file.
    #[error("{}: not a regular file ({kind}); give a file", path.display())]
    NotAFile {
        /// The path.
        path: std::path::PathBuf,
        /// What it is instead.
        kind: &'static str,
    },
    /// Larger than allowed.
    #[error("{}: {size} bytes, more than the {limit} a {what} may have", path.display())]
    TooLarge {
        /// The path.
        path: std::path::PathBuf,
        /// Its size, bytes.
        size: u64,
        /// The limit, bytes.
        limit: u64,
        /// What the file was read as.
        what: &'static str,
    },
    /// The file system refused (missing, no permission, …).
    #[error("{}: {source}", path.display())]
    Io {
        /// The path.
        path: std::path::PathBuf,
        /// The error.
        source: std::io::Error,
    },
    /// Read or decode failure.
    #[error("{}: {message}", path.display())]
    Other {
        /// The path.
        path: std::path::PathBuf,
        /// What went wrong.
        message: String,
    },
    /// A line of a text file does not hold what it should.
    #[error("{} line {line}: {message}", path.display())]
    Line {
        /// The path.
        path: std::path::PathBuf,
        /// The line, from 1.
        line: usize,
        /// What is wrong with it.
        message: String,
    },
    /// The image is not the size expected.
    #[error("{}: the image is {width}×{height}, expected {expected_width}×{expected_height}", path.display())]
    Size {
        /// The path.
        path: std::path::PathBuf,
        /// Its width, pixels.
        width: u32,
        /// Its height, pixels.
        height: u32,
        /// The expected width.
        expected_width: u32,
        /// The expected height.
        expected_height: u32,
    },
}

impl FileError {
    /// What is wrong, without the path (for errors that name the path themselves).
    pub fn reason(&self) -> String {
        let text = self.to_string();
        let path = match self {
            FileError::NotAFile { path, .. }
            | FileError::Io { path, .. }
            | FileError::TooLarge { path, .. }
            | FileError::Other { path, .. }
            | FileError::Line { path, .. }
            | FileError::Size { path, .. } => path.display().to_string(),
        };
        text.strip_prefix(&format!("{path}: "))
            .or_else(|| text.strip_prefix(&format!("{path} ")))
            .map_or(text.clone(), str::to_string)
    }
}

/// Refuses anything but a regular file, without opening it (a FIFO would block).
pub fn regular_file(path: &Path) -> Result<u64, FileError> {
    let meta = std::fs::metadata(path).map_err(|source| FileError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let t = meta.file_type();
    if t.is_file() {
        return Ok(meta.len());
    }
    #[cfg(unix)]
    let special = {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            Some("a FIFO")
        } else if t.is_char_device() || t.is_block_device() {
            Some("a device")
        } else if t.is_socket() {
            Some("a socket")
        } else {
            None
        }
    };
    #[cfg(not(unix))]
    let special = None;
    Err(FileError::NotAFile {
        path: path.to_path_buf(),
        kind: special.unwrap_or(if t.is_dir() { "a folder" } else { "not a file" }),
    })
}

/// A text file of at most [`MAX_TEXT_BYTES`]; `what` names it in errors.
pub fn read_text(path: &Path, what: &'static str) -> Result<String, FileError> {
    let bytes = read_bytes(path, MAX_TEXT_BYTES, what)?;
    String::from_utf8(bytes).map_err(|_| FileError::Other {
        path: path.to_path_buf(),
        message: format!("not UTF-8 text (a {what} is text)"),
    })
}

/// The data lines of a CSV text: each line that is neither blank nor a `#` comment, with its
/// number (from 1) and its fields split at commas and trimmed. Every CSV file flexshape reads
/// (numbers, points, timestamps) goes through it; each reader says what a line must hold.
pub fn csv_lines(text: &str) -> impl Iterator<Item = (usize, &str, Vec<&str>)> + '_ {
    text.lines().enumerate().filter_map(|(i, line)| {
        let line = line.trim();
        (!line.is_empty() && !line.starts_with('#'))
            .then(|| (i + 1, line, line.split(',').map(str::trim).collect()))
    })
}

/// The rows of a CSV file of numbers, each of `columns` finite numbers: blank lines and `#`
/// comments are skipped, and a first line that is not numbers (a header). `expected` says
/// what a line should hold (`` `x,y,z` (three numbers) ``) in the error that names the line.
pub fn read_csv_numbers(
    path: &Path,
    columns: usize,
    expected: &str,
) -> Result<Vec<Vec<f64>>, FileError> {
    let text = read_text(path, "CSV file")?;
    let mut rows = Vec::new();
    for (number, line, fields) in csv_lines(&text) {
        let v: Result<Vec<f64>, _> = fields.iter().map(|x| x.parse::<f64>()).collect();
        match v {
            Ok(v) if v.len() == columns && v.iter().all(|x| x.is_finite()) => rows.push(v),
            Err(_) if rows.is_empty() && number == 1 => continue, // a header
            _ => {
                return Err(FileError::Line {
                    path: path.to_path_buf(),
                    line: number,
                    message: format!("expected {expected}, found `{line}`"),
                });
            }
        }
    }
    Ok(rows)
}

/// A file's bytes, at most `limit`; `what` names it in errors.
pub fn read_bytes(path: &Path, limit: u64, what: &'static str) -> Result<Vec<u8>, FileError> {
    let size = regular_file(path)?;
    let too_large = |size| FileError::TooLarge {
        path: path.to_path_buf(),
        size,
        limit,
        what,
    };
    if size > limit {
        return Err(too_large(size));
    }
    let io = |source| FileError::Io {
        path: path.to_path_buf(),
        source,
    };
    let file = std::fs::File::open(path).map_err(io)?;
    let mut bytes = Vec::with_capacity(size as usize);
    file.take(limit + 1).read_to_end(&mut bytes).map_err(io)?;
    if bytes.len() as u64 > limit {
        return Err(too_large(bytes.len() as u64));
    }
    Ok(bytes)
}

/// An image file (PNG, JPEG), its size checked against `expected` (width, height) from its
/// header before any pixel is decoded, and never more than [`MAX_IMAGE_SIDE`] a side.
pub fn read_image(path: &Path, expected: Option<(u32, u32)>) -> Result<DynamicImage, FileError> {
    regular_file(path)?;
    let other = |message: String| FileError::Other {
        path: path.to_path_buf(),
        message,
    };
    let open = || {
        ImageReader::open(path)
            .and_then(|r| r.with_guessed_format())
            .map_err(|e| other(format!("cannot read: {e}")))
    };
    let (width, height) = open()?
        .into_dimensions()
        .map_err(|e| other(format!("cannot decode image: {e}")))?;
    if let Some((ew, eh)) = expected
        && (width, height) != (ew, eh)
    {
        return Err(FileError::Size {
            path: path.to_path_buf(),
            width,
            height,
            expected_width: ew,
            expected_height: eh,
        });
    }
    if width > MAX_IMAGE_SIDE || height > MAX_IMAGE_SIDE {
        return Err(other(format!(
            "the image is {width}×{height}: larger than {MAX_IMAGE_SIDE} pixels a side"
        )));
    }
    let mut reader = open()?;
    let mut limits = Limits::default();
    limits.max_image_width = Some(MAX_IMAGE_SIDE);
    limits.max_image_height = Some(MAX_IMAGE_SIDE);
    reader.limits(limits);
    reader
        .decode()
        .map_err(|e| other(format!("cannot decode image: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_folders_devices_and_oversized_files_without_reading_them() {
        let dir = tempfile::tempdir().unwrap();
        let e = read_text(dir.path(), "camera file")
            .unwrap_err()
            .to_string();
        assert!(e.contains("a folder"), "{e}");
        if Path::new("/dev/zero").exists() {
            let e = read_text(Path::new("/dev/zero"), "camera file")
                .unwrap_err()
                .to_string();
            assert!(e.contains("a device"), "{e}");
            let e = read_image(Path::new("/dev/zero"), None)
                .unwrap_err()
                .to_string();
            assert!(e.contains("a device"), "{e}");
        }
        let big = dir.path().join("big.txt");
        std::fs::write(&big, vec![b'a'; 2000]).unwrap();
        let e = read_bytes(&big, 1000, "points file")
            .unwrap_err()
            .to_string();
        assert!(e.contains("2000 bytes") && e.contains("points file"), "{e}");
    }

    #[test]
    fn an_image_of_the_wrong_size_is_refused_from_its_header() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.png");
        image::RgbImage::new(64, 32).save(&path).unwrap();
        assert_eq!(read_image(&path, Some((64, 32))).unwrap().width(), 64);
        let e = read_image(&path, Some((640, 480))).unwrap_err();
        assert!(
            matches!(
                e,
                FileError::Size {
                    width: 64,
                    height: 32,
                    ..
                }
            ),
            "{e}"
        );
        // A header announcing 20000 × 20000 (a valid signature and IHDR, no pixel data) is
        // refused without decoding.
        let mut png = b"\x89PNG\r\n\x1a\n\x00\x00\x00\x0dIHDR".to_vec();
        png.extend(20000u32.to_be_bytes());
        png.extend(20000u32.to_be_bytes());
        png.extend([8, 2, 0, 0, 0]);
        let crc = crc32(&png[12..]);
        png.extend(crc.to_be_bytes());
        // An empty IDAT chunk: the header is read up to the first one.
        png.extend(0u32.to_be_bytes());
        png.extend(b"IDAT");
        png.extend(crc32(b"IDAT").to_be_bytes());
        let huge = dir.path().join("huge.png");
        std::fs::write(&huge, png).unwrap();
        let e = read_image(&huge, None).unwrap_err().to_string();
        assert!(e.contains("20000×20000"), "{e}");
    }

    fn crc32(bytes: &[u8]) -> u32 {
        let mut c = 0xFFFF_FFFFu32;
        for &b in bytes {
            c ^= b as u32;
            for _ in 0..8 {
                c = if c & 1 == 1 {
                    0xEDB8_8320 ^ (c >> 1)
                } else {
                    c >> 1
                };
            }
        }
        !c
    }
}
