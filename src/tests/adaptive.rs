//! Adaptive precision: robust f32 with a per-pixel certainty test, uncertain pixels cast again
//! in f64.
//!
//! - On every pixel of the course scenes and of `scenes/extremes/`, hit/miss and id equal CPU
//!   f64 robust exactly, and on the course scenes less than 5% of pixels are re-cast; with the
//!   re-cast on the CPU (few pixels, the default) and forced onto the GPU's f64 kernel, whose
//!   images are the same bit for bit.
//! - The certainty test is sound: over seeded random scenes and the extreme scenes, no pixel
//!   the f32 pass marks certain disagrees with CPU f64 robust in hit/miss or id (the counter
//!   must find zero), and the same counter does find disagreements when the certainty flags
//!   are replaced by a test that trusts every pixel.
//! - Where f32's arithmetic leaves its range (the `range-*` extreme scenes: overflow,
//!   underflow, NaN), no pixel the f32 pass got wrong is marked certain.

use super::common;

use common::*;
use raycast::Algorithm::Robust;
use raycast::gpu::shader::Variant;
use raycast::images::Images;
use raycast::render::adaptive::{Adaptive, render_adaptive, render_adaptive_with};
use raycast::scene::Scene;

fn extreme_scenes() -> Vec<(String, Scene)> {
    common::extreme_scenes()
        .into_iter()
        .map(|(path, scene)| (scene_name(&path), scene))
        .collect()
}

/// The adaptive render of `scene` with its re-cast on the CPU (the default for few pixels) and
/// forced onto the GPU: the same images, bit for bit.
fn adaptive_both_ways(name: &str, scene: &Scene) -> Adaptive {
    let on_cpu = render_adaptive(gpu(), scene).unwrap();
    let on_gpu = render_adaptive_with(gpu(), scene, false, 0).unwrap();
    assert!(!on_cpu.recast_on_gpu || on_cpu.recast > raycast::render::adaptive::CPU_RECAST_PIXELS);
    let has_f64 = gpu().has_f64();
    assert_eq!(on_gpu.recast_on_gpu, has_f64 && on_gpu.recast > 0, "{name}");
    assert_eq!(on_cpu.recast, on_gpu.recast, "{name}");
    assert!(
        on_cpu.images == on_gpu.images,
        "{name}: CPU and GPU re-casts differ"
    );
    on_cpu
}

/// Pixels whose hit/miss or id differ.
fn disagreements<T: raycast::math::Real>(a: &Images<T>, truth: &Images<f64>) -> usize {
    (0..a.len()).filter(|&k| a.id[k] != truth.id[k]).count()
}

#[test]
fn adaptive_equals_f64_on_every_course_pixel_and_recasts_under_5_percent() {
    for name in COURSE_SCENES {
        let scene = course_scene(name);
        let adaptive = adaptive_both_ways(name, &scene);
        let truth = raycast::cpu::render::<f64>(&scene, Robust);
        let wrong = disagreements(&adaptive.images, &truth);
        println!(
            "{name}: re-cast {:.3}% of pixels, {wrong} disagree",
            100.0 * adaptive.recast_fraction()
        );
        assert_eq!(wrong, 0, "{name}");
        assert!(
            adaptive.recast_fraction() < 0.05,
            "{name}: {}",
            adaptive.recast_fraction()
        );
    }
}

#[test]
fn adaptive_equals_f64_on_every_extreme_pixel() {
    for (name, scene) in extreme_scenes() {
        let adaptive = adaptive_both_ways(&name, &scene);
        let truth = raycast::cpu::render::<f64>(&scene, Robust);
        let wrong = disagreements(&adaptive.images, &truth);
        println!(
            "{name}: re-cast {:.2}%, {wrong} disagree",
            100.0 * adaptive.recast_fraction()
        );
        assert_eq!(wrong, 0, "{name}");
    }
}

