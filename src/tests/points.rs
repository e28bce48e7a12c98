//! Point queries (`Accel::closest`): the CPU reference in f64 against an independent brute
//! force, the GPU kernel against the CPU mirror bit for bit in f32, and f32 against f64 within
//! f32's rounding of the scene's size.

use super::common;

use common::{Rng, gpu, random_scene};
use raycast::math::{Vec3, cross, dot, length};
use raycast::render::Mode;
use raycast::scene::{Object, Scene};
use raycast::{Closest, Geometry};

fn mode(s: &str) -> Mode {
    s.parse().unwrap()
}

fn closest(geometry: &Geometry, mode: Mode, points: &[[f64; 3]]) -> Closest {
    raycast::commit_mode(Some(gpu()), geometry, mode)
        .unwrap()
        .closest(points)
        .unwrap()
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
fn triangle_distance(p: Vec3<f64>, t: &[Vec3<f64>; 3]) -> f64 {
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
        Object::Sphere { center, radius } => (length(p - *center) - radius).abs(),
        Object::Plane { point, normal } => dot(p - *point, *normal).abs(),
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
        let mut scene = random_scene(seed / 2, [4, 4]);
        if seed % 2 == 1 {
            // Spheres, a plane and loose triangles, too few for a BVH: brute force.
            scene.objects.retain(|o| !matches!(o, Object::Soup { .. }));
        }
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

/// An empty geometry has no closest point: the id is a miss and the distance infinite.
#[test]
fn empty_geometry_has_no_closest_point() {
    for m in ["gpu:f32:robust", "cpu:f64:robust"] {
        let c = closest(&Geometry::new(), mode(m), &[[1.0, 2.0, 3.0]]);
        assert_eq!(c.id, [raycast::images::MISS]);
        assert_eq!(c.distance, [f64::INFINITY]);
    }
}
