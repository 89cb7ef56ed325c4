//! Plain image folders, one per camera: images with the same file name (without extension)
//! in every folder were taken at the same instant and make one frame; frames follow the names
//! in natural order (`img2` before `img10`).

use std::cmp::Ordering;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use crate::{FrameImage, FrameSet, FrameSource, InputError};

/// Frames from one image folder per camera.
pub struct FolderSource {
    /// Per frame: its name and one file per camera.
    frames: Vec<(String, Vec<PathBuf>)>,
    unpaired: Vec<String>,
    next: usize,
}

const EXTENSIONS: [&str; 3] = ["png", "jpg", "jpeg"];

impl FolderSource {
    /// Pairs the images of `folders` (camera name, folder), in the rig's camera order.
    pub fn open(folders: &[(String, PathBuf)]) -> Result<Self, InputError> {
        if folders.is_empty() {
            return Err(InputError::Cameras(
                "no image folders given: give one per camera".into(),
            ));
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
        let is_image = path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| EXTENSIONS.iter().any(|x| e.eq_ignore_ascii_case(x)));
        if let (true, Some(stem)) = (is_image, path.file_stem().and_then(|s| s.to_str())) {
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
}
