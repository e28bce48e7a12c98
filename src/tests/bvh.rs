//! The BVH finds exactly the hits brute force finds (brute force is the oracle): on the CPU
//! the whole images (id, distance, normal) are equal bit for bit, in f64 and f32 and for both
//! algorithm sets; on the GPU the BVH kernel (with subgroup packets and per ray) gives the same
//! hit/miss and ids as the brute-force kernel, and the same bits as the CPU's BVH traversal in
//! f32.
//!
//! Scenes: seeded random scenes (spheres, triangles, a closed mesh), dense random soups whose
//! boxes overlap heavily, the course bunny, and every scene of `scenes/extremes/`, among them
//! the shared-edge grids and fans where pixel rays pass exactly through edges and vertices
//! (in f32 not the `range-*` scenes, built to leave f32's range).

use super::common;

use std::path::Path;

use common::assert_same_bits;
use raycast::Algorithm::{self, Robust, Textbook};
use raycast::cpu;
use raycast::gpu::shader::{Kinds, Variant};
use raycast::math::{Float, Real, Vec3};
use raycast::prepare::bvh::{Bvh, MAX_DEPTH, Search};
use raycast::scene::{MeshPart, Scene};

/// `n` random small triangles in a cube of side 2 seen from z = 5: boxes overlap in depth, so
/// the traversal's ordering and culling both matter.
fn dense_soup(seed: u64, n: usize, resolution: [u32; 2]) -> Scene {
    let mut rng = common::Rng(seed);
    let triangles: Vec<_> = (0..n)
        .map(|_| {
            let c = rng.point(-1.0, 1.0);
            let corner = |rng: &mut common::Rng| {
                let d = rng.point(-0.15, 0.15);
                glam::DVec3::new(c[0] + d[0], c[1] + d[1], c[2] + d[2])
            };
            [corner(&mut rng), corner(&mut rng), corner(&mut rng)]
        })
        .collect();
    let json = format!(
        r#"{{"camera": {{"eye": [0.3, -0.2, 5], "look": [0, 0, -1], "up": [0, 1, 0],
            "focal_length": 2, "width": 1.2, "height": 0.9, "resolution": {resolution:?}}},
            "objects": [{{"type": "soup", "obj": "a.obj"}}, {{"type": "soup", "obj": "b.obj"}},
                        {{"type": "sphere", "center": [0.2, 0.1, 0], "radius": 0.5}}]}}"#
    );
    let half = n / 2;
    Scene::from_json(&json, Path::new("dense.json"), &mut |p, _| {
        Ok(MeshPart::whole(if p.ends_with("a.obj") {
            triangles[..half].to_vec()
        } else {
            triangles[half..].to_vec()
        }))
    })
    .unwrap()
}

/// Many spheres and nothing else (the BVH's sphere subtree alone).
fn sphere_cloud(seed: u64, n: usize, resolution: [u32; 2]) -> Scene {
    let mut rng = common::Rng(seed);
    let spheres: Vec<String> = (0..n)
        .map(|_| {
            let c = rng.point(-2.0, 2.0);
            format!(
                r#"{{"type": "sphere", "center": {c:?}, "radius": {}}}"#,
                rng.range(0.05, 0.4)
            )
        })
        .collect();
    let json = format!(
        r#"{{"camera": {{"eye": [0, 0, 6], "look": [0, 0, -1], "up": [0, 1, 0],
            "focal_length": 1.5, "width": 1.6, "height": 1.2, "resolution": {resolution:?}}},
            "objects": [{}]}}"#,
        spheres.join(",")
    );
    Scene::from_json(&json, Path::new("spheres.json"), &mut |_, _| unreachable!()).unwrap()
}

/// The extreme scenes built so that f32 overflows or underflows even in kernel units: there
/// f32's box test and intersection tests are both meaningless (and adaptive precision re-casts
/// every such pixel, src/tests/adaptive.rs), so the BVH has nothing exact to agree with.
fn out_of_f32_range(name: &str) -> bool {
    name.starts_with("range-")
}

