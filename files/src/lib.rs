//! # raycast-files
//!
//! Files written whole or not at all, beneath the `raycast` library and its clients: every file
//! goes to a temporary name beside it and is renamed into place only when all of a set were
//! written ([`write_files`], [`write_file`]), a folder is filled under a temporary name and
//! placed whole ([`write_folder`]), and an interrupted process removes the temporary files first
//! ([`remove_partial_files`]). [`pending`] is the registry of those temporary files, for a writer
//! of its own (the library's band-by-band files).

#![warn(missing_docs)]

pub mod pending;

use std::path::{Path, PathBuf};

pub use pending::remove_partial_files;

/// A file or folder that could not be written: the one line `PATH: MESSAGE`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FileError {
    /// The file or folder.
    pub path: PathBuf,
    /// The system's reason.
    pub message: String,
}

impl FileError {
    /// An error on `path`.
    pub fn new(path: impl Into<PathBuf>, message: impl std::fmt::Display) -> FileError {
        FileError {
            path: path.into(),
            message: message.to_string(),
        }
    }
}

impl std::fmt::Display for FileError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.path.display(), self.message)
    }
}

impl std::error::Error for FileError {}

/// The crate's functions' result.
type Result<T, E = FileError> = std::result::Result<T, E>;

/// One output file: its name in the output folder and its bytes.
pub struct EncodedFile {
    /// The file's name.
    pub name: &'static str,
    /// What it holds.
    pub bytes: Vec<u8>,
}

/// Writes the folder `folder` whole or not at all: `write` fills a temporary folder beside it
/// (its parent folders created), which then replaces `folder` (a folder there is moved aside,
/// then removed); at an error, or at an interruption ([`remove_partial_files`]), the temporary
/// folder is removed. Returns what `write` returned; `write`'s error type is the caller's.
pub fn write_folder<T, E: From<FileError>>(
    folder: &Path,
    write: impl FnOnce(&Path) -> Result<T, E>,
) -> Result<T, E> {
    let temporary = pending::temp_path(folder)?;
    if let Some(parent) = temporary.parent() {
        std::fs::create_dir_all(parent)
            .map_err(|e| FileError::new(parent, format!("cannot create folder: {e}")))?;
    }
    pending::create_dir(&temporary)?;
    match write(&temporary) {
        Ok(value) => Ok(pending::place_dir(&temporary, folder).map(|()| value)?),
        Err(e) => {
            pending::discard_dir(&temporary);
            Err(e)
        }
    }
}

/// Creates `dir` if needed and checks a file can be created in it, before any rendering.
pub fn check_writable(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| {
        // The system's "File exists" or "Not a directory" where the folder, or one above it,
        // is a file: name that file.
        match dir.ancestors().find(|a| a.exists() && !a.is_dir()) {
            Some(file) if file == dir => FileError::new(dir, "is a file, not a folder"),
            Some(file) => {
                FileError::new(dir, format!("{} is a file, not a folder", file.display()))
            }
            None => FileError::new(dir, format!("cannot create folder: {e}")),
        }
    })?;
    let probe = dir.join(format!(".raycast-write-test-{}", std::process::id()));
    let created = pending::create(&probe);
    pending::discard([probe.as_path()]);
    created
        .map(drop)
        .map_err(|e| FileError::new(dir, format!("folder is not writable: {e}")))
}

/// [`check_writable`] for the folder `file` goes into (the working folder for a bare name).
pub fn check_parent_writable(file: &Path) -> Result<()> {
    let dir = file.parent().filter(|d| !d.as_os_str().is_empty());
    check_writable(dir.unwrap_or(Path::new(".")))
}

/// Writes every file into `dir` (created if missing: [`check_writable`]) or none: all go to
/// temporary names first, then are renamed into place. The temporary files are registered for
/// removal on an interruption ([`remove_partial_files`]).
pub fn write_files(dir: &Path, files: &[EncodedFile]) -> Result<Vec<PathBuf>> {
    check_writable(dir)?;
    let named: Vec<(PathBuf, &[u8])> = files
        .iter()
        .map(|f| (dir.join(f.name), f.bytes.as_slice()))
        .collect();
    write_all_or_none(&named)
}

