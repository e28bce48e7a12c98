//! Rendering in a mode (`DEVICE:PRECISION:ALGORITHM`, as the options spell it) through the
//! library's API: [`raycast::Gpu::render`] or [`raycast::Cpu::render`].

use std::str::FromStr;
use std::time::{Duration, Instant};

use raycast::{AnyImages, Cpu, Error, Gpu, RenderOptions, Result, Scene};
use raycast::{Device, Mode, Precision};

/// A mode as an option writes it, `DEVICE[:PRECISION][:ALGORITHM]`: written without a
/// precision (`gpu`), the default precision of the render it is used for
/// ([`Precision::default_for`]), which a hook changes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ModeArg {
    mode: Mode,
    precision_given: bool,
}

impl FromStr for ModeArg {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        Ok(ModeArg {
            mode: s.parse()?,
            // The precision is the second field: the algorithm cannot be written without it.
            precision_given: s.contains(':'),
        })
    }
}

impl ModeArg {
    /// The mode, for a render that needs a single kernel (a shade hook, or one frame timed
    /// alone) or not.
    pub fn resolve(self, single_kernel: bool) -> Mode {
        let Mode {
            device, algorithm, ..
        } = self.mode;
        match self.precision_given {
            true => self.mode,
            false => Mode {
                precision: Precision::default_for(device, algorithm, single_kernel),
                ..self.mode
            },
        }
    }
}

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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_mode_without_a_precision_takes_the_renders_default() {
        let mode = |s: &str, single_kernel| s.parse::<ModeArg>().unwrap().resolve(single_kernel);
        assert_eq!(mode("gpu", false).to_string(), "gpu:adaptive:robust");
        assert_eq!(mode("gpu", true).to_string(), "gpu:f32:robust");
        assert_eq!(mode("cpu", true).to_string(), "cpu:f64:robust");
        assert_eq!(
            mode("gpu:adaptive", true).to_string(),
            "gpu:adaptive:robust"
        );
        assert_eq!(
            mode("gpu:f64:textbook", false).to_string(),
            "gpu:f64:textbook"
        );
        assert!("gpu:f16".parse::<ModeArg>().is_err());
    }
}
