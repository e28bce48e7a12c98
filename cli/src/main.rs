//! `raycast`: the command-line front end of the library.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use glam::DVec3;
use raycast::Format;
use raycast::Output;
use raycast::{Algorithm, Device, Gpu, Mode, Precision, RenderOptions, Result, Search};
use raycast_cli::render::ModeArg;
use raycast_cli::study::{self, Stream};
use raycast_cli::{compare, progress, watch};

mod allocator;

/// The system's allocator, but a refused allocation ends the command with one line, exit 2.
#[global_allocator]
static ALLOCATOR: allocator::ExitOnFailure = allocator::ExitOnFailure;

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

/// What every command's scene argument takes ([`raycast::load_viewed`]), for its help.
macro_rules! scene_file {
    () => {
        "scene file (JSON), or a mesh file (.obj, .stl, .ply) seen from its default view \
         (docs/cli.md)"
    };
}

// Parsed once per run: the size of the largest variant costs nothing.
#[allow(clippy::large_enum_variant)]
#[derive(Subcommand)]
enum Command {
    /// Render a scene to id, depth and normal images.
    Render {
        #[arg(help = concat!("A ", scene_file!(), ". Without it, the built-in default scene is \
            rendered. With --views or --orbit, any number of them"))]
        scenes: Vec<PathBuf>,
        /// Render every scene from each camera of this views file (a JSON list of cameras of
        /// the scene format, each with a `name`) into OUTPUT/<scene stem>/<name>/, with
        /// OUTPUT/manifest.jsonl (docs/datasets.md).
        #[arg(long, value_name = "FILE", conflicts_with = "orbit")]
        views: Option<PathBuf>,
        /// Render every scene at each pose of this poses file (JSON lines, a frame a line:
        /// its `name`, the `transforms` of the instances it moves, maybe a `camera`) as
        /// --views renders views; the meshes' own trees are built once (docs/datasets.md#poses).
        #[arg(long, value_name = "FILE", conflicts_with_all = ["views", "orbit"])]
        poses: Option<PathBuf>,
        /// Render every scene from N views around its objects (orbit-000, ...), as --views
        /// does: a turntable about the camera's up direction (--up) from where it stands
        /// (--eye), looking at the objects' centre (--look-at), kept on the objects' side of
        /// every plane (docs/datasets.md#orbits).
        #[arg(long, value_name = "N")]
        orbit: Option<u32>,
        /// With --orbit: the eye's distance from the centre (default: far enough for the
        /// objects' box to fit the image; nearer where planes leave less room).
        #[arg(long, value_name = "R", allow_hyphen_values = true)]
        orbit_radius: Option<f64>,
        /// With --orbit: the views' elevation above the turntable's plane, degrees in (-90, 90)
        /// (default: the camera's, within 80).
        #[arg(long, value_name = "DEGREES", allow_hyphen_values = true)]
        orbit_elevation: Option<f64>,
        /// With --views or --orbit: render views whose folder is complete again (they are
        /// skipped otherwise).
        #[arg(long)]
        force: bool,
        /// With --views or --orbit: render shard I of N (0-based) of the views, or `auto`: the
        /// shard of a Slurm array task or a Kubernetes Indexed Job.
        #[arg(long, value_name = "I/N|auto")]
        shard: Option<String>,
        /// The number of shards for --shard auto (a Kubernetes Indexed Job's completions;
        /// a Slurm array's task count by default).
        #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
        shard_count: Option<u32>,
        /// Output folder (created if missing).
        #[arg(short, long, default_value = "out")]
        output: PathBuf,
        /// Image size in pixels, e.g. 1920x1080 (overrides the scene's resolution).
        #[arg(long, value_parser = raycast_cli::parse_size)]
        size: Option<[u32; 2]>,
        /// Comma-separated output formats: png, ppm, npy, npz (render.npz), exr (render.exr),
        /// depth16 (depth16.png). camera.json is written beside every render.
        #[arg(long, value_delimiter = ',', default_value = "png")]
        format: Vec<Format>,
        /// The depth npy, npz, exr and depth16 hold: distance (from the ray's origin,
        /// distance.npy) or z (planar, along the viewing axis, z.npy). Default: distance in
        /// npy, npz and exr, z in depth16 (what RGB-D datasets store).
        #[arg(long, value_name = "distance|z")]
        depth: Option<raycast::Depth>,
        /// depth16.png's levels per scene unit: round(depth * scale), 0 on a miss or beyond
        /// 65535 (1000: millimetres for scenes in metres).
        #[arg(long, value_name = "SCALE", default_value_t = raycast::Encoding::default().depth_scale, value_parser = parse_depth_scale, allow_hyphen_values = true)]
        depth_scale: f64,
        /// The camera's position, X,Y,Z (replaces the scene's, or a mesh's default view's).
        #[arg(long, value_name = "X,Y,Z", value_parser = raycast_cli::parse_vector, allow_hyphen_values = true)]
        eye: Option<DVec3>,
        /// A point for the camera to look at, X,Y,Z.
        #[arg(long, value_name = "X,Y,Z", value_parser = raycast_cli::parse_vector, allow_hyphen_values = true)]
        look_at: Option<DVec3>,
        /// The camera's up direction, X,Y,Z.
        #[arg(long, value_name = "X,Y,Z", value_parser = raycast_cli::parse_vector, allow_hyphen_values = true)]
        up: Option<DVec3>,
        /// Vertical field of view in degrees (replaces the scene's image plane; perspective).
        #[arg(long, value_name = "DEGREES", allow_hyphen_values = true)]
        fov: Option<f64>,
        /// Which parts of an OBJ file given as a scene are objects of their own, each with its
        /// id: objects (each `o`), groups (each `g` of each object) or none (the whole file).
        /// STL and PLY files are one object. Default: objects. A scene file's soups say it
        /// with "split".
        #[arg(long, value_name = "objects|groups|none")]
        split: Option<raycast::Split>,
        /// Where to render: the WGSL kernel on the GPU, or the CPU reference.
        #[arg(long, default_value = "gpu")]
        device: Device,
        /// Arithmetic: f32, f64 (on the GPU it needs SHADER_F64), or adaptive (GPU, robust:
        /// f32 with uncertain pixels cast again in f64: on the CPU where they are few or the
        /// GPU has no f64, else on the GPU).
        /// Default: adaptive on the GPU (f32 with --shader, --kernel, --emit-shader,
        /// --band-rows, the textbook set, or images of more than 16,777,216 pixels, which f32
        /// renders in bands); f64 on the CPU.
        #[arg(long)]
        precision: Option<Precision>,
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
        #[arg(long, value_name = "R,G,B", value_parser = raycast_cli::parse_background)]
        background: Option<[u8; 3]>,
        /// Also write the assembled WGSL kernel this render ran (specialized for the scene and
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
        /// Colour color.png by the course's ray tracer from the scene's materials and lights
        /// (Blinn-Phong, hard shadows, mirror reflections): the shade hook
        /// shaders/examples/raytrace.wgsl on the GPU, its mirror on the CPU (f32 or f64)
        #[arg(long)]
        lit: bool,
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
        #[arg(help = concat!("A ", scene_file!()))]
        scene: PathBuf,
        /// Image size in pixels (overrides the scene's resolution).
        #[arg(long, value_parser = raycast_cli::parse_size)]
        size: Option<[u32; 2]>,
        /// First render, DEVICE[:PRECISION][:ALGORITHM]; a device alone renders in its default
        /// precision, as `raycast render` does (on the GPU adaptive, f32 with --shader or --lit).
        #[arg(long, default_value = "gpu")]
        a: ModeArg,
        /// Second render, the reference for relative errors (`cpu`: cpu:f64:robust).
        #[arg(long, default_value = "cpu")]
        b: ModeArg,
        /// Render side b from this scene (or mesh) instead (same camera size), to compare two
        /// scenes.
        #[arg(long)]
        b_scene: Option<PathBuf>,
        /// Also write mismatch.png and distance_error.png into this folder.
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Exit with code 1 when a metric exceeds its bound, e.g. hit_mismatch=0,distance.rel_max=1e-5.
        #[arg(long, value_delimiter = ',', value_parser = compare::parse_bound)]
        fail_above: Vec<(String, f64)>,
        /// Colour both sides' color.png by this shade hook (GPU sides) and compare them too
        /// (color_error.png).
        #[arg(long, value_name = "FILE")]
        shader: Option<PathBuf>,
        /// Light both sides by the course's ray tracer (the shipped hook on the GPU, its mirror
        /// on the CPU) and compare their color.png too.
        #[arg(long)]
        lit: bool,
    },
    /// Render scenes in every mode and print a markdown table of each against a reference.
    Accuracy {
        #[arg(required = true, help = concat!("Each a ", scene_file!()))]
        scenes: Vec<PathBuf>,
        /// Image size in pixels (overrides every scene's resolution).
        #[arg(long, value_parser = raycast_cli::parse_size)]
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
        #[arg(required = true, help = concat!("Each a ", scene_file!()))]
        scenes: Vec<PathBuf>,
        /// Image size in pixels (overrides every scene's resolution).
        #[arg(long, value_parser = raycast_cli::parse_size)]
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
    /// Time each kernel specialization on each scene, with it and with it turned off
    /// (interleaved, median of --runs GPU kernel times), and the BVH crossover; print the
    /// markdown (and write it to --output).
    Specializations {
        #[arg(long, value_name = "DIR_OR_FILES", num_args = 1.., default_value = study::specializations::DEFAULT_SCENES,
            help = concat!("Each a ", scene_file!(), ", or a folder of scene files (its *.json, in name order)"))]
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
        /// Also write the markdown to this file (whole or not at all), e.g.
        /// docs/specializations.md.
        #[arg(short, long, value_name = "FILE", alias = "out")]
        output: Option<PathBuf>,
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
        #[arg(help = concat!("A ", scene_file!()))]
        scene: PathBuf,
        /// Image size in pixels (overrides the scene's resolution).
        #[arg(long, value_parser = raycast_cli::parse_size)]
        size: Option<[u32; 2]>,
        /// Timed runs per configuration, after one warm-up run; the median is reported.
        #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..))]
        runs: u32,
        /// Print one JSON object per configuration, one per line, and nothing else on stdout.
        #[arg(long)]
        json: bool,
        /// Comma-separated modes, DEVICE[:PRECISION][:ALGORITHM] (not adaptive; a device alone is
        /// its one-kernel default: gpu:f32, cpu:f64).
        #[arg(long, value_delimiter = ',', default_value = "gpu:f32:robust")]
        mode: Vec<ModeArg>,
        /// Comma-separated accelerations: auto (a BVH where spheres / 32 + triangles / 8 >= 1),
        /// bvh, brute-force.
        #[arg(long, value_delimiter = ',', default_value = "auto")]
        accel: Vec<Search>,
        /// Comma-separated BVH traversals of GPU modes: auto (the device's choice), packets (a
        /// subgroup's rays together, each node fetched once for them), per-ray.
        #[arg(long, value_delimiter = ',', default_value = "auto")]
        traversal: Vec<study::bench::Traversal>,
        /// Run this shade hook in every frame (GPU modes); a hook that casts rays reports them
        /// as secondary rays a second.
        #[arg(long, value_name = "FILE")]
        shader: Option<PathBuf>,
        /// Run the course's ray tracer in every frame (the shipped hook on the GPU, its mirror
        /// on the CPU).
        #[arg(long, conflicts_with = "shader")]
        lit: bool,
        /// Cast this many incoherent rays at the scene's geometry instead of the camera's:
        /// origins uniform in a cube 4/3 the size of its bounds, directions uniform (at most
        /// 67,108,864).
        #[arg(long, value_name = "N", allow_hyphen_values = true, value_parser = clap::value_parser!(u64).range(1..=study::bench::MAX_RAYS as u64))]
        rays: Option<u64>,
        /// Render each run from every camera of this views file instead of the scene's, as
        /// `render --views` renders them; times are summed over the views (docs/cli.md#bench).
        #[arg(long, value_name = "FILE", conflicts_with_all = ["orbit", "rays"])]
        views: Option<PathBuf>,
        /// Render each run from the N views `render --orbit N` renders, the scene's camera the
        /// orbit's start; times are summed over the views (docs/cli.md#bench).
        #[arg(long, value_name = "N", conflicts_with = "rays")]
        orbit: Option<u32>,
        /// With --orbit: the eye's distance from the centre, as for `render --orbit`.
        #[arg(long, value_name = "R", allow_hyphen_values = true)]
        orbit_radius: Option<f64>,
        /// With --orbit: the views' elevation in degrees, as for `render --orbit`.
        #[arg(long, value_name = "DEGREES", allow_hyphen_values = true)]
        orbit_elevation: Option<f64>,
    },
    #[command(about = study::workload::about())]
    Workload {
        #[arg(help = study::workload::help())]
        name: String,
        /// Output folder (created if missing).
        #[arg(short, long, default_value = ".")]
        output: PathBuf,
        /// Image size in pixels.
        #[arg(long, value_parser = raycast_cli::parse_size, default_value = "1920x1080")]
        size: [u32; 2],
        /// The torus's triangles, about (a grid twice as long around as across).
        #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(8..=100_000_000))]
        triangles: Option<u64>,
        /// The instances workload's bunnies (default 1,000).
        #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..=1_000_000))]
        count: Option<u64>,
    },
    /// Serve a live page of a scene's render on this machine: rendered again when the scene,
    /// a mesh or the hook is saved, hook errors shown on the page, the camera moved with the
    /// mouse, the CPU reference and the difference a click away (docs/serve.md). Ctrl-C stops.
    Serve {
        #[arg(help = concat!("A ", scene_file!(), ". Without it, the built-in default scene"))]
        #[arg(value_name = "SCENE_OR_MESH")]
        scene: Option<PathBuf>,
        /// Shade hook colouring the colour tab (see render --shader).
        #[arg(long, value_name = "FILE")]
        shader: Option<PathBuf>,
        /// Colour the colour tab by the course's ray tracer (see render --lit).
        #[arg(long, conflicts_with = "shader")]
        lit: bool,
        /// Full image size in pixels, e.g. 1280x720 (overrides the scene's resolution).
        #[arg(long, value_parser = raycast_cli::parse_size)]
        size: Option<[u32; 2]>,
        /// The GPU's arithmetic: f32, f64 (needs SHADER_F64) or adaptive (without a hook).
        /// Default: as `raycast render`'s, adaptive (f32 with --shader or --lit).
        #[arg(long)]
        precision: Option<Precision>,
        /// The port to listen on (0: any free one; the address is printed).
        #[arg(long, default_value_t = 8421)]
        port: u16,
        /// The address to listen on: this machine only by default; 0.0.0.0 for every network
        /// the machine is on (anyone who reaches it sees the scene and its files' errors).
        #[arg(long, default_value = "127.0.0.1")]
        bind: std::net::IpAddr,
    },
    /// Show the GPU adapter, driver, and the features and limits raycast uses.
    Info,
    /// Render a built-in suite on this adapter and check each result against the CPU
    /// reference: one line per check, then a summary; exit 1 when a check fails.
    Selftest {
        /// Print one JSON object per check, then one with the adapter and the summary, and
        /// nothing else on stdout.
        #[arg(long)]
        json: bool,
        /// Comma-separated parts of check names: run only the checks whose name contains one.
        #[arg(long, value_delimiter = ',', value_name = "NAMES")]
        only: Vec<String>,
        /// Make this check's GPU result wrong in one pixel or ray, to see the check fail.
        #[arg(long, value_name = "CHECK")]
        plant: Option<String>,
    },
}

