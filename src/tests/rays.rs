//! Casting a caller's rays (`raycast::rays`): the GPU kernel's ray lists against the CPU
//! reference bit for bit, exact answers on simple geometry, the counting and occlusion
//! queries, adaptive precision, and bad input.

use super::common;

use common::Target;
use common::{Rng, f32_hits, gpu, indexed, moved_along, pinhole_rays, random_scene, sphere_mesh};
use raycast::math::{Vec3, cross, dot, length, normalize};
use raycast::rays::{AnyHits, Hits, INVALID_ID, Ray, RayList, coherent, one_origin};
use raycast::render::Mode;

fn mode(s: &str) -> Mode {
    s.parse().unwrap()
}

/// Rays from random points of the scene's box in random directions, some from the centre of
/// the closed mesh, and the camera's eye.
fn random_rays(rng: &mut Rng, n: usize) -> Vec<Ray> {
    (0..n)
        .map(|k| {
            let origin = match k % 4 {
                0 => [0.0, 0.0, 7.0],
                _ => rng.point(-3.0, 3.0),
            };
            let mut direction = rng.point(-1.0, 1.0);
            if k % 4 == 0 {
                direction[2] = -1.0;
            }
            Ray {
                origin: origin.into(),
                direction: direction.into(),
            }
        })
        .collect()
}

fn f64_hits(h: AnyHits) -> Hits<f64> {
    match h {
        AnyHits::F64(h) => h,
        AnyHits::F32(_) => panic!("an f64 cast returned f32 hits"),
    }
}

/// The GPU's f32 ray lists reproduce the CPU reference bit for bit (t, id, primitive,
/// barycentrics, normal, counts), robust and textbook, through the BVH and by brute force. In
/// f64 the decisions are the same and the numbers within 1e-14 relative: lavapipe's f64
/// division is not correctly rounded (it differs from the CPU's in the last bits).
#[test]
fn gpu_rays_equal_cpu_rays_bit_for_bit() {
    let gpu = gpu();
    for seed in 0..4 {
        let scene = Target::from_scene(random_scene(seed, [4, 4]));
        let rays = random_rays(&mut Rng(100 + seed), 3000);
        for algorithm in ["robust", "textbook"] {
            for precision in ["f32", "f64"] {
                let on = |device: &str| {
                    let m = mode(&format!("{device}:{precision}:{algorithm}"));
                    let hits = scene.cast(Some(gpu), m, &rays).unwrap();
                    let count = scene.count(Some(gpu), m, &rays).unwrap();
                    (hits, count)
                };
                let (gpu_hits, gpu_count) = on("gpu");
                let (cpu_hits, cpu_count) = on("cpu");
                let label = format!("seed {seed}, {precision}, {algorithm}");
                assert_eq!(gpu_count, cpu_count, "counts, {label}");
                let hit = gpu_hits.id().iter().filter(|&&id| id >= 0).count();
                assert!(hit > 100 && hit < 2900, "{hit} of 3000 rays hit ({label})");
                match (gpu_hits, cpu_hits) {
                    (AnyHits::F32(g), AnyHits::F32(c)) => assert_same(&g, &c, &label),
                    (AnyHits::F64(g), AnyHits::F64(c)) => assert_close(&g, &c, &label),
                    _ => panic!("precisions differ ({label})"),
                }
            }
        }
    }
}

fn assert_same<T: raycast::math::Real>(g: &Hits<T>, c: &Hits<T>, label: &str) {
    assert_eq!(g.id.len(), c.id.len(), "{label}");
    for k in 0..g.id.len() {
        let get = |h: &Hits<T>| (h.id[k], h.t[k], h.primitive[k], h.uv[k], h.normal[k]);
        assert_eq!(get(g), get(c), "ray {k}, {label}");
    }
}

fn assert_close(g: &Hits<f64>, c: &Hits<f64>, label: &str) {
    assert_eq!((&g.id, &g.primitive), (&c.id, &c.primitive), "{label}");
    for k in 0..g.id.len() {
        let numbers = |h: &Hits<f64>| {
            let [u, v] = h.uv[k];
            let [x, y, z] = h.normal[k];
            [h.t[k], u, v, x, y, z]
        };
        for (a, b) in numbers(g).into_iter().zip(numbers(c)) {
            let close = a == b || (a - b).abs() <= 1e-14 * a.abs().max(b.abs());
            assert!(
                close,
                "ray {k}, {label}: {:?} and {:?}",
                numbers(g),
                numbers(c)
            );
        }
    }
}

/// The device of `gpu` opened again without host-mapped buffers (lists and outputs go through
/// staging buffers, as on a discrete GPU) and with storage bindings of 64 KiB, so that a few
/// thousand rays take several dispatches.
fn staging_gpu(gpu: &raycast::gpu::Gpu) -> raycast::gpu::Gpu {
    let staging = reopened_gpu(gpu, 1 << 16, wgpu::Features::empty());
    assert!(!staging.host_memory());
    staging
}

