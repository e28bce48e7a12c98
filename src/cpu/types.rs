//! Mirror of shaders/types.wgsl: the kernel's value types, and the scene's primitives in the
//! kernel's precision (the GPU path uploads exactly these values).

use crate::math::{Real, Vec3};
use crate::scene::{Object, Scene};

pub use crate::camera::Frame;

/// Returned by the `intersect_*` functions when the ray misses (valid hits have `t >= 1`).
pub fn no_hit<T: Real>() -> T {
    -T::ONE
}

/// The largest finite f32: the initial "nearest so far" distance (`T_FAR` in WGSL).
pub fn t_far<T: Real>() -> T {
    T::from_f64(f32::MAX as f64)
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray<T> {
    pub origin: Vec3<T>,
    pub direction: Vec3<T>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere<T> {
    pub center: Vec3<T>,
    pub radius: T,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane<T> {
    pub point: Vec3<T>,
    /// Unit length.
    pub normal: Vec3<T>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle<T> {
    pub a: Vec3<T>,
    pub b: Vec3<T>,
    pub c: Vec3<T>,
}

/// A scene's primitives rounded to precision `T`, by kind, each with its object id
/// (`objects` in shaders/bindings.wgsl holds the ids in the order spheres, planes, triangles).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Primitives<T> {
    pub spheres: Vec<Sphere<T>>,
    pub planes: Vec<Plane<T>>,
    pub triangles: Vec<Triangle<T>>,
    pub sphere_objects: Vec<u32>,
    pub plane_objects: Vec<u32>,
    pub triangle_objects: Vec<u32>,
}

impl<T: Real> Primitives<T> {
    /// Every object of `scene`, rounded from f64 to `T`; a soup adds all its triangles under
    /// its one id.
    pub fn new(scene: &Scene) -> Primitives<T> {
        let mut p = Primitives {
            spheres: Vec::new(),
            planes: Vec::new(),
            triangles: Vec::new(),
            sphere_objects: Vec::new(),
            plane_objects: Vec::new(),
            triangle_objects: Vec::new(),
        };
        for (id, object) in scene.objects.iter().enumerate() {
            let id = id as u32;
            match object {
                Object::Sphere { center, radius } => {
                    p.spheres.push(Sphere {
                        center: center.cast(),
                        radius: T::from_f64(*radius),
                    });
                    p.sphere_objects.push(id);
                }
                Object::Plane { point, normal } => {
                    p.planes.push(Plane {
                        point: point.cast(),
                        normal: normal.cast(),
                    });
                    p.plane_objects.push(id);
                }
                Object::Triangle { corners } => p.push_triangle(id, corners),
                Object::Soup { triangles, .. } => {
                    triangles.iter().for_each(|t| p.push_triangle(id, t))
                }
            }
        }
        p
    }

    fn push_triangle(&mut self, id: u32, t: &crate::scene::Triangle) {
        self.triangles.push(Triangle {
            a: t[0].cast(),
            b: t[1].cast(),
            c: t[2].cast(),
        });
        self.triangle_objects.push(id);
    }
}
