//! `raycast selftest`: a built-in suite rendered on the chosen adapter, each result checked
//! against the CPU reference (or an exact invariant), one [`Check`] a line.
//!
//! What it covers: the course's six scenes in the default mode against the course's renders;
//! f32, f64 and adaptive precision against CPU f64 on seeded random scenes; the extreme scenes'
//! invariants (2^k scaling, translation by up to 1e6); ray lists from one origin, from many and
//! incoherent; a shade hook that casts rays (the lit course bunny) against its CPU mirror; the
//! packet traversal the adapter's subgroups select; a mesh split over several storage bindings
//! rendered in tiles.
//!
//! f32 results are held to CPU f64 on every pixel whose margin is certain, distances within a
//! stated bound ([`F32Rule::Bounded`]); where the fusion probe ([`crate::adapter::fusion_probe`]) finds
//! `a*b - c*d` unfused and the adapter has f64 shaders (for the f64 rechecks the CPU mirror
//! makes), also to CPU f32 bit for bit ([`F32Rule::Exact`]).

pub mod data;
pub mod scenes;

use std::time::Instant;

use serde::Serialize;

use crate::compare::color_error;
use crate::render::render;
use raycast::Algorithm::{self, Robust, Textbook};
use raycast::Pictures;
use raycast::Scene;
use raycast::{AnyHits, Hits, Ray};
use raycast::{AnyImages, Device, Mode, Precision};
use raycast::{Cpu, Error, Gpu, RenderOptions, Result, Search, ShadeHook, Tuning};
use raycast::{Images, MISS};

/// How far a bounded f32 distance may be from CPU f64's, relative, where both hit one object.
pub const F32_DISTANCE_BOUND: f64 = 1e-5;

/// How far a translated scene's distances may move from the base scene's, relative.
pub const TRANSLATION_BOUND: f64 = 1e-6;

/// The share of an f32 ray list that may hit another object than CPU f64 (a ray list has no
/// margins to excuse a close call).
pub const F32_RAY_ID_BOUND: f64 = 1e-3;

/// How far any f32 hit point of a ray list may be from CPU f64's, relative to the ray's extent:
/// grazing hits, whose t is ill-conditioned, included.
pub const F32_GRAZING_BOUND: f64 = 1e-3;

/// What to run.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Options {
    /// Only the checks whose name contains one of these (all when empty).
    pub only: Vec<String>,
    /// The check whose GPU result is made wrong in one pixel or ray, to show that it fails.
    pub plant: Option<String>,
}

/// A check's verdict.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Outcome {
    Pass,
    Fail,
    /// Not run on this adapter (the measured text says why).
    Skip,
}

/// One line of the self-test: what was rendered, how, what was measured against what bound.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Check {
    pub name: String,
    pub mode: String,
    pub measured: String,
    pub tolerance: String,
    pub result: Outcome,
    /// Wall seconds of the check, kernel compilation included.
    pub seconds: f64,
}

impl Check {
    /// The line printed for it: name, mode, measured, tolerance, result.
    pub fn line(&self) -> String {
        let result = match self.result {
            Outcome::Pass => "pass",
            Outcome::Fail => "FAIL",
            Outcome::Skip => "skip",
        };
        format!(
            "{:<34} {:<30} {}  [tolerance: {}]  {result} ({:.1} s)",
            self.name, self.mode, self.measured, self.tolerance, self.seconds
        )
    }
}

/// How the GPU's f32 results are judged on this adapter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum F32Rule {
    /// No fusion, and f64 shaders for the f64 rechecks the CPU mirror makes: every f32 result
    /// equals CPU f32's bit for bit.
    Exact,
    /// The driver contracts `a*b - c*d`, or has no f64 shaders: hit/miss and id as CPU f64
    /// wherever the pixel's margin is certain, distances within [`F32_DISTANCE_BOUND`].
    Bounded,
}

/// The whole run.
#[derive(Clone, Debug, PartialEq)]
pub struct Report {
    pub checks: Vec<Check>,
    pub seconds: f64,
}

impl Report {
    pub fn count(&self, outcome: Outcome) -> usize {
        self.checks.iter().filter(|c| c.result == outcome).count()
    }

    pub fn passed(&self) -> bool {
        self.count(Outcome::Fail) == 0
    }

    /// `selftest: 40 passed, 0 failed, 1 skipped in 41.2 s`, and the failed checks' names.
    pub fn summary(&self) -> String {
        let mut s = format!(
            "selftest: {} passed, {} failed, {} skipped in {:.1} s",
            self.count(Outcome::Pass),
            self.count(Outcome::Fail),
            self.count(Outcome::Skip),
            self.seconds
        );
        let failed: Vec<&str> = (self.checks.iter())
            .filter(|c| c.result == Outcome::Fail)
            .map(|c| c.name.as_str())
            .collect();
        if !failed.is_empty() {
            s += &format!("; FAILED: {}", failed.join(", "));
        }
        s
    }
}

/// What a check found.
struct Verdict {
    measured: String,
    tolerance: String,
    outcome: Outcome,
}

impl Verdict {
    fn new(measured: String, tolerance: impl Into<String>, pass: bool) -> Verdict {
        let outcome = if pass { Outcome::Pass } else { Outcome::Fail };
        let tolerance = tolerance.into();
        Verdict {
            measured,
            tolerance,
            outcome,
        }
    }

