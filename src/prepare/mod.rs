//! Preparation: what a render needs before any ray is cast, built once per scene and request
//! and used alike by the GPU kernel ([`crate::gpu::run`]) and the CPU reference
//! ([`crate::cpu`]): the kernel's coordinate origin, the camera frame in those coordinates, the
//! primitives rounded to the kernel's precision, and the BVH ([`bvh`]) that orders them.
//!
//! ```text
//! Scene (f64) --kernel_origin, kernel_frame--> Frame<T>
//!             --Primitives::new / with_bvh--> Primitives<T> (+ Arc<Bvh>)
//! ```

pub(crate) mod bvh;
pub(crate) mod order;
pub(crate) mod shared;
// The compressed 8-wide tree (#62), for the cost model and the tests until a kernel walks it.
#[cfg(any(test, feature = "model"))]
pub(crate) mod wide;
pub(crate) mod winding;

use std::borrow::Cow;
use std::sync::Arc;
use std::time::Instant;

use rayon::prelude::*;

use crate::algorithm::Algorithm;
use crate::kernel::types::{Frame, Instance, Plane, Ray, Sphere, Triangle};
use crate::math::{Real, Vec3, dot, vec3};
use crate::scene::{Lighting, Object, Scene};
use bvh::{Bvh, Search, Topology};

/// A scene prepared for the kernel in precision `T`.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Prepared<T> {
    pub algorithm: Algorithm,
    /// The camera frame in the kernel's coordinates, rounded to `T`.
    pub frame: Frame<T>,
    /// Where the kernel's coordinates are measured from, in world coordinates
    /// (`kernel_origin`).
    pub origin: Vec3<f64>,
    /// World units per kernel unit, `2^e` (`unit_exponent`): the kernel sees the scene
    /// scaled by `1 / unit` and multiplies distances back.
    pub unit: f64,
    pub primitives: Primitives<T>,
    /// The camera's focal length in scene units: the distance `depth.png` maps to white.
    pub focal_length: f64,
    /// Seconds spent building the BVH and rounding the primitives.
    pub build_s: f64,
    /// The scene's materials, lights and per-object values, for shade hooks (world
    /// coordinates, f64), and how many objects the scene has.
    pub lighting: Arc<Lighting>,
    pub objects: usize,
}

impl<T: Real> Prepared<T> {
    /// `scene` prepared for `algorithm`, through a BVH built here where `accel` asks for one.
    pub(crate) fn new(scene: &Scene, algorithm: Algorithm, accel: Search) -> Prepared<T> {
        let clock = Instant::now();
        let kernel = in_kernel_units(scene);
        let bvh = kernel_bvh(scene, &kernel.0, algorithm, accel).map(Arc::new);
        Prepared::assemble(scene, kernel, algorithm, bvh).timed(clock)
    }

    /// `scene` prepared for `algorithm` through a BVH that names its instances, each mesh's
    /// tree and triangles held once in the mesh's coordinates ([`bvh::Instanced`]; #64), for
    /// the traversal ray by ray of a nearest hit; through the BVH of [`Prepared::new`] where
    /// the scene places no mesh or that tree would be too deep.
    pub(crate) fn instanced(scene: &Scene, algorithm: Algorithm) -> Prepared<T> {
        let clock = Instant::now();
        let Some(topology) = Topology::instanced(scene) else {
            return Prepared::new(scene, algorithm, Search::Bvh);
        };
        let instanced = topology.named_instances().expect("a tree naming instances");
        let kernel = instanced_kernel_units(scene, instanced);
        let bvh = Arc::new(Bvh::fit(&topology, &kernel.0, algorithm));
        Prepared::assemble(scene, kernel, algorithm, Some(bvh)).timed(clock)
    }

    /// `scene` prepared for `algorithm` with a BVH already built by [`Prepared::new`] for the
    /// same scene and algorithm (shared between precisions), or none.
    pub(crate) fn with_bvh(
        scene: &Scene,
        algorithm: Algorithm,
        bvh: Option<Arc<Bvh>>,
    ) -> Prepared<T> {
        let clock = Instant::now();
        // A tree naming instances was fitted in the units of its instances' boxes.
        let kernel = match bvh.as_ref().and_then(|b| b.instanced.as_ref()) {
            Some(instanced) => instanced_kernel_units(scene, instanced),
            None => in_kernel_units(scene),
        };
        Prepared::assemble(scene, kernel, algorithm, bvh).timed(clock)
    }

