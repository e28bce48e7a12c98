//! The one error type of the library. Every variant but [`Error::Shader`] renders as a single
//! line that names the file, field or line at fault; the CLI prints it and exits with code 2.
//!
//! Arguments are named as the API names them (`precision`, `samples_per_pixel`), in
//! [`Error::Argument::option`]'s first word and in backticks within messages; a tool renames
//! them to its own spelling with [`Error::spelled`] (the command line's `--precision`, `--spp`).

use std::path::PathBuf;

/// Anything that stops a render: bad input, an unwritable output folder, no usable GPU.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The scene JSON is not well-formed or does not match the format.
    #[error("{}:{line}:{column}: {message}", file.display())]
    SceneSyntax {
        /// The scene file.
        file: PathBuf,
        /// The line, from 1.
        line: usize,
        /// The column, from 1.
        column: usize,
        /// What is wrong there.
        message: String,
    },
    /// A scene value is out of its valid range (`field` is a path such as `objects[2].radius`).
    #[error("{}: {field}: {message}", file.display())]
    SceneValue {
        /// The scene file.
        file: PathBuf,
        /// The path of the value within the file.
        field: String,
        /// What is wrong with it.
        message: String,
    },
    /// A mesh file is missing, unreadable or corrupt.
    #[error("{}: {message}", file.display())]
    Mesh {
        /// The mesh file.
        file: PathBuf,
        /// What is wrong with it.
        message: String,
    },
    /// A file or folder could not be read or written.
    #[error("{}: {message}", path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The system's reason.
        message: String,
    },
    /// An argument's value is out of range or does not fit the others: `option` names it by
    /// its API name, with the value where it helps (`samples_per_pixel 5`).
    #[error("{option}: {message}")]
    Argument {
        /// The argument (and its value, where it helps).
        option: String,
        /// What is wrong with it.
        message: String,
    },
    /// A user shader (`--shader`, `check-shader`) does not compile or does not fit the hook:
    /// a compiler-style block, `FILE:LINE:COLUMN: error: MESSAGE`, then the source line and a
    /// caret under the column (which counts characters from 1).
    #[error("{}:{line}:{column}: error: {message}{hint}\n{excerpt}", file.display())]
    Shader {
        /// The shader file, as given.
        file: PathBuf,
        /// The line, from 1.
        line: usize,
        /// The column, from 1, in characters.
        column: usize,
        /// The compiler's message or the check's, quoting code in backticks.
        message: String,
        /// The library's advice after it, naming arguments in backticks (empty where none).
        hint: String,
        /// The source line and the caret line.
        excerpt: String,
    },
    /// No GPU adapter, or the device could not run the request.
    #[error("{0}")]
    Device(String),
    /// A render would hold more memory than the machine has: refused before it starts.
    /// `option` names the argument that asks for it (with its value), as in
    /// [`Error::Argument`].
    #[error("{option}: {message}")]
    Memory {
        /// The argument (and its value).
        option: String,
        /// How much the render needs, how much there is, and what to lower.
        message: String,
    },
}

/// The library's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// This error with the arguments it names spelled as a tool spells them: `spelling`
    /// gives the spelling of an API name (`precision`) where the tool has one
    /// (`--precision`). It renames the first word of [`Error::Argument::option`] and every
    /// name written in backticks in an argument's, a memory refusal's or a device's message,
    /// or in a shader error's hint (its message quotes code).
    pub fn spelled(mut self, spelling: &dyn Fn(&str) -> Option<String>) -> Error {
        let text = |t: &mut String| *t = respell(t, spelling);
        match &mut self {
            Error::Argument { option, message } | Error::Memory { option, message } => {
                let (name, rest) = option.split_once(' ').unwrap_or((option, ""));
                if let Some(flag) = spelling(name) {
                    *option = [flag.as_str(), rest].join(if rest.is_empty() { "" } else { " " });
                }
                text(message);
            }
            Error::Device(message) => text(message),
            Error::Shader { hint, .. } => text(hint),
            _ => {}
        }
        self
    }

    /// An I/O error on `path`.
    pub(crate) fn io(path: impl Into<PathBuf>, err: impl std::fmt::Display) -> Self {
        Error::Io {
            path: path.into(),
            message: err.to_string(),
        }
    }
}

/// A file or folder the files' writer could not write, printed alike: `PATH: MESSAGE`.
impl From<raycast_files::FileError> for Error {
    fn from(e: raycast_files::FileError) -> Error {
        Error::Io {
            path: e.path,
            message: e.message,
        }
    }
}

/// `text` with each backticked name that `spelling` knows replaced by its spelling, without the
/// backticks.
fn respell(text: &str, spelling: &dyn Fn(&str) -> Option<String>) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(open) = rest.find('`') {
        let Some(len) = rest[open + 1..].find('`') else {
            break;
        };
        let name = &rest[open + 1..open + 1 + len];
        out.push_str(&rest[..open]);
        match spelling(name) {
            Some(flag) => out.push_str(&flag),
            None => out.push_str(&rest[open..open + len + 2]),
        }
        rest = &rest[open + len + 2..];
    }
    out.push_str(rest);
    out
}

/// An argument named in a message: `` `name` value `` for an option `name value`.
pub(crate) fn named(option: &str) -> String {
    match option.split_once(' ') {
        Some((name, rest)) => format!("`{name}` {rest}"),
        None => format!("`{option}`"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arguments_are_respelled_where_the_tool_has_a_spelling() {
        let flag = |name: &str| match name {
            "precision" => Some("--precision".to_string()),
            "samples_per_pixel" => Some("--spp".to_string()),
            _ => None,
        };
        let e = Error::Argument {
            option: "samples_per_pixel 5".into(),
            message: "runs with `precision` f32, not `f16` or `precision".into(),
        };
        assert_eq!(
            e.spelled(&flag).to_string(),
            "--spp 5: runs with --precision f32, not `f16` or `precision"
        );
        let e = Error::Argument {
            option: "rays[0] direction".into(),
            message: "must not be zero".into(),
        };
        assert_eq!(
            e.spelled(&flag).to_string(),
            "rays[0] direction: must not be zero"
        );
        assert_eq!(named("samples_per_pixel 4"), "`samples_per_pixel` 4");
    }

    #[test]
    fn a_write_error_prints_as_the_files_crate_printed_it() {
        let written = raycast_files::FileError::new("out/id.png", "cannot write: File too large");
        let line = written.to_string();
        let e = Error::from(written);
        assert!(matches!(&e, Error::Io { path, .. } if path.as_os_str() == "out/id.png"));
        assert_eq!(e.to_string(), line);
        assert_eq!(line, "out/id.png: cannot write: File too large");
    }
}
