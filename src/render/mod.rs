//! One entry point for every way of rendering, in every [`Mode`] ([`render`]): whole, in steps
//! ([`Begun`]) or in bands ([`render_streamed`]).

pub(crate) mod adaptive;
pub(crate) mod memory;
pub(crate) mod options;
pub(crate) mod supersample;
pub(crate) mod viewer;

pub(crate) use crate::mode::{Device, Mode, Precision};
pub(crate) use options::{Cpu, Tuning};

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU32, Ordering};
#[cfg(test)]
use std::time::Duration;
use std::time::Instant;

use crate::algorithm::Algorithm;
use crate::cpu;
use crate::error::{Error, Result};
use crate::gpu::hooks::ShadeHook;
use crate::gpu::kernel::UserKernel;
use crate::gpu::shader::Variant;
use crate::gpu::{self, Gpu, Job};
#[cfg(test)]
use crate::images::Coverage;
use crate::images::{Images, Outputs, Stages};
use crate::kernel::layout::{GpuReal, GpuTriangle};
use crate::math::Float;
use crate::output::{self, Encoding};
use crate::prepare::bvh::{Bvh, Search};
use crate::prepare::{Prepared, Primitives};
use crate::scene::{Camera, Scene};

/// Images in whichever precision they were rendered in.
#[derive(Clone, Debug, PartialEq)]
pub enum AnyImages {
    /// From f32 and adaptive renders.
    F32(Images<f32>),
    /// From f64 renders.
    F64(Images<f64>),
}

impl AnyImages {
    /// The files of the images, a render of `camera`, encoded as `encoding` asks, in memory:
    /// their names and bytes, for [`raycast_files::write_files`].
    pub fn encode(&self, encoding: &Encoding, camera: &Camera) -> Vec<output::EncodedFile> {
        match self {
            AnyImages::F32(i) => output::encode(i, encoding, camera),
            AnyImages::F64(i) => output::encode(i, encoding, camera),
        }
    }

    /// Images of `s x s` samples per pixel reduced to one pixel each, with their coverage
    /// ([`supersample::reduce`]).
    pub(crate) fn reduce(&self, s: u32) -> AnyImages {
        match self {
            AnyImages::F32(i) => AnyImages::F32(supersample::reduce(i, s)),
            AnyImages::F64(i) => AnyImages::F64(supersample::reduce(i, s)),
        }
    }

    /// The course's id, depth and normal pictures of these images.
    pub fn pictures(&self) -> output::Pictures {
        match self {
            AnyImages::F32(i) => output::pictures(i),
            AnyImages::F64(i) => output::pictures(i),
        }
    }

    /// The per-pixel object ids.
    pub fn id(&self) -> &[i32] {
        match self {
            AnyImages::F32(i) => &i.id,
            AnyImages::F64(i) => &i.id,
        }
    }

    /// The shade hook's colours, where one ran.
    pub fn color(&self) -> Option<&[[u8; 4]]> {
        match self {
            AnyImages::F32(i) => i.color.as_deref(),
            AnyImages::F64(i) => i.color.as_deref(),
        }
    }

    /// The rays the shade hook cast beyond the camera's, when it cast any.
    pub fn hook_rays(&self) -> Option<u64> {
        match self {
            AnyImages::F32(i) => i.hook_rays,
            AnyImages::F64(i) => i.hook_rays,
        }
    }

    /// The coverage of supersampled images.
    #[cfg(test)]
    pub(crate) fn coverage(&self) -> Option<&Coverage> {
        match self {
            AnyImages::F32(i) => i.coverage.as_ref(),
            AnyImages::F64(i) => i.coverage.as_ref(),
        }
    }

    /// Wall-clock seconds of the render's stages, and what its geometry held
    /// ([`Images::stages`]).
    pub fn stages(&self) -> Option<&Stages> {
        match self {
            AnyImages::F32(i) => i.stages.as_ref(),
            AnyImages::F64(i) => i.stages.as_ref(),
        }
    }

    /// The GPU kernel's time in seconds, where the render was timed and the device can tell.
    pub fn kernel_s(&self) -> Option<f64> {
        match self {
            AnyImages::F32(i) => i.kernel_s,
            AnyImages::F64(i) => i.kernel_s,
        }
    }

