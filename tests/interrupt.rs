//! A render stopped by SIGTERM or SIGINT removes the temporary files it was writing, prints one
//! line and exits with code 130: the output folder holds no file afterwards.
#![cfg(unix)]

mod common;

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use common::{file_names, repo_path};

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

/// Waits until `out` holds a temporary file (`.NAME.tmp-PID`), at most a minute.
fn wait_for_temporary_files(out: &Path, child: &mut Child) {
    let start = Instant::now();
    while start.elapsed() < Duration::from_secs(60) {
        if out.exists() && file_names(out).iter().any(|n| n.contains(".tmp-")) {
            return;
        }
        assert!(
            child.try_wait().unwrap().is_none(),
            "the render ended first"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    panic!("no temporary file appeared in {}", out.display());
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
        Some("error: interrupted; no output written")
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
        wait_for_temporary_files(&out, &mut child);
        stop_and_check(child, signal, &out);
    }
}

#[test]
fn a_signal_during_the_render_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let child = start(&out, &["--size", "2048x2048", "--device", "cpu"]);
    // The CPU reference takes seconds at this size: the signal comes before any file.
    std::thread::sleep(Duration::from_millis(300));
    stop_and_check(child, "-TERM", &out);
}
