//! The extreme scenes of `scenes/extremes/`, each with the invariant its `comment` states.
//!
//! - Every scene, GPU robust f32: hit/miss equals CPU f64 robust on every pixel whose f64
//!   hit/miss margin is at least 1, and the id on every pixel whose id margin is too (margins
//!   from `raycast::cpu::margin`: the decision quantity over `64 eps32` times its scale).
//!   No output holds NaN, and no infinity but `distance` on a miss, in any GPU mode (f32
//!   excepted on the `range` scenes, whose arithmetic leaves f32's range).
//! - `shared-edges`: robust f32 loses no hit of the f64 reference (no ray through a shared
//!   edge or vertex falls through); textbook f32 is measured, and on the full-view grid it does
//!   crack, as the literature says Cramer's rule does.
//! - `translated` (meshes in OBJ, ASCII PLY and binary double PLY): in robust f32, f64 and
//!   adaptive precision, the same hit/miss and ids as the base scene, distances within 1e-6
//!   (relative).
//! - `scaled` by 2^k (k = -20, 20, 40, 56 in files; -60 to 60 in memory): in robust f32, f64,
//!   adaptive and textbook f32, the same hit/miss and ids, distances exactly 2^k times the
//!   base's, normals identical.
//! - `far-camera`: a centimetre sphere 1e6 away, placed as an independent f64 computation says.
//! - `range`: f32 leaves its range; checked in src/tests/adaptive.rs.
//! - `degenerate`: zero-area triangles are never hit.
//! - `far-sphere` at 1e5: textbook f32 gets hit/miss wrong on certain pixels (the far-sphere
//!   ring of pbrt-v3 #265), robust f32 does not.

use super::common;

use std::path::{Path, PathBuf};

use common::*;
use raycast::Algorithm::{self, Robust, Textbook};
use raycast::cpu::margin::{Margins, margins};
use raycast::images::{Images, MISS};
use raycast::prepare::Prepared;
use raycast::prepare::bvh::Search;
use raycast::render::AnyImages;
use raycast::scene::{Object, Scene};

struct Extreme {
    name: String,
    path: PathBuf,
    scene: Scene,
    comment: serde_json::Value,
}

fn extremes() -> Vec<Extreme> {
    let scenes = common::extreme_scenes();
    assert!(scenes.len() >= 15, "only {} extreme scenes", scenes.len());
    scenes
        .into_iter()
        .map(|(path, scene)| {
            let text = std::fs::read_to_string(&path).unwrap();
            let json: serde_json::Value = serde_json::from_str(&text).unwrap();
            Extreme {
                name: scene_name(&path),
                comment: json["comment"].clone(),
                scene,
                path,
            }
        })
        .collect()
}

fn kind(e: &Extreme) -> &str {
    e.comment["kind"]
        .as_str()
        .unwrap_or_else(|| panic!("{}: comment.kind missing", e.name))
}

fn gpu_render<R: raycast::kernel::layout::GpuReal>(scene: &Scene, a: Algorithm) -> Images<R> {
    super::kernels::gpu_scene::<R>(gpu(), scene, a).unwrap()
}

fn truth(scene: &Scene) -> Images<f64> {
    raycast::cpu::render::<f64>(scene, Robust)
}

/// The f32 kernel's margins, judged in its own (kernel) units.
fn f32_margins(scene: &Scene) -> Vec<Margins> {
    let prepared = Prepared::<f64>::new(scene, Robust, Search::BruteForce);
    margins(&prepared.frame, &prepared.primitives, f32::EPSILON as f64)
}

/// (pixels where hit/miss differs on a certain pixel, id differs on a certain pixel,
/// uncertain pixels)
fn certain_disagreements(
    ours: &Images<f32>,
    truth: &Images<f64>,
    m: &[Margins],
) -> (usize, usize, usize) {
    let (mut hit, mut id, mut uncertain) = (0, 0, 0);
    for (k, margin) in m.iter().enumerate() {
        let (a, b) = (ours.id[k], truth.id[k]);
        if !margin.certain() {
            uncertain += 1;
        }
        if margin.hit >= 1.0 && (a == MISS) != (b == MISS) {
            hit += 1;
        } else if margin.certain() && a != b {
            id += 1;
        }
    }
    (hit, id, uncertain)
}

