// Ray/triangle intersection. CPU mirror: src/cpu/triangle.rs.
#import types
#if CERTAINTY
#import certainty
#endif

#if ROBUST
#if RECHECK_F64
// The edge functions a*b - c*d, one per component, with their exact signs. `approx` holds
// their f32 values; where one is too close to zero for its sign to be certain (fused or not),
// it is recomputed in f64, where products of f32 values are exact: one rounding is left,
// which keeps the sign, and a fused multiply-add would give the same value. So an edge shared
// by two triangles gets exactly opposite signs from both, on any driver. The three are
// checked together and the f64 arithmetic is behind one branch that almost no triangle takes:
// written per edge, llvmpipe computed it for every test.
fn edges_exact(a: vec3<real>, b: vec3<real>, c: vec3<real>, d: vec3<real>, approx: vec3<real>) -> vec3<real> {
    let close = !(abs(approx) > 2.0 * EPS * (abs(a * b) + abs(c * d)));
    if (!any(close)) {
        return approx;
    }
    let exact = vec3<f64>(a) * vec3<f64>(b) - vec3<f64>(c) * vec3<f64>(d);
    return select(approx, vec3<real>(exact), close);
}
#endif

#if CERTAINTY
// Two equal corners stay equal after any rounding: such a triangle always misses.
fn has_repeated_corner(tri: Triangle) -> bool {
    return all(tri.a == tri.b) || all(tri.b == tri.c) || all(tri.c == tri.a);
}

// How far each edge function (u, v, w) may be off, in units of EPS (is_certain's scale). A
// sheared corner's x and y are off by about EPS (|x| + |z| + s) and EPS (|y| + |z| + s), s the
// origin's size (origin_size, doubled): vertex rounding, the ray's origin, the shear. (Without
// s, rays started near a small triangle far from the kernel's origin are called certain on
// their wrong side of its edges: src/tests/rays.rs.) So e = x1 y2 - y1 x2 is off by about EPS
// ((|x1|+|z1|)|y2| + |x1|(|y2|+|z2|) + the same of y1 x2), doubled here, plus the
// second-order term. (The product (|x1|+|z1|)(|y2|+|z2|) would count |z1||z2| too,
// no error term at all, and much the largest for a small triangle far along the ray: it left
// many of the torus's pixels uncertain; docs/robustness.md.) Computed only where a decision
// needs it: most rays miss most triangles by a wide margin.
fn edge_scales(xs: vec3<real>, ys: vec3<real>, zs: vec3<real>, origin: real) -> vec3<real> {
    let ax = abs(xs);
    let ay = abs(ys);
#if INSTANCES
    let az = abs(zs) * (1.0 + placed_skew);
#else
    let az = abs(zs);
#endif
    let mx = ax + az + 2.0 * origin;
    let my = ay + az + 2.0 * origin;
    let first = vec3<real>(
        mx.z * ay.y + ax.z * my.y + my.z * ax.y + ay.z * mx.y,
        mx.x * ay.z + ax.x * my.z + my.x * ax.z + ay.x * mx.z,
        mx.y * ay.x + ax.y * my.x + my.y * ax.x + ay.y * mx.x,
    );
    let second = vec3<real>(
        mx.z * my.y + my.z * mx.y,
        mx.x * my.z + my.x * mx.z,
        mx.y * my.x + my.y * mx.x,
    );
    return 2.0 * first + 16.0 * EPS * second;
}

// The condition factor of the test's t (certainty.wgsl's t_error): 1 / cos of the angle
// between the ray and the triangle's plane normal. The edge functions' rounding shifts
// t = T / det by up to about that many EPS relative, and a factor of 1 let the adaptive pass
// call grazing start decisions certain that f64 reversed (docs/robustness.md). Scaled first
// (no overflow or underflow of the products); a degenerate normal or a
// ray in the plane gives NaN or inf, which decide() takes as uncertain.
// In an instance's mesh the direction's rounding (placed_skew) moves t by up to about
// 1 / cos of it as well, relative: far less than placed_skew / 8 of the 16 EPS t_error counts.
fn grazing_condition(ray: Ray, tri: Triangle) -> real {
    let n = cross(tri.b - tri.a, tri.c - tri.a);
    let n_unit = n / max_component(n);
    let d_unit = ray.direction / max_component(ray.direction);
    let c = length(n_unit) * length(d_unit) / abs(dot(n_unit, d_unit));
#if INSTANCES
    return c * (1.0 + 0.125 * placed_skew);
#else
    return c;
#endif
}
#endif

