//! `raycast bench`: one JSON line per configuration with every key, consistent numbers, the
//! views of a dataset (`--orbit`, `--views`), and the failure contract (exit 2, one stderr line)
//! for a bad scene and `--runs 0`.

use crate::common;

use std::process::Output;

use common::repo_path;
use raycast::Algorithm;

/// Every key of a `--json` line, in order.
const KEYS: [&str; 38] = [
    "scene",
    "mode",
    "accel",
    "traversal",
    "bvh",
    "size",
    "views",
    "rays",
    "hook",
    "secondary_rays",
    "triangles",
    "spheres",
    "planes",
    "runs",
    "load_s",
    "build_s",
    "compile_s",
    "upload_s",
    "trace_s",
    "trace_gpu_s",
    "write_s",
    "wait_s",
    "convert_s",
    "copy_s",
    "readback_bytes",
    "whole_over_kernel",
    "mrays_per_s",
    "mrays_per_s_wall",
    "secondary_mrays_per_s",
    "mrays_from",
    "hit_fraction",
    "peak_rss_mb",
    "bytes_per_triangle",
    "bvh_nodes",
    "packets",
    "adapter",
    "driver",
    "cpu",
];

fn bench(args: &[&str]) -> Output {
    common::raycast()
        .arg("bench")
        .args(args)
        .output()
        .expect("the raycast binary runs")
}

/// Checks the failure contract and returns the one stderr line.
fn fails(args: &[&str]) -> String {
    let out = bench(args);
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert_eq!(out.status.code(), Some(2), "stderr:\n{stderr}");
    assert!(out.stdout.is_empty(), "nothing on stdout on failure");
    assert_eq!(stderr.lines().count(), 1, "one stderr line, got:\n{stderr}");
    stderr
}

fn number(row: &serde_json::Value, key: &str) -> f64 {
    row[key]
        .as_f64()
        .unwrap_or_else(|| panic!("{key} is a number in {row}"))
}

