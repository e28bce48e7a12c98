//! # raycast
//!
//! A ray caster whose per-pixel work runs as a WGSL compute shader on any Vulkan GPU, or on
//! Mesa's lavapipe on a plain CPU.
//!
//! The data flows one way, through one path for every mode (docs/architecture.md):
//!
//! ```text
//! scene file --Scene::load--> Scene (validated, f64)
//!   --prepare::Prepared--> camera frame, camera-relative primitives in the kernel's precision, BVH
//!   --gpu::run(Job) | cpu::render_prepared--> Images (id, distance, normal)
//!   --output::write(Encoding, Camera)--> png / ppm / npy / npz / exr / depth16 files + camera.json
//! ```
//!
//! [`render::render`] does all of it for a [`render::Mode`] (device, precision, algorithm):
//!
//! ```no_run
//! use raycast::render::{self, Precision, Device, Mode};
//! use raycast::{Algorithm, Scene, gpu::Gpu, output::{Encoding, Format}};
//! let scene = Scene::load("scenes/course/bunny.json".as_ref())?;
//! let gpu = Gpu::new()?; // or Gpu::from_parts(adapter, device, queue)
//! let mode = Mode { device: Device::Gpu, precision: Precision::F32, algorithm: Algorithm::Robust };
//! let images = render::render(&scene, mode, Some(&gpu), None)?;
//! images.write("out".as_ref(), &Encoding::new(&[Format::Png, Format::Npy], None)?, &scene.camera)?;
//! # Ok::<(), raycast::Error>(())
//! ```
//!
//! The stages one by one, typed by precision:
//!
//! ```no_run
//! use raycast::{Algorithm, Scene, gpu::{self, Gpu, Job}, math::Float};
//! let scene = Scene::load("scenes/course/bunny.json".as_ref())?;
//! let gpu = Gpu::new()?;
//! let variant = gpu.scene_variant(&scene, Float::F32, Algorithm::Robust);
//! let prepared = gpu::prepare::<f32>(&scene, &variant)?;
//! let rendered = gpu::run(&gpu, &prepared, Job::new(variant).timed(true))?;
//! println!("{} hits, kernel {:?} s", rendered.images.id.iter().filter(|&&id| id >= 0).count(),
//!     rendered.stages.kernel_s);
//! # Ok::<(), raycast::Error>(())
//! ```

pub mod algorithm;
pub mod cpu;
pub mod error;
pub mod gpu;
pub mod images;
pub mod kernel;
pub mod math;
pub mod output;
pub mod prepare;
pub mod query;
pub mod rays;
pub mod render;
pub mod scene;

// The README's Rust code, compiled and run by `cargo test` as doc tests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;

pub use algorithm::Algorithm;
pub use error::{Error, Result};
pub use gpu::Gpu;
pub use images::{Images, Output, Outputs};
pub use query::{Accel, Geometry};
pub use rays::{AnyHits, Hits, Ray, RayList};
pub use render::{AnyImages, Cpu, Precision, RenderOptions};
pub use scene::Scene;
