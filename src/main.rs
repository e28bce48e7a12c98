//! `raycast`: the command-line front end of the library.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use raycast::Algorithm;
use raycast::compare;
use raycast::error::Result;
use raycast::gpu::{self, Gpu};
use raycast::images::{Output, Outputs};
use raycast::output::{self, Format};
use raycast::prepare::bvh::Accel;
use raycast::render::{self, AnyImages, Arithmetic, Device, Mode};
use raycast::scene::Scene;
use raycast::study::{self, Stream};
use raycast::supersample;

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
        /// Where to render: the WGSL kernel on the GPU, or the CPU reference.
        #[arg(long, default_value = "gpu")]
        device: Device,
        /// Arithmetic: f32, f64 (on the GPU it needs SHADER_F64), or adaptive (GPU, robust:
        /// f32 with uncertain pixels cast again in f64). Default: f32 on the GPU, f64 on the CPU.
        #[arg(long)]
        precision: Option<Arithmetic>,
        /// Intersection algorithms: robust (camera-relative, watertight) or textbook (the
        /// lecture's formulas in world coordinates).
        #[arg(long, default_value = "robust")]
        algorithm: Algorithm,
        /// Samples per pixel, a perfect square s*s (1, 4, 9, 16, 64, 256, ...): one at the
        /// centre of each of s x s strata; id by majority, coverage alpha. Adds alpha.npy to npy.
        #[arg(long, value_name = "N", value_parser = parse_spp)]
        spp: Option<u32>,
        /// Composite color.png over this opaque colour, R,G,B in 0..255 (default: transparent,
        /// premultiplied alpha).
        #[arg(long, value_name = "R,G,B", value_parser = parse_background)]
        background: Option<[u8; 3]>,
        /// Also write the assembled WGSL kernel this render ran (specialised for the scene and
        /// the mode) to this file.
        #[arg(long, value_name = "FILE")]
        emit_shader: Option<PathBuf>,
        /// Run this complete WGSL kernel (as --emit-shader writes it, possibly edited) instead
        /// of the assembled one; its bindings must be those of the kernel this render would
        /// assemble (GPU, f32 or f64).
        #[arg(long, value_name = "FILE")]
        kernel: Option<PathBuf>,
        /// Comma-separated outputs to compute and write: id, distance, normal, color (color.png,
        /// png only). Default: every output the formats write.
        #[arg(long, value_name = "LIST", value_delimiter = ',')]
        outputs: Option<Vec<Output>>,
        /// Shade hook: a WGSL file defining `fn shade(hit: ShadeHit) -> vec4<f32>`, called for
        /// every pixel, misses too, to colour color.png (GPU, f32 or f64).
        #[arg(long, value_name = "FILE")]
        shader: Option<PathBuf>,
        /// After rendering, watch the scene file, its meshes, the shader and kernel files and render
        /// again when one changes (polled every 200 ms); errors are printed and watching goes
        /// on. Ctrl-C ends it.
        #[arg(long)]
        watch: bool,
        /// Render and write in bands of at most this many rows, holding one band at a time
        /// (GPU, f32 or f64, without --spp). Images above 16.7 million pixels always are, in
        /// bands of about four million pixels.
        #[arg(long, value_name = "ROWS", value_parser = clap::value_parser!(u32).range(1..))]
        band_rows: Option<u32>,
    },
    /// Render a scene two ways and print how they differ, as one JSON object.
    Compare {
        /// Scene file (JSON).
        scene: PathBuf,
        /// Image size in pixels (overrides the scene's resolution).
        #[arg(long, value_parser = parse_size)]
        size: Option<[u32; 2]>,
        /// First render, DEVICE[:PRECISION][:ALGORITHM].
        #[arg(long, default_value = "gpu:f32:robust")]
        a: Mode,
        /// Second render, the reference for relative errors.
        #[arg(long, default_value = "cpu:f64:robust")]
        b: Mode,
        /// Render side b from this scene instead (same camera size), to compare two scenes.
        #[arg(long)]
        b_scene: Option<PathBuf>,
        /// Also write mismatch.png and distance_error.png into this folder.
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Exit with code 1 when a metric exceeds its bound, e.g. hit_mismatch=0,distance.rel_max=1e-5.
        #[arg(long, value_delimiter = ',', value_parser = compare::parse_bound)]
        fail_above: Vec<(String, f64)>,
    },
    /// Render scenes in every mode and print a markdown table of each against a reference.
    Accuracy {
        /// Scene files (JSON).
        #[arg(required = true)]
        scenes: Vec<PathBuf>,
        /// Image size in pixels (overrides every scene's resolution).
        #[arg(long, value_parser = parse_size)]
        size: Option<[u32; 2]>,
        /// The mode every other is compared with, DEVICE[:PRECISION][:ALGORITHM].
        #[arg(long, default_value = "cpu:f64:robust")]
        reference: Mode,
        /// Comma-separated modes. Default: gpu|cpu x f32|f64 x textbook|robust, GPU f64 only
        /// where the adapter has SHADER_F64.
        #[arg(long, value_delimiter = ',')]
        modes: Option<Vec<Mode>>,
        /// Also write the table, with what generated it and the scenes' comments, to this file.
        #[arg(long)]
        markdown: Option<PathBuf>,
    },
    /// Time and error of every mode the device supports, against CPU f64 robust: writes
    /// tradeoff.csv, tradeoff.md and tradeoff.png into DIR.
    Tradeoff {
        /// Scene files (JSON).
        #[arg(required = true)]
        scenes: Vec<PathBuf>,
        /// Image size in pixels (overrides every scene's resolution).
        #[arg(long, value_parser = parse_size)]
        size: Option<[u32; 2]>,
        /// Timed runs per mode, after one warm-up run; the median is reported.
        #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..))]
        runs: u32,
        /// Comma-separated sample counts at which gpu:f32:robust is also measured (against
        /// cpu:f64:robust at 64 spp); every mode is measured at 1.
        #[arg(long, value_name = "LIST", value_delimiter = ',', default_value = "1,4,16", value_parser = parse_spp)]
        spp: Vec<u32>,
        /// Output folder (created if missing).
        #[arg(short, long, value_name = "DIR")]
        output: PathBuf,
    },
    /// Time each kernel specialisation on each scene, with it and with it turned off
    /// (interleaved, median of --runs GPU kernel times), and the BVH crossover; print the
    /// markdown and write it to --out.
    Specializations {
        /// Scene files, or folders of scene files (their *.json, in name order).
        #[arg(long, value_name = "DIR_OR_FILES", num_args = 1.., default_value = study::specialize::DEFAULT_SCENES)]
        scenes: Vec<PathBuf>,
        /// The 518,400-triangle torus of benches/peers.sh. Default: target/bench/torus.json
        /// where it exists (else the table says it was not measured).
        #[arg(long, value_name = "FILE")]
        torus: Option<PathBuf>,
        /// Timed rounds, after one warm-up round; the median is reported.
        #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..))]
        runs: u32,
        /// Leave out the BVH crossover measurement (random spheres and triangles, n = 2..256).
        #[arg(long)]
        no_crossover: bool,
        /// The markdown file to write (whole or not at all).
        #[arg(long, value_name = "FILE", default_value = "docs/specializations.md")]
        out: PathBuf,
    },
    /// Check a shade hook file (see render --shader) without rendering: prints `FILE: ok` or
    /// the error, with its line and column.
    CheckShader {
        /// WGSL file defining `fn shade(hit: ShadeHit) -> vec4<f32>`.
        file: PathBuf,
    },
    /// Time the stages of a frame (build, upload, trace) and the primary-ray rate, per mode and
    /// acceleration: median of N runs after one warm-up.
    Bench {
        /// Scene file (JSON).
        scene: PathBuf,
        /// Image size in pixels (overrides the scene's resolution).
        #[arg(long, value_parser = parse_size)]
        size: Option<[u32; 2]>,
        /// Timed runs per configuration, after one warm-up run; the median is reported.
        #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..))]
        runs: u32,
        /// Print one JSON object per configuration, one per line, and nothing else on stdout.
        #[arg(long)]
        json: bool,
        /// Comma-separated modes, DEVICE[:PRECISION][:ALGORITHM] (not adaptive).
        #[arg(long, value_delimiter = ',', default_value = "gpu:f32:robust")]
        mode: Vec<Mode>,
        /// Comma-separated accelerations: auto (a BVH where spheres / 32 + triangles / 8 >= 1),
        /// bvh, brute-force.
        #[arg(long, value_delimiter = ',', default_value = "auto")]
        accel: Vec<Accel>,
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

/// `--spp N`: a perfect square (see [`supersample::side`]).
fn parse_spp(s: &str) -> std::result::Result<u32, String> {
    let n: u32 = s
        .trim()
        .parse()
        .map_err(|_| format!("expected a whole number of samples per pixel, got `{s}`"))?;
    supersample::side(n).map(|_| n)
}

/// `--background R,G,B`, each 0..255.
fn parse_background(s: &str) -> std::result::Result<[u8; 3], String> {
    let err = || {
        format!("expected R,G,B with each of the three in 0..255, such as 255,255,255, got `{s}`")
    };
    let parts: Vec<&str> = s.split(',').collect();
    if parts.len() != 3 {
        return Err(err());
    }
    let mut rgb = [0u8; 3];
    for (c, part) in rgb.iter_mut().zip(parts) {
        *c = part.trim().parse().map_err(|_| err())?;
    }
    Ok(rgb)
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
        Ok(code) => code,
        Err(e) => {
            report(&e);
            ExitCode::from(2)
        }
    }
}

