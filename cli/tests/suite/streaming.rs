//! Renders written in bands of rows (`--band-rows`, and automatically above 16.7 million
//! pixels), holding one band at a time, give exactly the files of a whole-image render: the
//! same bytes for ppm and npy, the same pixels for png.

use crate::common;

use std::path::Path;

fn render(scene: &str, out: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec!["--format", "png,ppm,npy"];
    args.extend(extra);
    render_args(scene, out, &args)
}

fn render_args(scene: &str, out: &Path, args: &[&str]) -> std::process::Output {
    let output = common::raycast()
        .arg("render")
        .arg(common::repo_path(scene))
        .arg("-o")
        .arg(out)
        .args(args)
        .env("NODEVICE_SELECT", "1")
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    output
}

fn same_files(whole: &Path, banded: &Path) {
    let names = common::file_names(whole);
    assert_eq!(names, common::file_names(banded));
    for name in names {
        let (a, b) = (whole.join(&name), banded.join(&name));
        if name.ends_with(".png") {
            let (a, b) = (image::open(&a).unwrap(), image::open(&b).unwrap());
            assert_eq!(a.color(), b.color(), "{name:?}");
            assert_eq!(a.as_bytes(), b.as_bytes(), "{name:?}");
        } else {
            assert_eq!(
                std::fs::read(a).unwrap(),
                std::fs::read(b).unwrap(),
                "{name:?}"
            );
        }
    }
}

#[test]
fn bands_give_the_files_of_a_whole_render() {
    let dir = tempfile::tempdir().unwrap();
    let cases: [(&str, &[&str]); 5] = [
        ("scenes/course/bunny.json", &[]),
        // Three pixels wide: an (H, 3) array must not be taken for an (H, W, 3) one.
        (
            "scenes/course/two-spheres-and-plane.json",
            &["--size", "3x20"],
        ),
        (
            "scenes/course/two-spheres-and-plane.json",
            &["--precision", "f64"],
        ),
        (
            "scenes/course/sphere-packing.json",
            &["--outputs", "distance,color"],
        ),
        (
            "scenes/course/two-spheres-and-plane.json",
            &["--shader", "shaders/examples/toon.wgsl"],
        ),
    ];
    for (k, (scene, extra)) in cases.iter().enumerate() {
        let extra: Vec<String> = extra
            .iter()
            .map(|a| {
                if a.ends_with(".wgsl") {
                    common::repo_path(a).display().to_string()
                } else {
                    a.to_string()
                }
            })
            .collect();
        let extra: Vec<&str> = extra.iter().map(String::as_str).collect();
        let whole = dir.path().join(format!("whole{k}"));
        let banded = dir.path().join(format!("banded{k}"));
        // Bands need a single kernel: without a precision they render in f32 (the whole image
        // would take the default, adaptive precision), so the whole render names it.
        let mut whole_args = extra.clone();
        if !extra.contains(&"--precision") {
            whole_args.extend(["--precision", "f32"]);
        }
        render(scene, &whole, &whole_args);
        let mut with_bands = extra.clone();
        with_bands.extend(["--band-rows", "7"]);
        let out = render(scene, &banded, &with_bands);
        assert!(String::from_utf8_lossy(&out.stdout).contains("in bands of 7 rows"));
        same_files(&whole, &banded);
    }
}

/// Bands are refused, before the output folder is made, where they cannot be rendered: on the
/// CPU and with samples per pixel.
#[test]
fn bands_need_a_gpu_kernel() {
    for args in [&["--device", "cpu"][..], &["--spp", "4"]] {
        let dir = tempfile::tempdir().unwrap();
        let output = common::raycast()
            .args(["render", "--band-rows", "8"])
            .args(args)
            .arg("-o")
            .arg(dir.path().join("out"))
            .env("NODEVICE_SELECT", "1")
            .output()
            .unwrap();
        assert_eq!(output.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&output.stderr);
        assert!(
            err.contains("--band-rows") && err.lines().count() == 1,
            "{args:?}: {err}"
        );
        assert!(!dir.path().join("out").exists(), "{args:?}");
    }
}

/// Renders above the streaming threshold (2^24 pixels) are written in bands, holding one band
/// at a time: the peak memory of the course's sphere-and-plane scene at 6144 x 6144 is within
/// 32 MiB of its peak at 4097 x 4097, while its id image alone grows by 80 MiB (as u32; 400 MiB
/// as the three f32 images), and is below 1500 MiB. The larger id picture, read back row by
/// row, has the objects of a small render of the same view.
#[test]
fn renders_above_the_threshold_stream_in_bounded_memory() {
    let peak_at = |size: &str, dir: &Path| -> f64 {
        let out = render_args(
            "scenes/course/two-spheres-and-plane.json",
            dir,
            &["--size", size, "--format", "png", "--outputs", "id"],
        );
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(stdout.contains("in bands of "), "{stdout}");
        stdout
            .split("peak memory ")
            .nth(1)
            .and_then(|s| s.split(' ').next())
            .and_then(|s| s.parse().ok())
            .unwrap_or_else(|| panic!("no peak memory in {stdout}"))
    };
    let (low, high) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let peak_low = peak_at("4097x4097", low.path());
    let peak_high = peak_at("6144x6144", high.path());
    assert!(
        peak_high < peak_low + 32.0 && peak_high < 1500.0,
        "peak memory {peak_low} MiB at 4097x4097, {peak_high} MiB at 6144x6144"
    );
    let file = std::io::BufReader::new(std::fs::File::open(high.path().join("id.png")).unwrap());
    let mut reader = png::Decoder::new(file).read_info().unwrap();
    assert_eq!((reader.info().width, reader.info().height), (6144, 6144));
    let mut colours = std::collections::BTreeSet::new();
    let mut rows = 0;
    while let Some(row) = reader.next_row().unwrap() {
        row.data().chunks_exact(3).step_by(97).for_each(|c| {
            colours.insert([c[0], c[1], c[2]]);
        });
        rows += 1;
    }
    assert_eq!(rows, 6144);
    let small = tempfile::tempdir().unwrap();
    render_args(
        "scenes/course/two-spheres-and-plane.json",
        small.path(),
        &["--size", "256x256", "--format", "png", "--outputs", "id"],
    );
    let small = image::open(small.path().join("id.png")).unwrap().to_rgb8();
    let small: std::collections::BTreeSet<[u8; 3]> = small.pixels().map(|p| p.0).collect();
    assert_eq!(colours, small);
}
