//! Rendering in a mode (`DEVICE:PRECISION:ALGORITHM`, as the options spell it) through the
//! library's API: [`raycast::Gpu::render`] or [`raycast::Cpu::render`].

use std::path::PathBuf;
use std::str::FromStr;
use std::time::{Duration, Instant};

use raycast::{Algorithm, AnyImages, Cpu, Error, Gpu, RenderOptions, Result, Scene};
use raycast::{Device, Mode, Precision};
use raycast_datasets::{Shard, Summary, ViewsSummary};

/// A mode as an option writes it, `DEVICE[:PRECISION][:ALGORITHM]`: written without a
/// precision (`gpu`), the default precision of the render it is used for
/// ([`Precision::default_for`]), which a hook changes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ModeArg {
    device: Device,
    precision: Option<Precision>,
    algorithm: Algorithm,
}

impl FromStr for ModeArg {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        let mode: Mode = s.parse()?;
        Ok(ModeArg {
            device: mode.device,
            // The precision is the second field: the algorithm cannot be written without it.
            precision: s.contains(':').then_some(mode.precision),
            algorithm: mode.algorithm,
        })
    }
}

impl ModeArg {
    /// The mode, for a render that needs a single kernel (a shade hook, or one frame timed
    /// alone) or not.
    pub fn resolve(self, single_kernel: bool) -> Mode {
        let default = || Precision::default_for(self.device, self.algorithm, single_kernel);
        Mode {
            device: self.device,
            precision: self.precision.unwrap_or_else(default),
            algorithm: self.algorithm,
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
    self::options(mode, options).check(mode.device, None)
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
pub fn gpu_for(devices: impl IntoIterator<Item = Device>) -> Result<Option<Gpu>> {
    match devices.into_iter().any(|d| d == Device::Gpu) {
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

/// The lines `raycast render` prints for a render to files.
pub fn summary_lines(s: &Summary) -> Vec<String> {
    let [nx, ny] = s.size;
    let (mode, device, seconds) = (s.mode, &s.device, s.elapsed.as_secs_f64());
    let first = match s.bands {
        Some(rows) => {
            let peak = s
                .peak_mib
                .map_or(String::new(), |m| format!(", peak memory {m:.0} MiB"));
            format!(
                "rendered {} ({nx}x{ny} in bands of {rows} rows, {mode}) on {device} in {seconds:.3} s{peak}",
                s.scene
            )
        }
        None => {
            let samples = s.spp.map_or(String::new(), |n| format!(", {n} spp"));
            let shaded = (s.shader.as_ref())
                .map_or(String::new(), |p| format!(", shaded by {}", p.display()));
            format!(
                "rendered {} ({nx}x{ny}{samples}, {mode}{shaded}) on {device} in {seconds:.3} s",
                s.scene
            )
        }
    };
    let traced = s.hook_rays.map(|rays| {
        let camera = nx as u64 * ny as u64 * s.spp.unwrap_or(1) as u64;
        format!(
            "cast {camera} camera rays and {rays} from the shade hook ({:.2} a camera ray)",
            rays as f64 / camera.max(1) as f64
        )
    });
    let recast = s.recast.map(|(fraction, on_gpu)| {
        let on = if on_gpu { "the GPU" } else { "the CPU" };
        format!("re-cast {:.3}% of pixels in f64 on {on}", 100.0 * fraction)
    });
    let wrote = |p: &PathBuf| format!("wrote {}", p.display());
    let emitted = s.emitted.iter().map(wrote);
    let written = s.written.iter().map(wrote);
    let lines = std::iter::once(first)
        .chain(traced)
        .chain(emitted)
        .chain(recast);
    lines.chain(written).collect()
}

/// The lines `raycast render --views` prints.
pub fn views_lines(s: &ViewsSummary) -> Vec<String> {
    let [rendered, skipped, total] = s.counts;
    let seconds = s.elapsed.as_secs_f64();
    let share = s.shard.map_or(String::new(), |shard| {
        format!(
            " (shard {}/{}: {total} of {} views)",
            shard.index, shard.count, s.job
        )
    });
    vec![
        format!(
            "rendered {rendered} views in {seconds:.3} s ({:.1} views/s), skipped {skipped} complete, rendered again {} stale{share}",
            rendered as f64 / seconds.max(1e-9),
            s.stale
        ),
        format!("wrote {}", s.manifest.display()),
    ]
}

/// The shard a cluster's job array gives this process: a Slurm array task's
/// (`SLURM_ARRAY_TASK_ID` counted from `SLURM_ARRAY_TASK_MIN`, of
/// `SLURM_ARRAY_TASK_COUNT`), or a Kubernetes Indexed Job's (`JOB_COMPLETION_INDEX`, of
/// `count`, its `completions`). `count` also sets a Slurm array's where given.
pub fn shard_from_env(count: Option<u32>) -> Result<Shard> {
    shard_from_vars(count, |name| std::env::var(name).ok())
}

fn shard_from_vars(count: Option<u32>, var: impl Fn(&str) -> Option<String>) -> Result<Shard> {
    let refuse = |message: String| Error::Argument {
        option: "shard auto".into(),
        message,
    };
    let number = |name: &str| -> Result<Option<u32>> {
        var(name)
            .map(|v| {
                v.trim()
                    .parse::<u32>()
                    .map_err(|_| refuse(format!("{name} is `{v}`, not a whole number")))
            })
            .transpose()
    };
    let shard = |index: u32, count: u32, from: &str| {
        (index < count)
            .then_some(Shard { index, count })
            .ok_or_else(|| {
                refuse(format!(
                    "{from} gives shard {index} of {count}, beyond the last"
                ))
            })
    };
    if let Some(id) = number("SLURM_ARRAY_TASK_ID")? {
        let min = number("SLURM_ARRAY_TASK_MIN")?.unwrap_or(0);
        let tasks = match (count, number("SLURM_ARRAY_TASK_COUNT")?) {
            (Some(n), _) | (None, Some(n)) => n,
            (None, None) => {
                return Err(refuse(
                    "SLURM_ARRAY_TASK_COUNT is not set; give the count as --shard-count".into(),
                ));
            }
        };
        let index = id.checked_sub(min).ok_or_else(|| {
            refuse(format!(
                "SLURM_ARRAY_TASK_ID {id} is below SLURM_ARRAY_TASK_MIN {min}"
            ))
        })?;
        return shard(index, tasks, "SLURM_ARRAY_TASK_ID");
    }
    if let Some(index) = number("JOB_COMPLETION_INDEX")? {
        let count = count.ok_or_else(|| {
            refuse("a Kubernetes Indexed Job needs its completions as --shard-count".into())
        })?;
        return shard(index, count, "JOB_COMPLETION_INDEX");
    }
    Err(refuse(
        "found neither a Slurm array task (SLURM_ARRAY_TASK_ID) nor a Kubernetes Indexed Job (JOB_COMPLETION_INDEX)".into(),
    ))
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

    #[test]
    fn auto_shards_come_from_slurm_arrays_and_indexed_jobs() {
        let vars = |pairs: &[(&str, &str)]| {
            let pairs: Vec<(String, String)> = pairs
                .iter()
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect();
            move |name: &str| {
                pairs
                    .iter()
                    .find(|(k, _)| k == name)
                    .map(|(_, v)| v.clone())
            }
        };
        let slurm = vars(&[
            ("SLURM_ARRAY_TASK_ID", "5"),
            ("SLURM_ARRAY_TASK_MIN", "4"),
            ("SLURM_ARRAY_TASK_COUNT", "3"),
        ]);
        assert_eq!(
            shard_from_vars(None, &slurm).unwrap(),
            Shard { index: 1, count: 3 }
        );
        let k8s = vars(&[("JOB_COMPLETION_INDEX", "3")]);
        assert_eq!(
            shard_from_vars(Some(4), &k8s).unwrap(),
            Shard { index: 3, count: 4 }
        );
        let message = |r: Result<Shard>| r.unwrap_err().to_string();
        assert!(message(shard_from_vars(None, &k8s)).contains("--shard-count"));
        assert!(message(shard_from_vars(Some(3), &k8s)).contains("beyond the last"));
        assert!(message(shard_from_vars(None, vars(&[]))).contains("JOB_COMPLETION_INDEX"));
        let below = vars(&[("SLURM_ARRAY_TASK_ID", "1"), ("SLURM_ARRAY_TASK_MIN", "2")]);
        assert!(message(shard_from_vars(Some(2), below)).contains("below"));
        let bad = vars(&[("SLURM_ARRAY_TASK_ID", "x")]);
        assert!(message(shard_from_vars(Some(2), bad)).contains("`x`"));
    }
}
