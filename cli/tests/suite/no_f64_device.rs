//! On a device without `SHADER_F64` (here: lavapipe opened with no optional features), f64
//! renders fail with a clear error and the robust f32 kernel builds without its f64 edge
//! recheck.

use crate::common;

use common::gpu_without_f64;
use raycast::Algorithm::{Robust, Textbook};

#[test]
fn f64_without_shader_f64_is_a_clear_error() {
    let gpu = gpu_without_f64();
    let scene = common::course_scene("triangle");
    // As the command line prints it (the library names `precision`).
    let err = common::gpu_scene::<f64>(&gpu, &scene, Textbook)
        .unwrap_err()
        .spelled(&raycast_cli::flag)
        .to_string();
    assert!(
        err.contains("SHADER_F64") && err.contains("--precision f32"),
        "{err}"
    );
}

#[test]
fn robust_f32_without_f64_still_renders_the_course_bunny() {
    // Its robust f32 kernel leaves out the f64 recheck (src/tests/no_f64_device.rs).
    let gpu = gpu_without_f64();
    assert!(!gpu.info().f64);
    let scene = common::course_scene("bunny");
    let without = common::gpu_scene::<f32>(&gpu, &scene, Robust).unwrap();
    let with = common::gpu_scene::<f32>(common::gpu(), &scene, Robust).unwrap();
    // Without the recheck only pixels on near-zero edge functions can differ.
    let differing = (0..with.id.len())
        .filter(|&k| with.id[k] != without.id[k])
        .count();
    assert!(
        differing * 10_000 <= with.id.len(),
        "{differing} pixels differ"
    );
}

/// `raycast selftest` on a device without f64 shaders and subgroups (as Metal, or a consumer GPU
/// without f64): what needs them is skipped, saying why, and everything else passes.
#[test]
fn selftest_skips_what_needs_f64_or_subgroups_and_passes_the_rest() {
    use raycast_cli::study::selftest::{self, Adapter, Options, Outcome};
    let gpu = gpu_without_f64();
    let parts = [
        "course/triangle",
        "random-0/",
        "extremes/scaled-2e40",
        "rays/incoherent/",
        "packets/wide",
    ];
    let options = Options {
        only: parts.iter().map(|p| p.to_string()).collect(),
        plant: None,
    };
    let adapter = Adapter::probe(&gpu).unwrap();
    let report =
        selftest::run(&gpu, &adapter, &options, &mut |c| println!("{}", c.line())).unwrap();
    assert!(report.passed(), "{}", report.summary());
    let skipped: Vec<&str> = (report.checks.iter())
        .filter(|c| c.result == Outcome::Skip)
        .map(|c| c.name.as_str())
        .collect();
    let expected = [
        "random-0/f32/packets",
        "random-0/f64",
        "packets/wide",
        "rays/incoherent/f64",
    ];
    assert_eq!(skipped, expected);
    let scaled = report
        .checks
        .iter()
        .find(|c| c.name == "extremes/scaled-2e40");
    assert!(
        scaled
            .unwrap()
            .measured
            .ends_with("(f64 skipped: no SHADER_F64)")
    );
}