/// Prints an error on stderr: one `error: ` line, or a shader error's own block (which says
/// `error:` after its location, as compilers do).
fn report(e: &raycast::Error) {
    match e {
        raycast::Error::Shader { .. } => eprintln!("{e}"),
        _ => eprintln!("error: {e}"),
    }
}

/// Prints a line on stdout. A closed stdout (`raycast ... | head -1`) is not an error worth a
/// panic: the output is simply not wanted any more.
fn say(line: impl std::fmt::Display) {
    use std::io::Write;
    let _ = writeln!(std::io::stdout().lock(), "{line}");
}

/// Mesa's device-select layer prints "XDG_RUNTIME_DIR is invalid" lines on headless machines;
/// raycast chooses its adapter itself, so the layer is not needed.
fn quiet_mesa() {
    if std::env::var_os("NODEVICE_SELECT").is_none() {
        // SAFETY: called first thing in main, before any other thread exists.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
}

fn run(command: Command) -> Result<ExitCode> {
    match command {
        Command::Render {
            scene,
            output,
            size,
            format,
            device,
            precision,
            algorithm,
            spp,
            background,
            emit_shader,
            kernel,
            outputs,
            shader,
            watch,
            band_rows,
        } => {
            let mode = Mode {
                device,
                precision: precision.unwrap_or(device.default_precision()),
                algorithm,
            };
            render(&RenderArgs {
                scene_path: scene.as_deref(),
                out_dir: &output,
                size,
                formats: &format,
                mode,
                spp,
                background,
                emit_shader: emit_shader.as_deref(),
                kernel: kernel.as_deref(),
                outputs: outputs.as_deref(),
                shader: shader.as_deref(),
                watch,
                band_rows,
            })?;
            Ok(ExitCode::SUCCESS)
        }
        Command::Compare {
            scene,
            size,
            a,
            b,
            b_scene,
            output,
            fail_above,
        } => compare(
            &scene,
            b_scene.as_deref(),
            size,
            [a, b],
            output.as_deref(),
            &fail_above,
        ),
        Command::Accuracy {
            scenes,
            size,
            reference,
            modes,
            markdown,
        } => {
            let markdown = markdown.as_deref();
            study::accuracy::command(&scenes, size, reference, modes, markdown, say_on)?;
            Ok(ExitCode::SUCCESS)
        }
        Command::Tradeoff {
            scenes,
            size,
            runs,
            spp,
            output,
        } => {
            study::tradeoff::command(&scenes, size, runs as usize, spp, &output, say_on)?;
            Ok(ExitCode::SUCCESS)
        }
        Command::Specializations {
            scenes,
            torus,
            runs,
            no_crossover,
            out,
        } => {
            let (torus, runs) = (torus.as_deref(), runs as usize);
            study::specialize::command(&scenes, torus, runs, !no_crossover, &out, say_on)?;
            Ok(ExitCode::SUCCESS)
        }
        Command::CheckShader { file } => {
            gpu::hooks::load(&file)?;
            say(format!("{}: ok", file.display()));
            Ok(ExitCode::SUCCESS)
        }
        Command::Bench {
            scene,
            size,
            runs,
            json,
            mode,
            accel,
        } => {
            let options = study::bench::Options {
                runs: runs as usize,
                modes: mode,
                accels: accel,
            };
            study::bench::command(&scene, size, options, json, say_on)?;
            Ok(ExitCode::SUCCESS)
        }
        Command::Info => {
            let gpu = Gpu::new()?;
            say(gpu::describe(&gpu).trim_end());
            Ok(ExitCode::SUCCESS)
        }
    }
}

fn load(path: Option<&Path>, size: Option<[u32; 2]>) -> Result<Scene> {
    let mut scene = match path {
        Some(path) => Scene::load(path)?,
        None => Scene::default_scene(),
    };
    if let Some(size) = size {
        scene.camera.resolution = size;
    }
    Ok(scene)
}

/// Opens the GPU only when some mode needs it.
fn gpu_for(modes: &[Mode]) -> Result<Option<Gpu>> {
    if modes.iter().any(|m| m.device == Device::Gpu) {
        Ok(Some(Gpu::new()?))
    } else {
        Ok(None)
    }
}

/// What `raycast render` was asked for.
struct RenderArgs<'a> {
    scene_path: Option<&'a Path>,
    out_dir: &'a Path,
    size: Option<[u32; 2]>,
    formats: &'a [Format],
    mode: Mode,
    spp: Option<u32>,
    background: Option<[u8; 3]>,
    emit_shader: Option<&'a Path>,
    kernel: Option<&'a Path>,
    /// `--outputs`, when given.
    outputs: Option<&'a [Output]>,
    shader: Option<&'a Path>,
    watch: bool,
    band_rows: Option<u32>,
}

