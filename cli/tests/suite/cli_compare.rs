//! `raycast compare` end to end: a planted difference of known size is counted exactly, the
//! mismatch picture marks exactly those pixels, and `--fail-above` gates on the bound.

use crate::common;

use std::path::Path;
use std::process::Output;

const CAMERA: &str = r#""camera": {"type": "orthographic", "eye": [0, 0, 5], "look": [0, 0, -1],
    "up": [0, 1, 0], "focal_length": 1, "width": 4, "height": 3, "resolution": [40, 30]}"#;

/// A sphere on an empty background; the "planted" scene adds a square (two triangles) at
/// x in [-0.6, -0.2], y in [0.1, 0.4]. Pixel centres are at x = -1.95 + 0.1 j and
/// y = 1.45 - 0.1 i, so the square covers exactly 4 x 3 = 12 of them, none near its edges or
/// its diagonal, all on background.
fn write_scenes(dir: &Path) -> (std::path::PathBuf, std::path::PathBuf) {
    let sphere = r#"{"type": "sphere", "center": [1, -0.5, 0], "radius": 0.6}"#;
    let square = r#"{"type": "triangle", "corners": [[-0.6, 0.1, 0], [-0.2, 0.1, 0], [-0.2, 0.4, 0]]},
        {"type": "triangle", "corners": [[-0.6, 0.1, 0], [-0.2, 0.4, 0], [-0.6, 0.4, 0]]}"#;
    let a = dir.join("a.json");
    let b = dir.join("b.json");
    std::fs::write(&a, format!(r#"{{{CAMERA}, "objects": [{sphere}]}}"#)).unwrap();
    std::fs::write(
        &b,
        format!(r#"{{{CAMERA}, "objects": [{sphere}, {square}]}}"#),
    )
    .unwrap();
    (a, b)
}

/// The planted square's pixels, (x, y), row by row.
fn square_pixels() -> Vec<(u32, u32)> {
    (11..14)
        .flat_map(|y| (14..18).map(move |x| (x, y)))
        .collect()
}

/// The pixels (x, y), row by row, of the 40x30 render drawn `top` rows down `picture` whose
/// colour `is` picks.
fn marked(picture: &image::RgbImage, top: u32, is: impl Fn([u8; 3]) -> bool) -> Vec<(u32, u32)> {
    (0..30)
        .flat_map(|y| (0..40).map(move |x| (x, y)))
        .filter(|&(x, y)| is(picture.get_pixel(x, y + top).0))
        .collect()
}

/// `raycast compare A --b-scene B --a MODE_A --b MODE_B EXTRA...`.
fn compare(a: &Path, b: &Path, [mode_a, mode_b]: [&str; 2], extra: &[&str]) -> Output {
    let mut args = vec![
        "compare",
        a.to_str().unwrap(),
        "--b-scene",
        b.to_str().unwrap(),
        "--a",
        mode_a,
        "--b",
        mode_b,
    ];
    args.extend(extra);
    raycast(&args)
}

fn raycast(args: &[&str]) -> Output {
    common::raycast().args(args).output().unwrap()
}

fn report(out: &Output) -> serde_json::Value {
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "stdout is not JSON ({e}): {}",
            String::from_utf8_lossy(&out.stdout)
        )
    })
}

#[test]
fn planted_square_is_counted_exactly_and_drawn() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = write_scenes(dir.path());
    let pics = dir.path().join("pics");
    let out = compare(
        &a,
        &b,
        ["gpu:f32", "cpu:f64"],
        &["-o", pics.to_str().unwrap()],
    );
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let r = report(&out);
    assert_eq!(r["pixels"], 1200);
    assert_eq!(r["hit_mismatch"], 12);
    assert_eq!(r["id_mismatch"], 0);
    assert_eq!(r["a"]["mode"], "gpu:f32:robust");
    assert_eq!(r["b"]["mode"], "cpu:f64:robust");
    assert!(r["a"]["time_s"].as_f64().unwrap() > 0.0);
    // The sphere: f32 against f64, tiny but non-zero errors.
    let rel = r["distance"]["rel_max"].as_f64().unwrap();
    assert!(rel > 0.0 && rel < 1e-5, "{rel}");

    let mask = image::open(pics.join("mismatch.png")).unwrap().into_rgb8();
    let magenta = marked(&mask, 0, |p| p == [255, 0, 255]);
    assert_eq!(magenta, square_pixels());
    assert!(pics.join("distance_error.png").exists());
}