    fn skip(why: impl Into<String>) -> Verdict {
        Verdict {
            measured: why.into(),
            tolerance: "-".into(),
            outcome: Outcome::Skip,
        }
    }
}

/// The adapter and the options a check runs with.
struct Ctx<'a> {
    gpu: &'a Gpu,
    rule: F32Rule,
}

impl Ctx<'_> {
    /// Whether the adapter runs f64 kernels (`SHADER_F64`).
    fn has_f64(&self) -> bool {
        self.gpu.info().f64
    }

    /// `mode` runs here: not f64 on an adapter without f64 kernels (adaptive precision re-casts
    /// on the CPU there).
    fn runs(&self, mode: Mode) -> bool {
        mode.precision != Precision::F64 || self.has_f64()
    }

    /// What a check of several modes says when it left f64 out.
    fn f64_skipped(&self) -> &'static str {
        match self.has_f64() {
            true => "",
            false => " (f64 skipped: no SHADER_F64)",
        }
    }
}

/// Why an f64 check is skipped.
const NO_F64: &str = "the adapter has no f64 shaders (SHADER_F64)";

type Body<'a> = Box<dyn FnOnce(&Ctx, bool) -> Result<Verdict> + 'a>;

/// A check to run: its body gets whether to plant a wrong result.
struct Planned<'a> {
    name: String,
    mode: String,
    body: Body<'a>,
}

fn planned<'a>(
    name: impl Into<String>,
    mode: impl Into<String>,
    body: impl FnOnce(&Ctx, bool) -> Result<Verdict> + 'a,
) -> Planned<'a> {
    Planned {
        name: name.into(),
        mode: mode.into(),
        body: Box::new(body),
    }
}

/// The adapter as the self-test judges it.
#[derive(Clone, Debug, PartialEq)]
pub struct Adapter {
    /// Name, backend, driver, f64, subgroups and fusion, as the report opens with them.
    pub lines: Vec<String>,
    pub rule: F32Rule,
}

impl Adapter {
    /// Probes `gpu` for fusion ([`crate::adapter::fusion_probe`]) and describes it.
    pub fn probe(gpu: &Gpu) -> Result<Adapter> {
        let fusion = crate::adapter::fusion_probe(gpu)?;
        let f64_support = gpu.info().f64;
        // Without f64 shaders the robust f32 kernel leaves out the f64 rechecks (edge signs,
        // a triangle's t) that the CPU mirror always makes.
        let rule = if fusion.unfused == fusion.samples && f64_support {
            F32Rule::Exact
        } else {
            F32Rule::Bounded
        };
        let info = gpu.info().adapter;
        let subgroups = if gpu.info().packet_subgroups {
            format!(
                "{}-{} lanes",
                info.subgroup_min_size, info.subgroup_max_size
            )
        } else {
            "none used".into()
        };
        let judged = match (rule, f64_support) {
            (F32Rule::Exact, _) => "f32 is held to CPU f32 bit for bit",
            (F32Rule::Bounded, true) => "f32 is held to CPU f64 within stated bounds",
            (F32Rule::Bounded, false) => {
                "f32 is held to CPU f64 within stated bounds (without f64 shaders the kernel leaves out the CPU mirror's f64 rechecks)"
            }
        };
        let lines = vec![
            format!(
                "adapter: {} ({:?}, {:?}), driver {} {}",
                info.name, info.backend, info.device_type, info.driver, info.driver_info
            ),
            format!(
                "shader f64: {}; subgroups: {subgroups}; f32 a*b - c*d: {}: {judged}",
                if f64_support { "yes" } else { "no" },
                fusion.describe()
            ),
            format!(
                "BVH traversal by default: {}; ray queries: {} (unused: the checks are raycast's own traversal)",
                match gpu.info().packet_rays_per_primitive {
                    Some(r) => format!("packets from {r} rays a sphere or triangle, else per ray"),
                    None => "per ray".into(),
                },
                match gpu
                    .adapter
                    .features()
                    .contains(wgpu::Features::EXPERIMENTAL_RAY_QUERY)
                {
                    true => "the adapter has them",
                    false => "the adapter has none",
                }
            ),
        ];
        Ok(Adapter { lines, rule })
    }
}

/// Names every check [`run`] would run with `options`, in order, without running any.
pub fn names(gpu: &Gpu, options: &Options) -> Vec<String> {
    plan(gpu, options).into_iter().map(|p| p.name).collect()
}

/// The error [`run`] would give for `options` before running anything: `--only` matching no
/// check, or `--plant` naming none of those it selects.
pub fn check_options(gpu: &Gpu, options: &Options) -> Result<()> {
    refuse_bad_options(&plan(gpu, options), options)
}

fn refuse_bad_options(checks: &[Planned], options: &Options) -> Result<()> {
    if checks.is_empty() {
        return Err(Error::Argument {
            option: "--only".into(),
            message: format!("no check's name contains `{}`", options.only.join("` or `")),
        });
    }
    match &options.plant {
        Some(plant) if !checks.iter().any(|c| &c.name == plant) => Err(Error::Argument {
            option: "--plant".into(),
            message: format!(
                "no check to run is named `{plant}` (the names are the first column of `raycast selftest`)"
            ),
        }),
        _ => Ok(()),
    }
}