/// The outputs a render computes and writes: those of `--outputs`, else every output the
/// formats write (color only with png). Colour without png is an error.
fn chosen_outputs(list: Option<&[Output]>, formats: &[Format]) -> Result<Outputs> {
    let png = formats.contains(&Format::Png);
    let Some(list) = list else {
        return Ok(Outputs {
            color: png,
            ..Outputs::ALL
        });
    };
    let outputs = Outputs::of(list);
    if outputs.color && !png {
        return Err(raycast::Error::Argument {
            option: "--outputs color".into(),
            message: "color is written as color.png only; add png to --format".into(),
        });
    }
    Ok(outputs)
}

/// The kernel a GPU render in `mode` at `spp` samples per pixel runs first (for adaptive
/// precision: its f32 certainty pass, which writes every output), specialised for `scene` and
/// `request`.
fn kernel_for(
    gpu: &Gpu,
    scene: &Scene,
    mode: Mode,
    request: &render::Request,
    spp: u32,
) -> Result<raycast::gpu::shader::Variant> {
    if mode.precision == Arithmetic::Adaptive {
        let precision = raycast::math::Precision::F32;
        return Ok(raycast::gpu::shader::Variant {
            certainty: true,
            ..gpu.scene_variant(scene, precision, mode.algorithm)
        });
    }
    supersample::sample_request(request, spp).kernel_variant(gpu, scene, mode)
}

