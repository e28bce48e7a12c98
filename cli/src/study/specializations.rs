//! `raycast specializations`: what each specialization of the kernel is worth, measured side by
//! side on the same device in one run.
//!
//! For every scene, each specialization is timed with the kernel specialized and with that one
//! specialization turned off, everything else as `raycast render` would run it (GPU, f32, robust,
//! the scene's own resolution):
//! - primitive kinds: only the scene's kinds compiled in, against every kind
//!   ([`Tuning::all_kinds`]);
//! - BVH against brute force (brute force skipped above [`BRUTE_FORCE_LIMIT`] triangles);
//! - subgroup packets against per-ray BVH traversal (where the scene uses a BVH);
//! - outputs: distance only against id, distance and normal.
//!
//! The distinct kernels of a scene are run in turn, round after round (one warm-up round, which
//! also compiles them, then `runs` timed rounds), so drifts of the machine's load fall on all of
//! them alike; each time is the median of its rounds' kernel GPU times ([`raycast::Stages::kernel_s`],
//! timestamp queries), or of the wall trace times where the device has no timestamps.
//!
//! [`crossover`] measures where a BVH starts to pay (random spheres and triangles, n = 2 to 256),
//! the measurement behind the crossover of [`Search::Auto`].

use std::path::{Path, PathBuf};

use super::{Align, NamedScene, Provenance, Stream, Table, cell, load_scenes, median};
use raycast::Precision;
use raycast::{Error, Gpu, Outputs, RenderOptions, Result, Search, Tuning};
use raycast::{MeshPart, Scene};

/// Above this many triangles brute force is not timed (the torus's 518,400 would take minutes
/// a frame on lavapipe).
pub const BRUTE_FORCE_LIMIT: usize = 20_000;
/// Where benches/peers.sh leaves its 518,400-triangle torus scene.
pub const DEFAULT_TORUS: &str = "target/bench/torus.json";
/// The scenes measured unless others are named.
pub const DEFAULT_SCENES: &str = "scenes/course";

/// A kernel specialization, as a row of the table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Specialization {
    Kinds,
    Bvh,
    Packets,
    Outputs,
}

impl Specialization {
    pub const ALL: [Specialization; 4] = [
        Specialization::Kinds,
        Specialization::Bvh,
        Specialization::Packets,
        Specialization::Outputs,
    ];

    /// Its name, and what "with" and "without" are.
    pub fn describe(self) -> (&'static str, &'static str, &'static str) {
        match self {
            Specialization::Kinds => ("primitive kinds", "the scene's kinds", "every kind"),
            Specialization::Bvh => ("BVH", "BVH", "brute force"),
            Specialization::Packets => ("subgroup packets", "packets", "per-ray traversal"),
            Specialization::Outputs => ("outputs", "distance only", "id, distance, normal"),
        }
    }
}

/// One row: a specialization on one scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub scene: String,
    pub specialization: Specialization,
    /// Median time with the specialization, and without, in milliseconds; `None` where not
    /// measured (see `note`).
    pub with_ms: Option<f64>,
    pub without_ms: Option<f64>,
    /// Which of the two `raycast render` runs for the scene: `Some(true)` with, `Some(false)`
    /// without, `None` where the request decides (outputs) or the row does not apply.
    pub default_with: Option<bool>,
    /// Why something was not measured, or a remark.
    pub note: Option<String>,
}

impl Row {
    /// Time without over time with (above 1: the specialization is faster).
    pub fn speed_up(&self) -> Option<f64> {
        Some(self.without_ms? / self.with_ms?)
    }
}

/// A kernel as the study runs it: GPU, f32, robust, `tuning` and `outputs` as given.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Kernel {
    pub tuning: Tuning,
    pub outputs: Outputs,
}

/// What to run for one row: the kernel with and without the specialization (`None`: not run).
struct Plan {
    specialization: Specialization,
    with: Option<Kernel>,
    without: Option<Kernel>,
    default_with: Option<bool>,
    note: Option<String>,
}

