//! One entry point for every way of rendering: device (GPU kernel or CPU reference) x
//! precision (f32 or f64), as the CLI spells them (`gpu:f32`, `cpu:f64`).

use std::fmt;
use std::str::FromStr;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

use crate::cpu;
use crate::error::{Error, Result};
use crate::gpu::{self, Gpu};
use crate::images::Images;
use crate::math::Precision;
use crate::output::{self, Format};
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
    pub fn default_precision(self) -> Precision {
        match self {
            Device::Gpu => Precision::F32,
            Device::Cpu => Precision::F64,
        }
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

/// A device and a precision, written `gpu:f32`, `cpu:f64`, or just `gpu` / `cpu` for the
/// device's default precision.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Mode {
    pub device: Device,
    pub precision: Precision,
}

impl FromStr for Mode {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        let (device, precision) = match s.split_once(':') {
            Some((d, p)) => (d.parse::<Device>()?, Some(p.parse::<Precision>()?)),
            None => (s.parse::<Device>()?, None),
        };
        Ok(Mode {
            device,
            precision: precision.unwrap_or(device.default_precision()),
        })
    }
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let device = match self.device {
            Device::Gpu => "gpu",
            Device::Cpu => "cpu",
        };
        write!(f, "{device}:{}", self.precision)
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

/// Renders `scene` in `mode`. `gpu` is needed for [`Device::Gpu`]; with `progress`, a CPU
/// render that takes over a second shows a progress bar on stderr when it is a terminal.
pub fn render(scene: &Scene, mode: Mode, gpu: Option<&Gpu>, progress: bool) -> Result<AnyImages> {
    match mode.device {
        Device::Gpu => {
            let gpu = gpu.ok_or_else(|| Error::Device("a GPU render needs a device".into()))?;
            Ok(match mode.precision {
                Precision::F32 => AnyImages::F32(gpu::render::<f32>(gpu, scene)?),
                Precision::F64 => AnyImages::F64(gpu::render::<f64>(gpu, scene)?),
            })
        }
        Device::Cpu => Ok(match mode.precision {
            Precision::F32 => AnyImages::F32(cpu_with_progress(scene, progress)),
            Precision::F64 => AnyImages::F64(cpu_with_progress(scene, progress)),
        }),
    }
}

/// Runs the CPU reference; if it is still running after a second and stderr is a terminal,
/// shows a progress bar of finished rows.
fn cpu_with_progress<T: crate::math::Real>(scene: &Scene, progress: bool) -> Images<T> {
    use std::io::IsTerminal;
    if !progress || !std::io::stderr().is_terminal() {
        return cpu::render(scene);
    }
    let rows = scene.camera.resolution[1];
    let done = AtomicU32::new(0);
    std::thread::scope(|s| {
        let worker = s.spawn(|| cpu::render_with_progress::<T>(scene, &done));
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
        assert_eq!(
            m,
            Mode {
                device: Device::Cpu,
                precision: Precision::F64
            }
        );
        let m: Mode = "gpu:f64".parse().unwrap();
        assert_eq!(m.to_string(), "gpu:f64");
        assert!("tpu:f32".parse::<Mode>().is_err());
        assert!("gpu:f16".parse::<Mode>().is_err());
    }
}
