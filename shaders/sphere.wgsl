// Ray/sphere intersection. CPU mirror: src/cpu/sphere.rs.
#import types
#if CERTAINTY
#import certainty
#endif

#if ROBUST
// The discriminant from the squared distance between the centre and the ray line (as in
// pbrt-v4 and Ray Tracing Gems I, ch. 7): its rounding error is about EPS * r^2 instead of
// EPS * b^2, so far and small spheres keep their silhouettes. The root pair q/a, c/q never
// subtracts nearly equal numbers.
fn intersect_sphere(ray: Ray, sphere: Sphere, min_t: real) -> real {
    let f = ray.origin - sphere.center;
    let d = ray.direction;
    let a = dot(d, d);
    let b = dot(f, d);
    let l = f - (b / a) * d;
    let r2 = sphere.radius * sphere.radius;
    let l2 = dot(l, l);
    let discriminant = a * (r2 - l2);
#if CERTAINTY
    // l is off by about 11 EPS |f| (absolute), so l2 by 22 EPS |l| |f| and, where l is smaller
    // than that error (a sphere thinner than an ulp of its distance), by its square,
    // 121 EPS^2 |f|^2: the last term.
    // |f| plus what the centre's rounding adds beyond it (origin_size): the size f's error
    // scales with. Without it, rays grazing a small sphere far from the kernel's origin were
    // called certain and wrong (docs/robustness.md, "Adaptive precision").
    let f_size = sqrt(dot(f, f)) + 2.0 * origin_size(ray);
    let ff = f_size * f_size;
    let disc_certain = is_certain(r2 - l2, r2 + 2.0 * l2 + 24.0 * sqrt(l2) * f_size + 128.0 * EPS * ff);
#endif
    if (discriminant < 0.0) {
#if CERTAINTY
        decide(disc_certain, -b / a, 1.0);
#endif
        return NO_HIT;
    }
    let root = sqrt(discriminant);
    let q = -(b + select(root, -root, b < 0.0));
    // Only a ray tangent at its own origin: t = 0, never beyond min_t.
    if (q == 0.0) {
#if CERTAINTY
        decide(false, 0.0, 1.0);
#endif
        return NO_HIT;
    }
    let c = dot(f, f) - r2;
    let t0 = q / a;
    let t1 = c / q;
    let t_near = min(t0, t1);
    let t_far = max(t0, t1);
#if CERTAINTY
    // c/q, the root of smaller magnitude, inherits the cancellation of c = |f|^2 - r^2 (eye
    // near the surface); capped so the factor stays finite.
    let c_condition = 1.0 + ff / max(abs(c), ff * 1e-20);
    let far_condition = select(1.0, c_condition, abs(t_far) <= abs(t_near));
    let near_condition = select(1.0, c_condition, abs(t_near) < abs(t_far));
    let far_certain = disc_certain && start_certain(t_far, min_t, far_condition);
    // Which root is the hit, not only whether the sphere is hit, decides the distance and the
    // normal: the near root's start test must be certain too.
    let root_certain = far_certain && start_certain(t_near, min_t, near_condition);
#endif
    if (is_beyond(t_near, min_t)) {
#if CERTAINTY
        decide(root_certain, t_near, near_condition);
#endif
        return t_near;
    }
    if (is_beyond(t_far, min_t)) {
#if CERTAINTY
        decide(root_certain, t_far, far_condition);
#endif
        return t_far;
    }
#if CERTAINTY
    decide(start_certain(t_far, min_t, far_condition), t_far, far_condition);
#endif
    return NO_HIT;
}

// Outward unit normal. p - c is rebuilt from two small, accurate vectors: the perpendicular l
// from the centre to the ray line, and the half-chord along the ray (backwards for the near
// root, forwards for the far one). The direct p - c loses digits when the sphere is far.
fn sphere_normal(ray: Ray, t: real, sphere: Sphere) -> vec3<real> {
    let f = ray.origin - sphere.center;
    let d = ray.direction;
    let a = dot(d, d);
    let b = dot(f, d);
    let l = f - (b / a) * d;
    let half_chord = sqrt(max(sphere.radius * sphere.radius - dot(l, l), 0.0) / a);
    let along = select(half_chord, -half_chord, t < -b / a);
    return normalize(l + along * d);
}
#else
// The lecture's quadratic: the near root if it is at or beyond min_t, else the far root.
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
#endif

// How many times the ray crosses the sphere's surface from min_t on: none where
// intersect_sphere finds no hit, else once from inside (the start point of the ray) and twice
// from outside (a tangent ray touches twice at one point).
fn sphere_crossings(ray: Ray, sphere: Sphere, min_t: real) -> u32 {
    if (intersect_sphere(ray, sphere, min_t) == NO_HIT) {
        return 0u;
    }
    let f = ray.origin + min_t * ray.direction - sphere.center;
    return select(2u, 1u, dot(f, f) < sphere.radius * sphere.radius);
}
