//! Mirror of shaders/types.wgsl: the kernel's value types. The scene's primitives in these
//! types are made by [`crate::prepare`].

use crate::math::{Real, Vec3};

pub use crate::camera::Frame;

/// Returned by the `intersect_*` functions when the ray misses (valid hits have `t >= 1`).
pub fn no_hit<T: Real>() -> T {
    -T::ONE
}

/// The largest finite f32: the initial "nearest so far" distance (`T_FAR` in WGSL).
pub fn t_far<T: Real>() -> T {
    T::from_f64(f32::MAX as f64)
}

/// Relative error allowed for a computed t in the conservative start test (robust set).
pub fn t_tolerance<T: Real>() -> T {
    T::from_f64(16.0) * T::EPS
}

/// Conservative `t >= min_t`: a hit within its own error bound of the ray's start is no hit.
pub fn is_beyond<T: Real>(t: T, min_t: T) -> bool {
    t - t_tolerance::<T>() * t.abs() >= min_t
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray<T> {
    pub origin: Vec3<T>,
    pub direction: Vec3<T>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere<T> {
    pub center: Vec3<T>,
    pub radius: T,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane<T> {
    pub point: Vec3<T>,
    /// Unit length.
    pub normal: Vec3<T>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle<T> {
    pub a: Vec3<T>,
    pub b: Vec3<T>,
    pub c: Vec3<T>,
}
