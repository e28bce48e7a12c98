//! Shade hooks' kernels: a hook that casts no ray compiles none of the machinery, and hooked
//! kernels of every lane count agree.

use super::common;

use std::path::Path;

use raycast::Algorithm::Robust;
use raycast::Scene;
use raycast::ShadeHook;
use raycast::images::{Images, Outputs};

/// A hook that casts no ray compiles none of the machinery: its kernel is a plain hook's
/// (packets where the device has them, no `trace`, no ray counter).
#[test]
fn only_a_hook_that_casts_rays_compiles_them_in() {
    let gpu = common::gpu();
    let scene = common::course_scene("bunny");
    let toon = ShadeHook::load(&common::repo_path("shaders/examples/toon.wgsl")).unwrap();
    let lit = ShadeHook::raytrace().unwrap();
    assert!(!toon.traces && lit.traces);
    let base = gpu.scene_variant(&scene, raycast::math::Float::F32, Robust);
    assert!(base.uses_packets(), "lavapipe has subgroups");
    let variant = |hook: &ShadeHook| {
        base.with_shade(hook.key, hook.traces)
            .with_outputs(Outputs::ALL)
    };
    let plain = variant(&toon);
    assert!(plain.uses_packets());
    assert!(!plain.defines().contains(&"HOOK_RAYS"));
    // The kernel's functions and globals, by name.
    let names = |variant| {
        let source = raycast::gpu::shader::kernel_source(&variant).unwrap();
        let module = naga::front::wgsl::parse_str(&source).unwrap();
        let functions = module.functions.iter().filter_map(|(_, f)| f.name.clone());
        let globals = module
            .global_variables
            .iter()
            .filter_map(|(_, g)| g.name.clone());
        functions.chain(globals).collect::<Vec<String>>()
    };
    let machinery = [
        "trace",
        "occluded",
        "hook_ray",
        "hook_rays",
        "hook_ray_count",
    ];
    let plain_names = names(plain);
    for name in machinery {
        assert!(!plain_names.iter().any(|n| n == name), "{name}");
    }
    let tracing = variant(&lit);
    // Primary rays in packets, and a hook's rays where its whole subgroup casts one, else
    // ray by ray (RAY_BY_RAY), one ray a lane.
    assert!(tracing.defines().contains(&"HOOK_RAYS"));
    assert!(tracing.uses_packets() && tracing.defines().contains(&"RAY_BY_RAY"));
    assert!(!plain.defines().contains(&"RAY_BY_RAY"));
    assert_eq!(tracing.lane_rays(), 1);
    let tracing_names = names(tracing);
    for name in machinery {
        assert!(tracing_names.iter().any(|n| n == name), "{name}");
    }
    // A plain render with the toon hook counts no rays.
    let mut small = scene.clone();
    small.camera.resolution = [96, 54];
    let options = raycast::RenderOptions {
        precision: Some(raycast::Precision::F32),
        shade: Some(toon.clone()),
        ..raycast::RenderOptions::default()
    };
    assert_eq!(gpu.render(&small, &options).unwrap().hook_rays(), None);
}

/// A hooked kernel gives the same colours, ids and surfaces with two, four and eight rays a lane
/// (smaller renders cast fewer, `Variant::for_rays`; the tests above run eight).
#[test]
fn hooked_kernels_of_every_lane_count_agree() {
    let mut scene = common::course_scene("bunny");
    scene.camera.resolution = [96, 54];
    let hook = ShadeHook::load(&common::repo_path("shaders/examples/toon.wgsl")).unwrap();
    let gpu = common::gpu();
    let base = gpu
        .scene_variant(&scene, raycast::math::Float::F32, Robust)
        .with_shade(hook.key, hook.traces)
        .with_outputs(Outputs::ALL);
    let render = |lane_rays_limit| {
        let variant = raycast::gpu::shader::Variant {
            lane_rays_limit,
            ..base
        };
        // Packets of several rays a lane on subgroups of 8 (lavapipe), one ray elsewhere.
        let packets = base.uses_packets() && base.eight_lanes;
        let rays = if packets { lane_rays_limit as u32 } else { 1 };
        assert_eq!(variant.lane_rays(), rays);
        let images: Images<f32> = super::kernels::gpu_variant(gpu, &scene, variant).unwrap();
        images
    };
    let eight = render(8);
    assert!(eight.color.as_ref().is_some_and(|c| c.len() == 96 * 54));
    for limit in [2, 4] {
        let fewer = render(limit);
        let what = format!("at most {limit} rays a lane");
        common::assert_same_bits(&fewer, &eight, &what);
        assert!(fewer.color == eight.color, "{what}");
    }
}

