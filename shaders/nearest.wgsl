// Nearest-hit search: over every primitive (brute force), or the planes by brute force and the
// rest through the BVH (BVH; shaders/traverse*.wgsl). CPU mirror: src/cpu/nearest.rs.
#import types
#import bindings
#import hit
#if BVH
#import traverse
#endif
// The traversals this kernel uses, chosen here alone (Variant::defines decides which).
#if PACKETS
#import traverse_packet
#endif
#if LANES
#import traverse_lanes
#endif
#if RAY_BY_RAY
#import traverse_ray
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
    keep_object(t, objects[base + index], kind, index, best);
}

// keep() for a primitive whose object is known.
fn keep_object(t: real, object: u32, kind: u32, index: u32, best: ptr<function, Hit>) {
    let closer = is_closer(t, object, index, *best);
#if CERTAINTY
    record(t, object, closer, *best);
#endif
    if (closer) {
        *best = Hit(t, i32(object), kind, index);
    }
}

fn nearest_hit(ray: Ray, min_t: real) -> Hit {
    return nearest_hit_before(ray, min_t, T_FAR);
}

// The nearest hit, searching no box that starts beyond `t_max` (shadow rays, shade.wgsl's
// `occluded`): a hit found is the nearest one where the nearest is before t_max, and may be any
// hit where none is.
fn nearest_hit_before(ray: Ray, min_t: real, t_max: real) -> Hit {
    var best = Hit(t_max, -1, 0u, 0u);
#if CERTAINTY
    start_certainty(ray);
#endif
#if SPHERES
#if !BVH
    for (var k = 0u; k < params.sphere_count; k++) {
        keep(intersect_sphere(ray, sphere_at(k), min_t), KIND_SPHERE, k, 0u, &best);
    }
#endif
#endif
#if PLANES
    nearest_plane(ray, min_t, &best);
#endif
    let triangle_base = params.sphere_count + params.plane_count;
#if TRIANGLES
#if !BVH
    let shear = shear_of(ray.direction);
    for (var k = 0u; k < params.triangle_count; k++) {
        keep(intersect_triangle(ray, shear, triangle_at(k), min_t), KIND_TRIANGLE, k, triangle_base, &best);
    }
#endif
#endif
#if BVH
    search_bvh(ray, min_t, &best);
#endif
    return best;
}

#if BVH
// The spheres and triangles of nearest_hit_before, through the BVH: in a packet of the
// subgroup's rays (PACKETS), a hook's ray only where every lane casts one at this call
// (subgroup_whole), else ray by ray.
fn search_bvh(ray: Ray, min_t: real, best: ptr<function, Hit>) {
#if PACKETS
#if HOOK_RAYS
    if (!subgroup_whole()) {
        traverse_bvh(ray, min_t, best);
        return;
    }
#endif
    traverse_bvh_packet(ray, min_t, best);
#else
    traverse_bvh(ray, min_t, best);
#endif
}
#endif

#if PLANES
// Keeps the nearest plane hit if nearer than `best` (planes, being unbounded, are searched by
// brute force).
fn nearest_plane(ray: Ray, min_t: real, best: ptr<function, Hit>) {
    for (var k = 0u; k < plane_count(); k++) {
        let plane = planes[k];
        keep_object(intersect_plane(ray, plane, min_t), plane_object(plane), KIND_PLANE, k, best);
    }
}
#endif
#if LANES

// nearest_hit() for a lane's rays, which traverse the BVH as one packet (traverse_bvh_lanes;
// LANES: packet kernels on subgroups of 8). With CERTAINTY (two rays a lane) the first ray's
// record is `certainty` and the second's is swapped in around its work (swap_rays).
fn nearest_hit_lanes(rays: LaneRays, min_t: real) -> LaneHits {
    var hits: LaneHits;
#each_ray
    var best$r = Hit(T_FAR, -1, 0u, 0u);
#if CERTAINTY
    start_certainty(rays.r$r);
#endif
#if PLANES
    nearest_plane(rays.r$r, min_t, &best$r);
#endif
    swap_rays();
    hits.h$r = best$r;
#end_each
    traverse_bvh_lanes(rays, min_t, &hits);
    return hits;
}
#endif

