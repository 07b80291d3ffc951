//! Typed errors of scene loading and checking.

use std::path::PathBuf;

/// Why a scene could not be loaded or used.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// A file could not be read.
    #[error("cannot read scene file {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The TOML scene file is malformed.
    #[error("scene file {path} is not valid: {message}")]
    Toml {
        /// The file.
        path: PathBuf,
        /// What the parser said.
        message: String,
    },
    /// The OBJ geometry could not be loaded.
    #[error("cannot load OBJ geometry {path}: {message}")]
    Obj {
        /// The file.
        path: PathBuf,
        /// What tobj said.
        message: String,
    },
    /// A value is outside its physical range.
    #[error("{what} is invalid: {message}")]
    Invalid {
        /// Which item (material, light, …).
        what: String,
        /// Why and how to fix it.
        message: String,
    },
    /// An object refers to a material that the scene file does not define.
    #[error(
        "object `{object}` uses material `{material}`, which is not defined in [materials]; add it or map the object in [objects]"
    )]
    UnknownMaterial {
        /// OBJ object/group name.
        object: String,
        /// Missing material name.
        material: String,
    },
    /// Nothing usable left after the checks.
    #[error("scene has no usable polygons after the input checks ({0})")]
    Empty(String),
}
