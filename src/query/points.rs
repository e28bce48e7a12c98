//! Point queries on an [`Accel`]: the closest point on the geometry to each query point
//! ([`Accel::closest`]), on the GPU (shaders/closest.wgsl) or the CPU reference
//! (src/cpu/closest.rs), through the same BVH as the ray casts; generalized winding numbers
//! ([`Accel::winding_numbers`], src/cpu/winding.rs) and which side of the surfaces a point is on
//! ([`Accel::inside`], by ray parity or winding number).

use std::sync::Arc;

use rayon::prelude::*;

use super::{Accel, CastReal, Query, RayScene, f64_mode, first_primitives};
use crate::algorithm::Algorithm;
use crate::cpu::triangle::triangle_normal;
use crate::error::Result;
use crate::gpu::Gpu;
use crate::images::MISS;
use crate::kernel::types::Triangle;
use crate::math::{Vec3, normalize};
use crate::mode::{Mode, Precision};
use crate::prepare::order::{PerPoint, in_spatial_order};
use crate::prepare::winding::{Dipole, dipoles};
use crate::prepare::{kernel_origin, kernel_unit};
use crate::rays::{Hits, INVALID_ID, Ray, RayList, argument, check_points};
use crate::scene::Object;
use glam::DVec3;

/// The closest point on the geometry to each query point, in world coordinates and f64 (from
/// a cast in the [`Accel`]'s precision): as Open3D's `compute_closest_points`, with the
/// distance.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Closest {
    /// The closest point.
    pub point: Vec<DVec3>,
    /// Its distance from the query point.
    pub distance: Vec<f64>,
    /// The id of the object it lies on ([`MISS`] where the geometry is empty).
    pub id: Vec<i32>,
    /// The index of its primitive within that object (a mesh's triangle).
    pub primitive: Vec<u32>,
    /// Its barycentric `u, v` on a triangle (the point is `(1 - u - v) a + u b + v c`); 0 on
    /// spheres and planes.
    pub uv: Vec<[f64; 2]>,
    /// The primitive's unit normal there: a triangle's by its corner order, a sphere's
    /// outward, a plane's own.
    pub normal: Vec<DVec3>,
}

/// How [`Accel::inside`] tells inside from outside.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sign {
    /// Open3D's rule: a point is inside where a ray from it crosses the surfaces an odd number
    /// of times ([`Accel::every_hit`]'s crossings: one through an edge two triangles share),
    /// or by the majority of `samples` rays (odd), along Open3D 0.20's directions (close to
    /// (1, 1, 1), each coordinate within 0.001 of 1, from its seeded generator). Counted by the
    /// CPU reference. Wrong on meshes that are not closed, and may be where a ray passes
    /// within rounding of an edge.
    Parity {
        /// How many rays vote (odd).
        samples: u32,
    },
    /// The generalized winding number above one half ([`Accel::winding_numbers`]): right on
    /// closed meshes wherever rounding allows, and meaningful on open or self-intersecting ones.
    Winding,
}

impl PerPoint for Closest {
    fn unsorted(&self, order: &[u32]) -> Closest {
        Closest {
            point: self.point.unsorted(order),
            distance: self.distance.unsorted(order),
            id: self.id.unsorted(order),
            primitive: self.primitive.unsorted(order),
            uv: self.uv.unsorted(order),
            normal: self.normal.unsorted(order),
        }
    }
}

