//! Faults outside the input: a full disk (a file-size limit, whose writes fail as a full
//! disk's do), an output path that is a file, a folder that cannot be created, the output
//! folder removed mid-render. Each exits with code 2 and one `error: ` line naming the path,
//! and leaves no file in the output folder.

use crate::common;

use std::path::Path;
use std::process::{Command, Output, Stdio};

use common::{
    assert_no_files, file_names, open_device, render_bunny, repo_path, temporary_files, wait_until,
};

/// Checks the failure contract and returns the one stderr line.
fn one_error(output: &Output) -> String {
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert_eq!(
        output.status.code(),
        Some(2),
        "{:?}: {stderr}",
        output.status
    );
    assert!(output.stdout.is_empty());
    assert_eq!(stderr.lines().count(), 1, "one line, got:\n{stderr}");
    assert!(stderr.starts_with("error: "), "{stderr}");
    stderr
}

/// Writing past `ulimit -f` fails with EFBIG, as a full disk fails with ENOSPC: at 200 blocks
/// (100 or 200 KiB, by the shell's block size) an early file of the set breaks it, at 2000 a
/// larger one further on, after smaller ones were written (which must go too). (The CPU
/// reference renders: lavapipe's device memory is file-backed, and the limit breaks it.)
#[test]
#[cfg(unix)]
fn a_full_disk_leaves_no_file() {
    for blocks in [200, 2000] {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out");
        let command = format!(
            "ulimit -f {blocks} && exec \"$0\" render \"$1\" --device cpu --size 640x360 --format png,npy -o \"$2\""
        );
        let output = Command::new("sh")
            .arg("-c")
            .arg(command)
            .arg(env!("CARGO_BIN_EXE_raycast"))
            .arg(repo_path("scenes/course/bunny.json"))
            .arg(&out)
            .output()
            .unwrap();
        let message = one_error(&output);
        assert!(message.contains(&out.display().to_string()), "{message}");
        assert!(message.contains("cannot write"), "{message}");
        assert_no_files(&out);
    }
}

#[test]
fn an_output_path_that_is_a_file() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("taken");
    std::fs::write(&file, b"kept").unwrap();
    let output = render_bunny().arg("-o").arg(&file).output().unwrap();
    let message = one_error(&output);
    let expected = format!("error: {}: is a file, not a folder", file.display());
    assert_eq!(message.trim_end(), expected);
    assert_eq!(std::fs::read(&file).unwrap(), b"kept");
    assert_eq!(file_names(dir.path()), ["taken"]);
}

/// /proc takes no new folders, not even from root (the tests may run as root, for whom
/// permission bits do not stop writes).
#[test]
#[cfg(target_os = "linux")]
fn a_folder_that_cannot_be_created() {
    let out = Path::new("/proc/raycast-no-such-folder/out");
    let output = render_bunny().arg("-o").arg(out).output().unwrap();
    let message = one_error(&output);
    assert!(
        message.starts_with(&format!("error: {}: ", out.display())),
        "{message}"
    );
    assert!(!out.exists());
}

/// The output folder removed while a banded render writes into it: the render fails when it
/// puts its files in place, and nothing is left (the folder is gone, and not recreated).
#[test]
fn the_output_folder_removed_mid_render() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let mut child = render_bunny()
        .args([
            "--size",
            "2048x2048",
            "--band-rows",
            "32",
            "--precision",
            "f32",
            "-o",
        ])
        .arg(&out)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // All four png files (id, depth, normal, color) open, so none is being created as the
    // folder goes.
    wait_until(&mut child, "four temporary files", || {
        temporary_files(&out) == 4
    });
    std::fs::remove_dir_all(&out).unwrap();
    let output = child.wait_with_output().unwrap();
    let message = one_error(&output);
    assert!(message.contains(&out.display().to_string()), "{message}");
    assert_no_files(&out);
}

/// A device lost before a render (destroyed here, as a driver reset would) gives an error,
/// not a panic.
#[test]
fn a_lost_device_is_an_error() {
    let gpu = open_device(|limits| limits);
    let device = gpu.device.clone();
    let mut scene = common::course_scene("sphere-and-plane");
    scene.camera.resolution = [64, 36];
    let options = raycast::RenderOptions {
        precision: Some(raycast::Precision::F32),
        ..raycast::RenderOptions::default()
    };
    assert!(gpu.render(&scene, &options).is_ok());
    device.destroy();
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        gpu.render(&scene, &options)
    }));
    match result {
        Ok(Err(e)) => {
            let message = e.to_string();
            assert_eq!(message.lines().count(), 1, "{message}");
            assert!(message.contains("the GPU device was lost"), "{message}");
        }
        Ok(Ok(_)) => panic!("a render on a destroyed device succeeded"),
        Err(_) => panic!("a render on a destroyed device panicked"),
    }
}

/// A binary STL of `side` x `side` cells of two triangles each, in the unit square at z = 0.
fn grid_stl(side: u32) -> Vec<u8> {
    let mut bytes = vec![0u8; 80];
    bytes.extend_from_slice(&(2 * side * side).to_le_bytes());
    let corner = |i: u32, j: u32| [i as f32 / side as f32, j as f32 / side as f32, 0.0];
    for i in 0..side {
        for j in 0..side {
            let (a, b, c, d) = (
                corner(i, j),
                corner(i + 1, j),
                corner(i + 1, j + 1),
                corner(i, j + 1),
            );
            for triangle in [[a, b, c], [a, c, d]] {
                bytes.extend_from_slice(&[0u8; 12]);
                for p in triangle.iter().flatten() {
                    bytes.extend_from_slice(&p.to_le_bytes());
                }
                bytes.extend_from_slice(&[0u8; 2]);
            }
        }
    }
    bytes
}

/// A mesh beyond what the device's storage bindings hold is refused with the limit named,
/// before its BVH is built: with `RAYCAST_MAX_BINDING` at 1 MiB the device holds 4 chunks of
/// 2^14 triangles, and the grid has 180,000.
#[test]
fn a_mesh_larger_than_the_device_holds() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("grid.stl"), grid_stl(300)).unwrap();
    let scene = dir.path().join("grid.json");
    let json = r#"{"camera": {"eye": [0.5, 0.5, 2], "look": [0, 0, -1], "up": [0, 1, 0],
        "focal_length": 1, "width": 1, "height": 1, "resolution": [32, 32]},
        "objects": [{"type": "soup", "stl": "grid.stl"}]}"#;
    std::fs::write(&scene, json).unwrap();
    let out = dir.path().join("out");
    let run = |max_binding: &str| {
        common::raycast()
            .args(["render", "--precision", "f32"])
            .arg(&scene)
            .arg("-o")
            .arg(&out)
            .env("RAYCAST_MAX_BINDING", max_binding)
            .output()
            .unwrap()
    };
    let message = one_error(&run("1048576"));
    assert!(
        message.contains("180000 spheres and triangles")
            && message.contains("at most 65536 triangles"),
        "{message}"
    );
    assert_no_files(&out);
    // The same scene fits bindings of 128 MiB (lavapipe's own size).
    assert!(run("134217728").status.success());
    std::fs::remove_dir_all(&out).unwrap();
    let message = one_error(&run("12"));
    assert!(
        message.contains("RAYCAST_MAX_BINDING") && message.contains("`12`"),
        "{message}"
    );
    assert_no_files(&out);
}