/// The option combinations `render` refuses, before anything is read.
fn check_render_args(args: &RenderArgs) -> Result<()> {
    let refuse = |option: &str, message: &str| {
        Err(raycast::Error::Argument {
            option: option.into(),
            message: message.into(),
        })
    };
    let gpu = args.mode.device == Device::Gpu;
    if args.emit_shader.is_some() && !gpu {
        return refuse(
            "--emit-shader",
            "the CPU reference runs no shader; use --device gpu",
        );
    }
    if args.watch && args.scene_path.is_none() && args.shader.is_none() && args.kernel.is_none() {
        return refuse(
            "--watch",
            "nothing to watch: the built-in scene has no file; give a scene file, --shader or --kernel",
        );
    }
    if args.kernel.is_some() {
        if !gpu {
            return refuse(
                "--kernel",
                "the CPU reference runs no shader; use --device gpu",
            );
        }
        if args.mode.precision == Arithmetic::Adaptive {
            return refuse(
                "--kernel",
                "runs with --precision f32 or f64 (adaptive precision runs two kernels)",
            );
        }
    }
    if args.shader.is_some() {
        if !gpu {
            return refuse(
                "--shader",
                "the CPU reference runs no shader; use --device gpu",
            );
        }
        if args.mode.precision == Arithmetic::Adaptive {
            return refuse("--shader", "runs with --precision f32 or f64, not adaptive");
        }
        if args.background.is_some() {
            return refuse(
                "--background",
                "a shade hook colours the background itself (it is called for misses too)",
            );
        }
        if !chosen_outputs(args.outputs, args.formats)?.color {
            return refuse(
                "--shader",
                "the hook colours color.png, which is not asked for; add png to --format and color to --outputs",
            );
        }
    }
    Ok(())
}