fn scenes() -> Vec<(String, Scene)> {
    let mut s = Vec::new();
    for seed in 0..6 {
        s.push((
            format!("random-{seed}"),
            common::random_scene(seed, [80, 60]),
        ));
    }
    for seed in 0..3 {
        s.push((format!("dense-{seed}"), dense_soup(seed, 3000, [80, 60])));
    }
    s.push(("spheres".into(), sphere_cloud(7, 300, [80, 60])));
    let mut bunny = common::course_scene("bunny");
    bunny.camera.resolution = [160, 90];
    s.push(("bunny".into(), bunny));
    for (path, scene) in common::extreme_scenes() {
        s.push((common::scene_name(&path), scene));
    }
    s
}

/// The differences between the BVH and the brute-force CPU renders, one line each.
///
/// The one exception allowed: the textbook formulas in f32, on the extreme scenes built to break
/// them, report hits for rays that pass far from a primitive (a sphere 10^4 away, needles),
/// farther than any box margin; the BVH then skips what brute force wrongly hits. Such pixels
/// must be ones where textbook brute force disagrees with the f64 robust reference. And f32
/// renders of the `range-*` scenes, whose arithmetic leaves f32's range (`out_of_f32_range`),
/// are not compared at all.
fn cpu_bvh_differences<T: Real>(name: &str, scene: &Scene, algorithm: Algorithm) -> Vec<String> {
    if T::PRECISION == Float::F32 && out_of_f32_range(name) {
        return Vec::new();
    }
    let bvh = cpu::render_with::<T>(scene, algorithm, Search::Bvh);
    let brute = cpu::render_with::<T>(scene, algorithm, Search::BruteForce);
    if bvh == brute {
        return Vec::new();
    }
    let truth = cpu::render_with::<f64>(scene, Robust, Search::BruteForce);
    let brute_wrong = |k: usize| algorithm == Textbook && brute.id[k] != truth.id[k];
    let differ: Vec<usize> = (0..bvh.len())
        .filter(|&k| bvh.pixel(k) != brute.pixel(k))
        .collect();
    let unexplained = differ.iter().filter(|&&k| !brute_wrong(k)).count();
    if unexplained == 0 {
        eprintln!(
            "{name} {algorithm} {}: {} pixels differ, at each brute force is wrong",
            T::PRECISION,
            differ.len()
        );
        return Vec::new();
    }
    vec![format!(
        "{name} {algorithm} {}: {unexplained} of {} differing pixels unexplained",
        T::PRECISION,
        differ.len()
    )]
}