/// Runs the self-test on `gpu`, calling `on_check` as each check ends. A check whose render
/// fails is a failed check (the error its measurement); an unknown `plant` is an error before
/// anything runs.
pub fn run(
    gpu: &Gpu,
    adapter: &Adapter,
    options: &Options,
    on_check: &mut dyn FnMut(&Check),
) -> Result<Report> {
    let start = Instant::now();
    let checks = plan(gpu, options);
    refuse_bad_options(&checks, options)?;
    let ctx = Ctx {
        gpu,
        rule: adapter.rule,
    };
    let mut done = Vec::with_capacity(checks.len());
    for p in checks {
        let planted = options.plant.as_deref() == Some(p.name.as_str());
        let check = perform(&ctx, p, planted);
        on_check(&check);
        done.push(check);
    }
    Ok(Report {
        checks: done,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// Runs one check, timed; a failed render fails the check.
fn perform(ctx: &Ctx, p: Planned, planted: bool) -> Check {
    let began = Instant::now();
    let verdict = (p.body)(ctx, planted).unwrap_or_else(|e| Verdict {
        measured: format!("error: {e}"),
        tolerance: "no error".into(),
        outcome: Outcome::Fail,
    });
    Check {
        name: p.name,
        mode: p.mode,
        measured: verdict.measured,
        tolerance: verdict.tolerance,
        result: verdict.outcome,
        seconds: began.elapsed().as_secs_f64(),
    }
}

/// Every check, filtered by `options.only`.
fn plan<'a>(gpu: &Gpu, options: &'a Options) -> Vec<Planned<'a>> {
    let mut all = Vec::new();
    for name in scenes::COURSE_SCENES {
        all.push(planned(
            format!("course/{name}"),
            "gpu:adaptive:robust (default)",
            move |ctx, planted| course(ctx, name, planted),
        ));
    }
    let packets = packet_path(gpu);
    for seed in RANDOM_SEEDS {
        for (traversal, on) in [(packets.as_str(), true), ("per ray", false)] {
            // Packets asked for on every seed, ray by ray on one: the suite's other renders
            // take the device's choice (ray by ray on hardware GPUs).
            if !on && seed != RANDOM_SEEDS[0] {
                continue;
            }
            all.push(planned(
                format!(
                    "random-{seed}/f32/{}",
                    if on { "packets" } else { "per-ray" }
                ),
                format!("gpu:f32:robust, bvh, {traversal}"),
                move |ctx, planted| random_f32(ctx, seed, on, planted),
            ));
        }
        for precision in [Precision::F64, Precision::Adaptive] {
            all.push(planned(
                format!("random-{seed}/{precision}"),
                format!("gpu:{precision}:robust"),
                move |ctx, planted| ids_as_cpu_f64(ctx, &random(seed), precision, planted),
            ));
        }
    }
    all.extend(wide_path_skipped(gpu));
    for precision in [Precision::F32, Precision::F64, Precision::Adaptive] {
        all.push(planned(
            format!("extremes/dyadic-base/{precision}"),
            format!("gpu:{precision}:robust"),
            move |ctx, planted| {
                let scene = data::extreme("dyadic-base")?;
                match precision {
                    Precision::F32 => scene_f32(ctx, &scene, planted),
                    _ => ids_as_cpu_f64(ctx, &scene, precision, planted),
                }
            },
        ));
    }
    for name in data::SCALED {
        all.push(planned(
            format!("extremes/{name}"),
            "f32, f64, adaptive, textbook f32",
            move |ctx, planted| scaled(ctx, name, planted),
        ));
    }
    for name in data::TRANSLATED {
        all.push(planned(
            format!("extremes/{name}"),
            "f32, f64, adaptive",
            move |ctx, planted| translated(ctx, name, planted),
        ));
    }
    for list in RayKind::ALL {
        // f64 and adaptive on the incoherent list: the others differ only in f32's packets.
        for precision in [Precision::F32, Precision::F64, Precision::Adaptive] {
            if precision != Precision::F32 && list != RayKind::Incoherent {
                continue;
            }
            all.push(planned(
                format!("rays/{}/{precision}", list.name()),
                format!("gpu:{precision}:robust, {} rays", list.len()),
                move |ctx, planted| ray_list(ctx, list, precision, planted),
            ));
        }
    }
    all.push(planned(
        "lit/bunny",
        "gpu:f32:robust, shaders/examples/raytrace.wgsl",
        lit_bunny,
    ));
    all.push(planned(
        format!("streaming/random-{}", RANDOM_SEEDS[1]),
        format!(
            "gpu:f32:robust, triangles in bindings of {STREAM_CHUNK}, tiles of {STREAM_ROWS} rows"
        ),
        streaming,
    ));
    all.retain(|p| {
        options.only.is_empty() || options.only.iter().any(|o| p.name.contains(o.as_str()))
    });
    all
}

const ADAPTIVE: Mode = Mode {
    device: Device::Gpu,
    precision: Precision::Adaptive,
    algorithm: Robust,
};

fn gpu_mode(precision: Precision, algorithm: Algorithm) -> Mode {
    Mode {
        device: Device::Gpu,
        precision,
        algorithm,
    }
}

/// Makes one result wrong: the first hit becomes a miss (or the first miss a hit).
fn plant(ids: &mut [i32]) {
    match ids.iter().position(|&id| id != MISS) {
        Some(k) => ids[k] = MISS,
        None => ids.iter_mut().take(1).for_each(|id| *id = 0),
    }
}

fn plant_any(images: &mut AnyImages) {
    match images {
        AnyImages::F32(i) => plant(&mut i.id),
        AnyImages::F64(i) => plant(&mut i.id),
    }
}

fn any_pictures(images: &AnyImages) -> Pictures {
    images.pictures()
}

/// (pixels that differ in any channel, the largest channel difference)
fn picture_diff(a: &[u8], b: &[u8], channels: usize) -> (usize, u8) {
    let mut differing = 0;
    let mut largest = 0;
    for (pa, pb) in a.chunks(channels).zip(b.chunks(channels)) {
        let level = pa.iter().zip(pb).map(|(x, y)| x.abs_diff(*y)).max();
        let level = level.unwrap_or(0);
        differing += usize::from(level > 0);
        largest = largest.max(level);
    }
    (differing, largest)
}

/// The default render of a course scene against the course's: ids exact, depth and normal
/// within one level (the course's own renders are f64, truncated to 8 bits).
fn course(ctx: &Ctx, name: &str, planted: bool) -> Result<Verdict> {
    let scene = data::course_scene(name)?;
    let mut images = render(&scene, ADAPTIVE, Some(ctx.gpu), RenderOptions::default())?;
    if planted {
        plant_any(&mut images);
    }
    let ours = any_pictures(&images);
    let id_render = data::course_render(name, "id")?;
    if ours.id.len() != id_render.len() {
        return Err(Error::Device(format!("{name}: the render's size changed")));
    }
    let (id, _) = picture_diff(&ours.id, &id_render, 3);
    let (_, depth) = picture_diff(&ours.depth, &data::course_render(name, "depth")?, 1);
    let (_, normal) = picture_diff(&ours.normal, &data::course_render(name, "normal")?, 3);
    Ok(Verdict::new(
        format!("id differs on {id} px; depth within {depth}, normal within {normal} levels"),
        "id 0 px; depth and normal within 1 level",
        id == 0 && depth <= 1 && normal <= 1,
    ))
}

/// Seeds of the random scenes: even seeds have a plane, as the extreme scenes do, so that
/// their kernels are the same and compile once.
const RANDOM_SEEDS: [u64; 2] = [0, 2];

fn random(seed: u64) -> Scene {
    scenes::random_scene(seed, [64, 48])
}

/// `scene` on the GPU in f32 (robust) with `tuning` and the hook `shade`, each lane casting its
/// most rays whatever the image's size.
fn gpu_f32(
    gpu: &Gpu,
    scene: &Scene,
    tuning: Tuning,
    shade: Option<ShadeHook>,
) -> Result<Images<f32>> {
    let options = RenderOptions {
        precision: Some(Precision::F32),
        shade,
        tuning: Tuning {
            most_lane_rays: true,
            ..tuning
        },
        ..RenderOptions::default()
    };
    f32_images(gpu.render(scene, &options)?)
}

/// `scene` by the CPU reference in f32 (robust), searching with `search`.
fn cpu_f32(scene: &Scene, search: Search) -> Result<Images<f32>> {
    let options = RenderOptions {
        precision: Some(Precision::F32),
        tuning: Tuning {
            search,
            ..Tuning::default()
        },
        ..RenderOptions::default()
    };
    f32_images(Cpu.render(scene, &options)?)
}

/// `scene` by the CPU reference in f64 (robust): the truth.
fn cpu_f64(scene: &Scene) -> Result<Images<f64>> {
    let options = RenderOptions {
        precision: Some(Precision::F64),
        ..RenderOptions::default()
    };
    match Cpu.render(scene, &options)? {
        AnyImages::F64(images) => Ok(images),
        AnyImages::F32(_) => Err(Error::Device("an f64 render returned f32 images".into())),
    }
}

fn f32_images(images: AnyImages) -> Result<Images<f32>> {
    match images {
        AnyImages::F32(images) => Ok(images),
        AnyImages::F64(_) => Err(Error::Device("an f32 render returned f64 images".into())),
    }
}

/// f32 through the BVH, in packets or ray by ray, judged by the adapter's [`F32Rule`].
fn random_f32(ctx: &Ctx, seed: u64, packets: bool, planted: bool) -> Result<Verdict> {
    let scene = random(seed);
    if packets && !ctx.gpu.info().packet_subgroups {
        return Ok(Verdict::skip("this adapter has no subgroups for packets"));
    }
    let tuning = Tuning {
        search: Search::Bvh,
        packets: Some(packets),
        ..Tuning::default()
    };
    let mut images = gpu_f32(ctx.gpu, &scene, tuning, None)?;
    if planted {
        plant(&mut images.id);
    }
    judge_f32(ctx, &scene, &images)
}

/// An f32 camera render through the BVH by the adapter's rule: CPU f64 on every certain pixel,
/// and where the rule is exact CPU f32 bit for bit too.
fn judge_f32(ctx: &Ctx, scene: &Scene, images: &Images<f32>) -> Result<Verdict> {
    judge_f32_with(ctx, scene, images, Search::Bvh)
}

/// [`judge_f32`] of a render that searched with `accel` (the CPU f32 reference searches so too).
fn judge_f32_with(
    ctx: &Ctx,
    scene: &Scene,
    images: &Images<f32>,
    accel: Search,
) -> Result<Verdict> {
    let f64_side = MarginCheck::of(scene, images)?;
    Ok(match ctx.rule {
        F32Rule::Exact => {
            let cpu = cpu_f32(scene, accel)?;
            let differ = differing_bits(images, &cpu);
            Verdict::new(
                format!(
                    "{differ} of {} px differ from CPU f32; {}",
                    images.id.len(),
                    f64_side.measured()
                ),
                format!(
                    "0 px (bit for bit: no fusion); {}",
                    MarginCheck::tolerance()
                ),
                differ == 0 && f64_side.pass(),
            )
        }
        F32Rule::Bounded => Verdict::new(
            f64_side.measured(),
            MarginCheck::tolerance(),
            f64_side.pass(),
        ),
    })
}

/// Pixels whose id, distance or normal bits differ.
fn differing_bits<T: Copy + Into<f64>>(a: &Images<T>, b: &Images<T>) -> usize {
    let bits = |x: T| x.into().to_bits();
    (0..a.id.len())
        .filter(|&k| {
            a.id[k] != b.id[k]
                || bits(a.distance[k]) != bits(b.distance[k])
                || (0..3).any(|c| bits(a.normal[k][c]) != bits(b.normal[k][c]))
        })
        .count()
}

/// Robust f32 against CPU f64: hit/miss and id on every pixel whose f32 margins are certain
/// ([`Cpu::f32_margins`]), distances within [`F32_DISTANCE_BOUND`] where both hit one object.
struct MarginCheck {
    /// Certain pixels whose hit/miss or id differs.
    wrong: usize,
    uncertain: usize,
    /// The largest relative distance error where both hit one object.
    worst: f64,
}

impl MarginCheck {
    fn tolerance() -> String {
        format!("0 certain px; distance within {F32_DISTANCE_BOUND:.0e}")
    }

    fn of(scene: &Scene, images: &Images<f32>) -> Result<MarginCheck> {
        let truth = cpu_f64(scene)?;
        let certain = Cpu.certain_in_f32(scene);
        let (mut wrong, mut uncertain, mut worst) = (0, 0, 0.0f64);
        for (k, &[hit, id]) in certain.iter().enumerate() {
            let (a, b) = (images.id[k], truth.id[k]);
            uncertain += usize::from(!id);
            if (hit && (a == MISS) != (b == MISS)) || (id && a != b) {
                wrong += 1;
            } else if a == b && a != MISS {
                let d = truth.distance[k];
                worst = worst.max((images.distance[k] as f64 - d).abs() / d);
            }
        }
        Ok(MarginCheck {
            wrong,
            uncertain,
            worst,
        })
    }

    fn measured(&self) -> String {
        format!(
            "{} certain px differ from CPU f64 ({} uncertain), distance within {:.1e}",
            self.wrong, self.uncertain, self.worst
        )
    }

    fn pass(&self) -> bool {
        self.wrong == 0 && self.worst <= F32_DISTANCE_BOUND
    }
}

/// The ids of `scene` in `precision` (f64 or adaptive) equal CPU f64's on every pixel.
fn ids_as_cpu_f64(
    ctx: &Ctx,
    scene: &Scene,
    precision: Precision,
    planted: bool,
) -> Result<Verdict> {
    if !ctx.runs(gpu_mode(precision, Robust)) {
        return Ok(Verdict::skip(NO_F64));
    }
    let mode = gpu_mode(precision, Robust);
    let mut images = render(scene, mode, Some(ctx.gpu), RenderOptions::default())?;
    if planted {
        plant_any(&mut images);
    }
    let truth = cpu_f64(scene)?;
    let differ = (images.id().iter().zip(&truth.id))
        .filter(|(a, b)| a != b)
        .count();
    Ok(Verdict::new(
        format!(
            "ids differ from CPU f64 on {differ} of {} px",
            truth.id.len()
        ),
        "0 px",
        differ == 0,
    ))
}

/// Robust f32 of a file scene by the kernel a render picks for it, judged by the adapter's rule.
fn scene_f32(ctx: &Ctx, scene: &Scene, planted: bool) -> Result<Verdict> {
    let mut images = gpu_f32(ctx.gpu, scene, Tuning::default(), None)?;
    if planted {
        plant(&mut images.id);
    }
    judge_f32_with(ctx, scene, &images, Search::Auto)
}

/// (ids, distances, normals) widened to f64.
type Widened = (Vec<i32>, Vec<f64>, Vec<[f64; 3]>);

fn widen(images: AnyImages) -> Widened {
    fn of<T: Copy + Into<f64>>(i: Images<T>) -> Widened {
        let distance = i.distance.iter().map(|&d| d.into()).collect();
        let normal = i.normal.iter().map(|n| n.map(T::into)).collect();
        (i.id, distance, normal)
    }
    match images {
        AnyImages::F32(i) => of(i),
        AnyImages::F64(i) => of(i),
    }
}

const INVARIANT_MODES: [Mode; 4] = [
    Mode {
        device: Device::Gpu,
        precision: Precision::F32,
        algorithm: Robust,
    },
    Mode {
        device: Device::Gpu,
        precision: Precision::F64,
        algorithm: Robust,
    },
    ADAPTIVE,
    Mode {
        device: Device::Gpu,
        precision: Precision::F32,
        algorithm: Textbook,
    },
];

/// The base scene and `scene`, rendered in `mode`; the planted fault goes into `scene`'s.
fn render_pair(ctx: &Ctx, scene: &Scene, mode: Mode, planted: bool) -> Result<[Widened; 2]> {
    let base = data::extreme("dyadic-base")?;
    let base = widen(render(
        &base,
        mode,
        Some(ctx.gpu),
        RenderOptions::default(),
    )?);
    let mut ours = render(scene, mode, Some(ctx.gpu), RenderOptions::default())?;
    if planted {
        plant_any(&mut ours);
    }
    Ok([base, widen(ours)])
}

/// A scene scaled by 2^k: in every mode the base's ids and normals, distances exactly 2^k
/// times the base's.
fn scaled(ctx: &Ctx, name: &str, planted: bool) -> Result<Verdict> {
    let scene = data::extreme(name)?;
    let scale = data::scale_of(name)?;
    let mut failures = Vec::new();
    for mode in INVARIANT_MODES.into_iter().filter(|&m| ctx.runs(m)) {
        let [(base_id, base_d, base_n), (id, d, n)] = render_pair(ctx, &scene, mode, planted)?;
        let ids = (0..id.len()).filter(|&k| id[k] != base_id[k]).count();
        let hit = |k: &usize| id[*k] != MISS && id[*k] == base_id[*k];
        let distances = (0..id.len())
            .filter(hit)
            .filter(|&k| d[k] != base_d[k] * scale)
            .count();
        let normals = (0..id.len())
            .filter(hit)
            .filter(|&k| n[k] != base_n[k])
            .count();
        if ids + distances + normals > 0 {
            failures.push(format!(
                "{mode}: {ids} ids, {distances} distances, {normals} normals"
            ));
        }
    }
    let measured = match failures.is_empty() {
        true => format!("the base's ids and normals, distances x 2^{}", scale.log2()),
        false => format!("differ from the base: {}", failures.join("; ")),
    } + ctx.f64_skipped();
    Ok(Verdict::new(
        measured,
        "0 px differ (exact)",
        failures.is_empty(),
    ))
}

/// A translated scene: in robust f32, f64 and adaptive precision the base's ids, distances
/// within [`TRANSLATION_BOUND`] (relative).
fn translated(ctx: &Ctx, name: &str, planted: bool) -> Result<Verdict> {
    let scene = data::extreme(name)?;
    let (mut ids, mut worst) = (Vec::new(), 0.0f64);
    for mode in INVARIANT_MODES[..3].iter().filter(|&&m| ctx.runs(m)) {
        let [(base_id, base_d, _), (id, d, _)] = render_pair(ctx, &scene, *mode, planted)?;
        let differ = (0..id.len()).filter(|&k| id[k] != base_id[k]).count();
        if differ > 0 {
            ids.push(format!("{mode}: {differ}"));
        }
        for k in (0..id.len()).filter(|&k| id[k] != MISS && id[k] == base_id[k]) {
            worst = worst.max(((d[k] - base_d[k]) / base_d[k]).abs());
        }
    }
    let id_text = match ids.is_empty() {
        true => "the base's ids".to_owned(),
        false => format!("ids differ ({})", ids.join("; ")),
    };
    Ok(Verdict::new(
        format!(
            "{id_text}; distance within {worst:.1e} of the base's{}",
            ctx.f64_skipped()
        ),
        format!("0 ids differ; distance within {TRANSLATION_BOUND:.0e}"),
        ids.is_empty() && worst <= TRANSLATION_BOUND,
    ))
}

/// The ray lists cast at a random scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum RayKind {
    /// A pinhole camera's rays: one origin.
    OneOrigin,
    /// The same rays each moved a little along itself: as many origins.
    ManyOrigins,
    /// Origins anywhere about the scene, directions anywhere.
    Incoherent,
}