fn render(args: &RenderArgs) -> Result<()> {
    check_render_args(args)?;
    let outputs = chosen_outputs(args.outputs, args.formats)?;
    if !args.watch {
        let gpu = gpu_for(&[args.mode])?;
        return render_once(args, outputs, gpu.as_ref());
    }
    // One device for every render, so kernels compiled once stay cached.
    let gpu = gpu_for(&[args.mode])?;
    loop {
        let files = watched_files(args);
        // Taken before rendering: a change during the render triggers the next one.
        let before = stamps(&files);
        if let Err(e) = render_once(args, outputs, gpu.as_ref()) {
            report(&e);
        }
        let names: Vec<String> = files.iter().map(|p| p.display().to_string()).collect();
        eprintln!("watching {} for changes (Ctrl-C ends)", names.join(", "));
        while stamps(&files) == before {
            std::thread::sleep(std::time::Duration::from_millis(200));
        }
    }
}

/// A file's modification time and length, `None` while it cannot be read.
type Stamp = Option<(std::time::SystemTime, u64)>;

fn stamps(files: &[PathBuf]) -> Vec<Stamp> {
    files
        .iter()
        .map(|f| {
            let m = std::fs::metadata(f).ok()?;
            Some((m.modified().ok()?, m.len()))
        })
        .collect()
}

/// The files `--watch` polls: the scene file and the meshes it names (as far as it loads),
/// the shader file and the kernel file.
fn watched_files(args: &RenderArgs) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = Vec::new();
    if let Some(scene) = args.scene_path {
        files.push(scene.to_owned());
        if let Ok(loaded) = Scene::load(scene) {
            let base = scene.parent().unwrap_or(Path::new(""));
            for object in &loaded.objects {
                if let raycast::scene::Object::Soup { path, .. } = object {
                    files.push(base.join(path));
                }
            }
        }
    }
    files.extend(args.shader.map(Path::to_owned));
    files.extend(args.kernel.map(Path::to_owned));
    files
}

