//! Mirror of shaders/types.wgsl: the kernel's value types. The scene's primitives in these
//! types are made by [`crate::prepare`].

use crate::math::{Real, Vec3, cross, dot, vec3};

pub(crate) use crate::kernel::frame::Frame;

/// Returned by the `intersect_*` functions when the ray misses (valid hits have `t >= 1`).
pub(crate) fn no_hit<T: Real>() -> T {
    -T::ONE
}

/// The largest finite f32: the initial "nearest so far" distance (`T_FAR` in WGSL).
pub(crate) fn t_far<T: Real>() -> T {
    T::from_f64(f32::MAX as f64)
}

/// Relative error allowed for a computed t in the conservative start test (robust set).
pub(crate) fn t_tolerance<T: Real>() -> T {
    T::from_f64(16.0) * T::EPS
}

/// Conservative `t >= min_t`: a hit within its own error bound of the ray's start is no hit.
pub(crate) fn is_beyond<T: Real>(t: T, min_t: T) -> bool {
    t - t_tolerance::<T>() * t.abs() >= min_t
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Ray<T> {
    pub origin: Vec3<T>,
    pub direction: Vec3<T>,
}

/// A ray's frame for the watertight triangle test, computed once per ray (`Shear` in WGSL): the
/// axes permuted so that z is the direction's largest component, and the shear that takes the
/// direction to +z.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Shear<T> {
    pub kx: usize,
    pub ky: usize,
    pub kz: usize,
    pub sx: T,
    pub sy: T,
    pub sz: T,
}

pub(crate) fn shear_of<T: Real>(d: Vec3<T>) -> Shear<T> {
    let ad = d.abs();
    let mut kz = 2;
    if ad.x >= ad.y && ad.x >= ad.z {
        kz = 0;
    } else if ad.y >= ad.z {
        kz = 1;
    }
    let mut kx = (kz + 1) % 3;
    let mut ky = (kx + 1) % 3;
    // Keep the winding (and so the sign convention) when the ray points down its main axis.
    if d.get(kz) < T::ZERO {
        std::mem::swap(&mut kx, &mut ky);
    }
    Shear {
        kx,
        ky,
        kz,
        sx: d.get(kx) / d.get(kz),
        sy: d.get(ky) / d.get(kz),
        sz: T::ONE / d.get(kz),
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Sphere<T> {
    pub center: Vec3<T>,
    pub radius: T,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Plane<T> {
    pub point: Vec3<T>,
    /// Unit length.
    pub normal: Vec3<T>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Triangle<T> {
    pub a: Vec3<T>,
    pub b: Vec3<T>,
    pub c: Vec3<T>,
}

/// An instance as a traversal enters it (`instance_transforms` and `instance_words` in WGSL,
/// shaders/bindings.wgsl): the map from the kernel's coordinates to its mesh's (each row
/// `[x, y, z, w]` gives one mesh coordinate, `x k.x + y k.y + z k.z + w`), the node its mesh's
/// tree starts at, and its object.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Instance<T> {
    pub rows: [[T; 4]; 3],
    pub root: u32,
    pub object: u32,
}

/// `ray` in `instance`'s mesh coordinates (`instance_ray`): its direction moved but not
/// normalised, so that the point at t along it is the kernel ray's point at t, placed.
pub(crate) fn instance_ray<T: Real>(ray: &Ray<T>, instance: &Instance<T>) -> Ray<T> {
    let [r0, r1, r2] = instance.rows;
    let point = |r: [T; 4], p: Vec3<T>| r[0] * p.x + r[1] * p.y + r[2] * p.z + r[3];
    let vector = |r: [T; 4], v: Vec3<T>| r[0] * v.x + r[1] * v.y + r[2] * v.z;
    let (o, d) = (ray.origin, ray.direction);
    Ray {
        origin: vec3(point(r0, o), point(r1, o), point(r2, o)),
        direction: vec3(vector(r0, d), vector(r1, d), vector(r2, d)),
    }
}

/// Whether `instance`'s placement mirrors (`mirrors`): its map's determinant is negative, as
/// its inverse's, the rows', is.
pub(crate) fn mirrors<T: Real>(instance: &Instance<T>) -> bool {
    let [r0, r1, r2] = instance.rows.map(|r| vec3(r[0], r[1], r[2]));
    dot(r0, cross(r1, r2)) < T::ZERO
}

/// A normal `n` in `instance`'s mesh coordinates as a direction in the kernel's, not
/// normalised (`instance_normal`): by the transpose of the rows' map, the inverse transpose of
/// the placement's, which keeps it perpendicular to the placed triangle.
pub(crate) fn instance_normal<T: Real>(n: Vec3<T>, instance: &Instance<T>) -> Vec3<T> {
    let [r0, r1, r2] = instance.rows;
    let column = |j: usize| r0[j] * n.x + r1[j] * n.y + r2[j] * n.z;
    vec3(column(0), column(1), column(2))
}
