//! Rendering in a mode (`DEVICE:PRECISION:ALGORITHM`, as the options spell it) through the
//! library's API: [`raycast::Gpu::render`] or [`raycast::Cpu::render`].

use std::time::{Duration, Instant};

use raycast::{AnyImages, Cpu, Error, Gpu, RenderOptions, Result, Scene};
use raycast::{Device, Mode};

/// `options` with `mode`'s precision and algorithm.
pub fn options(mode: Mode, options: RenderOptions) -> RenderOptions {
    RenderOptions {
        precision: Some(mode.precision),
        algorithm: mode.algorithm,
        ..options
    }
}

/// Refuses what `options` ask of `mode` that it cannot do, before any render.
pub fn check(mode: Mode, options: RenderOptions) -> Result<()> {
    self::options(mode, options).check(mode.device)
}

/// Renders `scene` in `mode` with `options`' other settings, on `gpu` for a GPU mode.
pub fn render(
    scene: &Scene,
    mode: Mode,
    gpu: Option<&Gpu>,
    options: RenderOptions,
) -> Result<AnyImages> {
    let options = self::options(mode, options);
    match (mode.device, gpu) {
        (Device::Gpu, Some(gpu)) => gpu.render(scene, &options),
        (Device::Gpu, None) => Err(Error::Device("a GPU render needs a device".into())),
        (Device::Cpu, _) => Cpu.render(scene, &options),
    }
}

/// A GPU device when one of `modes` needs it.
pub fn gpu_for(modes: &[Mode]) -> Result<Option<Gpu>> {
    match modes.iter().any(|m| m.device == Device::Gpu) {
        true => Gpu::new().map(Some),
        false => Ok(None),
    }
}

/// Wall time of `f`.
pub fn timed<T>(f: impl FnOnce() -> T) -> (T, Duration) {
    let start = Instant::now();
    let value = f();
    (value, start.elapsed())
}