impl RayKind {
    const ALL: [RayKind; 3] = [
        RayKind::OneOrigin,
        RayKind::ManyOrigins,
        RayKind::Incoherent,
    ];
    const WIDTH: usize = 90;
    const HEIGHT: usize = 50;

    fn name(self) -> &'static str {
        match self {
            RayKind::OneOrigin => "one-origin",
            RayKind::ManyOrigins => "many-origins",
            RayKind::Incoherent => "incoherent",
        }
    }

    fn len(self) -> usize {
        Self::WIDTH * Self::HEIGHT
    }

    fn rays(self, eye: [f64; 3]) -> Vec<Ray> {
        let pinhole = scenes::pinhole_rays(eye, Self::WIDTH, Self::HEIGHT, 0.2);
        match self {
            RayKind::OneOrigin => pinhole,
            RayKind::ManyOrigins => scenes::moved_along(&pinhole, 1e-3),
            RayKind::Incoherent => scenes::incoherent_rays(self.len(), 2.5, 7),
        }
    }
}

fn f32_hits(hits: AnyHits) -> Result<Hits<f32>> {
    match hits {
        AnyHits::F32(h) => Ok(h),
        AnyHits::F64(_) => Err(Error::Device("an f32 cast returned f64 hits".into())),
    }
}

