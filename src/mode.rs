//! The modes of a render: device (GPU kernel or CPU reference) x precision (f32, f64 or
//! adaptive) x algorithm (textbook or robust), as the CLI spells them (`gpu:f32`,
//! `cpu:f64:textbook`).

use std::fmt;
use std::str::FromStr;

use crate::algorithm::Algorithm;
use crate::math::Float;

/// Where a render runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Device {
    /// The WGSL kernel on the wgpu adapter.
    Gpu,
    /// The CPU reference (rayon threads).
    Cpu,
}

/// The precision of a render or a query: f32 or f64 throughout, or adaptive (robust f32, with
/// the pixels or rays it cannot be sure of cast again in f64: f64's hits and ids at close to
/// f32's cost; docs/robustness.md).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Precision {
    /// Single precision throughout.
    F32,
    /// Double precision throughout (on GPUs with `SHADER_F64`).
    F64,
    /// Robust f32, the uncertain pixels or rays cast again in f64 (the robust set only).
    Adaptive,
}

impl Precision {
    /// The precision of a render that asks for none: the one rule for every render of the
    /// library, the command line (`render`, `serve`, a mode written without a precision:
    /// `compare --a gpu`) and Python's `render()`.
    ///
    /// On the GPU adaptive precision (f64's hits and ids at close to f32's cost), where it can
    /// run: with the robust set, and where the render does not need a `single_kernel` (a shade
    /// hook, a kernel file, bands, a kernel to emit or time alone), else f32. On the CPU, the
    /// reference, f64.
    pub fn default_for(device: Device, algorithm: Algorithm, single_kernel: bool) -> Precision {
        match device {
            Device::Gpu if single_kernel || algorithm != Algorithm::Robust => Precision::F32,
            Device::Gpu => Precision::Adaptive,
            Device::Cpu => Precision::F64,
        }
    }
}

impl From<Float> for Precision {
    fn from(p: Float) -> Self {
        match p {
            Float::F32 => Precision::F32,
            Float::F64 => Precision::F64,
        }
    }
}

impl FromStr for Precision {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "adaptive" => Ok(Precision::Adaptive),
            other => other.parse::<Float>().map(Precision::from).map_err(|_| {
                format!("unknown precision `{other}` (expected f32, f64 or adaptive)")
            }),
        }
    }
}

impl fmt::Display for Precision {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Precision::F32 => "f32",
            Precision::F64 => "f64",
            Precision::Adaptive => "adaptive",
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

/// A device, a precision and an algorithm set, written `DEVICE[:PRECISION][:ALGORITHM]`:
/// `gpu:f32`, `cpu:f64:textbook`, or just `gpu` / `cpu` for the robust set in the default
/// precision of a render without a hook ([`Precision::default_for`]: `gpu:adaptive:robust`,
/// `cpu:f64:robust`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Mode {
    /// Where it renders.
    pub device: Device,
    /// In which precision.
    pub precision: Precision,
    /// With which intersection formulas.
    pub algorithm: Algorithm,
}

impl FromStr for Mode {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        let mut parts = s.split(':');
        let device: Device = parts.next().unwrap_or_default().parse()?;
        let mut mode = Mode {
            device,
            precision: Precision::default_for(device, Algorithm::default(), false),
            algorithm: Algorithm::default(),
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn modes_parse_with_device_defaults() {
        let m: Mode = "cpu".parse().unwrap();
        let expected = Mode {
            device: Device::Cpu,
            precision: Precision::F64,
            algorithm: Algorithm::Robust,
        };
        assert_eq!(m, expected);
        let m: Mode = "gpu".parse().unwrap();
        assert_eq!(m.to_string(), "gpu:adaptive:robust");
        let m: Mode = "gpu:adaptive".parse().unwrap();
        assert_eq!(m.precision, Precision::Adaptive);
        let m: Mode = "gpu:f64:textbook".parse().unwrap();
        assert_eq!(m.to_string(), "gpu:f64:textbook");
        assert!("tpu:f32".parse::<Mode>().is_err());
        assert!("gpu:f16".parse::<Mode>().is_err());
        assert!("gpu:f32:fast".parse::<Mode>().is_err());
        assert!("gpu:f32:robust:x".parse::<Mode>().is_err());
    }
}