#[test]
fn robust_f32_decides_as_f64_wherever_the_margin_allows() {
    for e in extremes() {
        let ours = gpu_render::<f32>(&e.scene, Robust);
        let reference = truth(&e.scene);
        let m = f32_margins(&e.scene);
        let (hit, id, uncertain) = certain_disagreements(&ours, &reference, &m);
        println!(
            "{}: {uncertain} of {} pixels uncertain; disagreements on certain pixels: {hit} hit/miss, {id} id",
            e.name,
            ours.len()
        );
        assert_eq!(
            (hit, id),
            (0, 0),
            "{}: robust f32 disagrees on certain pixels",
            e.name
        );
    }
}

fn assert_clean<R: raycast::math::Real>(label: &str, images: &Images<R>) {
    for k in 0..images.len() {
        let d = images.distance[k].to_f64();
        let n = images.normal[k].map(|c| c.to_f64());
        if images.id[k] == MISS {
            assert!(
                d == f64::INFINITY,
                "{label}: pixel {k}: a miss has distance {d}"
            );
        } else {
            assert!(d.is_finite(), "{label}: pixel {k}: distance {d}");
        }
        assert!(
            n.iter().all(|c| c.is_finite()),
            "{label}: pixel {k}: normal {n:?}"
        );
    }
}

/// f32 is exempt on the `range` scenes only, whose arithmetic leaves f32's range even in kernel
/// units: textbook f32 computes hits at t beyond it (a distance of infinity), robust f32 sphere
/// normals whose half-chord overflows (NaN). Guarding the normal would slow every f32 render
/// (docs/experiments.md#adaptive-precisions-bounds); adaptive precision re-casts such pixels
/// in f64 (src/tests/adaptive.rs), so its images, like f64's, must be clean on every scene.
#[test]
fn no_nan_or_infinity_in_any_gpu_mode() {
    for e in extremes() {
        let adaptive = raycast::render::adaptive::render_adaptive(gpu(), &e.scene).unwrap();
        assert_clean(&format!("{} gpu adaptive", e.name), &adaptive.images);
        for a in [Textbook, Robust] {
            if kind(&e) != "range" {
                assert_clean(
                    &format!("{} gpu f32 {a}", e.name),
                    &gpu_render::<f32>(&e.scene, a),
                );
            }
            assert_clean(
                &format!("{} gpu f64 {a}", e.name),
                &gpu_render::<f64>(&e.scene, a),
            );
        }
    }
}

/// Pixels where `truth` hits and `ours` misses.
fn lost_hits<R: raycast::math::Real>(ours: &Images<R>, truth: &Images<f64>) -> usize {
    (0..ours.len())
        .filter(|&k| truth.id[k] != MISS && ours.id[k] == MISS)
        .count()
}

#[test]
fn shared_edges_never_crack_in_robust_mode() {
    let mut textbook_cracks = Vec::new();
    for e in extremes().into_iter().filter(|e| kind(e) == "shared-edges") {
        let reference = truth(&e.scene);
        let robust = gpu_render::<f32>(&e.scene, Robust);
        let textbook = gpu_render::<f32>(&e.scene, Textbook);
        let (lost_robust, lost_textbook) = (
            lost_hits(&robust, &reference),
            lost_hits(&textbook, &reference),
        );
        println!(
            "{}: lost hits robust f32 {lost_robust}, textbook f32 {lost_textbook}",
            e.name
        );
        assert_eq!(lost_robust, 0, "{}: robust f32 cracks", e.name);
        assert_eq!(
            lost_hits(&gpu_render::<f64>(&e.scene, Robust), &reference),
            0,
            "{}: robust f64 cracks",
            e.name
        );
        textbook_cracks.push(lost_textbook);
    }
    assert!(!textbook_cracks.is_empty(), "no shared-edges scene");
    assert!(
        textbook_cracks.iter().any(|&c| c > 0),
        "textbook f32 was expected to crack on some shared-edge scene: {textbook_cracks:?}"
    );
}

fn base_of(e: &Extreme) -> Scene {
    let base = e.comment["base"]
        .as_str()
        .unwrap_or_else(|| panic!("{}: comment.base", e.name));
    Scene::load(&e.path.parent().unwrap().join(base)).unwrap()
}

/// The modes each translated and scaled scene is checked in.
const FILE_MODES: [&str; 4] = [
    "gpu:f32:robust",
    "gpu:f64:robust",
    "gpu:adaptive:robust",
    "gpu:f32:textbook",
];