/// A ray list cast at random scene 2: f32 by the adapter's rule (CPU f32's hits bit for bit,
/// or CPU f64's ids but for [`F32_RAY_ID_BOUND`] of the rays), f64 and adaptive with CPU
/// f64's ids.
fn ray_list(ctx: &Ctx, kind: RayKind, precision: Precision, planted: bool) -> Result<Verdict> {
    if !ctx.runs(gpu_mode(precision, Robust)) {
        return Ok(Verdict::skip(NO_F64));
    }
    let scene = random(2);
    let rays = kind.rays(scene.camera.eye.to_array());
    let geometry = raycast::Geometry::from_scene(&scene);
    let cast = |device, precision| match device {
        Device::Gpu => ctx.gpu.commit(&geometry, precision)?.intersect(&rays[..]),
        Device::Cpu => raycast::Cpu
            .commit(&geometry, precision)?
            .intersect(&rays[..]),
    };
    let mut ours = cast(Device::Gpu, precision)?;
    if planted {
        match &mut ours {
            AnyHits::F32(h) => plant(&mut h.id),
            AnyHits::F64(h) => plant(&mut h.id),
        }
    }
    let hit = ours.id().iter().filter(|&&id| id != MISS).count();
    if hit * 10 < rays.len() {
        return Err(Error::Device(format!(
            "only {hit} of {} rays hit: the list misses the scene",
            rays.len()
        )));
    }
    let exact = cast(Device::Cpu, Precision::F64)?;
    let id_differ = (ours.id().iter().zip(exact.id()))
        .filter(|(a, b)| a != b)
        .count();
    let n = rays.len();
    if precision != Precision::F32 {
        return Ok(Verdict::new(
            format!("ids differ from CPU f64 on {id_differ} of {n} rays"),
            "0 rays",
            id_differ == 0,
        ));
    }
    let ours = f32_hits(ours)?;
    // The hit point's error against the ray's extent |o| + t |d| (a ray starting near a
    // surface has a tiny t whose own relative error says nothing of the arithmetic). Grazing
    // hits, where t is ill-conditioned, get a looser bound than the 99% of rays.
    let t = exact.t_f64();
    let length = |v: [f64; 3]| v.iter().map(|c| c * c).sum::<f64>().sqrt();
    let mut errors: Vec<f64> = (0..n)
        .filter(|&k| ours.id[k] != MISS && ours.id[k] == exact.id()[k])
        .map(|k| {
            let (o, d) = (
                length(rays[k].origin.into()),
                length(rays[k].direction.into()),
            );
            (ours.t[k] as f64 - t[k]).abs() * d / (o + t[k] * d)
        })
        .collect();
    errors.sort_by(f64::total_cmp);
    let p99 = errors.get(errors.len() * 99 / 100).copied().unwrap_or(0.0);
    let worst = errors.last().copied().unwrap_or(0.0);
    let against_f64 = format!(
        "ids differ from CPU f64 on {id_differ} of {n} rays, hit points within {p99:.1e} (99%), {worst:.1e} (all)"
    );
    let f64_tolerance = format!(
        "ids on all but {F32_RAY_ID_BOUND:.0e} of rays; hit points within {F32_DISTANCE_BOUND:.0e} (99%), {F32_GRAZING_BOUND:.0e} (all) of |o| + t|d|"
    );
    let f64_pass = id_differ as f64 <= F32_RAY_ID_BOUND * n as f64
        && p99 <= F32_DISTANCE_BOUND
        && worst <= F32_GRAZING_BOUND;
    Ok(match ctx.rule {
        F32Rule::Exact => {
            let cpu = f32_hits(cast(Device::Cpu, Precision::F32)?)?;
            let bits = |x: f32| x.to_bits();
            let differ = (0..n)
                .filter(|&k| {
                    ours.id[k] != cpu.id[k]
                        || bits(ours.t[k]) != bits(cpu.t[k])
                        || ours.primitive[k] != cpu.primitive[k]
                        || ours.uv[k].map(bits) != cpu.uv[k].map(bits)
                        || ours.normal[k].map(bits) != cpu.normal[k].map(bits)
                })
                .count();
            Verdict::new(
                format!("{differ} of {n} rays' hits differ from CPU f32; {against_f64}"),
                format!("0 rays (bit for bit: no fusion); {f64_tolerance}"),
                differ == 0 && f64_pass,
            )
        }
        F32Rule::Bounded => Verdict::new(against_f64, f64_tolerance, f64_pass),
    })
}

