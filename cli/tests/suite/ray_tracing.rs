//! Shade hooks that cast rays (`trace`, `occluded`) and the course's ray tracer built on them
//! (shaders/examples/raytrace.wgsl, `--lit`): against the instructor's renders, against its CPU
//! mirror, and what `trace` and `occluded` find against what the camera's rays find.

use crate::common;

use raycast::Scene;
use raycast::ShadeHook;
use raycast::{AnyImages, Mode, RenderOptions};
use raycast::{Images, MISS};
use raycast_cli::compare::{ColorError, color_error};

/// The ray-tracing scenes the instructor published renders of.
const RENDERED: [&str; 3] = ["sphere-and-plane", "sphere-packing", "bunny"];

fn lit_scene(name: &str) -> Scene {
    Scene::load(&common::repo_path(&format!(
        "scenes/ray-tracing/{name}.json"
    )))
    .unwrap_or_else(|e| panic!("{e}"))
}

/// The instructor's render of `name`, as RGBA with alpha 255.
fn instructors(name: &str) -> Vec<[u8; 4]> {
    let path = common::repo_path(&format!("tests/data/ray-tracing/{name}.png"));
    let rgb = image::open(&path).unwrap().into_rgb8();
    rgb.pixels().map(|p| [p[0], p[1], p[2], 255]).collect()
}

/// `scene` rendered in `mode` with every output and the hook's colours.
fn render(scene: &Scene, mode: &str, hook: &ShadeHook) -> AnyImages {
    let mode: Mode = mode.parse().unwrap();
    let options = RenderOptions {
        shade: Some(hook.clone()),
        ..RenderOptions::default()
    };
    common::render_in(scene, mode, options).unwrap_or_else(|e| panic!("{e}"))
}

fn colours(images: &AnyImages) -> &[[u8; 4]] {
    images.color().expect("a hooked render has colours")
}

/// Saves both pictures and panics with `what` when `ok` fails.
fn check_colours(ok: bool, what: &str, a: &[[u8; 4]], b: &[[u8; 4]], size: [u32; 2]) {
    if !ok {
        let rgb =
            |v: &[[u8; 4]]| -> Vec<u8> { v.iter().flat_map(|p| [p[0], p[1], p[2]]).collect() };
        let name = what.replace([' ', ':', '/'], "-");
        let dir = common::save_failure(&name, &rgb(a), &rgb(b), size[0], size[1], 3);
        panic!("{what}; pictures in {}", dir.display());
    }
}

/// The issue's bar: at least 99.5% of pixels within 2 levels per channel, and a mean absolute
/// difference of at most 0.25 levels.
fn close_to_instructors(e: &ColorError) -> bool {
    e.beyond_2 <= 0.005 && e.mean_abs <= 0.25
}

#[test]
fn lit_gpu_renders_match_the_instructors_in_f32_and_f64() {
    let hook = ShadeHook::raytrace().unwrap();
    for name in RENDERED {
        let scene = lit_scene(name);
        let expected = instructors(name);
        for mode in ["gpu:f32:robust", "gpu:f64:robust"] {
            let images = render(&scene, mode, &hook);
            let e = color_error(colours(&images), &expected);
            check_colours(
                close_to_instructors(&e),
                &format!("{name} {mode}: {e:?}"),
                colours(&images),
                &expected,
                scene.camera.resolution,
            );
        }
    }
}

/// The model in f64 on the CPU is the instructor's: sphere-and-plane's pixels byte for byte,
/// and the other two as close as the issue asks of the GPU.
#[test]
fn the_cpu_reference_in_f64_reproduces_the_instructors_render() {
    let hook = ShadeHook::raytrace().unwrap();
    for name in RENDERED {
        let scene = lit_scene(name);
        let expected = instructors(name);
        let images = render(&scene, "cpu:f64:robust", &hook);
        let e = color_error(colours(&images), &expected);
        let ok = match name {
            "sphere-and-plane" => colours(&images) == expected,
            _ => close_to_instructors(&e),
        };
        check_colours(
            ok,
            &format!("{name} cpu f64: {e:?}"),
            colours(&images),
            &expected,
            scene.camera.resolution,
        );
    }
}

