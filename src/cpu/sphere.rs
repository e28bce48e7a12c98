//! Mirror of shaders/sphere.wgsl: ray/sphere intersection, the lecture's quadratic.

use super::types::{Ray, Sphere, no_hit};
use crate::math::{Real, Vec3, dot};

/// The near root if it is at or beyond `min_t`, else the far root, else [`no_hit`].
pub fn intersect_sphere<T: Real>(ray: &Ray<T>, sphere: &Sphere<T>, min_t: T) -> T {
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
pub fn sphere_normal<T: Real>(ray: &Ray<T>, t: T, sphere: &Sphere<T>) -> Vec3<T> {
    let p = ray.origin + ray.direction * t;
    (p - sphere.center) / sphere.radius
}
