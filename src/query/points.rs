//! Point queries on an [`Accel`]: the closest point on the geometry to each query point
//! ([`Accel::closest`]), on the GPU (shaders/closest.wgsl) or the CPU reference
//! (src/cpu/closest.rs), through the same BVH as the ray casts.

use super::{Accel, CastReal, RayScene, first_primitives};
use crate::error::Result;
use crate::gpu::{self, Gpu, Job};
use crate::images::MISS;
use crate::math::{Vec3, cross, length};
use crate::rays::{Hits, INVALID_ID, Ray, RayList, check_point};
use crate::render::{Device, Mode, Precision};
use crate::scene::Object;

/// The closest point on the geometry to each query point, in world coordinates and f64 (from
/// a cast in the [`Accel`]'s precision): as Open3D's `compute_closest_points`, with the
/// distance.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Closest {
    /// The closest point.
    pub point: Vec<[f64; 3]>,
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
    pub normal: Vec<[f64; 3]>,
}

impl Accel<'_> {
    /// The closest point on the geometry to each of `points`, through the BVH, nearer boxes
    /// first. Ties (two primitives equally close) go to the lower object id, then the lower
    /// primitive index. Adaptive precision searches in f32: a point query has no hit or miss
    /// for f64 to settle.
    ///
    /// ```
    /// use raycast::{Cpu, Geometry, Precision};
    /// let mut geometry = Geometry::new();
    /// geometry.add_mesh(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], &[[0, 1, 2]])?;
    /// let accel = Cpu.commit(&geometry, Precision::F64)?;
    /// let closest = accel.closest(&[[0.25, 0.25, 2.0], [-1.0, -1.0, 0.0]])?;
    /// assert_eq!(closest.point, [[0.25, 0.25, 0.0], [0.0, 0.0, 0.0]]);
    /// assert_eq!(closest.distance[0], 2.0);
    /// # Ok::<(), raycast::Error>(())
    /// ```
    pub fn closest(&self, points: &[[f64; 3]]) -> Result<Closest> {
        for (k, p) in points.iter().enumerate() {
            check_point(p, &format!("points[{k}]"))?;
        }
        self.scene.closest(self.gpu, self.mode, points)
    }
}

impl RayScene {
    fn closest(&self, gpu: Option<&Gpu>, mode: Mode, points: &[[f64; 3]]) -> Result<Closest> {
        // A query point is the origin of a ray whose direction the kernel does not read.
        let rays: Vec<Ray> = points
            .iter()
            .map(|&origin| Ray {
                origin,
                direction: [0.0, 0.0, 1.0],
            })
            .collect();
        let rays = RayList::from(&rays[..]);
        match (mode.precision, mode.device, gpu) {
            (Precision::F64, Device::Gpu, Some(g)) if !g.has_f64() => {
                let cpu = Mode {
                    device: Device::Cpu,
                    ..mode
                };
                self.closest_in::<f64>(gpu, cpu, rays)
            }
            (Precision::F64, ..) => self.closest_in::<f64>(gpu, mode, rays),
            _ => self.closest_in::<f32>(gpu, mode, rays),
        }
    }

    /// The closest points in precision `R`, in world coordinates.
    fn closest_in<R: CastReal>(
        &self,
        gpu: Option<&Gpu>,
        mode: Mode,
        rays: RayList<'_>,
    ) -> Result<Closest> {
        let (raw, origin, unit) = match mode.device {
            Device::Cpu => {
                let prepared = self.prepared::<R>(mode.algorithm, None)?;
                (
                    crate::cpu::closest_points(&prepared, rays),
                    prepared.origin,
                    prepared.unit,
                )
            }
            Device::Gpu => {
                let gpu =
                    gpu.ok_or_else(|| crate::Error::Device("a gpu: cast needs a GPU".into()))?;
                let general = gpu.scene_variant(&self.scene, R::PRECISION, mode.algorithm);
                let variant = gpu::shader::Variant {
                    closest: true,
                    packets: false,
                    ..general
                };
                let prepared = self.prepared::<R>(mode.algorithm, Some(&variant))?;
                let resident = self.resident(gpu, &prepared, &variant)?;
                let job = Job::new(variant).rays(rays, 0.0).resident(&resident);
                let hits = gpu::run(gpu, &prepared, job)?.hits;
                (
                    hits.expect("a ray list returns hits"),
                    prepared.origin,
                    prepared.unit,
                )
            }
        };
        Ok(self.in_world(&raw, origin, unit))
    }

    /// A closest-point pass's raw results (kernel coordinates: the point in `normal`, its
    /// distance in `t`; primitive keys) in world coordinates, primitives indexed within their
    /// objects, with their normals.
    fn in_world<R: CastReal>(&self, raw: &Hits<R>, origin: Vec3<f64>, unit: f64) -> Closest {
        let first = first_primitives(&self.scene.objects);
        let n = raw.id.len();
        let mut out = Closest {
            point: vec![[f64::INFINITY; 3]; n],
            distance: vec![f64::INFINITY; n],
            id: raw.id.clone(),
            primitive: vec![INVALID_ID; n],
            uv: vec![[0.0; 2]; n],
            normal: vec![[0.0; 3]; n],
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
            out.point[k] = point.to_array();
            out.distance[k] = raw.t[k].to_f64() * unit;
            out.primitive[k] = primitive;
            out.uv[k] = raw.uv[k].map(|x| x.to_f64());
            out.normal[k] = surface_normal(object, primitive, point).to_array();
        }
        out
    }
}

/// The unit normal of `object`'s primitive `primitive` at `point` (on it): a triangle's by its
/// corner order (zero for one without area), a sphere's outward, a plane's own.
fn surface_normal(object: &Object, primitive: u32, point: Vec3<f64>) -> Vec3<f64> {
    let unit = |v: Vec3<f64>| {
        let m = v.x.abs().max(v.y.abs()).max(v.z.abs());
        if m > 0.0 {
            let v = v * (1.0 / m);
            v * (1.0 / length(v))
        } else {
            v
        }
    };
    match object {
        Object::Sphere { center, .. } => {
            let n = unit(point - *center);
            if n == Vec3::splat(0.0) {
                crate::math::vec3(1.0, 0.0, 0.0)
            } else {
                n
            }
        }
        Object::Plane { normal, .. } => *normal,
        Object::Triangle { corners } => {
            unit(cross(corners[1] - corners[0], corners[2] - corners[0]))
        }
        Object::Soup { triangles, .. } => {
            let c = &triangles[primitive as usize];
            unit(cross(c[1] - c[0], c[2] - c[0]))
        }
    }
}
