//! Supersampling (`samples_per_pixel`) and the colour picture, on lavapipe and the CPU
//! reference (cli/tests/suite/supersample.rs runs `--spp` end to end).
//!
//! Coverage is checked exactly where it is known exactly: every expected alpha here is a count
//! of stratum centres, computed in f64 from the documented camera conventions (orthographic
//! camera down -z, `u = +x`, `v = +y`; fine column `J` of `s * nx` has its centre at
//! `x = W (J + 0.5) / (s nx) - W / 2`, fine row `I` at `y = -(H (I + 0.5) / (s ny) - H / 2)`),
//! never by calling the renderer's code.

use super::common;

use std::path::Path;

use common::{SPHERE, gpu, ortho_json};
use raycast::Mode;
use raycast::images::Coverage;
use raycast::images::MISS;
use raycast::output::{self, PALETTE, PixelCoverage};
use raycast::render::supersample;
use raycast::render::{self, AnyImages};
use raycast::{Images, Scene};

fn scene(json: &str) -> Scene {
    Scene::from_json(json, Path::new("test.json"), &mut |_, _| unreachable!()).unwrap()
}

fn mode(s: &str) -> Mode {
    s.parse().unwrap()
}

fn gpu_for(m: Mode) -> Option<&'static raycast::gpu::Gpu> {
    (m.device == render::Device::Gpu).then(gpu)
}

fn supersample(scene: &Scene, m: &str, spp: u32) -> AnyImages {
    let m = mode(m);
    supersample::supersample(scene, m, gpu_for(m), spp, None)
        .unwrap_or_else(|e| panic!("{m} at {spp} spp: {e}"))
}

/// Distances of the reduced images in f64.
fn distances(x: &AnyImages) -> Vec<f64> {
    match x {
        AnyImages::F32(x) => x.distance.iter().map(|&d| d as f64).collect(),
        AnyImages::F64(x) => x.distance.clone(),
    }
}

/// The coverage of supersampled images.
fn cov(x: &AnyImages) -> &Coverage {
    x.coverage().expect("supersampled images have coverage")
}

fn coverage(x: &AnyImages) -> Vec<PixelCoverage> {
    match x {
        AnyImages::F32(x) => output::pixel_coverage(x),
        AnyImages::F64(x) => output::pixel_coverage(x),
    }
}

// 1. A half-plane edge through pixel centres.

/// 16 x 8 pixels of one scene unit over the square [-8, 8] x [-4, 4]: column `j` spans
/// `x in [j - 8, j - 7]` with its centre at `x = j - 7.5`. The triangle's vertical edge
/// `x = -2.5` passes through the centres of column 5 and covers everything left of it (its
/// other corners are 1000 units away). With `s` even, the sample centres of column 5 lie at
/// `-3 + (b + 0.5)/s`: the edge falls exactly on a stratum boundary, midway between two fine
/// sample centres (`1/(2s)` of a pixel from each, 1/8 for s = 4), so exactly half of each row's
/// samples are inside, whatever the rounding. All numbers are dyadic (exact in f32).
const HALF_PLANE_TRIANGLE: &str =
    r#"{"type": "triangle", "corners": [[-2.5, -1000, 0], [-2.5, 1000, 0], [-1002.5, 0, 0]]}"#;
const EDGE_COLUMN: usize = 5;

#[test]
fn half_plane_edge_through_pixel_centres_has_alpha_one_half() {
    let scene = scene(&ortho_json(16.0, 8.0, 16, 8, HALF_PLANE_TRIANGLE));
    for m in [
        "gpu:f32:robust",
        "gpu:f64:robust",
        "gpu:f32:textbook",
        "cpu:f64:robust",
    ] {
        for s in [2u32, 4, 8] {
            let n = s * s;
            let x = supersample(&scene, m, n);
            assert_eq!(cov(&x).spp, n);
            for (k, (&alpha, &hits)) in cov(&x).alpha.iter().zip(&cov(&x).hits).enumerate() {
                let col = k % 16;
                let (want_alpha, want_hits, want_id) = match col.cmp(&EDGE_COLUMN) {
                    std::cmp::Ordering::Less => (1.0, n, 0),
                    std::cmp::Ordering::Equal => (0.5, n / 2, 0),
                    std::cmp::Ordering::Greater => (0.0, 0, MISS),
                };
                let at = format!("{m}, s = {s}, pixel {k} (column {col})");
                assert_eq!(alpha, want_alpha, "{at}");
                assert_eq!(hits, want_hits, "{at}");
                assert_eq!(x.id()[k], want_id, "{at}");
            }
            // Every sample hits the triangle's plane z = 0 at distance 5: the mean is exact.
            for (k, d) in distances(&x).into_iter().enumerate() {
                let want = if k % 16 <= EDGE_COLUMN {
                    5.0
                } else {
                    f64::INFINITY
                };
                assert_eq!(d, want, "{m}, s = {s}, pixel {k}");
            }
        }
    }
}