impl Plan {
    fn not_applicable(specialization: Specialization, why: &str) -> Plan {
        Plan {
            specialization,
            with: None,
            without: None,
            default_with: None,
            note: Some(why.to_owned()),
        }
    }
}

/// The rows to measure for `scene`, from the kernel `raycast render` runs for it by default
/// (GPU, f32, robust, id, distance and normal).
fn plans(gpu: &Gpu, scene: &Scene) -> Vec<Plan> {
    let [spheres, planes, triangles] = scene.primitive_counts();
    let auto_bvh = Search::Auto.uses_bvh(scene);
    // The search as raycast chooses it, named, so that the base kernel is one of the BVH row's.
    let search = if auto_bvh {
        Search::Bvh
    } else {
        Search::BruteForce
    };
    let base = Kernel {
        tuning: Tuning {
            search,
            ..Tuning::default()
        },
        outputs: Outputs::default(),
    };
    let tuned = |tuning: Tuning| Kernel { tuning, ..base };
    let toggle = |on: Kernel, off: Kernel, default_with: bool, spec| Plan {
        specialization: spec,
        with: Some(on),
        without: Some(off),
        default_with: Some(default_with),
        note: None,
    };
    let mut plans = Vec::new();
    plans.push(if spheres > 0 && planes > 0 && triangles > 0 {
        Plan::not_applicable(Specialization::Kinds, "the scene has every kind")
    } else {
        let all = tuned(Tuning {
            all_kinds: true,
            ..base.tuning
        });
        toggle(base, all, true, Specialization::Kinds)
    });
    let with_search = |search| {
        tuned(Tuning {
            search,
            ..base.tuning
        })
    };
    let bvh = with_search(Search::Bvh);
    plans.push(if spheres + triangles == 0 {
        Plan::not_applicable(Specialization::Bvh, "no spheres or triangles")
    } else if triangles > BRUTE_FORCE_LIMIT {
        Plan {
            without: None,
            note: Some(format!(
                "brute force skipped (too slow): more than {BRUTE_FORCE_LIMIT} triangles"
            )),
            ..toggle(bvh, base, true, Specialization::Bvh)
        }
    } else {
        let brute = with_search(Search::BruteForce);
        toggle(bvh, brute, auto_bvh, Specialization::Bvh)
    });
    plans.push(if !auto_bvh {
        Plan::not_applicable(Specialization::Packets, "no BVH for this scene")
    } else if !gpu.info().packet_subgroups {
        Plan::not_applicable(
            Specialization::Packets,
            "no subgroups of 8 or more invocations on this device",
        )
    } else {
        let traversal = |packets| {
            tuned(Tuning {
                packets: Some(packets),
                ..base.tuning
            })
        };
        // The device's choice for the scene's pixels and primitives (`Gpu::packets_pay`).
        let default_with = gpu.info().packet_rays_per_primitive.is_some_and(|r| {
            crate::pixels(&scene.camera) as f64 >= r * (spheres + triangles) as f64
        });
        toggle(
            traversal(true),
            traversal(false),
            default_with,
            Specialization::Packets,
        )
    });
    let distance = Kernel {
        outputs: Outputs {
            id: false,
            distance: true,
            normal: false,
            color: false,
        },
        ..base
    };
    plans.push(Plan {
        default_with: None,
        ..toggle(distance, base, false, Specialization::Outputs)
    });
    plans
}

/// Whether the times are GPU kernel times: the device has timestamp queries.
pub fn has_kernel_times(gpu: &Gpu) -> bool {
    gpu.device
        .features()
        .contains(wgpu::Features::TIMESTAMP_QUERY)
}

/// The time of one render with `kernel`, in seconds: the kernel's GPU time, or the wall trace
/// time without timestamps.
fn time_once(gpu: &Gpu, scene: &Scene, kernel: Kernel) -> Result<f64> {
    let options = RenderOptions {
        precision: Some(Precision::F32),
        outputs: kernel.outputs,
        tuning: kernel.tuning,
        timed: true,
        ..RenderOptions::default()
    };
    let images = gpu.render(scene, &options)?;
    let stages = images.stages().expect("an f32 render reports its stages");
    Ok(stages.kernel_s.unwrap_or(stages.trace_s))
}

