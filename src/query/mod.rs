//! Casting a caller's rays ([`crate::rays`]) at geometry held on a device: any number of rays
//! (origin and direction each, world coordinates) through the same preparation and the same
//! kernel job as camera renders ([`crate::gpu::Rays::List`]), on the GPU in f32, f64 or adaptive
//! precision, or on the CPU reference (`crate::cpu::cast_rays`).
//!
//! A [`Geometry`] holds the objects (from a scene file, or added from memory: meshes, spheres,
//! planes); [`Gpu::commit`] or [`Cpu::commit`] builds its search structure once, in one
//! precision, and uploads it: the [`Accel`] every query reuses. Per ray a nearest-hit query
//! ([`Accel::intersect`]) gives `t` (in units of the ray's direction, as Open3D's `t_hit`), the
//! object id, the primitive's index within its object, the barycentric `u, v` of a triangle
//! hit and the geometric normal ([`Hits`]); [`Accel::occluded`] answers shadow-ray queries
//! between `t_near` and `t_far`, and [`Accel::count`] counts the surfaces each ray crosses.
//!
//! ```no_run
//! use raycast::{DVec3, Geometry, Gpu, Precision, Ray};
//! let mut geometry = Geometry::new();
//! let id = geometry.add_mesh(&[DVec3::new(0.0, 0.0, 0.0), DVec3::new(1.0, 0.0, 0.0), DVec3::new(0.0, 1.0, 0.0)], &[[0, 1, 2]])?;
//! let gpu = Gpu::new()?;
//! let accel = gpu.commit(&geometry, Precision::F32)?;
//! let ray = Ray { origin: DVec3::new(0.25, 0.25, 1.0), direction: DVec3::NEG_Z };
//! let hits = accel.intersect(&[ray])?;
//! assert_eq!(hits.id()[0], id as i32);
//! # Ok::<(), raycast::Error>(())
//! ```

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use crate::algorithm::Algorithm;
use crate::error::{Error, Result};
use crate::gpu::{self, Gpu, Job};
use crate::images::MISS;
use crate::kernel::layout::GpuReal;
use crate::math::{Float, Vec3};
use crate::mode::{Device, Mode, Precision};
use crate::prepare::Prepared;
use crate::prepare::bvh::{Search, bounded_count};
use crate::prepare::shared::{Shared, sharing};
use crate::rays::{
    AnyHits, Hits, RayList, argument, check_point, check_rays, coherent, one_origin,
};
use crate::render::Cpu;
use crate::scene::{self, Camera, Lens, Mesh, Object, Placement, Projection, Scene};
use glam::{DAffine3, DVec3};

pub(crate) mod every_hit;
pub(crate) mod points;

/// Objects to cast rays at, without a camera: triangle meshes, spheres and planes, each with
/// its id (its index, in the order added). [`Gpu::commit`] and [`Cpu::commit`] prepare it for
/// queries.
///
/// ```
/// use raycast::{Cpu, DVec3, Geometry, Precision, Ray};
/// let mut geometry = Geometry::new();
/// let sphere = geometry.add_sphere([0.0, 0.0, -3.0], 1.0)?;
/// let accel = Cpu.commit(&geometry, Precision::F64)?;
/// let ray = Ray { origin: DVec3::ZERO, direction: DVec3::NEG_Z };
/// let hits = accel.intersect(&[ray])?;
/// assert_eq!(hits.id()[0], sphere as i32);
/// assert!((hits.t_f64()[0] - 2.0).abs() < 1e-12);
/// assert_eq!(accel.count(&[ray])?, [2]); // in and out
/// # Ok::<(), raycast::Error>(())
/// ```
#[derive(Clone, Debug, Default)]
pub struct Geometry {
    /// The intersection formulas its commits use: robust by default. Embree's robust flag in
    /// the same place: set on the geometry, before the commit.
    pub algorithm: Algorithm,
    objects: Vec<Object>,
    /// The camera of the scene file it came from: its eye is where the robust kernel measures
    /// from. Without one, [`framing_camera`] places it at the objects' centre.
    camera: Option<Camera>,
    /// The scene file's instances and those added (meshes placed by transforms), whose
    /// meshes' own trees a commit joins rather than building one tree over every copy.
    instances: Vec<Placement>,
    /// The meshes' own trees, built by the first commit that needs them and kept for the
    /// next (shared by clones: a mesh does not change).
    trees: Arc<Mutex<Shared>>,
}

impl Geometry {
    /// No objects: every ray misses.
    pub fn new() -> Geometry {
        Geometry::default()
    }

    /// Whether there are no objects.
    #[cfg(test)]
    pub(crate) fn is_empty(&self) -> bool {
        self.objects.is_empty()
    }

    /// A loaded scene's objects, measured from its camera's eye.
    pub fn from_scene(scene: &Scene) -> Geometry {
        Geometry {
            algorithm: Algorithm::default(),
            objects: scene.objects.clone(),
            camera: Some(scene.camera.clone()),
            instances: scene.instances.clone(),
            trees: Arc::default(),
        }
    }

    /// Adds a triangle mesh, `triangles` indexing `vertices`, as one object; returns its id.
    /// Every coordinate must be finite and at most 1e18 in magnitude, every index in range.
    ///
    /// ```
    /// use raycast::{Cpu, DVec3, Geometry, Precision, Ray};
    /// let mut geometry = Geometry::new();
    /// let square = [DVec3::new(0.0, 0.0, 0.0), DVec3::new(1.0, 0.0, 0.0), DVec3::new(1.0, 1.0, 0.0), DVec3::new(0.0, 1.0, 0.0)];
    /// let id = geometry.add_mesh(&square, &[[0, 1, 2], [0, 2, 3]])?;
    /// let accel = Cpu.commit(&geometry, Precision::F64)?;
    /// let down = Ray { origin: DVec3::new(0.75, 0.25, 2.0), direction: DVec3::NEG_Z };
    /// let hits = accel.intersect(&[down])?;
    /// assert_eq!((hits.id()[0], hits.t_f64()[0]), (id as i32, 2.0));
    /// assert_eq!(accel.count(&[down])?, [1]);
    /// # Ok::<(), raycast::Error>(())
    /// ```
    pub fn add_mesh(&mut self, vertices: &[DVec3], triangles: &[[u32; 3]]) -> Result<u32> {
        for (k, v) in vertices.iter().enumerate() {
            check_point(&v.to_array(), &format!("vertices[{k}]"))?;
        }
        let corners = triangles
            .iter()
            .enumerate()
            .map(|(k, t)| {
                let corner = |c: usize| {
                    let i = t[c] as usize;
                    vertices.get(i).copied().ok_or_else(|| {
                        argument(
                            &format!("triangles[{k}][{c}]"),
                            format!("index {i} is out of range ({} vertices)", vertices.len()),
                        )
                    })
                };
                Ok([corner(0)?, corner(1)?, corner(2)?])
            })
            .collect::<Result<Vec<_>>>()?;
        self.push(Object::Soup {
            path: "<memory>".into(),
            triangles: corners,
        })
    }