/// Exit code after SIGINT, SIGTERM or SIGHUP: 128 + SIGINT, as shells report an interrupt.
const INTERRUPTED: i32 = 130;

fn main() -> ExitCode {
    quiet_mesa();
    // A write beyond the file-size limit (`ulimit -f`) then fails with EFBIG, reported and
    // cleaned up like a full disk, instead of killing the process with its files half written.
    #[cfg(unix)]
    // SAFETY: setting a signal's disposition to SIG_IGN, before any other thread exists.
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
    // Stopped by a signal, remove the files being written first: output is all or nothing.
    // A server stops serving and exits normally; so does `render --watch`, whose documented
    // way out is Ctrl-C, quietly (the last whole render stays).
    let stop = || {
        if raycast_cli::serve::stop() {
            return;
        }
        match watch::watching() {
            true => raycast_cli::abandon(0, ""),
            false => raycast_cli::abandon(INTERRUPTED, "error: interrupted; no partial file left"),
        }
    };
    if let Err(e) = ctrlc::set_handler(stop) {
        eprintln!("error: cannot install the interrupt handler: {e}");
        return ExitCode::from(1);
    }
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
            report(e);
            ExitCode::from(2)
        }
    }
}

/// Prints an error on stderr ([`raycast_cli::error_text`]).
fn report(e: raycast::Error) {
    eprintln!("{}", raycast_cli::error_text(e));
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

/// `--spp`: samples per pixel, a perfect square ([`RenderOptions::check`] says why not).
fn parse_spp(s: &str) -> std::result::Result<u32, String> {
    let samples_per_pixel: u32 = s
        .trim()
        .parse()
        .map_err(|_| format!("expected a whole number of samples per pixel, got `{s}`"))?;
    let options = RenderOptions {
        samples_per_pixel: Some(samples_per_pixel),
        ..RenderOptions::default()
    };
    match options.check(Device::Cpu, None) {
        Err(raycast::Error::Argument { message, .. }) => Err(message),
        _ => Ok(samples_per_pixel),
    }
}

/// `--depth-scale`: a positive finite number.
fn parse_depth_scale(s: &str) -> std::result::Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(x) if x.is_finite() && x > 0.0 => Ok(x),
        _ => Err(format!("expected a positive number, got `{s}`")),
    }
}

