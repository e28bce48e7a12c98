//! `raycast tradeoff`: what each mode costs and what it buys. For every mode the device
//! supports, the time of a frame (median of warm runs) against its error relative to the CPU
//! in f64 with the robust algorithms; written as `tradeoff.csv`, `tradeoff.md` (a table) and
//! `tradeoff.png` (time against error).
//!
//! What is measured, per scene ([`measure`]):
//! - The reference, [`REFERENCE`] (`cpu:f64:robust`), is rendered once at one sample per pixel,
//!   and, when some row has more than one, once at [`REFERENCE_SPP`] samples per pixel
//!   (reduced as `--spp` does, [`raycast::RenderOptions::samples_per_pixel`]).
//! - Every mode of [`Options::modes`] is measured at one sample per pixel and compared with
//!   the plain reference: this is the error of the arithmetic and the algorithms, at the same
//!   ray positions.
//! - [`SUPERSAMPLED_MODE`] (`gpu:f32:robust`, the default render) is also measured at each
//!   sample count above 1 of [`Options::spp`], and compared with the reference at
//!   [`REFERENCE_SPP`]: this is the error of sampling the pixel's area, dominated by edges
//!   (a row at 64 spp or more is compared with a reference no finer than itself).
//! - Each (mode, spp) is rendered once to warm up (compiling its kernel), then
//!   [`Options::runs`] times: the wall time of the whole frame (upload, dispatch, readback; for
//!   spp > 1 also the reduction) and, on the GPU where it has timestamp queries, the kernel
//!   time (timestamps at the beginning and end of each compute pass, summed over tiles and over
//!   adaptive precision's two passes) are the medians over the runs. The last run's images are
//!   compared with the reference ([`compare::compare`]).
//!
//! The plot's error is the *mismatch fraction*, `(hit_mismatch + id_mismatch) / pixels`: the
//! share of pixels that show the wrong thing. A second panel shows the 99.9th percentile of
//! the relative distance error over the pixels that do show the right object.

mod plot;

use std::path::{Path, PathBuf};
use std::time::Instant;

use super::accuracy;
use super::{
    NamedScene, Provenance, Stream, Table, cell, format_error, format_seconds, load_scenes, median,
    plural,
};
use crate::compare;
use crate::render::render;
use raycast::Scene;
use raycast::{Algorithm, Error, Gpu, RenderOptions, Result};
use raycast::{AnyImages, Device, Mode, Precision};
use raycast_files::EncodedFile;

pub use plot::{LogAxis, plot};

/// Every row is compared with this mode: the CPU in f64 with the robust algorithms.
pub const REFERENCE: Mode = accuracy::DEFAULT_REFERENCE;

/// Samples per pixel of the reference that rows at more than one sample are compared with.
pub const REFERENCE_SPP: u32 = 64;

/// The mode also measured at more than one sample per pixel: the default render.
pub const SUPERSAMPLED_MODE: Mode = Mode {
    device: Device::Gpu,
    precision: Precision::F32,
    algorithm: Algorithm::Robust,
};

/// `--spp` unless given.
pub const DEFAULT_SPP: [u32; 3] = [1, 4, 16];

/// `--runs` unless given.
pub const DEFAULT_RUNS: usize = 5;

/// The names of the files written.
pub const FILES: [&str; 3] = ["tradeoff.csv", "tradeoff.md", "tradeoff.png"];

/// What to measure.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Image size overriding every scene's `resolution`.
    pub size: Option<[u32; 2]>,
    /// Timed runs per row, after one warm-up run (at least 1).
    pub runs: usize,
    /// Sample counts at which [`SUPERSAMPLED_MODE`] is measured; every mode is measured at 1
    /// whether or not it is listed.
    pub spp: Vec<u32>,
    /// The modes measured, in table order.
    pub modes: Vec<Mode>,
}

impl Options {
    /// `modes` at the scenes' own resolution, [`DEFAULT_RUNS`] runs, [`DEFAULT_SPP`].
    pub fn new(modes: Vec<Mode>) -> Options {
        Options {
            size: None,
            runs: DEFAULT_RUNS,
            spp: DEFAULT_SPP.to_vec(),
            modes,
        }
    }
}

