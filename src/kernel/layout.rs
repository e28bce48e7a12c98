//! GPU-side structs, byte for byte as WGSL lays them out, generic over the kernel's scalar `R`
//! (`f32` or `f64`, WGSL's `real`). Keep in sync with shaders/types.wgsl and
//! shaders/bindings.wgsl; the tests below compare every size and offset with naga's layout of
//! the WGSL structs, in both precisions.
//!
//! Every struct is `vec3<real>` + `real` pairs (or all `u32` after a `Frame`), or `real`s
//! only (`StoredTriangle`), which packs without implicit padding in both precisions, so one
//! generic Rust struct fits both.

use bytemuck::{Pod, Zeroable};

use crate::kernel::frame::Frame;
use crate::kernel::types::{Plane, Sphere, Triangle};
use crate::math::Real;
use crate::scene::Projection;

/// A scalar the GPU kernel can run in.
pub(crate) trait GpuReal: Real + Pod {
    /// A `u32` in the space of one real (`id_word` in shaders/: `Plane::object`).
    type IdWord: Pod + std::fmt::Debug;
    fn id_word(id: u32) -> Self::IdWord;
    /// The largest value not above `x`: a value `t` of this type is at most `x` exactly when it
    /// is at most `at_most(x)`.
    fn at_most(x: f64) -> Self;
}
impl GpuReal for f32 {
    type IdWord = u32;
    fn id_word(id: u32) -> u32 {
        id
    }
    fn at_most(x: f64) -> f32 {
        let nearest = x as f32;
        match nearest as f64 > x {
            true => nearest.next_down(),
            false => nearest,
        }
    }
}
impl GpuReal for f64 {
    type IdWord = [u32; 2];
    fn id_word(id: u32) -> [u32; 2] {
        [id, 0]
    }
    fn at_most(x: f64) -> f64 {
        x
    }
}

/// `struct Frame` in shaders/types.wgsl. Offsets f32 / f64.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub(crate) struct GpuFrame<R> {
    pub eye: [R; 3],     // offset 0 / 0
    pub focal_length: R, // offset 12 / 24
    pub u: [R; 3],       // offset 16 / 32
    pub width: R,        // offset 28 / 56
    pub v: [R; 3],       // offset 32 / 64
    pub height: R,       // offset 44 / 88
    pub w: [R; 3],       // offset 48 / 96
    pub min_t: R,        // offset 60 / 120
} // size 64 / 128

/// `struct Params` in shaders/bindings.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub(crate) struct GpuParams<R> {
    pub frame: GpuFrame<R>,  // offset 0
    pub projection: u32,     // offset 64 / 128
    pub nx: u32,             // offset 68 / 132
    pub ny: u32,             // offset 72 / 136
    pub row_offset: u32,     // offset 76 / 140
    pub tile_rows: u32,      // offset 80 / 144
    pub sphere_count: u32,   // offset 84 / 148
    pub plane_count: u32,    // offset 88 / 152
    pub triangle_count: u32, // offset 92 / 156
    pub origin: [R; 3],      // offset 96 / 160
    pub unit: R,             // offset 108 / 184
    pub max_t: R,            // offset 112 / 192
    pub _pad: [R; 3],        // offset 116 / 200
} // size 128 / 224

/// `struct Sphere` in shaders/types.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub(crate) struct GpuSphere<R> {
    pub center: [R; 3], // offset 0
    pub radius: R,      // offset 12 / 24
} // size 16 / 32

/// `struct Plane` in shaders/types.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub(crate) struct GpuPlane<R: GpuReal> {
    pub point: [R; 3],     // offset 0
    pub object: R::IdWord, // offset 12 / 24
    pub normal: [R; 3],    // offset 16 / 32
    pub _pad1: R,          // offset 28 / 56
} // size 32 / 64

/// `struct StoredTriangle` in shaders/types.wgsl: a triangle packed, 9 reals and one of
/// padding, which the kernel reads as five pairs.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub(crate) struct GpuTriangle<R> {
    pub a: [R; 3], // offset 0
    pub b: [R; 3], // offset 12 / 24
    pub c: [R; 3], // offset 24 / 48
    pub _pad: R,   // offset 36 / 72
} // size 40 / 80

/// `struct StoredRay` in shaders/types.wgsl: a caller's ray in kernel coordinates.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub(crate) struct GpuRay<R> {
    pub origin: [R; 3],    // offset 0
    pub _pad0: R,          // offset 12 / 24
    pub direction: [R; 3], // offset 16 / 32
    pub _pad1: R,          // offset 28 / 56
} // size 32 / 64

// SAFETY: each struct is `repr(C)` and made only of `R` (4- or 8-byte floats) and `u32`s whose
// offsets are multiples of their size, with a total size that is a multiple of the alignment:
// no padding bytes in either precision (the layout test checks the sizes), and any bit
// pattern is a valid value.
macro_rules! pod_for_gpu_real {
    ($($t:ident),*) => {$(
        unsafe impl<R: GpuReal> Zeroable for $t<R> {}
        unsafe impl<R: GpuReal> Pod for $t<R> {}
    )*};
}
pod_for_gpu_real!(
    GpuFrame,
    GpuParams,
    GpuSphere,
    GpuPlane,
    GpuTriangle,
    GpuRay
);