fn run(command: Command) -> Result<ExitCode> {
    match command {
        Command::Render {
            scenes,
            views,
            poses,
            orbit,
            orbit_radius,
            orbit_elevation,
            force,
            shard,
            shard_count,
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
            lit,
            watch,
            band_rows,
            depth,
            depth_scale,
            eye,
            look_at,
            up,
            fov,
            split,
        } => {
            let mut encoding = raycast::Encoding {
                background,
                depth_scale,
                ..raycast::Encoding::new(&format, outputs.as_deref())?
            };
            if let Some(depth) = depth {
                (encoding.depth, encoding.depth16) = (depth, depth);
            }
            let view = raycast::CameraOverrides {
                eye,
                look_at,
                up,
                fov,
            };
            let (views, view) = views_asked(views, orbit, orbit_radius, orbit_elevation, view)?;
            let views = poses.map(raycast_datasets::Views::Poses).or(views);
            let batch_only = [
                ("--force", force),
                ("--shard", shard.is_some()),
                ("--shard-count", shard_count.is_some()),
            ];
            if let (None, Some((flag, _))) = (&views, batch_only.iter().find(|(_, given)| *given)) {
                return Err(raycast::Error::Argument {
                    option: (*flag).into(),
                    message: "renders many views: give --views, --poses or --orbit".into(),
                });
            }
            if views.is_none() && scenes.len() > 1 {
                return Err(raycast::Error::Argument {
                    option: "scenes".into(),
                    message: format!(
                        "{} scene files given; one is rendered at a time, or many with --views or --orbit; to render meshes together, list them as soups of one scene file",
                        scenes.len()
                    ),
                });
            }
            let spec = raycast_datasets::RenderFiles {
                scene: if views.is_some() {
                    None
                } else {
                    scenes.first().cloned()
                },
                size,
                device,
                precision,
                algorithm,
                spp,
                band_rows,
                shader,
                lit,
                kernel,
                out_dir: output,
                encoding,
                emit_shader,
                view,
                split: split.unwrap_or_default(),
            };
            match views {
                Some(views) => {
                    if watch {
                        let many = match views {
                            raycast_datasets::Views::Orbit(_) => "--orbit",
                            raycast_datasets::Views::Poses(_) => "--poses",
                            _ => "--views",
                        };
                        return Err(raycast::Error::Argument {
                            option: "--watch".into(),
                            message: format!("watches one render; not with {many}"),
                        });
                    }
                    let batch = raycast_datasets::RenderViews {
                        scenes,
                        views,
                        force,
                        render: spec,
                    };
                    render_views(&batch, shard.as_deref(), shard_count)?;
                }
                None => render(&spec, watch)?,
            }
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
            shader,
            lit,
        } => compare(&compare::Spec {
            scene,
            b_scene,
            size,
            modes: [a, b].map(|m| m.resolve(lit || shader.is_some())),
            out_dir: output,
            bounds: fail_above,
            shader,
            lit,
        }),
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
            output,
        } => {
            let (torus, runs, output) = (torus.as_deref(), runs as usize, output.as_deref());
            study::specializations::command(&scenes, torus, runs, !no_crossover, output, say_on)?;
            Ok(ExitCode::SUCCESS)
        }
        Command::CheckShader { file } => {
            raycast::ShadeHook::load(&file)?;
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
            traversal,
            shader,
            lit,
            rays,
            views,
            orbit,
            orbit_radius,
            orbit_elevation,
        } => {
            let shade = raycast_datasets::requested_hook(lit, shader.as_deref())?;
            let camera = Default::default();
            let (views, _) = views_asked(views, orbit, orbit_radius, orbit_elevation, camera)?;
            let options = study::bench::Options {
                runs: runs as usize,
                // A frame is timed as one kernel: never adaptive.
                modes: mode.into_iter().map(|m| m.resolve(true)).collect(),
                accels: accel,
                traversals: traversal,
                shade,
                rays: rays.map(|n| n as usize),
                views,
            };
            study::bench::command(&scene, size, options, json, say_on)?;
            Ok(ExitCode::SUCCESS)
        }
        Command::Serve {
            scene,
            shader,
            lit,
            size,
            precision,
            port,
            bind,
        } => {
            let hooked = lit || shader.is_some();
            let options = raycast_cli::serve::Options {
                scene,
                shader,
                lit,
                size,
                precision: precision.unwrap_or(Precision::default_for(
                    Device::Gpu,
                    Algorithm::Robust,
                    hooked,
                )),
                bind,
                port,
            };
            raycast_cli::serve::run(&options, |url| say(format!("serving {url} (Ctrl-C stops)")))?;
            eprintln!("raycast serve: stopped");
            Ok(ExitCode::SUCCESS)
        }
        Command::Info => {
            let gpu = Gpu::new()?;
            say(raycast_cli::adapter::describe(&gpu).trim_end());
            Ok(ExitCode::SUCCESS)
        }
        Command::Workload {
            name,
            output,
            size,
            triangles,
            count,
        } => {
            let triangles = triangles.map(|n| n as usize);
            let count = count.map(|n| n as usize);
            let path = study::workload::write(&name, &output, size, triangles, count)?;
            say(format!("wrote {}", path.display()));
            Ok(ExitCode::SUCCESS)
        }
        Command::Selftest { json, only, plant } => {
            selftest(&study::selftest::Options { only, plant }, json)
        }
    }
}

