//! Point queries (`Accel::closest`): the CPU reference in f64 against an independent brute
//! force, the GPU kernel against the CPU mirror bit for bit in f32, and f32 against f64 within
//! f32's rounding of the scene's size.

use super::common;

use common::{Rng, gpu, random_scene};
use raycast::math::{Vec3, cross, dot, length};
use raycast::render::Mode;
use raycast::scene::{Object, Scene, Triangle};
use raycast::{Closest, Geometry, Sign};

fn mode(s: &str) -> Mode {
    s.parse().unwrap()
}

fn closest(geometry: &Geometry, mode: Mode, points: &[[f64; 3]]) -> Closest {
    common::commit(Some(gpu()), geometry, mode)
        .unwrap()
        .closest(common::dvec3s(points))
        .unwrap()
}

/// `random_scene(seed / 2)`, for odd seeds without its mesh: spheres, maybe a plane and loose
/// triangles, too few for a BVH (brute force).
fn random_scene_of(seed: u64) -> Scene {
    let mut scene = random_scene(seed / 2, [4, 4]);
    if seed % 2 == 1 {
        scene.objects.retain(|o| !matches!(o, Object::Soup { .. }));
    }
    scene
}

/// Random points around the scene, some on its objects' corners and centres.
fn query_points(scene: &Scene, rng: &mut Rng, n: usize) -> Vec<[f64; 3]> {
    let mut corners = Vec::new();
    for object in &scene.objects {
        match object {
            Object::Sphere { center, .. } => corners.push(center.to_array()),
            Object::Triangle { corners: c } => corners.extend(c.iter().map(|v| v.to_array())),
            Object::Soup { triangles, .. } => corners.push(triangles[3][1].to_array()),
            Object::Plane { point, .. } => corners.push(point.to_array()),
        }
    }
    let mut points: Vec<[f64; 3]> = (0..n).map(|_| rng.point(-4.0, 4.0)).collect();
    points.extend(corners);
    points
}

/// The distance from `p` to segment `a`-`b`, in f64.
fn segment_distance(p: Vec3<f64>, a: Vec3<f64>, b: Vec3<f64>) -> f64 {
    let ab = b - a;
    let s = (dot(p - a, ab) / dot(ab, ab)).clamp(0.0, 1.0);
    length(p - (a + ab * s))
}

/// The distance from `p` to a triangle: to its plane where `p` projects inside it, else to
/// its nearest edge (a method other than the kernel's regions).
fn triangle_distance(p: Vec3<f64>, t: &[glam::DVec3; 3]) -> f64 {
    let t = t.map(Vec3::from);
    let n = cross(t[1] - t[0], t[2] - t[0]);
    let n = n * (1.0 / length(n));
    let h = dot(p - t[0], n);
    let q = p - n * h;
    let inside = (0..3).all(|k| dot(cross(t[(k + 1) % 3] - t[k], q - t[k]), n) >= 0.0);
    if inside {
        return h.abs();
    }
    (0..3)
        .map(|k| segment_distance(p, t[k], t[(k + 1) % 3]))
        .fold(f64::INFINITY, f64::min)
}

/// Every object's distance from `p`.
fn distances(scene: &Scene, p: [f64; 3]) -> Vec<f64> {
    let p = Vec3::from(p);
    let to = |o: &Object| match o {
        Object::Sphere { center, radius } => (length(p - (*center).into()) - radius).abs(),
        Object::Plane { point, normal } => dot(p - (*point).into(), (*normal).into()).abs(),
        Object::Triangle { corners } => triangle_distance(p, corners),
        Object::Soup { triangles, .. } => triangles
            .iter()
            .map(|t| triangle_distance(p, t))
            .fold(f64::INFINITY, f64::min),
    };
    scene.objects.iter().map(to).collect()
}

