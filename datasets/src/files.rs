//! A render to files, as `raycast render` asks for it: which scene, which mode, how many
//! samples, which shader, where to write. [`RenderFiles::run`] decides how the render goes:
//!
//! - on the GPU in f32 or f64 without `--spp` or a kernel file, images above
//!   [`STREAM_PIXELS`] pixels, or any with `band_rows`, are rendered and written in bands of
//!   rows ([`Gpu::render_bands`] into [`Encoding::write_bands`]), one band held at a time;
//! - adaptive precision alone (GPU, robust) reports how much it re-cast in f64;
//! - anything else renders the whole image, supersampled with `spp`, and writes it all or
//!   nothing.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use raycast::Encoding;
use raycast::{Algorithm, AnyImages, Begun, Cpu, Device, Error, Gpu, Mode, Precision, Progress};
use raycast::{CameraOverrides, Scene, Split};
use raycast::{RenderOptions, Result, ShadeHook, UserKernel};

/// Images above this many pixels are rendered and written in bands of rows, holding one band
/// at a time.
pub const STREAM_PIXELS: u64 = 1 << 24;

/// Rows per band for a render in bands `width` pixels wide: about four million pixels.
fn band_rows(width: u32) -> u32 {
    ((1u32 << 22) / width.max(1)).max(1)
}

/// The shade hook a tool asks for: `lit` ([`ShadeHook::raytrace`], the course's ray tracer) or
/// a `shader` file ([`ShadeHook::load`]), or none; both at once is an error naming both.
pub fn requested_hook(lit: bool, shader: Option<&Path>) -> Result<Option<ShadeHook>> {
    match (lit, shader) {
        (true, Some(_)) => Err(lit_and_shader()),
        (true, None) => ShadeHook::raytrace().map(Some),
        (false, Some(path)) => ShadeHook::load(path).map(Some),
        (false, None) => Ok(None),
    }
}

/// The error of `lit` asked for with a `shader` file.
fn lit_and_shader() -> Error {
    // The shipped hook's file, as `ShadeHook::raytrace` names it.
    let file = ShadeHook::raytrace().map_or_else(|_| PathBuf::new(), |hook| hook.file);
    Error::Argument {
        option: "lit".into(),
        message: format!(
            "is the shade hook {}; give it or `shader`, not both",
            file.display()
        ),
    }
}

/// Wall time of `f`.
fn timed<T>(f: impl FnOnce() -> T) -> (T, Duration) {
    let start = Instant::now();
    let value = f();
    (value, start.elapsed())
}

/// Refuses a `split` other than the default where none of `scenes` is a mesh file (`None`: the
/// built-in default scene): it splits mesh files given as scenes, and a scene file's soups say
/// their own.
pub(crate) fn check_split<'a>(
    split: Split,
    mut scenes: impl Iterator<Item = Option<&'a Path>>,
) -> Result<()> {
    if split != Split::default() && !scenes.any(|s| s.is_some_and(raycast::is_mesh_file)) {
        return Err(Error::Argument {
            option: "split".into(),
            message: "splits mesh files given as scenes; in a scene file, give a soup \"split\""
                .into(),
        });
    }
    Ok(())
}

/// Everything a render to files is asked for.
#[derive(Clone, Debug)]
pub struct RenderFiles {
    /// The scene file; `None`: the built-in default scene.
    pub scene: Option<PathBuf>,
    /// Overrides the scene's resolution.
    pub size: Option<[u32; 2]>,
    /// Where it renders.
    pub device: Device,
    /// In which precision; `None`: the render's default ([`Precision::default_for`], given
    /// what the render needs).
    pub precision: Option<Precision>,
    /// With which intersection formulas.
    pub algorithm: Algorithm,
    /// Samples per pixel (a perfect square); `None`: one ray per pixel, no `alpha.npy`.
    pub spp: Option<u32>,
    /// Render and write in bands of at most this many rows.
    pub band_rows: Option<u32>,
    /// A shade hook file colouring `color.png`.
    pub shader: Option<PathBuf>,
    /// Colour `color.png` by the course's ray tracer, the shipped hook
    /// shaders/examples/raytrace.wgsl on the GPU, its mirror src/cpu/raytrace.rs on the CPU
    /// (`--lit`).
    pub lit: bool,
    /// A complete kernel file run instead of the assembled one.
    pub kernel: Option<PathBuf>,
    /// The output folder, created if missing.
    pub out_dir: PathBuf,
    /// The files' formats and what they hold.
    pub encoding: Encoding,
    /// Also write the kernel the render ran (its first pass, for adaptive precision) here.
    pub emit_shader: Option<PathBuf>,
    /// Camera settings replacing the scene's (or a mesh's default view's).
    pub view: CameraOverrides,
    /// Which parts of a mesh file given as the scene are objects of their own (a scene file's
    /// soups say it themselves: [`RenderFiles::check`] refuses any but the default for one).
    pub split: Split,
}

