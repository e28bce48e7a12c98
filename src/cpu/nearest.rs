//! Mirror of shaders/nearest.wgsl: the nearest hit over every primitive (brute force), or the
//! planes by brute force and the rest through the BVH (src/cpu/traverse.rs).

pub(crate) use super::hit::{Hit, KIND_PLANE, KIND_SPHERE, KIND_TRIANGLE, NO_INSTANCE, is_closer};
use super::plane::{intersect_plane, plane_normal};
use super::sphere::{intersect_sphere, sphere_normal};
use super::traverse::traverse_bvh;
use super::triangle::{intersect_triangle, plane_t, triangle_normal, triangle_uv, unit_normal};
use crate::kernel::types::{Ray, instance_normal, instance_ray, mirrors, shear_of, t_far};
use crate::math::{Real, Vec3};
use crate::prepare::Primitives;

/// Keeps primitive `index` of a kind (`objects`: the kind's object ids) as the nearest hit if
/// its `t` is closer (brute force: ties by object id, then index).
pub(crate) fn keep<T: Real>(t: T, kind: u32, index: usize, objects: &[u32], best: &mut Hit<T>) {
    let object = objects[index];
    if is_closer(t, object, index as u32, best) {
        *best = Hit {
            t,
            object: object as i32,
            kind,
            index: index as u32,
            instance: NO_INSTANCE,
        };
    }
}

pub(crate) fn nearest_hit<T: Real, const ROBUST: bool>(
    ray: &Ray<T>,
    min_t: T,
    prims: &Primitives<T>,
) -> Hit<T> {
    nearest_hit_before::<T, ROBUST>(ray, min_t, t_far(), prims)
}

/// The nearest hit of what is tested before the BVH (the planes; the spheres where there is
/// no BVH), `t_max` where there is none.
pub(crate) fn before_bvh<T: Real, const ROBUST: bool>(
    ray: &Ray<T>,
    min_t: T,
    t_max: T,
    prims: &Primitives<T>,
) -> Hit<T> {
    let mut best = Hit {
        t: t_max,
        object: -1,
        kind: 0,
        index: 0,
        instance: NO_INSTANCE,
    };
    if prims.bvh.is_none() {
        nearest_sphere::<T, ROBUST>(ray, min_t, prims, &mut best);
    }
    for (k, plane) in prims.planes.iter().enumerate() {
        let t = intersect_plane::<T, ROBUST>(ray, plane, min_t);
        keep(t, KIND_PLANE, k, &prims.plane_objects, &mut best);
    }
    best
}

/// The nearest hit, searching no box that starts beyond `t_max` (shadow rays,
/// [`super::shade`]'s `occluded`): the nearest one where it is before t_max, and may be any
/// hit where none is.
pub(crate) fn nearest_hit_before<T: Real, const ROBUST: bool>(
    ray: &Ray<T>,
    min_t: T,
    t_max: T,
    prims: &Primitives<T>,
) -> Hit<T> {
    let mut best = before_bvh::<T, ROBUST>(ray, min_t, t_max, prims);
    match &prims.bvh {
        None => nearest_triangle::<T, ROBUST>(ray, min_t, prims, &mut best),
        Some(bvh) => traverse_bvh::<T, ROBUST>(ray, min_t, prims, &bvh.nodes, &mut best),
    }
    best
}

fn nearest_sphere<T: Real, const ROBUST: bool>(
    ray: &Ray<T>,
    min_t: T,
    prims: &Primitives<T>,
    best: &mut Hit<T>,
) {
    for (k, sphere) in prims.spheres.iter().enumerate() {
        let t = intersect_sphere::<T, ROBUST>(ray, sphere, min_t);
        keep(t, KIND_SPHERE, k, &prims.sphere_objects, best);
    }
}