/// The (mode, spp) pairs measured on each scene, in table order: each mode at 1 sample per
/// pixel, [`SUPERSAMPLED_MODE`] followed by each distinct sample count above 1 of `spp`,
/// ascending.
pub fn plan(modes: &[Mode], spp: &[u32]) -> Vec<(Mode, u32)> {
    let mut extra: Vec<u32> = spp.iter().copied().filter(|&n| n > 1).collect();
    extra.sort_unstable();
    extra.dedup();
    let mut out = Vec::new();
    for &mode in modes {
        out.push((mode, 1));
        if mode == SUPERSAMPLED_MODE {
            out.extend(extra.iter().map(|&n| (mode, n)));
        }
    }
    out
}

/// One scene in one mode at one sample count.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// The scene file's name without its extension.
    pub scene: String,
    pub mode: Mode,
    /// Samples per pixel.
    pub spp: u32,
    /// Samples per pixel of the reference compared with: 1, or [`REFERENCE_SPP`].
    pub reference_spp: u32,
    pub pixels: usize,
    /// Median wall time of a frame in seconds.
    pub wall_s: f64,
    /// Median GPU kernel time in seconds; `None` on the CPU or without timestamp queries.
    pub kernel_s: Option<f64>,
    /// Pixels where exactly one of mode and reference hits.
    pub hit_mismatch: usize,
    /// Pixels where both hit, but different objects.
    pub id_mismatch: usize,
    /// Largest and 99.9th-percentile relative distance error, over pixels where both hit the
    /// same object (`None` if there are none).
    pub rel_max: Option<f64>,
    pub rel_p999: Option<f64>,
    /// Largest angle between the normals, in degrees, over the same pixels.
    pub normal_max_deg: Option<f64>,
    /// Fraction of pixels adaptive precision cast again in f64; `None` for other modes.
    pub recast_fraction: Option<f64>,
}

impl Row {
    /// `(hit_mismatch + id_mismatch) / pixels`: the plot's error.
    pub fn mismatch_fraction(&self) -> f64 {
        (self.hit_mismatch + self.id_mismatch) as f64 / self.pixels.max(1) as f64
    }

    /// The mode, with ` Nspp` when above 1 (the plot's labels).
    pub fn label(&self) -> String {
        if self.spp > 1 {
            format!("{} {}spp", self.mode, self.spp)
        } else {
            self.mode.to_string()
        }
    }
}

/// Checks the sample counts (perfect squares, see [`RenderOptions::check`]) and that `gpu` can
/// run every mode.
fn check(options: &Options, gpu: Option<&Gpu>) -> Result<()> {
    for &samples_per_pixel in &options.spp {
        let spp = RenderOptions {
            samples_per_pixel: Some(samples_per_pixel),
            ..RenderOptions::default()
        };
        crate::render::check(SUPERSAMPLED_MODE, spp)?;
    }
    let supported = accuracy::default_modes(gpu);
    if let Some(m) = options.modes.iter().find(|m| !supported.contains(m)) {
        return Err(Error::Device(format!("mode {m} is not supported here")));
    }
    Ok(())
}

/// Measures every scene in every (mode, spp) of [`plan`] (module docs). With `progress`, a
/// progress bar over scenes x rows x runs is drawn on stderr when it is a terminal.
pub fn measure(
    scenes: &[NamedScene],
    options: &Options,
    gpu: Option<&Gpu>,
    progress: bool,
) -> Result<Vec<Row>> {
    check(options, gpu)?;
    let plan = plan(&options.modes, &options.spp);
    let runs = options.runs.max(1);
    let needs_fine_reference = plan.iter().any(|&(_, n)| n > 1);
    let per_scene = 1 + usize::from(needs_fine_reference) + plan.len() * (1 + runs);
    let bar = crate::progress::bar(
        progress,
        (per_scene * scenes.len()) as u64,
        "{bar:24} {pos}/{len} renders, {eta} left: {wide_msg}",
    );
    let mut rows = Vec::new();
    for s in scenes {
        rows.extend(measure_scene(s, &plan, runs, gpu, &bar)?);
    }
    bar.finish_and_clear();
    Ok(rows)
}

