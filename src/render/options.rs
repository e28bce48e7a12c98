//! The render entry of the public API: [`Gpu::render`] and [`Cpu::render`] take a scene and
//! [`RenderOptions`], the same for both devices, and return its [`AnyImages`].

use std::sync::Arc;

use super::{AnyImages, Begun, Device, Mode, Precision, Progress, Request};
use super::{adaptive, render_streamed, supersample};
use crate::algorithm::Algorithm;
use crate::cpu::margin::margins;
use crate::error::{Error, Result};
use crate::gpu::hooks::ShadeHook;
use crate::gpu::kernel::UserKernel;
use crate::gpu::shader::{self, Kinds, MAX_LANE_RAYS, Variant, chunks_for};
use crate::gpu::{self, Gpu};
use crate::images::Outputs;
use crate::prepare::Prepared;
use crate::prepare::bvh::Search;
use crate::scene::Scene;

/// The CPU reference: the kernel's search mirrored in Rust (`src/cpu/`), in f32 or f64, on all
/// cores. It needs no adapter and runs no shader but the course's ray tracer's mirror.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Cpu;

/// How to render: the same options for [`Gpu::render`] and [`Cpu::render`].
///
/// ```no_run
/// use raycast::{Gpu, Precision, RenderOptions, Scene};
/// let scene = Scene::load("scenes/course/bunny.json".as_ref())?;
/// let options = RenderOptions { precision: Some(Precision::F64), ..Default::default() };
/// let images = Gpu::new()?.render(&scene, &options)?;
/// # Ok::<(), raycast::Error>(())
/// ```
#[derive(Clone, Debug)]
pub struct RenderOptions {
    /// `None`: the default ([`Precision::default_for`]): on the GPU adaptive precision (f64's
    /// hits and ids at close to f32's cost) with the robust set and without a hook or a kernel,
    /// else f32; on the CPU f64.
    pub precision: Option<Precision>,
    /// The intersection formulas: robust (default) or the lecture's textbook ones.
    pub algorithm: Algorithm,
    /// The images wanted. The GPU's f32 and f64 kernels compute only these; adaptive
    /// precision and the CPU compute every one.
    pub outputs: Outputs,
    /// Samples per pixel, a perfect square, the images reduced to one pixel each with their
    /// [`crate::images::Coverage`]; `None`: one ray through each pixel's centre, no coverage.
    pub samples_per_pixel: Option<u32>,
    /// A shade hook colouring [`crate::Images::color`] (with `outputs.color`): any hook on the
    /// GPU in f32 or f64; on the CPU only the course's ray tracer
    /// ([`ShadeHook::raytrace`]), by its mirror.
    pub shade: Option<ShadeHook>,
    /// A complete kernel run instead of the assembled one (GPU, f32 or f64).
    pub kernel: Option<UserKernel>,
    /// Measure the GPU kernel's time ([`crate::Images::kernel_s`]) where the device has
    /// timestamp queries (above one sample per pixel, the time of the samples' render).
    pub timed: bool,
    /// Overrides of the choices raycast makes for the scene (f32 and f64; refused with adaptive
    /// precision).
    pub tuning: Tuning,
    /// Where a CPU render counts its rows as it finishes them, for a caller's progress display.
    pub progress: Option<Arc<Progress>>,
}

/// Overrides of the choices raycast makes for each scene, to measure what each one brings
/// (`raycast bench`, `raycast specializations`). The default leaves every choice to raycast.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Tuning {
    /// Spheres and triangles searched through a BVH or by brute force (GPU and CPU).
    pub search: Search,
    /// GPU: a subgroup's rays traverse the BVH together, sharing node fetches (`Some(true)`,
    /// refused on devices without subgroups of 8 or more invocations), or each ray alone
    /// (`Some(false)`); `None`: the device's choice.
    pub packets: Option<bool>,
    /// GPU: the kernel carries code for every primitive kind, not only the scene's.
    pub all_kinds: bool,
    /// GPU: each lane casts its most rays (8) whatever the render's size, as a kernel run many
    /// times should; by default a small render casts fewer, so that its kernel compiles sooner.
    pub most_lane_rays: bool,
    /// GPU: at most this many spheres and triangles (a power of two) in each storage binding,
    /// as on a device with smaller bindings; `None`: as many as this device's bindings hold.
    pub triangles_per_binding: Option<u32>,
    /// GPU: at most this many image rows per dispatch, as for an image too large for one;
    /// `None`: as many as the device's limits allow.
    pub tile_rows: Option<u32>,
}

