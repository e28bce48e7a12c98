//! GPU-side structs, byte for byte as WGSL lays them out.
//! Keep in sync with shaders/types.wgsl and shaders/bindings.wgsl; the tests below compare
//! every size and offset with naga's layout of the WGSL structs.

use bytemuck::{Pod, Zeroable};

use crate::camera::Frame;
use crate::math::Vec3;
use crate::scene::Projection;

/// `struct Frame` in shaders/types.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuFrame {
    pub eye: [f32; 3],     // offset 0
    pub projection: u32,   // offset 12
    pub u: [f32; 3],       // offset 16
    pub nx: u32,           // offset 28
    pub v: [f32; 3],       // offset 32
    pub ny: u32,           // offset 44
    pub w: [f32; 3],       // offset 48
    pub focal_length: f32, // offset 60
    pub width: f32,        // offset 64
    pub height: f32,       // offset 68
    pub min_t: f32,        // offset 72
    pub _pad: u32,         // offset 76
} // size 80

/// `struct Params` in shaders/bindings.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuParams {
    pub frame: GpuFrame,     // offset 0
    pub row_offset: u32,     // offset 80
    pub tile_rows: u32,      // offset 84
    pub sphere_count: u32,   // offset 88
    pub plane_count: u32,    // offset 92
    pub triangle_count: u32, // offset 96
    pub _pad: [u32; 3],      // offset 100
} // size 112

/// `struct Sphere` in shaders/types.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuSphere {
    pub center: [f32; 3], // offset 0
    pub radius: f32,      // offset 12
    pub object: u32,      // offset 16
    pub _pad: [u32; 3],   // offset 20
} // size 32

/// `struct Plane` in shaders/types.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuPlane {
    pub point: [f32; 3],  // offset 0
    pub object: u32,      // offset 12
    pub normal: [f32; 3], // offset 16
    pub _pad: u32,        // offset 28
} // size 32

/// `struct Triangle` in shaders/types.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuTriangle {
    pub a: [f32; 3], // offset 0
    pub object: u32, // offset 12
    pub b: [f32; 3], // offset 16
    pub _pad0: u32,  // offset 28
    pub c: [f32; 3], // offset 32
    pub _pad1: u32,  // offset 44
} // size 48

/// Rounds an f64 vector to the GPU's f32.
pub fn f32x3(v: Vec3<f64>) -> [f32; 3] {
    v.cast::<f32>().to_array()
}

impl GpuFrame {
    pub fn new(frame: &Frame<f64>) -> Self {
        let f = frame.cast::<f32>();
        GpuFrame {
            eye: f.eye.to_array(),
            projection: match f.projection {
                Projection::Perspective => 0,
                Projection::Orthographic => 1,
            },
            u: f.u.to_array(),
            nx: f.nx,
            v: f.v.to_array(),
            ny: f.ny,
            w: f.w.to_array(),
            focal_length: f.focal_length,
            width: f.width,
            height: f.height,
            min_t: f.min_t,
            _pad: 0,
        }
    }
}

#[cfg(test)]
mod tests {
    use std::mem::{offset_of, size_of};

    use super::*;
    use crate::gpu::shader;

    /// (WGSL struct name, Rust size, [(member, Rust offset)]) checked against naga's layout.
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
        for (field, offset) in fields {
            let m = members
                .iter()
                .find(|m| m.name.as_deref() == Some(*field))
                .unwrap_or_else(|| panic!("{name} has no member {field}"));
            assert_eq!(m.offset as usize, *offset, "offset of {name}.{field}");
        }
    }

    #[test]
    fn rust_structs_match_naga_layout() {
        let source = shader::kernel_source().unwrap();
        let m = shader::validate(&source, "kernel").unwrap();
        check(
            &m,
            "Frame",
            size_of::<GpuFrame>(),
            &[
                ("eye", offset_of!(GpuFrame, eye)),
                ("projection", offset_of!(GpuFrame, projection)),
                ("u", offset_of!(GpuFrame, u)),
                ("nx", offset_of!(GpuFrame, nx)),
                ("v", offset_of!(GpuFrame, v)),
                ("ny", offset_of!(GpuFrame, ny)),
                ("w", offset_of!(GpuFrame, w)),
                ("focal_length", offset_of!(GpuFrame, focal_length)),
                ("width", offset_of!(GpuFrame, width)),
                ("height", offset_of!(GpuFrame, height)),
                ("min_t", offset_of!(GpuFrame, min_t)),
            ],
        );
        check(
            &m,
            "Params",
            size_of::<GpuParams>(),
            &[
                ("frame", offset_of!(GpuParams, frame)),
                ("row_offset", offset_of!(GpuParams, row_offset)),
                ("tile_rows", offset_of!(GpuParams, tile_rows)),
                ("sphere_count", offset_of!(GpuParams, sphere_count)),
                ("plane_count", offset_of!(GpuParams, plane_count)),
                ("triangle_count", offset_of!(GpuParams, triangle_count)),
            ],
        );
        check(
            &m,
            "Sphere",
            size_of::<GpuSphere>(),
            &[
                ("center", offset_of!(GpuSphere, center)),
                ("radius", offset_of!(GpuSphere, radius)),
                ("object", offset_of!(GpuSphere, object)),
            ],
        );
        check(
            &m,
            "Plane",
            size_of::<GpuPlane>(),
            &[
                ("point", offset_of!(GpuPlane, point)),
                ("object", offset_of!(GpuPlane, object)),
                ("normal", offset_of!(GpuPlane, normal)),
            ],
        );
        check(
            &m,
            "Triangle",
            size_of::<GpuTriangle>(),
            &[
                ("a", offset_of!(GpuTriangle, a)),
                ("object", offset_of!(GpuTriangle, object)),
                ("b", offset_of!(GpuTriangle, b)),
                ("c", offset_of!(GpuTriangle, c)),
            ],
        );
    }
}