/// The CPU reference in f64 finds the distance a brute force over every object finds (to
/// 1e-12 of the scene's size), an object at that distance, and a point on it at that distance
/// from the query point; through the BVH and without one.
#[test]
fn closest_points_are_the_brute_force_ones() {
    for seed in 0..4 {
        let scene = random_scene(seed, [4, 4]);
        let geometry = Geometry::from_scene(&scene);
        let points = query_points(&scene, &mut Rng(50 + seed), 400);
        let c = closest(&geometry, mode("cpu:f64:robust"), &points);
        for (k, p) in points.iter().enumerate() {
            let d = distances(&scene, *p);
            let best = d.iter().copied().fold(f64::INFINITY, f64::min);
            let tolerance = 1e-12 * 8.0;
            assert!(
                (c.distance[k] - best).abs() <= tolerance,
                "{p:?}: {} vs {best}",
                c.distance[k]
            );
            let id = c.id[k] as usize;
            assert!(
                (d[id] - best).abs() <= tolerance,
                "{p:?}: object {id} is not closest"
            );
            let to_point = length(Vec3::from(*p) - Vec3::from(c.point[k]));
            assert!(
                (to_point - best).abs() <= tolerance,
                "{p:?}: point {:?}",
                c.point[k]
            );
            assert!((length(Vec3::from(c.normal[k])) - 1.0).abs() < 1e-12);
        }
    }
}

/// The GPU's closest points equal the CPU mirror's bit for bit in f32 (id, primitive, point,
/// distance, barycentrics) and within 1e-14 relative in f64 (lavapipe's f64 division is not
/// correctly rounded); f32 distances are within f32 rounding of the scene's size (8 units) of
/// the f64 ones.
#[test]
fn gpu_closest_points_equal_the_cpu_mirror() {
    for seed in 0..6 {
        let scene = random_scene_of(seed);
        let geometry = Geometry::from_scene(&scene);
        let points = query_points(&scene, &mut Rng(90 + seed), 3000);
        let exact = closest(&geometry, mode("cpu:f64:robust"), &points);
        for precision in ["f32", "f64"] {
            let on = |device: &str| {
                closest(
                    &geometry,
                    mode(&format!("{device}:{precision}:robust")),
                    &points,
                )
            };
            let (g, c) = (on("gpu"), on("cpu"));
            assert_eq!(g.id, c.id, "seed {seed} {precision}");
            assert_eq!(g.primitive, c.primitive, "seed {seed} {precision}");
            if precision == "f32" {
                assert_eq!(g, c, "seed {seed}");
                for (k, p) in points.iter().enumerate() {
                    let error = (c.distance[k] - exact.distance[k]).abs();
                    assert!(error <= 8.0 * 2f64.powi(-21), "{p:?}: {error}");
                }
            } else {
                for (k, p) in points.iter().enumerate() {
                    let close = |a: f64, b: f64| (a - b).abs() <= 1e-14 * a.abs().max(1.0);
                    assert!(close(g.distance[k], c.distance[k]), "{p:?}");
                    assert!((0..3).all(|i| close(g.point[k][i], c.point[k][i])));
                }
            }
        }
    }
}

/// Many scattered points are searched in a spatial order (`prepare::order`): every answer is
/// the one the point gets in a query too small to be reordered, in the caller's order.
#[test]
fn searching_in_a_spatial_order_changes_no_answer() {
    let scene = random_scene_of(0);
    let geometry = Geometry::from_scene(&scene);
    let points = query_points(&scene, &mut Rng(7), 6000);
    assert!(crate::prepare::order::spatial_order(&points).is_some());
    assert!(crate::prepare::order::spatial_order(&points[..1000]).is_none());
    let in_pieces = |mode: Mode| {
        let accel = common::commit(Some(gpu()), &geometry, mode).unwrap();
        let pieces: Vec<Closest> = (points.chunks(1000))
            .map(|c| accel.closest(common::dvec3s(c)).unwrap())
            .collect();
        let mut all = Closest::default();
        for p in pieces {
            all.point.extend(p.point);
            all.distance.extend(p.distance);
            all.id.extend(p.id);
            all.primitive.extend(p.primitive);
            all.uv.extend(p.uv);
            all.normal.extend(p.normal);
        }
        let winding: Vec<f64> = (points.chunks(1000))
            .flat_map(|c| accel.winding_numbers(common::dvec3s(c)).unwrap())
            .collect();
        let parity = Sign::Parity { samples: 3 };
        let inside: Vec<bool> = (points.chunks(1000))
            .flat_map(|c| accel.inside(common::dvec3s(c), parity).unwrap())
            .collect();
        assert_eq!(
            accel.winding_numbers(common::dvec3s(&points)).unwrap(),
            winding
        );
        assert_eq!(
            accel.inside(common::dvec3s(&points), parity).unwrap(),
            inside
        );
        (accel.closest(common::dvec3s(&points)).unwrap(), all)
    };
    for m in ["gpu:f32:robust", "cpu:f32:robust", "cpu:f64:robust"] {
        let (whole, pieces) = in_pieces(mode(m));
        assert_eq!(whole, pieces, "{m}");
    }
}

