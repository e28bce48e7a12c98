//! A render stopped by SIGTERM or SIGINT removes the temporary files it was writing, prints one
//! line and exits with code 130: the output folder holds no file afterwards. `render --watch`,
//! whose way out is Ctrl-C, ends quietly with code 0.
#![cfg(unix)]

use crate::common;

use std::path::Path;
use std::process::{Child, Command, Stdio};

use common::{assert_no_files, render_bunny, temporary_files, wait_until};

/// `raycast render` of the course bunny into `out` with `args`.
fn start(out: &Path, args: &[&str]) -> Child {
    render_bunny()
        .arg("-o")
        .arg(out)
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the raycast binary runs")
}

/// Sends `signal` to the child and waits for it to end.
fn signal(child: Child, signal: &str) -> std::process::Output {
    let killed = Command::new("kill")
        .args([signal, &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    child.wait_with_output().unwrap()
}

/// Sends `signal` to the child, then checks the exit code, the message and the empty folder.
fn stop_and_check(child: Child, signal_name: &str, out: &Path) {
    let output = signal(child, signal_name);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(
        output.status.code(),
        Some(130),
        "{:?}: {stderr}",
        output.status
    );
    assert_eq!(
        stderr.lines().last(),
        Some("error: interrupted; no partial file left")
    );
    assert_no_files(out);
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

#[test]
fn ctrl_c_ends_a_watch_quietly_keeping_the_last_render() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let args = ["--watch", "--device", "cpu", "--size", "32x18"];
    let mut child = start(&out, &args);
    wait_until(&mut child, "the first render", || {
        out.join("camera.json").exists()
    });
    let output = signal(child, "-INT");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(
        output.status.code(),
        Some(0),
        "{:?}: {stderr}",
        output.status
    );
    assert!(!stderr.contains("error"), "{stderr}");
    let names = [
        "camera.json",
        "color.png",
        "depth.png",
        "id.png",
        "normal.png",
    ];
    assert_eq!(common::file_names(&out), names);
}