    /// Adds a sphere; returns its id. The radius must be positive.
    pub fn add_sphere(&mut self, center: impl Into<DVec3>, radius: f64) -> Result<u32> {
        let center = center.into();
        check_point(&center.to_array(), "center")?;
        if !(radius > 0.0 && radius <= crate::scene::MAX_MAGNITUDE) {
            return Err(argument(
                "radius",
                format!("must be positive and at most 1e18, got {radius}"),
            ));
        }
        self.push(Object::Sphere { center, radius })
    }

    /// Adds a plane through `point` facing `normal` (normalised here; it must not be zero);
    /// returns its id.
    pub fn add_plane(&mut self, point: impl Into<DVec3>, normal: impl Into<DVec3>) -> Result<u32> {
        let (point, normal) = (point.into(), normal.into());
        check_point(&point.to_array(), "point")?;
        check_point(&normal.to_array(), "normal")?;
        let n = Vec3::from(normal);
        let length = crate::math::length(n);
        if length.is_nan() || length <= 0.0 {
            return Err(argument("normal", "must not be zero".into()));
        }
        self.push(Object::Plane {
            point,
            normal: (n * (1.0 / length)).into(),
        })
    }

    /// Places another copy of the triangle mesh `mesh` (an id [`Geometry::add_mesh`] returned,
    /// or a scene file's mesh or instance) by `transform`, the map from the mesh's own
    /// coordinates (as added, or as its scene file's mesh file gives them) to the world's;
    /// returns its id.
    /// The copies share one mesh, whose tree a commit builds once however many place it.
    ///
    /// ```
    /// use raycast::{Cpu, DAffine3, DVec3, Geometry, Precision, Ray};
    /// let mut geometry = Geometry::new();
    /// let square = [DVec3::new(0.0, 0.0, 0.0), DVec3::new(1.0, 0.0, 0.0), DVec3::new(1.0, 1.0, 0.0), DVec3::new(0.0, 1.0, 0.0)];
    /// let mesh = geometry.add_mesh(&square, &[[0, 1, 2], [0, 2, 3]])?;
    /// let lifted = geometry.add_instance(mesh, DAffine3::from_translation(DVec3::new(0.0, 0.0, 1.0)))?;
    /// let down = Ray { origin: DVec3::new(0.75, 0.25, 2.0), direction: DVec3::NEG_Z };
    /// let hits = Cpu.commit(&geometry, Precision::F64)?.intersect(&[down])?;
    /// assert_eq!((hits.id()[0], hits.t_f64()[0]), (lifted as i32, 1.0));
    /// geometry.set_transforms(&[lifted], &[DAffine3::from_translation(DVec3::new(0.0, 0.0, -1.0))])?;
    /// let hits = Cpu.commit(&geometry, Precision::F64)?.intersect(&[down])?;
    /// assert_eq!((hits.id()[0], hits.t_f64()[0]), (mesh as i32, 2.0));
    /// # Ok::<(), raycast::Error>(())
    /// ```
    pub fn add_instance(&mut self, mesh: u32, transform: DAffine3) -> Result<u32> {
        let mesh = self.mesh_of(mesh)?;
        check_transform(&transform, &mesh, "transform")?;
        let id = self.push(Object::Soup {
            path: mesh.path.clone(),
            triangles: scene::place(&mesh.triangles, &transform),
        })?;
        self.instances.push(Placement {
            object: id as usize,
            mesh,
            transform,
        });
        Ok(id)
    }

    /// Moves the instances `ids` (ids [`Geometry::add_instance`] returned, or a scene file's
    /// instances) to `transforms`, one each, each from its mesh's own coordinates. A commit
    /// after it builds the tree over the instances again, not the meshes' trees.
    pub fn set_transforms(&mut self, ids: &[u32], transforms: &[DAffine3]) -> Result<()> {
        if ids.len() != transforms.len() {
            let message = format!(
                "gives {} transforms for {} ids: one each",
                transforms.len(),
                ids.len()
            );
            return Err(argument("transforms", message));
        }
        let mut moved = Vec::with_capacity(ids.len());
        for (k, (&id, m)) in ids.iter().zip(transforms).enumerate() {
            let Some(p) = self.instances.iter().position(|p| p.object == id as usize) else {
                let message = format!("object {id} is not an instance (add_instance places one)");
                return Err(argument(&format!("ids[{k}]"), message));
            };
            check_transform(m, &self.instances[p].mesh, &format!("transforms[{k}]"))?;
            moved.push((p, *m));
        }
        for (p, m) in moved {
            let placement = &mut self.instances[p];
            placement.transform = m;
            self.objects[placement.object] = Object::Soup {
                path: placement.mesh.path.clone(),
                triangles: scene::place(&placement.mesh.triangles, &m),
            };
        }
        Ok(())
    }

    /// The mesh object `of` places (argument `mesh`): its instance's, or (made an instance of
    /// itself, in place) its own triangles.
    fn mesh_of(&mut self, of: u32) -> Result<Arc<Mesh>> {
        if let Some(p) = self.instances.iter().find(|p| p.object == of as usize) {
            return Ok(p.mesh.clone());
        }
        let Some(Object::Soup { path, triangles }) = self.objects.get(of as usize) else {
            let message = match self.objects.len() {
                n if of as usize >= n => format!("object {of} does not exist ({n} objects)"),
                _ => format!("object {of} is not a triangle mesh"),
            };
            return Err(argument("mesh", message));
        };
        let mesh = Arc::new(Mesh {
            path: path.clone(),
            triangles: triangles.clone(),
        });
        self.instances.push(Placement {
            object: of as usize,
            mesh: mesh.clone(),
            transform: DAffine3::IDENTITY,
        });
        Ok(mesh)
    }