/// The times of `variants` on `scene`: the median in seconds, and the spread (interquartile
/// range over median) of the rounds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Timing {
    pub median_s: f64,
    pub spread: f64,
}

/// Each of `variants` timed on `scene`: one warm-up round, then `runs` rounds, each running
/// every variant once in turn, starting one further along each round (so that none is always
/// first after another scene's work).
pub fn interleaved_times(
    gpu: &Gpu,
    scene: &Scene,
    variants: &[Kernel],
    runs: usize,
) -> Result<Vec<Timing>> {
    let mut times = vec![Vec::with_capacity(runs); variants.len()];
    for round in 0..=runs {
        for k in 0..variants.len() {
            let at = (k + round) % variants.len();
            let s = time_once(gpu, scene, variants[at])?;
            if round > 0 {
                times[at].push(s);
            }
        }
    }
    Ok(times
        .into_iter()
        .map(|t| {
            let median_s = median(&t);
            let spread = (quantile(&t, 0.75) - quantile(&t, 0.25)) / median_s;
            Timing { median_s, spread }
        })
        .collect())
}

/// The `q` quantile of `v` by linear interpolation between order statistics.
fn quantile(v: &[f64], q: f64) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    let at = q * (v.len() - 1) as f64;
    let (lo, hi) = (at.floor() as usize, at.ceil() as usize);
    v[lo] + (v[hi] - v[lo]) * (at - lo as f64)
}

/// Measures every specialization on `scene` (`runs` timed rounds); also returns the spread of
/// every kernel timed.
pub fn scene_rows(gpu: &Gpu, named: &NamedScene, runs: usize) -> Result<(Vec<Row>, Vec<f64>)> {
    let plans = plans(gpu, &named.scene);
    let mut variants: Vec<Kernel> = Vec::new();
    for v in plans.iter().flat_map(|p| [p.with, p.without]).flatten() {
        if !variants.contains(&v) {
            variants.push(v);
        }
    }
    let times = interleaved_times(gpu, &named.scene, &variants, runs)?;
    let ms = |v: Option<Kernel>| {
        let k = variants.iter().position(|x| Some(*x) == v)?;
        Some(1e3 * times[k].median_s)
    };
    let rows = plans
        .into_iter()
        .map(|p| Row {
            scene: named.name.clone(),
            specialization: p.specialization,
            with_ms: ms(p.with),
            without_ms: ms(p.without),
            default_with: p.default_with,
            note: p.note,
        })
        .collect();
    Ok((rows, times.iter().map(|t| t.spread).collect()))
}

/// The scene files of `paths`: files as given, folders as their `*.json` files in name order.
pub fn scene_files(paths: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    for path in paths {
        if !path.is_dir() {
            files.push(path.clone());
            continue;
        }
        let entries = std::fs::read_dir(path).map_err(|e| Error::Io {
            path: path.to_path_buf(),
            message: format!("cannot read: {e}"),
        })?;
        let mut found: Vec<PathBuf> = entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e == "json"))
            .collect();
        found.sort();
        if found.is_empty() {
            return Err(Error::Io {
                path: path.to_path_buf(),
                message: "no .json scene files in this folder".into(),
            });
        }
        files.extend(found);
    }
    Ok(files)
}

/// Everything the document holds.
pub struct Report {
    pub provenance: Provenance,
    /// Timed rounds per kernel, after one warm-up round.
    pub runs: usize,
    /// Whether the times are GPU kernel times (timestamp queries) rather than wall trace times.
    pub kernel_times: bool,
    pub scenes: Vec<NamedScene>,
    pub rows: Vec<Row>,
    /// The spread (interquartile range over median) of every kernel timed for the rows.
    pub spreads: Vec<f64>,
    /// Remarks on scenes not measured (such as a missing torus).
    pub notes: Vec<String>,
    pub crossover: Option<Vec<CrossoverRow>>,
}

