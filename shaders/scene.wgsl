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

// The t a ray list's hit reports: with RECHECK_F64 a triangle's is recomputed from its plane
// (plane_t), the test's t kept for every decision. A caller's rays and corners given in f32
// reach the kernel unrounded (RayScene's kernel eye), so this t is the f32 answer within about
// an ulp. Camera renders keep the test's t: there the corners are rounded to camera-relative
// f32, which at grazing angles dominates (torus: 5.9e-6 relative at most against f64 either
// way), and recomputing cost 2.7% of the torus kernel's time.
fn hit_t(ray: Ray, hit: Hit) -> real {
#if TRIANGLES
#if RECHECK_F64
    if (hit.kind == KIND_TRIANGLE && hit.object >= 0) {
        return plane_t(ray, triangle_at(hit.index), hit.t);
    }
#endif
#endif
    return hit.t;
}

// The hit primitive's index among the primitives of its kind in the scene's order (the BVH
// stores spheres and triangles in its own order).
fn primitive_key(hit: Hit) -> u32 {
#if BVH
    var base = 0u;
    if (hit.kind == KIND_PLANE) {
        base = params.sphere_count;
    } else if (hit.kind == KIND_TRIANGLE) {
        base = params.sphere_count + params.plane_count;
    }
    return prim_order[base + hit.index];
#else
    return hit.index;
#endif
}

// The hit's barycentric (u, v) on a triangle (the hit point is (1 - u - v) a + u b + v c), zero
// on spheres and planes.
fn hit_uv(ray: Ray, hit: Hit) -> vec2<real> {
#if TRIANGLES
    if (hit.kind == KIND_TRIANGLE) {
        return triangle_uv(ray, shear_of(ray.direction), triangle_at(hit.index));
    }
#endif
    return vec2<real>(0.0);
}
