//! Scalar and 3-vector arithmetic shared by the host (f64) and the CPU reference (f32 or f64).
//!
//! The operations mirror WGSL's (`dot`, `cross`, `normalize`, `length`) and are written out
//! term by term in WGSL's evaluation order, so that the f32 instantiation rounds exactly as an
//! unfused GPU evaluation does. Rust never contracts `a * b + c` into an FMA on its own.

use std::fmt::Debug;
use std::ops::{Add, Div, Mul, Neg, Sub};

/// A floating-point scalar the renderer can run in: `f32` (what the GPU computes) or `f64`
/// (the reference).
pub trait Real:
    Copy
    + Debug
    + PartialOrd
    + Default
    + Send
    + Sync
    + 'static
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// Which of the two this is.
    const PRECISION: Float;
    const ZERO: Self;
    const ONE: Self;
    const HALF: Self;
    const TWO: Self;
    const INFINITY: Self;
    /// Rounds an f64 to this type (round to nearest, as `as` does).
    fn from_f64(x: f64) -> Self;
    /// Converts an integer exactly when it is below 2^24 (f32) or 2^53 (f64), as WGSL's `f32(u)`.
    fn from_u32(x: u32) -> Self;
    fn to_f64(self) -> f64;
    fn sqrt(self) -> Self;
    fn abs(self) -> Self;
    fn is_finite(self) -> bool;
    fn min(self, other: Self) -> Self;
    fn max(self, other: Self) -> Self;
    /// `self` to the power `e` (WGSL's `pow`).
    fn powf(self, e: Self) -> Self;
    fn floor(self) -> Self;
    /// Machine epsilon (WGSL's `EPS` in the generated precision module).
    const EPS: Self;
}

macro_rules! impl_real {
    ($t:ty, $p:expr) => {
        impl Real for $t {
            const PRECISION: Float = $p;
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            const HALF: Self = 0.5;
            const TWO: Self = 2.0;
            const INFINITY: Self = <$t>::INFINITY;
            #[inline]
            fn from_f64(x: f64) -> Self {
                x as $t
            }
            #[inline]
            fn from_u32(x: u32) -> Self {
                x as $t
            }
            #[inline]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline]
            fn sqrt(self) -> Self {
                <$t>::sqrt(self)
            }
            #[inline]
            fn abs(self) -> Self {
                <$t>::abs(self)
            }
            #[inline]
            fn is_finite(self) -> bool {
                <$t>::is_finite(self)
            }
            #[inline]
            fn min(self, other: Self) -> Self {
                <$t>::min(self, other)
            }
            #[inline]
            fn max(self, other: Self) -> Self {
                <$t>::max(self, other)
            }
            #[inline]
            fn powf(self, e: Self) -> Self {
                <$t>::powf(self, e)
            }
            #[inline]
            fn floor(self) -> Self {
                <$t>::floor(self)
            }
            const EPS: Self = <$t>::EPSILON;
        }
    };
}
impl_real!(f32, Float::F32);
impl_real!(f64, Float::F64);

/// The kernel's floating-point type, `real` in the WGSL (a render's [`crate::mode::Precision`]
/// runs one or, adaptive, both).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Float {
    F32,
    F64,
}

impl Float {
    /// `"f32"` or `"f64"`, also the WGSL type name.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Float::F32 => "f32",
            Float::F64 => "f64",
        }
    }
}

impl std::fmt::Display for Float {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Float {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "f32" => Ok(Float::F32),
            "f64" => Ok(Float::F64),
            other => Err(format!("unknown precision `{other}` (expected f32 or f64)")),
        }
    }
}

/// A 3-vector of [`Real`]s with WGSL's `vec3` semantics (component-wise operators).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub(crate) struct Vec3<T> {
    pub x: T,
    pub y: T,
    pub z: T,
}

/// `[x, y, z].into()`: how a client of the API writes a point (a scene's [`crate::scene::Triangle`]).
impl<T> From<[T; 3]> for Vec3<T> {
    fn from([x, y, z]: [T; 3]) -> Self {
        Vec3 { x, y, z }
    }
}

/// Builds a [`Vec3`], like WGSL's `vec3(x, y, z)`.
#[inline]
pub(crate) const fn vec3<T>(x: T, y: T, z: T) -> Vec3<T> {
    Vec3 { x, y, z }
}

