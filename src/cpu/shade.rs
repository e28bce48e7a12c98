//! Mirror of shaders/shade.wgsl and of the functions shaders/hooks.wgsl gives shade hooks: a hit
//! as a hook sees it, the rays a hook casts (`trace`, `occluded`), the point a ray leaves a
//! surface from (`leave`), and the scene's materials and lights. The CPU runs no WGSL, so a
//! hook's CPU mirror is Rust written against this module ([`super::raytrace`] mirrors
//! shaders/examples/raytrace.wgsl). In f32 it is the GPU's arithmetic; in f64 every step is
//! f64, the hook's too (on the GPU a hook computes in f32 whatever the kernel's precision).

use super::nearest::{Hit, hit_normal, nearest_hit, nearest_hit_before};
use crate::kernel::frame::camera_ray;
use crate::kernel::types::{Ray, t_far};
use crate::math::{Real, Vec3, dot, length, normalize};
use crate::prepare::Prepared;

/// `struct ShadeHit` of shaders/hooks.wgsl.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ShadeHit<T> {
    pub position: Vec3<T>,
    pub normal: Vec3<T>,
    pub distance: T,
    pub id: i32,
    pub direction: Vec3<T>,
    pub origin: Vec3<T>,
    /// Column and row.
    pub pixel: [u32; 2],
    pub resolution: [u32; 2],
    pub error: Vec3<T>,
}

/// `struct Material` of shaders/hooks.wgsl.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Material<T> {
    pub ka: Vec3<T>,
    pub phong_exponent: T,
    pub kd: Vec3<T>,
    pub ks: Vec3<T>,
    pub km: Vec3<T>,
}

pub(crate) const LIGHT_DIRECTIONAL: u32 = 0;
pub(crate) const LIGHT_POINT: u32 = 1;

/// `struct Light` of shaders/hooks.wgsl.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Light<T> {
    pub position: Vec3<T>,
    pub kind: u32,
    pub direction: Vec3<T>,
    pub color: Vec3<T>,
}

/// What one camera ray's hook reads and keeps: the prepared scene, its materials and lights
/// in `T`, and the kernel's private state while the hook runs (`shading_pixel`, and the rays
/// cast, `hook_rays`).
pub(crate) struct Shading<'a, T, const ROBUST: bool> {
    prepared: &'a Prepared<T>,
    scene: &'a HookScene<T>,
    /// Column and row of the camera ray being shaded.
    pub pixel: [u32; 2],
    /// Rays cast by `trace` and `occluded` so far.
    pub rays: u64,
}

/// The scene's materials, lights and per-object data as hooks read them, in `T` (the GPU's
/// hook buffers hold them in f32, src/gpu/layout.rs).
pub(crate) struct HookScene<T> {
    materials: Vec<Material<T>>,
    lights: Vec<Light<T>>,
    /// Per object: its material's index and its values.
    objects: Vec<(Option<usize>, [T; 4])>,
}

impl<T: Real> HookScene<T> {
    pub(crate) fn new(lighting: &crate::scene::Lighting, objects: usize) -> HookScene<T> {
        let v = |&v: &glam::DVec3| Vec3::from(v).cast::<T>();
        HookScene {
            materials: lighting
                .materials
                .iter()
                .map(|m| Material {
                    ka: v(&m.ka),
                    phong_exponent: T::from_f64(m.phong_exponent),
                    kd: v(&m.kd),
                    ks: v(&m.ks),
                    km: v(&m.km),
                })
                .collect(),
            lights: lighting
                .lights
                .iter()
                .map(|l| match l {
                    crate::scene::Light::Directional { direction, color } => Light {
                        kind: LIGHT_DIRECTIONAL,
                        direction: v(direction),
                        color: v(color),
                        ..Light::default()
                    },
                    crate::scene::Light::Point { position, color } => Light {
                        position: v(position),
                        kind: LIGHT_POINT,
                        color: v(color),
                        ..Light::default()
                    },
                })
                .collect(),
            objects: (0..objects)
                .map(|k| {
                    let (material, values) = lighting.object_data(k);
                    (material, values.map(T::from_f64))
                })
                .collect(),
        }
    }
}

impl<'a, T: Real, const ROBUST: bool> Shading<'a, T, ROBUST> {
    pub(crate) fn new(prepared: &'a Prepared<T>, scene: &'a HookScene<T>, pixel: [u32; 2]) -> Self {
        Shading {
            prepared,
            scene,
            pixel,
            rays: 0,
        }
    }

    /// `params.origin` and `params.unit`.
    fn origin_unit(&self) -> (Vec3<T>, T) {
        (
            self.prepared.origin.cast::<T>(),
            T::from_f64(self.prepared.unit),
        )
    }

    /// The hook's view of a hit of `ray` (`shade_hit`); `surface`: the normal and distance
    /// of a hit.
    pub(crate) fn shade_hit(
        &self,
        ray: &Ray<T>,
        hit: &Hit<T>,
        surface: Option<(Vec3<T>, T)>,
    ) -> ShadeHit<T> {
        let (origin, unit) = self.origin_unit();
        let zero = Vec3::splat(T::ZERO);
        let mut h = ShadeHit {
            position: zero,
            normal: zero,
            distance: T::ZERO,
            id: if hit.object < 0 { -1 } else { hit.object },
            direction: normalize(ray.direction),
            origin: origin + ray.origin * unit,
            pixel: self.pixel,
            resolution: [self.prepared.frame.nx, self.prepared.frame.ny],
            error: zero,
        };
        if let Some((normal, distance)) = surface.filter(|_| hit.object >= 0) {
            let along = ray.direction * hit.t;
            let world = origin + (ray.origin + along) * unit;
            h.position = world;
            h.normal = normal;
            h.distance = distance;
            h.error = position_error(along, ray.origin, world, h.position, unit);
        }
        h
    }