/// The same edge in front of a plane (object 0, at z = -1): the edge pixels are hit by 8
/// samples of each object at s = 4, a tie that goes to the lower id, the plane, with the
/// plane's mean distance; their colour is the mean of the two palette colours.
#[test]
fn a_tie_goes_to_the_lower_id_and_colours_mix_by_coverage() {
    let objects = format!(
        r#"{{"type": "plane", "point": [0, 0, -1], "normal": [0, 0, 1]}}, {HALF_PLANE_TRIANGLE}"#
    );
    let scene = scene(&ortho_json(16.0, 8.0, 16, 8, &objects));
    for m in ["gpu:f32:robust", "cpu:f64:robust"] {
        let x = supersample(&scene, m, 16);
        let d = distances(&x);
        let pixels = coverage(&x);
        let [plane, tri] = [PALETTE[0], PALETTE[1]];
        for k in 0..x.id().len() {
            let col = k % 16;
            let (id, dist, rgb) = match col.cmp(&EDGE_COLUMN) {
                std::cmp::Ordering::Less => (1, 5.0, tri),
                // 8 + 8 samples: ties to object 0; the colour is (plane + triangle) / 2
                // rounded to nearest, ties up: (228 + 55) / 2 = 141.5 -> 142, etc.
                std::cmp::Ordering::Equal => (0, 6.0, [142, 76, 106]),
                std::cmp::Ordering::Greater => (0, 6.0, plane),
            };
            let at = format!("{m}, pixel {k}");
            assert_eq!(x.id()[k], id, "{at}");
            assert_eq!(d[k], dist, "{at}");
            assert_eq!(cov(&x).alpha[k], 1.0, "{at}");
            assert_eq!(
                pixels[k].to_rgba8(None),
                [rgb[0], rgb[1], rgb[2], 255],
                "{at}"
            );
        }
    }
}

// 2. A sphere whose covered fraction is known.

/// Radius 1.3 at the origin, seen over [-2, 2]^2 at 32 x 32 (pixels of 1/8 unit).
/// [`SPHERE`]'s radius.
const R: f64 = 1.3;

fn sphere_scene(nx: u32, ny: u32, w: f64, h: f64) -> Scene {
    scene(&ortho_json(w, h, nx, ny, SPHERE))
}

/// For each pixel of `nx x ny` over a `w x h` plane with `s x s` strata: the number of stratum
/// centres inside the disc of radius `R`, or `None` if a centre lies within `margin` of the
/// circle (|x^2 + y^2 - R^2| <= margin), where the renderer's rounding may decide either way.
fn expected_hits(nx: u32, ny: u32, w: f64, h: f64, s: u32, margin: f64) -> Vec<Option<u32>> {
    let (fx, fy) = (s * nx, s * ny);
    let mut out = vec![Some(0); (nx * ny) as usize];
    for fi in 0..fy {
        let y = -(h * (fi as f64 + 0.5) / fy as f64 - h / 2.0);
        for fj in 0..fx {
            let x = w * (fj as f64 + 0.5) / fx as f64 - w / 2.0;
            let k = ((fi / s) * nx + fj / s) as usize;
            let g = x * x + y * y - R * R;
            out[k] = match out[k] {
                Some(_) if g.abs() <= margin => None,
                Some(c) => Some(c + u32::from(g < 0.0)),
                None => None,
            };
        }
    }
    out
}