    /// Whether its BVH names instances, which the kernel walks in their meshes' coordinates
    /// ([`Prepared::instanced`]).
    pub(crate) fn walks_instances(&self) -> bool {
        self.bvh().is_some_and(|b| b.instanced.is_some())
    }

    /// The preparation of `scene`, given as it is in kernel units, `kernel`.
    fn assemble(
        scene: &Scene,
        (kernel, unit): (Cow<'_, Scene>, f64),
        algorithm: Algorithm,
        bvh: Option<Arc<Bvh>>,
    ) -> Prepared<T> {
        let primitives = match bvh {
            Some(bvh) => Primitives::with_bvh(&kernel, algorithm, bvh),
            None => Primitives::new(&kernel, algorithm),
        };
        Prepared {
            algorithm,
            frame: kernel_frame(&kernel, algorithm).cast(),
            origin: kernel_origin(scene, algorithm),
            unit,
            primitives,
            focal_length: scene.camera.focal_length,
            build_s: 0.0,
            lighting: Arc::new(scene.lighting.clone()),
            objects: scene.objects.len(),
        }
    }

    fn timed(self, since: Instant) -> Self {
        Prepared {
            build_s: since.elapsed().as_secs_f64(),
            ..self
        }
    }

    /// The image size `[nx, ny]` in pixels.
    pub(crate) fn resolution(&self) -> [u32; 2] {
        [self.frame.nx, self.frame.ny]
    }

    /// A caller's ray (world coordinates) in the kernel's: its origin measured from
    /// [`Prepared::origin`], origin and direction scaled by `1 / unit` (exact: a power of two),
    /// both rounded to `T`. A point at parameter t along it is the world ray's point at t.
    pub(crate) fn kernel_ray(&self, ray: &crate::rays::Ray) -> Ray<T> {
        Ray {
            origin: self.kernel_point(ray.origin).cast(),
            direction: (Vec3::from(ray.direction) * (1.0 / self.unit)).cast(),
        }
    }

    /// A point (world coordinates) in the kernel's, in f64: measured from
    /// [`Prepared::origin`] and scaled by `1 / unit`.
    pub(crate) fn kernel_point(&self, p: impl Into<Vec3<f64>>) -> Vec3<f64> {
        (p.into() - self.origin) * (1.0 / self.unit)
    }

    /// Whether every camera ray starts at the kernel's origin: a perspective camera whose eye
    /// is that origin, +0 in each coordinate (the robust set measures from the eye,
    /// [`kernel_origin`], and eye - eye is +0).
    pub(crate) fn camera_rays_from_origin(&self) -> bool {
        self.frame.projection == crate::scene::Projection::Perspective
            && self
                .frame
                .eye
                .to_array()
                .iter()
                .all(|x| x.to_f64().to_bits() == 0)
    }

    /// The BVH the primitives are ordered by, if any.
    pub(crate) fn bvh(&self) -> Option<&Arc<Bvh>> {
        self.primitives.bvh.as_ref()
    }
}

/// A scene's primitives rounded to precision `T`, by kind, each with its object id
/// (`objects` in shaders/bindings.wgsl holds the ids in the order spheres, planes, triangles).
/// With a BVH, spheres and triangles are stored in its order.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Primitives<T> {
    pub spheres: Vec<Sphere<T>>,
    pub planes: Vec<Plane<T>>,
    pub triangles: Vec<Triangle<T>>,
    pub sphere_objects: Vec<u32>,
    pub plane_objects: Vec<u32>,
    pub triangle_objects: Vec<u32>,
    /// The BVH the spheres and triangles are ordered by, if the render uses one.
    pub bvh: Option<Arc<Bvh>>,
    /// Where the BVH names instances ([`bvh::Instanced`]): each one's map into its mesh's
    /// coordinates. The triangles are then the other objects', then each mesh's once, in the
    /// mesh's coordinates.
    pub instances: Vec<Instance<T>>,
}