/// The lit course bunny's size here (a quarter of its pixels).
const LIT_SIZE: [u32; 2] = [320, 180];

/// The course's ray tracer (a hook that casts rays) on the GPU in f32 against its CPU mirror
/// in f32. Only the driver's built-ins (`pow` above all) may differ, which moves a pixel by a
/// level where it lands on a level's edge; with fusion, hits move too, so the bound is the
/// course's bar against the instructor's renders.
fn lit_bunny(ctx: &Ctx, planted: bool) -> Result<Verdict> {
    let hook = ShadeHook::raytrace()?;
    let mut scene = data::scene("scenes/ray-tracing/bunny.json")?;
    scene.camera.resolution = LIT_SIZE;
    let lit = gpu_f32(ctx.gpu, &scene, Tuning::default(), Some(hook.clone()))?;
    let mut colours = lit
        .color
        .ok_or_else(|| Error::Device("the hook returned no colours".into()))?;
    if planted && let Some(c) = colours.first_mut() {
        c[0] ^= 0x80;
    }
    let options = RenderOptions {
        precision: Some(Precision::F32),
        shade: Some(hook),
        ..RenderOptions::default()
    };
    let mirrored = f32_images(Cpu.render(&scene, &options)?)?;
    let mirror = mirrored
        .color
        .ok_or_else(|| Error::Device("the CPU mirror returned no colours".into()))?;
    let mirror_rays = mirrored.hook_rays.unwrap_or(0);
    let e = color_error(&colours, &mirror);
    let rays = lit.hook_rays.unwrap_or(0);
    let ray_error = rays.abs_diff(mirror_rays) as f64 / mirror_rays.max(1) as f64;
    let measured = format!(
        "{:.3}% identical, {:.3}% beyond 2 levels, mean {:.4}, max {} levels; {rays} rays ({ray_error:.1e} off)",
        100.0 * e.exact,
        100.0 * e.beyond_2,
        e.mean_abs,
        e.max
    );
    Ok(match ctx.rule {
        F32Rule::Exact => Verdict::new(
            measured,
            "99.9% identical, max 2 levels; rays within 1e-4",
            e.exact >= 0.999 && e.max <= 2 && ray_error <= 1e-4,
        ),
        F32Rule::Bounded => Verdict::new(
            measured,
            "at most 0.5% beyond 2 levels, mean 0.25; rays within 1e-3",
            e.beyond_2 <= 0.005 && e.mean_abs <= 0.25 && ray_error <= 1e-3,
        ),
    })
}