    pub(crate) fn set_kernel_s(&mut self, kernel_s: Option<f64>) {
        match self {
            AnyImages::F32(i) => i.kernel_s = kernel_s,
            AnyImages::F64(i) => i.kernel_s = kernel_s,
        }
    }
}

impl Encoding {
    /// Writes the files of a render of `camera` into `dir` in bands of rows, as `render` hands
    /// them to the sink it is given, from the top (a [`Gpu::render_bands`] call, say), holding
    /// one band at a time; returns the files, placed all or none, and what `render` returned.
    /// Formats written whole ([`crate::Format::whole_only`]) are not.
    pub fn write_bands<T>(
        &self,
        dir: &Path,
        camera: &Camera,
        render: impl FnOnce(&mut dyn FnMut(AnyImages) -> Result<()>) -> Result<T>,
    ) -> Result<(Vec<PathBuf>, T)> {
        let mut writer = output::stream::BandWriter::new(dir, self, camera)?;
        let value = render(&mut |band| match band {
            AnyImages::F32(i) => writer.write_band(&i),
            AnyImages::F64(i) => writer.write_band(&i),
        })?;
        Ok((writer.finish()?, value))
    }
}

/// What a render is asked to produce beyond its [`Mode`].
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Request {
    /// The outputs wanted. The GPU kernels (f32, f64) compute and read back only these (and
    /// the ids when the palette `color.png` is wanted); adaptive precision and the CPU
    /// reference compute every output.
    pub outputs: Outputs,
    /// The user's shade hook, which colours `color.png` when `outputs.color` (GPU, f32 or f64
    /// only; any other mode is an [`Error::Argument`] naming `shade`).
    pub shade: Option<ShadeHook>,
    /// A complete kernel to run instead of the assembled one (GPU, f32 or f64 only; any
    /// other mode is an [`Error::Argument`] naming `kernel`). It must declare the bindings
    /// of the kernel this request would assemble ([`UserKernel::for_variant`]).
    pub kernel: Option<UserKernel>,
    /// Overrides of the kernel's specialization (GPU and CPU, f32 or f64 only; with adaptive
    /// precision an [`Error::Argument`] naming `tuning`).
    pub tuning: Tuning,
}

impl Default for Request {
    /// Every output, no hook, the assembled kernel as raycast specializes it.
    fn default() -> Self {
        Request {
            outputs: Outputs::ALL,
            shade: None,
            kernel: None,
            tuning: Tuning::default(),
        }
    }
}

impl Request {
    /// The kernel a GPU render of `scene` in `mode` (f32 or f64) runs for this request:
    /// specialized for the scene, its size ([`gpu::shader::Variant::for_rays`]) and the
    /// outputs, with the hook, and the user's kernel in its place where one is given (an error
    /// if its bindings do not fit).
    pub(crate) fn kernel_variant(
        &self,
        gpu: &Gpu,
        scene: &Scene,
        mode: Mode,
    ) -> Result<gpu::shader::Variant> {
        let precision = match mode.precision {
            Precision::F64 => Float::F64,
            _ => Float::F32,
        };
        let variant = gpu.scene_variant(scene, precision, mode.algorithm);
        let mut variant = self.tuning.apply(variant, scene, gpu)?;
        if let Some(hook) = &self.shade {
            variant = variant.with_shade(hook.key, hook.traces);
        }
        let variant = variant
            .with_outputs(self.kernel_outputs())
            .with_instances(scene);
        match &self.kernel {
            Some(kernel) => kernel.for_variant(variant),
            None => Ok(variant),
        }
    }

    /// The outputs the GPU kernel must write for this request: with a hook, the colour is the
    /// kernel's; without, the palette `color.png` is made on the host from the ids.
    pub(crate) fn kernel_outputs(&self) -> Outputs {
        let o = self.outputs;
        let hooked = self.shade.is_some();
        Outputs {
            id: o.id || (o.color && !hooked),
            color: o.color && hooked,
            ..o
        }
    }
}

/// How far a CPU render has got, for a caller's progress display
/// ([`crate::RenderOptions::progress`]); a GPU render leaves both counts at zero.
#[derive(Debug, Default)]
pub struct Progress {
    /// The rows the render has.
    pub rows: AtomicU32,
    /// The rows it has finished.
    pub rows_done: AtomicU32,
}