/// What a render to files did, for the user.
#[derive(Clone, Debug)]
pub struct Summary {
    /// The scene file, or "the default scene".
    pub scene: String,
    /// The image's size.
    pub size: [u32; 2],
    /// The mode it ran in, its precision resolved.
    pub mode: Mode,
    /// Samples per pixel, when supersampled.
    pub spp: Option<u32>,
    /// The shade hook's file, or the shipped ray tracer's for `--lit`.
    pub shader: Option<PathBuf>,
    /// The rays the shade hook cast beyond the camera's, when it cast any.
    pub hook_rays: Option<u64>,
    /// The adapter, or "the CPU".
    pub device: String,
    /// Wall time of the render and the writes.
    pub elapsed: Duration,
    /// Rows per band, when rendered in bands.
    pub bands: Option<u32>,
    /// The process's peak memory in MiB, where known: [`RenderFiles::run`] leaves it `None`,
    /// for the caller to set (`raycast render` does for renders in bands, and reports it).
    pub peak_mib: Option<f64>,
    /// Adaptive precision: the fraction of pixels cast again in f64, and whether on the GPU.
    pub recast: Option<(f64, bool)>,
    /// The kernel written with `emit_shader`.
    pub emitted: Option<PathBuf>,
    /// The image files written.
    pub written: Vec<PathBuf>,
}

impl RenderFiles {
    /// The mode the render runs in. Without a precision, the default ([`Precision::default_for`]):
    /// on the GPU adaptive precision, which reproduces f64's hits and ids (the course's
    /// pictures) at close to f32's cost; but f32 where a render needs a single kernel
    /// (`--shader`, `--kernel`, `--emit-shader`, whose kernel can then be fed back with
    /// `--kernel`, bands, or an image of more than [`STREAM_PIXELS`] pixels, `huge`, which f32
    /// streams in bands) or the textbook set, which adaptive precision does not run.
    pub(crate) fn resolved_mode(&self, huge: bool) -> Mode {
        let single_kernel = self.shaded()
            || self.kernel.is_some()
            || self.emit_shader.is_some()
            || self.band_rows.is_some()
            || (huge && self.spp.is_none());
        let default = || Precision::default_for(self.device, self.algorithm, single_kernel);
        Mode {
            device: self.device,
            precision: self.precision.unwrap_or_else(default),
            algorithm: self.algorithm,
        }
    }

    /// This spec with its precision resolved ([`RenderFiles::resolved_mode`]).
    fn resolved(&self, huge: bool) -> RenderFiles {
        RenderFiles {
            precision: Some(self.resolved_mode(huge).precision),
            ..self.clone()
        }
    }

    /// Refuses the option combinations that cannot render, before anything is read.
    pub fn check(&self) -> Result<()> {
        self.checked().map(drop)
    }

    /// [`RenderFiles::check`], returning the render's files, read and checked.
    fn checked(&self) -> Result<Files> {
        let files = self.check_options()?;
        check_split(self.split, std::iter::once(self.scene.as_deref()))?;
        Ok(files)
    }

    /// [`RenderFiles::check`] but for `scene` and `split`, which a job of many scenes checks
    /// against its own ([`crate::RenderViews`]); returns the render's files, read and checked.
    pub(crate) fn check_options(&self) -> Result<Files> {
        let resolved = self.resolved(false);
        resolved.check_resolved()?;
        let files = resolved.load_files()?;
        let options = resolved.options(&files);
        options.check(resolved.device, None)?;
        Ok(files)
    }

    fn check_resolved(&self) -> Result<()> {
        let refuse = |option: &str, message: &str| {
            Err(Error::Argument {
                option: option.into(),
                message: message.into(),
            })
        };
        let gpu = self.device == Device::Gpu;
        if self.emit_shader.is_some() && !gpu {
            return refuse(
                "emit_shader",
                "the CPU reference runs no shader; use `device` gpu",
            );
        }
        if self.lit && self.shader.is_some() {
            return Err(lit_and_shader());
        }
        if self.lit && self.precision == Some(Precision::Adaptive) {
            return refuse("lit", "runs with `precision` f32 or f64, not adaptive");
        }
        if self.shaded() {
            if self.encoding.background.is_some() {
                return refuse(
                    "background",
                    "a shade hook colours the background itself (it is called for misses too)",
                );
            }
            if !self.encoding.outputs.color {
                return refuse(
                    if self.lit { "lit" } else { "shader" },
                    "the hook colours color.png, which is not asked for; add png to `formats` and color to `outputs`",
                );
            }
        }
        if let Some(f) = self.encoding.formats.iter().find(|f| f.whole_only())
            && self.band_rows.is_some()
        {
            return refuse(
                &format!("formats {f}"),
                "is written whole, not in bands of rows (`band_rows`)",
            );
        }
        if self.band_rows.is_some() && !self.streamable() {
            return refuse(
                "band_rows",
                "bands are rendered on the GPU in f32 or f64, without `samples_per_pixel` or `kernel`",
            );
        }
        Ok(())
    }

