//! `--outputs`: a kernel asked for some outputs computes and reads back only those, and they
//! are bit for bit the full render's; the others keep their miss values, and the CLI writes
//! the files of the outputs asked for only. (That the kernel leaves the normal functions
//! uncalled is checked on the naga module in `src/gpu/shader/variant.rs`.)

use crate::common::{self, Kernel};

use common::file_names;

use raycast::Algorithm::{Robust, Textbook};
use raycast::{Images, MISS, Outputs};

fn only(id: bool, distance: bool, normal: bool) -> Outputs {
    Outputs {
        id,
        distance,
        normal,
        color: false,
    }
}

fn bits<R: Kernel>(values: &[R]) -> Vec<u64> {
    values.iter().map(|&v| v.into().to_bits()).collect()
}

/// Each output alone, and distance with normal, against the full render, for `scene`.
fn check<R: Kernel>(scene: &raycast::Scene, name: &str) {
    let g = common::gpu();
    for algorithm in [Textbook, Robust] {
        let full: Images<R> = common::gpu_scene(g, scene, algorithm).unwrap();
        assert!(
            full.id.iter().any(|&id| id != MISS),
            "{name}: no hit at all"
        );
        for outputs in [
            only(true, false, false),
            only(false, true, false),
            only(false, false, true),
            only(false, true, true),
        ] {
            let part: Images<R> = common::gpu_outputs(g, scene, algorithm, outputs, None).unwrap();
            let what = format!("{name} {algorithm} {outputs:?}");
            // What a miss holds: id MISS, distance +inf, normal zero.
            let n = full.id.len();
            let expected_id = if outputs.id {
                full.id.clone()
            } else {
                vec![MISS; n]
            };
            assert_eq!(part.id, expected_id, "id: {what}");
            let distance = match outputs.distance {
                true => bits(&full.distance),
                false => vec![f64::INFINITY.to_bits(); n],
            };
            assert_eq!(bits(&part.distance), distance, "distance: {what}");
            let flat = |i: &Images<R>| i.normal.iter().flatten().copied().collect::<Vec<R>>();
            let normal = match outputs.normal {
                true => bits(&flat(&full)),
                false => vec![0f64.to_bits(); 3 * n],
            };
            assert_eq!(bits(&flat(&part)), normal, "normal: {what}");
        }
    }
}

#[test]
fn each_output_alone_is_the_full_renders_bit_for_bit() {
    // Spheres and a plane, with misses above the horizon; and the bunny's triangles.
    let mut spheres = common::course_scene("two-spheres-and-plane");
    spheres.camera.resolution = [64, 36];
    let mut bunny = common::course_scene("bunny");
    bunny.camera.resolution = [48, 27];
    for (scene, name) in [(&spheres, "two-spheres"), (&bunny, "bunny")] {
        check::<f32>(scene, name);
        check::<f64>(scene, name);
    }
}

fn raycast_render(args: &[&str]) -> std::process::Output {
    common::raycast()
        .arg("render")
        .arg(common::repo_path(
            "scenes/course/two-spheres-and-plane.json",
        ))
        .args(["--size", "32x18"])
        .args(args)
        .output()
        .expect("the raycast binary runs")
}

#[test]
fn the_files_written_follow_outputs() {
    let dir = tempfile::tempdir().unwrap();
    for (outputs, formats, files) in [
        (
            "distance",
            "png,npy",
            vec!["camera.json", "depth.png", "distance.npy"],
        ),
        (
            "id,normal",
            "ppm",
            vec!["camera.json", "id.ppm", "normal.ppm"],
        ),
        (
            "normal,color",
            "png",
            vec!["camera.json", "color.png", "normal.png"],
        ),
    ] {
        let out = dir.path().join(outputs.replace(',', "-"));
        let o = raycast_render(&[
            "-o",
            out.to_str().unwrap(),
            "--outputs",
            outputs,
            "--format",
            formats,
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert_eq!(
            file_names(&out),
            files,
            "--outputs {outputs} --format {formats}"
        );
    }
    // Without --outputs: every file of the formats, color.png with png.
    let out = dir.path().join("default");
    let o = raycast_render(&["-o", out.to_str().unwrap(), "--format", "png,npy"]);
    assert!(o.status.success());
    assert_eq!(
        file_names(&out),
        [
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
}

#[test]
fn normal_png_without_ids_is_the_full_renders() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    for (out, outputs) in [(&a, "normal"), (&b, "id,distance,normal")] {
        let o = raycast_render(&["-o", out.to_str().unwrap(), "--outputs", outputs]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let read = |dir: &std::path::Path| image::open(dir.join("normal.png")).unwrap().into_rgb8();
    let (na, nb) = (read(&a), read(&b));
    // Misses (black) and hits both present, and the same pixels.
    assert!(nb.pixels().any(|p| p.0 == [0, 0, 0]) && nb.pixels().any(|p| p.0 != [0, 0, 0]));
    assert_eq!(na, nb);
}

#[test]
fn colour_without_png_and_unknown_outputs_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    for (args, expected) in [
        (
            vec!["--outputs", "color", "--format", "npy"],
            "error: --outputs color: color is written as color.png only",
        ),
        (vec!["--outputs", "id,alpha"], "unknown output `alpha`"),
    ] {
        let mut all = vec!["-o", out.to_str().unwrap()];
        all.extend(args);
        let o = raycast_render(&all);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{stderr}");
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert!(stderr.contains(expected), "{stderr}");
        assert!(!out.exists() || file_names(&out).is_empty());
    }
}
