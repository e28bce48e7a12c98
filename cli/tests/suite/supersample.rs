//! `raycast render --spp N` end to end: bad values refused, `color.png` and `alpha.npy` written
//! (src/tests/supersample.rs checks the coverage itself).

use crate::common;

use std::path::PathBuf;
use std::process::Output;

use common::{SPHERE, file_names, ortho_json};

// 4. Bad --spp and --background values.

fn run_render(scene_json: &str, args: &[&str]) -> (Output, tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.json");
    std::fs::write(&scene, scene_json).unwrap();
    let out = dir.path().join("out");
    let output = common::raycast()
        .arg("render")
        .arg(&scene)
        .arg("-o")
        .arg(&out)
        .args(args)
        .output()
        .expect("the raycast binary runs");
    (output, dir, out)
}

#[test]
fn bad_spp_and_background_values_exit_2_with_one_line() {
    let json = ortho_json(4.0, 4.0, 8, 8, SPHERE);
    for (args, option) in [
        (&["--spp", "3"][..], "--spp"),
        (&["--spp", "5"], "--spp"),
        (&["--spp", "0"], "--spp"),
        (&["--spp", "four"], "--spp"),
        (&["--background", "300,0,0"], "--background"),
        (&["--background", "1,2"], "--background"),
        (&["--background", "1,2,3,4"], "--background"),
    ] {
        let (output, _dir, out) = run_render(&json, args);
        let stderr = String::from_utf8(output.stderr).unwrap();
        assert_eq!(output.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(output.stdout.is_empty(), "{args:?}");
        assert!(
            stderr.starts_with("error: ") && stderr.lines().count() == 1,
            "{args:?}: one `error: ` line, got:\n{stderr}"
        );
        assert!(stderr.contains(option), "{args:?}: {stderr}");
        assert!(
            !out.exists() || file_names(&out).is_empty(),
            "{args:?}: wrote files"
        );
    }
}

// 5. End to end.

/// The payload of a float32 `.npy` file with its shape.
fn read_f32_npy(bytes: &[u8]) -> (String, Vec<f32>) {
    assert_eq!(&bytes[..8], b"\x93NUMPY\x01\x00");
    let len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    let header = std::str::from_utf8(&bytes[10..10 + len])
        .unwrap()
        .to_owned();
    assert!(header.contains("'descr': '<f4'"), "{header}");
    let data = bytes[10 + len..]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
        .collect();
    (header, data)
}

#[test]
fn render_with_spp_writes_color_png_and_alpha_npy() {
    let json = ortho_json(4.0, 3.0, 40, 30, SPHERE);
    let (output, _dir, out) = run_render(&json, &["--spp", "4", "--format", "png,npy"]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(0), "{stderr}");
    assert!(String::from_utf8_lossy(&output.stdout).contains("4 spp"));
    assert_eq!(
        file_names(&out),
        [
            "alpha.npy",
            "camera.json",
            "color.png",
            "depth.png",
            "distance.npy",
            "id.npy",
            "id.png",
            "normal.npy",
            "normal.png"
        ]
    );
    let color = image::open(out.join("color.png")).unwrap();
    assert_eq!(color.color(), image::ColorType::Rgba8);
    let color = color.into_rgba8();
    assert_eq!(color.dimensions(), (40, 30));
    let (header, alpha) = read_f32_npy(&std::fs::read(out.join("alpha.npy")).unwrap());
    assert!(header.contains("'shape': (30, 40)"), "{header}");
    assert_eq!(alpha.len(), 40 * 30);
    // The png's alpha is alpha.npy rounded to 8 bits, and partial coverage occurs.
    for (px, &a) in color.pixels().zip(&alpha) {
        assert!([0.0, 0.25, 0.5, 0.75, 1.0].contains(&a), "{a}");
        assert_eq!(px[3], (255.0 * a + 0.5).floor() as u8);
    }
    assert!(alpha.iter().any(|&a| a > 0.0 && a < 1.0));

    // With a background: opaque, the background where nothing was hit.
    let (output, _dir, out) = run_render(&json, &["--spp", "4", "--background", "0,0,255"]);
    assert_eq!(output.status.code(), Some(0));
    assert_eq!(
        file_names(&out),
        [
            "camera.json",
            "color.png",
            "depth.png",
            "id.png",
            "normal.png"
        ]
    );
    let color = image::open(out.join("color.png")).unwrap().into_rgba8();
    for (px, &a) in color.pixels().zip(&alpha) {
        assert_eq!(px[3], 255);
        if a == 0.0 {
            assert_eq!(px.0, [0, 0, 255, 255]);
        }
    }

    // Without --spp: color.png at one sample per pixel (alpha 0 or 1), no alpha.npy.
    let (output, _dir, out) = run_render(&json, &["--format", "png,npy"]);
    assert_eq!(output.status.code(), Some(0));
    assert!(!file_names(&out).contains(&"alpha.npy".to_owned()));
    let color = image::open(out.join("color.png")).unwrap().into_rgba8();
    assert!(color.pixels().all(|p| p[3] == 0 || p[3] == 255));
}
