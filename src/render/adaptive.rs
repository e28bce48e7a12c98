//! Adaptive precision: f64 answers at close to f32 cost.
//!
//! Both passes go through the scene's BVH where it has one (the certainty pass searches each
//! ray a little beyond its nearest hit, by that hit's error bound, so that no object the exact
//! search could find first is skipped), and share it.
//!
//! A robust f32 pass also decides, per pixel, whether its hit/miss and id are certain: every
//! decision it makes (sphere discriminant, plane parallel cutoff, triangle edge functions, the
//! start test, the order of the two nearest objects) is compared with twice its first-order
//! error bound (`shaders/certainty.wgsl`, `CERTAINTY`; the same bounds as `src/cpu/margin.rs`,
//! where they are derived). Uncertain pixels are cast again in f64 and merged in: on the CPU
//! where they are few ([`CPU_RECAST_PIXELS`]) or the GPU has no `SHADER_F64`, else on the
//! GPU. The images are f32: the decisions (hit/miss, id) are those of f64 on every pixel, and
//! re-cast pixels carry their f64 distance and normal rounded to f32 (keeping the whole image
//! in f32 spares a widening copy that costs more than the re-cast on small images).

use crate::algorithm::Algorithm;
use crate::cpu;
use crate::error::Result;
use crate::gpu::shader::Variant;
use crate::gpu::{self, Gpu, Job};
use crate::images::{Images, Pixel};
use crate::math::Float;
use crate::prepare::Prepared;
use crate::scene::Scene;

/// An adaptive render and what it re-cast.
pub(crate) struct Adaptive {
    pub images: Images<f32>,
    /// Pixels cast again in f64 (the tests count them; renders report the fraction).
    #[cfg_attr(not(test), allow(dead_code))]
    pub recast: usize,
    /// Whether the re-cast ran on the GPU (else on the CPU).
    pub recast_on_gpu: bool,
    /// GPU kernel time in seconds of the certainty pass plus the re-cast pass (timestamp
    /// queries), from [`render_adaptive_timed`] only; `None` from [`render_adaptive`], without
    /// `TIMESTAMP_QUERY`, or when pixels were re-cast on the CPU.
    pub kernel_s: Option<f64>,
}

impl Adaptive {
    /// Fraction of pixels re-cast in f64 ([`Images::recast_fraction`]).
    #[cfg(test)]
    pub(crate) fn recast_fraction(&self) -> f64 {
        self.images.recast_fraction.unwrap_or(0.0)
    }
}

/// The most uncertain pixels [`render_adaptive`] casts again on the CPU, where the GPU has
/// f64: the CPU reference casts that many in less time than compiling the GPU's f64 kernel
/// takes, and renders at 1920x1080 re-cast far fewer (docs/robustness.md, "Adaptive
/// precision").
pub(crate) const CPU_RECAST_PIXELS: usize = 1 << 16;

/// Whether `uncertain` pixels (or rays) are cast again on `gpu` rather than on the CPU: where
/// it has f64 and they are more than `cpu_recast_pixels`.
pub(crate) fn recasts_on_gpu(gpu: &Gpu, uncertain: usize, cpu_recast_pixels: usize) -> bool {
    gpu.has_f64() && uncertain > cpu_recast_pixels
}

/// Renders `scene` with adaptive precision on `gpu` (robust algorithm set).
#[cfg(test)]
pub(crate) fn render_adaptive(gpu: &Gpu, scene: &Scene) -> Result<Adaptive> {
    render_adaptive_with(gpu, scene, false, CPU_RECAST_PIXELS)
}

/// [`render_adaptive`], also measuring the kernels' GPU time ([`Adaptive::kernel_s`]).
#[cfg(test)]
pub(crate) fn render_adaptive_timed(gpu: &Gpu, scene: &Scene) -> Result<Adaptive> {
    render_adaptive_with(gpu, scene, true, CPU_RECAST_PIXELS)
}