impl Accel<'_> {
    /// The closest point on the geometry to each of `points`, through the BVH, nearer boxes
    /// first. Ties (two primitives equally close) go to the lower object id, then the lower
    /// primitive index. Adaptive precision searches in f32: a point query has no hit or miss
    /// for f64 to settle.
    ///
    /// ```
    /// use raycast::{Cpu, DVec3, Geometry, Precision};
    /// let mut geometry = Geometry::new();
    /// geometry.add_mesh(&[DVec3::new(0.0, 0.0, 0.0), DVec3::new(1.0, 0.0, 0.0), DVec3::new(0.0, 1.0, 0.0)], &[[0, 1, 2]])?;
    /// let accel = Cpu.commit(&geometry, Precision::F64)?;
    /// let closest = accel.closest(&[DVec3::new(0.25, 0.25, 2.0), DVec3::new(-1.0, -1.0, 0.0)])?;
    /// assert_eq!(closest.point, [DVec3::new(0.25, 0.25, 0.0), DVec3::ZERO]);
    /// assert_eq!(closest.distance[0], 2.0);
    /// # Ok::<(), raycast::Error>(())
    /// ```
    pub fn closest(&self, points: &[DVec3]) -> Result<Closest> {
        let points = bytemuck::cast_slice(points);
        check_points(points)?;
        self.scene.closest(self.gpu, self.mode, points)
    }

    /// The generalized winding number of the geometry at each of `points` (Jacobson et al.
    /// 2013): the solid angle its surfaces subtend there over 4 pi, a triangle positive where
    /// its normal (by corner order) faces away. 1 inside and 0 outside a closed mesh whose
    /// normals face out; on an open one a number between that still tells the sides apart.
    /// Spheres count 1 inside; a plane bounds a half-space and counts 1 behind its normal.
    /// Computed on the CPU in f64 whatever the [`Accel`]'s device and precision, exactly for
    /// triangles near the point and by the dipoles of far BVH subtrees (Barill et al. 2018).
    ///
    /// ```
    /// use raycast::{Cpu, DVec3, Geometry, Precision};
    /// let mut geometry = Geometry::new();
    /// let corners = [DVec3::new(0.0, 0.0, 0.0), DVec3::new(1.0, 0.0, 0.0), DVec3::new(0.0, 1.0, 0.0), DVec3::new(0.0, 0.0, 1.0)];
    /// geometry.add_mesh(&corners, &[[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])?;
    /// let accel = Cpu.commit(&geometry, Precision::F64)?;
    /// let w = accel.winding_numbers(&[DVec3::new(0.1, 0.1, 0.1), DVec3::new(2.0, 2.0, 2.0)])?;
    /// assert!((w[0] - 1.0).abs() < 1e-12 && w[1].abs() < 1e-12);
    /// # Ok::<(), raycast::Error>(())
    /// ```
    pub fn winding_numbers(&self, points: &[DVec3]) -> Result<Vec<f64>> {
        let points = bytemuck::cast_slice(points);
        check_points(points)?;
        self.scene.winding_numbers(points)
    }

    /// Whether each of `points` is inside the geometry, by `sign`'s rule: Open3D's occupancy
    /// (and the sign of its signed distance) with [`Sign::Parity`].
    pub fn inside(&self, points: &[DVec3], sign: Sign) -> Result<Vec<bool>> {
        let points = bytemuck::cast_slice(points);
        check_points(points)?;
        match sign {
            Sign::Winding => Ok(self
                .scene
                .winding_numbers(points)?
                .iter()
                .map(|&w| w > 0.5)
                .collect()),
            Sign::Parity { samples } => self.parity(points, samples),
        }
    }

    /// Inside by the majority of `samples` rays' parities.
    fn parity(&self, points: &[[f64; 3]], samples: u32) -> Result<Vec<bool>> {
        if samples == 0 || samples.is_multiple_of(2) {
            return Err(argument(
                "samples",
                format!("must be a positive odd number, got {samples}"),
            ));
        }
        // Cast from the points in a spatial order, answered in theirs.
        in_spatial_order(points, |origins| {
            let mut votes = vec![0u32; origins.len()];
            for direction in parity_directions(samples) {
                let rays: Vec<Ray> = origins
                    .iter()
                    .map(|&origin| Ray {
                        origin: origin.into(),
                        direction: direction.into(),
                    })
                    .collect();
                // Crossings as every_hit lists them: one where a ray passes through an edge.
                let crossings = self.crossings(RayList::from(&rays[..]))?;
                for (v, c) in votes.iter_mut().zip(crossings) {
                    *v += (c % 2) as u32;
                }
            }
            Ok(votes
                .into_iter()
                .map(|v| 2 * v > samples)
                .collect::<Vec<bool>>())
        })
    }
}

