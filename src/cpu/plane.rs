//! Mirror of shaders/plane.wgsl: ray/plane intersection.

use super::types::{Plane, Ray, no_hit};
use crate::math::{Real, Vec3, dot};

pub fn intersect_plane<T: Real>(ray: &Ray<T>, plane: &Plane<T>, min_t: T) -> T {
    let denominator = dot(ray.direction, plane.normal);
    // A ray parallel to the plane never meets it (and dividing by zero would make inf/NaN).
    if denominator == T::ZERO {
        return no_hit();
    }
    let t = dot(plane.point - ray.origin, plane.normal) / denominator;
    if t >= min_t {
        return t;
    }
    no_hit()
}

/// The stored (unit) normal, on both sides of the plane.
pub fn plane_normal<T: Real>(plane: &Plane<T>) -> Vec3<T> {
    plane.normal
}