/// (ids, distances, normals) of `scene` rendered in `mode`, widened to f64.
fn rendered(scene: &Scene, mode: &str) -> (Vec<i32>, Vec<f64>, Vec<[f64; 3]>) {
    let mode: raycast::render::Mode = mode.parse().unwrap();
    let widen = |i: AnyImages| match i {
        AnyImages::F32(i) => (
            i.id,
            i.distance.iter().map(|&d| d as f64).collect(),
            i.normal.iter().map(|n| n.map(|c| c as f64)).collect(),
        ),
        AnyImages::F64(i) => (i.id, i.distance, i.normal),
    };
    widen(raycast::render::render(scene, mode, Some(gpu()), None).unwrap())
}

/// Translated scenes, in robust f32, f64 and adaptive precision: the base's ids on every
/// pixel, distances within 1e-6 (relative). (Textbook, in world coordinates, is meant to fail.)
#[test]
fn translation_changes_nothing() {
    let mut seen = 0;
    for e in extremes().into_iter().filter(|e| kind(e) == "translated") {
        seen += 1;
        for mode in &FILE_MODES[..3] {
            let (base_id, base_distance, _) = rendered(&base_of(&e), mode);
            let (id, distance, _) = rendered(&e.scene, mode);
            assert_eq!(
                base_id, id,
                "{} {mode}: ids differ from the base scene",
                e.name
            );
            let worst = (0..id.len())
                .filter(|&k| id[k] != MISS)
                .map(|k| ((distance[k] - base_distance[k]) / base_distance[k]).abs())
                .fold(0.0, f64::max);
            println!("{} {mode}: max relative distance change {worst:e}", e.name);
            assert!(worst < 1e-6, "{} {mode}: {worst}", e.name);
        }
    }
    assert!(
        seen >= 4,
        "expected scenes translated by 1e3 and 1e6, OBJ and PLY"
    );
}

/// Scaled scenes, in every mode of `FILE_MODES` (textbook included: the host's rescale gives it
/// the base's numbers too): the base's ids, distances exactly 2^k times, normals identical.
#[test]
fn scaling_by_a_power_of_two_only_scales_distances() {
    let mut seen = 0;
    for e in extremes().into_iter().filter(|e| kind(e) == "scaled") {
        seen += 1;
        let s = e.comment["scale"]
            .as_f64()
            .unwrap_or_else(|| panic!("{}: comment.scale", e.name));
        assert_eq!(
            s.log2().fract(),
            0.0,
            "{}: scale {s} is not a power of two",
            e.name
        );
        for mode in FILE_MODES {
            let (base_id, base_distance, base_normal) = rendered(&base_of(&e), mode);
            let (id, distance, normal) = rendered(&e.scene, mode);
            assert_eq!(base_id, id, "{} ({mode}): ids differ", e.name);
            for k in (0..id.len()).filter(|&k| id[k] != MISS) {
                let what = format!("{} ({mode}) pixel {k}", e.name);
                assert_eq!(distance[k], base_distance[k] * s, "{what}");
                assert_eq!(normal[k], base_normal[k], "{what}");
            }
        }
    }
    assert!(
        seen >= 4,
        "expected scenes scaled by 2^-20, 2^20, 2^40 and 2^56"
    );
}

fn is_zero_area(t: &[glam::DVec3; 3]) -> bool {
    let t = t.map(raycast::math::Vec3::from);
    let n = raycast::math::cross(t[1] - t[0], t[2] - t[0]);
    raycast::math::dot(n, n) == 0.0
}

#[test]
fn degenerate_triangles_are_never_hit() {
    let mut checked = 0;
    for e in extremes().into_iter().filter(|e| kind(e) == "degenerate") {
        let degenerate: Vec<i32> = e
            .scene
            .objects
            .iter()
            .enumerate()
            .filter(|(_, o)| matches!(o, Object::Triangle { corners } if is_zero_area(corners)))
            .map(|(k, _)| k as i32)
            .collect();
        assert!(!degenerate.is_empty(), "{}: no zero-area triangle", e.name);
        for a in [Textbook, Robust] {
            let f32_ids = gpu_render::<f32>(&e.scene, a).id;
            let f64_ids = gpu_render::<f64>(&e.scene, a).id;
            let cpu_ids = raycast::cpu::render::<f64>(&e.scene, a).id;
            for ids in [&f32_ids, &f64_ids, &cpu_ids] {
                assert!(
                    !ids.iter().any(|id| degenerate.contains(id)),
                    "{} ({a}): a zero-area triangle was hit",
                    e.name
                );
            }
        }
        checked += degenerate.len();
    }
    assert!(checked > 0);
}