/// One render: reads the scene and the shader, renders, writes.
fn render_once(args: &RenderArgs, outputs: Outputs, gpu: Option<&Gpu>) -> Result<()> {
    let RenderArgs {
        scene_path,
        out_dir,
        size,
        formats,
        mode,
        spp,
        background,
        emit_shader,
        shader,
        kernel,
        ..
    } = *args;
    let scene = load(scene_path, size)?;
    let shade = shader.map(gpu::hooks::load).transpose()?;
    let kernel = kernel.map(gpu::kernel::load).transpose()?;
    let request = render::Request {
        outputs,
        shade,
        kernel,
    };
    if let (Some(_), Some(g)) = (&request.kernel, gpu) {
        // A kernel whose bindings do not fit is refused before the output folder is made.
        kernel_for(g, &scene, mode, &request, spp.unwrap_or(1))?;
    }
    output::check_writable(out_dir)?;
    if let Some(path) = emit_shader {
        output::check_writable(
            path.parent()
                .filter(|p| !p.as_os_str().is_empty())
                .unwrap_or(Path::new(".")),
        )?;
    }
    let mut recast = None;
    let [nx, ny] = scene.camera.resolution;
    let huge = nx as u64 * ny as u64 > render::STREAM_PIXELS;
    // A kernel file runs through the whole-image path only.
    let can_stream = spp.is_none() && render::can_stream(mode) && request.kernel.is_none();
    if args.band_rows.is_some() && !can_stream {
        return Err(raycast::Error::Argument {
            option: "--band-rows".into(),
            message: "bands are rendered on the GPU in f32 or f64, without --spp or --kernel"
                .into(),
        });
    }
    let streamed = (huge || args.band_rows.is_some()) && can_stream;
    if let (true, Some(g)) = (streamed, gpu) {
        let rows = args.band_rows.unwrap_or(render::band_rows(nx));
        let mut writer =
            output::stream::BandWriter::new(out_dir, [nx, ny], formats, outputs, background);
        let (done, elapsed) = render::timed(|| {
            render::render_streamed(&scene, mode, g, &request, rows, &mut |band| match band {
                render::AnyImages::F32(i) => {
                    writer.write_band(&supersample::Supersampled::from_images(i))
                }
                render::AnyImages::F64(i) => {
                    writer.write_band(&supersample::Supersampled::from_images(i))
                }
            })
        });
        done?;
        let written = writer.finish()?;
        if let Some(path) = emit_shader {
            let variant = kernel_for(g, &scene, mode, &request, 1)?;
            let source = raycast::gpu::shader::kernel_source(&variant)?;
            output::write_file(path, source.as_bytes())?;
        }
        let peak = study::bench::peak_rss_mib()
            .map_or(String::new(), |m| format!(", peak memory {m:.0} MiB"));
        say(format!(
            "rendered {} ({nx}x{ny} in bands of {rows} rows, {mode}) on {} in {:.3} s{peak}",
            scene_path.map_or("the default scene".into(), |p| p.display().to_string()),
            g.info().name,
            elapsed.as_secs_f64()
        ));
        for path in written {
            say(format!("wrote {}", path.display()));
        }
        return Ok(());
    }
    let (images, elapsed) = render::timed(|| match (mode.precision, spp, gpu) {
        // Plain adaptive renders report how much they re-cast in f64.
        (Arithmetic::Adaptive, None, Some(g)) if mode.algorithm == Algorithm::Robust => {
            let a = raycast::adaptive::render_adaptive(g, &scene)?;
            recast = Some((a.recast_fraction(), a.recast_on_gpu));
            Ok(supersample::AnySupersampled::F32(
                supersample::Supersampled::from_images(a.images),
            ))
        }
        _ => {
            let spp = spp.unwrap_or(1);
            supersample::supersample_request(&scene, mode, gpu, spp, true, &request)
        }
    });
    let written = images?.write(out_dir, formats, outputs, background, spp.is_some())?;
    let on = gpu.map_or("the CPU".to_owned(), |g| g.info().name);
    let samples = spp.map_or(String::new(), |n| format!(", {n} spp"));
    let shaded = shader.map_or(String::new(), |p| format!(", shaded by {}", p.display()));
    say(format!(
        "rendered {} ({nx}x{ny}{samples}, {mode}{shaded}) on {on} in {:.3} s",
        scene_path.map_or("the default scene".into(), |p| p.display().to_string()),
        elapsed.as_secs_f64()
    ));
    if let (Some(path), Some(g)) = (emit_shader, gpu) {
        let variant = kernel_for(g, &scene, mode, &request, spp.unwrap_or(1))?;
        let source = raycast::gpu::shader::kernel_source(&variant)?;
        output::write_file(path, source.as_bytes())?;
        say(format!("wrote {}", path.display()));
    }
    if let Some((fraction, on_gpu)) = recast {
        let on = if on_gpu { "the GPU" } else { "the CPU" };
        say(format!(
            "re-cast {:.3}% of pixels in f64 on {on}",
            100.0 * fraction
        ));
    }
    for path in written {
        say(format!("wrote {}", path.display()));
    }
    Ok(())
}

