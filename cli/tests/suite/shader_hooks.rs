//! User shade hooks (`render --shader`, `check-shader`): errors with the user's file, line and
//! column and exit code 2; exact properties of what the kernel hands the hook (normal, world
//! position, pixel); golden images of the examples; `--watch`.

use crate::common::{self, Kernel};

use std::path::{Path, PathBuf};
use std::process::Output;
use std::time::{Duration, Instant};

use raycast::Algorithm::{self, Robust, Textbook};
use raycast::Scene;
use raycast::ShadeHook;
use raycast::{Images, MISS, Outputs};

fn raycast(args: &[&str]) -> Output {
    common::raycast()
        .args(args)
        .output()
        .expect("the raycast binary runs")
}

fn scene_path(name: &str) -> String {
    common::repo_path(&format!("scenes/course/{name}.json"))
        .to_string_lossy()
        .into_owned()
}

/// `source` written to `name` in `dir`.
fn write(dir: &Path, name: &str, source: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, source).unwrap();
    path
}

/// A hook loaded from its text, written to a file of its own.
fn hook(source: &str) -> ShadeHook {
    let dir = tempfile::tempdir().unwrap();
    let file = write(dir.path(), "test-hook.wgsl", source);
    ShadeHook::load(&file).unwrap_or_else(|e| panic!("{e}"))
}

/// Renders only the hook's colour.
fn shaded<R: Kernel>(scene: &Scene, algorithm: Algorithm, hook: &ShadeHook) -> Vec<[u8; 4]> {
    let color = Outputs {
        id: false,
        distance: false,
        normal: false,
        color: true,
    };
    let images: Images<R> =
        common::gpu_outputs(common::gpu(), scene, algorithm, color, Some(hook)).unwrap();
    images.color.expect("a hooked render has colours")
}

// Errors.

/// A bad hook, and where its error is.
struct BadHook {
    name: &'static str,
    source: &'static str,
    line: usize,
    column: usize,
    message: &'static str,
}

const BAD_HOOKS: [BadHook; 6] = [
    // (a) A type error: an i32 where an f32 is declared; naga points at the `let`'s name.
    BadHook {
        name: "type-error.wgsl",
        source: "fn shade(hit: ShadeHit) -> vec4<f32> {\n    let k: f32 = hit.id;\n    return vec4<f32>(k);\n}\n",
        line: 2,
        column: 9,
        message: "the type of `k` is expected to be `f32`, but got `i32`",
    },
    // (b) An unknown identifier.
    BadHook {
        name: "unknown.wgsl",
        source: "// Normals as colour.\nfn shade(hit: ShadeHit) -> vec4<f32> {\n    return vec4<f32>(hit.normal, alpha);\n}\n",
        line: 3,
        column: 34,
        message: "no definition in scope for identifier: `alpha`",
    },
    // (c) A wrong hook signature: it points at the function.
    BadHook {
        name: "signature.wgsl",
        source: "// Returns RGB only.\n\nfn shade(hit: ShadeHit) -> vec3<f32> {\n    return hit.normal;\n}\n",
        line: 3,
        column: 1,
        message: "`shade` must be `fn shade(hit: ShadeHit) -> vec4<f32>`, found `fn shade(ShadeHit) -> vec3<f32>`",
    },
    // (d) Recursion, as the course writes its ray tracer: WGSL has none.
    BadHook {
        name: "recursive.wgsl",
        source: "fn shade(hit: ShadeHit) -> vec4<f32> {
    return bounce(hit, 0u);
}

fn bounce(h: ShadeHit, depth: u32) -> vec4<f32> {
    let next = trace(h.position, h.normal, 1e-4);
    return bounce(next, depth + 1u);
}
",
        line: 5,
        column: 4,
        message: "declaration of `bounce` is recursive (WGSL has no recursion: cast rays in a loop, as shaders/examples/raytrace.wgsl does)",
    },
    // (e) Rays cast from an entry point of the hook's own.
    BadHook {
        name: "entry.wgsl",
        source: "fn shade(hit: ShadeHit) -> vec4<f32> {
    return vec4<f32>(1.0);
}

