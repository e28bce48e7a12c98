//! One entry point for every way of rendering: device (GPU kernel or CPU reference) x
//! precision (f32 or f64) x algorithm (textbook or robust), as the CLI spells them
//! (`gpu:f32`, `cpu:f64:textbook`).

use std::fmt;
use std::str::FromStr;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

use crate::algorithm::Algorithm;
use crate::cpu;
use crate::error::{Error, Result};
use crate::gpu::hooks::ShadeHook;
use crate::gpu::kernel::UserKernel;
use crate::gpu::layout::GpuReal;
use crate::gpu::shader::Variant;
use crate::gpu::{self, Gpu, Job, Stages};
use crate::images::{Images, Outputs};
use crate::math::Precision;
use crate::output::{self, Format};
use crate::prepare::Prepared;
use crate::prepare::bvh::Accel;
use crate::scene::Scene;

/// Where a render runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Device {
    /// The WGSL kernel on the wgpu adapter.
    Gpu,
    /// The CPU reference (rayon threads).
    Cpu,
}

impl Device {
    /// f32 on the GPU (what GPUs are fast at), f64 on the CPU (the reference).
    pub fn default_precision(self) -> Arithmetic {
        match self {
            Device::Gpu => Arithmetic::F32,
            Device::Cpu => Arithmetic::F64,
        }
    }
}

/// The arithmetic of a render: one precision throughout, or adaptive (robust f32, with the
/// pixels it cannot be sure of cast again in f64; see [`crate::adaptive`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Arithmetic {
    F32,
    F64,
    Adaptive,
}

impl From<Precision> for Arithmetic {
    fn from(p: Precision) -> Self {
        match p {
            Precision::F32 => Arithmetic::F32,
            Precision::F64 => Arithmetic::F64,
        }
    }
}

impl FromStr for Arithmetic {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "adaptive" => Ok(Arithmetic::Adaptive),
            other => other
                .parse::<Precision>()
                .map(Arithmetic::from)
                .map_err(|_| {
                    format!("unknown precision `{other}` (expected f32, f64 or adaptive)")
                }),
        }
    }
}

impl fmt::Display for Arithmetic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Arithmetic::F32 => "f32",
            Arithmetic::F64 => "f64",
            Arithmetic::Adaptive => "adaptive",
        })
    }
}

impl FromStr for Device {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "gpu" => Ok(Device::Gpu),
            "cpu" => Ok(Device::Cpu),
            other => Err(format!("unknown device `{other}` (expected gpu or cpu)")),
        }
    }
}

/// The algorithm set used unless one is named.
pub const DEFAULT_ALGORITHM: Algorithm = Algorithm::Robust;

/// A device, a precision and an algorithm set, written `DEVICE[:PRECISION][:ALGORITHM]`:
/// `gpu:f32`, `cpu:f64:textbook`, or just `gpu` / `cpu` for the device's default precision
/// and the robust set.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Mode {
    pub device: Device,
    pub precision: Arithmetic,
    pub algorithm: Algorithm,
}

impl FromStr for Mode {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        let mut parts = s.split(':');
        let device: Device = parts.next().unwrap_or_default().parse()?;
        let mut mode = Mode {
            device,
            precision: device.default_precision(),
            algorithm: DEFAULT_ALGORITHM,
        };
        if let Some(p) = parts.next() {
            mode.precision = p.parse()?;
        }
        if let Some(a) = parts.next() {
            mode.algorithm = a.parse()?;
        }
        if parts.next().is_some() {
            return Err(format!("`{s}`: expected DEVICE[:PRECISION][:ALGORITHM]"));
        }
        Ok(mode)
    }
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let device = match self.device {
            Device::Gpu => "gpu",
            Device::Cpu => "cpu",
        };
        write!(f, "{device}:{}:{}", self.precision, self.algorithm)
    }
}

/// Images in whichever precision they were rendered in.
#[derive(Clone, Debug, PartialEq)]
pub enum AnyImages {
    F32(Images<f32>),
    F64(Images<f64>),
}

