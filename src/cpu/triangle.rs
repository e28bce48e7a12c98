//! Mirror of shaders/triangle.wgsl: ray/triangle intersection by Cramer's rule.

use super::types::{Ray, Triangle, no_hit};
use crate::math::{Real, Vec3, cross, dot, normalize};

/// Solves origin + t*direction = a + beta*(b - a) + gamma*(c - a) for (beta, gamma, t): the
/// 3x3 system with columns (a - b, a - c, direction) and right-hand side a - origin.
pub fn intersect_triangle<T: Real>(ray: &Ray<T>, tri: &Triangle<T>, min_t: T) -> T {
    let col0 = tri.a - tri.b;
    let col1 = tri.a - tri.c;
    let rhs = tri.a - ray.origin;
    let m = cross(col1, ray.direction);
    let determinant = dot(col0, m);
    // Zero-area triangles and rays in the triangle's plane: no unique solution.
    if determinant == T::ZERO {
        return no_hit();
    }
    let beta = dot(rhs, m) / determinant;
    if beta < T::ZERO {
        return no_hit();
    }
    let q = cross(col0, rhs);
    let gamma = dot(ray.direction, q) / determinant;
    if gamma < T::ZERO || beta + gamma > T::ONE {
        return no_hit();
    }
    let t = -dot(col1, q) / determinant;
    if t >= min_t {
        return t;
    }
    no_hit()
}

/// Unit normal by corner order: normalize((b - a) x (c - a)), never flipped.
pub fn triangle_normal<T: Real>(tri: &Triangle<T>) -> Vec3<T> {
    normalize(cross(tri.b - tri.a, tri.c - tri.a))
}