@compute @workgroup_size(1)
fn launch() {
    let h = trace(vec3<f32>(0.0), vec3<f32>(1.0, 0.0, 0.0), 0.0);
}
",
        line: 7,
        column: 19,
        message: "`launch` is an entry point that casts rays (`trace` and `occluded` are for `shade` and the functions it calls): a hook file declares no @compute, @vertex or @fragment function (the kernel has its own)",
    },
    // (f) `trace` with an argument missing.
    BadHook {
        name: "trace-arguments.wgsl",
        source: "fn shade(hit: ShadeHit) -> vec4<f32> {
    let h = trace(hit.position, hit.normal);
    return vec4<f32>(h.normal, 1.0);
}
",
        line: 2,
        column: 13,
        message: "Requires 3 arguments, but 2 are provided",
    },
];

/// The failure contract: exit code 2, nothing on stdout, and on stderr exactly the block
/// `FILE:LINE:COL: error: MESSAGE`, the source line, a caret under the column.
fn assert_shader_error(output: &Output, file: &Path, bad: &BadHook) {
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(
        output.stdout.is_empty(),
        "{}",
        String::from_utf8_lossy(&output.stdout)
    );
    let lines: Vec<&str> = stderr.lines().collect();
    assert_eq!(lines.len(), 3, "{stderr}");
    let head = format!("{}:{}:{}: error: ", file.display(), bad.line, bad.column);
    assert!(
        lines[0].starts_with(&head),
        "expected `{head}...`, got:\n{stderr}"
    );
    assert!(lines[0].ends_with(bad.message), "{stderr}");
    assert_eq!(lines[1], bad.source.lines().nth(bad.line - 1).unwrap());
    assert_eq!(lines[2].find('^'), Some(bad.column - 1), "{stderr}");
}

#[test]
fn bad_hooks_fail_with_file_line_and_column_in_render_and_check_shader() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    for bad in &BAD_HOOKS {
        let file = write(dir.path(), bad.name, bad.source);
        let f = file.to_str().unwrap();
        let scene = scene_path("sphere-and-plane");
        let render = raycast(&["render", &scene, "-o", out.to_str().unwrap(), "--shader", f]);
        assert_shader_error(&render, &file, bad);
        assert!(!out.exists(), "a failed render writes nothing");
        assert_shader_error(&raycast(&["check-shader", f]), &file, bad);
    }
}

