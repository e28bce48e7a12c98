//! Mirror of shaders/types.wgsl: the kernel's value types. The scene's primitives in these
//! types are made by [`crate::prepare`].

use crate::math::{Real, Vec3};

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