// The watertight test of Woop, Benthin and Wald (JCGT 2013): shear the triangle into the
// ray's frame (ray along +z through the origin; `shear` is shear_of(ray.direction), computed
// once per ray, not per triangle) and decide with 2D edge functions, which neighbouring
// triangles evaluate with exactly opposite signs on a shared edge.
// The triangle's corners in the ray's sheared frame (ray along +z through the origin) and its
// edge functions: u of edge b-c, v of edge c-a, w of edge a-b (the weights of a, b and c).
struct Sheared {
    xs: vec3<real>,
    ys: vec3<real>,
    zs: vec3<real>,
    edges: vec3<real>,
}

fn shear_triangle(ray: Ray, shear: Shear, tri: Triangle) -> Sheared {
    let pa = tri.a - ray.origin;
    let pb = tri.b - ray.origin;
    let pc = tri.c - ray.origin;
    // One vector expression for all three corners, so a corner shared with a neighbouring
    // triangle is transformed by the same instructions there.
    let zs = vec3<real>(pa[shear.kz], pb[shear.kz], pc[shear.kz]);
    let xs = vec3<real>(pa[shear.kx], pb[shear.kx], pc[shear.kx]) - shear.sx * zs;
    let ys = vec3<real>(pa[shear.ky], pb[shear.ky], pc[shear.ky]) - shear.sy * zs;
    let u = xs.z * ys.y - ys.z * xs.y;
    let v = xs.x * ys.z - ys.x * xs.z;
    let w = xs.y * ys.x - ys.y * xs.x;
#if RECHECK_F64
    return Sheared(xs, ys, zs, edges_exact(xs.zxy, ys.yzx, ys.zxy, xs.yzx, vec3<real>(u, v, w)));
#else
    return Sheared(xs, ys, zs, vec3<real>(u, v, w));
#endif
}

fn intersect_triangle(ray: Ray, shear: Shear, tri: Triangle, min_t: real) -> real {
    let sz = shear.sz;
    let s = shear_triangle(ray, shear, tri);
    let xs = s.xs;
    let ys = s.ys;
    let zs = s.zs;
    let u = s.edges.x;
    let v = s.edges.y;
    let w = s.edges.z;
    // Inside (or on an edge) iff no edge function has a sign opposite to another's.
    if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) {
#if CERTAINTY
        // A certain miss needs one edge certainly on the side opposite the others'. Computed
        // without short-circuits: straight-line arithmetic suits SIMD lanes better.
        let det_guess = u + v + w;
        let positive = det_guess >= 0.0;
        let scales = edge_scales(xs, ys, zs, origin_size(ray));
        let certain = ((u != 0.0) & ((u < 0.0) == positive) & is_certain(u, scales.x))
            | ((v != 0.0) & ((v < 0.0) == positive) & is_certain(v, scales.y))
            | ((w != 0.0) & ((w < 0.0) == positive) & is_certain(w, scales.z));
        if (certain) {
            decide(true, T_FAR, 1.0);
        } else if (has_repeated_corner(tri)) {
            decide(true, T_FAR, 1.0);
        } else {
            // Where the ray meets the triangle's plane: the hit a flipped decision would give.
            // Seen edge-on (det_guess 0) it could be anywhere along the ray: 0, nearer than
            // any hit.
            let t_guess = select(0.0, (u * (sz * zs.x) + v * (sz * zs.y) + w * (sz * zs.z)) / det_guess, det_guess != 0.0);
            decide(false, t_guess, grazing_condition(ray, tri));
        }
#endif
        return NO_HIT;
    }
    let determinant = u + v + w;
    // Degenerate (zero-area as seen along the ray): no hit.
    if (determinant == 0.0) {
#if CERTAINTY
        decide(has_repeated_corner(tri), T_FAR, 1.0);
#endif
        return NO_HIT;
    }
    let t_scaled = u * (sz * zs.x) + v * (sz * zs.y) + w * (sz * zs.z);
    let t = t_scaled / determinant;
#if CERTAINTY
    // The corners' rounding beyond what the edge functions see (origin_size) moves the plane,
    // so t, by EPS times that size over the distance to the hit.
    let d_size = max_component(ray.direction);
    let t_condition = grazing_condition(ray, tri) * (1.0 + 2.0 * origin_size(ray) / (abs(t) * d_size));
    let t_certain = start_certain(t, min_t, t_condition);
