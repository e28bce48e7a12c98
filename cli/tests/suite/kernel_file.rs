//! `render --kernel FILE` runs the kernel in FILE: an emitted kernel fed back renders byte for
//! byte what the assembled one did; an edited one changes exactly what the edit says; a broken
//! one is an error at its line and column, and one written for another scene a one-line
//! binding error (exit code 2, nothing written).

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Output;

/// The id line of the emitted kernel, and an edit that makes every hit's id 0.
const ID_LINE: &str = "out_id[index] = select(hit.object, -1, hit.object < 0);";
const ID_ZERO: &str = "out_id[index] = select(0, -1, hit.object < 0);";
/// The normal line, and an edit that negates it.
const NORMAL_LINE: &str = "surface = vec4<real>(hit_normal(ray, hit), 0.0);";
const NORMAL_NEGATED: &str = "surface = vec4<real>(-hit_normal(ray, hit), 0.0);";

fn raycast(args: &[&str]) -> Output {
    common::raycast().args(args).output().unwrap()
}

fn ok(out: &Output) {
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Renders `scene` at 96x54 into `dir` as png and npy, with `extra` options.
fn render(scene: &Path, dir: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "render",
        s(scene),
        "--size",
        "96x54",
        "--format",
        "png,npy",
        "-o",
        s(dir),
    ];
    args.extend_from_slice(extra);
    raycast(&args)
}

/// The files of an output folder, by name.
fn files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            let name = e.file_name().into_string().unwrap();
            (name, std::fs::read(e.path()).unwrap())
        })
        .collect();
    v.sort();
    v
}

/// The data of a little-endian npy file (version 1) as values of 4 bytes.
fn npy_words(path: &Path) -> Vec<[u8; 4]> {
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(&bytes[..6], b"\x93NUMPY");
    let header = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    let text = String::from_utf8_lossy(&bytes[10..10 + header]);
    assert!(text.contains("<i4") || text.contains("<f4"), "{text}");
    bytes[10 + header..]
        .chunks(4)
        .map(|c| c.try_into().unwrap())
        .collect()
}

fn ids(dir: &Path) -> Vec<i32> {
    npy_words(&dir.join("id.npy"))
        .into_iter()
        .map(i32::from_le_bytes)
        .collect()
}

fn floats(dir: &Path, name: &str) -> Vec<f32> {
    npy_words(&dir.join(name))
        .into_iter()
        .map(f32::from_le_bytes)
        .collect()
}

/// Emits the kernel of a render of `scene` (with `extra` options), renders again with that
/// kernel, and checks that every output file is the same bytes.
fn round_trip(scene: &Path, extra: &[&str]) -> PathBuf {
    let dir = tempfile::tempdir().unwrap().keep();
    let kernel = dir.join("kernel.wgsl");
    let mut emit = vec!["--emit-shader", s(&kernel)];
    emit.extend_from_slice(extra);
    ok(&render(scene, &dir.join("a"), &emit));
    let mut feed = vec!["--kernel", s(&kernel)];
    feed.extend_from_slice(extra);
    let out = render(scene, &dir.join("b"), &feed);
    ok(&out);
    let (a, b) = (files(&dir.join("a")), files(&dir.join("b")));
    assert_eq!(
        a.len(),
        8,
        "{:?}",
        a.iter().map(|f| &f.0).collect::<Vec<_>>()
    );
    assert_eq!(a, b, "{}", scene.display());
    dir
}

#[test]
fn an_emitted_kernel_fed_back_renders_the_same_bytes() {
    let course = |name: &str| common::repo_path(&format!("scenes/course/{name}.json"));
    // Spheres and a plane by brute force; the bunny through the BVH; f64.
    round_trip(&course("sphere-and-plane"), &[]);
    let dir = round_trip(&course("bunny"), &[]);
    let kernel = std::fs::read_to_string(dir.join("kernel.wgsl")).unwrap();
    assert!(
        kernel.contains("fn traverse_bvh"),
        "the bunny's kernel has a BVH"
    );
    let dir = round_trip(&course("two-spheres-and-plane"), &["--precision", "f64"]);
    let kernel = std::fs::read_to_string(dir.join("kernel.wgsl")).unwrap();
    assert!(kernel.contains("alias real = f64;"));
}