/// Renders `scene` in `mode`. `gpu` is needed for [`Device::Gpu`]; a CPU render counts its
/// rows in `progress`.
#[cfg(test)]
pub(crate) fn render(
    scene: &Scene,
    mode: Mode,
    gpu: Option<&Gpu>,
    progress: Option<&Progress>,
) -> Result<AnyImages> {
    render_request(scene, mode, gpu, progress, &Request::default())
}

/// [`render`] producing what `request` asks for.
#[cfg(test)]
pub(crate) fn render_request(
    scene: &Scene,
    mode: Mode,
    gpu: Option<&Gpu>,
    progress: Option<&Progress>,
    request: &Request,
) -> Result<AnyImages> {
    dispatch(scene, mode, gpu, progress, request, false).map(|(images, _)| images)
}

/// [`render`] (without progress), also returning the GPU kernel time in seconds for a GPU
/// mode on a device with timestamp queries (the sum over tiles, and for adaptive precision
/// over its certainty and re-cast passes; see [`gpu::Job::timed`]); `None` for the CPU.
#[cfg(test)]
pub(crate) fn render_timed(
    scene: &Scene,
    mode: Mode,
    gpu: Option<&Gpu>,
) -> Result<(AnyImages, Option<f64>)> {
    dispatch(scene, mode, gpu, None, &Request::default(), true)
}

/// The mode dispatch of [`render_request`] and [`render_timed`]: the images, and with `timed`
/// the GPU kernel time where the device can measure it.
fn dispatch(
    scene: &Scene,
    mode: Mode,
    gpu: Option<&Gpu>,
    progress: Option<&Progress>,
    request: &Request,
    timed: bool,
) -> Result<(AnyImages, Option<f64>)> {
    let start = begin(scene, mode, gpu, progress, request, timed)?;
    start.complete(gpu, scene).map(|o| (o.images, o.kernel_s))
}

/// A render of one scene and camera, whole: its images, and the GPU kernel's time where it was
/// timed and the device can tell.
pub(crate) struct Outcome {
    pub images: AnyImages,
    pub kernel_s: Option<f64>,
}

impl Outcome {
    fn of(images: AnyImages) -> Outcome {
        Outcome {
            images,
            kernel_s: None,
        }
    }

    /// The images, with the kernel's time.
    pub(crate) fn timed_images(self) -> AnyImages {
        let mut images = self.images;
        images.set_kernel_s(self.kernel_s);
        images
    }
}

/// A render [`begin`] started: done on the host, or prepared for the device, whose kernel is
/// still to run.
pub(crate) enum Start {
    Done(Outcome),
    Device(OnDevice),
}

impl Start {
    /// The render whole: the device's part run, and finished with `scene`, the scene `begin`
    /// prepared (the same camera).
    pub(crate) fn complete(self, gpu: Option<&Gpu>, scene: &Scene) -> Result<Outcome> {
        match self {
            Start::Done(outcome) => Ok(outcome),
            Start::Device(work) => {
                let gpu = device(gpu)?;
                work.run(gpu)?.finish(gpu, scene)
            }
        }
    }
}

/// A render on the GPU in steps ([`Gpu::begin`]): prepared on the host, its kernel run on the
/// device ([`Begun::run`], on any thread), then finished on the host ([`Begun::finish`]), so
/// that a caller prepares the next render while the device runs this one's kernel.
pub struct Begun(Step);

/// Where a [`Begun`] render stands.
enum Step {
    /// Rendered whole already (a supersampled render).
    Done(AnyImages),
    OnDevice(OnDevice),
    OnHost(Box<OnHost>),
}

impl Begun {
    /// A render started by [`begin`] on the GPU.
    pub(crate) fn of(start: Start) -> Begun {
        Begun(match start {
            Start::Done(outcome) => Step::Done(outcome.timed_images()),
            Start::Device(work) => Step::OnDevice(work),
        })
    }

    /// A render done whole already.
    pub(crate) fn done(images: AnyImages) -> Begun {
        Begun(Step::Done(images))
    }

