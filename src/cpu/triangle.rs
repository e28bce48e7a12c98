//! Mirror of shaders/triangle.wgsl: ray/triangle intersection.

use crate::kernel::types::{Ray, Shear, Triangle, is_beyond, no_hit};
use crate::math::{Float, Real, Vec3, cross, dot, normalize, vec3};

/// `shear` is [`crate::kernel::types::shear_of`] of the ray's direction (the robust test's; the textbook
/// one does not use it).
pub(crate) fn intersect_triangle<T: Real, const ROBUST: bool>(
    ray: &Ray<T>,
    shear: &Shear<T>,
    tri: &Triangle<T>,
    min_t: T,
) -> T {
    if ROBUST {
        intersect_triangle_robust(ray, shear, tri, min_t)
    } else {
        intersect_triangle_textbook(ray, tri, min_t)
    }
}

/// The edge functions `a*b - c*d`, one per component, with their exact signs (`#if
/// RECHECK_F64`, which the CPU always has for f32): where the f32 value in `approx` is too
/// close to zero for its sign to be certain, recomputed in f64, where products of f32 values
/// are exact.
pub(crate) fn edges_exact<T: Real>(
    a: Vec3<T>,
    b: Vec3<T>,
    c: Vec3<T>,
    d: Vec3<T>,
    approx: Vec3<T>,
) -> Vec3<T> {
    if T::PRECISION == Float::F64 {
        return approx;
    }
    let edge = |k: usize| {
        let (a, b, c, d, approx) = (a.get(k), b.get(k), c.get(k), d.get(k), approx.get(k));
        if approx.abs() > T::TWO * T::EPS * ((a * b).abs() + (c * d).abs()) {
            approx
        } else {
            T::from_f64(a.to_f64() * b.to_f64() - c.to_f64() * d.to_f64())
        }
    };
    vec3(edge(0), edge(1), edge(2))
}

/// The triangle's corners in the ray's sheared frame and its edge functions (`Sheared` in WGSL):
/// u of edge b-c, v of edge c-a, w of edge a-b (the weights of a, b and c).
// The sheared x and y serve the kernel's certainty test (`edge_scales`), which the mirror
// does not have (its bounds are in margin.rs); kept so that the struct reads as in WGSL.
#[allow(dead_code)]
pub(crate) struct Sheared<T> {
    pub xs: Vec3<T>,
    pub ys: Vec3<T>,
    pub zs: Vec3<T>,
    pub edges: Vec3<T>,
}

pub(crate) fn shear_triangle<T: Real>(
    ray: &Ray<T>,
    shear: &Shear<T>,
    tri: &Triangle<T>,
) -> Sheared<T> {
    let Shear {
        kx, ky, kz, sx, sy, ..
    } = *shear;
    let pa = tri.a - ray.origin;
    let pb = tri.b - ray.origin;
    let pc = tri.c - ray.origin;
    let zs = vec3(pa.get(kz), pb.get(kz), pc.get(kz));
    let xs = vec3(pa.get(kx), pb.get(kx), pc.get(kx)) - zs * sx;
    let ys = vec3(pa.get(ky), pb.get(ky), pc.get(ky)) - zs * sy;
    let u = xs.z * ys.y - ys.z * xs.y;
    let v = xs.x * ys.z - ys.x * xs.z;
    let w = xs.y * ys.x - ys.y * xs.x;
    let zxy = |p: Vec3<T>| vec3(p.z, p.x, p.y);
    let yzx = |p: Vec3<T>| vec3(p.y, p.z, p.x);
    Sheared {
        xs,
        ys,
        zs,
        edges: edges_exact(zxy(xs), yzx(ys), zxy(ys), yzx(xs), vec3(u, v, w)),
    }
}

/// The watertight test of Woop, Benthin and Wald (JCGT 2013): shear the triangle into the ray's
/// frame and decide with 2D edge functions, exactly negated on an edge shared by two triangles.
pub(crate) fn intersect_triangle_robust<T: Real>(
    ray: &Ray<T>,
    shear: &Shear<T>,
    tri: &Triangle<T>,
    min_t: T,
) -> T {
    let sz = shear.sz;
    let Sheared { zs, edges, .. } = shear_triangle(ray, shear, tri);
    let (u, v, w) = (edges.x, edges.y, edges.z);
    let zero = T::ZERO;
    if (u < zero || v < zero || w < zero) && (u > zero || v > zero || w > zero) {
        return no_hit();
    }
    let determinant = u + v + w;
    if determinant == zero {
        return no_hit();
    }
    let t_scaled = u * (sz * zs.x) + v * (sz * zs.y) + w * (sz * zs.z);
    let t = t_scaled / determinant;
    if is_beyond(t, min_t) {
        return t;
    }
    no_hit()
}