#[test]
fn textbook_f32_fails_on_the_far_sphere_where_robust_does_not() {
    let far: Vec<Extreme> = extremes()
        .into_iter()
        .filter(|e| kind(e) == "far-sphere")
        .collect();
    assert!(far.len() >= 4, "expected unit spheres at 1e2..1e5");
    let mut textbook_failures = 0;
    for e in &far {
        let reference = truth(&e.scene);
        let m = f32_margins(&e.scene);
        let (hit_t, _, _) =
            certain_disagreements(&gpu_render::<f32>(&e.scene, Textbook), &reference, &m);
        let (hit_r, _, _) =
            certain_disagreements(&gpu_render::<f32>(&e.scene, Robust), &reference, &m);
        println!(
            "{}: certain hit/miss errors: textbook f32 {hit_t}, robust f32 {hit_r}",
            e.name
        );
        assert_eq!(hit_r, 0);
        textbook_failures += hit_t;
    }
    assert!(
        textbook_failures > 0,
        "textbook f32 was expected to lose far-sphere silhouettes"
    );
}

/// The margin test is not vacuous: it can tell a wrong answer from an uncertain one.
#[test]
fn a_planted_wrong_pixel_on_a_certain_pixel_is_caught() {
    let e = extremes().into_iter().next().unwrap();
    let reference = truth(&e.scene);
    let m = f32_margins(&e.scene);
    let mut ours = gpu_render::<f32>(&e.scene, Robust);
    let k = (0..ours.len())
        .find(|&k| m[k].certain())
        .expect("a certain pixel");
    ours.id[k] = if ours.id[k] == MISS { 0 } else { MISS };
    let (hit, _, _) = certain_disagreements(&ours, &reference, &m);
    assert_eq!(hit, 1, "{}", Path::new(&e.name).display());
}

/// Rays lying in a triangle's plane and in a plane (the eye is in both, looking along them)
/// miss both, in every mode, without NaN; the sphere behind is still seen.
#[test]
fn rays_in_a_triangle_plane_or_a_plane_miss_without_nan() {
    let json = r#"{"camera": {"eye": [0, 0, 0], "look": [0, 0, -1], "up": [0, 1, 0],
        "focal_length": 1, "width": 1, "height": 1, "resolution": [33, 33]},
      "objects": [
        {"type": "sphere", "center": [0, 0, -6], "radius": 1},
        {"type": "triangle", "corners": [[-1, 0, -2], [1, 0, -2], [0, 0, -4]]},
        {"type": "plane", "point": [5, 0, 0], "normal": [0, 1, 0]}]}"#;
    let scene =
        Scene::from_json(json, Path::new("edge-on.json"), &mut |_, _| unreachable!()).unwrap();
    // Row 16 of 33 is the centre row: its rays have vs = 0 and lie in the plane y = 0.
    let centre_row = |ids: &[i32]| ids[16 * 33..17 * 33].to_vec();
    for a in [Textbook, Robust] {
        let images = [
            ("gpu f32", gpu_render::<f32>(&scene, a).id),
            ("gpu f64", gpu_render::<f64>(&scene, a).id),
            ("cpu f64", raycast::cpu::render::<f64>(&scene, a).id),
        ];
        for (label, ids) in &images {
            let row = centre_row(ids);
            assert!(
                row.iter().all(|&id| id != 1 && id != 2),
                "{label} {a}: edge-on hit: {row:?}"
            );
            assert_eq!(
                row[16], 0,
                "{label} {a}: the sphere straight ahead is hidden"
            );
        }
        assert_clean(
            &format!("edge-on gpu f32 {a}"),
            &gpu_render::<f32>(&scene, a),
        );
    }
}