/// The device of `gpu` opened again with its optional features but `without` (and so without
/// host-mapped buffers) and storage bindings of `binding` bytes.
fn reopened_gpu(
    gpu: &raycast::gpu::Gpu,
    binding: u64,
    without: wgpu::Features,
) -> raycast::gpu::Gpu {
    let adapter = gpu.adapter.clone();
    let limits = wgpu::Limits {
        max_storage_buffer_binding_size: binding,
        ..adapter.limits()
    };
    let features = adapter.features() & (raycast::gpu::OPTIONAL_FEATURES - without);
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        required_features: features,
        required_limits: limits,
        ..Default::default()
    }))
    .expect("the adapter opens a second device");
    raycast::gpu::Gpu::from_parts(adapter, device, queue)
}

/// Coherent rays are traced in packets: an image's in 4x2 tiles (a width that is no multiple of
/// 8, a short last row), a plain list's 8 at a time; on a device that maps its buffers and on one
/// that copies them through staging buffers in several dispatches. Every way gives the CPU
/// reference's hits, bit for bit in f32, from one origin (`LIST_ORIGIN`) and from many.
#[test]
fn coherent_rays_in_packets_equal_cpu_rays() {
    let gpu = gpu();
    let staging = staging_gpu(gpu);
    // With a plane behind everything, and without one (misses): two scenes, one set of kernels.
    for seed in common::LIST_SEEDS {
        let (scene, background) = common::list_scene(seed);
        let eye = scene.camera.eye.to_array();
        let scene = Target::from_scene(scene);
        let w = 90;
        // 0.002 between neighbours: coherent.
        let mut pinhole = pinhole_rays(eye, w, 50, 0.2);
        pinhole.truncate(pinhole.len() - 7);
        // The same rays, each starting a little way along itself: many origins.
        let along = moved_along(&pinhole, 1e-3);
        for (origins, rays) in [("one origin", &pinhole), ("many origins", &along)] {
            let image = RayList::image(rays, w);
            assert!(coherent(image, 4.0) && coherent(RayList::from(rays), 4.0));
            assert_eq!(one_origin(image), rays == &pinhole, "{origins}");
            for precision in ["f32", "f64"] {
                let cpu = scene
                    .cast(None, mode(&format!("cpu:{precision}")), rays)
                    .unwrap();
                let m = mode(&format!("gpu:{precision}"));
                let ways = [
                    ("image", scene.cast(Some(gpu), m, image).unwrap()),
                    ("list", scene.cast(Some(gpu), m, rays).unwrap()),
                    (
                        "staged image",
                        scene.cast(Some(&staging), m, image).unwrap(),
                    ),
                    ("staged list", scene.cast(Some(&staging), m, rays).unwrap()),
                ];
                for (way, hits) in ways {
                    let label = format!("seed {seed}, {origins}, {precision}, {way}");
                    let hit = hits.id().iter().filter(|&&id| id >= 0).count();
                    assert!(hit > 100, "{hit} rays hit ({label})");
                    assert!(background || hit < rays.len(), "no ray misses ({label})");
                    match (hits, &cpu) {
                        (AnyHits::F32(g), AnyHits::F32(c)) => assert_same(&g, c, &label),
                        (AnyHits::F64(g), AnyHits::F64(c)) => assert_close(&g, c, &label),
                        _ => panic!("precisions differ ({label})"),
                    }
                }
            }
            let adaptive = f32_hits(scene.cast(Some(gpu), mode("gpu:adaptive"), image).unwrap());
            let exact = f64_hits(scene.cast(None, mode("cpu:f64"), rays).unwrap());
            assert_eq!(adaptive.id, exact.id, "seed {seed}, {origins}, adaptive");
        }
    }
}

/// A list starts at one origin where every ray's is the first one's, bit for bit, in f64
/// rays and in f32 rows alike.
#[test]
fn one_origin_of_ray_lists() {
    let rays = pinhole_rays([1.0, -2.0, 0.5], 300, 200, 0.5);
    assert!(one_origin(RayList::from(&rays)));
    assert!(one_origin(RayList::image(&rays, 300)));
    let rows: Vec<[f32; 6]> = rays
        .iter()
        .map(|r| {
            let (o, d) = (r.origin, r.direction);
            [o[0], o[1], o[2], d[0], d[1], d[2]].map(|x| x as f32)
        })
        .collect();
    assert!(one_origin(RayList::from(&rows[..])));
    // One other origin anywhere, even -0 for +0 (other bits), makes many.
    for (k, axis, value) in [(rays.len() - 1, 0, 1.0 + 1e-12), (31_000, 1, -2.0 + 1e-9)] {
        let mut other = rays.clone();
        other[k].origin[axis] = value;
        assert!(!one_origin(RayList::from(&other)), "ray {k}");
        let mut other_rows = rows.clone();
        other_rows[k][axis] = value as f32 + 1e-3;
        assert!(!one_origin(RayList::from(&other_rows[..])), "row {k}");
    }
    let mut signed = pinhole_rays([0.0; 3], 8, 8, 0.5);
    signed[5].origin[2] = -0.0;
    assert!(!one_origin(RayList::from(&signed)));
    assert!(!one_origin(RayList::from(&Vec::new())), "an empty list");
}