#[test]
fn sphere_coverage_is_the_count_of_stratum_centres_in_the_disc() {
    let (nx, ny, w, h) = (32, 32, 4.0, 4.0);
    let scene = sphere_scene(nx, ny, w, h);
    // Margins in units of x^2 + y^2: f64 rounds sample positions and the discriminant at
    // ~1e-16, f32 at a few 1e-7 of the magnitudes (|o - c| ~ 5): 1e-4 leaves a wide margin.
    for (m, margin) in [
        ("gpu:f64:robust", 1e-9),
        ("gpu:f32:robust", 1e-4),
        ("cpu:f32:robust", 1e-4),
    ] {
        for s in [1u32, 2, 3, 4, 8] {
            let n = s * s;
            let x = supersample(&scene, m, n);
            let want = expected_hits(nx, ny, w, h, s, margin);
            let mut checked = 0;
            let mut partial = 0;
            for (k, want) in want.iter().enumerate() {
                let Some(c) = *want else { continue };
                checked += 1;
                if c != 0 && c != n {
                    partial += 1;
                }
                let at = format!("{m}, s = {s}, pixel {k}");
                assert_eq!(cov(&x).hits[k], c, "{at}");
                assert_eq!(cov(&x).alpha[k], c as f32 / n as f32, "{at}");
                assert_eq!(x.id()[k], if c == 0 { MISS } else { 0 }, "{at}");
            }
            let pixels = want.len();
            println!(
                "{m}, s = {s}: {checked} of {pixels} pixels checked exactly, {partial} partly covered"
            );
            // Not vacuous: nearly every pixel is checked, the edge pixels included.
            assert!(checked * 100 >= pixels * 99, "{m}, s = {s}: {checked}");
            if s > 1 {
                assert!(partial >= 30, "{m}, s = {s}: {partial} partial pixels");
            }
        }
    }
}

#[test]
fn total_sphere_coverage_approaches_the_disc_area() {
    let (nx, ny, w, h) = (32, 32, 4.0, 4.0);
    let scene = sphere_scene(nx, ny, w, h);
    let pixel = w / nx as f64;
    let area = std::f64::consts::PI * R * R / (pixel * pixel);
    for s in [2u32, 4, 8] {
        let n = s * s;
        let x = supersample(&scene, "gpu:f32:robust", n);
        let total: f64 = cov(&x).alpha.iter().map(|&a| a as f64).sum();
        // Exact total of hits / N, as f32 alphas are exact here (N a power of two).
        let hits: u32 = cov(&x).hits.iter().sum();
        assert_eq!(total, hits as f64 / n as f64);
        // Only strata the circle crosses can be wrong, each by one stratum (1/N pixel); a
        // circle of radius R crosses at most 8 R / h + 8 cells of side h = pixel / s.
        let strata = 8.0 * R / (pixel / s as f64) + 8.0;
        let bound = strata / n as f64;
        let error = (total - area).abs();
        println!(
            "s = {s}: coverage {total} pixels, disc {area:.4}, error {error:.4}, bound {bound:.4}"
        );
        assert!(error <= bound, "s = {s}: error {error} > bound {bound}");
    }
}

// 3. "over" with premultiplied alpha, on the rendered image.

#[test]
fn background_composites_over_the_rendered_coverage() {
    let scene = sphere_scene(32, 32, 4.0, 4.0);
    let x = supersample(&scene, "gpu:f32:robust", 16);
    let bg = [20, 200, 90];
    let (mut empty, mut full, mut partial) = (0, 0, 0);
    for p in coverage(&x) {
        let premultiplied = p.to_rgba8(None);
        let composited = p.to_rgba8(Some(bg));
        assert_eq!(composited[3], 255);
        match p.hits {
            0 => {
                empty += 1;
                assert_eq!(premultiplied, [0, 0, 0, 0]);
                assert_eq!(composited, [bg[0], bg[1], bg[2], 255]);
            }
            16 => {
                full += 1;
                let [r, g, b] = PALETTE[0];
                assert_eq!(premultiplied, [r, g, b, 255]);
                assert_eq!(composited, [r, g, b, 255]);
            }
            h => {
                partial += 1;
                // One object: the palette colour times the coverage, and c_o = c_a + c_b (1 - a).
                let a = h as f64 / 16.0;
                let want = output::over(p.rgba(), output::opaque(bg));
                for c in 0..3 {
                    let single = PALETTE[0][c] as f64 * a;
                    assert!((premultiplied[c] as f64 - single).abs() <= 0.5);
                    let formula = single + bg[c] as f64 * (1.0 - a);
                    assert!((255.0 * want[c] - formula).abs() < 1e-9);
                    assert!((composited[c] as f64 - formula).abs() <= 0.5);
                }
                assert!((premultiplied[3] as f64 - 255.0 * a).abs() <= 0.5);
            }
        }
    }
    assert!(empty > 0 && full > 0 && partial > 0);
}