    /// Runs the kernel and reads its outputs back (nothing where that is done).
    pub fn run(self, gpu: &Gpu) -> Result<Begun> {
        Ok(Begun(match self.0 {
            Step::OnDevice(work) => Step::OnHost(Box::new(work.run(gpu)?)),
            step => step,
        }))
    }

    /// The images: the kernel run where it has not been, then the render finished with
    /// `scene`, the scene [`Gpu::begin`] was given (adaptive precision casts its uncertain
    /// pixels again from it).
    pub fn finish(self, gpu: &Gpu, scene: &Scene) -> Result<AnyImages> {
        let ran = match self.0 {
            Step::Done(images) => return Ok(images),
            Step::OnDevice(work) => work.run(gpu)?,
            Step::OnHost(ran) => *ran,
        };
        ran.finish(gpu, scene).map(Outcome::timed_images)
    }
}

/// Starts the render of `scene` in `mode` that [`render_request`] makes: a CPU render whole,
/// a GPU render as far as the device (every check, the kernel chosen, the scene prepared for
/// it), so that a caller can run the device's part on another thread while it prepares the
/// next render ([`OnDevice`]).
pub(crate) fn begin(
    scene: &Scene,
    mode: Mode,
    gpu: Option<&Gpu>,
    progress: Option<&Progress>,
    request: &Request,
    timed: bool,
) -> Result<Start> {
    check_request(mode, request)?;
    let shaded = request.shade.is_some() && request.outputs.color;
    let bands = request.kernel.is_none();
    memory::check_whole_render(scene.camera.resolution, 1, mode.precision, shaded, bands)?;
    if mode.precision == Precision::Adaptive {
        let gpu = match (mode.device, mode.algorithm, gpu) {
            (Device::Gpu, Algorithm::Robust, Some(gpu)) => gpu,
            _ => {
                return Err(Error::Argument {
                    option: "precision adaptive".into(),
                    message: "runs on the GPU with the robust algorithm set".into(),
                });
            }
        };
        let variant = adaptive::certainty_variant(gpu, scene);
        let pass = Kernel::prepare(scene, variant, timed, None)?;
        return Ok(Start::Device(OnDevice::Adaptive(pass)));
    }
    match mode.device {
        Device::Gpu => {
            let gpu = device(gpu)?;
            let variant = request.kernel_variant(gpu, scene, mode)?;
            let rows = request.tuning.tile_rows;
            Ok(Start::Device(match mode.precision {
                Precision::F32 => OnDevice::F32(Kernel::prepare(scene, variant, timed, rows)?),
                _ => OnDevice::F64(Kernel::prepare(scene, variant, timed, rows)?),
            }))
        }
        Device::Cpu => {
            let lit = request.shade.is_some() && request.outputs.color;
            let search = request.tuning.search;
            let algorithm = mode.algorithm;
            let images = match mode.precision {
                Precision::F32 => {
                    AnyImages::F32(cpu_render(scene, algorithm, search, progress, lit, timed))
                }
                _ => AnyImages::F64(cpu_render(scene, algorithm, search, progress, lit, timed)),
            };
            Ok(Start::Done(Outcome::of(images)))
        }
    }
}

/// `gpu`, which a GPU render needs.
pub(crate) fn device(gpu: Option<&Gpu>) -> Result<&Gpu> {
    gpu.ok_or_else(|| Error::Device("a GPU render needs a device".into()))
}

/// A GPU render prepared on the host ([`begin`]): the scene laid out for its kernel, measured
/// from the camera. It holds nothing of the scene, so its kernel can run on another thread
/// ([`OnDevice::run`]) while the host prepares the next render.
pub(crate) enum OnDevice {
    F32(Kernel<f32>),
    F64(Kernel<f64>),
    /// Adaptive precision's certainty pass, whose uncertain pixels [`OnHost::finish`] casts
    /// again.
    Adaptive(Kernel<f32>),
}

impl OnDevice {
    /// Runs the kernel and reads its outputs back.
    pub(crate) fn run(self, gpu: &Gpu) -> Result<OnHost> {
        Ok(match self {
            OnDevice::F32(k) => OnHost::F32(k.run(gpu)?),
            OnDevice::F64(k) => OnHost::F64(k.run(gpu)?),
            OnDevice::Adaptive(k) => OnHost::Adaptive(k.run(gpu)?),
        })
    }
}