/// `raycast selftest`: the checks as they end, then the adapter and the summary.
fn selftest(options: &study::selftest::Options, json: bool) -> Result<ExitCode> {
    use study::selftest;
    let gpu = Gpu::new()?;
    // Refused before the adapter's lines are printed: a bad --only or --plant prints nothing.
    selftest::check_options(&gpu, options)?;
    let adapter = selftest::Adapter::probe(&gpu)?;
    if !json {
        adapter.lines.iter().for_each(say);
    }
    let mut on_check = |check: &selftest::Check| match json {
        true => say(serde_json::to_string(check).expect("a check serialises")),
        false => say(check.line()),
    };
    let report = selftest::run(&gpu, &adapter, options, &mut on_check)?;
    if json {
        let summary = serde_json::json!({
            "summary": {
                "adapter": adapter.lines,
                "passed": report.count(selftest::Outcome::Pass),
                "failed": report.count(selftest::Outcome::Fail),
                "skipped": report.count(selftest::Outcome::Skip),
                "seconds": report.seconds,
            }
        });
        say(summary);
    } else {
        say(report.summary());
    }
    Ok(ExitCode::from(u8::from(!report.passed())))
}

/// Renders once, or with `watch` again whenever a file it reads changes, for ever.
fn render(spec: &raycast_datasets::RenderFiles, watch: bool) -> Result<()> {
    // From the options alone: watch::watched_files would load the scene and its meshes.
    if watch && spec.scene.is_none() && spec.shader.is_none() && spec.kernel.is_none() {
        return Err(raycast::Error::Argument {
            option: "--watch".into(),
            message: "nothing to watch: the built-in scene has no file; give a scene file, --shader or --kernel".into(),
        });
    }
    spec.check()?;
    if watch {
        watch::start();
    }
    // One device for every render, so kernels compiled once stay cached.
    let gpu = raycast_cli::render::gpu_for([spec.device])?;
    let render_once = || {
        let mut summary = progress::cpu_rows(|p| spec.run(gpu.as_ref(), p))?;
        // A render in bands reports the process's peak memory, which the bands keep bounded.
        if summary.bands.is_some() {
            summary.peak_mib = raycast_cli::peak_rss_mib();
        }
        raycast_cli::render::summary_lines(&summary)
            .into_iter()
            .for_each(say);
        Ok(())
    };
    if !watch {
        return render_once();
    }
    loop {
        let files = watch::watched_files(
            spec.scene.as_deref(),
            spec.shader.as_deref(),
            spec.kernel.as_deref(),
        );
        // Taken before rendering: a change during the render triggers the next one.
        let before = watch::stamps(&files);
        if let Err(e) = render_once() {
            report(e);
        }
        let names: Vec<String> = files.iter().map(|p| p.display().to_string()).collect();
        eprintln!("watching {} for changes (Ctrl-C ends)", names.join(", "));
        while watch::stamps(&files) == before {
            std::thread::sleep(std::time::Duration::from_millis(200));
        }
    }
}