impl AnyImages {
    /// Encodes and writes the images (see [`output::write_images`]).
    pub fn write(
        &self,
        dir: &std::path::Path,
        formats: &[Format],
    ) -> Result<Vec<std::path::PathBuf>> {
        match self {
            AnyImages::F32(i) => output::write_images(i, dir, formats),
            AnyImages::F64(i) => output::write_images(i, dir, formats),
        }
    }
}

/// What a render is asked to produce beyond its [`Mode`].
#[derive(Clone, Debug, PartialEq)]
pub struct Request {
    /// The outputs wanted. The GPU kernels (f32, f64) compute and read back only these (and
    /// the ids when the palette `color.png` is wanted); adaptive precision and the CPU
    /// reference compute every output.
    pub outputs: Outputs,
    /// The user's shade hook, which colours `color.png` when `outputs.color` (GPU, f32 or f64
    /// only; any other mode is an [`Error::Argument`] naming `--shader`).
    pub shade: Option<ShadeHook>,
    /// A complete kernel to run instead of the assembled one (GPU, f32 or f64 only; any
    /// other mode is an [`Error::Argument`] naming `--kernel`). It must declare the bindings
    /// of the kernel this request would assemble ([`UserKernel::for_variant`]).
    pub kernel: Option<UserKernel>,
}

impl Default for Request {
    /// Every output, no hook, the assembled kernel.
    fn default() -> Self {
        Request {
            outputs: Outputs::ALL,
            shade: None,
            kernel: None,
        }
    }
}

impl Request {
    /// The kernel a GPU render of `scene` in `mode` (f32 or f64) runs for this request:
    /// specialised for the scene and the outputs, with the hook, and the user's kernel in its
    /// place where one is given (an error if its bindings do not fit).
    pub fn kernel_variant(
        &self,
        gpu: &Gpu,
        scene: &Scene,
        mode: Mode,
    ) -> Result<gpu::shader::Variant> {
        let precision = match mode.precision {
            Arithmetic::F64 => Precision::F64,
            _ => Precision::F32,
        };
        let mut variant = gpu.scene_variant(scene, precision, mode.algorithm);
        if let Some(hook) = &self.shade {
            variant = variant.with_shade(hook.key);
        }
        let variant = variant.with_outputs(self.kernel_outputs());
        match &self.kernel {
            Some(kernel) => kernel.for_variant(variant),
            None => Ok(variant),
        }
    }

    /// The outputs the GPU kernel must write for this request: with a hook, the colour is the
    /// kernel's; without, the palette `color.png` is made on the host from the ids.
    pub fn kernel_outputs(&self) -> Outputs {
        let o = self.outputs;
        let hooked = self.shade.is_some();
        Outputs {
            id: o.id || (o.color && !hooked),
            color: o.color && hooked,
            ..o
        }
    }
}

/// Renders `scene` in `mode`. `gpu` is needed for [`Device::Gpu`]; with `progress`, a CPU
/// render that takes over a second shows a progress bar on stderr when it is a terminal.
pub fn render(scene: &Scene, mode: Mode, gpu: Option<&Gpu>, progress: bool) -> Result<AnyImages> {
    render_request(scene, mode, gpu, progress, &Request::default())
}