#[test]
fn a_valid_hook_passes_check_shader() {
    let dir = tempfile::tempdir().unwrap();
    for example in ["fog", "checker", "toon", "raytrace", "ambient-occlusion"] {
        let path = common::repo_path(&format!("shaders/examples/{example}.wgsl"));
        let o = raycast(&["check-shader", path.to_str().unwrap()]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert_eq!(
            String::from_utf8_lossy(&o.stdout),
            format!("{}: ok\n", path.display())
        );
    }
    // A missing file is a one-line error.
    let missing = dir.path().join("missing.wgsl");
    let o = raycast(&["check-shader", missing.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr.starts_with("error: ") && stderr.lines().count() == 1,
        "{stderr}"
    );
}

#[test]
fn shader_is_refused_where_no_kernel_runs_it() {
    let dir = tempfile::tempdir().unwrap();
    let file = common::repo_path("shaders/examples/toon.wgsl");
    let out = dir.path().join("out");
    let scene = scene_path("sphere-and-plane");
    let base = ["render", &scene, "-o", out.to_str().unwrap()];
    for (extra, expected) in [
        (
            &["--device", "cpu"][..],
            "error: --shader: the CPU reference runs no shader",
        ),
        (&["--precision", "adaptive"][..], "error: --shader: "),
        (&["--background", "0,0,0"][..], "error: --background: "),
        (&["--outputs", "id,normal"][..], "error: --shader: "),
    ] {
        let mut args = base.to_vec();
        args.extend(["--shader", file.to_str().unwrap()]);
        args.extend(extra);
        let o = raycast(&args);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {stderr}");
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert!(stderr.starts_with(expected), "{stderr}");
        assert!(!out.exists());
    }
}

// What the hook sees.

const NORMAL_AS_COLOUR: &str = "fn shade(hit: ShadeHit) -> vec4<f32> {\n    return vec4<f32>(hit.normal * 0.5 + 0.5, 1.0);\n}\n";

/// `pack4x8unorm` of a channel the hook computed as `n * 0.5 + 0.5` in f32:
/// `floor(0.5 + 255 * clamp(x, 0, 1))` (the WGSL definition).
fn level(n: f32) -> u8 {
    let x = n * 0.5 + 0.5;
    (0.5 + 255.0 * x.clamp(0.0, 1.0)).floor() as u8
}

/// Checks every pixel; returns the number of misses.
fn check_normal_as_colour<R: Kernel>(scene: &Scene, algorithm: Algorithm, name: &str) -> usize {
    let hook = hook(NORMAL_AS_COLOUR);
    let outputs = Outputs {
        id: false,
        distance: false,
        normal: true,
        color: true,
    };
    let images: Images<R> =
        common::gpu_outputs(common::gpu(), scene, algorithm, outputs, Some(&hook)).unwrap();
    let color = images.color.as_ref().unwrap();
    let mut misses = 0;
    for (k, (n, c)) in images.normal.iter().zip(color).enumerate() {
        // The hook gets the normal in f32 (rounded to nearest from an f64 kernel); a miss's is 0.
        let n = n.map(|x| x.into() as f32);
        let expected = [level(n[0]), level(n[1]), level(n[2]), 255];
        assert_eq!(*c, expected, "{name} {algorithm} pixel {k}, normal {n:?}");
        misses += usize::from(n == [0.0; 3]);
    }
    assert!(misses < color.len(), "{name}: all misses");
    misses
}

/// A hook returning the normal as colour gives exactly the colour computed on the CPU from
/// the normal image of the same render, on every pixel (both precisions and algorithms).
#[test]
fn normal_as_colour_matches_the_normal_image_exactly() {
    let mut spheres = common::course_scene("two-spheres-and-plane");
    spheres.camera.resolution = [96, 54];
    let mut bunny = common::course_scene("bunny");
    bunny.camera.resolution = [64, 36];
    for algorithm in [Textbook, Robust] {
        // Misses (the sky of two-spheres-and-plane) get the zero normal's colour.
        assert!(check_normal_as_colour::<f32>(&spheres, algorithm, "two-spheres") > 0);
        assert!(check_normal_as_colour::<f64>(&spheres, algorithm, "two-spheres") > 0);
        check_normal_as_colour::<f32>(&bunny, algorithm, "bunny");
        check_normal_as_colour::<f64>(&bunny, algorithm, "bunny");
    }
}

/// The hook's position is in world coordinates in every kernel (the robust ones work relative
/// to the eye and add it back): on a sphere far from the origin, every hit is on the sphere.
#[test]
fn hit_positions_are_in_world_coordinates() {
    let json = r#"{"camera": {"eye": [300, 200, 5], "look": [0, 0, -1], "up": [0, 1, 0],
        "focal_length": 2, "width": 1.6, "height": 1.2, "resolution": [40, 30]},
        "objects": [{"type": "sphere", "center": [300, 200, 0], "radius": 1}]}"#;
    let scene = Scene::from_json(json, Path::new("far.json"), &mut |_, _| unreachable!()).unwrap();
    // Red where |position - centre| is the radius to 1e-3 (f32 ulps at 300 are 3e-5);
    // green on every hit; transparent on a miss.
    let hook = hook(
        "fn shade(hit: ShadeHit) -> vec4<f32> {
    if (hit.id < 0) {
        return vec4<f32>(0.0);
    }
    let e = abs(distance(hit.position, vec3<f32>(300.0, 200.0, 0.0)) - 1.0);
    let on_ray = distance(hit.position, hit.origin + hit.distance * hit.direction);
    return vec4<f32>(select(0.0, 1.0, e < 1e-3), select(0.0, 1.0, on_ray < 1e-3), 0.0, 1.0);
}
",
    );
    for algorithm in [Textbook, Robust] {
        for color in [
            shaded::<f32>(&scene, algorithm, &hook),
            shaded::<f64>(&scene, algorithm, &hook),
        ] {
            let hits = color.iter().filter(|c| c[3] == 255).count();
            assert!(hits > 100, "{algorithm}: {hits} hits");
            for c in &color {
                assert!(
                    *c == [255, 255, 0, 255] || *c == [0; 4],
                    "{algorithm}: {c:?}"
                );
            }
        }
    }
}