/// The views `--views FILE` or `--orbit N` (with `--orbit-radius`, `--orbit-elevation`) ask
/// for, if any, and the camera settings left for the render: an orbit starts from them, a views
/// file's cameras are refused them (by the render).
fn views_asked(
    file: Option<PathBuf>,
    orbit: Option<u32>,
    radius: Option<f64>,
    elevation: Option<f64>,
    camera: raycast::CameraOverrides,
) -> Result<(Option<raycast_datasets::Views>, raycast::CameraOverrides)> {
    let orbit_only = [
        ("--orbit-radius", radius.is_some()),
        ("--orbit-elevation", elevation.is_some()),
    ];
    if let (None, Some((flag, _))) = (orbit, orbit_only.iter().find(|(_, given)| *given)) {
        return Err(raycast::Error::Argument {
            option: (*flag).into(),
            message: "sets an orbit's views: give --orbit".into(),
        });
    }
    Ok(match (file, orbit) {
        (Some(file), _) => (Some(raycast_datasets::Views::File(file)), camera),
        (None, Some(views)) => {
            let orbit = raycast::Orbit {
                views,
                radius,
                elevation,
                camera,
            };
            (
                Some(raycast_datasets::Views::Orbit(orbit)),
                Default::default(),
            )
        }
        (None, None) => (None, camera),
    })
}

