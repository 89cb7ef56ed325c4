//! Plain image folders, one per camera: images with the same file name (without extension)
//! in every folder were taken at the same instant and make one frame; frames follow the names
//! in natural order (`img2` before `img10`). Or one image file per camera: a single frame
//! (static multi-view sets name each view's image differently).

use std::cmp::Ordering;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use crate::{CaptureTime, FrameImage, FrameSet, FrameSource, InputError};

/// Frames from one image folder per camera.
pub struct FolderSource {
    /// Per frame: its name and one file per camera.
    frames: Vec<(String, Vec<PathBuf>)>,
    unpaired: Vec<String>,
    next: usize,
}

impl FolderSource {
    /// Pairs the images of `folders` (camera name, folder), in the rig's camera order; when
    /// every path is an image file instead, they make one frame.
    pub fn open(folders: &[(String, PathBuf)]) -> Result<Self, InputError> {
        if folders.is_empty() {
            return Err(InputError::Cameras(
                "no image folders given: give one per camera".into(),
            ));
        }
        let files = folders.iter().filter(|(_, p)| p.is_file()).count();
        if files == folders.len() {
            return Self::single(folders);
        }
        if files > 0 {
            return Err(InputError::Cameras(format!(
                "give every camera an image folder, or every camera one image file; {} are files ({})",
                files,
                folders
                    .iter()
                    .filter(|(_, p)| p.is_file())
                    .map(|(c, p)| format!("{c}={}", p.display()))
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        }
        if let Some((camera, missing)) = folders.iter().find(|(_, p)| !p.exists()) {
            return Err(InputError::Cameras(format!(
                "camera `{camera}`: {} does not exist; give an image folder (or one image file per camera)",
                missing.display()
            )));
        }
        let mut per_camera = Vec::new();
        for (camera, dir) in folders {
            let images = images_in(dir)?;
            if images.is_empty() {
                return Err(InputError::NoFrames(format!(
                    "camera `{camera}`: {} holds no PNG or JPEG image",
                    dir.display()
                )));
            }
            per_camera.push(images);
        }
        let mut names: Vec<&String> = per_camera[0]
            .keys()
            .filter(|n| per_camera.iter().all(|m| m.contains_key(*n)))
            .collect();
        names.sort_by(|a, b| natural_order(a, b));
        let paired: BTreeSet<&String> = names.iter().copied().collect();
        let unpaired: BTreeSet<String> = per_camera
            .iter()
            .flat_map(|m| m.keys())
            .filter(|n| !paired.contains(n))
            .cloned()
            .collect();
        if names.is_empty() {
            return Err(InputError::NoFrames(format!(
                "no image name is in every camera's folder ({}); images of one instant must have the same file name in each folder",
                folders
                    .iter()
                    .map(|(c, d)| format!("{c}: {}", d.display()))
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        }
        let frames = names
            .into_iter()
            .map(|n| (n.clone(), per_camera.iter().map(|m| m[n].clone()).collect()))
            .collect();
        Ok(FolderSource {
            frames,
            unpaired: unpaired.into_iter().collect(),
            next: 0,
        })
    }

    /// One frame of one image file per camera, named after the first camera's file.
    fn single(files: &[(String, PathBuf)]) -> Result<Self, InputError> {
        for (camera, f) in files {
            if !flexshape_rig::files::is_image_path(f) {
                return Err(InputError::Cameras(format!(
                    "camera `{camera}`: {} is not a PNG or JPEG image",
                    f.display()
                )));
            }
        }
        let name = files[0]
            .1
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("frame")
            .to_string();
        Ok(FolderSource {
            frames: vec![(name, files.iter().map(|(_, f)| f.clone()).collect())],
            unpaired: Vec::new(),
            next: 0,
        })
    }

    /// Image names found in some folders but not all (left out).
    pub fn unpaired(&self) -> &[String] {
        &self.unpaired
    }
}

impl FrameSource for FolderSource {
    fn next_frame(&mut self) -> Option<Result<FrameSet, InputError>> {
        let (name, files) = self.frames.get(self.next)?;
        let mut set = FrameSet::new(
            self.next as u64,
            files.iter().cloned().map(FrameImage::File).collect(),
        );
        set.name = Some(name.clone());
        set.capture_time = files.first().and_then(|f| CaptureTime::of_file(f));
        self.next += 1;
        Some(Ok(set))
    }

    fn len_hint(&self) -> Option<usize> {
        Some(self.frames.len())
    }
}

/// The images of a folder by file stem.
fn images_in(dir: &Path) -> Result<BTreeMap<String, PathBuf>, InputError> {
    let entries = std::fs::read_dir(dir).map_err(|e| InputError::io(dir, e))?;
    let mut images = BTreeMap::new();
    for entry in entries {
        let path = entry.map_err(|e| InputError::io(dir, e))?.path();
        if let (true, Some(stem)) = (
            flexshape_rig::files::is_image_path(&path),
            path.file_stem().and_then(|s| s.to_str()),
        ) {
            images.insert(stem.to_string(), path.clone());
        }
    }
    Ok(images)
}

/// Orders names with digit runs compared as numbers: `img2` < `img10`.
pub fn natural_order(a: &str, b: &str) -> Ordering {
    let (mut a, mut b) = (a.as_bytes(), b.as_bytes());
    loop {
        match (a.first(), b.first()) {
            (None, None) => return Ordering::Equal,
            (None, _) => return Ordering::Less,
            (_, None) => return Ordering::Greater,
            (Some(x), Some(y)) if x.is_ascii_digit() && y.is_ascii_digit() => {
                let da = a.iter().take_while(|c| c.is_ascii_digit()).count();
                let db = b.iter().take_while(|c| c.is_ascii_digit()).count();
                let (na, nb) = (trim_zeros(&a[..da]), trim_zeros(&b[..db]));
                let order = na.len().cmp(&nb.len()).then(na.cmp(nb)).then(da.cmp(&db));
                if order != Ordering::Equal {
                    return order;
                }
                (a, b) = (&a[da..], &b[db..]);
            }
            (Some(x), Some(y)) => {
                if x != y {
                    return x.cmp(y);
                }
                (a, b) = (&a[1..], &b[1..]);
            }
        }
    }
}

fn trim_zeros(digits: &[u8]) -> &[u8] {
    let zeros = digits.iter().take_while(|&&c| c == b'0').count();
    &digits[zeros..]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn natural_order_compares_numbers() {
        let mut names = vec!["img10", "img2", "img1", "a", "img02", "b3c", "b3b"];
        names.sort_by(|a, b| natural_order(a, b));
        assert_eq!(names, ["a", "b3b", "b3c", "img1", "img2", "img02", "img10"]);
    }

    #[test]
    fn pairs_by_name_and_reports_the_unpaired() {
        let dir = tempfile::tempdir().unwrap();
        let pixel = image::RgbImage::from_pixel(4, 3, image::Rgb([9, 8, 7]));
        for (cam, names) in [
            ("a", ["f1", "f10", "f2", "only_a"]),
            ("b", ["f1", "f10", "f2", "only_b"]),
        ] {
            std::fs::create_dir(dir.path().join(cam)).unwrap();
            for n in names {
                pixel
                    .save(dir.path().join(cam).join(format!("{n}.png")))
                    .unwrap();
            }
        }
        std::fs::write(dir.path().join("a/notes.txt"), "not an image").unwrap();
        let folders = [("a", "a"), ("b", "b")].map(|(c, d)| (c.to_string(), dir.path().join(d)));
        let mut source = FolderSource::open(&folders).unwrap();
        assert_eq!(source.len_hint(), Some(3));
        assert_eq!(source.unpaired(), ["only_a", "only_b"]);
        let mut seen = Vec::new();
        while let Some(set) = source.next_frame() {
            let set = set.unwrap();
            let image = set.images[1].clone().load("b", (4, 3)).unwrap();
            assert_eq!(image.get_pixel(0, 0).0, [9, 8, 7]);
            seen.push((set.frame, set.name.unwrap()));
        }
        assert_eq!(
            seen,
            [(0, "f1".into()), (1, "f2".into()), (2, "f10".into())]
        );
        let wrong = FrameImage::File(dir.path().join("a/f1.png")).load("a", (640, 480));
        let message = wrong.unwrap_err().to_string();
        assert!(
            message.contains("4×3") && message.contains("640×480"),
            "{message}"
        );
    }

    #[test]
    fn folders_without_common_names_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let pixel = image::RgbImage::new(2, 2);
        for (cam, name) in [("a", "x"), ("b", "y")] {
            std::fs::create_dir(dir.path().join(cam)).unwrap();
            pixel
                .save(dir.path().join(cam).join(format!("{name}.png")))
                .unwrap();
        }
        let folders = [("a", "a"), ("b", "b")].map(|(c, d)| (c.to_string(), dir.path().join(d)));
        let err = FolderSource::open(&folders).err().unwrap();
        assert!(err.to_string().contains("same file name"), "{err}");
        std::fs::create_dir(dir.path().join("empty")).unwrap();
        let folders = [("c".to_string(), dir.path().join("empty"))];
        let err = FolderSource::open(&folders).err().unwrap();
        assert!(err.to_string().contains("no PNG or JPEG"), "{err}");
    }

    /// One image file per camera (view sets name each view differently): one frame. Files
    /// mixed with folders, a file that is not an image and a path that does not exist are
    /// refused, each once and by name.
    #[test]
    fn one_image_file_per_camera_is_one_frame() {
        let dir = tempfile::tempdir().unwrap();
        let pixel = image::RgbImage::from_pixel(4, 3, image::Rgb([1, 2, 3]));
        for n in ["templeSR0001", "templeSR0002"] {
            pixel.save(dir.path().join(format!("{n}.png"))).unwrap();
        }
        let files = [("a", "templeSR0001.png"), ("b", "templeSR0002.png")]
            .map(|(c, f)| (c.to_string(), dir.path().join(f)));
        let mut source = FolderSource::open(&files).unwrap();
        assert_eq!(source.len_hint(), Some(1));
        let set = source.next_frame().unwrap().unwrap();
        assert_eq!(set.name.as_deref(), Some("templeSR0001"));
        assert_eq!(set.images.len(), 2);
        assert!(source.next_frame().is_none());
        std::fs::create_dir(dir.path().join("folder")).unwrap();
        let mixed = [
            ("a".to_string(), dir.path().join("templeSR0001.png")),
            ("b".to_string(), dir.path().join("folder")),
        ];
        let err = FolderSource::open(&mixed).err().unwrap().to_string();
        assert!(
            err.contains("every camera one image file") && err.contains("a="),
            "{err}"
        );
        std::fs::write(dir.path().join("notes.txt"), "x").unwrap();
        let text = [("a".to_string(), dir.path().join("notes.txt"))];
        let err = FolderSource::open(&text).err().unwrap().to_string();
        assert!(err.contains("not a PNG or JPEG"), "{err}");
        let missing = [("a".to_string(), dir.path().join("nowhere"))];
        let err = FolderSource::open(&missing).err().unwrap().to_string();
        assert!(err.contains("does not exist"), "{err}");
    }
}
