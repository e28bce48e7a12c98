//! Mirror of shaders/plane.wgsl: ray/plane intersection.

use crate::kernel::types::{Plane, Ray, is_beyond, no_hit};
use crate::math::{Real, Vec3, dot, length};

pub(crate) fn intersect_plane<T: Real, const ROBUST: bool>(
    ray: &Ray<T>,
    plane: &Plane<T>,
    min_t: T,
) -> T {
    if ROBUST {
        intersect_plane_robust(ray, plane, min_t)
    } else {
        intersect_plane_textbook(ray, plane, min_t)
    }
}

/// Point-normal form with a parallel cutoff: within the dot product's rounding error the sign
/// of d.n, and so whether the ray meets the plane, is not known.
pub(crate) fn intersect_plane_robust<T: Real>(ray: &Ray<T>, plane: &Plane<T>, min_t: T) -> T {
    let denominator = dot(ray.direction, plane.normal);
    if denominator.abs() <= T::from_f64(4.0) * T::EPS * length(ray.direction) {
        return no_hit();
    }
    let t = dot(plane.point - ray.origin, plane.normal) / denominator;
    if is_beyond(t, min_t) {
        return t;
    }
    no_hit()
}

pub(crate) fn intersect_plane_textbook<T: Real>(ray: &Ray<T>, plane: &Plane<T>, min_t: T) -> T {
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
pub(crate) fn plane_normal<T: Real>(plane: &Plane<T>) -> Vec3<T> {
    plane.normal
}