/// Rays whose neighbours start far apart, point different ways or zig-zag are not coherent; a
/// camera's are, whether listed flat or as an image.
#[test]
fn coherence_of_ray_lists() {
    // A 640x480 camera's rays 0.001 apart, and a crop of them.
    let camera = pinhole_rays([0.0, 0.0, 5.0], 64, 48, 0.064);
    assert!(coherent(RayList::from(&camera), 2.0));
    assert!(coherent(RayList::image(&camera, 64), 2.0));
    // The same rays zig-zagging by 0.0045 (every other column turned one way, the rest the
    // other): as close together (a packet spreads 0.009 more), but not a smooth progression
    // (second differences 0.018), so a packet's interval would be far wider than its rays' paths.
    let zigzag: Vec<Ray> = camera
        .iter()
        .enumerate()
        .map(|(k, r)| Ray {
            origin: r.origin,
            direction: [
                r.direction[0] + if k % 2 == 0 { 0.0045 } else { -0.0045 },
                r.direction[1],
                r.direction[2],
            ]
            .into(),
        })
        .collect();
    assert!(!coherent(RayList::from(&zigzag), 2.0));
    assert!(!coherent(RayList::image(&zigzag, 64), 2.0));
    // 64x48 over the same field of view: 0.01 apart, 0.07 over 8 in a row, 0.03 over a tile.
    let wide = pinhole_rays([0.0, 0.0, 5.0], 64, 48, 0.64);
    assert!(!coherent(RayList::from(&wide), 2.0));
    assert!(!coherent(RayList::image(&wide, 64), 2.0));
    let random = random_rays(&mut Rng(5), 3000);
    assert!(!coherent(RayList::from(&random), 2.0));
    assert!(!coherent(RayList::image(&random, 50), 2.0));
    // Parallel rays from origins a tenth of the scene apart.
    let spread: Vec<Ray> = (0..800)
        .map(|k| Ray {
            origin: [0.2 * k as f64, 0.0, 5.0].into(),
            direction: [0.0, 0.0, -1.0].into(),
        })
        .collect();
    assert!(!coherent(RayList::from(&spread), 2.0));
    assert!(coherent(RayList::from(&Vec::new()), 2.0), "an empty list");
}

/// A unit sphere at the origin: t, normal, counts and occlusion have exact answers.
#[test]
fn sphere_answers_are_exact() {
    let gpu = gpu();
    let mut scene = Target::new();
    let id = scene.add_sphere([0.0, 0.0, 0.0], 1.0).unwrap();
    let outside = Ray {
        origin: [0.0, 0.0, 5.0].into(),
        direction: [0.0, 0.0, -2.0].into(),
    };
    let inside = Ray {
        origin: [0.0, 0.0, 0.0].into(),
        direction: [0.0, 4.0, 0.0].into(),
    };
    let away = Ray {
        origin: [0.0, 0.0, 5.0].into(),
        direction: [0.0, 0.0, 1.0].into(),
    };
    let rays = [outside, inside, away];
    for m in ["gpu:f32", "gpu:f64", "gpu:adaptive", "cpu:f32", "cpu:f64"] {
        let hits = scene.cast(Some(gpu), mode(m), &rays).unwrap();
        assert_eq!(hits.id(), [id as i32, id as i32, -1], "{m}");
        // t in units of the direction's length: 4 units away at 2 per t, 1 unit at 4 per t.
        assert_eq!(hits.t_f64()[..2], [2.0, 0.25], "{m}");
        assert_eq!(hits.t_f64()[2], f64::INFINITY, "{m}");
        let counts = scene.count(Some(gpu), mode(m), &rays).unwrap();
        assert_eq!(counts, [2, 1, 0], "{m}");
        let shadow = |near, far| {
            scene
                .occluded(Some(gpu), mode(m), &rays, near, far)
                .unwrap()
        };
        assert_eq!(shadow(0.0, 1.9), [false, true, false], "{m}");
        assert_eq!(shadow(0.0, 2.0), [true, true, false], "{m}");
        // From beyond the near side, the far side (t = 3) is what remains.
        assert_eq!(shadow(2.5, 2.9), [false, false, false], "{m}");
        assert_eq!(shadow(2.5, 3.0), [true, false, false], "{m}");
    }
    let AnyHits::F64(h) = scene.cast(Some(gpu), mode("gpu:f64"), &rays).unwrap() else {
        panic!("f64 hits expected");
    };
    assert_eq!(h.normal[0], [0.0, 0.0, 1.0]);
    assert_eq!(h.normal[1], [0.0, 1.0, 0.0]);
    assert_eq!(h.primitive[..], [0, 0, INVALID_ID]);
}