/// One scene: the references, then each (mode, spp) of `plan`, `runs` timed runs each.
fn measure_scene(
    s: &NamedScene,
    plan: &[(Mode, u32)],
    runs: usize,
    gpu: Option<&Gpu>,
    bar: &indicatif::ProgressBar,
) -> Result<Vec<Row>> {
    let scene = &s.scene;
    bar.set_message(format!("{}: reference {REFERENCE}", s.name));
    let reference = render(scene, REFERENCE, gpu, RenderOptions::default())?;
    bar.inc(1);
    let fine_reference = if plan.iter().any(|&(_, n)| n > 1) {
        bar.set_message(format!(
            "{}: reference {REFERENCE} at {REFERENCE_SPP} spp",
            s.name
        ));
        let fine = RenderOptions {
            samples_per_pixel: Some(REFERENCE_SPP),
            ..RenderOptions::default()
        };
        let r = render(scene, REFERENCE, gpu, fine)?;
        bar.inc(1);
        Some(r)
    } else {
        None
    };
    let mut rows = Vec::with_capacity(plan.len());
    for &(mode, spp) in plan {
        let mut walls = Vec::with_capacity(runs);
        let mut kernels = Vec::with_capacity(runs);
        let mut last = None;
        for run in 0..=runs {
            let what = if run == 0 {
                "warm-up".to_owned()
            } else {
                format!("run {run}/{runs}")
            };
            bar.set_message(format!("{}: {mode} {spp} spp, {what}", s.name));
            let start = Instant::now();
            let frame = render_frame(scene, mode, spp, gpu)?;
            let wall = start.elapsed().as_secs_f64();
            bar.inc(1);
            if run > 0 {
                walls.push(wall);
                kernels.push(frame.kernel_s);
                last = Some(frame);
            }
        }
        let frame = last.expect("at least one run");
        let (truth, reference_spp) = match (&fine_reference, spp) {
            (Some(fine), n) if n > 1 => (fine, REFERENCE_SPP),
            _ => (&reference, 1),
        };
        let c = compare::compare(&frame.images, truth).report;
        let kernel_s = kernels
            .into_iter()
            .collect::<Option<Vec<f64>>>()
            .map(|k| median(&k));
        rows.push(Row {
            scene: s.name.clone(),
            mode,
            spp,
            reference_spp,
            pixels: c.pixels,
            wall_s: median(&walls),
            kernel_s,
            hit_mismatch: c.hit_mismatch,
            id_mismatch: c.id_mismatch,
            rel_max: c.distance.rel_max,
            rel_p999: c.distance.rel_p999,
            normal_max_deg: c.normal_angle_deg.max,
            recast_fraction: frame.recast_fraction,
        });
    }
    Ok(rows)
}

/// One timed frame.
struct Frame {
    images: AnyImages,
    kernel_s: Option<f64>,
    recast_fraction: Option<f64>,
}

/// Renders `scene` in `mode` at `spp` samples per pixel (reduced as `--spp` does), timed.
fn render_frame(scene: &Scene, mode: Mode, spp: u32, gpu: Option<&Gpu>) -> Result<Frame> {
    let options = RenderOptions {
        // One sample: the plain render, without coverage.
        samples_per_pixel: (spp > 1).then_some(spp),
        timed: true,
        ..RenderOptions::default()
    };
    let images = render(scene, mode, gpu, options)?;
    let recast_fraction = match &images {
        AnyImages::F32(i) => i.recast_fraction,
        AnyImages::F64(i) => i.recast_fraction,
    };
    Ok(Frame {
        kernel_s: images.kernel_s(),
        images,
        recast_fraction,
    })
}

/// Column names of [`to_csv`].
pub const CSV_COLUMNS: [&str; 13] = [
    "scene",
    "mode",
    "spp",
    "reference_spp",
    "pixels",
    "wall_s",
    "kernel_s",
    "hit_mismatch",
    "id_mismatch",
    "rel_max",
    "rel_p999",
    "normal_max_deg",
    "recast_fraction",
];