/// A GPU render whose kernel has run ([`OnDevice::run`]), to be finished on the host.
pub(crate) enum OnHost {
    F32(Ran<f32>),
    F64(Ran<f64>),
    Adaptive(Ran<f32>),
}

impl OnHost {
    /// The render's outcome; adaptive precision casts its uncertain pixels again here, which
    /// needs `scene`, the scene the render was prepared from (the same camera).
    pub(crate) fn finish(self, gpu: &Gpu, scene: &Scene) -> Result<Outcome> {
        fn timed<R: GpuReal>(ran: Ran<R>, wrap: fn(Images<R>) -> AnyImages) -> Outcome {
            let timed = ran.timed;
            let (mut images, stages) = ran.laid_out();
            images.stages = timed.then_some(stages);
            Outcome {
                kernel_s: stages.kernel_s,
                ..Outcome::of(wrap(images))
            }
        }
        Ok(match self {
            OnHost::F32(ran) => timed(ran, AnyImages::F32),
            OnHost::F64(ran) => timed(ran, AnyImages::F64),
            OnHost::Adaptive(ran) => {
                let (first, prepared, timed) = (ran.rendered, ran.prepared, ran.timed);
                let cpu_recast = adaptive::CPU_RECAST_PIXELS;
                let a = adaptive::recast(gpu, scene, first, &prepared, timed, cpu_recast)?;
                let images = Images {
                    recast_on_gpu: a.recast_on_gpu,
                    ..a.images
                };
                Outcome {
                    kernel_s: a.kernel_s,
                    ..Outcome::of(AnyImages::F32(images))
                }
            }
        })
    }
}

/// One kernel's job on a prepared scene: the scene prepared for `variant` on the host, run on
/// the device in tiles of at most `rows` rows, timing the kernel if `timed`.
pub(crate) struct Kernel<R> {
    prepared: Prepared<R>,
    variant: Variant,
    timed: bool,
    rows: Option<u32>,
}

/// What a [`Kernel`] rendered, with the preparation it ran on.
pub(crate) struct Ran<R> {
    pub rendered: gpu::Rendered<R>,
    pub prepared: Prepared<R>,
    timed: bool,
}

impl<R: GpuReal> Kernel<R> {
    /// `scene` prepared for `variant` ([`gpu::prepare`]).
    pub(crate) fn prepare(
        scene: &Scene,
        variant: Variant,
        timed: bool,
        rows: Option<u32>,
    ) -> Result<Kernel<R>> {
        Ok(Kernel {
            prepared: gpu::prepare::<R>(scene, &variant)?,
            variant,
            timed,
            rows,
        })
    }

    pub(crate) fn run(self, gpu: &Gpu) -> Result<Ran<R>> {
        let mut job = Job::new(self.variant).timed(self.timed);
        if let Some(rows) = self.rows {
            job = job.rows(rows);
        }
        Ok(Ran {
            rendered: gpu::run(gpu, &self.prepared, job)?,
            prepared: self.prepared,
            timed: self.timed,
        })
    }
}

impl<R: GpuReal> Ran<R> {
    /// The images, and the stages with the layout of the geometry ([`with_layout`]).
    fn laid_out(self) -> (Images<R>, Stages) {
        let triangle_bytes = size_of::<GpuTriangle<R>>();
        let stages = with_layout(
            self.rendered.stages,
            &self.prepared.primitives,
            triangle_bytes,
        );
        (self.rendered.images, stages)
    }
}

/// Refuses what `request` asks of a `mode` that cannot do it: a shade hook that colours
/// `color.png` or a kernel file, other than on the GPU in f32 or f64.
pub(crate) fn check_request(mode: Mode, request: &Request) -> Result<()> {
    let shades = request.shade.as_ref().filter(|_| request.outputs.color);
    // The CPU runs the course's ray tracer by its mirror, and no other hook.
    let mirrored = mode.device == Device::Cpu
        && mode.precision != Precision::Adaptive
        && shades.is_some_and(ShadeHook::has_cpu_mirror);
    check_kernels(
        mode,
        request.kernel.is_some(),
        shades.is_some() && !mirrored,
    )?;
    if mode.precision == Precision::Adaptive && request.tuning != Tuning::default() {
        return Err(Error::Argument {
            option: "tuning".into(),
            message: "applies to `precision` f32 or f64 (adaptive precision runs two kernels)"
                .into(),
        });
    }
    Ok(())
}