/// [`render`] producing what `request` asks for.
pub fn render_request(
    scene: &Scene,
    mode: Mode,
    gpu: Option<&Gpu>,
    progress: bool,
    request: &Request,
) -> Result<AnyImages> {
    if request.shade.is_some() && request.outputs.color {
        let ok = mode.device == Device::Gpu && mode.precision != Arithmetic::Adaptive;
        if !ok {
            return Err(Error::Argument {
                option: "--shader".into(),
                message: if mode.device == Device::Cpu {
                    "the CPU reference runs no shader; use --device gpu".into()
                } else {
                    "runs with --precision f32 or f64, not adaptive".into()
                },
            });
        }
    }
    if request.kernel.is_some() {
        let plain = mode.device == Device::Gpu && mode.precision != Arithmetic::Adaptive;
        if !plain {
            return Err(Error::Argument {
                option: "--kernel".into(),
                message: if mode.device == Device::Cpu {
                    "the CPU reference runs no shader; use --device gpu".into()
                } else {
                    "runs with --precision f32 or f64 (adaptive precision runs two kernels)".into()
                },
            });
        }
    }
    if mode.precision == Arithmetic::Adaptive {
        let gpu = match (mode.device, mode.algorithm, gpu) {
            (Device::Gpu, Algorithm::Robust, Some(gpu)) => gpu,
            _ => {
                return Err(Error::Argument {
                    option: "--precision adaptive".into(),
                    message: "runs on the GPU with the robust algorithm set".into(),
                });
            }
        };
        return Ok(AnyImages::F32(
            crate::adaptive::render_adaptive(gpu, scene)?.images,
        ));
    }
    match mode.device {
        Device::Gpu => {
            let gpu = gpu.ok_or_else(|| Error::Device("a GPU render needs a device".into()))?;
            let variant = request.kernel_variant(gpu, scene, mode)?;
            Ok(match mode.precision {
                Arithmetic::F32 => AnyImages::F32(on_gpu::<f32>(gpu, scene, variant, false)?.0),
                _ => AnyImages::F64(on_gpu::<f64>(gpu, scene, variant, false)?.0),
            })
        }
        Device::Cpu => Ok(match mode.precision {
            Arithmetic::F32 => AnyImages::F32(cpu_with_progress(scene, mode.algorithm, progress)),
            _ => AnyImages::F64(cpu_with_progress(scene, mode.algorithm, progress)),
        }),
    }
}

/// Renders `scene` with the kernel `variant` (prepared for it), timing the stages and, with
/// `timed`, the kernel.
pub fn on_gpu<R: GpuReal>(
    gpu: &Gpu,
    scene: &Scene,
    variant: Variant,
    timed: bool,
) -> Result<(Images<R>, Stages)> {
    let prepared = gpu::prepare::<R>(scene, &variant);
    let r = gpu::run(gpu, &prepared, Job::new(variant).timed(timed))?;
    Ok((r.images, r.stages))
}

/// A progress bar of `len` steps drawn with `template` on stderr, or a hidden one unless
/// `enabled` and stderr is a terminal.
pub fn progress_bar(enabled: bool, len: u64, template: &str) -> indicatif::ProgressBar {
    use std::io::IsTerminal;
    if !enabled || !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    indicatif::ProgressBar::new(len)
        .with_style(indicatif::ProgressStyle::with_template(template).expect("valid template"))
}

/// Images above this many pixels are rendered and written in bands of rows
/// ([`render_streamed`]), holding one band at a time.
pub const STREAM_PIXELS: u64 = 1 << 24;

/// Rows per band for a streamed render `width` pixels wide: about four million pixels.
pub fn band_rows(width: u32) -> u32 {
    ((1u32 << 22) / width.max(1)).max(1)
}

/// Whether [`render_streamed`] can render `mode`: a GPU kernel in f32 or f64.
pub fn can_stream(mode: Mode) -> bool {
    mode.device == Device::Gpu && mode.precision != Arithmetic::Adaptive
}

/// Renders `scene` on the GPU in bands of at most `max_rows` rows, handing each band to
/// `sink` from the top as soon as it is read back (see [`gpu::Job::sink`]). Only for
/// modes where [`can_stream`] holds.
pub fn render_streamed(
    scene: &Scene,
    mode: Mode,
    gpu: &Gpu,
    request: &Request,
    max_rows: u32,
    sink: &mut dyn FnMut(AnyImages) -> Result<()>,
) -> Result<()> {
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
    ) -> Result<()> {
        let prepared = gpu::prepare::<R>(scene, &variant);
        let mut each = |_, band| sink(band);
        let job = Job::new(variant).rows(max_rows).timed(true).sink(&mut each);
        gpu::run(gpu, &prepared, job).map(|_| ())
    }
    match mode.precision {
        Arithmetic::F32 => bands::<f32>(gpu, scene, variant, max_rows, &mut |b| {
            sink(AnyImages::F32(b))
        }),
        _ => bands::<f64>(gpu, scene, variant, max_rows, &mut |b| {
            sink(AnyImages::F64(b))
        }),
    }
}