    /// The camera's ray through this pixel, its nearest hit and the hook's view of it (what
    /// `write_pixel` in shaders/entry.wgsl hands the hook).
    pub(crate) fn camera_hit(&self) -> ShadeHit<T> {
        let frame = &self.prepared.frame;
        let ray = camera_ray(frame, self.pixel[1], self.pixel[0]);
        let hit = nearest_hit::<T, ROBUST>(&ray, frame.min_t, &self.prepared.primitives);
        self.shade_hit(&ray, &hit, self.surface(&ray, &hit))
    }

    /// A hit's normal and world distance, as the kernel computes them for the hook.
    fn surface(&self, ray: &Ray<T>, hit: &Hit<T>) -> Option<(Vec3<T>, T)> {
        let (_, unit) = self.origin_unit();
        (hit.object >= 0).then(|| {
            (
                hit_normal::<T, ROBUST>(ray, hit, &self.prepared.primitives),
                hit.t * length(ray.direction) * unit,
            )
        })
    }

    /// `hook_ray`: a hook's ray in the kernel's coordinates.
    fn hook_ray(&self, origin: Vec3<T>, direction: Vec3<T>) -> Ray<T> {
        let (kernel_origin, unit) = self.origin_unit();
        let scale = T::ONE / unit;
        Ray {
            origin: (origin - kernel_origin) * scale,
            direction: direction * scale,
        }
    }

    /// `trace`: the nearest hit along origin + t direction, t >= t_min.
    pub(crate) fn trace(&mut self, origin: Vec3<T>, direction: Vec3<T>, t_min: T) -> ShadeHit<T> {
        self.rays += 1;
        let ray = self.hook_ray(origin, direction);
        let hit = nearest_hit::<T, ROBUST>(&ray, t_min, &self.prepared.primitives);
        self.shade_hit(&ray, &hit, self.surface(&ray, &hit))
    }

    /// `occluded`: whether anything is hit with t_min <= t < t_max.
    pub(crate) fn occluded(
        &mut self,
        origin: Vec3<T>,
        direction: Vec3<T>,
        t_min: T,
        t_max: T,
    ) -> bool {
        self.rays += 1;
        let far = t_max.min(t_far());
        let ray = self.hook_ray(origin, direction);
        let hit = nearest_hit_before::<T, ROBUST>(&ray, t_min, far, &self.prepared.primitives);
        hit.object >= 0 && hit.t < far
    }

    /// `object_material`: zero where the object names none.
    pub(crate) fn object_material(&self, id: i32) -> Material<T> {
        usize::try_from(id)
            .ok()
            .and_then(|k| self.scene.objects.get(k))
            .and_then(|(m, _)| *m)
            .map_or_else(Material::default, |m| self.scene.materials[m])
    }

    /// `object_values`, which hooks call (the course's ray tracer, mirrored here, does not).
    #[allow(dead_code)]
    pub(crate) fn object_values(&self, id: i32) -> [T; 4] {
        usize::try_from(id)
            .ok()
            .and_then(|k| self.scene.objects.get(k))
            .map_or([T::ZERO; 4], |(_, v)| *v)
    }

    /// `light_count`.
    pub(crate) fn light_count(&self) -> u32 {
        self.scene.lights.len() as u32
    }

    /// `scene_light`.
    pub(crate) fn scene_light(&self, k: u32) -> Light<T> {
        self.scene.lights[k as usize]
    }
}

/// `position_error`: a bound on each coordinate's error in a hit's world position, in the
/// hook's precision (`T` here, f32 on the GPU).
fn position_error<T: Real>(
    along: Vec3<T>,
    start: Vec3<T>,
    world: Vec3<T>,
    position: Vec3<T>,
    unit: T,
) -> Vec3<T> {
    let t_tolerance = T::from_f64(16.0) * T::EPS;
    let kernel = along.abs() * (t_tolerance + T::TWO * T::EPS) + start.abs() * T::EPS;
    (kernel * unit + world.abs() * T::EPS) + position.abs() * T::EPS
}

/// `leave` (shaders/hooks.wgsl): `hit.position` moved off the surface by twice its error
/// bound, to the side `direction` goes.
pub(crate) fn leave<T: Real>(hit: &ShadeHit<T>, direction: Vec3<T>) -> Vec3<T> {
    let off = T::TWO * dot(hit.normal.abs(), hit.error);
    let off = if dot(direction, hit.normal) < T::ZERO {
        -off
    } else {
        off
    };
    hit.position + hit.normal * off
}

/// WGSL's `pack4x8unorm`: each component clamped to [0, 1], times 255, rounded.
pub(crate) fn pack_unorm<T: Real>(colour: [T; 4]) -> [u8; 4] {
    colour.map(|c| {
        let c = c.max(T::ZERO).min(T::ONE);
        (T::HALF + T::from_f64(255.0) * c).floor().to_f64() as u8
    })
}