    fn push(&mut self, object: Object) -> Result<u32> {
        let id = u32::try_from(self.objects.len())
            .ok()
            .filter(|&id| id < i32::MAX as u32)
            .ok_or_else(|| argument("geometry", "too many objects".into()))?;
        self.objects.push(object);
        Ok(id)
    }
}

/// Refuses a transform (argument `what`) that is not finite, is singular, or places `mesh`
/// beyond 1e18, a scene file's largest coordinate.
fn check_transform(m: &DAffine3, mesh: &Mesh, what: &str) -> Result<()> {
    if let Some(x) = (m.to_cols_array().into_iter()).find(|x| !x.is_finite()) {
        return Err(argument(what, format!("must be finite, got {x}")));
    }
    if let Some(why) = scene::singular(m) {
        return Err(argument(what, why));
    }
    let moved = mesh.bounds().map(|b| scene::moved_box(b, m));
    if let Some((lo, hi)) = moved
        && lo.abs().max(hi.abs()).max_element() > scene::MAX_MAGNITUDE
    {
        let message = format!("places the mesh beyond {:e}", scene::MAX_MAGNITUDE);
        return Err(argument(what, message));
    }
    Ok(())
}

/// A [`Geometry`] prepared on a device in one precision: its search structure built and
/// uploaded once by [`Gpu::commit`] or [`Cpu::commit`], then queried by any number of casts.
pub struct Accel<'d> {
    scene: RayScene,
    gpu: Option<&'d Gpu>,
    mode: Mode,
}

impl std::fmt::Debug for Accel<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Accel")
            .field("objects", &self.scene.scene.objects.len())
            .field("mode", &self.mode)
            .finish_non_exhaustive()
    }
}

impl Gpu {
    /// Prepares `geometry` for queries on this GPU in `precision` (with its
    /// [`Geometry::algorithm`]): the BVH built and the buffers uploaded now, once.
    ///
    /// ```no_run
    /// use raycast::{DVec3, Geometry, Gpu, Precision, Ray};
    /// let mut geometry = Geometry::new();
    /// geometry.add_mesh(&[DVec3::new(0.0, 0.0, 0.0), DVec3::new(1.0, 0.0, 0.0), DVec3::new(0.0, 1.0, 0.0)], &[[0, 1, 2]])?;
    /// let gpu = Gpu::new()?;
    /// let accel = gpu.commit(&geometry, Precision::Adaptive)?; // borrows `gpu`
    /// let down = Ray { origin: DVec3::new(0.25, 0.25, 1.0), direction: DVec3::NEG_Z };
    /// assert_eq!(accel.occluded(&[down], 0.0, 2.0)?, [true]);
    /// # Ok::<(), raycast::Error>(())
    /// ```
    pub fn commit(&self, geometry: &Geometry, precision: Precision) -> Result<Accel<'_>> {
        Accel::new(geometry, Some(self), Device::Gpu, precision)
    }
}

impl Cpu {
    /// Prepares `geometry` for queries by the CPU reference in `precision` (with its
    /// [`Geometry::algorithm`]; adaptive precision casts in f64 throughout).
    pub fn commit(&self, geometry: &Geometry, precision: Precision) -> Result<Accel<'static>> {
        Accel::new(geometry, None, Device::Cpu, precision)
    }
}

impl<'d> Accel<'d> {
    fn new(
        geometry: &Geometry,
        gpu: Option<&'d Gpu>,
        device: Device,
        precision: Precision,
    ) -> Result<Accel<'d>> {
        let mode = Mode {
            device,
            precision,
            algorithm: geometry.algorithm,
        };
        Accel::with_mode(geometry, gpu, mode)
    }

    fn with_mode(geometry: &Geometry, gpu: Option<&'d Gpu>, mode: Mode) -> Result<Accel<'d>> {
        let scene = RayScene::new(geometry);
        let mut trees = geometry.trees.lock().expect("the mesh trees' lock");
        trees.keep_trees_of(&geometry.instances);
        sharing(&scene.scene, &mut trees, || scene.warm(gpu, mode))?;
        Ok(Accel { scene, gpu, mode })
    }

    /// This `Accel` with its GPU queries' kernels timed from now on, by the device's timestamp
    /// queries (each cast reads them back too: a small cost), for [`Accel::kernel_seconds`].
    pub fn timed(mut self) -> Accel<'d> {
        self.scene.kernel_s.get_or_insert_with(Mutex::default);
        self
    }

    /// The GPU seconds of the kernels of every query since [`Accel::timed`], each pass of a
    /// query counted (adaptive precision's f64 re-cast too); `None` before a GPU pass was timed,
    /// on the CPU, or where the device has no timestamp queries.
    pub fn kernel_seconds(&self) -> Option<f64> {
        let total = self.scene.kernel_s.as_ref()?;
        *total.lock().expect("the kernel time's lock")
    }

    /// The nearest hit of every ray (`t >= 0`). Rays are traced one by one, or where the
    /// device takes packets ([`crate::GpuInfo::packet_rays_per_primitive`]: lavapipe, for lists
    /// of many rays for the scene's primitives) and they are coherent (neighbours in the list
    /// start close together and point nearly the same way), in packets sharing node fetches.
    pub fn intersect<'a>(&self, rays: impl Into<RayList<'a>>) -> Result<AnyHits> {
        self.scene.nearest(self.gpu, self.mode, rays.into(), 0.0)
    }

    /// Whether each ray hits anything with `t_near <= t <= t_far` (shadow rays).
    pub fn occluded<'a>(
        &self,
        rays: impl Into<RayList<'a>>,
        t_near: f64,
        t_far: f64,
    ) -> Result<Vec<bool>> {
        self.scene
            .occluded(self.gpu, self.mode, rays.into(), t_near, t_far)
    }

    /// How many surfaces each ray crosses (`t >= 0`): a mesh's triangles once each (a ray
    /// through an edge two triangles share counts both; [`Accel::every_hit`] lists such a
    /// crossing once), a sphere twice from outside and once from inside. Adaptive precision
    /// counts in f64.
    pub fn count<'a>(&self, rays: impl Into<RayList<'a>>) -> Result<Vec<u32>> {
        self.scene.count(self.gpu, self.mode, rays.into())
    }
}

/// What a pass over a ray list finds for each ray.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Query {
    /// The nearest hit.
    Nearest,
    /// How many surfaces it crosses.
    Count,
    /// The primitive nearest its origin (a query point).
    Closest,
    /// Whether it hits anything up to this t.
    Occluded(f64),
}