/// [`render`] (without a progress bar), also returning the GPU kernel time in seconds for a GPU
/// mode on a device with timestamp queries (the sum over tiles, and for adaptive precision
/// over its certainty and re-cast passes; see [`gpu::render_timed`]); `None` for the CPU.
pub fn render_timed(
    scene: &Scene,
    mode: Mode,
    gpu: Option<&Gpu>,
) -> Result<(AnyImages, Option<f64>)> {
    match (mode.device, mode.precision, gpu) {
        (Device::Gpu, Arithmetic::Adaptive, Some(g)) if mode.algorithm == Algorithm::Robust => {
            let a = crate::adaptive::render_adaptive_timed(g, scene)?;
            Ok((AnyImages::F32(a.images), a.kernel_s))
        }
        (Device::Gpu, Arithmetic::F32, Some(g)) => {
            let variant = g.scene_variant(scene, Precision::F32, mode.algorithm);
            let (images, s) = on_gpu::<f32>(g, scene, variant, true)?;
            Ok((AnyImages::F32(images), s.kernel_s))
        }
        (Device::Gpu, Arithmetic::F64, Some(g)) => {
            let variant = g.scene_variant(scene, Precision::F64, mode.algorithm);
            let (images, s) = on_gpu::<f64>(g, scene, variant, true)?;
            Ok((AnyImages::F64(images), s.kernel_s))
        }
        // The CPU, and the errors of [`render`].
        _ => Ok((render(scene, mode, gpu, false)?, None)),
    }
}

/// Runs the CPU reference; if it is still running after a second and stderr is a terminal,
/// shows a progress bar of finished rows.
fn cpu_with_progress<T: crate::math::Real>(
    scene: &Scene,
    algorithm: Algorithm,
    progress: bool,
) -> Images<T> {
    use std::io::IsTerminal;
    if !progress || !std::io::stderr().is_terminal() {
        return cpu::render(scene, algorithm);
    }
    let rows = scene.camera.resolution[1];
    let done = AtomicU32::new(0);
    std::thread::scope(|s| {
        let worker = s.spawn(|| {
            cpu::render_prepared::<T>(&Prepared::new(scene, algorithm, Accel::Auto), &done)
        });
        let start = Instant::now();
        let mut bar: Option<indicatif::ProgressBar> = None;
        while !worker.is_finished() {
            std::thread::sleep(Duration::from_millis(50));
            if bar.is_none() && start.elapsed() > Duration::from_secs(1) {
                let b = indicatif::ProgressBar::new(rows as u64).with_style(
                    indicatif::ProgressStyle::with_template(
                        "cpu render {bar:40} {pos}/{len} rows, {eta} left",
                    )
                    .expect("valid template"),
                );
                bar = Some(b);
            }
            if let Some(b) = &bar {
                b.set_position(done.load(Ordering::Relaxed) as u64);
            }
        }
        if let Some(b) = bar {
            b.finish_and_clear();
        }
        worker.join().expect("the CPU renderer does not panic")
    })
}

/// Wall time of `f`.
pub fn timed<T>(f: impl FnOnce() -> T) -> (T, Duration) {
    let start = Instant::now();
    let value = f();
    (value, start.elapsed())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn modes_parse_with_device_defaults() {
        let m: Mode = "cpu".parse().unwrap();
        let expected = Mode {
            device: Device::Cpu,
            precision: Arithmetic::F64,
            algorithm: Algorithm::Robust,
        };
        assert_eq!(m, expected);
        let m: Mode = "gpu:adaptive".parse().unwrap();
        assert_eq!(m.precision, Arithmetic::Adaptive);
        let m: Mode = "gpu:f64:textbook".parse().unwrap();
        assert_eq!(m.to_string(), "gpu:f64:textbook");
        assert!("tpu:f32".parse::<Mode>().is_err());
        assert!("gpu:f16".parse::<Mode>().is_err());
        assert!("gpu:f32:fast".parse::<Mode>().is_err());
        assert!("gpu:f32:robust:x".parse::<Mode>().is_err());
    }
}