/// An empty geometry has no closest point: the id is a miss and the distance infinite.
#[test]
fn empty_geometry_has_no_closest_point() {
    for m in ["gpu:f32:robust", "cpu:f64:robust"] {
        let c = closest(&Geometry::new(), mode(m), &[[1.0, 2.0, 3.0]]);
        assert_eq!(c.id, [raycast::images::MISS]);
        assert_eq!(c.distance, [f64::INFINITY]);
    }
}

/// A UV sphere mesh of `slices` x `stacks` about `centre`, as a geometry, and its triangles.
fn uv_sphere(centre: [f64; 3], slices: usize, stacks: usize) -> (Geometry, Vec<Triangle>) {
    let triangles = common::sphere_mesh(centre, 1.0, slices, stacks);
    (common::soup_geometry(&triangles), triangles)
}

/// The solid angle of triangle `t` at `p` over 4 pi, in f64 (Van Oosterom and Strackee).
fn exact_winding(p: Vec3<f64>, triangles: &[Triangle]) -> f64 {
    let one = |t: &Triangle| {
        let [a, b, c] = t.map(|v| Vec3::from(v) - p);
        let (la, lb, lc) = (length(a), length(b), length(c));
        let numerator = dot(a, cross(b, c));
        let denominator = la * lb * lc + dot(a, b) * lc + dot(a, c) * lb + dot(b, c) * la;
        2.0 * numerator.atan2(denominator)
    };
    triangles.iter().map(one).sum::<f64>() / (4.0 * std::f64::consts::PI)
}

/// Points about the unit sphere at `centre`, some 1e-6 to 1e-3 off its mesh's faces.
fn points_near(centre: [f64; 3], triangles: &[Triangle], rng: &mut Rng) -> Vec<[f64; 3]> {
    let mut points: Vec<[f64; 3]> = (0..3000)
        .map(|_| {
            let d = rng.point(-1.6, 1.6);
            [centre[0] + d[0], centre[1] + d[1], centre[2] + d[2]]
        })
        .collect();
    for (k, t) in triangles.iter().enumerate().step_by(3) {
        let t = t.map(Vec3::from);
        let n = cross(t[1] - t[0], t[2] - t[0]);
        let n = n * (1.0 / length(n));
        let on = (t[0] + t[1] + t[2]) * (1.0 / 3.0);
        let offset = [1.1e-6, 1e-5, 1e-3][k % 3] * if k % 2 == 0 { 1.0 } else { -1.0 };
        points.push((on + n * offset).to_array());
    }
    points
}

