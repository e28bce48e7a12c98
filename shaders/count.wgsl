// Counting query (COUNT, ray lists): how many times a ray crosses a surface from min_t on, over
// every primitive, through the BVH where there is one (no culling: every box the ray meets is
// opened, in any order). CPU mirror: src/cpu/count.rs.
#import types
#import bindings
#if BVH
#import traverse
#endif
#if SPHERES
#import sphere
#endif
#if PLANES
#import plane
#endif
#if TRIANGLES
#import triangle
#endif

fn hit_count(t: real) -> u32 {
    return select(0u, 1u, t != NO_HIT);
}

fn count_crossings(ray: Ray, min_t: real) -> u32 {
    var n = 0u;
    let shear = shear_of(ray.direction);
#if PLANES
    for (var k = 0u; k < plane_count(); k++) {
        n += hit_count(intersect_plane(ray, planes[k], min_t));
    }
#endif
#if BVH
    n += count_in_bvh(ray, shear, min_t);
#else
#if SPHERES
    n += count_spheres(ray, min_t, 0u, params.sphere_count);
#endif
#if TRIANGLES
    n += count_triangles(ray, shear, min_t, 0u, params.triangle_count);
#endif
#endif
    return n;
}

#if SPHERES
fn count_spheres(ray: Ray, min_t: real, first: u32, count: u32) -> u32 {
    var n = 0u;
    for (var k = first; k < first + count; k++) {
        n += sphere_crossings(ray, sphere_at(k), min_t);
    }
    return n;
}
#endif

#if TRIANGLES
fn count_triangles(ray: Ray, shear: Shear, min_t: real, first: u32, count: u32) -> u32 {
    var n = 0u;
    for (var k = first; k < first + count; k++) {
        n += hit_count(intersect_triangle(ray, shear, triangle_at(k), min_t));
    }
    return n;
}
#endif

#if BVH
fn count_leaf(ray: Ray, shear: Shear, min_t: real, first: u32, count: u32) -> u32 {
    let n = leaf_len(count);
    if ((count & SPHERE_LEAF) != 0u) {
#if SPHERES
        return count_spheres(ray, min_t, first, n);
#endif
    } else {
#if TRIANGLES
        return count_triangles(ray, shear, min_t, first, n);
#endif
    }
    return 0u;
}

fn count_in_bvh(ray: Ray, shear: Shear, min_t: real) -> u32 {
    let ri = ray_inverse(ray);
    var stack: array<u32, BVH_STACK>;
    var sp = 0u;
    var node = 0u;
    var n = 0u;
    loop {
        let v = visit(node, ray, ri, min_t, T_FAR);
        let hit0 = v.t0 != NO_HIT;
        let hit1 = v.t1 != NO_HIT;
        let inner0 = hit0 && (v.reference0 & LEAF_BIT) == 0u;
        let inner1 = hit1 && (v.reference1 & LEAF_BIT) == 0u;
        if (hit0 && !inner0) {
            n += count_leaf(ray, shear, min_t, v.reference0 & ~LEAF_BIT, v.count0);
        }
        if (hit1 && !inner1) {
            n += count_leaf(ray, shear, min_t, v.reference1 & ~LEAF_BIT, v.count1);
        }
        if (inner0 && inner1) {
            stack[sp] = v.reference1;
            sp++;
            node = v.reference0;
        } else if (inner0) {
            node = v.reference0;
        } else if (inner1) {
            node = v.reference1;
        } else if (sp > 0u) {
            sp--;
            node = stack[sp];
        } else {
            break;
        }
    }
    return n;
}
#endif