#endif
    if (is_beyond(t, min_t)) {
#if CERTAINTY
        let scales = edge_scales(xs, ys, zs, origin_size(ray));
        let edges_certain = is_certain(u, scales.x) && is_certain(v, scales.y) && is_certain(w, scales.z);
        decide(edges_certain && t_certain, t, t_condition);
#endif
        return t;
    }
#if CERTAINTY
    decide(t_certain || has_repeated_corner(tri), t, t_condition);
#endif
    return NO_HIT;
}

#if RECHECK_F64
// The t of a hit the test found, recomputed where the ray meets the triangle's plane, in f64
// from the f32 corners and ray: their differences and products are exact there, so the
// normal's components and the two dot products round once each in f64. The test's own
// t = T / det weighs the corners' depths by edge functions that each carry f32 rounding, which
// a grazing ray magnifies by up to 1 / cos; here only the three f32 roundings at the end are
// left (f64 division is not correctly rounded on lavapipe, f32 division is;
// docs/performance.md#ray-lists). A degenerate triangle (zero normal in f64: NaN) or a
// ray in its plane keeps `t`.
fn plane_t(ray: Ray, tri: Triangle, t: real) -> real {
    let a = vec3<f64>(tri.a);
    let normal = cross(vec3<f64>(tri.b) - a, vec3<f64>(tri.c) - a);
    let numerator = dot(normal, a - vec3<f64>(ray.origin));
    let denominator = dot(normal, vec3<f64>(ray.direction));
    let refined = real(numerator) / real(denominator);
    return select(t, refined, abs(refined - t) <= 0.5 * abs(t));
}
#endif

// Barycentric (u, v) of the ray's hit on the triangle, from the edge functions of the test:
// the hit point is (1 - u - v) a + u b + v c.
fn triangle_uv(ray: Ray, shear: Shear, tri: Triangle) -> vec2<real> {
    let e = shear_triangle(ray, shear, tri).edges;
    let determinant = e.x + e.y + e.z;
    return vec2<real>(e.y / determinant, e.z / determinant);
}
#else
// Cramer's rule, as in the lecture: solves origin + t*direction = a + beta*(b - a) +
// gamma*(c - a), the 3x3 system with columns (a - b, a - c, direction) and right-hand side
// a - origin. (`shear` is the robust test's; unused.)
fn intersect_triangle(ray: Ray, shear: Shear, tri: Triangle, min_t: real) -> real {
    let c = cramer(ray, tri);
    // Zero-area triangles and rays in the triangle's plane: no unique solution.
    if (c.determinant == 0.0) {
        return NO_HIT;
    }
    if (c.beta < 0.0 || c.gamma < 0.0 || c.beta + c.gamma > 1.0) {
        return NO_HIT;
    }
    let t = -dot(tri.a - tri.c, c.q) / c.determinant;
    if (t >= min_t) {
        return t;
    }
    return NO_HIT;
}

// The lecture's system solved for the barycentrics beta (of b) and gamma (of c); `q` is what t
// needs besides.
struct Cramer {
    determinant: real,
    beta: real,
    gamma: real,
    q: vec3<real>,
}

fn cramer(ray: Ray, tri: Triangle) -> Cramer {
    let col0 = tri.a - tri.b;
    let col1 = tri.a - tri.c;
    let rhs = tri.a - ray.origin;
    let m = cross(col1, ray.direction);
    let determinant = dot(col0, m);
    let q = cross(col0, rhs);
    return Cramer(determinant, dot(rhs, m) / determinant, dot(ray.direction, q) / determinant, q);
}

// Barycentric (u, v) of the ray's hit on the triangle: the hit point is (1 - u - v) a + u b + v c.
fn triangle_uv(ray: Ray, shear: Shear, tri: Triangle) -> vec2<real> {
    let c = cramer(ray, tri);
    return vec2<real>(c.beta, c.gamma);
}
#endif

// Unit normal by corner order: normalize((b - a) x (c - a)), never flipped.
fn triangle_normal(tri: Triangle) -> vec3<real> {
    return unit_normal(cross(tri.b - tri.a, tri.c - tri.a));
}

// `n` normalised; zero where it is zero.
fn unit_normal(n: vec3<real>) -> vec3<real> {
#if ROBUST
    // Scale first: the squared length of a tiny triangle's normal can underflow to zero.
    let m = max_component(n);
    if (m == 0.0) {
        return vec3<real>(0.0);
    }
    return normalize(n / m);
#else
    return normalize(n);
#endif
}
