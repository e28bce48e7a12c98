//! Mirror of shaders/entry.wgsl: the work of one pixel.

use super::camera::camera_ray;
use super::scene::{hit_normal, nearest_hit};
use super::types::Frame;
use crate::math::{Real, length};
use crate::prepare::Primitives;

/// What the kernel writes for one pixel: object id (-1 on a miss), distance and normal
/// (`None` on a miss).
pub struct PixelOut<T> {
    pub id: i32,
    pub surface: Option<([T; 3], T)>,
}

/// The kernel's entry point for pixel (`i`, `j`) (`main` in shaders/entry.wgsl).
pub fn main<T: Real, const ROBUST: bool>(
    frame: &Frame<T>,
    prims: &Primitives<T>,
    unit: T,
    i: u32,
    j: u32,
) -> PixelOut<T> {
    let ray = camera_ray(frame, i, j);
    let hit = nearest_hit::<T, ROBUST>(&ray, frame.min_t, prims);
    if hit.object < 0 {
        return PixelOut {
            id: -1,
            surface: None,
        };
    }
    // Back to world units: an exact power-of-two scaling.
    let distance = hit.t * length(ray.direction) * unit;
    PixelOut {
        id: hit.object,
        surface: Some((
            hit_normal::<T, ROBUST>(&ray, &hit, prims).to_array(),
            distance,
        )),
    }
}