fn ms_cell(ms: Option<f64>) -> String {
    match ms {
        Some(ms) if ms >= 100.0 => format!("{ms:.0}"),
        Some(ms) if ms >= 10.0 => format!("{ms:.1}"),
        Some(ms) => format!("{ms:.2}"),
        None => "-".into(),
    }
}

/// The specialization table, in markdown.
pub fn table(rows: &[Row]) -> String {
    use Align::{Left, Right};
    let mut table = Table::new(
        &[
            "scene",
            "specialization: with / without",
            "with (ms)",
            "without (ms)",
            "speed-up",
            "`render` runs",
            "note",
        ],
        &[Left, Left, Right, Right, Right, Left, Left],
    );
    for r in rows {
        let (name, with, without) = r.specialization.describe();
        let without_ms = match (&r.without_ms, &r.note) {
            (None, Some(note)) if note.starts_with("brute force skipped") => {
                "skipped (too slow)".to_owned()
            }
            (ms, _) => ms_cell(*ms),
        };
        let default = match r.default_with {
            Some(true) => with,
            Some(false) => without,
            None if r.with_ms.is_some() => "as requested",
            None => "-",
        };
        table.row([
            cell(&r.scene),
            format!("{name}: {with} / {without}"),
            ms_cell(r.with_ms),
            without_ms,
            r.speed_up().map_or("-".into(), times),
            default.to_owned(),
            r.note.as_deref().map_or(String::new(), cell),
        ]);
    }
    table.markdown()
}

/// The scenes' sizes, in markdown.
fn scenes_table(scenes: &[NamedScene]) -> String {
    let mut table = Table::text_then_numbers(
        &["scene", "resolution", "spheres", "planes", "triangles"],
        2,
    );
    for n in scenes {
        let [w, h] = n.scene.camera.resolution;
        let counts = n.scene.primitive_counts().map(|c| c.to_string());
        table.row(
            [cell(&n.name), format!("{w}x{h}")]
                .into_iter()
                .chain(counts),
        );
    }
    table.markdown()
}

/// The geometric mean, least and greatest speed-up of the measured rows of `spec`.
fn summary(rows: &[Row], spec: Specialization) -> Option<(f64, f64, f64, usize)> {
    let ups: Vec<f64> = rows
        .iter()
        .filter(|r| r.specialization == spec)
        .filter_map(Row::speed_up)
        .collect();
    if ups.is_empty() {
        return None;
    }
    let geo = (ups.iter().map(|x| x.ln()).sum::<f64>() / ups.len() as f64).exp();
    let lo = ups.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = ups.iter().copied().fold(0.0, f64::max);
    Some((geo, lo, hi, ups.len()))
}

/// Per specialization, the speed-ups over the scenes where it was measured, in markdown.
fn summary_table(rows: &[Row]) -> String {
    let mut table = Table::text_then_numbers(
        &[
            "specialization",
            "scenes measured",
            "speed-up, geometric mean",
            "least",
            "greatest",
        ],
        1,
    );
    for spec in Specialization::ALL {
        let (name, with, without) = spec.describe();
        let cells = match summary(rows, spec) {
            Some((geo, lo, hi, n)) => [n.to_string(), times(geo), times(lo), times(hi)],
            None => ["0", "-", "-", "-"].map(String::from),
        };
        table.row(
            [format!("{name}: {with} / {without}")]
                .into_iter()
                .chain(cells),
        );
    }
    table.markdown()
}

/// A speed-up, `1.23x`.
fn times(x: f64) -> String {
    format!("{x:.2}x")
}