/// Writes one file whole or not at all: to a temporary name beside it, then renamed.
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    write_all_or_none(&[(path.to_owned(), bytes)]).map(drop)
}

/// [`write_files`] for files given by path: each is written to `.NAME.tmp-PID` beside it.
fn write_all_or_none(files: &[(PathBuf, &[u8])]) -> Result<Vec<PathBuf>> {
    // Every name is checked before any file is created.
    let pairs = files
        .iter()
        .map(|(path, _)| Ok((pending::temp_path(path)?, path.clone())))
        .collect::<Result<Vec<_>>>()?;
    for ((tmp, _), (_, bytes)) in pairs.iter().zip(files) {
        let written =
            pending::create(tmp).and_then(|mut f| std::io::Write::write_all(&mut f, bytes));
        if let Err(e) = written {
            pending::discard(pairs.iter().map(|(tmp, _)| tmp.as_path()));
            return Err(FileError::new(tmp, format!("cannot write: {e}")));
        }
    }
    pending::place_all(&pairs)?;
    Ok(pairs.into_iter().map(|(_, path)| path).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The names in `dir`, sorted.
    fn names(dir: &Path) -> Vec<String> {
        let mut names: Vec<_> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect();
        names.sort();
        names
    }

    #[test]
    fn write_files_leaves_nothing_on_failure() {
        let dir = tempfile::tempdir().unwrap();
        // A folder where the second file should go makes its rename fail.
        std::fs::create_dir(dir.path().join("b.bin")).unwrap();
        std::fs::write(dir.path().join("b.bin").join("x"), b"").unwrap();
        let files = [
            EncodedFile {
                name: "a.bin",
                bytes: vec![1],
            },
            EncodedFile {
                name: "b.bin",
                bytes: vec![2],
            },
        ];
        assert!(write_files(dir.path(), &files).is_err());
        assert!(!pending::holds_any_in(dir.path()));
        // Neither a.bin nor any temporary file is left behind.
        assert_eq!(names(dir.path()), ["b.bin"]);
        // Written and placed: forgotten too.
        std::fs::remove_dir_all(dir.path().join("b.bin")).unwrap();
        assert_eq!(write_files(dir.path(), &files).unwrap().len(), 2);
        assert!(!pending::holds_any_in(dir.path()));
        assert_eq!(std::fs::read(dir.path().join("b.bin")).unwrap(), [2]);
    }

    #[test]
    fn errors_print_the_path_then_the_message() {
        let error = FileError::new("out/depth.png", "cannot write: File too large");
        assert_eq!(
            error.to_string(),
            "out/depth.png: cannot write: File too large"
        );
    }

    #[test]
    fn a_folder_is_placed_whole_or_left_as_it_was() {
        let root = tempfile::tempdir().unwrap();
        let folder = root.path().join("views").join("0001");
        let written = write_folder(&folder, |temporary| {
            std::fs::write(temporary.join("id.png"), b"new")
                .map_err(|e| FileError::new(temporary, e))
        });
        assert_eq!(written, Ok(()));
        assert_eq!(names(&folder), ["id.png"]);
        // A failed write leaves the folder there as it was, and no temporary folder beside it.
        let failed: Result<()> = write_folder(&folder, |temporary| {
            std::fs::write(temporary.join("id.png"), b"newer").unwrap();
            Err(FileError::new(temporary, "stopped"))
        });
        assert_eq!(failed.unwrap_err().message, "stopped");
        assert_eq!(std::fs::read(folder.join("id.png")).unwrap(), b"new");
        assert_eq!(names(&root.path().join("views")), ["0001"]);
        assert!(!pending::holds_any_in(&root.path().join("views")));
    }

    #[test]
    fn a_file_where_the_folder_should_be_is_named() {
        let root = tempfile::tempdir().unwrap();
        let file = root.path().join("taken");
        std::fs::write(&file, b"").unwrap();
        let error = check_writable(&file).unwrap_err();
        assert_eq!(error.message, "is a file, not a folder");
        let below = file.join("out");
        let error = check_writable(&below).unwrap_err();
        assert_eq!(error.path, below);
        assert_eq!(
            error.message,
            format!("{} is a file, not a folder", file.display())
        );
    }
}