#[test]
fn one_sample_per_pixel_is_the_plain_render() {
    let scene = sphere_scene(40, 30, 4.0, 3.0);
    for m in ["gpu:f32:robust", "cpu:f64:robust"] {
        let plain = render::render(&scene, mode(m), gpu_for(mode(m)), None).unwrap();
        let x = supersample(&scene, m, 1);
        let images = match x.clone() {
            AnyImages::F32(i) => AnyImages::F32(Images {
                coverage: None,
                ..i
            }),
            AnyImages::F64(i) => AnyImages::F64(Images {
                coverage: None,
                ..i
            }),
        };
        assert_eq!(images, plain, "{m}");
        let ids: Vec<i32> = match &plain {
            AnyImages::F32(i) => i.id.clone(),
            AnyImages::F64(i) => i.id.clone(),
        };
        let alpha: Vec<f32> = ids.iter().map(|&id| f32::from(id != MISS)).collect();
        assert_eq!(cov(&x).alpha, alpha);
    }
}

#[test]
fn reduce_of_a_rendered_fine_image_matches_supersample() {
    // supersample() is render at s times the size, then reduce(): check the pieces agree.
    let scene = sphere_scene(20, 15, 4.0, 3.0);
    let mut fine_scene = scene.clone();
    fine_scene.camera.resolution = [60, 45];
    let fine: Images<f32> =
        match render::render(&fine_scene, mode("gpu:f32:robust"), Some(gpu()), None) {
            Ok(AnyImages::F32(i)) => i,
            other => panic!("{other:?}"),
        };
    let direct = supersample::reduce(&fine, 3);
    assert_eq!(
        supersample(&scene, "gpu:f32:robust", 9),
        AnyImages::F32(direct)
    );
}

// 6. Error of N spp against a high-spp f64 reference.

fn course_at(name: &str, resolution: [u32; 2]) -> Scene {
    let mut scene = common::course_scene(name);
    scene.camera.resolution = resolution;
    scene
}

#[test]
fn alpha_error_decreases_with_more_samples() {
    let spps = [1, 4, 16];
    let reference = mode("cpu:f64:robust");
    let cases = [
        (
            "sphere (orthographic, r = 1.3)",
            sphere_scene(64, 48, 4.0, 3.0),
        ),
        ("course triangle", course_at("triangle", [64, 36])),
        (
            "course sphere-packing",
            course_at("sphere-packing", [64, 36]),
        ),
    ];
    for (name, scene) in cases {
        let rows = supersample::spp_errors(
            &scene,
            mode("gpu:f32:robust"),
            &spps,
            reference,
            256,
            Some(gpu()),
        )
        .unwrap();
        let [nx, ny] = scene.camera.resolution;
        println!("{name}, {nx}x{ny}, gpu:f32:robust against cpu:f64:robust at 256 spp:");
        println!("| spp | alpha mean abs | alpha max abs | id mismatch | time (s) |");
        for r in &rows {
            println!(
                "| {} | {:.5} | {:.4} | {:.4} | {:.3} |",
                r.spp, r.alpha_mean_abs, r.alpha_max_abs, r.id_mismatch, r.time_s
            );
        }
        if name.starts_with("sphere") {
            let e: Vec<f64> = rows.iter().map(|r| r.alpha_mean_abs).collect();
            assert!(e[0] > e[1] && e[1] > e[2], "{name}: {e:?}");
            assert!(e[2] > 0.0 && e[2] < e[0] / 4.0, "{name}: {e:?}");
        }
    }
}