/// (certain pixels disagreeing with f64, all pixels disagreeing with f64) of the f32 pass,
/// whose kernel (one ray a lane at these sizes) gives the same images and certainty as that of
/// large renders (two rays a lane).
fn certain_disagreements(scene: &Scene) -> (usize, usize) {
    let (pass, _) = raycast::render::adaptive::certainty_pass(gpu(), scene, false).unwrap();
    let large = Variant {
        lane_rays_limit: raycast::gpu::shader::MAX_LANE_RAYS,
        ..raycast::render::adaptive::certainty_variant(gpu(), scene)
    };
    let prepared = raycast::gpu::prepare::<f32>(scene, &large).unwrap();
    let other = raycast::gpu::run(gpu(), &prepared, raycast::gpu::Job::new(large)).unwrap();
    assert_same_bits(&pass.images, &other.images, "one and two rays a lane");
    assert!(pass.certainty == other.certainty, "one and two rays a lane");
    let (first, certain) = (pass.images, pass.certainty.unwrap());
    let truth = raycast::cpu::render::<f64>(scene, Robust);
    let wrong: Vec<usize> = (0..first.len())
        .filter(|&k| first.id[k] != truth.id[k])
        .collect();
    let certain_wrong = wrong.iter().filter(|&&k| certain[k]).count();
    (certain_wrong, wrong.len())
}

#[test]
fn the_certainty_test_is_sound_and_the_counter_can_tell() {
    let mut scenes: Vec<(String, Scene)> = (1..=8)
        .map(|seed| (format!("random {seed}"), random_scene(seed, [160, 120])))
        .collect();
    scenes.extend(extreme_scenes());
    scenes.extend(
        COURSE_SCENES
            .iter()
            .map(|n| (n.to_string(), course_scene(n))),
    );
    let (mut certain_wrong, mut all_wrong) = (0, 0);
    for (name, scene) in &scenes {
        let (c, a) = certain_disagreements(scene);
        if a > 0 {
            println!(
                "{name}: f32 pass disagrees with f64 on {a} pixels, {c} of them marked certain"
            );
        }
        certain_wrong += c;
        all_wrong += a;
    }
    assert_eq!(certain_wrong, 0, "pixels marked certain disagree with f64");
    // The same count with every pixel trusted (a certainty test that always says yes) is not
    // zero: the scenes do contain pixels where f32 decides differently.
    assert!(
        all_wrong > 0,
        "no f32/f64 disagreement at all: the soundness check would be vacuous"
    );
}

/// The `range-*` extreme scenes leave f32's range even after the host's rescale (a triangle's t
/// overflows, a tiny camera's ray directions underflow). There the f32 pass gets pixels wrong
/// (ids, or outputs that are not finite), and none of them may be marked certain; on the
/// pixels it does mark certain, its distances are f32-accurate.
#[test]
fn no_pixel_is_certain_where_f32_left_its_range() {
    let scenes: Vec<(String, Scene)> = extreme_scenes()
        .into_iter()
        .filter(|(name, _)| name.starts_with("range-"))
        .collect();
    assert!(scenes.len() >= 3, "only {} range scenes", scenes.len());
    for (name, scene) in &scenes {
        let (pass, _) = raycast::render::adaptive::certainty_pass(gpu(), scene, false).unwrap();
        let (first, certain) = (pass.images, pass.certainty.unwrap());
        let truth = raycast::cpu::render::<f64>(scene, Robust);
        let broken = |k: usize| {
            let finite = first.distance[k].is_finite() || first.id[k] == raycast::images::MISS;
            first.id[k] != truth.id[k] || !finite || first.normal[k].iter().any(|c| c.is_nan())
        };
        let wrong: Vec<usize> = (0..first.len()).filter(|&k| broken(k)).collect();
        let certain_wrong = wrong.iter().filter(|&&k| certain[k]).count();
        let certain_hits: Vec<usize> = (0..first.len())
            .filter(|&k| certain[k] && truth.id[k] != raycast::images::MISS)
            .collect();
        let worst = certain_hits
            .iter()
            .map(|&k| {
                let d = truth.distance[k];
                (first.distance[k] as f64 - d).abs() / d
            })
            .fold(0.0, f64::max);
        println!(
            "{name}: f32 wrong on {} pixels, {certain_wrong} of them certain; {} certain hits, \
             worst relative distance error {worst:.1e}",
            wrong.len(),
            certain_hits.len()
        );
        assert!(!wrong.is_empty(), "{name}: f32 never leaves its range");
        assert_eq!(certain_wrong, 0, "{name}: certain pixels where f32 failed");
        assert!(worst <= 1e-5, "{name}: certain distance off by {worst:e}");
    }
}