/// A geometry's objects with their preparations, built once per precision and algorithm and
/// reused by every cast.
#[derive(Debug)]
struct RayScene {
    /// The objects, and the camera of a scene file (its eye is where the robust kernel measures
    /// from) or one [`framing_camera`] places at their centre.
    scene: Scene,
    /// The largest side of the objects' bounds: what [`coherent`] measures ray origins by.
    extent: f64,
    cache: Mutex<Cache>,
    /// Where the GPU's kernels are timed ([`Accel::timed`]): their seconds so far, `None` until
    /// a pass reported some.
    kernel_s: Option<Mutex<Option<f64>>>,
}

/// Preparations by precision, algorithm and acceleration, and their buffers on a device.
#[derive(Default)]
pub(crate) struct Cache {
    f32: HashMap<PreparedFor, Arc<Prepared<f32>>>,
    f64: HashMap<PreparedFor, Arc<Prepared<f64>>>,
    resident: HashMap<(Float, PreparedFor), Arc<gpu::Resident>>,
    /// The far-field data of the robust f64 preparation's BVH, for winding numbers.
    dipoles: Option<Arc<Vec<[crate::prepare::winding::Dipole; 2]>>>,
}

impl std::fmt::Debug for Cache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Cache")
            .field("f32", &self.f32.keys())
            .field("f64", &self.f64.keys())
            .field("resident", &self.resident.keys())
            .finish()
    }
}

/// What a preparation is for: the algorithm, whether through a BVH, and whether that tree
/// names the instances, which the kernel walks in their meshes' coordinates.
type PreparedFor = (Algorithm, bool, bool);

/// A kernel precision with its place in the [`Cache`].
pub(crate) trait CastReal: GpuReal {
    fn cached(cache: &mut Cache) -> &mut HashMap<PreparedFor, Arc<Prepared<Self>>>;
}

impl CastReal for f32 {
    fn cached(cache: &mut Cache) -> &mut HashMap<PreparedFor, Arc<Prepared<f32>>> {
        &mut cache.f32
    }
}

impl CastReal for f64 {
    fn cached(cache: &mut Cache) -> &mut HashMap<PreparedFor, Arc<Prepared<f64>>> {
        &mut cache.f64
    }
}

impl RayScene {
    fn new(geometry: &Geometry) -> RayScene {
        let bounds = scene::bounds(&geometry.objects);
        let camera = (geometry.camera.clone()).unwrap_or_else(|| framing_camera(bounds));
        RayScene {
            scene: Scene {
                camera,
                objects: geometry.objects.clone(),
                lighting: Default::default(),
                warnings: Vec::new(),
                instances: geometry.instances.clone(),
            },
            extent: extent(bounds),
            cache: Mutex::default(),
            kernel_s: None,
        }
    }

    /// Builds (and on a GPU uploads) what casts in `mode` use first.
    fn warm(&self, gpu: Option<&Gpu>, mode: Mode) -> Result<()> {
        fn on<R: CastReal>(scene: &RayScene, gpu: Option<&Gpu>, mode: Mode) -> Result<()> {
            match (mode.device, gpu) {
                (Device::Gpu, Some(gpu)) if R::PRECISION == Float::F32 || gpu.has_f64() => {
                    let variant = gpu.scene_variant(&scene.scene, R::PRECISION, mode.algorithm);
                    let variant = variant.with_instances(&scene.scene);
                    let prepared = scene.prepared::<R>(mode.algorithm, Some(&variant))?;
                    scene.resident(gpu, &prepared, &variant).map(|_| ())
                }
                _ => scene.prepared::<R>(mode.algorithm, None).map(|_| ()),
            }
        }
        match (mode.device, mode.precision) {
            (Device::Gpu, Precision::F32 | Precision::Adaptive) => on::<f32>(self, gpu, mode),
            (Device::Cpu, Precision::F32) => on::<f32>(self, gpu, mode),
            _ => on::<f64>(self, gpu, mode),
        }
    }

    fn occluded(
        &self,
        gpu: Option<&Gpu>,
        mode: Mode,
        rays: RayList<'_>,
        t_near: f64,
        t_far: f64,
    ) -> Result<Vec<bool>> {
        if !(t_near >= 0.0 && t_near.is_finite()) || t_far.is_nan() {
            return Err(argument(
                "tnear",
                format!("expected 0 <= tnear < inf and a tfar, got {t_near} and {t_far}"),
            ));
        }
        // One word a ray from the GPU's occlusion kernel; adaptive precision decides by the
        // nearest hit, which its certainty pass covers.
        match (mode.device, mode.precision, gpu) {
            (Device::Gpu, Precision::F32, Some(gpu)) => {
                return self.occluded_on::<f32>(gpu, mode, rays, t_near, t_far);
            }
            (Device::Gpu, Precision::F64, Some(gpu)) => {
                return self.occluded_on::<f64>(gpu, mode, rays, t_near, t_far);
            }
            _ => {}
        }
        let hits = self.nearest(gpu, mode, rays, t_near)?;
        let t = hits.t_f64();
        let hit = |k: usize| hits.id()[k] != MISS && t[k] <= t_far;
        Ok((0..rays.len()).map(hit).collect())
    }

    /// Whether each ray hits anything from `t_near` to `t_far`, by the GPU's occlusion kernel
    /// in precision `R`.
    fn occluded_on<R: CastReal>(
        &self,
        gpu: &Gpu,
        mode: Mode,
        rays: RayList<'_>,
        t_near: f64,
        t_far: f64,
    ) -> Result<Vec<bool>> {
        let rendered = self.on_gpu::<R>(gpu, mode, rays, t_near, Query::Occluded(t_far))?;
        Ok(rendered
            .occluded
            .expect("an occlusion pass returns its flags"))
    }

    fn count(&self, gpu: Option<&Gpu>, mode: Mode, rays: RayList<'_>) -> Result<Vec<u32>> {
        let hits = match mode.precision {
            Precision::F32 => self.run::<f32>(gpu, mode, rays, 0.0, Query::Count)?.0.count,
            Precision::F64 | Precision::Adaptive => {
                self.run::<f64>(gpu, f64_mode(mode, gpu), rays, 0.0, Query::Count)?
                    .0
                    .count
            }
        };
        Ok(hits)
    }

