//! # raycast
//!
//! A ray caster whose per-pixel work runs as a WGSL compute shader on any Vulkan GPU, or on
//! Mesa's lavapipe on a plain CPU.
//!
//! Two devices with the same methods: [`Gpu`] (the WGSL kernels on a wgpu adapter) and [`Cpu`]
//! (the CPU reference, the kernels mirrored in Rust). Each renders a [`Scene`] (a camera and
//! objects) with [`RenderOptions`], and commits a [`Geometry`] (objects alone) as an [`Accel`]
//! that rays are cast at, Embree's commit-then-query. The files of a render are written whole or
//! not at all by the crate beside it, `raycast_files`:
//!
//! ```no_run
//! use raycast::{DVec3, Encoding, Format, Geometry, Gpu, Precision, Ray, RenderOptions, Scene};
//! let gpu = Gpu::new()?; // or Gpu::from_parts(adapter, device, queue)
//! let scene = Scene::load("scenes/course/bunny.json".as_ref())?;
//! let images = gpu.render(&scene, &RenderOptions::default())?;
//! let encoding = Encoding::new(&[Format::Png, Format::Npy], None)?;
//! raycast_files::write_files("out".as_ref(), &images.encode(&encoding, &scene.camera))?;
//!
//! let accel = gpu.commit(&Geometry::from_scene(&scene), Precision::F32)?;
//! let ray = Ray { origin: DVec3::new(0.0, 0.1, 1.0), direction: DVec3::NEG_Z };
//! let hits = accel.intersect(&[ray])?;
//! println!("object {} at t = {:?}", hits.id()[0], hits.t_f64()[0]);
//! # Ok::<(), raycast::Error>(())
//! ```
//!
//! The layers beneath (preparation, the kernel variants, the CPU mirror, the mode dispatch) are
//! crate-private; docs/architecture.md maps them.

#![warn(missing_docs)]

// The layers beneath the API, crate-private (docs/architecture.md maps them).
mod algorithm;
mod cpu;
mod error;
mod gpu;
mod images;
mod kernel;
mod math;
mod mode;
mod output;
mod prepare;
mod query;
mod rays;
mod render;
mod scene;

// The GPU cost model's traces (feature `model`, off by default): for benches/gpu_model, not
// part of the library's API.
#[cfg(feature = "model")]
#[doc(hidden)]
pub mod model;

// The tests that reach below the API (the kernel variants, the mirror, preparation), a module
// per topic in the library's own test binary; they name the crate `raycast` as a client would.
#[cfg(test)]
extern crate self as raycast;
#[cfg(test)]
mod tests;

// The README's Rust code, compiled and run by `cargo test` as doc tests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub(crate) struct ReadmeDoctests;

// The API: the devices and what they take and give, re-exported from the layers that define them.
pub use crate::{
    algorithm::Algorithm,
    error::{Error, Result},
    gpu::{Gpu, GpuInfo, hooks::ShadeHook, kernel::UserKernel},
    images::{Coverage, Images, MISS, Output, Outputs, Stages},
    mode::{Device, Mode, Precision},
    prepare::bvh::Search,
    query::{
        Accel, Geometry,
        every_hit::Intersections,
        points::{Closest, Sign},
    },
    rays::{AnyHits, Hits, INVALID_ID, Ray, RayList},
    render::options::{Cpu, RenderOptions, Tuning},
    render::viewer::Viewer,
    render::{AnyImages, Begun, Progress},
};

// The scenes: scene and mesh files, cameras, views files and orbits.
pub use crate::scene::{
    Camera, CameraOverrides, DEFAULT_RESOLUTION, DEFAULT_SCENE_FILES, Lens, Light, Lighting,
    Material, MeshPart, Object, Orbit, Projection, Scene, Split, Triangle, ViewCamera, bounds,
    is_mesh_file, load_mesh, load_viewed, parse_mesh, parse_poses, parse_views,
};

// The file formats.
pub use crate::output::{Depth, Encoding, Format, Pictures, encode_png_rgb};
/// The API's vector type (points, directions, colours) and transform (an instance's place:
/// [`Geometry::add_instance`], [`Viewer::pose`]): glam's, re-exported so that a client's match
/// the library's version.
pub use glam::{DAffine3, DVec3};