/// On a closed mesh (a UV sphere, convex: inside is behind every face), the winding number's
/// sign is right at every point further than 1e-6 from the surface, and within 0.02 of 1 or 0
/// (the BVH's far-field error) 0.01 from it; ray parity along (1, 1, 1) agrees wherever its ray grazes no edge (checked
/// here with 3 rays' majority too).
#[test]
fn the_winding_sign_is_right_off_a_closed_mesh() {
    let centre = [0.3, -0.2, 0.1];
    let (geometry, triangles) = uv_sphere(centre, 48, 32);
    let points = points_near(centre, &triangles, &mut Rng(7));
    let accel = raycast::Cpu
        .commit(&geometry, raycast::Precision::F64)
        .unwrap();
    let w = accel.winding_numbers(common::dvec3s(&points)).unwrap();
    let distance = accel.closest(common::dvec3s(&points)).unwrap().distance;
    let inside = |p: &[f64; 3]| {
        let p = Vec3::from(*p);
        triangles
            .iter()
            .map(|t| t.map(Vec3::from))
            .all(|t| dot(cross(t[1] - t[0], t[2] - t[0]), p - t[0]) < 0.0)
    };
    let mut checked = 0;
    let mut largest: f64 = 0.0;
    for (k, p) in points.iter().enumerate() {
        if distance[k] <= 1e-6 {
            continue;
        }
        checked += 1;
        assert_eq!(
            w[k] > 0.5,
            inside(p),
            "{p:?}: w {} at {}",
            w[k],
            distance[k]
        );
        if distance[k] > 1e-2 {
            let expected = if inside(p) { 1.0 } else { 0.0 };
            largest = largest.max((w[k] - expected).abs());
        }
    }
    assert!(checked > 3500, "{checked}");
    assert!(largest < 0.02, "{largest}");
    let for_sign = |sign| accel.inside(common::dvec3s(&points), sign).unwrap();
    let winding = for_sign(raycast::Sign::Winding);
    for samples in [1, 3] {
        let parity = for_sign(raycast::Sign::Parity { samples });
        let differ = (0..points.len()).filter(|&k| distance[k] > 1e-6 && parity[k] != winding[k]);
        assert_eq!(differ.count(), 0, "{samples} rays");
    }
}

/// On an open mesh (the UV sphere without its top cap and a band of its side), the BVH's
/// winding numbers agree with the exact sum in f64 to 0.02, and so on the side of one half
/// wherever the exact number is not within 0.1 of it.
#[test]
fn winding_numbers_of_an_open_mesh_match_the_exact_sum() {
    let centre = [-0.4, 0.2, 0.05];
    let (_, mut triangles) = uv_sphere(centre, 48, 32);
    triangles.retain(|t| {
        let c = (t[0] + t[1] + t[2]) * (1.0 / 3.0) - glam::DVec3::from(centre);
        c.y < 0.7 && !(c.x > 0.5 && c.z.abs() < 0.3)
    });
    let geometry = common::soup_geometry(&triangles);
    let points = points_near(centre, &triangles, &mut Rng(11));
    for device in ["cpu", "gpu"] {
        let w = common::commit(
            Some(gpu()),
            &geometry,
            mode(&format!("{device}:f32:robust")),
        )
        .unwrap()
        .winding_numbers(common::dvec3s(&points))
        .unwrap();
        let mut largest: f64 = 0.0;
        for (k, p) in points.iter().enumerate() {
            let exact = exact_winding(Vec3::from(*p), &triangles);
            largest = largest.max((w[k] - exact).abs());
            if (exact - 0.5).abs() > 0.1 {
                assert_eq!(w[k] > 0.5, exact > 0.5, "{p:?}: {} vs {exact}", w[k]);
            }
        }
        assert!(largest < 0.02, "{largest}");
    }
}

/// Every hit along a ray is listed once, in order of t: as many as `count` counts, the first
/// the nearest hit `intersect` finds, in f32 and f64, through the BVH and by brute force.
#[test]
fn every_hit_lists_what_count_counts() {
    for seed in 0..4 {
        let scene = random_scene_of(seed);
        let geometry = Geometry::from_scene(&scene);
        let mut rng = Rng(300 + seed);
        let rays: Vec<raycast::Ray> = (0..2000)
            .map(|_| raycast::Ray {
                origin: rng.point(-4.0, 4.0).into(),
                direction: rng.direction().into(),
            })
            .collect();
        for m in ["cpu:f64:robust", "gpu:f32:robust", "cpu:f32:textbook"] {
            let accel = common::commit(Some(gpu()), &geometry, mode(m)).unwrap();
            let all = accel.every_hit(&rays[..]).unwrap();
            let counts = accel.count(&rays[..]).unwrap();
            let nearest = accel.intersect(&rays[..]).unwrap();
            assert_eq!(all.ray_splits.len(), rays.len() + 1);
            for (k, ray) in rays.iter().enumerate() {
                let range = all.ray_splits[k]..all.ray_splits[k + 1];
                assert_eq!(range.len(), counts[k] as usize, "{m} {ray:?}");
                assert!(all.ray_id[range.clone()].iter().all(|&r| r as usize == k));
                assert!(
                    all.t[range.clone()].windows(2).all(|w| w[0] <= w[1]),
                    "{m} {ray:?}"
                );
                if let Some(first) = range.clone().next() {
                    assert_eq!(all.id[first], nearest.id()[k], "{m} {ray:?}");
                    assert_eq!(all.t[first], nearest.t_f64()[k], "{m} {ray:?}");
                }
            }
        }
    }
}

