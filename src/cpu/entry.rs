//! Mirror of shaders/entry.wgsl: the work of one pixel, or of one ray of a list.

use super::nearest::{hit_details, hit_normal, nearest_hit, primitive_key};
use crate::kernel::frame::camera_ray;
use crate::kernel::types::{Frame, Ray};
use crate::math::{Real, length};
use crate::prepare::Primitives;

/// What the kernel writes for one pixel: object id (-1 on a miss), distance and normal
/// (`None` on a miss).
pub(crate) struct PixelOut<T> {
    pub id: i32,
    pub surface: Option<([T; 3], T)>,
}

/// The kernel's entry point for pixel (`i`, `j`) (`main` in shaders/entry.wgsl).
pub(crate) fn main<T: Real, const ROBUST: bool>(
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

/// What the kernel writes for one ray of a list (`cast_ray` in shaders/entry.wgsl): object id
/// (-1 on a miss), and on a hit its normal, t, primitive key and barycentrics.
pub(crate) struct RayOut<T> {
    pub id: i32,
    pub hit: Option<RayHit<T>>,
}

pub(crate) struct RayHit<T> {
    pub normal: [T; 3],
    pub t: T,
    /// The primitive's index among its kind in the scene's order.
    pub primitive: u32,
    pub uv: [T; 2],
}

pub(crate) fn cast_ray<T: Real, const ROBUST: bool>(
    ray: &Ray<T>,
    min_t: T,
    prims: &Primitives<T>,
) -> RayOut<T> {
    let hit = nearest_hit::<T, ROBUST>(ray, min_t, prims);
    if hit.object < 0 {
        return RayOut { id: -1, hit: None };
    }
    RayOut {
        id: hit.object,
        hit: Some({
            let details = hit_details::<T, ROBUST>(ray, &hit, prims);
            RayHit {
                normal: details.normal.to_array(),
                t: details.t,
                primitive: primitive_key(&hit, prims),
                uv: details.uv,
            }
        }),
    }
}