#[test]
fn fail_above_exits_1_exactly_when_a_bound_is_crossed() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = write_scenes(dir.path());
    let run = |bound: &str| compare(&a, &b, ["cpu:f64", "cpu:f64"], &["--fail-above", bound]);
    assert_eq!(run("hit_mismatch=12").status.code(), Some(0));
    let crossed = run("hit_mismatch=11");
    assert_eq!(crossed.status.code(), Some(1));
    assert_eq!(
        report(&crossed)["hit_mismatch"],
        12,
        "the report is still printed"
    );
    assert!(String::from_utf8_lossy(&crossed.stderr).contains("hit_mismatch = 12 > 11"));
    // Identical modes on the common pixels: zero error, so a zero bound holds...
    assert_eq!(
        run("distance.rel_max=0,id_mismatch=0").status.code(),
        Some(0)
    );
    // ...and one crossed bound among several is enough.
    assert_eq!(run("id_mismatch=0,hit_mismatch=5").status.code(), Some(1));
    let unknown = run("speed=1");
    assert_eq!(unknown.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&unknown.stderr).contains("unknown metric `speed`"));
}

/// With a hook on both sides their `color.png`s are compared too: the planted square, red on
/// black, is 12 pixels 255 levels off in red only, and `color_error.png` marks exactly them.
/// Without a hook there is nothing to compare (`color` is null).
#[test]
fn colours_are_compared_when_a_hook_colours_both_sides() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = write_scenes(dir.path());
    let hook = dir.path().join("ids.wgsl");
    std::fs::write(
        &hook,
        "fn shade(hit: ShadeHit) -> vec4<f32> {\n\
         \x20   if (hit.id < 0) { return vec4<f32>(0.0, 0.0, 0.0, 1.0); }\n\
         \x20   if (hit.id == 0) { return vec4<f32>(1.0); }\n\
         \x20   return vec4<f32>(1.0, 0.0, 0.0, 1.0);\n\
         }\n",
    )
    .unwrap();
    let pics = dir.path().join("pics");
    let run = |extra: &[&str]| compare(&a, &b, ["gpu:f32", "gpu:f64"], extra);
    let out = run(&[
        "--shader",
        hook.to_str().unwrap(),
        "-o",
        pics.to_str().unwrap(),
        "--fail-above",
        "color.max=255,color.beyond_2=0.01",
    ]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let c = &report(&out)["color"];
    assert_eq!(c["max"], 255, "{c}");
    assert_eq!(c["beyond_2"].as_f64().unwrap(), 12.0 / 1200.0, "{c}");
    assert_eq!(c["exact"].as_f64().unwrap(), 1188.0 / 1200.0, "{c}");
    assert_eq!(
        c["mean_abs"].as_f64().unwrap(),
        12.0 * 255.0 / 3600.0,
        "{c}"
    );
    let picture = image::open(pics.join("color_error.png"))
        .unwrap()
        .into_rgb8();
    // Below a title line, equal pixels in grey.
    let grey = picture.get_pixel(0, 14).0;
    assert_eq!(marked(&picture, 14, |p| p != grey), square_pixels());
    // A bound on a colour metric gates like any other.
    assert_eq!(
        run(&[
            "--shader",
            hook.to_str().unwrap(),
            "--fail-above",
            "color.max=254"
        ])
        .status
        .code(),
        Some(1)
    );
    assert!(report(&run(&[]))["color"].is_null());
}

/// Without `--a` and `--b`, the renders `raycast render` makes by default on each device:
/// adaptive on the GPU (whose hits and ids are f64's), f32 there with a hook, f64 on the CPU.
#[test]
fn the_default_sides_are_renders_defaults() {
    let dir = tempfile::tempdir().unwrap();
    let (a, _) = write_scenes(dir.path());
    let plain = raycast(&["compare", a.to_str().unwrap()]);
    assert_eq!(
        plain.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&plain.stderr)
    );
    let r = report(&plain);
    assert_eq!(r["a"]["mode"], "gpu:adaptive:robust");
    assert_eq!(r["b"]["mode"], "cpu:f64:robust");
    assert_eq!(
        (r["hit_mismatch"].as_u64(), r["id_mismatch"].as_u64()),
        (Some(0), Some(0))
    );
    let lit = raycast(&["compare", a.to_str().unwrap(), "--lit"]);
    assert_eq!(
        lit.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&lit.stderr)
    );
    assert_eq!(report(&lit)["a"]["mode"], "gpu:f32:robust");
}

/// `compare`, `bench`, `accuracy` and `tradeoff` take mesh files as `render` does, and their
/// help says so.
#[test]
fn the_scene_arguments_take_meshes_as_their_help_says() {
    for command in [
        "compare", "bench", "accuracy", "tradeoff", "render", "serve",
    ] {
        let help = raycast(&[command, "--help"]);
        let help = String::from_utf8_lossy(&help.stdout);
        assert!(
            help.contains("or a mesh file (.obj, .stl, .ply)"),
            "{command}: {help}"
        );
    }
    let mesh = common::repo_path("scenes/bunny.stl");
    let mesh = mesh.to_str().unwrap();
    let size = ["--size", "16x9"];
    let out = raycast(
        &[
            &["compare", mesh, "--a", "cpu:f32", "--b", "cpu:f64"],
            &size[..],
        ]
        .concat(),
    );
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(report(&out)["pixels"], 144);
    let bench = ["bench", mesh, "--mode", "cpu:f32", "--runs", "1", "--json"];
    let out = raycast(&[&bench[..], &size[..]].concat());
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