/// Bytes of one object id (`objects` in shaders/bindings.wgsl, `u32`).
const OBJECT_ID_BYTES: usize = 4;

/// The binary exponent `e` of the camera's size, `max(focal length, width, height)`, so that
/// the scene scaled by `2^-e` has a camera of size in `[1, 2)`. Scaling a scene by `2^k` adds
/// exactly `k`, so every render sees the same numbers at every power-of-two scale: products of
/// coordinates can neither overflow nor flush to zero in f32 where the unscaled scene's do not.
///
/// A camera more than 2^60 times smaller than the scene's largest number (more than a scene
/// file's 1e18 can span) would carry that number beyond 2^60 in kernel units, and even beyond
/// f64's range for a camera near 1e-300: `e` is then raised to keep every kernel coordinate
/// within 2^61, which also adds exactly `k` under scaling.
pub(crate) fn unit_exponent(scene: &Scene) -> i32 {
    exponent_for(scene, shared::objects_magnitude(scene))
}

/// [`unit_exponent`] of `scene` whose objects' largest coordinate is at most `objects`.
fn exponent_for(scene: &Scene, objects: f64) -> i32 {
    let c = &scene.camera;
    let plane = c.image_plane();
    let camera = binary_exponent(c.focal_length.max(plane.width).max(plane.height));
    let largest = scene.camera_magnitude().max(objects);
    camera.max(binary_exponent(largest) - MAX_KERNEL_EXPONENT)
}

/// The largest binary exponent a kernel coordinate may have: 2^60 > 1e18, the largest number
/// a scene file may hold.
const MAX_KERNEL_EXPONENT: i32 = 60;
const _: () = assert!((1u64 << MAX_KERNEL_EXPONENT) as f64 > crate::scene::MAX_MAGNITUDE);

/// `floor(log2(x))` of a positive finite `x`, or -1023 for a subnormal one.
fn binary_exponent(x: f64) -> i32 {
    ((x.to_bits() >> 52) & 0x7ff) as i32 - 1023
}

/// The BVH [`Prepared::new`] builds for `scene` where `accel` asks for one, without the rest
/// of the preparation.
pub(crate) fn bvh_of(scene: &Scene, algorithm: Algorithm, accel: Search) -> Option<Bvh> {
    kernel_bvh(scene, &in_kernel_units(scene).0, algorithm, accel)
}

/// The BVH [`Prepared::instanced`] builds for `scene`, without the rest of the preparation.
pub(crate) fn instanced_bvh_of(scene: &Scene, algorithm: Algorithm) -> Option<Bvh> {
    match Topology::instanced(scene) {
        Some(topology) => Some(Bvh::fit(
            &topology,
            &instanced_kernel_units(scene, topology.named_instances()?).0,
            algorithm,
        )),
        None => bvh_of(scene, algorithm, Search::Bvh),
    }
}

/// [`in_kernel_units`] for a tree naming `scene`'s instances: the scene without its copies
/// of the instances' triangles (their meshes are read instead), so that a frame scales and
/// copies only the other objects.
fn instanced_kernel_units<'a>(
    scene: &'a Scene,
    instanced: &bvh::Instanced,
) -> (Cow<'a, Scene>, f64) {
    let mut is_copy = vec![false; scene.objects.len()];
    for i in &instanced.instances {
        is_copy[scene.instances[i.placement as usize].object] = true;
    }
    let light = emptied(scene, |k, _| is_copy[k], scene.instances.clone());
    // The instances' coordinates bounded by their boxes: not a pass over every copy's.
    let placed = (instanced.boxes(scene)).map(|(lo, hi)| lo.abs().max(hi.abs()).max_element());
    let magnitude = light.objects_magnitude().max(placed.fold(0.0, f64::max));
    let e = exponent_for(scene, magnitude);
    let kernel = match e {
        0 => light,
        e => light.scaled_by_pow2(-e),
    };
    (Cow::Owned(kernel), 2f64.powi(e))
}