fn compare(
    scene_path: &Path,
    b_scene_path: Option<&Path>,
    size: Option<[u32; 2]>,
    modes: [Mode; 2],
    out_dir: Option<&Path>,
    bounds: &[(String, f64)],
) -> Result<ExitCode> {
    let scene_a = load(Some(scene_path), size)?;
    let mut scene_b = load(Some(b_scene_path.unwrap_or(scene_path)), size)?;
    // Side b must be comparable pixel for pixel.
    scene_b.camera.resolution = scene_a.camera.resolution;
    if let Some(dir) = out_dir {
        output::check_writable(dir)?;
    }
    let gpu = gpu_for(&modes)?;
    let (a, time_a) = render::timed(|| render::render(&scene_a, modes[0], gpu.as_ref(), true));
    let (b, time_b) = render::timed(|| render::render(&scene_b, modes[1], gpu.as_ref(), true));
    let (a, b) = (a?, b?);
    let c = compare::compare(&a, &b);
    let mut json = serde_json::json!({
        "scene": scene_path.display().to_string(),
        "size": scene_a.camera.resolution,
        "a": {"mode": modes[0].to_string(), "time_s": time_a.as_secs_f64()},
        "b": {"mode": modes[1].to_string(), "time_s": time_b.as_secs_f64()},
    });
    if let Some(p) = b_scene_path {
        json["b"]["scene"] = p.display().to_string().into();
    }
    let report = serde_json::to_value(&c.report).expect("a report serialises");
    json.as_object_mut()
        .expect("an object")
        .extend(report.as_object().expect("an object").clone());
    say(json);
    if let Some(dir) = out_dir {
        write_compare_pictures(&c, &b, dir)?;
    }
    let crossed = compare::exceeded(&c.report, bounds);
    for line in &crossed {
        eprintln!("fail-above: {line}");
    }
    Ok(if crossed.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

fn write_compare_pictures(c: &compare::Comparison, b: &AnyImages, dir: &Path) -> Result<()> {
    let base = match b {
        AnyImages::F32(i) => output::pictures(i).normal,
        AnyImages::F64(i) => output::pictures(i).normal,
    };
    let files = [
        ("mismatch.png", compare::mismatch_picture(c, &base)),
        ("distance_error.png", compare::distance_error_picture(c)),
    ]
    .map(|(name, img)| output::EncodedFile {
        name,
        bytes: output::encode_png_rgb(&img),
    });
    for path in output::write_files(dir, &files)? {
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}

/// Prints a study's line on the stream it names.
fn say_on(stream: Stream, line: &str) {
    match stream {
        Stream::Stdout => say(line),
        Stream::Stderr => eprintln!("{line}"),
    }
}
