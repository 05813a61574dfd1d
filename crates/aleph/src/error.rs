//! Errors from loading scenes (writing outputs: [`crate::output::OutputError`]; reading
//! images: [`crate::imageio::ImageError`]).

use std::path::PathBuf;

/// Something wrong with a scene or one of the files it names. Every variant names the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SceneError {
    /// A file could not be opened or read (missing, unreadable); the cause is the source.
    #[error("{}: cannot read file", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating-system error.
        #[source]
        source: std::io::Error,
    },
    /// The scene TOML is malformed, has an unknown key, or a value of the wrong type. The
    /// message carries the line and column.
    #[error("{}: {message}", path.display())]
    Toml {
        /// The scene file.
        path: PathBuf,
        /// The parser's message, with location.
        message: String,
    },
    /// An OBJ file could not be parsed.
    #[error("{}: invalid OBJ file: {message}", path.display())]
    Obj {
        /// The OBJ file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// An MTL file named by an OBJ could not be loaded.
    #[error("{}: cannot load MTL file: {message}", path.display())]
    Mtl {
        /// The MTL file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A material's `map_*` statement in an MTL file names no image, or its image could not
    /// be loaded.
    #[error("{}: material {material:?}, {statement}: {message}", mtl.display())]
    MaterialTexture {
        /// The MTL file.
        mtl: PathBuf,
        /// The material (`newmtl` name).
        material: String,
        /// The statement (`map_Kd`, `map_Ks`, `map_Ke`, `map_d`, `bump`, `norm`).
        statement: &'static str,
        /// What is wrong, with the image file's path where one is named.
        message: String,
    },
    /// A texture named by an MTL file could not be loaded.
    #[error("{}: cannot load texture: {message}", path.display())]
    Texture {
        /// The image file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A value is out of range or inconsistent (NaN vertex, zero resolution, unknown material
    /// name, …). The message names the key or element and the valid range.
    #[error("{}: {message}", path.display())]
    Invalid {
        /// The file holding the value.
        path: PathBuf,
        /// What is wrong and what is allowed.
        message: String,
    },
    /// Nothing in the scene emits light.
    #[error(
        "{}: the scene has no light: no MTL material has a non-zero Ke and no [[light]] emits{hint}",
        path.display()
    )]
    NoLights {
        /// The scene file.
        path: PathBuf,
        /// Empty, or what may have been meant as a light: MTL materials whose `Ka` exceeds 1
        /// (an emitter's radiance written as ambient colour), and how to make one emit.
        hint: String,
    },
}

/// Result alias for scene loading.
pub type SceneResult<T> = Result<T, SceneError>;