    /// Refuses a render of `size` pixels with `files` whose images, held whole, need more
    /// memory than this machine has ([`RenderOptions::check`]); one in bands holds a band and
    /// passes.
    pub(crate) fn check_memory(&self, size: [u32; 2], files: &Files) -> Result<()> {
        let huge = u64::from(size[0]) * u64::from(size[1]) > STREAM_PIXELS;
        self.resolved(huge).check_resolved_memory(size, huge, files)
    }

    fn check_resolved_memory(&self, size: [u32; 2], huge: bool, files: &Files) -> Result<()> {
        match self.in_bands(huge) {
            true => Ok(()),
            false => self.options(files).check(self.device, Some(size)),
        }
    }

    /// Whether this (resolved) render runs one GPU kernel, in f32 or f64, as bands need.
    fn on_one_gpu_kernel(&self) -> bool {
        self.device == Device::Gpu && self.precision != Some(Precision::Adaptive)
    }

    /// Whether a shade hook colours `color.png`: `--shader` or `--lit`.
    fn shaded(&self) -> bool {
        self.shader.is_some() || self.lit
    }

    /// Whether the render can go in bands: a GPU kernel in f32 or f64, one sample per pixel,
    /// the assembled kernel.
    fn streamable(&self) -> bool {
        self.spp.is_none() && self.on_one_gpu_kernel() && self.kernel.is_none()
    }

    /// Reads the scene and the shader, renders and writes every file (all or none), and the
    /// kernel with `emit_shader`. `gpu` is needed for a GPU mode; a CPU render counts its rows
    /// in `progress`.
    ///
    /// ```no_run
    /// use raycast::{Algorithm, Device, Gpu};
    /// use raycast::{Encoding, Format};
    /// use raycast_datasets::RenderFiles;
    /// let render = RenderFiles {
    ///     scene: Some("scenes/course/bunny.json".into()),
    ///     size: Some([1920, 1080]),
    ///     device: Device::Gpu,
    ///     precision: None,
    ///     algorithm: Algorithm::Robust,
    ///     spp: None,
    ///     band_rows: None,
    ///     shader: None,
    ///     lit: false,
    ///     kernel: None,
    ///     out_dir: "out".into(),
    ///     encoding: Encoding::new(&[Format::Png, Format::Npy], None)?,
    ///     emit_shader: None,
    ///     view: Default::default(),
    ///     split: Default::default(),
    /// };
    /// let summary = render.run(Some(&Gpu::new()?), None)?;
    /// println!("wrote {} files", summary.written.len());
    /// # Ok::<(), raycast::Error>(())
    /// ```
    pub fn run(&self, gpu: Option<&Gpu>, progress: Option<Arc<Progress>>) -> Result<Summary> {
        let files = self.checked()?;
        let scene = raycast::load_viewed(self.scene.as_deref(), self.size, &self.view, self.split)?;
        for warning in &scene.warnings {
            eprintln!("warning: {warning}");
        }
        if let Some(path) = &self.scene
            && !self.shaded()
            && !scene.lighting.is_empty()
        {
            eprintln!(
                "note: {}: materials and lights ({}) light color.png with --lit",
                path.display(),
                scene.lighting
            );
        }
        self.run_with(gpu, progress, &scene, &files)
    }

    /// [`RenderFiles::run`] of `scene`, loaded already (with its camera as the render sees it).
    pub(crate) fn run_loaded(
        &self,
        gpu: Option<&Gpu>,
        progress: Option<Arc<Progress>>,
        scene: &Scene,
    ) -> Result<Summary> {
        self.run_with(gpu, progress, scene, &self.load_files()?)
    }

    /// [`RenderFiles::run_loaded`] with the render's `files`, read already.
    fn run_with(
        &self,
        gpu: Option<&Gpu>,
        progress: Option<Arc<Progress>>,
        scene: &Scene,
        files: &Files,
    ) -> Result<Summary> {
        let huge = pixels(&scene.camera) > STREAM_PIXELS;
        self.resolved(huge)
            .run_resolved(gpu, progress, scene, huge, files)
    }

