//! `raycast render --precision adaptive` end to end (src/tests/adaptive.rs checks adaptive
//! precision itself).

use crate::common;

use common::repo_path;

#[test]
fn the_cli_reports_the_recast_fraction_and_refuses_cpu_adaptive() {
    let dir = tempfile::tempdir().unwrap();
    let scene = repo_path("scenes/course/bunny.json");
    let run = |extra: &[&str]| {
        common::raycast()
            .args(["render", scene.to_str().unwrap(), "--size", "64x36", "-o"])
            .arg(dir.path().join("out"))
            .args(extra)
            .output()
            .unwrap()
    };
    let ok = run(&["--precision", "adaptive"]);
    assert_eq!(
        ok.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    let stdout = String::from_utf8_lossy(&ok.stdout);
    assert!(
        stdout.contains("re-cast ") && stdout.contains("% of pixels in f64"),
        "{stdout}"
    );
    let refused = run(&["--precision", "adaptive", "--device", "cpu"]);
    assert_eq!(refused.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(stderr.contains("--precision adaptive"), "{stderr}");
}