/// Cramer's rule, as in the lecture: solves origin + t*direction = a + beta*(b - a) +
/// gamma*(c - a), the system with columns (a - b, a - c, direction) and right-hand side
/// a - origin.
pub(crate) fn intersect_triangle_textbook<T: Real>(ray: &Ray<T>, tri: &Triangle<T>, min_t: T) -> T {
    let c = cramer(ray, tri);
    // Zero-area triangles and rays in the triangle's plane: no unique solution.
    if c.determinant == T::ZERO {
        return no_hit();
    }
    if c.beta < T::ZERO || c.gamma < T::ZERO || c.beta + c.gamma > T::ONE {
        return no_hit();
    }
    let t = -dot(tri.a - tri.c, c.q) / c.determinant;
    if t >= min_t {
        return t;
    }
    no_hit()
}

/// The lecture's system solved for the barycentrics beta (of b) and gamma (of c); `q` is what t
/// needs besides (`Cramer` in WGSL).
pub(crate) struct Cramer<T> {
    pub determinant: T,
    pub beta: T,
    pub gamma: T,
    pub q: Vec3<T>,
}

pub(crate) fn cramer<T: Real>(ray: &Ray<T>, tri: &Triangle<T>) -> Cramer<T> {
    let col0 = tri.a - tri.b;
    let col1 = tri.a - tri.c;
    let rhs = tri.a - ray.origin;
    let m = cross(col1, ray.direction);
    let determinant = dot(col0, m);
    let q = cross(col0, rhs);
    Cramer {
        determinant,
        beta: dot(rhs, m) / determinant,
        gamma: dot(ray.direction, q) / determinant,
        q,
    }
}

/// The t of a hit the robust test found, recomputed where the ray meets the triangle's plane in
/// f64 from the f32 corners and ray (`#if RECHECK_F64`, which the CPU always has for f32): the
/// differences and products are exact there, so a grazing ray keeps f32 accuracy, which the
/// test's t = T / det loses by up to 1 / cos. A degenerate triangle or a ray in its plane keeps
/// `t`. f64 kernels keep the test's t.
pub(crate) fn plane_t<T: Real>(ray: &Ray<T>, tri: &Triangle<T>, t: T) -> T {
    if T::PRECISION == Float::F64 {
        return t;
    }
    let a = tri.a.cast::<f64>();
    let normal = cross(tri.b.cast::<f64>() - a, tri.c.cast::<f64>() - a);
    let numerator = dot(normal, a - ray.origin.cast::<f64>());
    let denominator = dot(normal, ray.direction.cast::<f64>());
    let refined = T::from_f64(numerator) / T::from_f64(denominator);
    // As WGSL's select on the comparison: NaN keeps t.
    if (refined - t).abs() <= T::HALF * t.abs() {
        refined
    } else {
        t
    }
}

/// Barycentric (u, v) of the ray's hit on the triangle: the hit point is (1 - u - v) a + u b +
/// v c. From the edge functions of the watertight test, or the lecture's Cramer solution.
pub(crate) fn triangle_uv<T: Real, const ROBUST: bool>(
    ray: &Ray<T>,
    shear: &Shear<T>,
    tri: &Triangle<T>,
) -> [T; 2] {
    if ROBUST {
        let e = shear_triangle(ray, shear, tri).edges;
        let determinant = e.x + e.y + e.z;
        [e.y / determinant, e.z / determinant]
    } else {
        let c = cramer(ray, tri);
        [c.beta, c.gamma]
    }
}

/// Unit normal by corner order: normalize((b - a) x (c - a)), never flipped. The robust set
/// scales first, since the squared length of a tiny triangle's normal can underflow.
pub(crate) fn triangle_normal<T: Real, const ROBUST: bool>(tri: &Triangle<T>) -> Vec3<T> {
    unit_normal::<T, ROBUST>(cross(tri.b - tri.a, tri.c - tri.a))
}

/// `n` normalised; zero where it is zero (`unit_normal`).
pub(crate) fn unit_normal<T: Real, const ROBUST: bool>(n: Vec3<T>) -> Vec3<T> {
    if ROBUST {
        let m = n.x.abs().max(n.y.abs().max(n.z.abs()));
        if m == T::ZERO {
            return vec3(T::ZERO, T::ZERO, T::ZERO);
        }
        return normalize(n / m);
    }
    normalize(n)
}
