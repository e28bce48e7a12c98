//! Mirror of shaders/closest.wgsl: the primitive nearest a query point, planes by brute force
//! and the rest through the BVH where there is one, nearer boxes first. A candidate's [`Hit`]
//! holds its squared distance in `t`, so that the nearest-hit order decides ties.

use super::hit::{Hit, KIND_PLANE, KIND_SPHERE, KIND_TRIANGLE, NO_INSTANCE};
use super::nearest::keep;
use super::traverse::{BVH_STACK, box_slack, is_leaf, keep_ordered};
use crate::kernel::types::{Plane, Sphere, Triangle, t_far};
use crate::math::{Real, Vec3, dot, length, vec3};
use crate::prepare::Primitives;
use crate::prepare::bvh::{BvhNode, LEAF_BIT, SPHERE_LEAF, leaf_len, leaf_object};

/// The point of a primitive nearest a query point, and its barycentric (u, v) on a triangle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Closest<T> {
    pub point: Vec3<T>,
    pub uv: [T; 2],
}

fn ratio<T: Real>(a: T, b: T) -> T {
    if b > T::ZERO { a / b } else { T::ZERO }
}

/// The point of `tri` nearest `p`, by the Voronoi region `p` projects into.
pub(crate) fn closest_on_triangle<T: Real>(p: Vec3<T>, tri: &Triangle<T>) -> Closest<T> {
    let (zero, one) = (T::ZERO, T::ONE);
    let ab = tri.b - tri.a;
    let ac = tri.c - tri.a;
    let ap = p - tri.a;
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if d1 <= zero && d2 <= zero {
        return Closest {
            point: tri.a,
            uv: [zero, zero],
        };
    }
    let bp = p - tri.b;
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if d3 >= zero && d4 <= d3 {
        return Closest {
            point: tri.b,
            uv: [one, zero],
        };
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= zero && d1 >= zero && d3 <= zero {
        let v = ratio(d1, d1 - d3);
        return Closest {
            point: tri.a + ab * v,
            uv: [v, zero],
        };
    }
    let cp = p - tri.c;
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if d6 >= zero && d5 <= d6 {
        return Closest {
            point: tri.c,
            uv: [zero, one],
        };
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= zero && d2 >= zero && d6 <= zero {
        let w = ratio(d2, d2 - d6);
        return Closest {
            point: tri.a + ac * w,
            uv: [zero, w],
        };
    }
    let va = d3 * d6 - d5 * d4;
    let e4 = d4 - d3;
    let e5 = d5 - d6;
    if va <= zero && e4 >= zero && e5 >= zero {
        let w = ratio(e4, e4 + e5);
        return Closest {
            point: tri.b + (tri.c - tri.b) * w,
            uv: [one - w, w],
        };
    }
    let sum = va + vb + vc;
    let v = ratio(vb, sum);
    let w = ratio(vc, sum);
    Closest {
        point: tri.a + ab * v + ac * w,
        uv: [v, w],
    }
}

pub(crate) fn triangle_distance2<T: Real>(p: Vec3<T>, tri: &Triangle<T>) -> T {
    let e = p - closest_on_triangle(p, tri).point;
    dot(e, e)
}

fn closest_on_sphere<T: Real>(p: Vec3<T>, s: &Sphere<T>) -> Closest<T> {
    let d = p - s.center;
    let r = length(d);
    let mut direction = vec3(T::ONE, T::ZERO, T::ZERO);
    if r > T::ZERO {
        direction = d / r;
    }
    Closest {
        point: s.center + direction * s.radius,
        uv: [T::ZERO; 2],
    }
}

fn sphere_distance2<T: Real>(p: Vec3<T>, s: &Sphere<T>) -> T {
    let h = length(p - s.center) - s.radius;
    h * h
}

fn plane_height<T: Real>(p: Vec3<T>, pl: &Plane<T>) -> T {
    dot(p - pl.point, pl.normal)
}

/// The primitive nearest `p`: its Hit, `t` its squared distance (object -1 where there is none).
pub(crate) fn closest_to<T: Real>(p: Vec3<T>, prims: &Primitives<T>) -> Hit<T> {
    let mut best = Hit {
        t: t_far(),
        object: -1,
        kind: 0,
        index: 0,
        instance: NO_INSTANCE,
    };
    for (k, plane) in prims.planes.iter().enumerate() {
        let h = plane_height(p, plane);
        keep(h * h, KIND_PLANE, k, &prims.plane_objects, &mut best);
    }
    match &prims.bvh {
        Some(bvh) => closest_in_bvh(p, prims, &bvh.nodes, &mut best),
        None => {
            for (k, s) in prims.spheres.iter().enumerate() {
                keep(
                    sphere_distance2(p, s),
                    KIND_SPHERE,
                    k,
                    &prims.sphere_objects,
                    &mut best,
                );
            }
            for (k, tri) in prims.triangles.iter().enumerate() {
                let d2 = triangle_distance2(p, tri);
                keep(d2, KIND_TRIANGLE, k, &prims.triangle_objects, &mut best);
            }
        }
    }
    best
}

/// The closest point of `hit`'s primitive to `p`, computed once for the winner.
pub(crate) fn closest_details<T: Real>(
    p: Vec3<T>,
    hit: &Hit<T>,
    prims: &Primitives<T>,
) -> Closest<T> {
    let k = hit.index as usize;
    match hit.kind {
        KIND_SPHERE => closest_on_sphere(p, &prims.spheres[k]),
        KIND_PLANE => {
            let pl = &prims.planes[k];
            Closest {
                point: p - pl.normal * plane_height(p, pl),
                uv: [T::ZERO; 2],
            }
        }
        _ => closest_on_triangle(p, &prims.triangles[k]),
    }
}

fn box_distance2<T: Real>(p: Vec3<T>, lo: [f32; 3], hi: [f32; 3]) -> T {
    let axis = |k: usize| {
        let below = T::from_f64(lo[k] as f64) - p.get(k);
        let above = p.get(k) - T::from_f64(hi[k] as f64);
        below.max(T::ZERO).max(above)
    };
    let d = vec3(axis(0), axis(1), axis(2));
    dot(d, d)
}

fn may_hold<T: Real>(d2: T, best: &Hit<T>) -> bool {
    d2 - d2 * (T::from_f64(4.0) * box_slack()) <= best.t
}

fn closest_in_leaf<T: Real>(
    p: Vec3<T>,
    prims: &Primitives<T>,
    first: u32,
    count: u32,
    best: &mut Hit<T>,
) {
    let n = leaf_len(count);
    let leaf = leaf_object(count);
    if count & SPHERE_LEAF != 0 {
        for k in first..first + n {
            let d2 = sphere_distance2(p, &prims.spheres[k as usize]);
            let key = |i| prims.sphere_key(i);
            keep_ordered(d2, KIND_SPHERE, k, leaf, &prims.sphere_objects, key, best);
        }
    } else {
        for k in first..first + n {
            let d2 = triangle_distance2(p, &prims.triangles[k as usize]);
            let key = |i| prims.triangle_key(i);
            keep_ordered(
                d2,
                KIND_TRIANGLE,
                k,
                leaf,
                &prims.triangle_objects,
                key,
                best,
            );
        }
    }
}

/// Nearest-first traversal, as in WGSL.
fn closest_in_bvh<T: Real>(
    p: Vec3<T>,
    prims: &Primitives<T>,
    nodes: &[BvhNode],
    best: &mut Hit<T>,
) {
    let mut stack_node = [0u32; BVH_STACK];
    let mut stack_d2 = [T::ZERO; BVH_STACK];
    let mut sp = 0;
    let mut node = 0u32;
    loop {
        let n = &nodes[node as usize];
        let d0 = box_distance2(p, n.lo0, n.hi0);
        let d1 = box_distance2(p, n.lo1, n.hi1);
        let leaf0 = is_leaf(n.reference0);
        let leaf1 = is_leaf(n.reference1);
        if leaf0 && may_hold(d0, best) {
            closest_in_leaf(p, prims, n.reference0 & !LEAF_BIT, n.count0, best);
        }
        if leaf1 && may_hold(d1, best) {
            closest_in_leaf(p, prims, n.reference1 & !LEAF_BIT, n.count1, best);
        }
        let go0 = !leaf0 && may_hold(d0, best);
        let go1 = !leaf1 && may_hold(d1, best);
        if go0 && go1 {
            let first0 = d0 <= d1;
            stack_node[sp] = if first0 { n.reference1 } else { n.reference0 };
            stack_d2[sp] = if first0 { d1 } else { d0 };
            sp += 1;
            node = if first0 { n.reference0 } else { n.reference1 };
        } else if go0 {
            node = n.reference0;
        } else if go1 {
            node = n.reference1;
        } else {
            let mut next = false;
            while sp > 0 {
                sp -= 1;
                if may_hold(stack_d2[sp], best) {
                    node = stack_node[sp];
                    next = true;
                    break;
                }
            }
            if !next {
                break;
            }
        }
    }
}