/// The BVH over `kernel`, `scene` in kernel units, where `accel` asks for one: the topology of
/// `scene`'s objects ([`Topology::of`]) fitted to the kernel's coordinates.
fn kernel_bvh(scene: &Scene, kernel: &Scene, algorithm: Algorithm, accel: Search) -> Option<Bvh> {
    accel
        .uses_bvh(scene)
        .then(|| Bvh::fit(&Topology::of(scene), kernel, algorithm))
}

/// `scene` in kernel units (scaled by `2^-e`, [`unit_exponent`]; borrowed when `e` is 0, the
/// usual case) and the world units per kernel unit, `2^e`. Scaling a scene already in kernel
/// units changes nothing.
fn in_kernel_units(scene: &Scene) -> (Cow<'_, Scene>, f64) {
    match unit_exponent(scene) {
        0 => (Cow::Borrowed(scene), 1.0),
        e => (Cow::Owned(scene.scaled_by_pow2(-e)), kernel_unit(scene)),
    }
}

/// World units per kernel unit for `scene`, `2^e` ([`unit_exponent`]): [`Prepared::unit`].
pub(crate) fn kernel_unit(scene: &Scene) -> f64 {
    2f64.powi(unit_exponent(scene))
}

/// Where the kernel's coordinates are measured from: the world origin for
/// [`Algorithm::Textbook`], the eye for [`Algorithm::Robust`] (camera-relative rendering: the
/// subtraction happens here in f64, so f32 precision sits where the camera is).
pub(crate) fn kernel_origin(scene: &Scene, algorithm: Algorithm) -> Vec3<f64> {
    match algorithm {
        Algorithm::Textbook => vec3(0.0, 0.0, 0.0),
        Algorithm::Robust => scene.camera.eye.into(),
    }
}

/// The camera frame in the kernel's coordinates (f64, not yet rounded).
pub(crate) fn kernel_frame(scene: &Scene, algorithm: Algorithm) -> Frame<f64> {
    let mut frame = Frame::new(&scene.camera, scene.camera.resolution);
    frame.eye = frame.eye - kernel_origin(scene, algorithm);
    frame
}

/// The object id of each primitive of `scene` by kind, in the scene's order: its spheres, its
/// planes and its triangles (a soup's triangles all under its one id).
pub(crate) struct ObjectIds {
    pub spheres: Vec<u32>,
    pub planes: Vec<u32>,
    pub triangles: Vec<u32>,
}

impl ObjectIds {
    pub(crate) fn of(scene: &Scene) -> ObjectIds {
        ObjectIds::of_objects(&scene.objects)
    }

    pub(crate) fn of_objects<'a>(objects: impl IntoIterator<Item = &'a Object>) -> ObjectIds {
        let mut ids = ObjectIds {
            spheres: Vec::new(),
            planes: Vec::new(),
            triangles: Vec::new(),
        };
        for (id, object) in objects.into_iter().enumerate() {
            let id = id as u32;
            match object {
                Object::Sphere { .. } => ids.spheres.push(id),
                Object::Plane { .. } => ids.planes.push(id),
                Object::Triangle { .. } => ids.triangles.push(id),
                Object::Soup { triangles, .. } => {
                    let len = ids.triangles.len() + triangles.len();
                    ids.triangles.resize(len, id);
                }
            }
        }
        ids
    }
}

impl<T: Real> Primitives<T> {
    /// Every object of `scene` in the kernel's coordinates for `algorithm`, rounded from f64
    /// to `T`; a soup adds all its triangles under its one id. Robust planes are stored by
    /// their point nearest the eye, `((p - e).n) n`, computed in f64.
    pub(crate) fn new(scene: &Scene, algorithm: Algorithm) -> Primitives<T> {
        Primitives::ordered(scene, algorithm, None)
    }

    /// [`Primitives::new`] with the spheres and triangles in the order of `bvh` (built by
    /// [`Bvh::build`] for the same scene and algorithm), which the traversal then uses.
    pub(crate) fn with_bvh(scene: &Scene, algorithm: Algorithm, bvh: Arc<Bvh>) -> Primitives<T> {
        Primitives::ordered(scene, algorithm, Some(bvh))
    }

