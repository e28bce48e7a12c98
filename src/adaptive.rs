//! Adaptive precision: f64 answers at close to f32 cost.
//!
//! A robust f32 pass also decides, per pixel, whether its hit/miss and id are certain: every
//! decision it makes (sphere discriminant, plane parallel cutoff, triangle edge functions, the
//! start test, the order of the two nearest objects) is compared with twice its first-order
//! error bound (`shaders/types.wgsl`, `CERTAINTY`; the same bounds as `src/cpu/margin.rs`,
//! where they are derived). Uncertain pixels are cast again in f64 (on the GPU where it has
//! `SHADER_F64`, else on the CPU) and merged in. The images are f32: the decisions (hit/miss,
//! id) are those of f64 on every pixel, and re-cast pixels carry their f64 distance and normal
//! rounded to f32 (keeping the whole image in f32 spares a widening copy that costs more than
//! the re-cast on small images).

use crate::algorithm::Algorithm;
use crate::cpu;
use crate::error::Result;
use crate::gpu::{self, Gpu};
use crate::images::Images;
use crate::scene::Scene;

/// An adaptive render and what it re-cast.
pub struct Adaptive {
    pub images: Images<f32>,
    /// Pixels cast again in f64.
    pub recast: usize,
    /// Whether the re-cast ran on the GPU (else on the CPU).
    pub recast_on_gpu: bool,
    /// GPU kernel time in seconds of the certainty pass plus the re-cast pass (timestamp
    /// queries; see [`gpu::render_timed`]), from [`render_adaptive_timed`] only; `None` from
    /// [`render_adaptive`], without `TIMESTAMP_QUERY`, or when pixels were re-cast on the CPU.
    pub kernel_s: Option<f64>,
}

impl Adaptive {
    /// Fraction of pixels re-cast in f64.
    pub fn recast_fraction(&self) -> f64 {
        self.recast as f64 / self.images.len().max(1) as f64
    }
}

/// Renders `scene` with adaptive precision on `gpu` (robust algorithm set).
pub fn render_adaptive(gpu: &Gpu, scene: &Scene) -> Result<Adaptive> {
    adaptive(gpu, scene, false)
}

/// [`render_adaptive`], also measuring the kernels' GPU time ([`Adaptive::kernel_s`]).
pub fn render_adaptive_timed(gpu: &Gpu, scene: &Scene) -> Result<Adaptive> {
    adaptive(gpu, scene, true)
}

fn adaptive(gpu: &Gpu, scene: &Scene, timed: bool) -> Result<Adaptive> {
    let (first, certain, first_s) = if timed {
        gpu::render_with_certainty_timed(gpu, scene)?
    } else {
        let (first, certain) = gpu::render_with_certainty(gpu, scene)?;
        (first, certain, None)
    };
    let uncertain: Vec<usize> = (0..certain.len()).filter(|&k| !certain[k]).collect();
    let mut images = first;
    let recast_on_gpu = gpu.device.features().contains(wgpu::Features::SHADER_F64);
    if uncertain.is_empty() {
        return Ok(Adaptive {
            images,
            recast: 0,
            recast_on_gpu,
            kernel_s: first_s,
        });
    }
    let (exact, kernel_s) = if recast_on_gpu && timed {
        let (exact, second_s) =
            gpu::render_pixels_timed::<f64>(gpu, scene, Algorithm::Robust, &uncertain)?;
        (exact, first_s.zip(second_s).map(|(a, b)| a + b))
    } else if recast_on_gpu {
        let exact = gpu::render_pixels::<f64>(gpu, scene, Algorithm::Robust, &uncertain)?;
        (exact, None)
    } else {
        let exact = cpu::render_pixels::<f64>(scene, Algorithm::Robust, &uncertain);
        (exact, None)
    };
    for (k, pixel) in uncertain.iter().zip(exact) {
        images.id[*k] = pixel.id;
        images.distance[*k] = pixel.distance as f32;
        images.normal[*k] = pixel.normal.map(|c| c as f32);
    }
    Ok(Adaptive {
        images,
        recast: uncertain.len(),
        recast_on_gpu,
        kernel_s,
    })
}
