// Ray/triangle intersection by Cramer's rule, as in the lecture. CPU mirror: src/cpu/triangle.rs.
#import types

// Solves origin + t*direction = a + beta*(b - a) + gamma*(c - a) for (beta, gamma, t), i.e. the
// 3x3 system with columns (a - b, a - c, direction) and right-hand side a - origin.
fn intersect_triangle(ray: Ray, tri: Triangle, min_t: real) -> real {
    let col0 = tri.a - tri.b;
    let col1 = tri.a - tri.c;
    let rhs = tri.a - ray.origin;
    let m = cross(col1, ray.direction);
    let determinant = dot(col0, m);
    // Zero-area triangles and rays in the triangle's plane: no unique solution.
    if (determinant == 0.0) {
        return NO_HIT;
    }
    let beta = dot(rhs, m) / determinant;
    if (beta < 0.0) {
        return NO_HIT;
    }
    let q = cross(col0, rhs);
    let gamma = dot(ray.direction, q) / determinant;
    if (gamma < 0.0 || beta + gamma > 1.0) {
        return NO_HIT;
    }
    let t = -dot(col1, q) / determinant;
    if (t >= min_t) {
        return t;
    }
    return NO_HIT;
}

// Unit normal by corner order: normalize((b - a) x (c - a)), never flipped.
fn triangle_normal(tri: Triangle) -> vec3<real> {
    return normalize(cross(tri.b - tri.a, tri.c - tri.a));
}