    /// The primitives in the scene's order, or in `bvh`'s. The triangles are rounded straight
    /// into the BVH's order, one pass over them rather than a rounding and then a permutation
    /// (docs/performance.md#bvh).
    fn ordered(scene: &Scene, algorithm: Algorithm, bvh: Option<Arc<Bvh>>) -> Primitives<T> {
        if let Some(bvh) = bvh.as_ref().filter(|b| b.instanced.is_some()) {
            return Primitives::instanced(scene, algorithm, bvh.clone());
        }
        let origin = kernel_origin(scene, algorithm);
        let ids = ObjectIds::of(scene);
        let mut spheres = Vec::new();
        let mut planes = Vec::new();
        let mut scene_triangles: Vec<&crate::scene::Triangle> = Vec::new();
        for object in &scene.objects {
            match object {
                Object::Sphere { center, radius } => spheres.push(Sphere {
                    center: (Vec3::from(*center) - origin).cast(),
                    radius: T::from_f64(*radius),
                }),
                Object::Plane { point, normal } => {
                    let (point, normal) = (Vec3::from(*point), Vec3::from(*normal));
                    let point = match algorithm {
                        Algorithm::Textbook => point,
                        Algorithm::Robust => normal * dot(point - origin, normal),
                    };
                    planes.push(Plane {
                        point: point.cast(),
                        normal: normal.cast(),
                    });
                }
                Object::Triangle { corners } => scene_triangles.push(corners),
                Object::Soup { triangles, .. } => scene_triangles.extend(triangles),
            }
        }
        let round = |t: &crate::scene::Triangle| triangle_at(t, origin);
        let (spheres, sphere_objects, triangles, triangle_objects) = match &bvh {
            None => (
                spheres,
                ids.spheres,
                scene_triangles.par_iter().map(|t| round(t)).collect(),
                ids.triangles,
            ),
            Some(bvh) => (
                permute(&spheres, &bvh.sphere_order),
                permute(&ids.spheres, &bvh.sphere_order),
                bvh.triangle_order
                    .par_iter()
                    .map(|&k| round(scene_triangles[k as usize]))
                    .collect(),
                permute(&ids.triangles, &bvh.triangle_order),
            ),
        };
        Primitives {
            spheres,
            planes,
            triangles,
            sphere_objects,
            plane_objects: ids.planes,
            triangle_objects,
            bvh,
            instances: Vec::new(),
        }
    }

    /// [`Primitives::ordered`] with a BVH naming `scene`'s instances ([`bvh::Instanced`]): the
    /// other objects' triangles in the kernel's coordinates, each mesh's once in its own, and
    /// the instances' maps. Only the other objects' triangles are read, not the copies the
    /// scene holds of each instance's.
    fn instanced(scene: &Scene, algorithm: Algorithm, bvh: Arc<Bvh>) -> Primitives<T> {
        let origin = kernel_origin(scene, algorithm);
        let instanced = bvh.instanced.as_ref().expect("a tree naming instances");
        // The spheres and planes alone (their ids the scene's): the triangles follow.
        let solid = emptied(
            scene,
            |_, o| matches!(o, Object::Triangle { .. } | Object::Soup { .. }),
            Vec::new(),
        );
        let solid = Primitives::<T>::ordered(&solid, algorithm, None);
        let (triangles, triangle_objects) = instanced_triangles(scene, &bvh, instanced, origin);
        Primitives {
            spheres: permute(&solid.spheres, &bvh.sphere_order),
            sphere_objects: permute(&solid.sphere_objects, &bvh.sphere_order),
            planes: solid.planes,
            plane_objects: solid.plane_objects,
            triangles,
            triangle_objects,
            instances: instance_maps(scene, instanced, origin),
            bvh: Some(bvh),
        }
    }

    /// The index in the scene's own order of sphere `k` of this list (ties between primitives
    /// of one object go to the lower one, whatever order they are stored in).
    pub(crate) fn sphere_key(&self, k: u32) -> u32 {
        self.bvh.as_ref().map_or(k, |b| b.sphere_order[k as usize])
    }

    /// As [`Primitives::sphere_key`], for triangle `k`.
    pub(crate) fn triangle_key(&self, k: u32) -> u32 {
        self.bvh
            .as_ref()
            .map_or(k, |b| b.triangle_order[k as usize])
    }
}