/// Packets vote by butterflies where subgroups are exactly this many lanes wide.
const PACKET_LANES: u32 = 8;

/// Whether this adapter's packets take the eight-lane path (subgroups exactly 8 wide).
fn eight_lanes(gpu: &Gpu) -> bool {
    gpu.info().packet_subgroups && gpu.info().adapter.subgroup_max_size == PACKET_LANES
}

/// The packet traversal this adapter's subgroups select: eight lanes a packet by butterfly
/// votes where subgroups are 8 wide, by `subgroupAny` and `subgroupAdd` where wider.
fn packet_path(gpu: &Gpu) -> String {
    let lanes = gpu.info().adapter.subgroup_max_size;
    match (gpu.info().packet_subgroups, eight_lanes(gpu)) {
        (false, _) => "no subgroups: ray by ray".into(),
        (true, true) => format!("eight-lane packets ({lanes}-lane subgroups)"),
        (true, false) => format!("wide packets ({lanes}-lane subgroups)"),
    }
}

/// A line saying that the wide packet path does not run here, where it does not.
fn wide_path_skipped<'a>(gpu: &Gpu) -> Option<Planned<'a>> {
    let packets = gpu.info().packet_subgroups;
    if packets && !eight_lanes(gpu) {
        return None;
    }
    let why = match packets {
        true => format!(
            "needs subgroups wider than 8 lanes; this adapter's are {}",
            gpu.info().adapter.subgroup_max_size
        ),
        false => "needs subgroups, which this device does not offer".to_owned(),
    };
    Some(planned(
        "packets/wide",
        "gpu:f32:robust, bvh",
        move |_, _| Ok(Verdict::skip(why)),
    ))
}

/// Rows per tile of the streaming check.
const STREAM_ROWS: u32 = 7;

/// Triangles per storage binding in the streaming check.
const STREAM_CHUNK: u32 = 1 << 6;

/// A random scene's triangles split over several storage bindings, its image dispatched and
/// read back in tiles, judged as any f32 render (against the CPU's brute-force search: without
/// a BVH, whose node bindings split the same way, the kernel compiles several times faster).
fn streaming(ctx: &Ctx, planted: bool) -> Result<Verdict> {
    let scene = random(RANDOM_SEEDS[1]);
    let [spheres, _, triangles] = scene.primitive_counts();
    if spheres + triangles <= STREAM_CHUNK as usize {
        return Err(Error::Device(format!(
            "the scene fits one binding of {STREAM_CHUNK}: nothing streams"
        )));
    }
    let tuning = Tuning {
        search: Search::BruteForce,
        triangles_per_binding: Some(STREAM_CHUNK),
        tile_rows: Some(STREAM_ROWS),
        ..Tuning::default()
    };
    let mut images = gpu_f32(ctx.gpu, &scene, tuning, None)?;
    if planted {
        plant(&mut images.id);
    }
    judge_f32_with(ctx, &scene, &images, Search::BruteForce)
}