fn nearest_triangle<T: Real, const ROBUST: bool>(
    ray: &Ray<T>,
    min_t: T,
    prims: &Primitives<T>,
    best: &mut Hit<T>,
) {
    let shear = shear_of(ray.direction);
    for (k, tri) in prims.triangles.iter().enumerate() {
        let t = intersect_triangle::<T, ROBUST>(ray, &shear, tri, min_t);
        keep(t, KIND_TRIANGLE, k, &prims.triangle_objects, best);
    }
}

/// The normal of the nearest hit, computed once rather than for every candidate.
pub(crate) fn hit_normal<T: Real, const ROBUST: bool>(
    ray: &Ray<T>,
    hit: &Hit<T>,
    prims: &Primitives<T>,
) -> Vec3<T> {
    let k = hit.index as usize;
    match hit.kind {
        KIND_SPHERE => sphere_normal::<T, ROBUST>(ray, hit.t, &prims.spheres[k]),
        KIND_PLANE => plane_normal(&prims.planes[k]),
        _ => placed_normal::<T, ROBUST>(
            hit,
            triangle_normal::<T, ROBUST>(&prims.triangles[k]),
            prims,
        ),
    }
}

/// The normal `n` of the triangle `hit` hit, in the kernel's coordinates: as it is, or where an
/// instance places the triangle, moved out of its mesh's coordinates (`placed_normal`).
fn placed_normal<T: Real, const ROBUST: bool>(
    hit: &Hit<T>,
    n: Vec3<T>,
    prims: &Primitives<T>,
) -> Vec3<T> {
    match hit.instance {
        NO_INSTANCE => n,
        k => unit_normal::<T, ROBUST>(instance_normal(n, &prims.instances[k as usize])),
    }
}

/// The hit primitive's index among the primitives of its kind in the scene's order (the BVH
/// stores spheres and triangles in its own order).
pub(crate) fn primitive_key<T: Real>(hit: &Hit<T>, prims: &Primitives<T>) -> u32 {
    match hit.kind {
        KIND_SPHERE => prims.sphere_key(hit.index),
        KIND_PLANE => hit.index,
        _ => prims.triangle_key(hit.index),
    }
}

/// A ray list's view of its nearest hit (`HitDetails` in WGSL): the normal, the t it reports
/// (a robust triangle hit's recomputed from its plane, [`plane_t`]; decisions keep the test's)
/// and the barycentrics of a triangle (zero on spheres and planes).
pub(crate) struct HitDetails<T> {
    pub normal: Vec3<T>,
    pub t: T,
    pub uv: [T; 2],
}

pub(crate) fn hit_details<T: Real, const ROBUST: bool>(
    ray: &Ray<T>,
    hit: &Hit<T>,
    prims: &Primitives<T>,
) -> HitDetails<T> {
    if hit.kind != KIND_TRIANGLE {
        return HitDetails {
            normal: hit_normal::<T, ROBUST>(ray, hit, prims),
            t: hit.t,
            uv: [T::ZERO; 2],
        };
    }
    let tri = &prims.triangles[hit.index as usize];
    // Barycentrics and t are the same in an instance's mesh coordinates.
    let ray = &match hit.instance {
        NO_INSTANCE => *ray,
        k => instance_ray(ray, &prims.instances[k as usize]),
    };
    HitDetails {
        normal: placed_normal::<T, ROBUST>(hit, triangle_normal::<T, ROBUST>(tri), prims),
        t: if ROBUST {
            plane_t(ray, tri, hit.t)
        } else {
            hit.t
        },
        uv: placed_uv(
            hit,
            triangle_uv::<T, ROBUST>(ray, &shear_of(ray.direction), tri),
            prims,
        ),
    }
}

/// The barycentrics `uv` of the triangle `hit` hit as the flattened scene's (`placed_uv`): an
/// instance that mirrors swaps its triangles' last two corners, so u and v trade places.
fn placed_uv<T: Real>(hit: &Hit<T>, [u, v]: [T; 2], prims: &Primitives<T>) -> [T; 2] {
    match hit.instance {
        k if k != NO_INSTANCE && mirrors(&prims.instances[k as usize]) => [v, u],
        _ => [u, v],
    }
}
