//! Errors that name the file and say what is wrong with it.

use std::fmt;
use std::io;
use std::path::PathBuf;

/// A model could not be loaded. `Display` gives `path: cause`, ready for a user.
#[derive(Debug)]
pub struct MeshError {
    /// The file the error is about (the model, or the external file it references).
    pub file: PathBuf,
    /// What went wrong.
    pub kind: ErrorKind,
}

impl fmt::Display for MeshError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.file.display(), self.kind)
    }
}

impl std::error::Error for MeshError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.kind.source_error()
    }
}

/// The cause of a [`MeshError`].
#[derive(Debug, thiserror::Error)]
pub enum ErrorKind {
    /// The file itself could not be read.
    #[error("cannot read file: {0}")]
    Io(#[source] io::Error),
    /// The extension is not one of the supported formats.
    #[error("unsupported file type (expected .gltf, .glb, .obj or .ply)")]
    UnknownFormat,
    /// A text format has a malformed line.
    #[error("line {line}: {message}")]
    Syntax { line: usize, message: String },
    /// A binary file is truncated or structurally invalid, or a glTF document is invalid.
    #[error("{0}")]
    Corrupt(String),
    /// A file referenced by the model (buffer, image, material library) is missing.
    #[error("cannot read referenced file `{uri}`: {source}")]
    MissingExternal {
        uri: String,
        #[source]
        source: io::Error,
    },
    /// An image could not be decoded.
    #[error("cannot decode image {name}: {message}")]
    Image { name: String, message: String },
    /// An image in a format this loader does not decode (only PNG and JPEG): loaders drop the
    /// texture with a warning rather than failing the model.
    #[error("image `{name}` is {format}, which cannot be decoded (only PNG and JPEG can)")]
    UnsupportedImage { name: String, format: &'static str },
    /// A face refers to a vertex that does not exist.
    #[error("{context}: index {index} is out of range ({count} vertices)")]
    IndexOutOfRange {
        context: String,
        index: i64,
        count: usize,
    },
    /// A position is NaN or infinite.
    #[error("vertex {vertex} has a non-finite position {value:?}")]
    NonFinite { vertex: usize, value: [f32; 3] },
    /// Nothing to draw.
    #[error("the model has no triangles{0}")]
    Empty(String),
    /// The model holds more than a configured limit allows.
    #[error("{what} is {value}, more than the limit of {limit} ({key})")]
    Limit {
        what: String,
        value: u64,
        limit: u64,
        /// The configuration key that sets the limit.
        key: &'static str,
    },
    /// A glTF extension that changes geometry, which this loader does not implement.
    #[error(
        "unsupported glTF extension `{0}` (it changes the geometry, so loading without it would be wrong)"
    )]
    UnsupportedExtension(String),
}

impl ErrorKind {
    fn source_error(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            ErrorKind::Io(e) | ErrorKind::MissingExternal { source: e, .. } => Some(e),
            _ => None,
        }
    }

    /// Attach the file this error is about.
    pub fn in_file(self, file: impl Into<PathBuf>) -> MeshError {
        MeshError {
            file: file.into(),
            kind: self,
        }
    }
}