/// [`check_request`] for a request with a kernel file and a colouring shade hook or not.
fn check_kernels(mode: Mode, kernel: bool, shade: bool) -> Result<()> {
    let refuse = |option: &str| {
        let message = if mode.device == Device::Cpu {
            "the CPU reference runs no shader but the course's ray tracer (`ShadeHook::raytrace`); use `Gpu`"
        } else if option == "kernel" {
            "runs with `precision` f32 or f64 (adaptive precision runs two kernels)"
        } else {
            "runs with `precision` f32 or f64, not adaptive"
        };
        Err(Error::Argument {
            option: option.into(),
            message: message.into(),
        })
    };
    let kernels = mode.device == Device::Gpu && mode.precision != Precision::Adaptive;
    if kernel && !kernels {
        return refuse("kernel");
    }
    if shade && !kernels {
        return refuse("shade");
    }
    Ok(())
}

/// Renders `scene` with the kernel `variant` (prepared for it) in tiles of at most `rows` rows,
/// timing the stages and, with `timed`, the kernel.
#[cfg(test)]
pub(crate) fn on_gpu<R: GpuReal>(
    gpu: &Gpu,
    scene: &Scene,
    variant: Variant,
    timed: bool,
    rows: Option<u32>,
) -> Result<(Images<R>, Stages)> {
    Ok(Kernel::prepare(scene, variant, timed, rows)?
        .run(gpu)?
        .laid_out())
}

/// `stages` with the layout of `primitives` ([`Stages::bvh_nodes`],
/// [`Stages::bytes_per_triangle`]), each triangle taking `triangle_bytes`.
fn with_layout<T>(stages: Stages, primitives: &Primitives<T>, triangle_bytes: usize) -> Stages {
    let p = primitives;
    let bvh = p
        .bvh
        .as_deref()
        .filter(|_| p.spheres.len() + p.triangles.len() > 0);
    Stages {
        bvh_nodes: bvh.map(|b| b.nodes.len()),
        bytes_per_triangle: p.bytes_per_triangle(triangle_bytes, bvh.map_or(0, Bvh::bytes)),
        ..stages
    }
}

/// Whether [`render_streamed`] can render `mode`: a GPU kernel in f32 or f64.
pub(crate) fn can_stream(mode: Mode) -> bool {
    mode.device == Device::Gpu && mode.precision != Precision::Adaptive
}

/// Renders `scene` on the GPU in bands of at most `max_rows` rows, handing each band to
/// `sink` from the top as soon as it is read back (see [`gpu::Job::sink`]). Only for
/// modes where [`can_stream`] holds. Returns the rays the shade hook cast, where it casts any.
pub(crate) fn render_streamed(
    scene: &Scene,
    mode: Mode,
    gpu: &Gpu,
    request: &Request,
    max_rows: u32,
    sink: &mut dyn FnMut(AnyImages) -> Result<()>,
) -> Result<Option<u64>> {
    if !can_stream(mode) {
        return Err(Error::Argument {
            option: "mode".into(),
            message: format!("{mode} cannot be rendered in bands (GPU f32 or f64 only)"),
        });
    }
    let variant = request.kernel_variant(gpu, scene, mode)?;
    fn bands<R: GpuReal>(
        gpu: &Gpu,
        scene: &Scene,
        variant: Variant,
        max_rows: u32,
        sink: &mut dyn FnMut(Images<R>) -> Result<()>,
    ) -> Result<Option<u64>> {
        let prepared = gpu::prepare::<R>(scene, &variant)?;
        let mut each = |_, band| sink(band);
        let job = Job::new(variant).rows(max_rows).timed(true).sink(&mut each);
        gpu::run(gpu, &prepared, job).map(|r| r.stages.hook_rays)
    }
    match mode.precision {
        Precision::F32 => bands::<f32>(gpu, scene, variant, max_rows, &mut |b| {
            sink(AnyImages::F32(b))
        }),
        _ => bands::<f64>(gpu, scene, variant, max_rows, &mut |b| {
            sink(AnyImages::F64(b))
        }),
    }
}