    fn run_resolved(
        &self,
        gpu: Option<&Gpu>,
        progress: Option<Arc<Progress>>,
        scene: &Scene,
        huge: bool,
        files: &Files,
    ) -> Result<Summary> {
        self.check_resolved_memory(scene.camera.resolution, huge, files)?;
        let options = RenderOptions {
            progress,
            ..self.options(files)
        };
        let gpu = self.device_for(&options, gpu, scene)?;
        raycast_files::check_writable(&self.out_dir)?;
        if let Some(path) = &self.emit_shader {
            raycast_files::check_parent_writable(path)?;
        }
        let [nx, ny] = scene.camera.resolution;
        let mut summary = Summary {
            scene: (self.scene.as_ref())
                .map_or("the default scene".into(), |p| p.display().to_string()),
            size: [nx, ny],
            mode: self.resolved_mode(huge),
            spp: self.spp,
            // The hook's file as given, or the shipped ray tracer's for `lit`.
            shader: options.shade.as_ref().map(|hook| hook.file.clone()),
            hook_rays: None,
            device: gpu.map_or("the CPU".to_owned(), |g| g.info().adapter.name),
            elapsed: Duration::ZERO,
            bands: None,
            peak_mib: None,
            recast: None,
            emitted: None,
            written: Vec::new(),
        };
        match gpu {
            Some(g) if self.in_bands(huge) => {
                let rows = self.band_rows.unwrap_or(band_rows(nx));
                let (written, elapsed) = timed(|| {
                    (self.encoding).write_bands(&self.out_dir, &scene.camera, |band| {
                        g.render_bands(scene, &options, rows, band)
                    })
                });
                let (written, hook_rays) = written?;
                summary.written = written;
                summary.hook_rays = hook_rays;
                summary.elapsed = elapsed;
                summary.bands = Some(rows);
            }
            _ => {
                let (images, elapsed) = timed(|| render_whole(scene, gpu, &options));
                let images = images?;
                summary.hook_rays = images.hook_rays();
                summary.elapsed = elapsed;
                summary.recast = self.recast(&images);
                let files = images.encode(&self.encoding, &scene.camera);
                summary.written = raycast_files::write_files(&self.out_dir, &files)?;
            }
        }
        if let (Some(path), Some(g)) = (&self.emit_shader, gpu) {
            let source = g.kernel_source(scene, &options)?;
            raycast_files::write_file(path, source.as_bytes())?;
            summary.emitted = Some(path.clone());
        }
        Ok(summary)
    }

    /// For plain adaptive precision, the fraction of `images`' pixels re-cast in f64 and
    /// whether on the GPU.
    fn recast(&self, images: &AnyImages) -> Option<(f64, bool)> {
        let plain = self.spp.is_none() && self.precision == Some(Precision::Adaptive);
        match images {
            AnyImages::F32(i) if plain => i.recast_fraction.map(|f| (f, i.recast_on_gpu)),
            _ => None,
        }
    }

    /// The files of this render, its shade hook and kernel file read and checked: the same
    /// for every scene and view it renders.
    pub(crate) fn load_files(&self) -> Result<Files> {
        Ok(Files {
            shade: requested_hook(self.lit, self.shader.as_deref())?,
            kernel: (self.kernel.as_deref().map(UserKernel::load)).transpose()?,
        })
    }

    /// The options of this (resolved) render, with its `files`.
    fn options(&self, files: &Files) -> RenderOptions {
        RenderOptions {
            precision: self.precision,
            algorithm: self.algorithm,
            outputs: self.encoding.outputs,
            samples_per_pixel: self.spp,
            shade: files.shade.clone(),
            kernel: files.kernel.clone(),
            ..RenderOptions::default()
        }
    }