    fn nearest(
        &self,
        gpu: Option<&Gpu>,
        mode: Mode,
        rays: RayList<'_>,
        t_near: f64,
    ) -> Result<AnyHits> {
        let hits = match mode.precision {
            Precision::F32 => {
                AnyHits::F32(self.run::<f32>(gpu, mode, rays, t_near, Query::Nearest)?.0)
            }
            Precision::F64 => {
                AnyHits::F64(self.run::<f64>(gpu, mode, rays, t_near, Query::Nearest)?.0)
            }
            Precision::Adaptive => AnyHits::F32(self.adaptive(gpu, mode, rays, t_near)?),
        };
        Ok(self.within_objects(hits))
    }

    /// Adaptive precision for rays (as for images, [`crate::render::adaptive`]): a robust f32 pass that
    /// says which rays' hit/miss and id are certain, the others cast again in f64 and merged
    /// in: on the CPU where they are at most [`crate::render::adaptive::CPU_RECAST_PIXELS`] (quicker
    /// than compiling the GPU's f64 kernel) or the GPU has no f64, else on the GPU.
    fn adaptive(
        &self,
        gpu: Option<&Gpu>,
        mode: Mode,
        rays: RayList<'_>,
        t_near: f64,
    ) -> Result<Hits<f32>> {
        let n = rays.len();
        let mode = Mode {
            algorithm: Algorithm::Robust,
            ..mode
        };
        let (mut hits, certain) = match mode.device {
            Device::Gpu => self.run::<f32>(gpu, mode, rays, t_near, Query::Nearest)?,
            // The CPU reference has no certainty pass: f64 throughout.
            Device::Cpu => (Hits::new(n, false), Some(vec![false; n])),
        };
        let certain = certain.expect("a certainty pass reports certainty");
        let uncertain: Vec<usize> = (0..n).filter(|&k| !certain[k]).collect();
        if uncertain.is_empty() {
            return Ok(hits);
        }
        let again = rays.subset(&uncertain);
        let exact_mode = match gpu {
            Some(g)
                if mode.device == Device::Gpu
                    && crate::render::adaptive::recasts_on_gpu(
                        g,
                        uncertain.len(),
                        crate::render::adaptive::CPU_RECAST_PIXELS,
                    ) =>
            {
                mode
            }
            _ => Mode {
                device: Device::Cpu,
                ..mode
            },
        };
        let (exact, _) = self.run::<f64>(
            gpu,
            exact_mode,
            again.as_slice().into(),
            t_near,
            Query::Nearest,
        )?;
        for (j, &k) in uncertain.iter().enumerate() {
            hits.id[k] = exact.id[j];
            hits.t[k] = exact.t[j] as f32;
            hits.primitive[k] = exact.primitive[j];
            hits.uv[k] = exact.uv[j].map(|x| x as f32);
            hits.normal[k] = exact.normal[j].map(|x| x as f32);
        }
        Ok(hits)
    }

    /// One pass of `query` in precision `R`: the raw hits (primitive keys; a closest-point
    /// pass's as `crate::cpu::closest_points` describes them) and, from an adaptive GPU pass,
    /// the certainty flags.
    fn run<R: CastReal>(
        &self,
        gpu: Option<&Gpu>,
        mode: Mode,
        rays: RayList<'_>,
        t_near: f64,
        query: Query,
    ) -> Result<(Hits<R>, Option<Vec<bool>>)> {
        match mode.device {
            Device::Cpu => {
                check_rays(rays)?;
                let prepared = self.prepared::<R>(mode.algorithm, None)?;
                let hits = match query {
                    Query::Closest => crate::cpu::closest_points(&prepared, rays),
                    _ => crate::cpu::cast_rays(&prepared, rays, t_near, query == Query::Count),
                };
                Ok((hits, None))
            }
            Device::Gpu => {
                let gpu = gpu.ok_or_else(|| Error::Device("a gpu: cast needs a GPU".into()))?;
                let rendered = self.on_gpu::<R>(gpu, mode, rays, t_near, query)?;
                let hits = rendered.hits.expect("a ray list returns hits");
                Ok((hits, rendered.certainty))
            }
        }
    }

    /// One pass of `query` in precision `R` on `gpu`, as the kernel delivers it.
    fn on_gpu<R: CastReal>(
        &self,
        gpu: &Gpu,
        mode: Mode,
        rays: RayList<'_>,
        t_near: f64,
        query: Query,
    ) -> Result<gpu::Rendered<R>> {
        let general = gpu.scene_variant(&self.scene, R::PRECISION, mode.algorithm);
        let variant = gpu::shader::Variant {
            certainty: query == Query::Nearest
                && mode.precision == Precision::Adaptive
                && R::PRECISION == Float::F32,
            count: query == Query::Count,
            closest: query == Query::Closest,
            occluded: matches!(query, Query::Occluded(_)),
            packets: gpu.packets_pay(rays.len() as u64, bounded_count(&self.scene))
                && coherent(rays, self.extent),
            list_origin: one_origin(rays),
            ..general
        }
        .with_instances(&self.scene);
        let prepared = self.prepared::<R>(mode.algorithm, Some(&variant))?;
        let resident = self.resident(gpu, &prepared, &variant)?;
        let mut job = (Job::new(variant).rays(rays, t_near).resident(&resident))
            .timed(self.kernel_s.is_some());
        if let Query::Occluded(t_far) = query {
            job = job.t_far(t_far);
        }
        let mut rendered = gpu::run(gpu, &prepared, job)?;
        if let (Some(total), Some(k)) = (&self.kernel_s, rendered.stages.kernel_s) {
            let mut total = total.lock().expect("the kernel time's lock");
            *total = Some(total.unwrap_or(0.0) + k);
        }
        if let Some(hits) = rendered
            .hits
            .as_mut()
            .filter(|_| prepared.walks_instances())
        {
            self.in_scene_order(hits);
        }
        Ok(rendered)
    }

    /// `hits` of a kernel that walked the instances in their meshes, whose keys of instances'
    /// triangles are their indices in the mesh, as keys in the scene's order (the flattened
    /// scene's, which [`RayScene::within_objects`] takes).
    fn in_scene_order<R>(&self, hits: &mut Hits<R>) {
        let first = first_primitives(&self.scene.objects);
        let mut placed = vec![false; first.len()];
        for p in &self.scene.instances {
            placed[p.object] = true;
        }
        for (p, &id) in hits.primitive.iter_mut().zip(&hits.id) {
            if id != MISS && placed[id as usize] {
                *p += first[id as usize];
            }
        }
    }