impl Tuning {
    /// `variant`, the kernel raycast specializes for `scene` (`rays` rays), with these overrides.
    pub(crate) fn apply(self, variant: Variant, scene: &Scene, gpu: &Gpu) -> Result<Variant> {
        let mut variant = match self.most_lane_rays {
            true => Variant {
                lane_rays_limit: MAX_LANE_RAYS,
                ..variant
            },
            false => variant.for_rays(scene.camera.pixel_count()),
        };
        variant.bvh = self.search.uses_bvh(scene);
        if self.all_kinds {
            variant = variant.with_kinds(Kinds::ALL);
        }
        if let Some(n) = self.triangles_per_binding {
            let most = 1u32 << variant.chunk_bits;
            if !n.is_power_of_two() || n > most {
                return Err(Error::Argument {
                    option: format!("triangles_per_binding {n}"),
                    message: format!(
                        "a power of two up to {most}, what this device's bindings hold"
                    ),
                });
            }
            let bits = n.ilog2() as u8;
            variant = Variant {
                chunks: chunks_for(scene, bits),
                chunk_bits: bits,
                ..variant
            };
        }
        match self.packets {
            Some(true) if !gpu.has_packet_subgroups() => Err(Error::Argument {
                option: "packets".into(),
                message: "need subgroups of at least 8 invocations, which this device lacks".into(),
            }),
            Some(packets) => Ok(Variant { packets, ..variant }),
            None => Ok(variant),
        }
    }
}

impl Default for RenderOptions {
    /// The device's precision, the robust set, every output, one sample per pixel, no hook.
    fn default() -> Self {
        RenderOptions {
            precision: None,
            algorithm: Algorithm::Robust,
            outputs: Outputs::ALL,
            samples_per_pixel: None,
            shade: None,
            kernel: None,
            timed: false,
            tuning: Tuning::default(),
            progress: None,
        }
    }
}

impl RenderOptions {
    /// The mode these options render in on `device`: their precision, else the default
    /// ([`Precision::default_for`]; a shade hook or a kernel needs a single kernel).
    pub(crate) fn mode(&self, device: Device) -> Mode {
        let single_kernel = self.shade.is_some() || self.kernel.is_some();
        Mode {
            device,
            precision: (self.precision)
                .unwrap_or_else(|| Precision::default_for(device, self.algorithm, single_kernel)),
            algorithm: self.algorithm,
        }
    }

    /// Refuses what these options ask of `device` that it cannot do, before any render: samples
    /// per pixel that are not a perfect square, a kernel or a shade hook other than on the GPU
    /// in f32 or f64 (the CPU runs the course's ray tracer's mirror), tuning with adaptive
    /// precision; and, given the image's `size`, images held whole whose samples need more
    /// memory than this process may use (docs/cli.md#limits; a render in bands holds a band
    /// and is not asked for it).
    pub fn check(&self, device: Device, size: Option<[u32; 2]>) -> Result<()> {
        if let Some(spp) = self.samples_per_pixel {
            supersample::side(spp).map_err(|message| Error::Argument {
                option: "samples_per_pixel".into(),
                message,
            })?;
        }
        let mode = self.mode(device);
        super::check_request(mode, &self.request())?;
        match size {
            Some(size) => super::memory::check_whole_render(
                size,
                self.samples_per_pixel.unwrap_or(1),
                mode.precision,
                self.shade.is_some(),
                self.samples_per_pixel.is_none() && self.kernel.is_none(),
            ),
            None => Ok(()),
        }
    }

    pub(crate) fn request(&self) -> Request {
        Request {
            outputs: self.outputs,
            shade: self.shade.clone(),
            kernel: self.kernel.clone(),
            tuning: self.tuning,
        }
    }

    fn render(&self, scene: &Scene, mode: Mode, gpu: Option<&Gpu>) -> Result<AnyImages> {
        let request = self.request();
        let progress = self.progress.as_deref();
        match self.samples_per_pixel {
            None => {
                let start = super::begin(scene, mode, gpu, progress, &request, self.timed)?;
                start.complete(gpu, scene).map(super::Outcome::timed_images)
            }
            Some(spp) => supersample::supersample_request(
                scene, mode, gpu, spp, progress, &request, self.timed,
            ),
        }
    }
}

impl Gpu {
    /// Renders `scene`'s camera on this GPU.
    ///
    /// ```no_run
    /// use raycast::{Gpu, RenderOptions, Scene};
    /// let scene = Scene::load("scenes/course/bunny.json".as_ref())?;
    /// let images = Gpu::new()?.render(&scene, &RenderOptions::default())?;
    /// println!("{} pixels hit", images.id().iter().filter(|&&id| id >= 0).count());
    /// # Ok::<(), raycast::Error>(())
    /// ```
    pub fn render(&self, scene: &Scene, options: &RenderOptions) -> Result<AnyImages> {
        self.begin(scene, options)?.finish(self, scene)
    }

