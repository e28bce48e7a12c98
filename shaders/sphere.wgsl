// Ray/sphere intersection, the lecture's quadratic. CPU mirror: src/cpu/sphere.rs.
#import types

// The near root if it is at or beyond min_t, else the far root, else NO_HIT.
fn intersect_sphere(ray: Ray, sphere: Sphere, min_t: real) -> real {
    let oc = ray.origin - sphere.center;
    let a = dot(ray.direction, ray.direction);
    let b = 2.0 * dot(ray.direction, oc);
    let c = dot(oc, oc) - sphere.radius * sphere.radius;
    let discriminant = b * b - 4.0 * a * c;
    if (discriminant < 0.0) {
        return NO_HIT;
    }
    let root = sqrt(discriminant);
    let t_near = (-b - root) / (2.0 * a);
    if (t_near >= min_t) {
        return t_near;
    }
    let t_far = (-b + root) / (2.0 * a);
    if (t_far >= min_t) {
        return t_far;
    }
    return NO_HIT;
}

// Outward unit normal at the hit point, never flipped (seen from inside it points away).
fn sphere_normal(ray: Ray, t: real, sphere: Sphere) -> vec3<real> {
    let p = ray.origin + t * ray.direction;
    return (p - sphere.center) / sphere.radius;
}
