//! Every hit along each ray ([`Accel::every_hit`], Open3D's `list_intersections`), listed by
//! the CPU reference (src/cpu/every_hit.rs) in the [`Accel`]'s precision.

use rayon::prelude::*;

use super::{Accel, CastReal, RayScene, first_primitives};
use crate::algorithm::Algorithm;
use crate::cpu::every_hit::{EveryHit, every_hit};
use crate::error::Result;
use crate::mode::Precision;
use crate::rays::{RayList, check_rays};

/// Every hit of each ray, ordered by t along it: the hits of ray `k` are entries
/// `ray_splits[k]..ray_splits[k + 1]` of the other lists (Open3D's `list_intersections`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Intersections {
    /// Where each ray's hits start, and the total at the end (`rays + 1` entries).
    pub ray_splits: Vec<usize>,
    /// The ray of each hit.
    pub ray_id: Vec<u32>,
    /// Where along its ray, in units of its direction.
    pub t: Vec<f64>,
    /// The object hit.
    pub id: Vec<i32>,
    /// The primitive's index within its object.
    pub primitive: Vec<u32>,
    /// The barycentric `u, v` of a triangle hit (0 on spheres and planes).
    pub uv: Vec<[f64; 2]>,
}

impl Accel<'_> {
    /// Every surface each ray crosses (`t >= 0`), ordered by t (ties by object id, then
    /// primitive): a mesh's triangles once each, a sphere twice from outside and once from
    /// inside, as [`Accel::count`] counts them. Listed by the CPU reference whatever the
    /// [`Accel`]'s device, in its precision (f64 for adaptive).
    ///
    /// ```
    /// use raycast::{Cpu, DVec3, Geometry, Precision, Ray};
    /// let mut geometry = Geometry::new();
    /// geometry.add_sphere([0.0, 0.0, -3.0], 1.0)?;
    /// let accel = Cpu.commit(&geometry, Precision::F64)?;
    /// let ray = Ray { origin: DVec3::ZERO, direction: DVec3::NEG_Z };
    /// let hits = accel.every_hit(&[ray])?;
    /// assert_eq!((hits.ray_splits, hits.t), (vec![0, 2], vec![2.0, 4.0]));
    /// # Ok::<(), raycast::Error>(())
    /// ```
    pub fn every_hit<'a>(&self, rays: impl Into<RayList<'a>>) -> Result<Intersections> {
        let rays = rays.into();
        check_rays(rays)?;
        let algorithm = self.mode.algorithm;
        Ok(match self.mode.precision {
            Precision::F32 => self
                .scene
                .listed(self.scene.hits_along::<f32>(algorithm, rays)?),
            Precision::F64 | Precision::Adaptive => self
                .scene
                .listed(self.scene.hits_along::<f64>(algorithm, rays)?),
        })
    }

    /// How many crossings [`Accel::every_hit`] lists for each ray, without listing them.
    pub(super) fn crossings(&self, rays: RayList<'_>) -> Result<Vec<usize>> {
        check_rays(rays)?;
        let algorithm = self.mode.algorithm;
        fn counts<T>(per_ray: Vec<Vec<T>>) -> Vec<usize> {
            per_ray.iter().map(Vec::len).collect()
        }
        Ok(match self.mode.precision {
            Precision::F32 => counts(self.scene.hits_along::<f32>(algorithm, rays)?),
            Precision::F64 | Precision::Adaptive => {
                counts(self.scene.hits_along::<f64>(algorithm, rays)?)
            }
        })
    }
}

impl RayScene {
    /// Every hit of each ray, in precision `R`, by the CPU reference.
    fn hits_along<R: CastReal>(
        &self,
        algorithm: Algorithm,
        rays: RayList<'_>,
    ) -> Result<Vec<Vec<EveryHit<R>>>> {
        let prepared = self.prepared::<R>(algorithm, None)?;
        let prims = &prepared.primitives;
        Ok((0..rays.len())
            .into_par_iter()
            .map(|k| {
                let ray = prepared.kernel_ray(&rays.get(k));
                match algorithm {
                    Algorithm::Robust => every_hit::<R, true>(&ray, R::ZERO, prims),
                    Algorithm::Textbook => every_hit::<R, false>(&ray, R::ZERO, prims),
                }
            })
            .collect())
    }

    /// Each ray's hits as one list, primitives indexed within their objects.
    fn listed<R: CastReal>(&self, per_ray: Vec<Vec<EveryHit<R>>>) -> Intersections {
        let first = first_primitives(&self.scene.objects);
        let mut out = Intersections {
            ray_splits: Vec::with_capacity(per_ray.len() + 1),
            ..Intersections::default()
        };
        out.ray_splits.push(0);
        for (k, hits) in per_ray.into_iter().enumerate() {
            for h in hits {
                out.ray_id.push(k as u32);
                out.t.push(h.t.to_f64());
                out.id.push(h.object);
                out.primitive.push(h.key - first[h.object as usize]);
                out.uv.push(h.uv.map(|x| x.to_f64()));
            }
            out.ray_splits.push(out.t.len());
        }
        out
    }
}