/// The whole document.
pub fn document(report: &Report) -> String {
    let p = &report.provenance;
    let timing = if report.kernel_times {
        "GPU kernel time of the compute passes (timestamp queries)"
    } else {
        "wall time of dispatch and readback (the device has no timestamp queries)"
    };
    let mut s = String::from("# Kernel specializations\n\n");
    s += "What each specialization of the kernel is worth: every scene rendered by the kernel \
          `raycast render` runs for it (GPU, f32, robust, the scene's own resolution, id, \
          distance and normal), and by the same kernel with one specialization turned off. \
          Generated by\n\n";
    s += &format!("    {}\n\n", p.command);
    let adapter = match &p.adapter {
        Some((name, driver)) => format!("on {name}, driver {driver}"),
        None => "without a GPU".to_owned(),
    };
    s += &format!(
        "{adapter}, {}. Each time is the median of {} rounds after one warm-up round; the \
         kernels of a scene run in turn within each round. Times are the {timing}. Speed-up is \
         time without over time with. *`render` runs* names which of the two `raycast render` \
         picks for the scene.\n\n",
        p.date, report.runs
    );
    if !report.spreads.is_empty() {
        let mut spreads = report.spreads.clone();
        spreads.sort_by(f64::total_cmp);
        s += &format!(
            "Run-to-run noise: the interquartile range of a kernel's rounds is {:.0}% of its \
             median for the median kernel timed, {:.0}% for the noisiest; speed-ups closer to \
             1 than that are no measured difference.\n\n",
            100.0 * median(&spreads),
            100.0 * spreads[spreads.len() - 1]
        );
    }
    s += &scenes_table(&report.scenes);
    s += "\n";
    s += &table(&report.rows);
    s += "\n";
    s += &summary_table(&report.rows);
    s += "\n";
    for note in &report.notes {
        s += &format!("{note}\n\n");
    }
    if let Some(rows) = &report.crossover {
        s += "\n";
        s += &crossover_section(rows);
    }
    s
}

/// `raycast specializations`: measures every specialization on the scenes of `scenes` (files,
/// or folders of them, [`scene_files`]) and the torus (`torus`, else [`DEFAULT_TORUS`] where
/// it exists, else a note that it was not), `runs` rounds each, and with `with_crossover` where a
/// BVH starts to pay; progress on stderr. Prints the [`document`] on stdout and writes it to
/// `out` where given (whole or not at all). Scenes are validated and `out`'s folder checked
/// before the GPU is opened.
pub fn command(
    scenes: &[PathBuf],
    torus: Option<&Path>,
    runs: usize,
    with_crossover: bool,
    out: Option<&Path>,
    mut say: impl FnMut(Stream, &str),
) -> Result<()> {
    let mut files = scene_files(scenes)?;
    let mut notes = Vec::new();
    match torus {
        Some(path) => files.push(path.to_owned()),
        None if Path::new(DEFAULT_TORUS).is_file() => files.push(DEFAULT_TORUS.into()),
        None => notes.push(format!(
            "The 518,400-triangle torus was not measured: `{DEFAULT_TORUS}` is absent \
             (benches/peers.sh makes it; or give `--torus FILE`)."
        )),
    }
    let named = load_scenes(&files, None)?;
    if let Some(out) = out {
        raycast_files::check_parent_writable(out)?;
    }
    let gpu = Gpu::new()?;
    let (mut rows, mut spreads) = (Vec::new(), Vec::new());
    for (k, scene) in named.iter().enumerate() {
        say(
            Stream::Stderr,
            &format!("[{}/{}] {}", k + 1, named.len(), scene.name),
        );
        let (r, s) = scene_rows(&gpu, scene, runs)?;
        rows.extend(r);
        spreads.extend(s);
    }
    let crossover = if with_crossover {
        Some(crossover(&gpu, runs, |kind, n| {
            say(Stream::Stderr, &format!("crossover: {n} {kind}"));
        })?)
    } else {
        None
    };
    let report = Report {
        provenance: Provenance::now(Some(&gpu)),
        runs,
        kernel_times: has_kernel_times(&gpu),
        scenes: named,
        rows,
        spreads,
        notes,
        crossover,
    };
    let text = document(&report);
    if let Some(out) = out {
        raycast_files::write_file(out, text.as_bytes())?;
    }
    say(Stream::Stdout, text.trim_end());
    if let Some(out) = out {
        say(Stream::Stderr, &format!("wrote {}", out.display()));
    }
    Ok(())
}

/// One size of the crossover measurement.
#[derive(Clone, Debug, PartialEq)]
pub struct CrossoverRow {
    /// `spheres` or `triangles`.
    pub kind: &'static str,
    pub n: usize,
    pub brute_ms: f64,
    pub bvh_ms: f64,
}