/// Bad point queries are refused with the argument named: a NaN point, an even number of
/// parity rays.
#[test]
fn bad_point_queries_name_their_argument() {
    let (geometry, _) = uv_sphere([0.0; 3], 8, 6);
    let accel = raycast::Cpu
        .commit(&geometry, raycast::Precision::F64)
        .unwrap();
    let nan = [[0.0, f64::NAN, 0.0]];
    let message = |e: raycast::Error| e.to_string();
    assert!(message(accel.closest(common::dvec3s(&nan)).unwrap_err()).contains("points[0]"));
    assert!(
        message(accel.winding_numbers(common::dvec3s(&nan)).unwrap_err()).contains("points[0]")
    );
    let even = accel.inside(&[[0.0; 3].into()], raycast::Sign::Parity { samples: 2 });
    assert!(message(even.unwrap_err()).contains("samples"));
}

/// The unit cube as 12 outward-facing triangles, each face split along a diagonal.
fn unit_cube() -> Geometry {
    let (vertices, triangles) = common::unit_cube_mesh();
    let mut geometry = Geometry::new();
    geometry.add_mesh(&vertices, &triangles).unwrap();
    geometry
}

/// A ray through an edge that two triangles share, or along a face's diagonal, crosses the
/// surface once there (Open3D's count on the same rays: 1, 2 and 2), so that parity along
/// (1, 1, 1) puts points inside the cube with x = y inside; a ray that only touches a corner
/// enters and leaves there, so the point it starts from stays outside.
#[test]
fn a_ray_through_a_shared_edge_crosses_once() {
    let cube = unit_cube();
    let rays = [
        ([0.5, 0.5, -1.0], [0.0, 0.0, 1.0]),
        ([1.5, 0.5, 0.5], [-1.0, 0.0, 0.0]),
        ([0.5, 0.5, 0.25], [1.0, 1.0, 1.0]),
        ([-0.25, -0.25, 0.75], [1.0, 1.0, 1.0]),
    ]
    .map(|(origin, direction)| raycast::Ray {
        origin: origin.into(),
        direction: direction.into(),
    });
    for m in ["cpu:f64:robust", "gpu:f32:robust", "cpu:f32:textbook"] {
        let accel = common::commit(Some(gpu()), &cube, mode(m)).unwrap();
        let splits = accel.every_hit(&rays[..]).unwrap().ray_splits;
        assert_eq!(splits, [0, 2, 4, 5, 7], "{m}");
        let points = [
            [0.5, 0.5, 0.25],
            [0.2, 0.2, 0.9],
            [1.5, 1.5, 0.5],
            [-0.25, -0.25, 0.75],
        ];
        let inside = accel
            .inside(
                common::dvec3s(&points),
                raycast::Sign::Parity { samples: 1 },
            )
            .unwrap();
        assert_eq!(inside, [true, true, false, false], "{m}");
    }
}

/// Query points that are all one point reach the kernel that reads one origin for the list
/// (`LIST_ORIGIN`), and give the CPU mirror's answer.
#[test]
fn one_point_many_times_equals_the_cpu_mirror() {
    let scene = random_scene_of(0);
    let geometry = Geometry::from_scene(&scene);
    let points = vec![[0.3, -0.7, 1.1]; 100];
    let on = |device: &str| closest(&geometry, mode(&format!("{device}:f32:robust")), &points);
    assert_eq!(on("gpu"), on("cpu"));
}
