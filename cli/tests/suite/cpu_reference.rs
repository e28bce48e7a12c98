//! The CPU reference (src/cpu/) against the course renders, against the GPU kernel, and
//! `compare` on planted differences.

use crate::common;

use common::*;
use raycast::Algorithm::{self, Robust, Textbook};
use raycast::AnyImages;
use raycast::{Images, MISS};
use raycast_cli::compare::{PixelMatch, compare};

/// CPU f64 is the course's own arithmetic: all 18 pictures equal, every pixel. No GPU needed.
#[test]
fn cpu_f64_reproduces_every_course_render_exactly() {
    for name in COURSE_SCENES {
        let options = raycast::RenderOptions {
            precision: Some(raycast::Precision::F64),
            algorithm: Textbook,
            ..raycast::RenderOptions::default()
        };
        let p = raycast::Cpu
            .render(&course_scene(name), &options)
            .unwrap()
            .pictures();
        for (kind, ours) in [("id", &p.id), ("depth", &p.depth), ("normal", &p.normal)] {
            let reference = course_render(name, kind);
            let differing = ours.iter().zip(&reference).filter(|(a, b)| a != b).count();
            assert_eq!(
                differing, 0,
                "{name}.{kind}: {differing} channel values differ"
            );
        }
    }
}

/// Ulps between two f32 values of the same sign.
fn ulps(a: f32, b: f32) -> u32 {
    (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs() as u32
}

/// CPU f32 against GPU f32, where both compute the same operations in the same order.
///
/// Tolerances: hit/miss and id identical on at least 99.99% of pixels (the bound);
/// where both hit, distances within 4 ulps and normals within 4 ulps per component. Why not 0:
/// Vulkan allows f32 division 2.5 ulp and sqrt about 3 ulp of error, and a driver may fuse
/// a*b+c into an FMA, so a conforming GPU need not round like the CPU. lavapipe does not fuse
/// and rounds div and sqrt correctly; there the measured difference is 0 ulps everywhere.
fn check_cpu_f32_matches_gpu(label: &str, scene: &raycast::Scene) {
    for algorithm in [Textbook, Robust] {
        check_cpu_f32_matches_gpu_with(&format!("{label} ({algorithm})"), scene, algorithm);
    }
}

fn check_cpu_f32_matches_gpu_with(label: &str, scene: &raycast::Scene, algorithm: Algorithm) {
    let cpu = common::cpu_render::<f32>(scene, algorithm);
    let gpu = common::gpu_scene::<f32>(gpu(), scene, algorithm).unwrap();
    let pixels = cpu.id.len();
    let id_differs = (0..pixels).filter(|&k| cpu.id[k] != gpu.id[k]).count();
    let (mut max_ulps, mut hits) = (0, 0);
    for k in (0..pixels).filter(|&k| cpu.id[k] != MISS && gpu.id[k] != MISS) {
        hits += 1;
        max_ulps = max_ulps.max(ulps(cpu.distance[k], gpu.distance[k]));
        for c in 0..3 {
            max_ulps = max_ulps.max(ulps(cpu.normal[k][c], gpu.normal[k][c]));
        }
    }
    println!(
        "{label}: id differs on {id_differs} of {pixels} px; max {max_ulps} ulps over {hits} common hits"
    );
    assert!(
        hits * 100 > pixels,
        "{label}: too few hits ({hits}) for a meaningful test"
    );
    assert!(
        id_differs * 10_000 <= pixels,
        "{label}: id differs on {id_differs} px"
    );
    assert!(max_ulps <= 4, "{label}: {max_ulps} ulps");
}

#[test]
fn cpu_f32_reproduces_gpu_f32_on_course_scenes() {
    for name in COURSE_SCENES {
        check_cpu_f32_matches_gpu(name, &course_scene(name));
    }
}

#[test]
fn cpu_f32_reproduces_gpu_f32_on_random_scenes() {
    for seed in 1..=6 {
        check_cpu_f32_matches_gpu(&format!("random {seed}"), &random_scene(seed, [160, 120]));
    }
}

/// GPU f32 (textbook, the weaker set) against the f64 truth (CPU f64 robust) on random scenes.
///
/// Tolerances, for these scenes (sizes 0.1..2, distances 3..10, so no catastrophic
/// cancellation beyond what the textbook formulas always have):
/// - hit/miss + id mismatches: at most 0.1% of pixels. They can only occur where the f64
///   decision margin is within f32 error: silhouettes, mesh edges (Cramer's rule is not
///   watertight) and near-ties between surfaces.
/// - relative distance error, 99th percentile: below 1e-5 (about 100 f32 epsilons: the
///   quadratic's b*b - 4ac loses up to (b^2/disc) digits near silhouettes, so the maximum is
///   not bounded, but the bulk is within a few ulps times a modest condition number).
/// - normal angle, 99th percentile: below 0.01 degrees.
#[test]
fn gpu_f32_agrees_with_cpu_f64_on_random_scenes() {
    for seed in 1..=6 {
        let scene = random_scene(seed, [160, 120]);
        let a = AnyImages::F32(common::gpu_scene::<f32>(gpu(), &scene, Textbook).unwrap());
        let b = AnyImages::F64(common::cpu_render::<f64>(&scene, Robust));
        let r = compare(&a, &b).report;
        println!("random {seed}: {}", serde_json::to_string(&r).unwrap());
        assert!(
            (r.hit_mismatch + r.id_mismatch) * 1000 <= r.pixels,
            "seed {seed}: {r:?}"
        );
        assert!(r.distance.rel_p99.unwrap() < 1e-5, "seed {seed}: {r:?}");
        assert!(r.normal_angle_deg.p99.unwrap() < 0.01, "seed {seed}: {r:?}");
    }
}

/// A planted difference is counted exactly, by kind.
#[test]
fn compare_counts_planted_differences_exactly() {
    let scene = random_scene(7, [96, 72]);
    let truth: Images<f64> = common::cpu_render(&scene, Robust);
    let mut planted = truth.clone();
    let hits: Vec<usize> = (0..truth.id.len())
        .filter(|&k| truth.id[k] != MISS)
        .collect();
    let misses: Vec<usize> = (0..truth.id.len())
        .filter(|&k| truth.id[k] == MISS)
        .collect();
    // 17 hits turned into misses, 5 misses into hits, 11 hits given another id.
    for &k in hits.iter().step_by(7).take(17) {
        planted.id[k] = MISS;
        planted.distance[k] = f64::INFINITY;
    }
    for &k in misses.iter().step_by(5).take(5) {
        planted.id[k] = 0;
        planted.distance[k] = 1.0;
    }
    let relabelled: Vec<usize> = hits.iter().skip(3).step_by(7).take(11).copied().collect();
    for &k in &relabelled {
        planted.id[k] += 1000;
    }
    assert!(
        hits.len() >= 7 * 17 && misses.len() >= 5 * 5,
        "scene too empty or too full"
    );
    let c = compare(&AnyImages::F64(planted), &AnyImages::F64(truth));
    assert_eq!(c.report.hit_mismatch, 17 + 5);
    assert_eq!(c.report.id_mismatch, 11);
    assert!(
        relabelled
            .iter()
            .all(|&k| c.per_pixel[k] == PixelMatch::IdMismatch)
    );
    // Everything not planted agrees exactly.
    assert_eq!(c.report.distance.abs_max, Some(0.0));
}