/// The directions of [`Sign::Parity`]'s rays, Open3D 0.20's (`VoteInsideOutside`): each
/// coordinate `1 + u` in f32, `u` uniform in [-0.001, 0.001] from a Mersenne Twister seeded 42,
/// drawn as libstdc++'s `uniform_real_distribution<float>` draws (one 32-bit output over 2^32,
/// below 1), three a direction. Open3D's own rays, so that parity decides as it does.
fn parity_directions(samples: u32) -> Vec<[f64; 3]> {
    let mut twister = Mt19937::new(42);
    let mut coordinate = || {
        let u = (twister.next_u32() as f32 / 4_294_967_296.0_f32).min(1.0 - f32::EPSILON / 2.0);
        let (low, high) = (-0.001_f32, 0.001_f32);
        f64::from(1.0 + (u * (high - low) + low))
    };
    (0..samples)
        .map(|_| [coordinate(), coordinate(), coordinate()])
        .collect()
}

/// The 32-bit Mersenne Twister (Matsumoto and Nishimura 1998), C++'s `std::mt19937`.
struct Mt19937 {
    state: [u32; 624],
    next: usize,
}

impl Mt19937 {
    fn new(seed: u32) -> Mt19937 {
        let mut state = [0u32; 624];
        state[0] = seed;
        for i in 1..624 {
            let previous = state[i - 1];
            state[i] = 1_812_433_253u32
                .wrapping_mul(previous ^ (previous >> 30))
                .wrapping_add(i as u32);
        }
        Mt19937 { state, next: 624 }
    }

    fn next_u32(&mut self) -> u32 {
        if self.next == 624 {
            for i in 0..624 {
                let y = (self.state[i] & 0x8000_0000) | (self.state[(i + 1) % 624] & 0x7fff_ffff);
                let twisted = (y >> 1) ^ if y & 1 != 0 { 0x9908_b0df } else { 0 };
                self.state[i] = self.state[(i + 397) % 624] ^ twisted;
            }
            self.next = 0;
        }
        let mut y = self.state[self.next];
        self.next += 1;
        y ^= y >> 11;
        y ^= (y << 7) & 0x9d2c_5680;
        y ^= (y << 15) & 0xefc6_0000;
        y ^ (y >> 18)
    }
}

impl RayScene {
    /// The winding numbers, computed in a spatial order of the points and returned in theirs.
    fn winding_numbers(&self, points: &[[f64; 3]]) -> Result<Vec<f64>> {
        let prepared = self.prepared::<f64>(Algorithm::Robust, None)?;
        let dipoles = self.dipoles(&prepared);
        in_spatial_order(points, |points| {
            Ok(points
                .par_iter()
                .map(|&p| {
                    crate::cpu::winding::winding_number(
                        prepared.kernel_point(p),
                        &prepared.primitives,
                        dipoles.as_deref().map(|d| &d[..]),
                    )
                })
                .collect::<Vec<f64>>())
        })
    }

    /// The dipoles of `prepared`'s BVH (if it has one), built on first use and kept.
    fn dipoles(&self, prepared: &crate::prepare::Prepared<f64>) -> Option<Arc<Vec<[Dipole; 2]>>> {
        let bvh = prepared.bvh()?;
        let mut cache = self.cache.lock().expect("cache lock");
        let built = cache
            .dipoles
            .get_or_insert_with(|| Arc::new(dipoles(&bvh.nodes, &prepared.primitives)));
        Some(built.clone())
    }

    /// The closest points, searched in a spatial order of the points (each point's answer is
    /// the same, found sooner) and returned in theirs.
    fn closest(&self, gpu: Option<&Gpu>, mode: Mode, points: &[[f64; 3]]) -> Result<Closest> {
        in_spatial_order(points, |points| {
            // A query point is the origin of a ray whose direction the kernel does not read.
            let rays: Vec<Ray> = points
                .iter()
                .map(|&origin| Ray {
                    origin: origin.into(),
                    direction: [0.0, 0.0, 1.0].into(),
                })
                .collect();
            let rays = RayList::from(&rays[..]);
            match mode.precision {
                Precision::F64 => self.closest_in::<f64>(gpu, f64_mode(mode, gpu), rays),
                Precision::F32 | Precision::Adaptive => self.closest_in::<f32>(gpu, mode, rays),
            }
        })
    }