/// The GPU's occlusion kernel (one word a ray) answers as its nearest hit does: a ray is
/// occluded exactly when its nearest hit from `t_near` on has `t <= t_far`, also where `t_far`
/// is a hit's t, or one f64 ulp either side of it (which f32's `t_far` must round down for).
#[test]
fn occlusion_kernel_answers_as_the_nearest_hit() {
    let gpu = gpu();
    let scene = Target::from_scene(random_scene(7, [4, 4]));
    let rays = random_rays(&mut Rng(77), 2000);
    // f32, whose t_far is rounded down (f64's is exact; sphere_answers_are_exact covers it).
    for m in ["gpu:f32"] {
        let hits = scene.cast(Some(gpu), mode(m), &rays).unwrap();
        let (id, t) = (hits.id(), hits.t_f64());
        let hit_ts: Vec<f64> = (0..rays.len())
            .filter(|&k| id[k] != -1)
            .map(|k| t[k])
            .collect();
        assert!(hit_ts.len() > 100, "{m}: {} hits", hit_ts.len());
        let mut t_fars = vec![0.0, 1.0, f64::INFINITY];
        for &th in hit_ts.iter().step_by(hit_ts.len() / 12) {
            t_fars.extend([th, th.next_down(), th.next_up()]);
        }
        for t_far in t_fars {
            let by_hits: Vec<bool> = (0..rays.len())
                .map(|k| id[k] != -1 && t[k] <= t_far)
                .collect();
            let occluded = scene
                .occluded(Some(gpu), mode(m), &rays, 0.0, t_far)
                .unwrap();
            assert!(occluded == by_hits, "{m}, t_far {t_far}");
        }
    }
}

/// Meshes from memory: the object id add_mesh returns, the triangle's index within its mesh,
/// and barycentrics that are exact where the numbers are.
#[test]
fn mesh_hits_name_their_triangle_and_barycentrics() {
    let gpu = gpu();
    let mut scene = Target::new();
    let sphere = scene.add_sphere([5.0, 5.0, 5.0], 0.5).unwrap();
    let vertices = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
    ];
    let mesh = scene
        .add_mesh(common::dvec3s(&vertices), &[[0, 1, 2], [1, 3, 2]])
        .unwrap();
    assert_eq!((sphere, mesh), (0, 1));
    let down = |x, y| Ray {
        origin: [x, y, 1.0].into(),
        direction: [0.0, 0.0, -1.0].into(),
    };
    let rays = [down(0.25, 0.5), down(0.75, 0.5), down(2.0, 2.0)];
    for m in [
        "gpu:f32",
        "gpu:f64",
        "cpu:f32",
        "cpu:f64",
        "gpu:f32:textbook",
    ] {
        let h = f64_of(scene.cast(Some(gpu), mode(m), &rays).unwrap());
        assert_eq!(h.id, [1, 1, -1], "{m}");
        assert_eq!(h.primitive, [0, 1, INVALID_ID], "{m}");
        assert_eq!(h.t[..2], [1.0, 1.0], "{m}");
        // (0.25, 0.5) = 0.25 a + 0.25 b + 0.5 c; (0.75, 0.5) of (b, d, c) = 0.5 b + 0.25 d +
        // 0.25 c.
        assert_eq!(h.uv[..2], [[0.25, 0.5], [0.25, 0.25]], "{m}");
        assert_eq!(h.normal[..2], [[0.0, 0.0, 1.0]; 2], "{m}");
    }
}

/// Any hits widened to f64.
fn f64_of(h: AnyHits) -> Hits<f64> {
    match h {
        AnyHits::F64(h) => h,
        AnyHits::F32(h) => Hits {
            t: h.t.iter().map(|&x| x as f64).collect(),
            id: h.id,
            primitive: h.primitive,
            uv: h.uv.iter().map(|u| u.map(f64::from)).collect(),
            normal: h.normal.iter().map(|n| n.map(f64::from)).collect(),
            count: h.count,
        },
    }
}

/// On a closed mesh (every edge shared) the barycentrics rebuild the hit point, and the count
/// of surfaces crossed is odd from inside and even from outside.
#[test]
fn closed_mesh_barycentrics_and_parity() {
    let gpu = gpu();
    let triangles = sphere_mesh([0.5, -0.25, 0.0], 1.0, 24, 16);
    let (vertices, indices) = indexed(&triangles);
    let mut scene = Target::new();
    scene.add_mesh(common::dvec3s(&vertices), &indices).unwrap();
    let mut rng = Rng(7);
    let from = |origin: [f64; 3], rng: &mut Rng| Ray {
        origin: origin.into(),
        direction: rng.point(-1.0, 1.0).into(),
    };
    let inside: Vec<Ray> = (0..500)
        .map(|_| from([0.5, -0.25, 0.1], &mut rng))
        .collect();
    let outside: Vec<Ray> = (0..500).map(|_| from([3.0, 2.0, -1.0], &mut rng)).collect();
    for m in ["gpu:f32", "gpu:f64", "cpu:f64"] {
        let counts = scene.count(Some(gpu), mode(m), &inside).unwrap();
        assert!(counts.iter().all(|&c| c == 1), "{m}: {counts:?}");
        let counts = scene.count(Some(gpu), mode(m), &outside).unwrap();
        assert!(counts.iter().all(|&c| c % 2 == 0), "{m}: {counts:?}");
        assert!(counts.contains(&2), "{m}: no outside ray hits");
        let h = f64_of(scene.cast(Some(gpu), mode(m), &inside).unwrap());
        for (k, ray) in inside.iter().enumerate() {
            let [a, b, c] = triangles[h.primitive[k] as usize];
            let [u, v] = h.uv[k];
            let p = a * (1.0 - u - v) + b * u + c * v;
            for axis in 0..3 {
                let along = ray.origin[axis] + h.t[k] * ray.direction[axis];
                let e = (along - p.to_array()[axis]).abs();
                assert!(e < 1e-5, "{m}: ray {k}: hit point off by {e}");
            }
        }
    }
}

