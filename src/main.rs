//! `raycast`: the command-line front end of the library.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use raycast::error::Result;
use raycast::gpu::layout::GpuReal;
use raycast::gpu::{self, Gpu};
use raycast::math::Precision;
use raycast::output::{self, Format};
use raycast::scene::Scene;

#[derive(Parser)]
#[command(
    name = "raycast",
    version,
    about = "GPU compute-shader ray caster (wgpu/WGSL)"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene to id, depth and normal images.
    Render {
        /// Scene file (JSON). Without it, the built-in default scene is rendered.
        scene: Option<PathBuf>,
        /// Output folder (created if missing).
        #[arg(short, long, default_value = "out")]
        output: PathBuf,
        /// Image size in pixels, e.g. 1920x1080 (overrides the scene's resolution).
        #[arg(long, value_parser = parse_size)]
        size: Option<[u32; 2]>,
        /// Comma-separated output formats: png, ppm, npy.
        #[arg(long, value_delimiter = ',', default_value = "png")]
        format: Vec<Format>,
        /// Arithmetic precision of the kernel: f32, or f64 where the GPU supports it.
        #[arg(long, default_value = "f32")]
        precision: Precision,
    },
    /// Show the GPU adapter, driver, and the features and limits raycast uses.
    Info,
}

fn parse_size(s: &str) -> std::result::Result<[u32; 2], String> {
    let err = || format!("expected WIDTHxHEIGHT such as 640x360, got `{s}`");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(err)?;
    let w: u32 = w.trim().parse().map_err(|_| err())?;
    let h: u32 = h.trim().parse().map_err(|_| err())?;
    if w == 0 || h == 0 {
        return Err(format!("image size must be at least 1x1, got `{s}`"));
    }
    Ok([w, h])
}

fn main() -> ExitCode {
    quiet_mesa();
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        // A bad option value is one line like every other error, without clap's
        // "For more information" footer; help, usage and other errors stay clap's own.
        Err(e) if e.kind() == clap::error::ErrorKind::ValueValidation => {
            let text = e.render().to_string();
            eprintln!("{}", text.lines().next().unwrap_or_default());
            return ExitCode::from(2);
        }
        Err(e) => e.exit(),
    };
    match run(cli.command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}

/// Mesa's device-select layer prints "XDG_RUNTIME_DIR is invalid" lines on headless machines;
/// raycast chooses its adapter itself, so the layer is not needed.
fn quiet_mesa() {
    if std::env::var_os("NODEVICE_SELECT").is_none() {
        // SAFETY: called first thing in main, before any other thread exists.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
}

fn run(command: Command) -> Result<()> {
    match command {
        Command::Render {
            scene,
            output,
            size,
            format,
            precision,
        } => render(scene.as_deref(), &output, size, &format, precision),
        Command::Info => {
            let gpu = Gpu::new()?;
            print!("{}", gpu::describe(&gpu));
            Ok(())
        }
    }
}

fn render_and_write<R: GpuReal>(
    gpu: &Gpu,
    scene: &Scene,
    out_dir: &Path,
    formats: &[Format],
) -> Result<Vec<PathBuf>> {
    let images = gpu::render::<R>(gpu, scene)?;
    output::write_images(&images, out_dir, formats)
}

fn render(
    scene_path: Option<&Path>,
    out_dir: &Path,
    size: Option<[u32; 2]>,
    formats: &[Format],
    precision: Precision,
) -> Result<()> {
    let mut scene = match scene_path {
        Some(path) => Scene::load(path)?,
        None => Scene::default_scene(),
    };
    if let Some(size) = size {
        scene.camera.resolution = size;
    }
    output::check_writable(out_dir)?;
    let gpu = Gpu::new()?;
    let start = std::time::Instant::now();
    let written = match precision {
        Precision::F32 => render_and_write::<f32>(&gpu, &scene, out_dir, formats)?,
        Precision::F64 => render_and_write::<f64>(&gpu, &scene, out_dir, formats)?,
    };
    let [nx, ny] = scene.camera.resolution;
    println!(
        "rendered {} ({nx}x{ny}, {precision}) on {} in {:.3} s",
        scene_path.map_or("the default scene".into(), |p| p.display().to_string()),
        gpu.info().name,
        start.elapsed().as_secs_f64()
    );
    for path in written {
        println!("wrote {}", path.display());
    }
    Ok(())
}