    /// The preparation for `algorithm` in `R` (for `variant`'s acceleration, or the CPU's
    /// default), built on first use and kept; the other precision's BVH is reused.
    fn prepared<R: CastReal>(
        &self,
        algorithm: Algorithm,
        variant: Option<&gpu::shader::Variant>,
    ) -> Result<Arc<Prepared<R>>> {
        let scene = &self.scene;
        let bvh = match variant {
            Some(v) => v.uses_bvh(),
            None => Search::Auto.uses_bvh(scene),
        };
        let key = (algorithm, bvh, variant.is_some_and(|v| v.instances));
        let mut cache = self.cache.lock().expect("cache lock");
        if let Some(p) = R::cached(&mut cache).get(&key) {
            return Ok(p.clone());
        }
        if let Some(v) = variant {
            gpu::dispatch::check_capacity(scene, v)?;
        }
        let shared = match R::PRECISION {
            Float::F32 => cache.f64.get(&key).map(|p| p.bvh().cloned()),
            Float::F64 => cache.f32.get(&key).map(|p| p.bvh().cloned()),
        };
        let prepared = Arc::new(match (shared, key.2) {
            (Some(shared), _) => Prepared::with_bvh(scene, algorithm, shared),
            (None, true) => Prepared::instanced(scene, algorithm),
            (None, false) => {
                let accel = if bvh { Search::Bvh } else { Search::BruteForce };
                Prepared::new(scene, algorithm, accel)
            }
        });
        R::cached(&mut cache).insert(key, prepared.clone());
        Ok(prepared)
    }

    /// `prepared`'s buffers on `gpu` for `variant`, uploaded on first use and kept.
    fn resident<R: CastReal>(
        &self,
        gpu: &Gpu,
        prepared: &Prepared<R>,
        variant: &gpu::shader::Variant,
    ) -> Result<Arc<gpu::Resident>> {
        let key = (
            R::PRECISION,
            (variant.algorithm, variant.uses_bvh(), variant.instances),
        );
        let mut cache = self.cache.lock().expect("cache lock");
        if let Some(r) = cache.resident.get(&key).filter(|r| r.fits(gpu, variant)) {
            return Ok(r.clone());
        }
        let resident = Arc::new(gpu::upload(gpu, prepared, variant)?);
        cache.resident.insert(key, resident.clone());
        Ok(resident)
    }

    /// `hits` with primitive keys (indices among their kind in the scene's order) turned into
    /// indices within their object.
    fn within_objects(&self, mut hits: AnyHits) -> AnyHits {
        let first = first_primitives(&self.scene.objects);
        if first.iter().all(|&f| f == 0) {
            // One object of each kind (a mesh): keys are indices within it already.
            return hits;
        }
        let fix = |id: &[i32], primitive: &mut [u32]| {
            for (p, &id) in primitive.iter_mut().zip(id) {
                if id != MISS {
                    *p -= first[id as usize];
                }
            }
        };
        match &mut hits {
            AnyHits::F32(h) => fix(&h.id, &mut h.primitive),
            AnyHits::F64(h) => fix(&h.id, &mut h.primitive),
        }
        hits
    }
}

/// `mode` for a pass in f64: on the CPU reference where the GPU has no f64.
fn f64_mode(mode: Mode, gpu: Option<&Gpu>) -> Mode {
    match (mode.device, gpu) {
        (Device::Gpu, Some(g)) if !g.has_f64() => Mode {
            device: Device::Cpu,
            ..mode
        },
        _ => mode,
    }
}

/// Per object, the index of its first primitive among the primitives of its kind (spheres,
/// planes, triangles), in the order [`crate::prepare::Primitives::new`] stores them.
fn first_primitives(objects: &[Object]) -> Vec<u32> {
    let mut next = [0u32; 3];
    objects
        .iter()
        .map(|o| {
            let (kind, n) = match o {
                Object::Sphere { .. } => (0, 1),
                Object::Plane { .. } => (1, 1),
                Object::Triangle { .. } => (2, 1),
                Object::Soup { triangles, .. } => (2, triangles.len() as u32),
            };
            let first = next[kind];
            next[kind] += n;
            first
        })
        .collect()
}

/// The largest side of `bounds`, or 1 where there is none.
fn extent(bounds: Option<(DVec3, DVec3)>) -> f64 {
    let side = bounds.map_or(0.0, |(lo, hi)| {
        (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max)
    });
    if side > 0.0 { side } else { 1.0 }
}

/// A camera for objects within `bounds` given without one: its eye (where the robust kernel
/// measures coordinates from, so where f32 is most precise) at their centre ([`kernel_eye`]),
/// its size their extent (which sets the kernel's power-of-two unit), 1x1 pixels; it casts no
/// ray.
fn framing_camera(bounds: Option<(DVec3, DVec3)>) -> Camera {
    let size = extent(bounds);
    let eye = bounds.map_or([0.0; 3], |(lo, hi)| {
        [0, 1, 2].map(|k| kernel_eye(0.5 * lo[k] + 0.5 * hi[k], size))
    });
    Camera {
        projection: Projection::Perspective,
        eye: DVec3::from_array(eye),
        look: DVec3::NEG_Z,
        up: DVec3::Y,
        focal_length: size,
        lens: Lens::Size {
            width: size,
            height: size,
        },
        resolution: [1, 1],
        depth_white: size,
    }
}

/// A coordinate of the kernel's eye for objects centred at `centre` of size `extent`, chosen
/// so that coordinates given in f32 (as numpy arrays usually are) reach the kernel unrounded:
/// 0 where the objects are within their extent of the origin, else the centre rounded to f32
/// (Sterbenz: an f32 within a factor 2 of it differs from it exactly) unless that moves it by
/// more than 2^-12 of the extent (coordinates given in f64 far from the origin). Any other eye
/// would round f32 corners again and cost f32 `t` its accuracy (docs/performance.md#ray-lists).
fn kernel_eye(centre: f64, extent: f64) -> f64 {
    if centre.abs() < extent {
        return 0.0;
    }
    let rounded = f64::from(centre as f32);
    if (rounded - centre).abs() <= extent / 4096.0 {
        rounded
    } else {
        centre
    }
}

