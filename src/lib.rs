//! # raycast
//!
//! A ray caster whose per-pixel work runs as a WGSL compute shader on any Vulkan GPU, or on
//! Mesa's lavapipe on a plain CPU.
//!
//! The data flows one way:
//!
//! ```text
//! scene file --Scene::load--> Scene (validated, f64)
//!            --camera::Frame + primitives--> gpu::render::<f32 | f64> --> Images (id, distance, normal)
//!            --output::write--> png / ppm / npy files
//! ```
//!
//! ```no_run
//! use raycast::{Scene, gpu::Gpu, output::{write_images, Format}};
//! let scene = Scene::load("scenes/course/bunny.json".as_ref())?;
//! let gpu = Gpu::new()?;
//! let images = raycast::gpu::render::<f32>(&gpu, &scene, raycast::Algorithm::Robust)?;
//! write_images(&images, "out".as_ref(), &[Format::Png])?;
//! # Ok::<(), raycast::Error>(())
//! ```

pub mod accuracy;
pub mod adaptive;
pub mod algorithm;
pub mod bench;
pub mod bvh;
pub mod camera;
pub mod compare;
pub mod cpu;
pub mod error;
pub mod gpu;
pub mod images;
pub mod math;
pub mod output;
pub mod render;
pub mod scene;
pub mod specialize;
pub mod supersample;
pub mod tradeoff;

pub use algorithm::Algorithm;
pub use error::{Error, Result};
pub use images::Images;
pub use scene::Scene;