/// Every mode renders a scene scaled by 2^k, k from -60 to 60, exactly like the unscaled one:
/// the same ids and normals bit for bit, distances exactly 2^k times (the host renders every
/// scale at the camera's own scale, `prepare::unit_exponent`). The base is the dyadic scene
/// scaled so that its largest number times 2^60 stays within the 1e18 a scene file may hold.
#[test]
fn every_mode_is_invariant_under_power_of_two_scaling() {
    let dyadic = Scene::load(&repo_path("scenes/extremes/dyadic-base.json")).unwrap();
    let shift = (1e18 / 2f64.powi(60) / Scene::largest_magnitude(&dyadic))
        .log2()
        .floor() as i32;
    let base = dyadic.scaled_by_pow2(shift);
    // The test's own setup, not a property of raycast: the rounding of log2 kept the bound.
    assert!(Scene::largest_magnitude(&base) * 2f64.powi(60) <= 1e18);
    let modes = [
        "gpu:f32:robust",
        "gpu:f64:robust",
        "gpu:adaptive:robust",
        "gpu:f32:textbook",
        "gpu:f64:textbook",
        "cpu:f32:robust",
        "cpu:f64:robust",
        "cpu:f32:textbook",
        "cpu:f64:textbook",
    ];
    for mode in modes {
        let mode: raycast::render::Mode = mode.parse().unwrap();
        let render =
            |scene: &Scene| raycast::render::render(scene, mode, Some(gpu()), None).unwrap();
        let reference = render(&base);
        assert!(
            reference.id().iter().any(|&id| id != MISS),
            "{mode}: the scene is seen"
        );
        for k in [-60, -41, -20, -1, 1, 7, 33, 60] {
            let scaled = render(&base.scaled_by_pow2(k));
            let ids_differ = (scaled.id().iter().zip(reference.id()))
                .filter(|(a, b)| a != b)
                .count();
            assert_eq!(ids_differ, 0, "{mode}, 2^{k}: pixels whose id differs");
            let factor = 2f64.powi(k);
            match (&reference, &scaled) {
                (AnyImages::F32(a), AnyImages::F32(b)) => assert_scaled(a, b, factor, mode, k),
                (AnyImages::F64(a), AnyImages::F64(b)) => assert_scaled(a, b, factor, mode, k),
                _ => panic!("{mode}: precision changed with the scale"),
            }
        }
    }
}

fn assert_scaled<R: raycast::math::Real>(
    a: &Images<R>,
    b: &Images<R>,
    factor: f64,
    mode: raycast::render::Mode,
    k: i32,
) {
    for p in (0..a.len()).filter(|&p| a.id[p] != MISS) {
        assert_eq!(
            b.distance[p].to_f64(),
            a.distance[p].to_f64() * factor,
            "{mode}, 2^{k}, pixel {p}: distance"
        );
        assert_eq!(b.normal[p], a.normal[p], "{mode}, 2^{k}, pixel {p}: normal");
    }
}

/// `far-camera`: a sphere 1 cm across seen from 1e6 away. In f64, on the GPU and the CPU, a
/// pixel hits the sphere only where its ray passes within the radius of the centre, every
/// ray that passes clearly within it hits the sphere or the cube beside it, and the distance
/// is where the ray enters the sphere: all computed here independently (perpendicular distance
/// by a cross product, entry from the chord), pixels within 1e-6 (relative) of the silhouette
/// skipped. Adaptive precision and robust f32 are held to f64 by the tests over every scene.
#[test]
fn a_centimetre_sphere_a_million_away_is_placed_exactly_in_f64() {
    let mut seen = 0;
    for e in extremes().into_iter().filter(|e| kind(e) == "far-camera") {
        seen += 1;
        let Object::Sphere { center, radius } = e.scene.objects[0] else {
            panic!("{}: object 0 is the sphere", e.name)
        };
        let frame = raycast::kernel::frame::Frame::new(&e.scene.camera, e.scene.camera.resolution);
        let renders = [
            ("gpu f64", gpu_render::<f64>(&e.scene, Robust)),
            ("cpu f64", truth(&e.scene)),
        ];
        for (label, images) in renders {
            let mut sphere_pixels = 0;
            for k in 0..images.len() {
                let (i, j) = (k as u32 / frame.nx, k as u32 % frame.nx);
                let ray = raycast::kernel::frame::camera_ray(&frame, i, j);
                let d = raycast::math::normalize(ray.direction);
                let v = raycast::math::Vec3::from(center) - ray.origin;
                let l = raycast::math::length(raycast::math::cross(v, d));
                let near_silhouette = (l - radius).abs() <= 1e-6 * radius;
                let id = images.id[k];
                if near_silhouette {
                    continue;
                }
                if l < radius {
                    assert!(
                        id == 0 || id == 1,
                        "{} {label} pixel {k}: ray passes within the radius, id {id}",
                        e.name
                    );
                } else {
                    assert_ne!(
                        id, 0,
                        "{} {label} pixel {k}: sphere hit {l} from the centre",
                        e.name
                    );
                }
                if id == 0 {
                    sphere_pixels += 1;
                    let entry = raycast::math::dot(v, d) - (radius * radius - l * l).sqrt();
                    let error = (images.distance[k] - entry).abs() / entry;
                    assert!(
                        error <= 1e-9,
                        "{} {label} pixel {k}: distance off by {error:e}",
                        e.name
                    );
                }
            }
            println!("{} {label}: {sphere_pixels} sphere pixels checked", e.name);
            assert!(
                sphere_pixels > 100,
                "{} {label}: only {sphere_pixels}",
                e.name
            );
        }
    }
    assert!(seen >= 1, "expected the far-camera scene");
}
