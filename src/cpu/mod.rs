//! The CPU reference renderer: the same algorithms as the WGSL kernel, file for file and name
//! for name (`shaders/sphere.wgsl` <-> `src/cpu/sphere.rs`), generic over f32 (to reproduce the
//! GPU) and f64 (the truth), multi-threaded with rayon, needing no GPU device.
//!
//! The code keeps the shader's structure and evaluation order even where idiomatic Rust would
//! differ, so the two can be read side by side and f32 results compared bit for bit.

pub(crate) mod closest;
pub(crate) mod count;
pub(crate) mod entry;
pub(crate) mod every_hit;
pub(crate) mod hit;
pub(crate) mod margin;
pub(crate) mod nearest;
#[cfg(any(test, feature = "model"))]
pub(crate) mod packet;
pub(crate) mod plane;
pub(crate) mod raytrace;
pub(crate) mod shade;
pub(crate) mod sphere;
pub(crate) mod traverse;
pub(crate) mod triangle;
// The 8-wide tree's traversal (#62), for the cost model and the tests until a kernel walks it.
#[cfg(any(test, feature = "model"))]
pub(crate) mod wide;
pub(crate) mod winding;

use std::sync::atomic::{AtomicU32, Ordering};

use rayon::prelude::*;

use crate::algorithm::Algorithm;
use crate::images::{Images, MISS, Pixel};
use crate::math::Real;
use crate::prepare::Prepared;

/// Renders `scene` at `scene.camera.resolution` on the CPU with `algorithm` in precision `T`,
/// through a BVH where it pays.
#[cfg(test)]
pub(crate) fn render<T: Real>(scene: &crate::scene::Scene, algorithm: Algorithm) -> Images<T> {
    render_with(scene, algorithm, crate::prepare::bvh::Search::Auto)
}

/// As [`render`], searching with `accel` (for example brute force, the BVH's oracle).
#[cfg(test)]
pub(crate) fn render_with<T: Real>(
    scene: &crate::scene::Scene,
    algorithm: Algorithm,
    accel: crate::prepare::bvh::Search,
) -> Images<T> {
    render_prepared(&Prepared::new(scene, algorithm, accel), &AtomicU32::new(0))
}

/// Renders a prepared scene (through its BVH if it has one), counting finished rows in
/// `rows_done` (for a progress display).
pub(crate) fn render_prepared<T: Real>(prepared: &Prepared<T>, rows_done: &AtomicU32) -> Images<T> {
    let frame = &prepared.frame;
    let prims = &prepared.primitives;
    let robust = prepared.algorithm == Algorithm::Robust;
    let unit = T::from_f64(prepared.unit);
    let mut images = Images::new_miss(frame.nx, frame.ny, prepared.focal_length);
    let width = frame.nx as usize;
    let Images {
        id,
        distance,
        normal,
        ..
    } = &mut images;
    id.par_chunks_mut(width)
        .zip(distance.par_chunks_mut(width))
        .zip(normal.par_chunks_mut(width))
        .enumerate()
        .for_each(|(i, ((id, distance), normal))| {
            for j in 0..width {
                let out = if robust {
                    entry::main::<T, true>(frame, prims, unit, i as u32, j as u32)
                } else {
                    entry::main::<T, false>(frame, prims, unit, i as u32, j as u32)
                };
                id[j] = out.id;
                if let Some((n, d)) = out.surface {
                    normal[j] = n;
                    distance[j] = d;
                }
            }
            rows_done.fetch_add(1, Ordering::Relaxed);
        });
    images
}

/// Renders only the listed pixels (row-major indices) of a prepared scene, in list order.
pub(crate) fn render_pixels<T: Real>(prepared: &Prepared<T>, pixels: &[u32]) -> Vec<Pixel<T>> {
    let frame = &prepared.frame;
    let prims = &prepared.primitives;
    let width = frame.nx;
    let unit = T::from_f64(prepared.unit);
    pixels
        .par_iter()
        .map(|&k| {
            let (i, j) = (k / width, k % width);
            let out = if prepared.algorithm == Algorithm::Robust {
                entry::main::<T, true>(frame, prims, unit, i, j)
            } else {
                entry::main::<T, false>(frame, prims, unit, i, j)
            };
            match out.surface {
                Some((normal, distance)) => Pixel {
                    id: out.id,
                    distance,
                    normal,
                },
                None => Pixel {
                    id: MISS,
                    distance: T::INFINITY,
                    normal: [T::ZERO; 3],
                },
            }
        })
        .collect()
}

/// Casts a caller's rays (world coordinates) through a prepared scene, hits counted from `t_near`
/// (in units of each ray's direction), or with `count` counts every surface crossed: the CPU
/// mirror of a [`crate::gpu::Rays::List`] job, with its raw results (primitive keys).
pub(crate) fn cast_rays<T: Real>(
    prepared: &Prepared<T>,
    rays: crate::rays::RayList<'_>,
    t_near: f64,
    count: bool,
) -> crate::rays::Hits<T> {
    let prims = &prepared.primitives;
    let min_t = T::from_f64(t_near);
    let robust = prepared.algorithm == Algorithm::Robust;
    let mut hits = crate::rays::Hits::new(rays.len(), count);
    if count {
        hits.count = (0..rays.len())
            .into_par_iter()
            .map(|k| {
                let ray = prepared.kernel_ray(&rays.get(k));
                match robust {
                    true => count::count_crossings::<T, true>(&ray, min_t, prims),
                    false => count::count_crossings::<T, false>(&ray, min_t, prims),
                }
            })
            .collect();
        return hits;
    }
    let outs: Vec<entry::RayOut<T>> = (0..rays.len())
        .into_par_iter()
        .map(|k| {
            let ray = prepared.kernel_ray(&rays.get(k));
            match robust {
                true => entry::cast_ray::<T, true>(&ray, min_t, prims),
                false => entry::cast_ray::<T, false>(&ray, min_t, prims),
            }
        })
        .collect();
    for (k, out) in outs.into_iter().enumerate() {
        if let Some(h) = out.hit {
            hits.set(k, out.id, h.t, h.normal, h.primitive, h.uv);
        }
    }
    hits
}

/// The primitive nearest each listed ray's origin (the query points; directions are ignored):
/// the CPU mirror of a CLOSEST ray-list job, with its raw results as the kernel writes them:
/// `t` the distance and `normal` the closest point, both in kernel coordinates, the primitive's
/// key and barycentrics.
pub(crate) fn closest_points<T: Real>(
    prepared: &Prepared<T>,
    points: crate::rays::RayList<'_>,
) -> crate::rays::Hits<T> {
    let prims = &prepared.primitives;
    let outs: Vec<_> = (0..points.len())
        .into_par_iter()
        .map(|k| {
            let p = prepared.kernel_ray(&points.get(k)).origin;
            let hit = closest::closest_to(p, prims);
            let details = (hit.object >= 0).then(|| closest::closest_details(p, &hit, prims));
            (hit, details)
        })
        .collect();
    let mut hits = crate::rays::Hits::new(points.len(), false);
    for (k, (hit, details)) in outs.into_iter().enumerate() {
        if let Some(c) = details {
            let key = nearest::primitive_key(&hit, prims);
            hits.set(k, hit.object, hit.t.sqrt(), c.point.to_array(), key, c.uv);
        }
    }
    hits
}