/// A CSV field: quoted (quotes doubled) when it holds a comma, quote or line break.
fn csv_field(text: &str) -> String {
    if text.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_owned()
    }
}

/// A float for CSV: the shortest text that reads back as the same f64 (`1.5e-7`, `0e0`);
/// empty for `None`.
fn csv_number(x: Option<f64>) -> String {
    x.map_or(String::new(), |x| format!("{x:e}"))
}

/// The rows as CSV: a header line of [`CSV_COLUMNS`], then one line per row, each ending in
/// `\n`. Missing values (kernel time on the CPU, errors with no common hits, the re-cast
/// fraction of modes other than adaptive) are empty fields.
pub fn to_csv(rows: &[Row]) -> String {
    let mut s = CSV_COLUMNS.join(",") + "\n";
    for r in rows {
        let fields = [
            csv_field(&r.scene),
            r.mode.to_string(),
            r.spp.to_string(),
            r.reference_spp.to_string(),
            r.pixels.to_string(),
            csv_number(Some(r.wall_s)),
            csv_number(r.kernel_s),
            r.hit_mismatch.to_string(),
            r.id_mismatch.to_string(),
            csv_number(r.rel_max),
            csv_number(r.rel_p999),
            csv_number(r.normal_max_deg),
            csv_number(r.recast_fraction),
        ];
        s += &fields.join(",");
        s += "\n";
    }
    s
}

/// Column headings of [`to_markdown`].
pub const MD_COLUMNS: [&str; 13] = [
    "scene",
    "mode",
    "spp",
    "ref. spp",
    "wall (s)",
    "kernel (s)",
    "hit/miss",
    "id",
    "mismatch fraction",
    "rel. distance max",
    "rel. distance p99.9",
    "normal max (deg)",
    "re-cast",
];

/// The rows as a markdown table (heading, alignment line, one line per row), ending in a
/// newline.
pub fn to_markdown(rows: &[Row]) -> String {
    let mut table = Table::text_then_numbers(&MD_COLUMNS, 2);
    for r in rows {
        let fraction = r.mismatch_fraction();
        table.row([
            cell(&r.scene),
            r.mode.to_string(),
            r.spp.to_string(),
            r.reference_spp.to_string(),
            format_seconds(r.wall_s),
            r.kernel_s.map_or("-".to_owned(), format_seconds),
            r.hit_mismatch.to_string(),
            r.id_mismatch.to_string(),
            format_error(Some(fraction)),
            format_error(r.rel_max),
            format_error(r.rel_p999),
            format_error(r.normal_max_deg),
            r.recast_fraction
                .map_or("-".to_owned(), |f| format!("{:.2}%", 100.0 * f)),
        ]);
    }
    table.markdown()
}

/// Where and how the measurement was made, in one line of text (the plot's subtitle).
pub fn provenance_line(p: &Provenance, runs: usize) -> String {
    let adapter = p.adapter_text().unwrap_or_else(|| "no GPU".to_owned());
    let runs = plural(runs, "run");
    format!("{adapter}, median of {runs}, {} (UTC)", p.date)
}