/// Adaptive rays decide hit/miss and id as f64 does, on every ray.
#[test]
fn adaptive_rays_decide_as_f64() {
    let gpu = gpu();
    for seed in 0..3 {
        let scene = Target::from_scene(random_scene(seed, [4, 4]));
        let rays = random_rays(&mut Rng(200 + seed), 4000);
        let adaptive = f32_hits(scene.cast(Some(gpu), mode("gpu:adaptive"), &rays).unwrap());
        let exact = f64_hits(scene.cast(Some(gpu), mode("cpu:f64"), &rays).unwrap());
        assert_eq!(adaptive.id, exact.id, "seed {seed}");
        let cpu = f32_hits(scene.cast(None, mode("cpu:adaptive"), &rays).unwrap());
        assert_eq!(cpu.id, exact.id, "seed {seed}, on the CPU");
    }
}

/// Bad geometry and rays are errors naming what is wrong.
#[test]
fn bad_input_is_an_error_naming_it() {
    let mut scene = Target::new();
    let message = |e: raycast::Error| e.to_string();
    let tri = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let e = scene
        .add_mesh(common::dvec3s(&tri), &[[0, 1, 3]])
        .unwrap_err();
    assert_eq!(
        message(e),
        "triangles[0][2]: index 3 is out of range (3 vertices)"
    );
    let e = scene
        .add_mesh(&[[0.0; 3].into(), [f64::NAN, 0.0, 0.0].into()], &[])
        .unwrap_err();
    assert!(message(e).starts_with("vertices[1]: NaN is not a finite number"));
    assert!(scene.add_sphere([0.0; 3], 0.0).is_err());
    assert!(scene.add_plane([0.0; 3], [0.0; 3]).is_err());
    assert!(scene.is_empty(), "a refused object was kept");
    let zero = Ray {
        origin: [0.0; 3].into(),
        direction: [0.0; 3].into(),
    };
    let e = scene.cast(None, mode("cpu:f64"), &[zero]).unwrap_err();
    assert_eq!(message(e), "rays[0] direction: must not be zero");
    let e = scene
        .occluded(None, mode("cpu:f64"), &[], -1.0, 1.0)
        .unwrap_err();
    assert!(message(e).starts_with("tnear: "));
}

/// An empty scene: every ray misses, on both devices; no rays, no hits.
#[test]
fn empty_scene_misses() {
    let scene = Target::new();
    let ray = Ray {
        origin: [0.0; 3].into(),
        direction: [1.0, 0.0, 0.0].into(),
    };
    for m in ["gpu:f32", "cpu:f64"] {
        let hits = scene.cast(Some(gpu()), mode(m), &[ray; 3]).unwrap();
        assert_eq!(hits.id(), [-1; 3]);
        assert_eq!(scene.count(Some(gpu()), mode(m), &[ray]).unwrap(), [0]);
        assert!(
            scene
                .cast(Some(gpu()), mode(m), &[])
                .unwrap()
                .id()
                .is_empty()
        );
    }
}

