//! scripts/gpu-check.sh end to end on lavapipe, as on a GPU machine without a Rust toolchain:
//! the script packs itself, the stripped binary and the Vulkan loader into an empty folder,
//! and runs from there (`--quick` sizes), writing report.md and report.json. Where the cost
//! model was built beside the binary (`cargo build -p raycast-benches`, not in CI), the kit
//! brings it and the report sets its predictions for the H200 beside the measurements.

use crate::common;

use std::process::Command;

#[test]
fn gpu_check_runs_from_a_packed_folder() {
    let dir = tempfile::tempdir().unwrap();
    let kit = dir.path().join("kit");
    let pack = Command::new("bash")
        .arg(common::repo_path("scripts/gpu-check.sh"))
        .args(["--pack"])
        .arg(&kit)
        .arg(env!("CARGO_BIN_EXE_raycast"))
        .output()
        .unwrap();
    assert!(
        pack.status.success(),
        "{}",
        String::from_utf8_lossy(&pack.stderr)
    );
    let model = std::path::Path::new(env!("CARGO_BIN_EXE_raycast"))
        .with_file_name("gpu_model")
        .exists();
    let mut kit_files = vec!["commit", "gpu-check.sh", "lib", "raycast"];
    if model {
        kit_files.insert(2, "gpu_model");
    }
    assert_eq!(common::file_names(&kit), kit_files);
    let size = |p: &std::path::Path| std::fs::metadata(p).unwrap().len();
    assert!(size(&kit.join("raycast")) < size(env!("CARGO_BIN_EXE_raycast").as_ref()));

    let out = dir.path().join("report");
    let run = Command::new(kit.join("gpu-check.sh"))
        .env("GPU_MODEL_DEVICE", "h200")
        .args(["--quick", "--out"])
        .arg(&out)
        .arg(kit.join("raycast"))
        .current_dir(dir.path())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(
        stdout.contains(" 0 failed, ") && stdout.contains("failed steps: none"),
        "{stdout}"
    );

    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    for (step, result) in report["steps"].as_object().unwrap() {
        assert_eq!(result["exit"], 0, "{step}");
    }
    // What the kit was packed from: this checkout's commit.
    let head = Command::new("git")
        .args(["rev-parse", "--short=12", "HEAD"])
        .current_dir(common::repo_path(""))
        .output()
        .unwrap();
    let head = String::from_utf8_lossy(&head.stdout).trim().to_owned();
    assert!(
        report["commit"].as_str().unwrap().starts_with(&head),
        "{head}"
    );
    assert!(report["device"].as_str().unwrap().contains("llvmpipe"));
    // `raycast info` as the kit kept it: lavapipe offers ray queries (#65) and packets.
    let info: Vec<&str> = (report["info"].as_array().unwrap().iter())
        .map(|l| l.as_str().unwrap())
        .collect();
    for line in [
        "ray queries:  yes",
        "subgroups:    8 to 8 invocations; packet traversal: yes",
    ] {
        assert!(info.iter().any(|l| l.starts_with(line)), "{line}: {info:?}");
    }
    let workloads = report["workloads"].as_array().unwrap();
    let per_ray = |w: &&serde_json::Value| w["traversal"] == "per-ray";
    assert_eq!(workloads.iter().filter(per_ray).count(), 6, "{workloads:?}");
    let bench = &report["bench"];
    let torus = bench["torus"].as_array().unwrap();
    // Each mode by both traversals (lavapipe's subgroups hold packets), which see the same.
    let configs: Vec<String> = (torus.iter())
        .map(|r| format!("{} {}", r["mode"].as_str().unwrap(), r["traversal"]))
        .collect();
    assert_eq!(
        configs,
        [
            "gpu:f32:robust \"packets\"",
            "gpu:f32:robust \"per-ray\"",
            "gpu:f64:robust \"packets\"",
            "gpu:f64:robust \"per-ray\""
        ]
    );
    for name in ["torus", "big", "big-small", "spheres", "lit"] {
        let rows = bench[name].as_array().unwrap();
        for pair in rows.chunks(2) {
            assert_eq!(pair[0]["hit_fraction"], pair[1]["hit_fraction"], "{name}");
        }
    }
    for r in torus {
        // The traversal asked for is the one the kernel took.
        assert_eq!(r["packets"], r["traversal"] == "packets", "{r}");
        assert_eq!(r["triangles"], 518_400);
        assert_eq!(r["rays"], 640 * 360);
        assert!(r["whole_over_kernel"].as_f64().unwrap() >= 1.0, "{r}");
        // The peers' torus, seen by their camera, covers 34.5% of the picture.
        let hit = r["hit_fraction"].as_f64().unwrap();
        assert!((hit - 0.345).abs() < 0.002, "{hit}");
    }
    assert_eq!(bench["big"][0]["triangles"], 200_704);
    assert_eq!(bench["big-small"][0]["rays"], 160 * 90);
    assert_eq!(bench["spheres"][0]["spheres"], 100);
    assert_eq!(bench["incoherent"][0]["rays"], 100_000);
    assert!(bench["lit"][0]["secondary_rays"].as_u64().unwrap() > 0);
    // The f32 bytes of the id, distance and normal bench asks for, read back whole.
    assert_eq!(torus[0]["readback_bytes"], 640 * 360 * (4 + 4 + 12));
    // The kernel's rate on the dataset's own views: each of the 10 once a run.
    let orbit = &bench["views"][0];
    assert_eq!(orbit["views"], 10);
    assert_eq!(orbit["rays"], 10 * 640 * 360);
    let views = &report["views"];
    assert_eq!(views["views"], 10);
    for ratio in ["loop_over_batch", "batch_over_kernel"] {
        assert!(views[ratio].as_f64().unwrap() > 0.0, "{ratio}");
    }
    for cost in ["f64_over_f32_kernel", "adaptive_over_f32_render"] {
        assert!(report["cost"][cost].as_f64().unwrap() > 0.0, "{cost}");
    }
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    for part in [
        "## raycast info",
        "## raycast selftest",
        "## Benchmarks",
        "lit course bunny",
        "Dataset (lit bunny, 640x360): 10 views",
        "## Stages of the whole cast",
    ] {
        assert!(md.contains(part), "report.md lacks {part}");
    }
    // The model's prediction beside each workload it replays: camera casts by both
    // traversals, the incoherent list per ray; none for the lit bunny (a hook's rays).
    let predicted = |w: &&serde_json::Value| w["predicted_ms"].as_f64().is_some_and(|p| p > 0.0);
    let predictions = workloads.iter().filter(predicted).count();
    assert_eq!(predictions, if model { 11 } else { 0 }, "{workloads:?}");
    assert_eq!(md.contains("## The cost model against the kernel"), model);
}
