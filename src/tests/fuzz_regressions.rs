//! Every input the fuzz targets (fuzz/) found a fault with, run through the same reader: each
//! must return (an error or a value) within 10 seconds, without panicking. The inputs are in
//! tests/data/fuzz/TARGET/, named by what they broke.

use super::common;

use std::path::Path;
use std::sync::mpsc;
use std::time::Duration;

/// Runs `read` on every file of tests/data/fuzz/`target` in a thread of its own, failing on a
/// panic or after 10 seconds. Returns how many files there were.
fn each_input(target: &str, read: fn(&[u8], &Path)) -> usize {
    let dir = common::repo_path(&format!("tests/data/fuzz/{target}"));
    let mut count = 0;
    for name in common::file_names(&dir) {
        let path = dir.join(name);
        let bytes = std::fs::read(&path).unwrap();
        let (done, finished) = mpsc::channel();
        let input = path.clone();
        std::thread::spawn(move || {
            read(&bytes, &input);
            let _ = done.send(());
        });
        match finished.recv_timeout(Duration::from_secs(10)) {
            Ok(()) => count += 1,
            Err(mpsc::RecvTimeoutError::Timeout) => panic!("{} takes over 10 s", path.display()),
            Err(mpsc::RecvTimeoutError::Disconnected) => panic!("{} panicked", path.display()),
        }
    }
    count
}

#[test]
fn ply_inputs_the_fuzzer_found() {
    let read = |bytes: &[u8], path: &Path| {
        let _ = raycast::scene::parse_mesh(bytes, path, raycast::scene::Split::None);
    };
    assert!(each_input("ply", read) >= 1);
}
