// Ray/plane intersection. CPU mirror: src/cpu/plane.rs.
#import types

#if ROBUST
// Point-normal form; the host stores the plane's point nearest the eye, so p - o is small.
fn intersect_plane(ray: Ray, plane: Plane, min_t: real) -> real {
    let denominator = dot(ray.direction, plane.normal);
    // Parallel cutoff: within the dot product's rounding error (about 3 EPS |d| |n|) the
    // sign of d.n, and so whether the ray meets the plane, is not known.
    if (abs(denominator) <= 4.0 * EPS * length(ray.direction)) {
        return NO_HIT;
    }
    let t = dot(plane.point - ray.origin, plane.normal) / denominator;
    if (is_beyond(t, min_t)) {
        return t;
    }
    return NO_HIT;
}
#else
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
#endif

// The stored (unit) normal, on both sides of the plane.
fn plane_normal(plane: Plane) -> vec3<real> {
    return plane.normal;
}