/// A hook's rays cast in packets (where its whole subgroup casts one at the same call) find
/// what they find ray by ray: the course's ray tracer gives the same colours, ids and surfaces,
/// bit for bit, and casts the same rays, as the kernel without packets.
#[test]
fn a_hooks_rays_in_packets_find_what_they_find_ray_by_ray() {
    let path = common::repo_path("scenes/ray-tracing/bunny.json");
    let mut scene = raycast::Scene::load(&path).unwrap();
    scene.camera.resolution = [160, 90];
    let hook = ShadeHook::raytrace().unwrap();
    let gpu = common::gpu();
    let packets = gpu
        .scene_variant(&scene, raycast::math::Float::F32, Robust)
        .with_shade(hook.key, hook.traces)
        .with_outputs(Outputs::ALL);
    assert!(packets.uses_packets() && packets.defines().contains(&"RAY_BY_RAY"));
    let ray_by_ray = raycast::gpu::shader::Variant {
        packets: false,
        ..packets
    };
    let render = |variant| {
        let images: Images<f32> = super::kernels::gpu_variant(gpu, &scene, variant).unwrap();
        images
    };
    let (a, b) = (render(packets), render(ray_by_ray));
    common::assert_same_bits(&a, &b, "packets against ray by ray");
    assert!(a.color.is_some() && a.color == b.color);
    assert!(a.hook_rays.is_some() && a.hook_rays == b.hook_rays);
}

/// The hook sees world coordinates whatever the scene's scale (the kernel works on the scene
/// scaled to its camera's size and scales positions and distances back): a scene scaled by
/// 2^k gives the hook positions and distances 2^k times the unscaled ones, so a hook that
/// tests them against the scaled sphere colours the same pixels at every k.
#[test]
fn hooks_see_world_coordinates_at_every_power_of_two_scale() {
    let json = r#"{"camera": {"eye": [0.75, 0.5, 0.25], "look": [0, 0, -1], "up": [0, 1, 0],
        "focal_length": 0.5, "width": 0.375, "height": 0.25, "resolution": [40, 30]},
        "objects": [{"type": "sphere", "center": [0.75, 0.5, -0.5], "radius": 0.125}]}"#;
    let base = Scene::from_json(json, Path::new("small.json"), &mut |_, _| unreachable!()).unwrap();
    let mut reference = None;
    for k in [-40, -7, 0, 9, 40] {
        let s = 2f64.powi(k);
        // Red where |position - centre| is the radius to 1e-4 of it; green where position is
        // origin + distance * direction to 1e-4 of the distance.
        let hook = ShadeHook::check(
            &format!(
                "fn shade(hit: ShadeHit) -> vec4<f32> {{
    if (hit.id < 0) {{
        return vec4<f32>(0.0);
    }}
    let centre = vec3<f32>({cx:e}, {cy:e}, {cz:e});
    let e = abs(distance(hit.position, centre) - {r:e}) / {r:e};
    let on_ray = distance(hit.position, hit.origin + hit.distance * hit.direction) / hit.distance;
    return vec4<f32>(select(0.0, 1.0, e < 1e-4), select(0.0, 1.0, on_ray < 1e-4), 0.0, 1.0);
}}
",
                cx = 0.75 * s,
                cy = 0.5 * s,
                cz = -0.5 * s,
                r = 0.125 * s,
            ),
            Path::new("test-hook.wgsl"),
        )
        .unwrap();
        let color = Outputs {
            id: false,
            distance: false,
            normal: false,
            color: true,
        };
        let images: Images<f32> = common::gpu_outputs(
            common::gpu(),
            &base.scaled_by_pow2(k),
            Robust,
            color,
            Some(&hook),
        )
        .unwrap();
        let color = images.color.expect("a hooked render has colours");
        let hits = color.iter().filter(|c| c[3] == 255).count();
        assert!(hits > 100, "2^{k}: {hits} hits");
        assert!(
            color
                .iter()
                .all(|c| *c == [255, 255, 0, 255] || *c == [0; 4]),
            "2^{k}: a hit off the sphere or off its ray"
        );
        match &reference {
            None => reference = Some(color),
            Some(r) => assert!(r == &color, "2^{k}: the hook coloured other pixels"),
        }
    }
}
