//! A render stopped by SIGTERM or SIGINT removes the temporary files it was writing, prints one
//! line and exits with code 130: the output folder holds no file afterwards.
#![cfg(unix)]

mod common;

use std::path::Path;
use std::process::{Child, Command, Stdio};

use common::{file_names, repo_path, temporary_files, wait_until};

/// `raycast render` of the course bunny into `out` with `args`.
fn start(out: &Path, args: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_raycast"))
        .arg("render")
        .arg(repo_path("scenes/course/bunny.json"))
        .arg("-o")
        .arg(out)
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the raycast binary runs")
}

/// Sends `signal` to the child, then checks the exit code, the message and the empty folder.
fn stop_and_check(mut child: Child, signal: &str, out: &Path) {
    let killed = Command::new("kill")
        .args([signal, &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let status = child.wait().unwrap();
    let mut stderr = String::new();
    std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut stderr).unwrap();
    assert_eq!(status.code(), Some(130), "{status:?}: {stderr}");
    assert_eq!(
        stderr.lines().last(),
        Some("error: interrupted; no partial file left")
    );
    let left = if out.exists() {
        file_names(out)
    } else {
        Vec::new()
    };
    assert!(left.is_empty(), "{signal} left {left:?}");
}

#[test]
fn a_signal_while_bands_are_written_leaves_no_file() {
    for signal in ["-TERM", "-INT"] {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out");
        // Banded: every file is open from the first band to the last.
        let args = [
            "--size",
            "4096x4096",
            "--band-rows",
            "64",
            "--precision",
            "f32",
            "--format",
            "png,npy",
        ];
        let mut child = start(&out, &args);
        wait_until(&mut child, "a temporary file", || temporary_files(&out) > 0);
        stop_and_check(child, signal, &out);
    }
}

#[test]
fn a_signal_during_the_render_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let mut child = start(&out, &["--size", "4096x4096", "--device", "cpu"]);
    // The folder is made after the handler is installed and before rendering; the CPU
    // reference then takes many seconds at this size, so the signal comes before any file.
    wait_until(&mut child, "the output folder", || out.exists());
    stop_and_check(child, "-TERM", &out);
}