impl<T> Primitives<T> {
    /// `raycast::Stages::bytes_per_triangle`: each triangle held taking `triangle_bytes`, an
    /// object id for every sphere, plane and triangle held, the instances' maps and words, and
    /// the tree `tree_bytes`, over the scene's triangles (each instance's mesh counted once
    /// for every instance, though held once); `None` without triangles.
    pub(crate) fn bytes_per_triangle(
        &self,
        triangle_bytes: usize,
        tree_bytes: usize,
    ) -> Option<f64> {
        let t = self.triangles.len();
        let ids = OBJECT_ID_BYTES * (self.spheres.len() + self.planes.len() + t);
        let instances = self.instances.len() * (12 * size_of::<T>() + 8);
        let bytes = t * triangle_bytes + ids + instances + tree_bytes;
        let scene = self.scene_triangles();
        (scene > 0).then(|| bytes as f64 / scene as f64)
    }

    /// How many triangles the scene has: those held, or where the BVH names instances, the
    /// other objects' and each instance's mesh's.
    fn scene_triangles(&self) -> usize {
        match self.bvh.as_ref().and_then(|b| b.instanced.as_ref()) {
            None => self.triangles.len(),
            Some(i) => {
                let placed = i
                    .instances
                    .iter()
                    .map(|k| i.meshes[k.mesh as usize].len as usize);
                i.rest_triangles as usize + placed.sum::<usize>()
            }
        }
    }
}

/// `list` in `order` (`list[order[k]]` at k).
fn permute<X: Copy + Send + Sync>(list: &[X], order: &[u32]) -> Vec<X> {
    order.par_iter().map(|&k| list[k as usize]).collect()
}

/// `scene`'s camera and objects, those `empty` says emptied (an empty soup at their place, so
/// that every object keeps its id), and `instances`.
fn emptied(
    scene: &Scene,
    empty: impl Fn(usize, &Object) -> bool,
    instances: Vec<crate::scene::Placement>,
) -> Scene {
    let objects = (scene.objects.iter().enumerate())
        .map(|(k, o)| match empty(k, o) {
            true => Object::Soup {
                path: Default::default(),
                triangles: Vec::new(),
            },
            false => o.clone(),
        })
        .collect();
    Scene {
        camera: scene.camera.clone(),
        objects,
        lighting: Default::default(),
        warnings: Vec::new(),
        instances,
    }
}

/// The triangles of a tree naming instances, rounded to `T`, and their objects: the other
/// objects' (in the scene's order) measured from `origin`, then each mesh's in its own
/// coordinates (object 0: a traversal takes an instance's object from the instance).
fn instanced_triangles<T: Real>(
    scene: &Scene,
    bvh: &Bvh,
    instanced: &bvh::Instanced,
    origin: Vec3<f64>,
) -> (Vec<Triangle<T>>, Vec<u32>) {
    let rest = &bvh.triangle_order[..instanced.rest_triangles as usize];
    let scene_triangles = SceneTriangles::of(scene, &instanced.firsts);
    let mut triangles: Vec<Triangle<T>> = (rest.par_iter())
        .map(|&k| triangle_at(scene_triangles.get(k).0, origin))
        .collect();
    let mut ids: Vec<u32> = rest.iter().map(|&k| scene_triangles.get(k).1).collect();
    for m in &instanced.meshes {
        let mesh = &scene.instances[m.placement as usize].mesh;
        let span = &bvh.triangle_order[m.first as usize..(m.first + m.len) as usize];
        let zero = Vec3::splat(0.0);
        triangles.par_extend(
            span.par_iter()
                .map(|&k| triangle_at(&mesh.triangles[k as usize], zero)),
        );
        ids.resize(triangles.len(), 0);
    }
    (triangles, ids)
}

/// A scene's triangles by their index in its order (a soup's all under its one id), found
/// through each object's first index: without a list of every triangle, which for a scene of
/// instances would hold every copy's.
pub(crate) struct SceneTriangles<'a> {
    /// Each triangle-holding object's first index, its id and its triangles.
    starts: Vec<(u32, u32, &'a [crate::scene::Triangle])>,
}