#[cfg(test)]
mod tests {
    use super::kernel_eye;
    use crate::{Cpu, DAffine3, DVec3, Geometry, Precision, Ray};
    use glam::DQuat;

    /// `mesh` placed by `m` as a mesh of its own: its vertices moved, and each triangle's last
    /// two corners swapped where `m` mirrors (as an instance's are).
    fn placed_copy(geometry: &mut Geometry, (v, t): &(Vec<DVec3>, Vec<[u32; 3]>), m: &DAffine3) {
        let mirrors = m.matrix3.determinant() < 0.0;
        let v: Vec<DVec3> = v.iter().map(|p| m.transform_point3(*p)).collect();
        let t: Vec<[u32; 3]> = (t.iter())
            .map(|&[a, b, c]| if mirrors { [a, c, b] } else { [a, b, c] })
            .collect();
        geometry.add_mesh(&v, &t).unwrap();
    }

    /// Rays from above the scene's objects down through a grid around them.
    fn grid_rays() -> Vec<Ray> {
        (0..3600)
            .map(|k| Ray {
                origin: DVec3::new(0.5, 0.5, 12.0),
                direction: DVec3::new(
                    (k % 60) as f64 * 0.02 - 0.6,
                    (k / 60) as f64 * 0.02 - 0.6,
                    -1.0,
                ),
            })
            .collect()
    }

    /// Ids and t of `rays` at `geometry` on the CPU in `precision`, t's bits.
    fn cast(geometry: &Geometry, precision: Precision, rays: &[Ray]) -> (Vec<i32>, Vec<u64>) {
        let hits = Cpu
            .commit(geometry, precision)
            .unwrap()
            .intersect(rays)
            .unwrap();
        (
            hits.id().to_vec(),
            hits.t_f64().iter().map(|t| t.to_bits()).collect(),
        )
    }