/// A hit's t keeps f32 accuracy at grazing angles: on a mesh and rays given in f32 (as numpy
/// arrays usually are), near the origin and far from it, every f32 t of a hit at cos < 0.02
/// between ray and triangle is within three f32 roundings (3 * 2^-24 relative) of the f64
/// cast's on the same numbers (whose own error, about 2^-53 / cos, is negligible). The
/// watertight test's t alone is far off at such angles; this needs the plane's t
/// (`plane_t`) and coordinates reaching the kernel unrounded (the kernel's eye).
#[test]
fn grazing_hits_keep_f32_accuracy() {
    let gpu = gpu();
    let f32_point = |p: [f64; 3]| p.map(|x| x as f32 as f64);
    for centre in [[0.3, -0.2, 0.1], [1.0e4, 2.5e3, -7.0e2]] {
        let triangles = sphere_mesh(centre, 1.0, 64, 48);
        let (vertices, indices) = indexed(&triangles);
        let vertices: Vec<[f64; 3]> = vertices.into_iter().map(f32_point).collect();
        let mut scene = Target::new();
        scene.add_mesh(common::dvec3s(&vertices), &indices).unwrap();
        let mut rng = Rng(11);
        let rays: Vec<Ray> = (0..4000)
            .map(|_| {
                // At a random point of a random facet, from outside, nearly in its plane.
                let [a, b, c] = indices[(rng.next_u64() % indices.len() as u64) as usize]
                    .map(|k| Vec3::from_array(vertices[k as usize]));
                let normal = normalize(cross(b - a, c - a));
                let (u, v) = (rng.range(0.05, 0.9), rng.range(0.05, 0.9));
                let (u, v) = if u + v > 0.95 {
                    (0.95 - v, 0.95 - u)
                } else {
                    (u, v)
                };
                let at = a + (b - a) * u + (c - a) * v;
                let along = normalize(cross(normal, Vec3::from_array(rng.point(-1.0, 1.0))));
                let d = normalize(along - normal * rng.range(0.0005, 0.02));
                Ray {
                    origin: f32_point((at - d * 3.0).to_array()).into(),
                    direction: f32_point(d.to_array()).into(),
                }
            })
            .collect();
        let exact = f64_hits(scene.cast(None, mode("cpu:f64"), &rays).unwrap());
        for device in ["gpu", "cpu"] {
            let m = mode(&format!("{device}:f32"));
            let h = f32_hits(scene.cast(Some(gpu), m, &rays).unwrap());
            let mut grazing = 0;
            for (k, ray) in rays.iter().enumerate() {
                if h.id[k] < 0 || h.primitive[k] != exact.primitive[k] {
                    continue;
                }
                let d = Vec3::from_array(ray.direction.into());
                let n = Vec3::from_array(exact.normal[k]);
                if dot(d, n).abs() >= 0.02 * length(d) {
                    continue;
                }
                grazing += 1;
                let rel = (h.t[k] as f64 - exact.t[k]).abs() / exact.t[k];
                assert!(
                    rel <= 3.0 * 2f64.powi(-24),
                    "{device} centre {centre:?} ray {k}: t {} vs {} ({rel:e} relative)",
                    h.t[k],
                    exact.t[k]
                );
            }
            assert!(
                grazing >= 200,
                "{device} {centre:?}: {grazing} grazing hits"
            );
        }
    }
}

/// Rows of six f32s (numpy's float32, read without a copy) cast exactly as the same rays in
/// f64, as a list and as an image, on the GPU and the CPU.
#[test]
fn f32_rows_equal_their_f64_rays() {
    let gpu = gpu();
    let scene = Target::from_scene(random_scene(3, [4, 4]));
    let rows: Vec<[f32; 6]> = random_rays(&mut Rng(9), 2000)
        .iter()
        .map(|r| {
            let [x, y, z] = r.origin.to_array().map(|v| v as f32);
            let [dx, dy, dz] = r.direction.to_array().map(|v| v as f32);
            [x, y, z, dx, dy, dz]
        })
        .collect();
    let rays: Vec<Ray> = rows
        .iter()
        .map(|r| Ray {
            origin: [r[0], r[1], r[2]].map(f64::from).into(),
            direction: [r[3], r[4], r[5]].map(f64::from).into(),
        })
        .collect();
    for m in ["gpu:f32", "cpu:f32"] {
        let from_rows = f32_hits(scene.cast(Some(gpu), mode(m), &rows[..]).unwrap());
        assert_same(
            &from_rows,
            &f32_hits(scene.cast(Some(gpu), mode(m), &rays).unwrap()),
            m,
        );
        let image = f32_hits(
            scene
                .cast(Some(gpu), mode(m), RayList::image(&rows[..], 40))
                .unwrap(),
        );
        assert_same(&image, &from_rows, m);
    }
}

/// Asserts that adaptive precision on the GPU finds exactly the rays CPU f64 finds occluded
/// from `t_near` on; returns how many are.
fn occluded_as_f64(gpu: &raycast::gpu::Gpu, scene: &Target, rays: &[Ray], t_near: f64) -> usize {
    let exact = scene
        .occluded(None, mode("cpu:f64"), rays, t_near, f64::INFINITY)
        .unwrap();
    let adaptive = scene
        .occluded(Some(gpu), mode("gpu:adaptive"), rays, t_near, f64::INFINITY)
        .unwrap();
    let differ = (0..rays.len()).filter(|&k| adaptive[k] != exact[k]).count();
    assert_eq!(differ, 0, "of {} rays", rays.len());
    exact.iter().filter(|&&o| o).count()
}

