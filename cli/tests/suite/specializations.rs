//! `raycast specializations`: one row per specialization and scene, times where they apply and
//! the reason where not, the same markdown printed and written with `-o`, nothing written
//! without it, a missing torus noted; bad input is a one-line error with exit code 2 and writes
//! nothing.

use crate::common;

use std::process::Output;

fn raycast(args: &[&str], cwd: &std::path::Path) -> Output {
    common::raycast()
        .current_dir(cwd)
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn every_specialization_is_measured_or_says_why_not() {
    // Run from an empty folder: the default torus path does not exist there.
    let dir = tempfile::tempdir().unwrap();
    let scenes = ["triangle", "sphere-packing"]
        .map(|n| common::repo_path(&format!("scenes/course/{n}.json")));
    let out_file = dir.path().join("docs/spec.md");
    let out = raycast(
        &[
            "specializations",
            "--scenes",
            scenes[0].to_str().unwrap(),
            scenes[1].to_str().unwrap(),
            "--runs",
            "1",
            "--no-crossover",
            "-o",
            out_file.to_str().unwrap(),
        ],
        dir.path(),
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let written = std::fs::read_to_string(&out_file).unwrap();
    assert_eq!(written.trim_end(), stdout.trim_end());
    assert!(
        written.contains("raycast specializations --scenes"),
        "{written}"
    );
    assert!(
        written.contains("llvmpipe") || written.contains(" on "),
        "{written}"
    );
    assert!(written.contains("torus was not measured"), "{written}");
    for scene in ["triangle", "sphere-packing"] {
        let rows: Vec<&str> = written
            .lines()
            .filter(|l| l.starts_with(&format!("| {scene} | ")) && l.contains(": "))
            .collect();
        assert_eq!(rows.len(), 4, "{rows:#?}");
        let cells =
            |row: &str| -> Vec<String> { row.split('|').map(|c| c.trim().to_owned()).collect() };
        for row in &rows {
            let c = cells(row);
            // | scene | spec | with | without | speed-up | default | note |
            let measured = c[3] != "-";
            if measured {
                let with: f64 = c[3].parse().unwrap();
                let without: f64 = c[4].parse().unwrap();
                let up: f64 = c[5].trim_end_matches('x').parse().unwrap();
                assert!(with > 0.0 && without > 0.0, "{row}");
                assert!((up - without / with).abs() <= 0.01 * up + 0.01, "{row}");
            } else {
                assert!(!c[7].is_empty(), "an unmeasured row says why: {row}");
            }
        }
        // Neither scene gets a BVH from `render`, so packets do not apply.
        let packets = rows
            .iter()
            .find(|r| r.contains("subgroup packets"))
            .unwrap();
        assert!(packets.contains("no BVH"), "{packets}");
        let bvh = rows.iter().find(|r| r.contains("BVH: ")).unwrap();
        assert_eq!(cells(bvh)[6], "brute force", "{bvh}");
    }
    // The triangle scene has one kind; sphere-packing spheres and a plane: neither every kind.
    assert!(!written.contains("the scene has every kind"));
}

#[test]
fn bad_input_is_one_line_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out_file = dir.path().join("spec.md");
    let bad = dir.path().join("bad.json");
    std::fs::write(&bad, "{\"camera\": ").unwrap();
    let missing_torus = dir.path().join("torus.json");
    for args in [
        vec!["--scenes", bad.to_str().unwrap()],
        vec!["--torus", missing_torus.to_str().unwrap()],
    ] {
        // `--out`, the option's former name, is kept as a hidden alias of `-o`.
        let mut all = vec!["specializations", "--out", out_file.to_str().unwrap()];
        all.extend(args);
        let out = raycast(&all, &common::repo_path(""));
        assert_eq!(out.status.code(), Some(2));
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert!(stderr.starts_with("error: "), "{stderr}");
        assert!(!out_file.exists());
    }
}

#[test]
fn without_output_the_markdown_is_printed_and_nothing_written() {
    // A checkout's layout: the former default, docs/specializations.md, must not be written.
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("docs")).unwrap();
    let scene = common::repo_path("scenes/course/triangle.json");
    let args = ["--runs", "1", "--no-crossover", "--scenes"];
    let mut all = vec!["specializations"];
    all.extend(args);
    all.push(scene.to_str().unwrap());
    let out = raycast(&all, dir.path());
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.starts_with("# Kernel specializations"), "{stdout}");
    assert!(stdout.contains("| triangle | "), "{stdout}");
    assert_eq!(
        common::file_names(&dir.path().join("docs")),
        Vec::<String>::new()
    );
    assert_eq!(common::file_names(dir.path()), vec!["docs".to_owned()]);
}