/// `tradeoff.md`: a title, the provenance line, what the columns mean, the plot and the table.
pub fn document(p: &Provenance, options: &Options, scenes: &[NamedScene], rows: &[Row]) -> String {
    let sizes: Vec<String> = scenes
        .iter()
        .map(|s| {
            let [nx, ny] = s.scene.camera.resolution;
            format!("`{}` {nx}x{ny}", cell(&s.name))
        })
        .collect();
    let mut s = String::from("# Speed and accuracy of every mode\n\n");
    s += &format!("{} Scenes: {}.\n\n", p.generated_by(), sizes.join(", "));
    s += &format!(
        "Each row is one scene in one mode (`device:precision:algorithm`) at `spp` samples per \
         pixel, after one warm-up frame. *wall*: the median over {runs} of the wall time \
         of a whole frame (upload, kernel, readback; for spp > 1 also the reduction to one \
         pixel). *kernel*: the median GPU time of the compute passes, from timestamp queries \
         (summed over tiles, and for adaptive precision over its f32 pass and its f64 re-cast; \
         `-` on the CPU). Errors are against `{reference}` rendered at *ref. spp* samples per \
         pixel: at 1 spp, every mode against the reference at the same ray positions (the \
         error of the arithmetic and the algorithms); at more, `{ss}` against the reference at \
         {REFERENCE_SPP} spp, both reduced by majority id (the error of sampling the pixel's \
         area, dominated by edges). *hit/miss*: pixels where exactly one of the two hits; *id*: \
         pixels where both hit different objects; *mismatch fraction*: the two together over \
         all pixels (the plot's error). *rel. distance*: the largest and the 99.9th-percentile \
         |d - d_ref| / d_ref over pixels where both hit the same object; *normal max*: the \
         largest angle between the normals there (`-`: no such pixel, `0`: exact). *re-cast*: \
         the share of pixels adaptive precision cast again in f64.\n\n",
        runs = plural(options.runs.max(1), "frame"),
        reference = REFERENCE,
        ss = SUPERSAMPLED_MODE,
    );
    s += "![wall time against mismatch fraction and distance error](tradeoff.png)\n\n";
    s += &to_markdown(rows);
    s
}

/// The three files: `tradeoff.csv`, `tradeoff.md` and `tradeoff.png`.
pub fn files(
    p: &Provenance,
    options: &Options,
    scenes: &[NamedScene],
    rows: &[Row],
) -> Vec<EncodedFile> {
    let picture = plot(rows, &provenance_line(p, options.runs.max(1)));
    let [csv, md, png] = FILES;
    vec![
        EncodedFile {
            name: csv,
            bytes: to_csv(rows).into_bytes(),
        },
        EncodedFile {
            name: md,
            bytes: document(p, options, scenes, rows).into_bytes(),
        },
        EncodedFile {
            name: png,
            bytes: raycast::encode_png_rgb(&picture),
        },
    ]
}

/// Measures `scenes` (from [`load_scenes`]) and writes the three files into `dir` (created if
/// missing; all files or none); returns their paths. The folder is checked before anything
/// renders.
pub fn run(
    scenes: &[NamedScene],
    dir: &Path,
    options: &Options,
    gpu: Option<&Gpu>,
    provenance: &Provenance,
    progress: bool,
) -> Result<Vec<PathBuf>> {
    raycast_files::check_writable(dir)?;
    let rows = measure(scenes, options, gpu, progress)?;
    Ok(raycast_files::write_files(
        dir,
        &files(provenance, options, scenes, &rows),
    )?)
}