/// Adaptive precision decides as f64 whether a grazing hit lies beyond the rays' start: rays
/// nearly in a triangle's plane (cos 2e-4 to 1e-2), started within some hundred EPS of the
/// hit, where the f32 test's t is off by up to about 1 / cos EPS. With the condition factor of
/// t taken as 1, some of these are called certain and decided against f64.
#[test]
fn adaptive_grazing_starts_decide_as_f64() {
    let gpu = gpu();
    let mut rng = Rng(3);
    let eps = f64::from(f32::EPSILON);
    let mut near = 0;
    for _ in 0..40 {
        let v: Vec<[f64; 3]> = (0..3)
            .map(|_| rng.point(-1.0, 1.0).map(|x| x as f32 as f64))
            .collect();
        let mut scene = Target::new();
        scene.add_mesh(common::dvec3s(&v), &[[0, 1, 2]]).unwrap();
        let [a, b, c] = [0, 1, 2].map(|k| Vec3::from_array(v[k]));
        let normal = normalize(cross(b - a, c - a));
        let at = a + (b - a) * 0.3 + (c - a) * 0.3;
        let rays: Vec<Ray> = (0..600)
            .map(|k| {
                let along = normalize(cross(normal, Vec3::from_array(rng.point(-1.0, 1.0))));
                let d = normalize(along - normal * rng.range(0.0002, 0.01));
                let offset = [-600.0, -200.0, -50.0, 50.0, 200.0, 600.0][k % 6] * eps;
                Ray {
                    origin: (at - d * (2.0 * (1.0 + offset)))
                        .to_array()
                        .map(|x| x as f32 as f64)
                        .into(),
                    direction: d.to_array().map(|x| x as f32 as f64).into(),
                }
            })
            .collect();
        near += occluded_as_f64(gpu, &scene, &rays, 2.0);
    }
    // Both sides of the start: some hits beyond it, some before.
    assert!(near > 2000 && near < 22000, "{near} of 24000 occluded");
}

/// A point 40 from the origin, not representable in f32, where the scenes of the tests below
/// put a small object; each adds another 100 away, so that the scene's extent (the kernel's
/// unit) is large and its origin far from the rays.
const FAR_POINT: [f64; 3] = [37.123456789, -12.3456789123, 5.7891234567];

/// Adaptive precision decides as f64 for rays that start next to a small triangle far from the
/// scene's centre (so far from the kernel's origin), aimed within 2e-6 of one of its edges:
/// there the corners' f32 rounding, not seen from the ray's origin, decides the side. An edge
/// bound that ignores the origin's size calls many of these certain, and wrongly.
#[test]
fn adaptive_rays_near_far_triangles_decide_as_f64() {
    let gpu = gpu();
    let mut rng = Rng(5);
    for _ in 0..10 {
        let centre = Vec3::from_array(FAR_POINT);
        let corners: Vec<Vec3<f64>> = (0..3)
            .map(|_| centre + Vec3::from_array(rng.point(-0.01, 0.01)))
            .collect();
        let mut scene = Target::new();
        scene
            .add_mesh(
                &corners
                    .iter()
                    .map(|&c| glam::DVec3::from(c))
                    .collect::<Vec<_>>(),
                &[[0, 1, 2]],
            )
            .unwrap();
        // A second mesh 100 away: the scene's extent, and so the kernel's unit, is large.
        let far = [
            [-60.0, -60.0, -60.0],
            [-60.5, -60.0, -60.0],
            [-60.0, -60.5, -60.0],
        ];
        scene.add_mesh(common::dvec3s(&far), &[[0, 1, 2]]).unwrap();
        let [a, b, c] = [corners[0], corners[1], corners[2]];
        let normal = normalize(cross(b - a, c - a));
        let across = normalize((a + b) * 0.5 - c);
        let rays: Vec<Ray> = (0..2000)
            .map(|_| {
                let on_edge = a + (b - a) * rng.range(0.1, 0.9) + across * rng.range(-2e-6, 2e-6);
                Ray {
                    origin: (on_edge + normal * 1e-3).to_array().into(),
                    direction: (-normal).to_array().into(),
                }
            })
            .collect();
        let hits = occluded_as_f64(gpu, &scene, &rays, 0.0);
        assert!(hits > 400 && hits < 1600, "{hits} of 2000 on the triangle");
    }
}

/// As for triangles: adaptive precision decides as f64 for rays that pass within 3e-6 of the
/// silhouette of a small sphere far from the kernel's origin, starting 2e-3 before it. The
/// sphere's bound must count the origin's size too, or many of these are certain and wrong.
#[test]
fn adaptive_rays_near_far_spheres_decide_as_f64() {
    let gpu = gpu();
    let mut rng = Rng(8);
    let centre = FAR_POINT;
    for _ in 0..10 {
        let radius = 0.01 * rng.range(0.5, 1.0);
        let mut scene = Target::new();
        scene.add_sphere(centre, radius).unwrap();
        scene.add_sphere([-60.0, -60.0, -60.0], 0.5).unwrap();
        let rays: Vec<Ray> = (0..2000)
            .map(|_| {
                let off = radius * (1.0 + rng.range(-3e-6, 3e-6));
                let (sin, cos) = rng.range(0.0, std::f64::consts::TAU).sin_cos();
                Ray {
                    origin: [
                        centre[0] - 2e-3,
                        centre[1] + off * cos,
                        centre[2] + off * sin,
                    ]
                    .into(),
                    direction: [1.0, 0.0, 0.0].into(),
                }
            })
            .collect();
        let hits = occluded_as_f64(gpu, &scene, &rays, 0.0);
        assert!(hits > 400 && hits < 1600, "{hits} of 2000 on the sphere");
    }
}

