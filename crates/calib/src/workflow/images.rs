//! Which images belong to which camera, and which instant each shows.

use std::path::{Path, PathBuf};

use super::RigCalibError;

/// One camera's target images.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraImages {
    /// The camera's name (its file in the rig is `NAME.yml`).
    pub name: String,
    /// Its images, sorted by name.
    pub files: Vec<PathBuf>,
    /// The file-name pattern the images were given by (`left*.jpg`), if any.
    pub pattern: Option<String>,
}

impl CameraImages {
    /// A camera's images from a folder (every PNG or JPEG in it) or a folder and a file-name
    /// pattern (`imgs/left*.jpg`: `*` any run of characters, `?` one).
    pub fn find(name: &str, given: &Path) -> Result<Self, RigCalibError> {
        let pattern = given
            .file_name()
            .and_then(|f| f.to_str())
            .filter(|f| f.contains(['*', '?']))
            .map(str::to_string);
        let dir = match &pattern {
            Some(_) => match given.parent() {
                Some(p) if !p.as_os_str().is_empty() => p,
                _ => Path::new("."),
            },
            None => given,
        };
        let files: Vec<PathBuf> = flexshape_rig::files::images_in(dir)
            .map_err(|source| RigCalibError::Folder {
                camera: name.to_string(),
                dir: dir.to_path_buf(),
                source,
            })?
            .into_iter()
            .filter(|p| {
                pattern.as_deref().is_none_or(|pat| {
                    p.file_name()
                        .and_then(|f| f.to_str())
                        .is_some_and(|f| wildcards(pat, f).is_some())
                })
            })
            .collect();
        if files.is_empty() {
            return Err(RigCalibError::NoImages {
                camera: name.to_string(),
                given: given.to_path_buf(),
                pattern: pattern.is_some(),
            });
        }
        Ok(CameraImages {
            name: name.to_string(),
            files,
            pattern,
        })
    }

    /// Every camera's images from `(name, folder or pattern)` pairs; a camera named twice, or
    /// two cameras given the same images, are refused.
    pub fn find_all(specs: &[(String, PathBuf)]) -> Result<Vec<Self>, RigCalibError> {
        let mut out: Vec<CameraImages> = Vec::new();
        for (name, given) in specs {
            if out.iter().any(|c| &c.name == name) {
                return Err(RigCalibError::CameraTwice {
                    camera: name.clone(),
                });
            }
            let cam = Self::find(name, given)?;
            if let Some(other) = out.iter().find(|c| c.files == cam.files) {
                return Err(RigCalibError::SameImages {
                    first: other.name.clone(),
                    second: name.clone(),
                    given: given.clone(),
                });
            }
            out.push(cam);
        }
        Ok(out)
    }

    /// Which instant an image of this camera shows: images of different cameras with the same
    /// instant were taken together. From a folder, the file name without its extension; from
    /// a pattern, what its wildcards matched (`left07.jpg` by `left*.jpg`: `07`, the instant of
    /// `right07.jpg` by `right*.jpg` too).
    pub fn instant(&self, image: &str) -> String {
        match &self.pattern {
            Some(p) => wildcards(p, image).unwrap_or_else(|| stem(image).to_string()),
            None => stem(image).to_string(),
        }
    }
}

/// A file name without its extension.
pub(super) fn stem(name: &str) -> &str {
    name.rsplit_once('.').map_or(name, |(s, _)| s)
}

/// What the wildcards of `pattern` (`*` any run of characters, `?` one) matched in `name`,
/// joined, or `None` when `name` does not match.
fn wildcards(pattern: &str, name: &str) -> Option<String> {
    fn go(p: &[char], n: &[char], out: &mut String) -> bool {
        match p.first() {
            None => n.is_empty(),
            Some('*') => (0..=n.len()).rev().any(|k| {
                let len = out.len();
                out.extend(&n[..k]);
                if go(&p[1..], &n[k..], out) {
                    return true;
                }
                out.truncate(len);
                false
            }),
            Some('?') => {
                let Some(&c) = n.first() else { return false };
                out.push(c);
                go(&p[1..], &n[1..], out) || {
                    out.pop();
                    false
                }
            }
            Some(&c) => n.first() == Some(&c) && go(&p[1..], &n[1..], out),
        }
    }
    let (p, n): (Vec<char>, Vec<char>) = (pattern.chars().collect(), name.chars().collect());
    let mut out = String::new();
    go(&p, &n, &mut out).then_some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wildcards_give_what_they_matched() {
        assert_eq!(wildcards("left*.jpg", "left07.jpg").as_deref(), Some("07"));
        assert_eq!(
            wildcards("cam?_*.png", "cam1_003.png").as_deref(),
            Some("1003")
        );
        assert_eq!(wildcards("left*.jpg", "right07.jpg"), None);
        assert_eq!(wildcards("*", "").as_deref(), Some(""));
    }

    #[test]
    fn an_instant_is_the_stem_or_what_the_pattern_matched() {
        let folder = CameraImages {
            name: "a".into(),
            files: vec![],
            pattern: None,
        };
        assert_eq!(folder.instant("03.png"), "03");
        let pattern = CameraImages {
            pattern: Some("left*.jpg".into()),
            ..folder
        };
        assert_eq!(pattern.instant("left03.jpg"), "03");
    }
}