// The normal of the nearest hit, computed once rather than for every candidate.
fn hit_normal(ray: Ray, hit: Hit) -> vec3<real> {
    switch (hit.kind) {
#if SPHERES
        case KIND_SPHERE: {
            return sphere_normal(ray, hit.t, sphere_at(hit.index));
        }
#endif
#if PLANES
        case KIND_PLANE: {
            return plane_normal(planes[hit.index]);
        }
#endif
#if TRIANGLES
        case KIND_TRIANGLE: {
            return placed_normal(hit, triangle_normal(triangle_at(hit.index)));
        }
#endif
        default: {
            return vec3<real>(0.0);
        }
    }
}

#if INSTANCES
// Whether an instance places the triangle `hit` hit: hit_instance, where its object is the
// hit's (a nearest hit found after it in the world is another object's).
fn is_placed(hit: Hit) -> bool {
    return hit_instance != NO_INSTANCE && hit.kind == KIND_TRIANGLE && i32(instance_words[hit_instance].y) == hit.object;
}
#endif

// The normal `n` of the triangle `hit` hit, in the kernel's coordinates: as it is, or where an
// instance places the triangle, moved out of its mesh's coordinates.
fn placed_normal(hit: Hit, n: vec3<real>) -> vec3<real> {
#if INSTANCES
    if (is_placed(hit)) {
        return unit_normal(instance_normal(n, instance_at(hit_instance)));
    }
#endif
    return n;
}

// The barycentrics `uv` of the triangle `hit` hit as the flattened scene's: an instance that
// mirrors swaps its triangles' last two corners (docs/scene-format.md), so u and v trade places.
fn placed_uv(hit: Hit, uv: vec2<real>) -> vec2<real> {
#if INSTANCES
    if (is_placed(hit) && mirrors(instance_at(hit_instance))) {
        return uv.yx;
    }
#endif
    return uv;
}

// The ray as the primitive `hit` hit sees it: in its instance's mesh coordinates where an
// instance places it (barycentrics and t are the same there).
fn placed_ray(ray: Ray, hit: Hit) -> Ray {
#if INSTANCES
    if (is_placed(hit)) {
        return instance_ray(ray, instance_at(hit_instance));
    }
#endif
    return ray;
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

// A ray list's view of its nearest hit: the normal, the t it reports and the barycentrics (u, v)
// of a triangle (the hit point is (1 - u - v) a + u b + v c; zero on spheres and planes). A
// triangle's corners are loaded once for all three: each load is a loop over the lanes.
struct HitDetails {
    normal: vec3<real>,
    t: real,
    uv: vec2<real>,
}

#if TRIANGLES
// The t a hit on triangle `tri` reports, from the test's `t`. With RECHECK_F64 the plane's:
// a caller's rays and corners given in f32 reach the kernel unrounded (RayScene's kernel eye),
// so the plane's t is the f32 answer within about an ulp; decisions keep the test's t. Camera
// renders keep it too: there the corners are rounded to camera-relative f32, which dominates
// at grazing angles either way, so the plane's t would cost them time for nothing
// (docs/performance.md#ray-lists).
fn triangle_hit_t(ray: Ray, tri: Triangle, t: real) -> real {
#if RECHECK_F64
    return plane_t(ray, tri, t);
#else
    return t;
#endif
}
#endif

// The t `hit_details` reports for `hit`, alone.
fn hit_t(ray: Ray, hit: Hit) -> real {
#if TRIANGLES
#if RECHECK_F64
    if (hit.kind == KIND_TRIANGLE) {
        return triangle_hit_t(placed_ray(ray, hit), triangle_at(hit.index), hit.t);
    }
#endif
#endif
    return hit.t;
}

fn hit_details(ray: Ray, hit: Hit) -> HitDetails {
#if TRIANGLES
    if (hit.kind == KIND_TRIANGLE) {
        let tri = triangle_at(hit.index);
        let placed = placed_ray(ray, hit);
        let t = triangle_hit_t(placed, tri, hit.t);
        return HitDetails(placed_normal(hit, triangle_normal(tri)), t, placed_uv(hit, triangle_uv(placed, shear_of(placed.direction), tri)));
    }
#endif
    return HitDetails(hit_normal(ray, hit), hit.t, vec2<real>(0.0));
}