impl<T: Real> Vec3<T> {
    pub(crate) fn from_array(a: [T; 3]) -> Self {
        vec3(a[0], a[1], a[2])
    }
    pub(crate) fn to_array(self) -> [T; 3] {
        [self.x, self.y, self.z]
    }
    pub(crate) fn splat(s: T) -> Self {
        vec3(s, s, s)
    }
    /// Rounds each component to another precision (f64 -> f32 rounds to nearest).
    pub(crate) fn cast<U: Real>(self) -> Vec3<U> {
        vec3(
            U::from_f64(self.x.to_f64()),
            U::from_f64(self.y.to_f64()),
            U::from_f64(self.z.to_f64()),
        )
    }
    pub(crate) fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.z.is_finite()
    }
    /// Component `k` (0, 1, 2), like WGSL's `v[k]`.
    pub(crate) fn get(self, k: usize) -> T {
        match k {
            0 => self.x,
            1 => self.y,
            _ => self.z,
        }
    }
    /// Component-wise absolute value.
    pub(crate) fn abs(self) -> Self {
        vec3(self.x.abs(), self.y.abs(), self.z.abs())
    }
    /// Component-wise product, WGSL's `a * b` of two vectors.
    pub(crate) fn times(self, b: Self) -> Self {
        vec3(self.x * b.x, self.y * b.y, self.z * b.z)
    }
}

/// `dot(a, b)` evaluated left to right, unfused: `(a.x*b.x + a.y*b.y) + a.z*b.z`.
#[inline]
pub(crate) fn dot<T: Real>(a: Vec3<T>, b: Vec3<T>) -> T {
    a.x * b.x + a.y * b.y + a.z * b.z
}

/// `cross(a, b)`, each component an unfused difference of products.
#[inline]
pub(crate) fn cross<T: Real>(a: Vec3<T>, b: Vec3<T>) -> Vec3<T> {
    vec3(
        a.y * b.z - a.z * b.y,
        a.z * b.x - a.x * b.z,
        a.x * b.y - a.y * b.x,
    )
}

#[inline]
pub(crate) fn length<T: Real>(a: Vec3<T>) -> T {
    dot(a, a).sqrt()
}

/// `a / length(a)`; the caller guarantees a non-zero vector.
#[inline]
pub(crate) fn normalize<T: Real>(a: Vec3<T>) -> Vec3<T> {
    a / length(a)
}

impl From<glam::DVec3> for Vec3<f64> {
    fn from(v: glam::DVec3) -> Self {
        vec3(v.x, v.y, v.z)
    }
}

impl From<Vec3<f64>> for glam::DVec3 {
    fn from(v: Vec3<f64>) -> Self {
        glam::DVec3::new(v.x, v.y, v.z)
    }
}

impl<T: Real> Add for Vec3<T> {
    type Output = Self;
    #[inline]
    fn add(self, o: Self) -> Self {
        vec3(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}
impl<T: Real> Sub for Vec3<T> {
    type Output = Self;
    #[inline]
    fn sub(self, o: Self) -> Self {
        vec3(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}
impl<T: Real> Neg for Vec3<T> {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        vec3(-self.x, -self.y, -self.z)
    }
}
impl<T: Real> Mul<T> for Vec3<T> {
    type Output = Self;
    #[inline]
    fn mul(self, s: T) -> Self {
        vec3(self.x * s, self.y * s, self.z * s)
    }
}
impl<T: Real> Div<T> for Vec3<T> {
    type Output = Self;
    #[inline]
    fn div(self, s: T) -> Self {
        vec3(self.x / s, self.y / s, self.z / s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cross_follows_right_hand_rule() {
        let x = vec3(1.0f64, 0.0, 0.0);
        let y = vec3(0.0f64, 1.0, 0.0);
        assert_eq!(cross(x, y), vec3(0.0, 0.0, 1.0));
        assert_eq!(cross(y, x), vec3(0.0, 0.0, -1.0));
    }

    #[test]
    fn cast_rounds_to_nearest_f32() {
        let v = vec3(0.1f64, 1.0 / 3.0, 1e-50);
        let w: Vec3<f32> = v.cast();
        assert_eq!(w, vec3(0.1f32, 1.0f32 / 3.0, 0.0));
    }
}