/// The sizes the crossover is measured at.
pub const CROSSOVER_SIZES: [usize; 8] = [2, 4, 8, 16, 32, 64, 128, 256];

/// Where a BVH starts to pay: `n` random spheres, and `n` random triangles, for each of
/// [`CROSSOVER_SIZES`], rendered at 640x360 by the brute-force and the BVH kernels (GPU, f32,
/// robust), interleaved, median of `runs` times each after a warm-up. `progress` is told each
/// size as it starts.
pub fn crossover(
    gpu: &Gpu,
    runs: usize,
    mut progress: impl FnMut(&str, usize),
) -> Result<Vec<CrossoverRow>> {
    let mut rng = Rng(1);
    let mut rows = Vec::new();
    for kind in ["spheres", "triangles"] {
        for n in CROSSOVER_SIZES {
            progress(kind, n);
            let scene = random_scene(kind, n, &mut rng);
            // Each lane casting its most rays, as the crossover was measured.
            let variants = [Search::BruteForce, Search::Bvh].map(|search| Kernel {
                tuning: Tuning {
                    search,
                    most_lane_rays: true,
                    ..Tuning::default()
                },
                outputs: Outputs::default(),
            });
            let t = interleaved_times(gpu, &scene, &variants, runs)?;
            rows.push(CrossoverRow {
                kind,
                n,
                brute_ms: 1e3 * t[0].median_s,
                bvh_ms: 1e3 * t[1].median_s,
            });
        }
    }
    Ok(rows)
}

/// The smallest measured n of `kind` from which the BVH is faster at every larger size.
pub fn measured_crossover(rows: &[CrossoverRow], kind: &str) -> Option<usize> {
    let of_kind: Vec<&CrossoverRow> = rows.iter().filter(|r| r.kind == kind).collect();
    let mut from = None;
    for r in of_kind.iter().rev() {
        if r.bvh_ms < r.brute_ms {
            from = Some(r.n);
        } else {
            break;
        }
    }
    from
}

/// The crossover table, in markdown.
pub fn crossover_table(rows: &[CrossoverRow]) -> String {
    let mut table = Table::text_then_numbers(
        &[
            "primitives",
            "n",
            "brute force ms",
            "BVH ms",
            "BVH / brute force",
        ],
        1,
    );
    for r in rows {
        table.row([
            r.kind.to_owned(),
            r.n.to_string(),
            format!("{:.2}", r.brute_ms),
            format!("{:.2}", r.bvh_ms),
            format!("{:.2}", r.bvh_ms / r.brute_ms),
        ]);
    }
    table.markdown()
}

fn crossover_section(rows: &[CrossoverRow]) -> String {
    let from = |kind| measured_crossover(rows, kind).map_or("never".into(), |n| format!("n = {n}"));
    format!(
        "## Where a BVH starts to pay\n\n\
         Random spheres (radius 0.1 to 0.5), and random triangles (corners within 0.5 of a \
         centre), in a 4 x 2.4 x 4 box, rendered at 640x360 by the brute-force and the BVH \
         kernels, interleaved, median of the same number of rounds as above \
         (`cargo run --release -p raycast-benches --bin bvh_crossover` prints this table from 5 rounds). \
         The BVH is faster from {} for spheres and from {} for triangles (the smallest \
         n from which it stays faster). `raycast render` builds one when \
         spheres / {} + triangles / {} >= 1 (`bvh::CROSSOVER`, `bvh::TRIANGLE_CROSSOVER`).\n\n{}",
        from("spheres"),
        from("triangles"),
        auto_crossover("spheres"),
        auto_crossover("triangles"),
        crossover_table(rows)
    )
}

/// A deterministic generator (SplitMix64).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }

    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }

    fn centre(&mut self) -> [f64; 3] {
        [
            self.range(-2.0, 2.0),
            self.range(-1.2, 1.2),
            self.range(-2.0, 2.0),
        ]
    }
}

