//! The one error type of scene loading and evaluation. Every message starts
//! with the file it is about, says what is wrong in the file's own terms
//! (accessor, node, extension) and ends with how to fix it, because these
//! messages are the whole user interface of a failed `soupray` run.

use std::io;

/// Why a glTF file could not be loaded or a frame could not be evaluated.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file (or a file it refers to) could not be read.
    #[error(
        "{file}: cannot read {what}: {cause}. Fix: check that the path exists and is readable."
    )]
    Io {
        file: String,
        what: String,
        // Not a `#[source]`: the message already says it, and error chains
        // would print it twice.
        cause: io::Error,
    },

    /// The JSON or the GLB container is broken; nothing can be trusted.
    #[error("{file}: {detail}")]
    Malformed { file: String, detail: String },

    /// `extensionsRequired` names something soupray cannot honour.
    #[error(
        "{file}: the file requires the glTF extension {extension}, which soupray does not implement \
         (soupray implements: {supported}). Fix: re-export the asset without {extension}, \
         or convert it (for example with gltf-transform) to plain glTF 2.0."
    )]
    UnsupportedExtension {
        file: String,
        extension: String,
        supported: String,
    },

    /// A buffer's external file or data URI cannot be turned into bytes.
    #[error("{file}: buffer {buffer} refers to \"{uri}\", which {problem}")]
    Buffer {
        file: String,
        buffer: usize,
        uri: String,
        problem: String,
    },

    /// An accessor's bytes are missing, out of range or hold invalid values.
    #[error("{file}: accessor {accessor}{name} ({usage}): {problem}")]
    Accessor {
        file: String,
        accessor: usize,
        /// ` "name"` or empty, so the message reads naturally either way.
        name: String,
        usage: String,
        problem: String,
    },

    /// Anything else that makes the file unusable (bad hierarchy, bad skin...).
    #[error("{file}: {detail}")]
    Invalid { file: String, detail: String },

    /// `--scene`, `--animation` or `--camera` names something the file lacks.
    #[error("{file}: {detail}")]
    Selection { file: String, detail: String },

    /// A frame produced geometry that cannot be traced.
    #[error("{file}: {detail}")]
    Evaluation { file: String, detail: String },
}

impl SceneError {
    pub(crate) fn invalid(file: &str, detail: impl Into<String>) -> Self {
        SceneError::Invalid {
            file: file.to_owned(),
            detail: detail.into(),
        }
    }

    pub(crate) fn selection(file: &str, detail: impl Into<String>) -> Self {
        SceneError::Selection {
            file: file.to_owned(),
            detail: detail.into(),
        }
    }
}

pub type Result<T, E = SceneError> = std::result::Result<T, E>;