/// As for triangles and spheres: adaptive precision decides as f64 for rays started 1e-3
/// above a plane far from the kernel's origin, straight at it, from a start near their hit
/// (t_near within 1e-3 relative of it). A condition on t that ignores the origin's size calls
/// many of these certain, and wrongly.
#[test]
fn adaptive_rays_near_far_planes_decide_as_f64() {
    let gpu = gpu();
    let mut rng = Rng(4);
    let point = Vec3::from_array(FAR_POINT);
    let normal = normalize(Vec3::from_array([0.3, 0.5, 0.81]));
    let mut scene = Target::new();
    scene
        .add_plane(point.to_array(), normal.to_array())
        .unwrap();
    scene.add_sphere([-60.0, -60.0, -60.0], 0.5).unwrap();
    let mut occluded = 0;
    for _ in 0..10 {
        let rays: Vec<Ray> = (0..2000)
            .map(|_| {
                let q = Vec3::from_array(rng.point(-0.01, 0.01));
                let in_plane = q - normal * dot(q, normal);
                Ray {
                    origin: (point + in_plane + normal * 1e-3).to_array().into(),
                    direction: (-normal).to_array().into(),
                }
            })
            .collect();
        let t_near = 1e-3 * (1.0 + rng.range(-1e-3, 1e-3));
        occluded += occluded_as_f64(gpu, &scene, &rays, t_near);
    }
    assert!(
        occluded > 2000 && occluded < 18000,
        "{occluded} of 20000 occluded"
    );
}

/// Kernels that load per ray read nodes, and in f32 triangles, as 64-bit words on a device
/// with `SHADER_INT64` (`WIDE_LOADS`, `WIDE_TRIANGLES`): incoherent rays' hits and counts and
/// the closest points to scattered points are then the same bits as with 32-bit loads (the
/// same device without it), and the CPU reference's (f32 robust: the algorithm sets and f64
/// kernels load nodes alike; gpu_rays_equal_cpu_rays_bit_for_bit runs them all). The mesh's
/// triangles lie in several bindings, odd and even ones at each binding's end.
#[test]
fn wide_and_narrow_loads_give_the_same_answers() {
    use raycast::gpu::shader::{Casts, Variant};
    use raycast::math::Float;
    // Bindings of 8 KiB, so that the mesh's triangles take several.
    let wide = reopened_gpu(gpu(), 1 << 13, wgpu::Features::empty());
    let narrow = reopened_gpu(gpu(), 1 << 13, wgpu::Features::SHADER_INT64);
    let per_ray = |g: &raycast::gpu::Gpu, precision| Variant {
        casts: Casts::Rays,
        bvh: true,
        packets: false,
        ..g.variant(precision, raycast::Algorithm::Robust)
    };
    for (precision, defines) in [
        (Float::F32, &["WIDE_LOADS", "WIDE_TRIANGLES"][..]),
        (Float::F64, &["WIDE_LOADS"][..]),
    ] {
        let w = per_ray(&wide, precision).defines();
        let n = per_ray(&narrow, precision).defines();
        assert!(defines.iter().all(|d| w.contains(d)), "{w:?}");
        assert!(!n.iter().any(|d| d.starts_with("WIDE")), "{n:?}");
        assert!(!w.contains(&"WIDE_TRIANGLES") || precision == Float::F32);
    }
    let scene = random_scene(5, [4, 4]);
    let triangles: usize = (scene.objects.iter())
        .map(|o| match o {
            raycast::scene::Object::Soup { triangles, .. } => triangles.len(),
            raycast::scene::Object::Triangle { .. } => 1,
            _ => 0,
        })
        .sum();
    let per_binding = 1 << raycast::gpu::shader::chunk_bits_for(1 << 13, Float::F32);
    assert!(
        triangles > per_binding,
        "{triangles} triangles fit one binding"
    );
    let target = Target::from_scene(scene);
    let rays = common::incoherent_rays(2000, 3.0, 7);
    let points: Vec<glam::DVec3> = rays.iter().map(|r| r.origin).collect();
    let on = |g: &raycast::gpu::Gpu| {
        let m = mode("gpu:f32:robust");
        let hits = f32_hits(target.cast(Some(g), m, &rays).unwrap());
        let count = target.count(Some(g), m, &rays).unwrap();
        let accel = common::commit(Some(g), &target.geometry, m).unwrap();
        (hits, count, accel.closest(&points).unwrap())
    };
    let (wide_hits, wide_count, wide_closest) = on(&wide);
    let (narrow_hits, narrow_count, narrow_closest) = on(&narrow);
    assert_eq!(wide_count, narrow_count, "counts");
    assert_eq!(wide_closest, narrow_closest, "closest points");
    let hit = wide_hits.id.iter().filter(|&&id| id >= 0).count();
    assert!(hit > 200 && hit < 1800, "{hit} of 2000 rays hit");
    assert_same(&wide_hits, &narrow_hits, "wide and narrow");
    let cpu = f32_hits(target.cast(None, mode("cpu:f32:robust"), &rays).unwrap());
    assert_same(&wide_hits, &cpu, "wide against the CPU");
}
