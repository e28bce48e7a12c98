//! Mirror of shaders/sphere.wgsl: ray/sphere intersection, `ROBUST` choosing the body as
//! `#if ROBUST` does in WGSL.

use crate::kernel::types::{Ray, Sphere, is_beyond, no_hit};
use crate::math::{Real, Vec3, dot, normalize};

pub(crate) fn intersect_sphere<T: Real, const ROBUST: bool>(
    ray: &Ray<T>,
    sphere: &Sphere<T>,
    min_t: T,
) -> T {
    if ROBUST {
        intersect_sphere_robust(ray, sphere, min_t)
    } else {
        intersect_sphere_textbook(ray, sphere, min_t)
    }
}

pub(crate) fn sphere_normal<T: Real, const ROBUST: bool>(
    ray: &Ray<T>,
    t: T,
    sphere: &Sphere<T>,
) -> Vec3<T> {
    if ROBUST {
        sphere_normal_robust(ray, t, sphere)
    } else {
        sphere_normal_textbook(ray, t, sphere)
    }
}

/// The discriminant from the squared distance between the centre and the ray line: error about
/// EPS * r^2 instead of EPS * b^2. The root pair q/a, c/q never subtracts nearly equal numbers.
pub(crate) fn intersect_sphere_robust<T: Real>(ray: &Ray<T>, sphere: &Sphere<T>, min_t: T) -> T {
    let f = ray.origin - sphere.center;
    let d = ray.direction;
    let a = dot(d, d);
    let b = dot(f, d);
    let l = f - d * (b / a);
    let r2 = sphere.radius * sphere.radius;
    let discriminant = a * (r2 - dot(l, l));
    if discriminant < T::ZERO {
        return no_hit();
    }
    let root = discriminant.sqrt();
    let q = -(b + if b < T::ZERO { -root } else { root });
    // Only a ray tangent at its own origin: t = 0, never beyond min_t.
    if q == T::ZERO {
        return no_hit();
    }
    let c = dot(f, f) - r2;
    let t0 = q / a;
    let t1 = c / q;
    let t_near = t0.min(t1);
    let t_far = t0.max(t1);
    if is_beyond(t_near, min_t) {
        return t_near;
    }
    if is_beyond(t_far, min_t) {
        return t_far;
    }
    no_hit()
}

/// Outward unit normal from the perpendicular l and the half-chord along the ray (backwards for
/// the near root, forwards for the far one): no cancellation for far spheres.
pub(crate) fn sphere_normal_robust<T: Real>(ray: &Ray<T>, t: T, sphere: &Sphere<T>) -> Vec3<T> {
    let f = ray.origin - sphere.center;
    let d = ray.direction;
    let a = dot(d, d);
    let b = dot(f, d);
    let l = f - d * (b / a);
    let half_chord = ((sphere.radius * sphere.radius - dot(l, l)).max(T::ZERO) / a).sqrt();
    let along = if t < -b / a { -half_chord } else { half_chord };
    normalize(l + d * along)
}

/// The lecture's quadratic: the near root if it is at or beyond `min_t`, else the far root.
pub(crate) fn intersect_sphere_textbook<T: Real>(ray: &Ray<T>, sphere: &Sphere<T>, min_t: T) -> T {
    let oc = ray.origin - sphere.center;
    let a = dot(ray.direction, ray.direction);
    let b = T::TWO * dot(ray.direction, oc);
    let c = dot(oc, oc) - sphere.radius * sphere.radius;
    let discriminant = b * b - T::from_f64(4.0) * a * c;
    if discriminant < T::ZERO {
        return no_hit();
    }
    let root = discriminant.sqrt();
    let t_near = (-b - root) / (T::TWO * a);
    if t_near >= min_t {
        return t_near;
    }
    let t_far = (-b + root) / (T::TWO * a);
    if t_far >= min_t {
        return t_far;
    }
    no_hit()
}

/// Outward unit normal at the hit point, never flipped (seen from inside it points away).
pub(crate) fn sphere_normal_textbook<T: Real>(ray: &Ray<T>, t: T, sphere: &Sphere<T>) -> Vec3<T> {
    let p = ray.origin + ray.direction * t;
    (p - sphere.center) / sphere.radius
}

/// How many times the ray crosses the sphere's surface from `min_t` on: none where
/// [`intersect_sphere`] finds no hit, else once from inside (the ray's start point) and twice from
/// outside (a tangent ray touches twice at one point).
pub(crate) fn sphere_crossings<T: Real, const ROBUST: bool>(
    ray: &Ray<T>,
    sphere: &Sphere<T>,
    min_t: T,
) -> u32 {
    if intersect_sphere::<T, ROBUST>(ray, sphere, min_t) == crate::kernel::types::no_hit() {
        return 0;
    }
    let f = ray.origin + ray.direction * min_t - sphere.center;
    if dot(f, f) < sphere.radius * sphere.radius {
        1
    } else {
        2
    }
}
