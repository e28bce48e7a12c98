//! Mirror of shaders/count.wgsl: how many times a ray crosses a surface from `min_t` on, over
//! every primitive, through the BVH where there is one (no culling).

use super::plane::intersect_plane;
use super::sphere::sphere_crossings;
use super::traverse::{ray_inverse, visit};
use super::triangle::intersect_triangle;
use crate::kernel::types::{Ray, Shear, no_hit, shear_of, t_far};
use crate::math::Real;
use crate::prepare::Primitives;
use crate::prepare::bvh::{BvhNode, LEAF_BIT, MAX_DEPTH, SPHERE_LEAF, leaf_len};

fn hit_count<T: Real>(t: T) -> u32 {
    u32::from(t != no_hit())
}

pub(crate) fn count_crossings<T: Real, const ROBUST: bool>(
    ray: &Ray<T>,
    min_t: T,
    prims: &Primitives<T>,
) -> u32 {
    let shear = shear_of(ray.direction);
    let mut n: u32 = prims
        .planes
        .iter()
        .map(|plane| hit_count(intersect_plane::<T, ROBUST>(ray, plane, min_t)))
        .sum();
    match &prims.bvh {
        Some(bvh) => n += count_in_bvh::<T, ROBUST>(ray, &shear, min_t, prims, &bvh.nodes),
        None => {
            n += count_spheres::<T, ROBUST>(ray, min_t, prims, 0, prims.spheres.len() as u32);
            n += count_triangles::<T, ROBUST>(
                ray,
                &shear,
                min_t,
                prims,
                0,
                prims.triangles.len() as u32,
            );
        }
    }
    n
}

fn count_spheres<T: Real, const ROBUST: bool>(
    ray: &Ray<T>,
    min_t: T,
    prims: &Primitives<T>,
    first: u32,
    count: u32,
) -> u32 {
    let spheres = &prims.spheres[first as usize..(first + count) as usize];
    spheres
        .iter()
        .map(|s| sphere_crossings::<T, ROBUST>(ray, s, min_t))
        .sum()
}

fn count_triangles<T: Real, const ROBUST: bool>(
    ray: &Ray<T>,
    shear: &Shear<T>,
    min_t: T,
    prims: &Primitives<T>,
    first: u32,
    count: u32,
) -> u32 {
    let triangles = &prims.triangles[first as usize..(first + count) as usize];
    triangles
        .iter()
        .map(|tri| hit_count(intersect_triangle::<T, ROBUST>(ray, shear, tri, min_t)))
        .sum()
}

fn count_leaf<T: Real, const ROBUST: bool>(
    ray: &Ray<T>,
    shear: &Shear<T>,
    min_t: T,
    prims: &Primitives<T>,
    first: u32,
    count: u32,
) -> u32 {
    let n = leaf_len(count);
    if count & SPHERE_LEAF != 0 {
        count_spheres::<T, ROBUST>(ray, min_t, prims, first, n)
    } else {
        count_triangles::<T, ROBUST>(ray, shear, min_t, prims, first, n)
    }
}

fn count_in_bvh<T: Real, const ROBUST: bool>(
    ray: &Ray<T>,
    shear: &Shear<T>,
    min_t: T,
    prims: &Primitives<T>,
    nodes: &[BvhNode],
) -> u32 {
    let mut n = 0;
    for_each_leaf(ray, min_t, nodes, |first, count| {
        n += count_leaf::<T, ROBUST>(ray, shear, min_t, prims, first, count);
    });
    n
}

/// Calls `leaf(first, count)` for every leaf whose box the ray meets from `min_t` on, in no
/// particular order (every box the ray meets is opened).
pub(crate) fn for_each_leaf<T: Real>(
    ray: &Ray<T>,
    min_t: T,
    nodes: &[BvhNode],
    mut leaf: impl FnMut(u32, u32),
) {
    let ri = ray_inverse(ray);
    let mut stack = [0u32; MAX_DEPTH];
    let mut sp = 0;
    let mut node = 0u32;
    loop {
        let v = visit(nodes, node, ray, &ri, min_t, t_far());
        let hit0 = v.t0 != no_hit();
        let hit1 = v.t1 != no_hit();
        let inner0 = hit0 && v.reference0 & LEAF_BIT == 0;
        let inner1 = hit1 && v.reference1 & LEAF_BIT == 0;
        if hit0 && !inner0 {
            leaf(v.reference0 & !LEAF_BIT, v.count0);
        }
        if hit1 && !inner1 {
            leaf(v.reference1 & !LEAF_BIT, v.count1);
        }
        if inner0 && inner1 {
            stack[sp] = v.reference1;
            sp += 1;
            node = v.reference0;
        } else if inner0 {
            node = v.reference0;
        } else if inner1 {
            node = v.reference1;
        } else if sp > 0 {
            sp -= 1;
            node = stack[sp];
        } else {
            break;
        }
    }
}