    /// Begins the render of `scene`'s camera on this GPU ([`Gpu::render`] in steps): every
    /// check made, the kernel chosen and the scene prepared for it, the kernel still to run
    /// (a supersampled render is done whole here).
    ///
    /// ```no_run
    /// use raycast::{Gpu, RenderOptions, Scene};
    /// let (gpu, options) = (Gpu::new()?, RenderOptions::default());
    /// let scene = Scene::load("scenes/course/bunny.json".as_ref())?;
    /// let begun = gpu.begin(&scene, &options)?;
    /// let ran = std::thread::scope(|s| s.spawn(|| begun.run(&gpu)).join().unwrap())?;
    /// let images = ran.finish(&gpu, &scene)?;
    /// # Ok::<(), raycast::Error>(())
    /// ```
    pub fn begin(&self, scene: &Scene, options: &RenderOptions) -> Result<Begun> {
        let mode = options.mode(Device::Gpu);
        let (request, progress) = (options.request(), options.progress.as_deref());
        let timed = options.timed;
        match options.samples_per_pixel {
            None => super::begin(scene, mode, Some(self), progress, &request, timed).map(Begun::of),
            Some(spp) => {
                let gpu = Some(self);
                supersample::supersample_request(scene, mode, gpu, spp, progress, &request, timed)
                    .map(Begun::done)
            }
        }
    }

    /// The kernel a render of `scene` with `options` runs first (adaptive precision's f32
    /// certainty pass, which writes every output), as the WGSL source `kernel` takes back; a
    /// `kernel` whose bindings do not fit is refused.
    pub fn kernel_source(&self, scene: &Scene, options: &RenderOptions) -> Result<String> {
        let mode = options.mode(Device::Gpu);
        let variant = match mode.precision {
            Precision::Adaptive => adaptive::certainty_variant(self, scene),
            _ => {
                let spp = options.samples_per_pixel.unwrap_or(1);
                let request = supersample::sample_request(&options.request(), spp);
                let variant = request.kernel_variant(self, scene, mode)?;
                // Sized for the samples the render casts, as the render of the samples' scene is.
                variant.for_rays(scene.camera.pixel_count() * u64::from(spp))
            }
        };
        // A user's kernel is its own text, whatever the scene.
        let ran = match variant.kernel {
            Some(_) => variant,
            None => gpu::dispatch::as_run(scene, variant),
        };
        shader::kernel_source(&ran)
    }

    /// Renders `scene`'s camera in bands of at most `rows` rows, handing each band to `band`
    /// from the top as soon as it is read back, so that one band is held at a time: for
    /// images larger than memory. GPU, f32 or f64, one sample per pixel. Returns the rays the
    /// shade hook cast, where it casts any.
    ///
    /// ```no_run
    /// use raycast::{Gpu, RenderOptions, Scene};
    /// let scene = Scene::load("scenes/course/bunny.json".as_ref())?;
    /// let mut hits = 0;
    /// Gpu::new()?.render_bands(&scene, &RenderOptions::default(), 64, &mut |band| {
    ///     hits += band.id().iter().filter(|&&id| id >= 0).count();
    ///     Ok(())
    /// })?;
    /// # Ok::<(), raycast::Error>(())
    /// ```
    pub fn render_bands(
        &self,
        scene: &Scene,
        options: &RenderOptions,
        rows: u32,
        band: &mut dyn FnMut(AnyImages) -> Result<()>,
    ) -> Result<Option<u64>> {
        let mut mode = options.mode(Device::Gpu);
        if options.precision.is_none() {
            mode.precision = Precision::F32;
        }
        render_streamed(scene, mode, self, &options.request(), rows.max(1), band)
    }
}

impl Cpu {
    /// Which of each pixel's decisions in a render of `scene` in f32 with the robust
    /// algorithms are certain, row-major: `[hit, id]`, whether it hits anything and which
    /// object is nearest lie far enough from where f32 rounding could decide otherwise
    /// (src/cpu/margin.rs) that an f32 render must decide them as exact arithmetic does.
    ///
    /// ```
    /// use raycast::{Cpu, Scene};
    /// let mut scene = Scene::load("scenes/course/sphere-and-plane.json".as_ref())?;
    /// scene.camera.resolution = [32, 18];
    /// let certain = Cpu.certain_in_f32(&scene);
    /// let both = certain.iter().filter(|[hit, id]| *hit && *id).count();
    /// assert!(both > certain.len() / 2, "{both} of {} pixels certain", certain.len());
    /// # Ok::<(), raycast::Error>(())
    /// ```
    pub fn certain_in_f32(&self, scene: &Scene) -> Vec<[bool; 2]> {
        let prepared = Prepared::<f64>::new(scene, Algorithm::Robust, Search::BruteForce);
        let margins = margins(&prepared.frame, &prepared.primitives, f32::EPSILON as f64);
        margins
            .iter()
            .map(|m| [m.hit >= 1.0, m.certain()])
            .collect()
    }

    /// Renders `scene`'s camera by the CPU reference.
    ///
    /// ```
    /// use raycast::{Cpu, RenderOptions, Scene};
    /// let mut scene = Scene::load("scenes/course/sphere-and-plane.json".as_ref())?;
    /// scene.camera.resolution = [64, 36];
    /// let images = Cpu.render(&scene, &RenderOptions::default())?;
    /// assert_eq!(images.id()[18 * 64 + 32], 0); // the centre pixel sees the sphere
    /// # Ok::<(), raycast::Error>(())
    /// ```
    pub fn render(&self, scene: &Scene, options: &RenderOptions) -> Result<AnyImages> {
        options.render(scene, options.mode(Device::Cpu), None)
    }
}
