// Nearest-hit search: over every primitive (brute force), or the planes by brute force and the
// rest through the BVH (BVH; shaders/traverse.wgsl). CPU mirror: src/cpu/scene.rs.
#import types
#import bindings
#import hit
#if BVH
#import traverse
#endif
#if CERTAINTY
#import certainty
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

// Keeps primitive `index` of a kind (`base`: the kind's offset in `objects`) as the nearest hit
// if its `t` is closer (brute force: ties by object id, then index). With CERTAINTY every
// decision is recorded, misses too.
fn keep(t: real, kind: u32, index: u32, base: u32, best: ptr<function, Hit>) {
    let object = objects[base + index];
    let closer = is_closer(t, object, index, *best);
#if CERTAINTY
    record(t, object, closer, *best);
#endif
    if (closer) {
        *best = Hit(t, i32(object), kind, index);
    }
}

fn nearest_hit(ray: Ray, min_t: real) -> Hit {
    var best = Hit(T_FAR, -1, 0u, 0u);
#if CERTAINTY
    start_certainty(ray);
#endif
#if SPHERES
#if !BVH
    for (var k = 0u; k < params.sphere_count; k++) {
        keep(intersect_sphere(ray, spheres[k], min_t), KIND_SPHERE, k, 0u, &best);
    }
#endif
#endif
    let plane_base = params.sphere_count;
#if PLANES
    for (var k = 0u; k < params.plane_count; k++) {
        keep(intersect_plane(ray, planes[k], min_t), KIND_PLANE, k, plane_base, &best);
    }
#endif
    let triangle_base = plane_base + params.plane_count;
#if TRIANGLES
#if !BVH
    let shear = shear_of(ray.direction);
    for (var k = 0u; k < params.triangle_count; k++) {
        keep(intersect_triangle(ray, shear, triangle_at(k), min_t), KIND_TRIANGLE, k, triangle_base, &best);
    }
#endif
#endif
#if BVH
    traverse_bvh(ray, min_t, &best);
#endif
    return best;
}

// The normal of the nearest hit, computed once rather than for every candidate.
fn hit_normal(ray: Ray, hit: Hit) -> vec3<real> {
    switch (hit.kind) {
#if SPHERES
        case KIND_SPHERE: {
            return sphere_normal(ray, hit.t, spheres[hit.index]);
        }
#endif
#if PLANES
        case KIND_PLANE: {
            return plane_normal(planes[hit.index]);
        }
#endif
#if TRIANGLES
        case KIND_TRIANGLE: {
            return triangle_normal(triangle_at(hit.index));
        }
#endif
        default: {
            return vec3<real>(0.0);
        }
    }
}