/// The JSON lines of a bench that succeeds.
fn rows(args: &[&str]) -> Vec<serde_json::Value> {
    let out = bench(args);
    assert!(
        out.status.success(),
        "stderr:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect()
}

/// Bytes a pixel of every output bench asks for is delivered in, in f32: the id (4), the
/// distance (4) and the normal (12); the palette's colours are made from the ids on the host.
const F32_PIXEL_BYTES: u64 = 4 + 4 + 3 * 4;

/// A GPU row's trace in parts: the bytes read back are those of `pixels` pixels of every
/// output; the inputs written, the wait and the conversion are parts of the trace; the whole
/// trace over the kernel is the ratio of the two.
fn assert_trace_parts(row: &serde_json::Value, pixels: u64) {
    assert_eq!(row["readback_bytes"], pixels * F32_PIXEL_BYTES, "{row}");
    let parts: f64 = ["write_s", "wait_s", "convert_s"]
        .iter()
        .map(|key| {
            let s = number(row, key);
            assert!(s >= 0.0, "{key} in {row}");
            s
        })
        .sum();
    let trace_s = number(row, "trace_s");
    assert!(
        parts <= trace_s * (1.0 + 1e-9),
        "{parts} > trace_s in {row}"
    );
    assert!(
        row["copy_s"].is_null() || number(row, "copy_s") >= 0.0,
        "{row}"
    );
    let ratio = trace_s / number(row, "trace_gpu_s");
    assert!(
        (number(row, "whole_over_kernel") - ratio).abs() <= 1e-9 * ratio,
        "{row}"
    );
}

#[test]
fn json_lines_per_configuration_with_consistent_numbers() {
    let scene_path = repo_path("scenes/course/bunny.json");
    let scene_arg = scene_path.to_str().unwrap();
    let out = bench(&[
        scene_arg,
        "--size",
        "64x36",
        "--runs",
        "2",
        "--json",
        "--accel",
        "bvh,brute-force",
    ]);
    let stdout = String::from_utf8(out.stdout).unwrap();
    assert!(
        out.status.success(),
        "stderr:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows: Vec<serde_json::Value> = stdout
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect();
    assert_eq!(rows.len(), 2, "one line per configuration:\n{stdout}");

    let scene = raycast::Scene::load(&scene_path).unwrap();
    // The tree as the CPU reference builds it for the same scene, through the API.
    let options = raycast::RenderOptions {
        algorithm: Algorithm::Robust,
        timed: true,
        tuning: raycast::Tuning {
            search: raycast::Search::Bvh,
            ..raycast::Tuning::default()
        },
        ..raycast::RenderOptions::default()
    };
    let cpu = raycast::Cpu.render(&scene, &options).unwrap();
    let nodes = cpu.stages().unwrap().bvh_nodes.unwrap();
    for (row, accel) in rows.iter().zip(["bvh", "brute-force"]) {
        let keys: Vec<&str> = row
            .as_object()
            .unwrap()
            .keys()
            .map(|k| k.as_str())
            .collect();
        assert_eq!(keys, KEYS, "keys in order");
        assert_eq!(row["scene"], scene_arg);
        assert_eq!(row["mode"], "gpu:f32:robust");
        assert_eq!(row["accel"], accel);
        assert_eq!(row["bvh"], accel == "bvh");
        assert_eq!(row["size"], serde_json::json!([64, 36]));
        assert_eq!(row["views"], 1);
        assert_eq!(row["rays"], 64 * 36);
        assert_eq!(row["runs"], 2);
        assert_eq!(row["triangles"], 1000);
        assert_eq!(row["spheres"], 0);
        for key in ["load_s", "build_s", "compile_s", "upload_s", "trace_s"] {
            assert!(number(row, key) > 0.0, "{key} > 0 in {row}");
        }
        // lavapipe has timestamp queries.
        let gpu_s = number(row, "trace_gpu_s");
        assert!(gpu_s > 0.0);
        assert_eq!(row["mrays_from"], "gpu_timestamps");
        assert_trace_parts(row, 64 * 36);
        let rays = (64 * 36) as f64;
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b;
        assert!(close(number(row, "mrays_per_s"), rays / gpu_s * 1e-6));
        assert!(close(
            number(row, "mrays_per_s_wall"),
            rays / number(row, "trace_s") * 1e-6
        ));
        let hit = number(row, "hit_fraction");
        assert!(hit > 0.0 && hit <= 1.0);
        assert!(number(row, "peak_rss_mb") > 1.0);
        assert!(!row["adapter"].as_str().unwrap().is_empty());
        assert!(!row["driver"].as_str().unwrap().is_empty());
        for key in ["hook", "secondary_rays", "secondary_mrays_per_s"] {
            assert!(row[key].is_null(), "no hook, no {key}: {row}");
        }

        // The documented formula: (T * 40 + 4 * (S + P + T) + BVH bytes) / T in f32 on the GPU.
        let (t, s, p) = (1000.0, 0.0, number(row, "planes"));
        let bvh_bytes = if accel == "bvh" {
            assert_eq!(row["bvh_nodes"], nodes);
            // lavapipe's choice at 2.3 rays a triangle: packets.
            assert_eq!(row["packets"], true, "{row}");
            64.0 * nodes as f64 + 4.0 * (s + t)
        } else {
            assert!(row["bvh_nodes"].is_null());
            assert!(row["packets"].is_null(), "{row}");
            0.0
        };
        let expected = (t * 40.0 + 4.0 * (s + p + t) + bvh_bytes) / t;
        assert!(close(number(row, "bytes_per_triangle"), expected), "{row}");
    }
    let load: Vec<f64> = rows.iter().map(|r| number(r, "load_s")).collect();
    assert_eq!(load[0], load[1], "the scene is loaded once");
}

/// With the course's ray tracer every frame casts secondary rays, reported over the frame's
/// time; the GPU and the CPU mirror count the same rays.
#[test]
fn a_lit_frame_reports_its_secondary_rays() {
    let scene = repo_path("scenes/ray-tracing/sphere-packing.json");
    let out = bench(&[
        scene.to_str().unwrap(),
        "--size",
        "64x36",
        "--runs",
        "1",
        "--json",
        "--lit",
        "--mode",
        "gpu:f32,cpu:f32",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let stdout = String::from_utf8(out.stdout).unwrap();
    let rows: Vec<serde_json::Value> = stdout
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(rows.len(), 2);
    for row in &rows {
        assert_eq!(row["hook"], "shaders/examples/raytrace.wgsl", "{row}");
        let secondary = number(row, "secondary_rays");
        // At least a shadow ray to each of its two lights from every pixel: the plane fills
        // the background.
        assert!(secondary >= 2.0 * 64.0 * 36.0, "{row}");
        let seconds = match row["mrays_from"].as_str() {
            Some("gpu_timestamps") => number(row, "trace_gpu_s"),
            _ => number(row, "trace_s"),
        };
        let expected = secondary / seconds * 1e-6;
        let got = number(row, "secondary_mrays_per_s");
        assert!((got - expected).abs() <= 1e-9 * expected, "{row}");
    }
    let counts: Vec<f64> = rows.iter().map(|r| number(r, "secondary_rays")).collect();
    assert!(
        (counts[0] - counts[1]).abs() <= 1e-4 * counts[1],
        "{counts:?}"
    );
}

#[test]
fn a_cpu_mode_has_no_upload_nor_gpu_time() {
    let scene = repo_path("scenes/course/sphere-packing.json");
    let out = bench(&[
        scene.to_str().unwrap(),
        "--size",
        "32x18",
        "--runs",
        "1",
        "--json",
        "--mode",
        "cpu:f64",
    ]);
    assert!(out.status.success());
    let stdout = String::from_utf8(out.stdout).unwrap();
    let row: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert_eq!(row["mode"], "cpu:f64:robust");
    let gpu_only = [
        "upload_s",
        "compile_s",
        "trace_gpu_s",
        "write_s",
        "wait_s",
        "convert_s",
        "copy_s",
        "readback_bytes",
        "whole_over_kernel",
        "adapter",
        "driver",
    ];
    for key in gpu_only {
        assert!(row[key].is_null(), "{key} is null on the CPU: {row}");
    }
    assert_eq!(row["mrays_from"], "wall");
    assert_eq!(row["mrays_per_s"], row["mrays_per_s_wall"]);
    assert!(number(&row, "trace_s") > 0.0);
}

#[test]
fn the_table_names_the_adapter_and_each_configuration() {
    let scene = repo_path("scenes/course/bunny.json");
    let out = bench(&[scene.to_str().unwrap(), "--size", "32x18", "--runs", "1"]);
    assert!(out.status.success());
    let stdout = String::from_utf8(out.stdout).unwrap();
    assert!(stdout.starts_with("adapter: "), "{stdout}");
    assert!(stdout.contains(", driver: "), "{stdout}");
    let rows: Vec<&str> = stdout.lines().filter(|l| l.starts_with("| gpu:")).collect();
    assert_eq!(rows.len(), 1, "{stdout}");
    assert!(rows[0].contains("auto (bvh)"), "{stdout}");
    // Under the table, the parts of the GPU row's trace and the bytes it read back.
    let bytes = (32 * 18 * F32_PIXEL_BYTES) as f64 * 1e-6;
    let stages = format!(
        "; {} MB read back",
        raycast_cli::study::format_seconds(bytes)
    );
    let line = stdout.lines().last().unwrap();
    assert!(line.starts_with("gpu:f32:robust auto: trace "), "{stdout}");
    assert!(
        line.contains(", of it write ") && line.ends_with(&stages),
        "{stdout}"
    );
}

#[test]
fn a_bad_scene_path_exits_2_with_one_line() {
    let line = fails(&["no/such/scene.json", "--json"]);
    assert!(line.starts_with("error: "), "{line}");
    assert!(line.contains("no/such/scene.json"), "{line}");
}

#[test]
fn zero_runs_are_rejected() {
    let scene = repo_path("scenes/course/bunny.json");
    let line = fails(&[scene.to_str().unwrap(), "--runs", "0"]);
    assert!(line.contains("--runs"), "{line}");
}

#[test]
fn adaptive_precision_is_rejected() {
    let scene = repo_path("scenes/course/bunny.json");
    let line = fails(&[scene.to_str().unwrap(), "--mode", "gpu:adaptive"]);
    assert!(line.starts_with("error: --mode: "), "{line}");
}

/// `--rays N`: N incoherent rays cast as a list, on the GPU and the CPU, each row's hits those
/// of the same rays cast here.
#[test]
fn incoherent_rays_are_cast_as_a_list() {
    let path = repo_path("scenes/course/bunny.json");
    let out = bench(&[
        path.to_str().unwrap(),
        "--rays",
        "5000",
        "--runs",
        "1",
        "--json",
        "--mode",
        "gpu:f32,cpu:f64",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows: Vec<serde_json::Value> = String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let scene = raycast::Scene::load(&path).unwrap();
    let rays = raycast_cli::study::bench::incoherent_rays(&scene, 5000);
    let lists = common::Target::from_scene(scene);
    let hits = lists
        .cast(None, "cpu:f64".parse().unwrap(), &rays[..])
        .unwrap();
    let hit = hits.id().iter().filter(|&&id| id >= 0).count() as f64 / 5000.0;
    assert!(hit > 0.1, "the rays see the room: {hit}");
    assert_eq!(rows.len(), 2);
    for row in &rows {
        assert_eq!(row["rays"], 5000);
        assert_eq!(row["size"], serde_json::json!([5000, 1]));
        // The API gives a ray list's kernel time (a timed Accel), not its other stages.
        for key in ["views", "write_s", "readback_bytes"] {
            assert!(row[key].is_null(), "{key} in {row}");
        }
        match row["mode"].as_str() {
            Some("gpu:f32:robust") => {
                assert_eq!(row["mrays_from"], "gpu_timestamps", "{row}");
                let kernel = number(row, "trace_gpu_s");
                assert!(kernel > 0.0 && kernel <= number(row, "trace_s"), "{row}");
            }
            _ => {
                assert_eq!(row["mrays_from"], "wall", "{row}");
                assert!(row["trace_gpu_s"].is_null(), "{row}");
            }
        }
        assert_eq!(number(row, "hit_fraction"), hit, "{}", row["mode"]);
    }
}

#[test]
fn ray_lists_refuse_hooks_accelerations_and_counts_out_of_range() {
    let scene = repo_path("scenes/course/bunny.json");
    let scene = scene.to_str().unwrap();
    for extra in [
        &["--rays", "10", "--lit"][..],
        &["--rays", "10", "--accel", "bvh"][..],
    ] {
        let line = fails(&[&[scene][..], extra].concat());
        assert!(line.starts_with("error: --rays: "), "{extra:?}: {line}");
    }
    for n in ["0", "-3", "67108865"] {
        let line = fails(&[scene, "--rays", n]);
        assert!(
            line.starts_with(&format!("error: invalid value '{n}' for '--rays")),
            "{line}"
        );
    }
}

/// bench renders frames whole: a size beyond what a render would stream in bands is refused
/// before anything is printed, rather than run out of memory.
#[test]
fn frames_too_large_to_render_whole_are_refused() {
    let scene = repo_path("scenes/course/bunny.json");
    let line = fails(&[scene.to_str().unwrap(), "--size", "8192x4097"]);
    assert!(line.starts_with("error: --size: 8192x4097: "), "{line}");
}

/// `raycast workload --help` and the command list name every workload `workload` writes.
#[test]
fn the_workload_help_names_every_workload() {
    let help = |args: &[&str]| {
        let out = common::raycast().args(args).output().unwrap();
        assert!(out.status.success());
        String::from_utf8(out.stdout).unwrap()
    };
    let (command, list) = (help(&["workload", "--help"]), help(&["help"]));
    let line = list
        .lines()
        .find(|l| l.trim_start().starts_with("workload "));
    for (name, _) in raycast_cli::study::workload::WORKLOADS {
        assert!(command.contains(&format!("{name}: ")), "{name}: {command}");
        assert!(line.is_some_and(|l| l.contains(name)), "{name}: {list}");
    }
}

/// `raycast workload`: the peers' torus (its size by `--triangles`) and spheres as scene files
/// that load, with the peers' camera; an unknown name writes nothing.
#[test]
fn workloads_are_scene_files() {
    let dir = tempfile::tempdir().unwrap();
    let workload = |args: &[&str]| {
        common::raycast()
            .arg("workload")
            .args(args)
            .arg("-o")
            .arg(dir.path())
            .output()
            .unwrap()
    };
    for args in [
        &["torus", "--triangles", "5000", "--size", "64x36"][..],
        &["spheres"],
        &["lit-bunny"],
    ] {
        let out = workload(args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let torus = raycast::Scene::load(&dir.path().join("torus.json")).unwrap();
    let [nu, nv] = raycast_cli::study::workload::torus_grid(5000);
    assert_eq!(torus.primitive_counts()[2], 2 * nu * nv);
    assert_eq!(torus.camera.resolution, [64, 36]);
    let spheres = raycast::Scene::load(&dir.path().join("spheres.json")).unwrap();
    assert_eq!(spheres.primitive_counts(), [100, 0, 0]);
    assert_eq!(spheres.camera.resolution, [1920, 1080]);
    let lit = raycast::Scene::load(&dir.path().join("bunny.json")).unwrap();
    assert_eq!(
        lit,
        raycast::Scene::load(&repo_path("scenes/ray-tracing/bunny.json")).unwrap()
    );

    let empty = tempfile::tempdir().unwrap();
    let out = common::raycast()
        .args(["workload", "cube", "-o"])
        .arg(empty.path())
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(String::from_utf8_lossy(&out.stderr).lines().count(), 1);
    assert_eq!(common::file_names(empty.path()), Vec::<String>::new());
}

/// `--orbit N`: a run renders the N views `raycast render --orbit N` renders, each of them
/// once: the rays and the bytes read back are the views', the hits those of the views' renders.
#[test]
fn an_orbit_run_renders_the_views_render_renders() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = repo_path("scenes/bunny.stl");
    let mesh = mesh.to_str().unwrap();
    let (views, pixels) = (3, 32 * 18);
    let render = common::raycast()
        .args([
            "render", mesh, "--orbit", "3", "--size", "32x18", "--device", "cpu",
        ])
        .args(["--precision", "f32", "--format", "npy", "-o"])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(
        render.status.success(),
        "{}",
        String::from_utf8_lossy(&render.stderr)
    );
    let hits: usize = (0..views)
        .map(|k| dir.path().join(format!("bunny/orbit-{k:03}")))
        .map(|view| crate::mesh_files::id_npy(&view))
        .map(|ids| ids.iter().filter(|&&id| id >= 0).count())
        .sum();
    assert!(hits > 0);

    let rows = rows(&[
        mesh,
        "--orbit",
        "3",
        "--size",
        "32x18",
        "--runs",
        "1",
        "--json",
        "--mode",
        "gpu:f32,cpu:f32",
    ]);
    assert_eq!(rows.len(), 2);
    for row in &rows {
        assert_eq!(row["views"], views);
        assert_eq!(row["size"], serde_json::json!([32, 18]));
        assert_eq!(row["rays"], views * pixels);
    }
    assert_trace_parts(&rows[0], views * pixels);
    // The count (JSON's decimal fraction is read back to within an ulp).
    let rays = (views * pixels) as f64;
    let counted = number(&rows[1], "hit_fraction") * rays;
    assert_eq!(counted.round() as usize, hits, "{counted}");
}

/// `--views FILE`: a run renders the file's cameras, which a row needs of one size: `--size`
/// gives them one. `--orbit-radius` goes with `--orbit`.
#[test]
fn a_views_file_is_benched_at_one_size() {
    let dir = tempfile::tempdir().unwrap();
    let cameras = serde_json::json!([
        {"name": "side", "eye": [2.5, 0.5, 0.3], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 50},
        {"name": "pinhole", "eye": [0, 0, 2.2], "look": [0, 0, -1], "up": [0, 1, 0],
         "intrinsics": {"fx": 100, "fy": 100, "cx": 47.5, "cy": 26.5}, "resolution": [96, 54]}
    ]);
    let views = dir.path().join("views.json");
    std::fs::write(&views, cameras.to_string()).unwrap();
    let scene = repo_path("scenes/course/bunny.json");
    let args = [scene.to_str().unwrap(), "--views", views.to_str().unwrap()];
    let cpu = ["--runs", "1", "--json", "--mode", "cpu:f32"];
    let line = fails(&[&args[..], &cpu].concat());
    assert!(
        line.starts_with("error: --views: the views are of different sizes ("),
        "{line}"
    );
    let rows = rows(&[&args[..], &cpu, &["--size", "24x16"]].concat());
    assert_eq!(rows[0]["views"], 2);
    assert_eq!(rows[0]["rays"], 2 * 24 * 16);

    let line = fails(&[scene.to_str().unwrap(), "--orbit-radius", "3"]);
    assert!(line.starts_with("error: --orbit-radius: "), "{line}");
}