/// The kernel of the first pass: robust f32, specialized for `scene` and its size
/// ([`Variant::for_rays`]), with the certainty test.
pub(crate) fn certainty_variant(gpu: &Gpu, scene: &Scene) -> Variant {
    Variant {
        certainty: true,
        ..gpu.scene_variant(scene, Float::F32, Algorithm::Robust)
    }
    .for_rays(scene.camera.pixel_count())
    .with_instances(scene)
}

/// The first pass alone: a robust f32 render of `scene` that also says, per pixel, whether its
/// hit/miss and id are certain; and the preparation it used.
#[cfg(test)]
pub(crate) fn certainty_pass(
    gpu: &Gpu,
    scene: &Scene,
    timed: bool,
) -> Result<(gpu::Rendered<f32>, Prepared<f32>)> {
    certainty_pass_as(gpu, scene, certainty_variant(gpu, scene), timed)
}

/// [`certainty_pass`] through `variant`, a [`certainty_variant`] of `scene` tuned otherwise.
#[cfg(test)]
pub(crate) fn certainty_pass_as(
    gpu: &Gpu,
    scene: &Scene,
    variant: Variant,
    timed: bool,
) -> Result<(gpu::Rendered<f32>, Prepared<f32>)> {
    let ran = super::Kernel::<f32>::prepare(scene, variant, timed, None)?.run(gpu)?;
    Ok((ran.rendered, ran.prepared))
}

/// [`render_adaptive`], measuring the kernels' time if `timed`, with at most
/// `cpu_recast_pixels` uncertain pixels cast again on the CPU (more go to the GPU where it has
/// f64).
#[cfg(test)]
pub(crate) fn render_adaptive_with(
    gpu: &Gpu,
    scene: &Scene,
    timed: bool,
    cpu_recast_pixels: usize,
) -> Result<Adaptive> {
    let (first, prepared) = certainty_pass(gpu, scene, timed)?;
    recast(gpu, scene, first, &prepared, timed, cpu_recast_pixels)
}

/// The second pass: the pixels the certainty pass `first` (of `scene`, through `prepared`)
/// left uncertain cast again in f64 and merged in.
pub(crate) fn recast(
    gpu: &Gpu,
    scene: &Scene,
    first: gpu::Rendered<f32>,
    prepared: &Prepared<f32>,
    timed: bool,
    cpu_recast_pixels: usize,
) -> Result<Adaptive> {
    let certain = first
        .certainty
        .expect("a certainty variant reports certainty");
    let uncertain: Vec<u32> = (0..certain.len() as u32)
        .filter(|&k| !certain[k as usize])
        .collect();
    let mut images = first.images;
    images.recast_fraction = Some(uncertain.len() as f64 / certain.len().max(1) as f64);
    let recast_on_gpu = recasts_on_gpu(gpu, uncertain.len(), cpu_recast_pixels);
    let first_s = first.stages.kernel_s;
    if uncertain.is_empty() {
        return Ok(Adaptive {
            images,
            recast: 0,
            recast_on_gpu,
            kernel_s: first_s,
        });
    }
    // The f64 pass walks the same BVH, its instances too where it names them.
    let exact = Prepared::<f64>::with_bvh(scene, Algorithm::Robust, prepared.bvh().cloned());
    let (pixels, kernel_s): (Vec<Pixel<f64>>, _) = if recast_on_gpu {
        let variant = Variant {
            instances: exact.walks_instances(),
            ..gpu.scene_variant(scene, Float::F64, Algorithm::Robust)
        };
        let job = Job::new(variant).pixels(&uncertain).timed(timed);
        let second = gpu::run(gpu, &exact, job)?;
        let pixels = (0..uncertain.len()).map(|k| second.images.pixel(k));
        let second_s = second.stages.kernel_s;
        (pixels.collect(), first_s.zip(second_s).map(|(a, b)| a + b))
    } else {
        (cpu::render_pixels(&exact, &uncertain), None)
    };
    for (k, pixel) in uncertain.iter().zip(pixels) {
        let k = *k as usize;
        images.id[k] = pixel.id;
        images.distance[k] = pixel.distance as f32;
        images.normal[k] = pixel.normal.map(|c| c as f32);
    }
    Ok(Adaptive {
        images,
        recast: uncertain.len(),
        recast_on_gpu,
        kernel_s,
    })
}
