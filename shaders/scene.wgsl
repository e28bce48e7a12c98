// Nearest-hit search over every primitive (brute force). CPU mirror: src/cpu/scene.rs.
#import types
#import bindings
#import sphere
#import plane
#import triangle

const KIND_SPHERE: u32 = 0u;
const KIND_PLANE: u32 = 1u;
const KIND_TRIANGLE: u32 = 2u;

struct Hit {
    t: real,
    object: i32,          // -1: no hit
    kind: u32,
    index: u32,           // into the buffer of its kind
}

// Ties in t go to the lower object id, then the lower primitive index, so the answer does not
// depend on the order primitives are visited (the course visits objects in file order).
fn is_closer(t: real, object: u32, index: u32, best: Hit) -> bool {
    if (t == NO_HIT) {
        return false;
    }
    if (best.object < 0 || t < best.t) {
        return true;
    }
    return t == best.t && (i32(object) < best.object || (i32(object) == best.object && index < best.index));
}

fn nearest_hit(ray: Ray, min_t: real) -> Hit {
    var best = Hit(T_FAR, -1, 0u, 0u);
    for (var k = 0u; k < params.sphere_count; k++) {
        let t = intersect_sphere(ray, spheres[k], min_t);
        let object = objects[k];
        if (is_closer(t, object, k, best)) {
            best = Hit(t, i32(object), KIND_SPHERE, k);
        }
    }
    let plane_base = params.sphere_count;
    for (var k = 0u; k < params.plane_count; k++) {
        let t = intersect_plane(ray, planes[k], min_t);
        let object = objects[plane_base + k];
        if (is_closer(t, object, k, best)) {
            best = Hit(t, i32(object), KIND_PLANE, k);
        }
    }
    let triangle_base = plane_base + params.plane_count;
    for (var k = 0u; k < params.triangle_count; k++) {
        let t = intersect_triangle(ray, triangles[k], min_t);
        let object = objects[triangle_base + k];
        if (is_closer(t, object, k, best)) {
            best = Hit(t, i32(object), KIND_TRIANGLE, k);
        }
    }
    return best;
}

// The normal of the nearest hit, computed once rather than for every candidate.
fn hit_normal(ray: Ray, hit: Hit) -> vec3<real> {
    switch (hit.kind) {
        case KIND_SPHERE: {
            return sphere_normal(ray, hit.t, spheres[hit.index]);
        }
        case KIND_PLANE: {
            return plane_normal(planes[hit.index]);
        }
        default: {
            return triangle_normal(triangles[hit.index]);
        }
    }
}