/// `pixel`, `resolution` and `id` reach the hook exactly: pixel (column j, row i) of a 40x30
/// image gets `(j, i, 40, 30)`, and the id is the render's.
#[test]
fn pixel_resolution_and_id_reach_the_hook() {
    let mut scene = common::course_scene("two-spheres-and-plane");
    scene.camera.resolution = [40, 30];
    let hook = hook(
        "fn shade(hit: ShadeHit) -> vec4<f32> {
    return vec4<f32>(vec2<f32>(hit.pixel), vec2<f32>(hit.resolution)) / 255.0;
}
",
    );
    let color = shaded::<f32>(&scene, Robust, &hook);
    for (k, c) in color.iter().enumerate() {
        let (i, j) = (k / 40, k % 40);
        assert_eq!(*c, [j as u8, i as u8, 40, 30], "pixel {k}");
    }
    let ids = hook_ids(&scene);
    let images: Images<f32> = common::gpu_scene(common::gpu(), &scene, Robust).unwrap();
    assert_eq!(ids, images.id);
}

/// The ids the hook sees, encoded as `id + 1` in red.
fn hook_ids(scene: &Scene) -> Vec<i32> {
    let hook = hook(
        "fn shade(hit: ShadeHit) -> vec4<f32> {\n    return vec4<f32>(f32(hit.id + 1) / 255.0);\n}\n",
    );
    let ids: Vec<i32> = shaded::<f32>(scene, Robust, &hook)
        .iter()
        .map(|c| i32::from(c[0]) - 1)
        .collect();
    assert!(ids.contains(&MISS) && ids.iter().any(|&id| id >= 0));
    ids
}

// Golden images of the examples.

/// Each example on `two-spheres-and-plane` at 96x54, f32 robust, against the committed image
/// in tests/data/shaders/. Tolerance: every channel within 2 levels on all but 0.5% of the
/// pixels. On lavapipe the images are identical; other drivers may round the hooks' `exp`,
/// `normalize` or `floor` (on a checker edge) differently. `RAYCAST_BLESS=1` rewrites the
/// golden images from this machine's renders.
#[test]
fn examples_match_their_golden_images() {
    let mut scene = common::course_scene("two-spheres-and-plane");
    let [w, h] = [96, 54];
    scene.camera.resolution = [w, h];
    let bless = std::env::var_os("RAYCAST_BLESS").is_some();
    for example in ["fog", "checker", "toon"] {
        let hook = ShadeHook::load(&common::repo_path(&format!(
            "shaders/examples/{example}.wgsl"
        )))
        .unwrap_or_else(|e| panic!("{e}"));
        let actual: Vec<u8> = shaded::<f32>(&scene, Robust, &hook)
            .into_iter()
            .flatten()
            .collect();
        let golden = common::repo_path(&format!("tests/data/shaders/{example}.png"));
        if bless {
            std::fs::create_dir_all(golden.parent().unwrap()).unwrap();
            image::save_buffer(&golden, &actual, w, h, image::ExtendedColorType::Rgba8).unwrap();
            continue;
        }
        let expected = image::open(&golden)
            .unwrap_or_else(|e| panic!("{}: {e} (RAYCAST_BLESS=1 writes it)", golden.display()))
            .into_rgba8();
        assert_eq!(expected.dimensions(), (w, h), "{}", golden.display());
        let expected = expected.into_raw();
        let off = actual
            .chunks(4)
            .zip(expected.chunks(4))
            .filter(|(a, e)| a.iter().zip(*e).any(|(x, y)| x.abs_diff(*y) > 2))
            .count();
        let allowed = (w * h) as usize / 200;
        if off > allowed {
            let rgb =
                |v: &[u8]| -> Vec<u8> { v.chunks(4).flat_map(|p| [p[0], p[1], p[2]]).collect() };
            let dir = common::save_failure(example, &rgb(&actual), &rgb(&expected), w, h, 3);
            panic!(
                "{example}: {off} pixels off by more than 2 levels (at most {allowed}); pictures in {}",
                dir.display()
            );
        }
    }
}