    /// The closest points in precision `R`, in world coordinates.
    fn closest_in<R: CastReal>(
        &self,
        gpu: Option<&Gpu>,
        mode: Mode,
        rays: RayList<'_>,
    ) -> Result<Closest> {
        let (raw, _) = self.run::<R>(gpu, mode, rays, 0.0, Query::Closest)?;
        let origin = kernel_origin(&self.scene, mode.algorithm);
        Ok(self.in_world(&raw, origin, kernel_unit(&self.scene)))
    }

    /// A closest-point pass's raw results (kernel coordinates: the point in `normal`, its
    /// distance in `t`; primitive keys) in world coordinates, primitives indexed within their
    /// objects, with their normals.
    fn in_world<R: CastReal>(&self, raw: &Hits<R>, origin: Vec3<f64>, unit: f64) -> Closest {
        let first = first_primitives(&self.scene.objects);
        let n = raw.id.len();
        let mut out = Closest {
            point: vec![DVec3::INFINITY; n],
            distance: vec![f64::INFINITY; n],
            id: raw.id.clone(),
            primitive: vec![INVALID_ID; n],
            uv: vec![[0.0; 2]; n],
            normal: vec![DVec3::ZERO; n],
        };
        for k in 0..n {
            let id = raw.id[k];
            if id == MISS {
                continue;
            }
            let p = Vec3::from_array(raw.normal[k].map(|x| x.to_f64()));
            let point = origin + p * unit;
            let primitive = raw.primitive[k] - first[id as usize];
            let object = &self.scene.objects[id as usize];
            out.point[k] = point.into();
            out.distance[k] = raw.t[k].to_f64() * unit;
            out.primitive[k] = primitive;
            out.uv[k] = raw.uv[k].map(|x| x.to_f64());
            out.normal[k] = surface_normal(object, primitive, point).into();
        }
        out
    }
}

/// The unit normal of `object`'s primitive `primitive` at `point` (on it): a triangle's by its
/// corner order, as the kernel computes it (zero for one without area), a sphere's outward, a
/// plane's own.
fn surface_normal(object: &Object, primitive: u32, point: Vec3<f64>) -> Vec3<f64> {
    let triangle = |c: &crate::scene::Triangle| {
        triangle_normal::<f64, true>(&Triangle {
            a: c[0].into(),
            b: c[1].into(),
            c: c[2].into(),
        })
    };
    match object {
        // The closest point lies a radius from the centre.
        Object::Sphere { center, .. } => normalize(point - Vec3::from(*center)),
        Object::Plane { normal, .. } => Vec3::from(*normal),
        Object::Triangle { corners } => triangle(corners),
        Object::Soup { triangles, .. } => triangle(&triangles[primitive as usize]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The C++ standard's check of `std::mt19937` ([rand.predef]): seeded 5489, its 10000th
    /// output is 4123659995.
    #[test]
    fn the_twister_is_cpp_mt19937() {
        let mut twister = Mt19937::new(5489);
        let last = (0..10_000).map(|_| twister.next_u32()).last();
        assert_eq!(last, Some(4_123_659_995));
    }

    /// Open3D 0.20's first parity direction, as its occupancy answers showed it
    /// (benches/open3d_queries.py, `open3d_directions`): every coordinate within 0.001 of 1.
    #[test]
    fn parity_directions_are_open3ds() {
        let d = parity_directions(3);
        let first = d[0].map(|x| x as f32);
        assert_eq!(first, [0.999_749_06, 1.000_593_1, 1.000_901_5]);
        assert!(d.iter().flatten().all(|x| (x - 1.0).abs() <= 0.001));
    }
}
