//! Every hit along a ray (`list_intersections`): each primitive the ray crosses from `min_t`
//! on, through the BVH where there is one (every box the ray meets is opened, as in
//! [`super::count`]), in order of t, a crossing through an edge or corner that triangles of one
//! object share listed once. CPU only: the GPU counts crossings (shaders/count.wgsl) but
//! does not list them.

use super::count::for_each_leaf;
use super::hit::{Hit, KIND_PLANE, KIND_SPHERE, KIND_TRIANGLE, NO_INSTANCE};
use super::nearest::{hit_details, primitive_key};
use super::plane::intersect_plane;
use super::sphere::{intersect_sphere, sphere_crossings};
use super::triangle::intersect_triangle;
use crate::kernel::types::{Ray, Shear, no_hit, shear_of, t_tolerance};
use crate::math::{Real, dot};
use crate::prepare::Primitives;
use crate::prepare::bvh::{SPHERE_LEAF, leaf_len};

/// One hit of a ray: its t (in units of the ray's direction), object, primitive key (the index
/// among its kind in the scene's order) and barycentrics.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct EveryHit<T> {
    pub t: T,
    pub object: i32,
    pub kind: u32,
    pub key: u32,
    pub uv: [T; 2],
    /// The ray meets the primitive's front (its normal faces the ray): it enters there.
    pub entering: bool,
}

/// Every hit of `ray` from `min_t` on, ordered by t (ties by object, then primitive).
pub(crate) fn every_hit<T: Real, const ROBUST: bool>(
    ray: &Ray<T>,
    min_t: T,
    prims: &Primitives<T>,
) -> Vec<EveryHit<T>> {
    let shear = shear_of(ray.direction);
    let mut hits = Vec::new();
    let mut add = |t: T, kind: u32, index: u32, objects: &[u32]| {
        if t != no_hit() {
            let hit = Hit {
                t,
                object: objects[index as usize] as i32,
                kind,
                index,
                instance: NO_INSTANCE,
            };
            let details = hit_details::<T, ROBUST>(ray, &hit, prims);
            let key = primitive_key(&hit, prims);
            hits.push(EveryHit {
                t: details.t,
                object: hit.object,
                kind,
                key,
                uv: details.uv,
                entering: dot(details.normal, ray.direction) < T::ZERO,
            });
        }
    };
    for (k, plane) in prims.planes.iter().enumerate() {
        let t = intersect_plane::<T, ROBUST>(ray, plane, min_t);
        add(t, KIND_PLANE, k as u32, &prims.plane_objects);
    }
    // The `n` primitives of one kind from `first`.
    let mut leaf = |first: u32, n: u32, spheres: bool| {
        for k in first..first + n {
            if spheres {
                for t in sphere_hits::<T, ROBUST>(ray, prims, k, min_t) {
                    add(t, KIND_SPHERE, k, &prims.sphere_objects);
                }
            } else {
                let t = triangle_hit::<T, ROBUST>(ray, &shear, prims, k, min_t);
                add(t, KIND_TRIANGLE, k, &prims.triangle_objects);
            }
        }
    };
    match &prims.bvh {
        Some(bvh) => for_each_leaf(ray, min_t, &bvh.nodes, |first, count| {
            leaf(first, leaf_len(count), count & SPHERE_LEAF != 0)
        }),
        None => {
            leaf(0, prims.spheres.len() as u32, true);
            leaf(0, prims.triangles.len() as u32, false);
        }
    }
    hits.sort_by(|a, b| {
        (a.t.to_f64(), a.object, a.key)
            .partial_cmp(&(b.t.to_f64(), b.object, b.key))
            .expect("hit distances are numbers")
    });
    merge_shared_crossings(hits)
}

/// `hits` (ordered by t) with each crossing of an edge or corner that several triangles of one
/// object share listed once, by its first triangle: a triangle hit is left out where one of
/// the same object, met from the same side, was kept within the error bound of a computed t
/// (`t_tolerance`) before it. A ray that only touches the surface at an edge or corner meets
/// triangles there from both sides and keeps one of each: it enters and leaves, and its parity
/// is unchanged. Open3D merges hits of one object at the same t, so that a ray's parity says
/// inside or outside.
fn merge_shared_crossings<T: Real>(hits: Vec<EveryHit<T>>) -> Vec<EveryHit<T>> {
    let mut kept: Vec<EveryHit<T>> = Vec::with_capacity(hits.len());
    for h in hits {
        let shared = kept
            .iter()
            .rev()
            .take_while(|k| h.t - k.t <= t_tolerance::<T>() * h.t.abs());
        let same_crossing = |k: &EveryHit<T>| {
            k.kind == KIND_TRIANGLE && k.object == h.object && k.entering == h.entering
        };
        if h.kind != KIND_TRIANGLE || !shared.into_iter().any(same_crossing) {
            kept.push(h);
        }
    }
    kept
}

fn triangle_hit<T: Real, const ROBUST: bool>(
    ray: &Ray<T>,
    shear: &Shear<T>,
    prims: &Primitives<T>,
    k: u32,
    min_t: T,
) -> T {
    intersect_triangle::<T, ROBUST>(ray, shear, &prims.triangles[k as usize], min_t)
}

/// The ts at which the ray crosses sphere `k` from `min_t` on: none, one (from inside) or two.
fn sphere_hits<T: Real, const ROBUST: bool>(
    ray: &Ray<T>,
    prims: &Primitives<T>,
    k: u32,
    min_t: T,
) -> Vec<T> {
    let sphere = &prims.spheres[k as usize];
    let first = intersect_sphere::<T, ROBUST>(ray, sphere, min_t);
    match sphere_crossings::<T, ROBUST>(ray, sphere, min_t) {
        0 => vec![],
        1 => vec![first],
        _ => {
            let second = intersect_sphere::<T, ROBUST>(ray, sphere, first);
            [first, second]
                .into_iter()
                .filter(|&t| t != no_hit())
                .collect()
        }
    }
}