/// The CPU reference's render, and with `lit` its colours by the mirror of the course's ray
/// tracer ([`cpu::raytrace`], the only hook the CPU runs: [`check_request`]); with `timed`
/// its [`Stages`].
fn cpu_render<T: crate::math::Real>(
    scene: &Scene,
    algorithm: Algorithm,
    search: Search,
    progress: Option<&Progress>,
    lit: bool,
    timed: bool,
) -> Images<T> {
    // The CPU traverses ray by ray: a scene's instances are walked in their meshes' own
    // coordinates, each mesh held once.
    let prepared = match !scene.instances.is_empty() && search.uses_bvh(scene) {
        true => Prepared::<T>::instanced(scene, algorithm),
        false => Prepared::<T>::new(scene, algorithm, search),
    };
    let start = Instant::now();
    let unwatched = Progress::default();
    let progress = progress.unwrap_or(&unwatched);
    progress.rows.store(prepared.frame.ny, Ordering::Relaxed);
    progress.rows_done.store(0, Ordering::Relaxed);
    let mut images = cpu::render_prepared(&prepared, &progress.rows_done);
    if lit {
        let (colours, rays) = cpu::raytrace::render(&prepared);
        images.color = Some(colours);
        images.hook_rays = Some(rays);
    }
    if timed {
        let stages = Stages {
            build_s: prepared.build_s,
            trace_s: start.elapsed().as_secs_f64(),
            hook_rays: images.hook_rays,
            ..Stages::default()
        };
        let triangle_bytes = size_of::<crate::kernel::types::Triangle<T>>();
        images.stages = Some(with_layout(stages, &prepared.primitives, triangle_bytes));
    }
    images
}

/// Wall time of `f`.
#[cfg(test)]
pub(crate) fn timed<T>(f: impl FnOnce() -> T) -> (T, Duration) {
    let start = Instant::now();
    let value = f();
    (value, start.elapsed())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::types::{Plane, Sphere, Triangle};
    use crate::math::vec3;

    #[test]
    fn bytes_per_triangle_count_ids_and_the_bvh() {
        let p = vec3(0.0, 0.0, 0.0);
        let mut primitives = Primitives::<f32> {
            spheres: vec![
                Sphere {
                    center: p,
                    radius: 1.0
                };
                2
            ],
            planes: vec![
                Plane {
                    point: p,
                    normal: p
                };
                1
            ],
            triangles: vec![Triangle { a: p, b: p, c: p }; 10],
            sphere_objects: vec![0; 2],
            plane_objects: vec![0; 1],
            triangle_objects: vec![0; 10],
            bvh: None,
            instances: Vec::new(),
        };
        // 10 * 48 + 4 * 13 = 532 bytes without a BVH.
        let stages = with_layout(Stages::default(), &primitives, 48);
        assert_eq!(
            (stages.bvh_nodes, stages.bytes_per_triangle),
            (None, Some(53.2))
        );
        primitives.bvh = Some(std::sync::Arc::new(Bvh {
            nodes: vec![bytemuck::Zeroable::zeroed(); 3],
            sphere_order: vec![0; 2],
            triangle_order: vec![0; 10],
            depth: 1,
            instanced: None,
        }));
        // + 3 * 64 + 4 * 12 = 240.
        let stages = with_layout(Stages::default(), &primitives, 48);
        assert_eq!(
            (stages.bvh_nodes, stages.bytes_per_triangle),
            (Some(3), Some(77.2))
        );
        primitives.triangles.clear();
        let stages = with_layout(Stages::default(), &primitives, 48);
        assert_eq!(stages.bytes_per_triangle, None);
    }

    #[test]
    fn triangle_sizes_are_as_documented() {
        assert_eq!(size_of::<GpuTriangle<f32>>(), 40);
        assert_eq!(size_of::<GpuTriangle<f64>>(), 80);
        assert_eq!(size_of::<Triangle<f32>>(), 36);
        assert_eq!(size_of::<Triangle<f64>>(), 72);
    }
}
