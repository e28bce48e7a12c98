// Ray/plane intersection. CPU mirror: src/cpu/plane.rs.
#import types

fn intersect_plane(ray: Ray, plane: Plane, min_t: real) -> real {
    let denominator = dot(ray.direction, plane.normal);
    // A ray parallel to the plane never meets it (and dividing by zero would make inf/NaN).
    if (denominator == 0.0) {
        return NO_HIT;
    }
    let t = dot(plane.point - ray.origin, plane.normal) / denominator;
    if (t >= min_t) {
        return t;
    }
    return NO_HIT;
}

// The stored (unit) normal, on both sides of the plane.
fn plane_normal(plane: Plane) -> vec3<real> {
    return plane.normal;
}