impl<R: GpuReal> GpuFrame<R> {
    /// `frame` rounded to `R` (exact when it is in `R` already).
    pub(crate) fn new<T: Real>(frame: &Frame<T>) -> Self {
        let f = frame.cast::<R>();
        GpuFrame {
            eye: f.eye.to_array(),
            focal_length: f.focal_length,
            u: f.u.to_array(),
            width: f.width,
            v: f.v.to_array(),
            height: f.height,
            w: f.w.to_array(),
            min_t: f.min_t,
        }
    }
}

impl<R: GpuReal> From<&Sphere<R>> for GpuSphere<R> {
    fn from(s: &Sphere<R>) -> Self {
        GpuSphere {
            center: s.center.to_array(),
            radius: s.radius,
        }
    }
}

impl<R: GpuReal> GpuPlane<R> {
    /// Plane `q` of object `object`.
    pub(crate) fn new(q: &Plane<R>, object: u32) -> Self {
        GpuPlane {
            point: q.point.to_array(),
            object: R::id_word(object),
            normal: q.normal.to_array(),
            _pad1: R::ZERO,
        }
    }
}

impl<R: GpuReal> From<&Triangle<R>> for GpuTriangle<R> {
    fn from(t: &Triangle<R>) -> Self {
        GpuTriangle {
            a: t.a.to_array(),
            b: t.b.to_array(),
            c: t.c.to_array(),
            _pad: R::ZERO,
        }
    }
}

impl<R: GpuReal> From<&crate::kernel::types::Ray<R>> for GpuRay<R> {
    fn from(r: &crate::kernel::types::Ray<R>) -> Self {
        GpuRay {
            origin: r.origin.to_array(),
            _pad0: R::ZERO,
            direction: r.direction.to_array(),
            _pad1: R::ZERO,
        }
    }
}

/// `struct Material` in shaders/hooks.wgsl (f32 whatever the kernel's precision, as hooks are).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub(crate) struct GpuMaterial {
    pub ka: [f32; 3],        // offset 0
    pub phong_exponent: f32, // offset 12
    pub kd: [f32; 3],        // offset 16
    pub _pad0: f32,
    pub ks: [f32; 3], // offset 32
    pub _pad1: f32,
    pub km: [f32; 3], // offset 48
    pub _pad2: f32,
} // size 64

/// `struct Light` in shaders/hooks.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub(crate) struct GpuLight {
    pub position: [f32; 3],  // offset 0
    pub kind: u32,           // offset 12: LIGHT_DIRECTIONAL 0, LIGHT_POINT 1
    pub direction: [f32; 3], // offset 16
    pub _pad0: f32,
    pub color: [f32; 3], // offset 32
    pub _pad1: f32,
} // size 48

/// `struct HookObject` in shaders/hooks.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub(crate) struct GpuHookObject {
    pub values: [f32; 4], // offset 0
    pub material: i32,    // offset 16: -1 for none
    pub _pad: [u32; 3],
} // size 32

/// The header of `struct HookLights` in shaders/hooks.wgsl: the count, then padding to the
/// lights at offset 16.
pub(crate) const HOOK_LIGHTS_HEADER: usize = 16;

impl From<&crate::scene::Material> for GpuMaterial {
    fn from(m: &crate::scene::Material) -> Self {
        GpuMaterial {
            ka: crate::math::Vec3::from(m.ka).cast::<f32>().to_array(),
            phong_exponent: m.phong_exponent as f32,
            kd: crate::math::Vec3::from(m.kd).cast::<f32>().to_array(),
            ks: crate::math::Vec3::from(m.ks).cast::<f32>().to_array(),
            km: crate::math::Vec3::from(m.km).cast::<f32>().to_array(),
            ..GpuMaterial::default()
        }
    }
}

impl From<&crate::scene::Light> for GpuLight {
    fn from(l: &crate::scene::Light) -> Self {
        match l {
            crate::scene::Light::Directional { direction, color } => GpuLight {
                kind: 0,
                direction: crate::math::Vec3::from(*direction).cast::<f32>().to_array(),
                color: crate::math::Vec3::from(*color).cast::<f32>().to_array(),
                ..GpuLight::default()
            },
            crate::scene::Light::Point { position, color } => GpuLight {
                position: crate::math::Vec3::from(*position).cast::<f32>().to_array(),
                kind: 1,
                color: crate::math::Vec3::from(*color).cast::<f32>().to_array(),
                ..GpuLight::default()
            },
        }
    }
}