/// The examples render through the command line too, and `--emit-shader` shows the hook in
/// the kernel.
#[test]
fn render_with_shader_writes_the_hooks_colour() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let kernel = dir.path().join("kernel.wgsl");
    let example = common::repo_path("shaders/examples/checker.wgsl");
    let o = raycast(&[
        "render",
        &scene_path("two-spheres-and-plane"),
        "--size",
        "96x54",
        "-o",
        out.to_str().unwrap(),
        "--shader",
        example.to_str().unwrap(),
        "--emit-shader",
        kernel.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let png = image::open(out.join("color.png")).unwrap().into_rgba8();
    let golden = image::open(common::repo_path("tests/data/shaders/checker.png"))
        .unwrap()
        .into_rgba8();
    let near = png
        .pixels()
        .zip(golden.pixels())
        .filter(|(a, b)| a.0.iter().zip(b.0).all(|(x, y)| x.abs_diff(y) <= 2))
        .count();
    assert!(near >= 96 * 54 * 199 / 200, "{near}");
    let kernel = std::fs::read_to_string(kernel).unwrap();
    let source = std::fs::read_to_string(example).unwrap();
    assert!(kernel.contains(&source));
    assert!(kernel.contains("fn shade_hit("));
}

// --watch.

/// Kills the child process when dropped, also when a test fails.
struct Child(std::process::Child);

impl Drop for Child {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Polls `f` every 50 ms until it returns `Some`, for at most a minute.
fn wait_for<T>(what: &str, mut f: impl FnMut() -> Option<T>) -> T {
    let start = Instant::now();
    loop {
        if let Some(x) = f() {
            return x;
        }
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "timed out waiting for {what}"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

fn solid(rgb: &str) -> String {
    format!("fn shade(hit: ShadeHit) -> vec4<f32> {{\n    return vec4<f32>({rgb}, 1.0);\n}}\n")
}

#[test]
fn watch_without_files_is_an_error() {
    let o = raycast(&["render", "--watch", "-o", "never-written"]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.starts_with("error: --watch: nothing to watch"),
        "{stderr}"
    );
    assert!(!Path::new("never-written").exists());
}

/// `render --watch` renders again when the shader changes, and keeps watching after a broken
/// shader.
#[test]
fn watch_renders_again_when_the_shader_changes() {
    let dir = tempfile::tempdir().unwrap();
    let shader = write(dir.path(), "hook.wgsl", &solid("1.0, 0.0, 0.0"));
    let out = dir.path().join("out");
    let png = out.join("color.png");
    let child = common::raycast()
        .args(["render", &scene_path("sphere-and-plane"), "--size", "16x9"])
        .args(["-o", out.to_str().unwrap(), "--outputs", "color", "--watch"])
        .args(["--shader", shader.to_str().unwrap()])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let _child = Child(child);
    let first_pixel = |want: [u8; 4]| {
        let p = image::open(&png).ok()?.into_rgba8();
        (p.get_pixel(0, 0).0 == want).then_some(())
    };
    wait_for("the first render (red)", || first_pixel([255, 0, 0, 255]));
    // A broken shader is reported and watching goes on; the picture stays.
    std::fs::write(
        &shader,
        "fn shade(hit: ShadeHit) -> vec4<f32> { return blue; }\n",
    )
    .unwrap();
    std::thread::sleep(Duration::from_millis(800));
    assert!(first_pixel([255, 0, 0, 255]).is_some());
    std::fs::write(&shader, solid("0.0, 0.0, 1.0")).unwrap();
    wait_for("the render after the fix (blue)", || {
        first_pixel([0, 0, 255, 255])
    });
}