/// `raycast render --views | --orbit`: every view of the shard, with a progress bar of views
/// on a terminal.
fn render_views(
    batch: &raycast_datasets::RenderViews,
    shard: Option<&str>,
    count: Option<u32>,
) -> Result<()> {
    let shard = match shard {
        None => None,
        Some("auto") => Some(raycast_cli::render::shard_from_env(count)?),
        Some(text) => {
            if count.is_some() {
                return Err(raycast::Error::Argument {
                    option: "--shard-count".into(),
                    message: "goes with --shard auto; --shard I/N gives the count".into(),
                });
            }
            Some(text.parse().map_err(|message| raycast::Error::Argument {
                option: "--shard".into(),
                message,
            })?)
        }
    };
    batch.check()?;
    let gpu = raycast_cli::render::gpu_for([batch.render.device])?;
    let bar = progress::views_bar();
    let summary = batch.run(gpu.as_ref(), shard, &mut |done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    })?;
    bar.finish_and_clear();
    raycast_cli::render::views_lines(&summary)
        .into_iter()
        .for_each(say);
    Ok(())
}

fn compare(spec: &compare::Spec) -> Result<ExitCode> {
    let gpu = raycast_cli::render::gpu_for(spec.modes.iter().map(|m| m.device))?;
    let outcome = spec.run(gpu.as_ref())?;
    say(&outcome.json);
    for path in &outcome.written {
        eprintln!("wrote {}", path.display());
    }
    for line in &outcome.exceeded {
        eprintln!("fail-above: {line}");
    }
    Ok(ExitCode::from(u8::from(!outcome.exceeded.is_empty())))
}

/// Prints a study's line on the stream it names.
fn say_on(stream: Stream, line: &str) {
    match stream {
        Stream::Stdout => say(line),
        Stream::Stderr => eprintln!("{line}"),
    }
}