    /// The device this (resolved) render of `scene` with `options` runs on; a kernel file
    /// whose bindings do not fit `scene` is refused here, before the output folder is made.
    fn device_for<'g>(
        &self,
        options: &RenderOptions,
        gpu: Option<&'g Gpu>,
        scene: &Scene,
    ) -> Result<Option<&'g Gpu>> {
        let gpu = match self.device {
            Device::Gpu => {
                Some(gpu.ok_or_else(|| Error::Device("a GPU render needs a device".into()))?)
            }
            Device::Cpu => None,
        };
        if let (Some(_), Some(g)) = (&options.kernel, gpu) {
            g.kernel_source(scene, options)?;
        }
        Ok(gpu)
    }

    /// Whether this (resolved) render goes in bands, written as they come.
    fn in_bands(&self, huge: bool) -> bool {
        self.device == Device::Gpu && self.streamable() && (huge || self.band_rows.is_some())
    }

    /// The render of the images [`RenderFiles::run_loaded`] writes, begun, for a caller that
    /// writes them itself (with [`AnyImages::encode`], the same bytes); `None` for a render
    /// that goes in bands, which only `run_loaded` writes. `files` holds this render's
    /// [`RenderFiles::load_files`] once made, for the renders that follow.
    pub(crate) fn begin_images(
        &self,
        gpu: Option<&Gpu>,
        scene: &Scene,
        files: &mut Option<Files>,
    ) -> Result<Option<Whole>> {
        let huge = pixels(&scene.camera) > STREAM_PIXELS;
        let resolved = self.resolved(huge);
        if resolved.in_bands(huge) {
            return Ok(None);
        }
        let files = match files {
            Some(files) => files,
            None => files.insert(resolved.load_files()?),
        };
        resolved.check_resolved_memory(scene.camera.resolution, huge, files)?;
        let options = resolved.options(files);
        Ok(Some(match resolved.device_for(&options, gpu, scene)? {
            Some(g) => Whole::Device(g.begin(scene, &options)?),
            None => Whole::Done(Cpu.render(scene, &options)?),
        }))
    }
}

/// A render's shade hook and kernel file, read and checked.
#[derive(Clone, Debug)]
pub(crate) struct Files {
    shade: Option<ShadeHook>,
    kernel: Option<UserKernel>,
}

/// A whole render begun ([`RenderFiles::begin_images`]): on the device, or done on the host.
pub(crate) enum Whole {
    Device(Begun),
    Done(AnyImages),
}

/// The whole image of `scene`, on `gpu` or else the CPU.
fn render_whole(scene: &Scene, gpu: Option<&Gpu>, options: &RenderOptions) -> Result<AnyImages> {
    match gpu {
        Some(g) => g.render(scene, options),
        None => Cpu.render(scene, options),
    }
}

/// Pixels of `camera`'s image.
fn pixels(camera: &raycast::Camera) -> u64 {
    let [nx, ny] = camera.resolution;
    u64::from(nx) * u64::from(ny)
}

#[cfg(test)]
mod tests {
    use super::*;
    use raycast::Format;

    /// A render in `mode`, its precision left to the default where `default_precision`.
    fn spec(mode: &str, default_precision: bool) -> RenderFiles {
        let mode: Mode = mode.parse().unwrap();
        RenderFiles {
            scene: None,
            size: None,
            device: mode.device,
            precision: (!default_precision).then_some(mode.precision),
            algorithm: mode.algorithm,
            spp: None,
            band_rows: None,
            shader: None,
            lit: false,
            kernel: None,
            out_dir: PathBuf::from("out"),
            encoding: Encoding::new(&[Format::Png], None).unwrap(),
            emit_shader: None,
            view: CameraOverrides::default(),
            split: Split::default(),
        }
    }

    #[test]
    fn the_default_precision_is_adaptive_where_one_render_path_allows_it() {
        let resolved = |s: &RenderFiles, huge| s.resolved_mode(huge).to_string();
        let gpu = spec("gpu", true);
        assert_eq!(resolved(&gpu, false), "gpu:adaptive:robust");
        assert_eq!(
            resolved(&spec("gpu:f32:textbook", true), false),
            "gpu:f32:textbook"
        );
        assert_eq!(resolved(&spec("cpu", true), false), "cpu:f64:robust");
        // One kernel, or bands: f32.
        assert_eq!(resolved(&gpu, true), "gpu:f32:robust");
        let with = |f: fn(&mut RenderFiles)| {
            let mut s = gpu.clone();
            f(&mut s);
            resolved(&s, false)
        };
        assert_eq!(with(|s| s.shader = Some("a.wgsl".into())), "gpu:f32:robust");
        assert_eq!(with(|s| s.kernel = Some("k.wgsl".into())), "gpu:f32:robust");
        assert_eq!(
            with(|s| s.emit_shader = Some("k.wgsl".into())),
            "gpu:f32:robust"
        );
        assert_eq!(with(|s| s.band_rows = Some(7)), "gpu:f32:robust");
        // Supersampled renders are never banded: a huge one stays adaptive.
        let mut spp = gpu.clone();
        spp.spp = Some(4);
        assert_eq!(resolved(&spp, true), "gpu:adaptive:robust");
        // A precision asked for is kept.
        let mut shaded = spec("gpu:f64", false);
        shaded.shader = Some("a.wgsl".into());
        assert_eq!(resolved(&shaded, true), "gpu:f64:robust");
    }
}