#[test]
fn cpu_bvh_equals_brute_force_bit_for_bit() {
    let mut failures = Vec::new();
    for (name, scene) in scenes() {
        for algorithm in [Robust, Textbook] {
            failures.extend(cpu_bvh_differences::<f64>(&name, &scene, algorithm));
            failures.extend(cpu_bvh_differences::<f32>(&name, &scene, algorithm));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

// One test per algorithm set, so that the two run side by side.

#[test]
fn gpu_bvh_equals_brute_force_and_the_cpu_traversal_robust() {
    gpu_bvh_equals_brute_force_and_the_cpu_traversal(Robust);
}

#[test]
fn gpu_bvh_equals_brute_force_and_the_cpu_traversal_textbook() {
    gpu_bvh_equals_brute_force_and_the_cpu_traversal(Textbook);
}

fn gpu_bvh_equals_brute_force_and_the_cpu_traversal(algorithm: Algorithm) {
    let gpu = common::gpu();
    // Kernels of every primitive kind, their stack deep enough for any tree and their plane
    // loops to any count, compiled as given: each serves every scene (a compile each; the
    // specialized_kernels tests show they render as the specialized ones do).
    let general = |precision, bvh| Variant {
        kinds: Kinds::ALL,
        bvh,
        rays_from_origin: false,
        as_given: true,
        ..gpu.variant(precision, algorithm)
    };
    for (name, scene) in scenes() {
        // The kernel a render of the scene compiles.
        let bvh32 = Variant {
            bvh: true,
            ..gpu.scene_variant(&scene, Float::F32, algorithm)
        };
        let bvh32 = bvh32.for_rays(scene.camera.pixel_count());
        let bvh32 = super::kernels::gpu_variant::<f32>(gpu, &scene, bvh32).unwrap();
        let brute32 = general(Float::F32, false);
        let brute32 = super::kernels::gpu_variant::<f32>(gpu, &scene, brute32).unwrap();
        // Where the textbook f32 formulas are wrong, as on the CPU (see above).
        let cpu_brute32 = cpu::render_with::<f32>(&scene, algorithm, Search::BruteForce);
        let cpu32 = cpu::render_with::<f32>(&scene, algorithm, Search::Bvh);
        assert_same_bits(
            &bvh32,
            &cpu32,
            &format!("{name} {algorithm}: GPU vs CPU BVH, f32"),
        );
        // Rays traversing one by one find what the subgroup packets found.
        let per_ray = Variant {
            packets: false,
            ..general(Float::F32, true)
        };
        let per_ray = super::kernels::gpu_variant::<f32>(gpu, &scene, per_ray).unwrap();
        assert_same_bits(
            &per_ray,
            &cpu32,
            &format!("{name} {algorithm}: per-ray traversal"),
        );
        // So do the kernels of every number of rays a lane (renders of every size).
        for lane_rays_limit in [2, 4, 8] {
            let lanes = Variant {
                lane_rays_limit,
                ..general(Float::F32, true)
            };
            let lanes = super::kernels::gpu_variant::<f32>(gpu, &scene, lanes).unwrap();
            let what = format!("{name} {algorithm}: at most {lane_rays_limit} rays a lane");
            assert_same_bits(&lanes, &cpu32, &what);
        }
        let what = format!("{name} {algorithm}: GPU vs CPU brute force");
        assert_same_bits(&brute32, &cpu_brute32, &what);
        if algorithm == Robust && !out_of_f32_range(&name) {
            assert_eq!(bvh32.id, brute32.id, "{name} {algorithm} f32");
        }
        let bvh64 = general(Float::F64, true);
        let bvh64 = super::kernels::gpu_variant::<f64>(gpu, &scene, bvh64);
        let brute64 = general(Float::F64, false);
        let brute64 = super::kernels::gpu_variant::<f64>(gpu, &scene, brute64);
        assert_eq!(
            bvh64.unwrap().id,
            brute64.unwrap().id,
            "{name} {algorithm} f64"
        );
    }
}

/// A kernel compiled as given must still fit the scene it renders: a traversal stack shallower
/// than the scene's tree, or a constant plane count other than the scene's, is refused before
/// anything runs (the unchecked kernel relies on the first).
#[test]
fn a_kernel_compiled_as_given_is_refused_where_the_scene_does_not_fit_it() {
    let gpu = common::gpu();
    let scene = dense_soup(1, 3000, [8, 6]);
    let tree = Bvh::build(&scene, Robust);
    let given = Variant {
        bvh: true,
        as_given: true,
        ..gpu.variant(Float::F32, Robust)
    };
    let shallow = Variant {
        bvh_stack: tree.stack_entries() - 1,
        ..given
    };
    let one_plane = Variant { planes: 1, ..given };
    for (variant, what) in [(shallow, "a stack of"), (one_plane, "1 planes")] {
        let e = super::kernels::gpu_variant::<f32>(gpu, &scene, variant).unwrap_err();
        assert!(e.to_string().contains(what), "{e}");
    }
    assert!(super::kernels::gpu_variant::<f32>(gpu, &scene, given).is_ok());
}

#[test]
fn bvh_depth_stays_within_the_traversal_stack() {
    for (name, scene) in scenes() {
        let bvh = Bvh::build(&scene, Robust);
        assert!(bvh.depth() <= MAX_DEPTH, "{name}: depth {}", bvh.depth());
        // What the kernels' stacks are sized to (BVH_STACK: shaders/traverse_ray.wgsl, count.wgsl, closest.wgsl).
        let stack = bvh.stack_entries() as usize;
        assert!(
            stack >= bvh.depth() && stack <= MAX_DEPTH,
            "{name}: stack {stack}"
        );
        let n = raycast::prepare::bvh::bounded_count(&scene);
        assert_eq!(
            bvh.sphere_order.len() + bvh.triangle_order.len(),
            n,
            "{name}"
        );
    }
}

/// The packet traversal's box test (`interval_entry`) skips a box only where every ray's own
/// `box_entry` does, and enters it no later than any of them: seeded packets of 32 rays (from
/// one point, as the camera's, or from several, as a caller's), boxes around points the rays
/// pass at distances from 2^-30 to 2^10 of the box, in f32 and f64.
#[test]
fn packet_intervals_skip_only_boxes_every_ray_misses() {
    fn check<T: Real>(seed: u64) -> (usize, usize) {
        let mut rng = common::Rng(seed);
        let (mut skipped, mut boxes) = (0, 0);
        for packet in 0..400 {
            let shared_origin = packet % 2 == 0;
            let eye = rng.point(-4.0, 4.0);
            let axis = rng.point(-1.0, 1.0);
            let spread = 2f64.powi(-(rng.range(2.0, 12.0) as i32));
            let rays: Vec<_> = (0..32)
                .map(|_| {
                    let o = if shared_origin {
                        eye
                    } else {
                        rng.point(-4.0, 4.0)
                    };
                    let mut d = axis.map(|a| a + spread * rng.range(-1.0, 1.0));
                    if packet % 7 == 3 {
                        d[packet % 3] = 0.0;
                    }
                    let ray = raycast::kernel::types::Ray {
                        origin: Vec3::from_array(o.map(T::from_f64)),
                        direction: Vec3::from_array(d.map(T::from_f64)),
                    };
                    let ri = cpu::traverse::ray_inverse(&ray);
                    (ray, ri)
                })
                .collect();
            let interval = rays
                .iter()
                .map(|(ray, ri)| cpu::traverse::ray_interval(ray, ri))
                .reduce(|a, b| cpu::traverse::join_intervals(&a, &b))
                .unwrap();
            // A zero direction component makes the packet test boxes per ray instead.
            assert_eq!(interval.unbounded, packet % 7 == 3, "packet {packet}");
            if interval.unbounded {
                continue;
            }
            let min_t = T::from_f64(rng.range(0.0, 0.1));
            for _ in 0..64 {
                let (ray, _) = &rays[rng.range(0.0, 32.0) as usize];
                let t = 8.0 * rng.range(0.0, 1.0).powi(3);
                let at = [0, 1, 2].map(|k| {
                    ray.origin.to_array()[k].to_f64() + t * ray.direction.to_array()[k].to_f64()
                });
                let size = 2f64.powi(rng.range(-20.0, 2.0) as i32);
                let off = size * 2f64.powi(rng.range(-30.0, 10.0) as i32);
                let centre = at.map(|x| x + off * rng.range(-1.0, 1.0));
                let lo = centre.map(|x| (x - size * rng.range(0.0, 1.0)) as f32);
                let hi =
                    [0, 1, 2].map(|k| lo[k].max((centre[k] + size * rng.range(0.0, 1.0)) as f32));
                let t_maxes: Vec<T> = rays
                    .iter()
                    .map(|_| {
                        T::from_f64(if rng.range(0.0, 1.0) < 0.5 {
                            3.4e38
                        } else {
                            rng.range(0.0, 9.0)
                        })
                    })
                    .collect();
                let t_max = t_maxes
                    .iter()
                    .fold(T::ZERO, |m, &x| if x > m { x } else { m });
                let packet_t = cpu::traverse::interval_entry(lo, hi, &interval, min_t, t_max);
                boxes += 1;
                skipped += usize::from(packet_t == raycast::kernel::types::no_hit::<T>());
                for ((ray, ri), &ray_max) in rays.iter().zip(&t_maxes) {
                    let ray_t = cpu::traverse::box_entry(lo, hi, ray, ri, min_t, ray_max);
                    if ray_t != raycast::kernel::types::no_hit::<T>() {
                        assert!(
                            packet_t != raycast::kernel::types::no_hit::<T>() && packet_t <= ray_t,
                            "packet {packet}: box {lo:?}..{hi:?} entered by a ray at {ray_t:?}, by the packet at {packet_t:?}"
                        );
                    }
                }
            }
        }
        (skipped, boxes)
    }
    for (skipped, boxes) in [check::<f32>(1), check::<f64>(2)] {
        // Only worth something if the packets do skip boxes (a few: most boxes lie around
        // points on the rays) and enter others.
        assert!(
            skipped * 20 > boxes && skipped < boxes,
            "{skipped} of {boxes} boxes skipped"
        );
    }
}

/// The packet traversal's mirror (src/cpu/packet.rs, the GPU cost model's) gives every ray of
/// a packet exactly the per-ray traversal's nearest hit (t to the bit, object, kind,
/// primitive), in f32 and f64: for camera packets (8x4 pixels, as a 32-lane subgroup casts
/// them) and for packets of incoherent rays, whose paths diverge most.
#[test]
fn packet_mirror_gives_each_ray_the_per_ray_answer() {
    let scenes = [
        dense_soup(7, 400, [32, 24]),
        sphere_cloud(8, 120, [32, 24]),
        common::course_scene("bunny"),
    ];
    for mut scene in scenes {
        scene.camera.resolution = [32, 24];
        packet_mirror_agrees::<f32>(&scene);
        packet_mirror_agrees::<f64>(&scene);
    }
}

fn packet_mirror_agrees<T: Real>(scene: &Scene) {
    use raycast::cpu::traverse::traverse_bvh;
    let prepared = raycast::prepare::Prepared::<T>::new(scene, Robust, Search::Bvh);
    let (prims, frame) = (&prepared.primitives, &prepared.frame);
    let nodes = &prepared.bvh().unwrap().nodes;
    let camera = (0..24 * 32).map(|k| {
        let (tile, lane) = (k / 32, k % 32);
        let i = (tile / 4) * 4 + lane / 8;
        let j = (tile % 4) * 8 + lane % 8;
        raycast::kernel::frame::camera_ray(frame, i as u32, j as u32)
    });
    let rays: Vec<_> = camera.chain(incoherent_rays::<T>(3, 256)).collect();
    let start = |r| {
        cpu::nearest::before_bvh::<T, true>(r, frame.min_t, raycast::kernel::types::t_far(), prims)
    };
    for packet in rays.chunks(32) {
        let mut together: Vec<_> = packet.iter().map(start).collect();
        cpu::packet::traverse_bvh_packet::<T, true>(
            packet,
            frame.min_t,
            prims,
            nodes,
            &mut together,
            &mut (),
        );
        for (ray, hit) in packet.iter().zip(&together) {
            let mut alone = start(ray);
            traverse_bvh::<T, true>(ray, frame.min_t, prims, nodes, &mut alone);
            assert_eq!(
                (hit.t.to_f64().to_bits(), hit.object, hit.kind, hit.index),
                (
                    alone.t.to_f64().to_bits(),
                    alone.object,
                    alone.kind,
                    alone.index
                ),
                "{ray:?}"
            );
        }
    }
}

/// On lavapipe, a CPU adapter, a render goes in packets where its rays are many for the
/// scene's spheres and triangles (at least `packet_rays_per_primitive` a primitive: the
/// crossover measured on the tori), ray by ray where they are fewer; packets asked for are
/// taken either way. Both traversals give the same bits (the tests above).
#[test]
fn lavapipe_casts_in_packets_only_with_enough_rays_a_primitive() {
    let gpu = common::gpu();
    let per_primitive = gpu.info().packet_rays_per_primitive;
    let per_primitive = per_primitive.expect("lavapipe takes packets by default");
    let scene = |rays: u32| dense_soup(7, 10_000, [rays, 1]);
    let primitives = raycast::prepare::bvh::bounded_count(&scene(1));
    let threshold = (per_primitive * primitives as f64).ceil() as u32;
    let uses_packets = |rays: u32, tuning: raycast::Tuning| {
        let scene = scene(rays);
        let variant = gpu.scene_variant(&scene, Float::F32, Robust);
        tuning.apply(variant, &scene, gpu).unwrap().uses_packets()
    };
    let asked = raycast::Tuning {
        packets: Some(true),
        ..Default::default()
    };
    assert!(uses_packets(threshold, Default::default()));
    assert!(!uses_packets(threshold - 1, Default::default()));
    assert!(uses_packets(threshold - 1, asked));
}

/// The compressed 8-wide tree (#62) finds what the binary tree finds, bit for bit (t, object,
/// primitive), in f32 and f64: camera rays and incoherent rays through dense soups, the course
/// bunny and the extreme scenes, their triangles and planes; every primitive is named by
/// exactly one leaf.
#[test]
fn the_wide_tree_finds_the_binary_trees_hits() {
    let mut scenes = vec![
        dense_soup(7, 400, [32, 24]),
        dense_soup(11, 3000, [32, 24]),
        common::course_scene("bunny"),
    ];
    scenes.extend(common::extreme_scenes().into_iter().map(|(_, s)| s));
    // Their triangles: the wide tree holds no spheres.
    for scene in &mut scenes {
        (scene.objects).retain(|o| !matches!(o, raycast::scene::Object::Sphere { .. }));
    }
    scenes.retain(|s| s.primitive_counts()[2] > 0);
    assert!(scenes.len() >= 20, "{} scenes", scenes.len());
    for mut scene in scenes {
        scene.camera.resolution = [32, 24];
        assert!(wide_agrees::<f32>(&scene), "{:?}", scene.camera);
        wide_agrees::<f64>(&scene);
    }
}

/// Whether `scene` has a wide tree, asserting that it agrees with the binary one.
fn wide_agrees<T: Real>(scene: &Scene) -> bool {
    use raycast::cpu::traverse::traverse_bvh;
    use raycast::cpu::wide::traverse_wide;
    use raycast::prepare::wide::WideBvh;
    let prepared = raycast::prepare::Prepared::<T>::new(scene, Robust, Search::Bvh);
    let (prims, frame) = (&prepared.primitives, &prepared.frame);
    let bvh = prepared.bvh().unwrap();
    let Some(wide) = WideBvh::collapse(bvh) else {
        return false;
    };
    let mut named = wide.primitives.clone();
    named.sort_unstable();
    assert!(named.iter().copied().eq(0..prims.triangles.len() as u32));
    let camera = (0..24 * 32).map(|k| raycast::kernel::frame::camera_ray(frame, k / 32, k % 32));
    let start = |r: &raycast::kernel::types::Ray<T>| {
        cpu::nearest::before_bvh::<T, true>(r, frame.min_t, raycast::kernel::types::t_far(), prims)
    };
    for ray in camera.chain(incoherent_rays::<T>(5, 256)) {
        let (mut binary, mut wide_hit) = (start(&ray), start(&ray));
        traverse_bvh::<T, true>(&ray, frame.min_t, prims, &bvh.nodes, &mut binary);
        traverse_wide::<T, true>(&ray, frame.min_t, prims, &wide, &mut wide_hit);
        let key =
            |h: &raycast::cpu::hit::Hit<T>| (h.t.to_f64().to_bits(), h.object, h.kind, h.index);
        assert_eq!(key(&wide_hit), key(&binary), "{ray:?}");
    }
    true
}

/// `n` rays from origins in a cube of side 4 about the origin, directions uniform in a cube
/// (seeded), in the kernel's precision.
fn incoherent_rays<T: Real>(seed: u64, n: usize) -> Vec<raycast::kernel::types::Ray<T>> {
    let mut rng = common::Rng(seed);
    (0..n)
        .map(|_| {
            let o = rng.point(-2.0, 2.0);
            let d = rng.point(-1.0, 1.0);
            raycast::kernel::types::Ray {
                origin: Vec3::from_array(o.map(T::from_f64)),
                direction: Vec3::from_array(d.map(T::from_f64)),
            }
        })
        .collect()
}