const CROSSOVER_CAMERA: &str = r#""camera": {"eye": [0, 0, 6], "look": [0, 0, -1], "up": [0, 1, 0],
    "focal_length": 1.5, "width": 1.6, "height": 0.9, "resolution": [640, 360]}"#;

/// The smallest count of `kind` (spheres or triangles) alone from which [`Search::Auto`]
/// builds a BVH: the library's rule, asked rather than restated.
fn auto_crossover(kind: &str) -> usize {
    let mut rng = Rng(1);
    (1..)
        .find(|&n| Search::Auto.uses_bvh(&random_scene(kind, n, &mut rng)))
        .expect("Search::Auto builds a BVH for some count")
}

/// `n` random spheres or triangles, as `kind` says.
fn random_scene(kind: &str, n: usize, rng: &mut Rng) -> Scene {
    match kind {
        "spheres" => random_spheres(n, rng),
        _ => random_triangles(n, rng),
    }
}

fn random_spheres(n: usize, rng: &mut Rng) -> Scene {
    let objects: Vec<String> = (0..n)
        .map(|_| {
            let c = rng.centre();
            let r = rng.range(0.1, 0.5);
            format!(r#"{{"type": "sphere", "center": {c:?}, "radius": {r}}}"#)
        })
        .collect();
    let json = format!(
        r#"{{{CROSSOVER_CAMERA}, "objects": [{}]}}"#,
        objects.join(",")
    );
    Scene::from_json(&json, Path::new("spheres.json"), &mut |_, _| unreachable!())
        .expect("a generated scene is valid")
}

fn random_triangles(n: usize, rng: &mut Rng) -> Scene {
    let mesh: Vec<_> = (0..n)
        .map(|_| {
            let c = rng.centre();
            let mut corner = || {
                [
                    c[0] + rng.range(-0.5, 0.5),
                    c[1] + rng.range(-0.5, 0.5),
                    c[2] + rng.range(-0.5, 0.5),
                ]
                .into()
            };
            [corner(), corner(), corner()]
        })
        .collect();
    let json =
        format!(r#"{{{CROSSOVER_CAMERA}, "objects": [{{"type": "soup", "obj": "m.obj"}}]}}"#);
    Scene::from_json(&json, Path::new("triangles.json"), &mut |_, _| {
        let triangles = mesh.clone();
        Ok(vec![MeshPart {
            name: String::new(),
            triangles,
        }])
    })
    .expect("a generated scene is valid")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn crossover_row(kind: &'static str, n: usize, brute_ms: f64, bvh_ms: f64) -> CrossoverRow {
        CrossoverRow {
            kind,
            n,
            brute_ms,
            bvh_ms,
        }
    }

    /// The crossover is where the BVH stays faster, not its first lucky size.
    #[test]
    fn the_crossover_is_where_the_bvh_stays_faster() {
        let rows = [
            crossover_row("spheres", 2, 1.0, 0.9),
            crossover_row("spheres", 4, 1.0, 1.1),
            crossover_row("spheres", 8, 1.0, 0.8),
            crossover_row("spheres", 16, 2.0, 0.8),
            crossover_row("triangles", 2, 1.0, 1.5),
        ];
        assert_eq!(measured_crossover(&rows, "spheres"), Some(8));
        assert_eq!(measured_crossover(&rows, "triangles"), None);
    }

    #[test]
    fn the_table_shows_speed_ups_and_skipped_brute_force() {
        let rows = [
            Row {
                scene: "a".into(),
                specialization: Specialization::Bvh,
                with_ms: Some(2.0),
                without_ms: Some(5.0),
                default_with: Some(true),
                note: None,
            },
            Row {
                scene: "torus".into(),
                specialization: Specialization::Bvh,
                with_ms: Some(500.0),
                without_ms: None,
                default_with: Some(true),
                note: Some("brute force skipped (too slow): more than 20000 triangles".into()),
            },
        ];
        let t = table(&rows);
        assert!(
            t.contains("| a | BVH: BVH / brute force | 2.00 | 5.00 | 2.50x | BVH |"),
            "{t}"
        );
        assert!(t.contains("| 500 | skipped (too slow) | - |"), "{t}");
    }
}