/// The GPU's f32 render and its CPU mirror in f32 run the same arithmetic; only the
/// driver's built-ins, `pow` above all (lavapipe approximates `exp2(y log2 x)`), may differ in
/// the last bits, which moves a pixel by a level where it lands on a level's edge.
#[test]
fn the_gpu_in_f32_agrees_with_its_cpu_mirror() {
    let hook = ShadeHook::raytrace().unwrap();
    for name in RENDERED {
        let scene = lit_scene(name);
        let gpu = render(&scene, "gpu:f32:robust", &hook);
        let cpu = render(&scene, "cpu:f32:robust", &hook);
        let e = color_error(colours(&gpu), colours(&cpu));
        check_colours(
            e.exact >= 0.9999 && e.max <= 2,
            &format!("{name} gpu f32 against cpu f32: {e:?}"),
            colours(&gpu),
            colours(&cpu),
            scene.camera.resolution,
        );
        let (g, c) = (gpu.hook_rays().unwrap(), cpu.hook_rays().unwrap());
        let relative = g.abs_diff(c) as f64 / c as f64;
        assert!(
            relative <= 1e-4,
            "{name}: {g} rays on the GPU, {c} on the CPU"
        );
    }
}

/// A small render of the course's bunny (spheres, planes, a mesh through a BVH).
fn small(name: &str) -> Scene {
    let mut scene = common::course_scene(name);
    scene.camera.resolution = [96, 54];
    scene
}

/// An f32 as the four levels of a colour (`unpack4x8unorm(bitcast<u32>(x))` in a hook).
fn f32_of(rgba: [u8; 4]) -> f32 {
    f32::from_bits(u32::from_le_bytes(rgba))
}

/// Of `n` pixels, how many may see another object when cast again from the hook: the hook's
/// ray has the camera ray's direction normalised and rounded to f32, so a ray grazing an edge
/// may fall on its other side. One in 500.
fn grazing(n: usize) -> usize {
    n / 500
}

/// `trace` from the eye along the camera ray's direction finds what the camera ray found: the
/// same object at the same distance (within the rounding of a normalised direction), but for
/// a few grazing rays.
#[test]
fn trace_along_a_camera_ray_finds_its_hit() {
    let hook = common_hook(
        "fn shade(hit: ShadeHit) -> vec4<f32> {\n\
         \x20   let again = trace(hit.origin, hit.direction, 1e-3);\n\
         \x20   if (again.id != hit.id) {\n\
         \x20       return vec4<f32>(1.0);\n\
         \x20   }\n\
         \x20   return unpack4x8unorm(bitcast<u32>(again.distance));\n\
         }\n",
    );
    assert!(hook.traces);
    for name in ["bunny", "two-spheres-and-plane", "triangle"] {
        let scene = small(name);
        let images = render(&scene, "gpu:f32:robust", &hook);
        let AnyImages::F32(images) = images else {
            unreachable!()
        };
        let (mut hits, mut other) = (0, 0);
        for (k, &rgba) in colours_of(&images).iter().enumerate() {
            if rgba == [255; 4] {
                other += 1;
                continue;
            }
            if images.id[k] == MISS {
                assert_eq!(f32_of(rgba), 0.0, "{name}: pixel {k}");
                continue;
            }
            hits += 1;
            let (again, first) = (f32_of(rgba), images.distance[k]);
            assert!(
                (again - first).abs() <= 4e-6 * first,
                "{name}: pixel {k}: {again} against {first}"
            );
        }
        assert!(hits > 0, "{name}");
        assert!(
            other <= grazing(images.id.len()),
            "{name}: {other} pixels see another object"
        );
        // One ray a pixel, hit or miss.
        assert_eq!(images.hook_rays, Some(images.id.len() as u64), "{name}");
    }
}

/// `occluded` along the camera ray: nothing before its hit, the hit itself just beyond it.
#[test]
fn occluded_sees_the_camera_rays_hit_and_nothing_before_it() {
    let hook = common_hook(
        "fn shade(hit: ShadeHit) -> vec4<f32> {\n\
         \x20   let before = occluded(hit.origin, hit.direction, 1e-3, 0.999 * hit.distance);\n\
         \x20   let through = occluded(hit.origin, hit.direction, 1e-3, 1.001 * hit.distance);\n\
         \x20   let forever = occluded(hit.origin, hit.direction, 1e-3, 3.0e38);\n\
         \x20   return vec4<f32>(f32(before), f32(through), f32(forever), 1.0);\n\
         }\n",
    );
    for name in ["bunny", "two-spheres-and-plane", "sphere-packing"] {
        let scene = small(name);
        let AnyImages::F32(images) = render(&scene, "gpu:f32:robust", &hook) else {
            unreachable!()
        };
        let mut other = Vec::new();
        for (k, &rgba) in colours_of(&images).iter().enumerate() {
            let hit = images.id[k] != MISS;
            let level = |b: bool| if b { 255 } else { 0 };
            // A miss has distance 0: nothing lies before it either.
            if rgba != [0, level(hit), level(hit), 255] {
                other.push((k, images.id[k], rgba));
            }
        }
        assert!(other.len() <= grazing(images.id.len()), "{name}: {other:?}");
        assert_eq!(images.hook_rays, Some(3 * images.id.len() as u64), "{name}");
    }
}