impl<'a> SceneTriangles<'a> {
    /// The triangles of `scene`'s objects, object k's from `firsts[k]` on (a scene's own
    /// order, or another's whose objects held more: the copies an instanced preparation
    /// leaves out).
    pub(crate) fn of(scene: &'a Scene, firsts: &[u32]) -> SceneTriangles<'a> {
        let mut starts = Vec::new();
        for ((id, object), &first) in scene.objects.iter().enumerate().zip(firsts) {
            let triangles = match object {
                Object::Triangle { corners } => std::slice::from_ref(corners),
                Object::Soup { triangles, .. } if !triangles.is_empty() => &triangles[..],
                _ => continue,
            };
            starts.push((first, id as u32, triangles));
        }
        SceneTriangles { starts }
    }

    /// Triangle `k` of the scene's order, and its object's id.
    pub(crate) fn get(&self, k: u32) -> (&'a crate::scene::Triangle, u32) {
        let at = self.starts.partition_point(|(first, _, _)| *first <= k) - 1;
        let (first, id, triangles) = self.starts[at];
        (&triangles[(k - first) as usize], id)
    }
}

/// Each instance's map from the kernel's coordinates (measured from `origin`, in `scene`'s
/// units) into its mesh's: the inverse of its placement, composed in f64 and rounded to `T`.
fn instance_maps<T: Real>(
    scene: &Scene,
    instanced: &bvh::Instanced,
    origin: Vec3<f64>,
) -> Vec<Instance<T>> {
    let origin = glam::DVec3::from(origin);
    (instanced.instances.iter())
        .map(|i| {
            let placement = &scene.instances[i.placement as usize];
            let inverse = placement.transform.inverse();
            let c = inverse.transform_point3(origin);
            let row = |k: usize| {
                let r = inverse.matrix3.row(k);
                [r.x, r.y, r.z, c[k]].map(T::from_f64)
            };
            Instance {
                rows: [row(0), row(1), row(2)],
                root: i.root,
                object: placement.object as u32,
            }
        })
        .collect()
}

/// Triangle `t` measured from `origin`, rounded to `T`.
fn triangle_at<T: Real>(t: &crate::scene::Triangle, origin: Vec3<f64>) -> Triangle<T> {
    Triangle {
        a: (Vec3::from(t[0]) - origin).cast(),
        b: (Vec3::from(t[1]) - origin).cast(),
        c: (Vec3::from(t[2]) - origin).cast(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Projection;

    /// The kernel's RAYS_FROM_ORIGIN (shaders/frame.wgsl) puts every camera ray's origin at +0:
    /// right exactly where the prepared eye is +0, which the robust set gives every perspective
    /// camera, and the textbook set only a perspective camera at the world origin.
    #[test]
    fn camera_rays_start_at_the_origin_exactly_for_robust_perspective_cameras() {
        let dirs = ["scenes/course", "scenes/extremes"]
            .map(|d| std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(d));
        let mut seen = [0; 2];
        for dir in dirs {
            for entry in std::fs::read_dir(dir).unwrap() {
                let path = entry.unwrap().path();
                if path.extension().is_none_or(|e| e != "json") {
                    continue;
                }
                let scene = Scene::load(&path).unwrap();
                let perspective = scene.camera.projection == Projection::Perspective;
                seen[perspective as usize] += 1;
                let at_world_origin = scene.camera.eye.to_array().iter().all(|x| x.to_bits() == 0);
                for (algorithm, expected) in [
                    (Algorithm::Robust, perspective),
                    (Algorithm::Textbook, perspective && at_world_origin),
                ] {
                    let prepared = Prepared::<f32>::new(&scene, algorithm, Search::BruteForce);
                    assert_eq!(
                        prepared.camera_rays_from_origin(),
                        expected,
                        "{} {algorithm:?}",
                        path.display()
                    );
                    if expected {
                        let eye = prepared.frame.eye.to_array();
                        assert!(eye.iter().all(|x| x.to_bits() == 0), "{eye:?}");
                    }
                }
            }
        }
        assert!(
            seen[0] > 0 && seen[1] > 0,
            "both projections among the scenes: {seen:?}"
        );
    }
}
