//! Errors of reading, validating and writing rig files; each names the file and field.

use std::path::PathBuf;

use thiserror::Error;

/// A problem with a rig or camera file.
#[derive(Debug, Error)]
pub enum RigError {
    /// The file could not be read.
    #[error("{}: cannot read: {source}", file.display())]
    Read {
        /// The file.
        file: PathBuf,
        /// Underlying I/O error.
        source: std::io::Error,
    },
    /// The file could not be written.
    #[error("{}: cannot write: {source}", file.display())]
    Write {
        /// The file.
        file: PathBuf,
        /// Underlying I/O error.
        source: std::io::Error,
    },
    /// The file is not valid YAML/JSON/TOML or has a value of the wrong type.
    #[error("{}: {message}", file.display())]
    Syntax {
        /// The file.
        file: PathBuf,
        /// Parser message (with line and column where the parser gives them).
        message: String,
    },
    /// The path is not a regular file, or too large to be what it should be.
    #[error(transparent)]
    File(crate::files::FileError),
    /// A field is missing or has an invalid value.
    #[error("{}: field `{field}`: {problem}", file.display())]
    Field {
        /// The file.
        file: PathBuf,
        /// The field, e.g. `camera_matrix` or `cameras[1].file`.
        field: String,
        /// What is wrong and what to do about it.
        problem: String,
    },
}

impl RigError {
    pub(crate) fn field(
        file: impl Into<PathBuf>,
        field: impl Into<String>,
        problem: impl Into<String>,
    ) -> Self {
        RigError::Field {
            file: file.into(),
            field: field.into(),
            problem: problem.into(),
        }
    }
}

impl From<crate::files::FileError> for RigError {
    /// A file system error stays a [`RigError::Read`] naming the file.
    fn from(e: crate::files::FileError) -> Self {
        match e {
            crate::files::FileError::Io { path, source } => RigError::Read { file: path, source },
            other => RigError::File(other),
        }
    }
}