/// `raycast tradeoff`: loads `scenes` (validated before the GPU is opened or `dir` created),
/// measures them in every mode the GPU supports with a progress bar, writes the three files
/// into `dir` and names each on stdout.
pub fn command(
    scenes: &[PathBuf],
    size: Option<[u32; 2]>,
    runs: usize,
    spp: Vec<u32>,
    dir: &Path,
    mut say: impl FnMut(Stream, &str),
) -> Result<()> {
    let scenes = load_scenes(scenes, size)?;
    raycast_files::check_writable(dir)?;
    let gpu = Gpu::new()?;
    let options = Options {
        size,
        runs,
        spp,
        modes: accuracy::default_modes(Some(&gpu)),
    };
    let provenance = Provenance::now(Some(&gpu));
    for path in run(&scenes, dir, &options, Some(&gpu), &provenance, true)? {
        say(Stream::Stdout, &format!("wrote {}", path.display()));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mode(s: &str) -> Mode {
        s.parse().unwrap()
    }

    fn sample_row() -> Row {
        Row {
            scene: "bunny".into(),
            mode: mode("gpu:f32:textbook"),
            spp: 1,
            reference_spp: 1,
            pixels: 57_600,
            wall_s: 0.25,
            kernel_s: Some(0.125),
            hit_mismatch: 3,
            id_mismatch: 9,
            rel_max: Some(1.5e-6),
            rel_p999: Some(2.5e-7),
            normal_max_deg: Some(0.0),
            recast_fraction: None,
        }
    }

    #[test]
    fn plan_has_every_mode_once_and_the_supersampled_mode_per_count() {
        let modes = accuracy::all_modes();
        let p = plan(&modes, &[16, 1, 4, 4]);
        assert_eq!(p.len(), modes.len() + 2);
        let at = modes.iter().position(|&m| m == SUPERSAMPLED_MODE).unwrap();
        assert_eq!(p[at], (SUPERSAMPLED_MODE, 1));
        assert_eq!(p[at + 1], (SUPERSAMPLED_MODE, 4));
        assert_eq!(p[at + 2], (SUPERSAMPLED_MODE, 16));
        assert!(
            p.iter()
                .filter(|&&(_, n)| n > 1)
                .all(|&(m, _)| m == SUPERSAMPLED_MODE)
        );
        // Without the supersampled mode, or with 1 only: one row per mode.
        let cpu = accuracy::default_modes(None);
        assert_eq!(plan(&cpu, &[1, 4, 16]).len(), cpu.len());
        assert_eq!(plan(&modes, &[1]).len(), modes.len());
        assert_eq!(plan(&modes, &[]).len(), modes.len());
    }

    #[test]
    fn csv_has_header_and_round_trip_numbers() {
        let mut cpu = sample_row();
        cpu.mode = mode("cpu:f64:robust");
        cpu.scene = "a,\"b\"".into();
        cpu.kernel_s = None;
        cpu.rel_max = None;
        let mut adaptive = sample_row();
        adaptive.mode = mode("gpu:adaptive:robust");
        adaptive.recast_fraction = Some(0.0125);
        adaptive.spp = 16;
        adaptive.reference_spp = 64;
        let csv = to_csv(&[sample_row(), cpu, adaptive]);
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines.len(), 4);
        assert_eq!(
            lines[0],
            "scene,mode,spp,reference_spp,pixels,wall_s,kernel_s,hit_mismatch,id_mismatch,\
             rel_max,rel_p999,normal_max_deg,recast_fraction"
        );
        assert_eq!(
            lines[1],
            "bunny,gpu:f32:textbook,1,1,57600,2.5e-1,1.25e-1,3,9,1.5e-6,2.5e-7,0e0,"
        );
        assert_eq!(
            lines[2],
            "\"a,\"\"b\"\"\",cpu:f64:robust,1,1,57600,2.5e-1,,3,9,,2.5e-7,0e0,"
        );
        assert!(lines[3].starts_with("bunny,gpu:adaptive:robust,16,64,"));
        assert!(lines[3].ends_with(",1.25e-2"));
        assert!(csv.ends_with('\n'));
        // Every number reads back as the same f64.
        let x = 0.1 + 0.2;
        assert_eq!(csv_number(Some(x)).parse::<f64>().unwrap(), x);
        assert_eq!(csv_field("plain"), "plain");
    }

    #[test]
    fn markdown_table_has_one_line_per_row() {
        let mut r = sample_row();
        r.recast_fraction = Some(0.01234);
        r.kernel_s = None;
        let md = to_markdown(&[sample_row(), r]);
        let lines: Vec<&str> = md.lines().collect();
        assert_eq!(lines.len(), 4);
        for line in &lines {
            assert_eq!(line.matches('|').count(), MD_COLUMNS.len() + 1, "{line}");
        }
        assert_eq!(
            lines[2],
            "| bunny | gpu:f32:textbook | 1 | 1 | 0.250 | 0.125 | 3 | 9 | 2.1e-4 | 1.5e-6 | \
             2.5e-7 | 0 | - |"
        );
        assert!(lines[3].ends_with("| - | 3 | 9 | 2.1e-4 | 1.5e-6 | 2.5e-7 | 0 | 1.23% |"));
    }

    #[test]
    fn labels_and_mismatch_fraction() {
        let mut r = sample_row();
        assert_eq!(r.label(), "gpu:f32:textbook");
        assert_eq!(r.mismatch_fraction(), 12.0 / 57_600.0);
        r.spp = 16;
        assert_eq!(r.label(), "gpu:f32:textbook 16spp");
    }
}