fn colours_of<T>(images: &Images<T>) -> &[[u8; 4]] {
    images
        .color
        .as_deref()
        .expect("a hooked render has colours")
}

/// A hook loaded from its text, written to a file of its own.
fn common_hook(source: &str) -> ShadeHook {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("test-hook.wgsl");
    std::fs::write(&file, source).unwrap();
    ShadeHook::load(&file).unwrap_or_else(|e| panic!("{e}"))
}

/// The ambient-occlusion example casts exactly its 16 rays from every hit and none from a miss.
#[test]
fn every_ray_a_hook_casts_is_counted() {
    let hook = ShadeHook::load(&common::repo_path(
        "shaders/examples/ambient-occlusion.wgsl",
    ))
    .unwrap();
    let scene = small("bunny");
    let AnyImages::F32(images) = render(&scene, "gpu:f32:robust", &hook) else {
        unreachable!()
    };
    let hits = images.id.iter().filter(|&&id| id != MISS).count() as u64;
    assert!(hits > 0);
    assert_eq!(images.hook_rays, Some(16 * hits));
}

/// The scene file's materials, lights and per-object values reach the hook, typed as
/// shaders/hooks.wgsl declares them.
#[test]
fn materials_lights_and_values_reach_the_hook() {
    let scene_json = r#"{
        "camera": {"type": "perspective", "eye": [0, 0, 5], "look": [0, 0, -1], "up": [0, 1, 0],
                   "focal_length": 3, "width": 1.6, "height": 0.9, "resolution": [32, 18]},
        "materials": [
            {"name": "a", "ka": [0.2, 0.4, 0.6], "kd": [0.8, 0.6, 0.4], "ks": [0, 0, 0],
             "km": [0, 0, 0], "phong_exponent": 51},
            {"name": "b", "ka": [1, 0, 1], "kd": [0, 1, 0], "ks": [0, 0, 0], "km": [0, 0, 0],
             "phong_exponent": 1}],
        "lights": [
            {"type": "directional", "direction": [0, 0, -2], "color": [0.4, 0.2, 0.6]},
            {"type": "point", "position": [1, 2, 3], "color": [1, 1, 1]}],
        "objects": [
            {"type": "sphere", "center": [-0.5, 0, 0], "radius": 0.4, "material": "b"},
            {"type": "sphere", "center": [0.5, 0, 0], "radius": 0.4, "values": [0.2, 0.4]},
            {"type": "plane", "point": [0, 0, -1], "normal": [0, 0, 1], "material": "a"}]
    }"#;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.json");
    std::fs::write(&path, scene_json).unwrap();
    let scene = Scene::load(&path).unwrap();
    // Object 0: its material's ka; object 1: its values (no material: all zero); object 2:
    // kd, and the phong exponent / 255 in alpha. Misses: the lights.
    let hook = common_hook(
        "fn shade(hit: ShadeHit) -> vec4<f32> {\n\
         \x20   let m = object_material(hit.id);\n\
         \x20   if (hit.id == 0) { return vec4<f32>(m.ka, 1.0); }\n\
         \x20   if (hit.id == 1) { return object_values(1) + vec4<f32>(m.kd, 0.0) + vec4<f32>(0.0, 0.0, 0.0, 1.0); }\n\
         \x20   if (hit.id == 2) { return vec4<f32>(m.kd, m.phong_exponent / 255.0); }\n\
         \x20   let d = scene_light(0u);\n\
         \x20   let p = scene_light(1u);\n\
         \x20   if (light_count() != 2u || d.kind != LIGHT_DIRECTIONAL || p.kind != LIGHT_POINT) { return vec4<f32>(0.0); }\n\
         \x20   return vec4<f32>(d.color.x, -d.direction.z / 4.0, p.position.y / 4.0, p.color.z);\n\
         }\n",
    );
    assert!(!hook.traces);
    let AnyImages::F32(images) = render(&scene, "gpu:f32:robust", &hook) else {
        unreachable!()
    };
    let level = |x: f32| (x * 255.0).round() as u8;
    let expected = |id: i32| match id {
        0 => [255, 0, 255, 255],
        1 => [level(0.2), level(0.4), 0, 255],
        2 => [level(0.8), level(0.6), level(0.4), 51],
        _ => [level(0.4), level(0.5), level(0.5), 255],
    };
    let mut seen = [false; 4];
    for (k, &rgba) in colours_of(&images).iter().enumerate() {
        let id = images.id[k];
        seen[(id + 1) as usize] = true;
        assert_eq!(rgba, expected(id), "pixel {k}, id {id}");
    }
    // The plane fills the background, so no pixel misses.
    assert_eq!(seen, [false, true, true, true]);
}