    fn poses() -> [DAffine3; 3] {
        let turn = DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 0.7);
        [
            DAffine3::from_scale_rotation_translation(
                DVec3::new(1.5, 0.5, 2.0),
                turn,
                DVec3::new(3.0, -2.0, 1.0),
            ),
            DAffine3::from_scale_rotation_translation(
                DVec3::new(-1.0, 1.0, 1.0),
                turn.inverse(),
                DVec3::new(-3.0, 2.5, 0.5),
            ),
            DAffine3::from_translation(DVec3::new(0.2, 3.0, -2.0)),
        ]
    }

    /// A sphere and a cube mesh with the cube placed at [`poses`] twice over: as instances of
    /// it, and as meshes of their own (the copies). The mesh, then both geometries.
    #[allow(clippy::type_complexity)]
    fn placed_cubes() -> ((Vec<DVec3>, Vec<[u32; 3]>), Geometry, Geometry) {
        let mesh = crate::tests::common::unit_cube_mesh();
        let (mut instanced, mut copies) = (Geometry::new(), Geometry::new());
        for geometry in [&mut instanced, &mut copies] {
            geometry.add_sphere([0.5, -2.0, 0.0], 0.75).unwrap();
            geometry.add_mesh(&mesh.0, &mesh.1).unwrap();
        }
        for m in poses() {
            let id = instanced.add_instance(1, m).unwrap();
            assert_eq!(id as usize, instanced.objects.len() - 1);
            placed_copy(&mut copies, &mesh, &m);
        }
        (mesh, instanced, copies)
    }

    /// Instances added to a mesh hit as copies of the mesh placed by their transforms, added
    /// as meshes of their own: the same ids and t, bit for bit, in f32 and f64; and they share
    /// the mesh's one tree, which a commit after they move builds no more.
    #[test]
    fn added_instances_are_their_meshes_placed_and_move_without_building_the_mesh_again() {
        let (mesh, mut instanced, copies) = placed_cubes();
        let rays = grid_rays();
        for precision in [Precision::F32, Precision::F64] {
            let (ids, t) = cast(&instanced, precision, &rays);
            assert_eq!((ids.clone(), t), cast(&copies, precision, &rays));
            assert!(
                (0..5).all(|o| ids.contains(&o)),
                "every object hit: {ids:?}"
            );
        }
        let trees = instanced.trees.lock().unwrap().mesh_trees();
        assert_eq!(trees.len(), 1, "one tree for the mesh and its three copies");

        let moved = [
            DAffine3::from_translation(DVec3::new(-1.0, -1.0, 0.5)),
            poses()[0],
        ];
        instanced.set_transforms(&[2, 1], &moved).unwrap();
        let mut copies = Geometry::new();
        copies.add_sphere([0.5, -2.0, 0.0], 0.75).unwrap();
        for m in [moved[1], moved[0], poses()[1], poses()[2]] {
            placed_copy(&mut copies, &mesh, &m);
        }
        assert_eq!(
            cast(&instanced, Precision::F64, &rays),
            cast(&copies, Precision::F64, &rays)
        );
        let after = instanced.trees.lock().unwrap().mesh_trees();
        assert!(after.len() == 1 && std::sync::Arc::ptr_eq(&trees[0], &after[0]));
    }

    /// On the GPU, nearest-hit casts at instances walk them in their meshes' coordinates, a
    /// tree held once per mesh, and find the copies' hits (the CPU f64 reference's, at the
    /// meshes added placed): in f64 and adaptive precision the same ids; in f32 on all but 0.2%
    /// of the rays (near edges, where the move into the mesh rounds otherwise); where they
    /// agree, the same primitives, and t and barycentrics within 1e-12 and 1e-9 in f64, 1e-5 and
    /// 1e-4 in f32 and adaptive precision (whose hits are f32's).
    #[test]
    fn gpu_casts_walk_instances_and_find_the_copies_hits() {
        use crate::rays::AnyHits;
        let gpu = crate::tests::common::gpu();
        let (_, instanced, copies) = placed_cubes();
        // Incoherent (ray by ray), many starting inside the instances' boxes.
        let rays = crate::tests::common::incoherent_rays(3000, 4.0, 5);
        let exact = Cpu.commit(&copies, Precision::F64).unwrap();
        let AnyHits::F64(exact) = exact.intersect(&rays[..]).unwrap() else {
            panic!("f64 hits")
        };
        let mut precisions = vec![Precision::F32, Precision::Adaptive];
        if gpu.has_f64() {
            precisions.push(Precision::F64);
        }
        for precision in precisions {
            let accel = gpu.commit(&instanced, precision).unwrap();
            let h = match accel.intersect(&rays[..]).unwrap() {
                AnyHits::F32(h) => widened(h),
                AnyHits::F64(h) => h,
            };
            let (id, primitive, t, uv, normal) = (h.id, h.primitive, h.t, h.uv, h.normal);
            let cache = accel.scene.cache.lock().unwrap();
            let walked = cache.f32.keys().chain(cache.f64.keys()).any(|k| k.2);
            assert!(walked, "{precision:?}: the tree naming instances");
            let f32 = precision == Precision::F32;
            let wrong = (0..rays.len()).filter(|&k| id[k] != exact.id[k]).count();
            assert!(
                wrong <= if f32 { 6 } else { 0 },
                "{precision:?}: {wrong} ids"
            );
            // Adaptive precision's hits are f32's, its ids f64's.
            let (t_tol, uv_tol) = match precision {
                Precision::F64 => (1e-12, 1e-9),
                _ => (1e-5, 1e-4),
            };
            let hit = (0..rays.len()).filter(|&k| id[k] >= 0 && id[k] == exact.id[k]);
            let mut placed = 0;
            for k in hit {
                placed += usize::from(id[k] >= 2);
                let what = format!("{precision:?}, ray {k}, object {}", id[k]);
                assert_eq!(
                    primitive[k], exact.primitive[k],
                    "{what}: {} {}",
                    primitive[k], exact.primitive[k]
                );
                assert!(
                    (t[k] - exact.t[k]).abs() <= t_tol * exact.t[k].abs(),
                    "{what}: t {} {}",
                    t[k],
                    exact.t[k]
                );
                let off = (0..2).map(|j| (uv[k][j] - exact.uv[k][j]).abs());
                assert!(
                    off.fold(0.0, f64::max) <= uv_tol,
                    "{what}: uv {:?} {:?}",
                    uv[k],
                    exact.uv[k]
                );
                let off = (0..3).map(|j| (normal[k][j] - exact.normal[k][j]).abs());
                assert!(off.fold(0.0, f64::max) <= uv_tol, "{what}: normal");
            }
            assert!(
                placed > 100,
                "{precision:?}: {placed} rays hit the instances"
            );
        }
    }

    /// f32 hits in f64.
    fn widened(h: crate::Hits<f32>) -> crate::Hits<f64> {
        crate::Hits {
            t: h.t.iter().map(|&t| f64::from(t)).collect(),
            id: h.id,
            primitive: h.primitive,
            uv: h.uv.iter().map(|p| p.map(f64::from)).collect(),
            normal: h.normal.iter().map(|p| p.map(f64::from)).collect(),
            count: h.count,
        }
    }

    /// Instances and transforms a geometry cannot take are refused, naming the argument.
    #[test]
    fn bad_instances_and_transforms_name_the_argument() {
        let (v, t) = crate::tests::common::unit_cube_mesh();
        let mut geometry = Geometry::new();
        geometry.add_sphere([0.0, 0.0, 0.0], 1.0).unwrap();
        let mesh = geometry.add_mesh(&v, &t).unwrap();
        let id = geometry.add_instance(mesh, DAffine3::IDENTITY).unwrap();
        let mut singular = DAffine3::IDENTITY;
        singular.matrix3.z_axis = DVec3::new(1.0, 1.0, 0.0);
        singular.matrix3.y_axis = DVec3::new(1.0, 1.0, 0.0);
        let mut nan = DAffine3::IDENTITY;
        nan.translation.x = f64::NAN;
        let far = DAffine3::from_translation(DVec3::new(0.0, 2e18, 0.0));
        let cases = [
            (
                geometry.clone().add_instance(0, DAffine3::IDENTITY).err(),
                "mesh: object 0 is not a triangle mesh",
            ),
            (
                geometry.clone().add_instance(9, DAffine3::IDENTITY).err(),
                "mesh: object 9 does not exist (3 objects)",
            ),
            (
                geometry.clone().add_instance(mesh, singular).err(),
                "transform: is singular",
            ),
            (
                geometry.clone().add_instance(mesh, nan).err(),
                "transform: must be finite, got NaN",
            ),
            (
                geometry.clone().add_instance(id, far).err(),
                "transform: places the mesh beyond 1e18",
            ),
            (
                geometry
                    .clone()
                    .set_transforms(&[0], &[DAffine3::IDENTITY])
                    .err(),
                "ids[0]: object 0 is not an instance",
            ),
            (
                geometry
                    .clone()
                    .set_transforms(&[id, mesh], &[DAffine3::IDENTITY, far])
                    .err(),
                "transforms[1]: places the mesh beyond 1e18",
            ),
            (
                geometry.clone().set_transforms(&[id], &[]).err(),
                "transforms: gives 0 transforms for 1 ids",
            ),
        ];
        for (k, (error, expected)) in cases.into_iter().enumerate() {
            let message = error.map(|e| e.to_string()).unwrap_or_default();
            assert!(message.starts_with(expected), "case {k}: {message}");
        }
        // A refused call changes nothing.
        let mut refused = geometry.clone();
        assert!(
            refused
                .set_transforms(&[id, 0], &[far, DAffine3::IDENTITY])
                .is_err()
        );
        let rays = grid_rays();
        assert_eq!(
            cast(&refused, Precision::F64, &rays),
            cast(&geometry, Precision::F64, &rays)
        );
    }

    /// f32 coordinates within half the extent of the centre differ from the kernel's eye
    /// exactly (so reach the kernel unrounded), near the origin and far from it; f64 objects
    /// far from the origin keep the eye at their centre, so kernel coordinates stay small.
    #[test]
    fn kernel_eye_keeps_f32_coordinates_exact() {
        let mut state = 7u64;
        let mut unit = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for (centre, extent) in [(0.005, 2.9), (-3.0, 1.0), (1.0e4, 0.5), (-7.5e6, 3.0e3)] {
            let eye = kernel_eye(centre, extent);
            assert!((eye - centre).abs() <= extent / 4096.0 || eye == 0.0);
            for _ in 0..10_000 {
                let v = f64::from((centre + extent * unit()) as f32);
                let d = v - eye;
                assert_eq!(
                    f64::from(d as f32),
                    d,
                    "centre {centre} extent {extent} v {v}"
                );
            }
        }
        let far = 2f64.powi(40) + 0.3;
        assert_eq!(kernel_eye(far, 1.0), far);
    }
}