/// Emits the kernel for `scene`, edits `from` into `to`, and renders with the original and the
/// edited kernel into DIR/a and DIR/b.
fn edited(scene: &Path, from: &str, to: &str) -> PathBuf {
    let dir = tempfile::tempdir().unwrap().keep();
    let kernel = dir.join("kernel.wgsl");
    ok(&render(
        scene,
        &dir.join("a"),
        &["--emit-shader", s(&kernel)],
    ));
    let source = std::fs::read_to_string(&kernel).unwrap();
    assert_eq!(source.matches(from).count(), 1, "{from}");
    let edit = dir.join("edited.wgsl");
    std::fs::write(&edit, source.replace(from, to)).unwrap();
    ok(&render(scene, &dir.join("b"), &["--kernel", s(&edit)]));
    dir
}

#[test]
fn an_edited_kernel_is_the_one_that_runs() {
    let scene = common::repo_path("scenes/course/two-spheres-and-plane.json");
    // Every hit's id becomes 0; misses, distances and normals stay.
    let dir = edited(&scene, ID_LINE, ID_ZERO);
    let (a, b) = (dir.join("a"), dir.join("b"));
    let (ida, idb) = (ids(&a), ids(&b));
    assert!(ida.iter().any(|&i| i > 0), "the scene has ids above 0");
    for (x, y) in ida.iter().zip(&idb) {
        assert_eq!(*y, if *x < 0 { -1 } else { 0 });
    }
    for name in ["distance.npy", "normal.npy"] {
        assert_eq!(
            std::fs::read(a.join(name)).unwrap(),
            std::fs::read(b.join(name)).unwrap()
        );
    }
    // Every normal is negated, exactly; ids and distances stay.
    let dir = edited(&scene, NORMAL_LINE, NORMAL_NEGATED);
    let (a, b) = (dir.join("a"), dir.join("b"));
    let (na, nb) = (floats(&a, "normal.npy"), floats(&b, "normal.npy"));
    assert!(na.iter().any(|&x| x != 0.0));
    for (x, y) in na.iter().zip(&nb) {
        assert_eq!(*y, -*x);
    }
    assert_eq!(ids(&a), ids(&b));
    assert_ne!(
        std::fs::read(a.join("normal.png")).unwrap(),
        std::fs::read(b.join("normal.png")).unwrap()
    );
}

#[test]
fn a_broken_kernel_is_an_error_at_its_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let scene = common::repo_path("scenes/course/sphere-and-plane.json");
    let kernel = dir.path().join("kernel.wgsl");
    ok(&render(
        &scene,
        &dir.path().join("a"),
        &["--emit-shader", s(&kernel)],
    ));
    let source = std::fs::read_to_string(&kernel).unwrap();
    let line = source.lines().position(|l| l.contains(ID_LINE)).unwrap() + 1;
    // One `)` too many at the end of the id line.
    let text = source.lines().nth(line - 1).unwrap();
    let column = text.rfind(';').unwrap() + 1;
    let broken = source.replace(ID_LINE, &ID_LINE.replace(';', ");"));
    std::fs::write(&kernel, &broken).unwrap();
    let out_dir = dir.path().join("b");
    let out = render(&scene, &out_dir, &["--kernel", s(&kernel)]);
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    let first = stderr.lines().next().unwrap();
    let at = format!("{}:{line}:{column}: error: ", kernel.display());
    assert!(first.starts_with(&at), "expected {at}\n{stderr}");
    // The source line and a caret under the column follow.
    let caret = stderr.lines().nth(2).unwrap();
    assert_eq!(caret.find('^'), Some(column - 1), "{stderr}");
    assert!(!out_dir.exists());
}

#[test]
fn a_kernel_for_another_scene_is_a_binding_error() {
    let dir = tempfile::tempdir().unwrap();
    let spheres = dir.path().join("spheres.json");
    std::fs::write(
        &spheres,
        r#"{"camera": {"eye": [0, 0, 5], "look": [0, 0, -1], "up": [0, 1, 0],
            "focal_length": 3, "width": 1.6, "height": 0.9},
            "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 0.5}]}"#,
    )
    .unwrap();
    let kernel = dir.path().join("spheres.wgsl");
    ok(&render(
        &spheres,
        &dir.path().join("a"),
        &["--emit-shader", s(&kernel)],
    ));
    let triangle = common::repo_path("scenes/course/triangle.json");
    let out_dir = dir.path().join("b");
    let out = render(&triangle, &out_dir, &["--kernel", s(&kernel)]);
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(
        stderr.starts_with(&format!("error: --kernel {}: ", kernel.display())),
        "{stderr}"
    );
    // The triangles' binding is missing (the spheres' one is extra).
    assert!(stderr.contains("@binding(3)"), "{stderr}");
    assert!(stderr.contains("--emit-shader"), "{stderr}");
    assert!(!out_dir.exists());
    // The CPU runs no kernel.
    let out = render(
        &triangle,
        &out_dir,
        &["--kernel", s(&kernel), "--device", "cpu"],
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--kernel"));
}
