//! Mirror of shaders/scene.wgsl: the nearest hit over every primitive (brute force).

use super::plane::{intersect_plane, plane_normal};
use super::sphere::{intersect_sphere, sphere_normal};
use super::triangle::{intersect_triangle, triangle_normal};
use super::types::{Primitives, Ray, no_hit, t_far};
use crate::math::{Real, Vec3};

pub const KIND_SPHERE: u32 = 0;
pub const KIND_PLANE: u32 = 1;
pub const KIND_TRIANGLE: u32 = 2;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit<T> {
    pub t: T,
    /// -1: no hit.
    pub object: i32,
    pub kind: u32,
    /// Into the list of its kind.
    pub index: u32,
}

/// Ties in t go to the lower object id, then the lower primitive index, so the answer does not
/// depend on the order primitives are visited.
pub fn is_closer<T: Real>(t: T, object: u32, index: u32, best: &Hit<T>) -> bool {
    if t == no_hit() {
        return false;
    }
    if best.object < 0 || t < best.t {
        return true;
    }
    t == best.t
        && ((object as i32) < best.object || (object as i32 == best.object && index < best.index))
}

pub fn nearest_hit<T: Real, const ROBUST: bool>(
    ray: &Ray<T>,
    min_t: T,
    prims: &Primitives<T>,
) -> Hit<T> {
    let mut best = Hit {
        t: t_far(),
        object: -1,
        kind: 0,
        index: 0,
    };
    for (k, sphere) in prims.spheres.iter().enumerate() {
        let t = intersect_sphere::<T, ROBUST>(ray, sphere, min_t);
        let object = prims.sphere_objects[k];
        if is_closer(t, object, k as u32, &best) {
            best = Hit {
                t,
                object: object as i32,
                kind: KIND_SPHERE,
                index: k as u32,
            };
        }
    }
    for (k, plane) in prims.planes.iter().enumerate() {
        let t = intersect_plane::<T, ROBUST>(ray, plane, min_t);
        let object = prims.plane_objects[k];
        if is_closer(t, object, k as u32, &best) {
            best = Hit {
                t,
                object: object as i32,
                kind: KIND_PLANE,
                index: k as u32,
            };
        }
    }
    for (k, tri) in prims.triangles.iter().enumerate() {
        let t = intersect_triangle::<T, ROBUST>(ray, tri, min_t);
        let object = prims.triangle_objects[k];
        if is_closer(t, object, k as u32, &best) {
            best = Hit {
                t,
                object: object as i32,
                kind: KIND_TRIANGLE,
                index: k as u32,
            };
        }
    }
    best
}

/// The normal of the nearest hit, computed once rather than for every candidate.
pub fn hit_normal<T: Real, const ROBUST: bool>(
    ray: &Ray<T>,
    hit: &Hit<T>,
    prims: &Primitives<T>,
) -> Vec3<T> {
    let k = hit.index as usize;
    match hit.kind {
        KIND_SPHERE => sphere_normal::<T, ROBUST>(ray, hit.t, &prims.spheres[k]),
        KIND_PLANE => plane_normal(&prims.planes[k]),
        _ => triangle_normal::<T, ROBUST>(&prims.triangles[k]),
    }
}
