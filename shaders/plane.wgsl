// Ray/plane intersection. CPU mirror: src/cpu/plane.rs.
#import types
#if CERTAINTY
#import certainty
#endif

#if ROBUST
// Point-normal form; the host stores the plane's point nearest the eye, so p - o is small.
fn intersect_plane(ray: Ray, plane: Plane, min_t: real) -> real {
    let denominator = dot(ray.direction, plane.normal);
    let length_d = length(ray.direction);
    // Parallel cutoff: within the dot product's rounding error (about 3 EPS |d| |n|) the
    // sign of d.n, and so whether the ray meets the plane, is not known.
    let cutoff = 4.0 * EPS * length_d;
#if CERTAINTY
    let parallel_certain = is_certain(abs(denominator) - cutoff, 4.0 * length_d);
#endif
    if (abs(denominator) <= cutoff) {
#if CERTAINTY
        decide(parallel_certain, T_FAR, 1.0);
#endif
        return NO_HIT;
    }
    let t = dot(plane.point - ray.origin, plane.normal) / denominator;
#if CERTAINTY
    // The point's and the origin's rounding, EPS (|p| + |o|), over |t d.n|; for a caller's ray
    // off the kernel's origin that is the origin's size (origin_size), 0 for a camera's.
    // Without it, rays started near their hit on a plane far from the origin were called
    // certain and wrong (docs/robustness.md, "Adaptive precision").
    let t_condition = 1.0 + length_d / abs(denominator) + 4.0 * origin_size(ray) / abs(t * denominator);
    let t_certain = start_certain(t, min_t, t_condition);
#endif
    if (is_beyond(t, min_t)) {
#if CERTAINTY
        decide(parallel_certain && t_certain, t, t_condition);
#endif
        return t;
    }
#if CERTAINTY
    decide(t_certain, t, t_condition);
#endif
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
