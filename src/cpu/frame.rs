//! Mirror of shaders/frame.wgsl: per-pixel ray generation.

use crate::kernel::types::{Frame, Ray};
use crate::math::{Real, vec3};
use crate::scene::Projection;

/// The ray through the centre of pixel (`i`, `j`) of an `nx` x `ny` image: row `i` counts from
/// the top, column `j` from the left. It reaches the image plane at t = 1.
pub(crate) fn camera_ray<T: Real>(frame: &Frame<T>, i: u32, j: u32) -> Ray<T> {
    let (nx, ny) = (frame.nx, frame.ny);
    let two = T::TWO;
    let us = frame.width * (T::from_u32(j) + T::HALF) / T::from_u32(nx) - frame.width / two;
    let vs = -(frame.height * (T::from_u32(i) + T::HALF) / T::from_u32(ny) - frame.height / two);
    let mut ray = Ray {
        origin: vec3(T::ZERO, T::ZERO, T::ZERO),
        direction: vec3(T::ZERO, T::ZERO, T::ZERO),
    };
    if frame.projection == Projection::Orthographic {
        ray.origin = frame.eye + frame.u * us + frame.v * vs;
        ray.direction = frame.w * -frame.focal_length;
    } else {
        ray.origin = frame.eye;
        ray.direction = frame.u * us + frame.v * vs - frame.w * frame.focal_length;
    }
    ray
}
