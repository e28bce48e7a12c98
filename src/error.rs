//! The one error type of the library. Every variant but [`Error::Shader`] renders as a single
//! line that names the file, field or line at fault; the CLI prints it and exits with code 2.

use std::path::PathBuf;

/// Anything that stops a render: bad input, an unwritable output folder, no usable GPU.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The scene JSON is not well-formed or does not match the format.
    #[error("{}:{line}:{column}: {message}", file.display())]
    SceneSyntax {
        file: PathBuf,
        line: usize,
        column: usize,
        message: String,
    },
    /// A scene value is out of its valid range (`field` is a path such as `objects[2].radius`).
    #[error("{}: {field}: {message}", file.display())]
    SceneValue {
        file: PathBuf,
        field: String,
        message: String,
    },
    /// A mesh file is missing, unreadable or corrupt.
    #[error("{}: {message}", file.display())]
    Mesh { file: PathBuf, message: String },
    /// A file or folder could not be read or written.
    #[error("{}: {message}", path.display())]
    Io { path: PathBuf, message: String },
    /// A command-line value is out of range (`option` names it, e.g. `--size`).
    #[error("{option}: {message}")]
    Argument { option: String, message: String },
    /// A user shader (`--shader`, `check-shader`) does not compile or does not fit the hook:
    /// a compiler-style block, `FILE:LINE:COLUMN: error: MESSAGE`, then the source line and a
    /// caret under the column (which counts characters from 1).
    #[error("{}:{line}:{column}: error: {message}\n{excerpt}", file.display())]
    Shader {
        file: PathBuf,
        line: usize,
        column: usize,
        message: String,
        /// The source line and the caret line.
        excerpt: String,
    },
    /// No GPU adapter, or the device could not run the request.
    #[error("{0}")]
    Device(String),
}

/// The library's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, err: impl std::fmt::Display) -> Self {
        Error::Io {
            path: path.into(),
            message: err.to_string(),
        }
    }
}