/// The hook's view of `lighting` for a scene of `objects` objects: the buffers
/// `hook_materials`, `hook_lights` (as bytes: the count, then the lights) and `hook_objects`
/// of shaders/hooks.wgsl, each with at least one entry (a binding is never empty).
pub(crate) fn hook_buffers(
    lighting: &crate::scene::Lighting,
    objects: usize,
) -> (Vec<GpuMaterial>, Vec<u8>, Vec<GpuHookObject>) {
    let mut materials: Vec<GpuMaterial> = lighting.materials.iter().map(Into::into).collect();
    materials.resize(materials.len().max(1), GpuMaterial::default());
    let mut lights: Vec<GpuLight> = lighting.lights.iter().map(Into::into).collect();
    lights.resize(lights.len().max(1), GpuLight::default());
    let mut light_bytes = vec![0u8; HOOK_LIGHTS_HEADER];
    light_bytes[..4].copy_from_slice(&(lighting.lights.len() as u32).to_ne_bytes());
    light_bytes.extend_from_slice(bytemuck::cast_slice(&lights));
    let hook_objects = (0..objects.max(1))
        .map(|k| {
            let (material, values) = lighting.object_data(k);
            GpuHookObject {
                values: values.map(|x| x as f32),
                material: material.map_or(-1, |m| m as i32),
                _pad: [0; 3],
            }
        })
        .collect();
    (materials, light_bytes, hook_objects)
}

/// The `projection` code of shaders/types.wgsl.
pub(crate) fn projection_code(p: Projection) -> u32 {
    match p {
        Projection::Perspective => 0,
        Projection::Orthographic => 1,
    }
}

#[cfg(test)]
mod tests {
    use std::mem::{offset_of, size_of};

    use super::*;
    use crate::gpu::shader;

    /// Checks a WGSL struct's size and member offsets (naga's layout) against Rust's.
    fn check(module: &naga::Module, name: &str, size: usize, fields: &[(&str, usize)]) {
        let (_, ty) = module
            .types
            .iter()
            .find(|(_, t)| t.name.as_deref() == Some(name))
            .unwrap_or_else(|| panic!("no WGSL struct {name}"));
        let naga::TypeInner::Struct { members, span } = &ty.inner else {
            panic!("{name} is not a struct");
        };
        assert_eq!(*span as usize, size, "size of {name}");
        assert_eq!(members.len(), fields.len(), "member count of {name}");
        for (field, offset) in fields {
            let m = members
                .iter()
                .find(|m| m.name.as_deref() == Some(*field))
                .unwrap_or_else(|| panic!("{name} has no member {field}"));
            assert_eq!(m.offset as usize, *offset, "offset of {name}.{field}");
        }
    }

    fn check_precision<R: GpuReal>() {
        let variant = shader::Variant::new(R::PRECISION, crate::Algorithm::Robust);
        let source = shader::kernel_source(&variant).unwrap();
        let (m, _) = shader::validate(&source, "kernel").unwrap();
        macro_rules! fields {
            ($t:ty: $($f:ident),*) => { &[$((stringify!($f), offset_of!($t, $f))),*] };
        }
        check(
            &m,
            "Frame",
            size_of::<GpuFrame<R>>(),
            fields!(GpuFrame<R>: eye, focal_length, u, width, v, height, w, min_t),
        );
        check(
            &m,
            "Params",
            size_of::<GpuParams<R>>(),
            fields!(GpuParams<R>: frame, projection, nx, ny, row_offset, tile_rows,
                sphere_count, plane_count, triangle_count, origin, unit, max_t),
        );
        check(
            &m,
            "Sphere",
            size_of::<GpuSphere<R>>(),
            fields!(GpuSphere<R>: center, radius),
        );
        check(
            &m,
            "Plane",
            size_of::<GpuPlane<R>>(),
            fields!(GpuPlane<R>: point, object, normal, _pad1),
        );
        check(
            &m,
            "StoredTriangle",
            size_of::<GpuTriangle<R>>(),
            fields!(GpuTriangle<R>: a, b, c, _pad),
        );
        check(
            &m,
            "StoredRay",
            size_of::<GpuRay<R>>(),
            fields!(GpuRay<R>: origin, _pad0, direction, _pad1),
        );
    }

    /// The hook's structs (shaders/hooks.wgsl, f32 in every kernel), from the prelude alone.
    #[test]
    fn hook_structs_match_naga_layout() {
        let m = naga::front::wgsl::parse_str(crate::gpu::hooks::PRELUDE).unwrap();
        macro_rules! fields {
            ($t:ty: $($f:ident),*) => { &[$((stringify!($f), offset_of!($t, $f))),*] };
        }
        check(
            &m,
            "Material",
            size_of::<GpuMaterial>(),
            fields!(GpuMaterial: ka, phong_exponent, kd, ks, km),
        );
        check(
            &m,
            "Light",
            size_of::<GpuLight>(),
            fields!(GpuLight: position, kind, direction, color),
        );
        check(
            &m,
            "HookObject",
            size_of::<GpuHookObject>(),
            fields!(GpuHookObject: values, material),
        );
        check(
            &m,
            "HookLights",
            HOOK_LIGHTS_HEADER + size_of::<GpuLight>(),
            &[("count", 0), ("lights", HOOK_LIGHTS_HEADER)],
        );
    }

    #[test]
    fn rust_structs_match_naga_layout_f32() {
        check_precision::<f32>();
    }

    #[test]
    fn rust_structs_match_naga_layout_f64() {
        check_precision::<f64>();
    }
}
