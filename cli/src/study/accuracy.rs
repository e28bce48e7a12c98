//! `raycast accuracy`: every mode (device x precision x algorithm) against one reference mode on
//! a set of scenes, as a markdown table.
//!
//! For each scene the reference is rendered once, then each mode; each mode's images are
//! compared with the reference's by [`compare::compare`] (the reference is side b, so relative
//! errors are relative to it). One [`Row`] per scene and mode.
//!
//! ```no_run
//! use raycast_cli::study::accuracy::{self, Options};
//! use raycast::Gpu;
//! let gpu = Gpu::new()?;
//! let options = Options::new(accuracy::default_modes(Some(&gpu)));
//! let scenes = ["scenes/extremes/far-sphere-1e5.json".into()];
//! let result = accuracy::run(&scenes, &options, Some(&gpu), |_, _| {})?;
//! print!("{}", accuracy::to_markdown(&result.rows));
//! # Ok::<(), raycast::Error>(())
//! ```

use std::path::{Path, PathBuf};

use super::{Align, Provenance, Stream, Table, cell, format_error, scene_name};
use crate::compare;
use crate::render::{render, timed};
use raycast::Scene;
use raycast::{Algorithm, Error, Gpu, RenderOptions, Result};
use raycast::{AnyImages, Device, Mode, Precision};
use raycast::{Images, MISS};

/// The reference mode unless another is named: the CPU in f64 with the robust algorithms.
pub const DEFAULT_REFERENCE: Mode = Mode {
    device: Device::Cpu,
    precision: Precision::F64,
    algorithm: Algorithm::Robust,
};

/// What to measure.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Image size overriding every scene's `resolution`.
    pub size: Option<[u32; 2]>,
    /// The mode every other is compared with.
    pub reference: Mode,
    /// The modes measured, in table order.
    pub modes: Vec<Mode>,
}

impl Options {
    /// `modes` against [`DEFAULT_REFERENCE`] at each scene's own resolution.
    pub fn new(modes: Vec<Mode>) -> Options {
        Options {
            size: None,
            reference: DEFAULT_REFERENCE,
            modes,
        }
    }
}

/// One scene in one mode, compared with the reference.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// The scene file's name without its extension.
    pub scene: String,
    pub mode: Mode,
    pub pixels: usize,
    /// Pixels where exactly one of mode and reference hits.
    pub hit_mismatch: usize,
    /// Pixels where both hit, but different objects.
    pub id_mismatch: usize,
    /// Pixels where the reference hits and the mode misses (a subset of `hit_mismatch`): on
    /// meshes with shared edges these are cracks.
    pub lost_hits: usize,
    /// Largest |d - d_ref| / d_ref over pixels where both hit the same object; `None` if none.
    pub rel_distance_max: Option<f64>,
    /// Largest angle between the mode's and the reference's normals, in degrees, over pixels
    /// where both hit the same object; `None` if none.
    pub normal_angle_max_deg: Option<f64>,
    /// Pixels of the mode with a NaN anywhere, an infinite normal, or an infinite distance on a
    /// hit (a miss's distance is +inf by definition).
    pub non_finite: usize,
    /// Wall time of the mode's render in seconds (GPU: dispatch and readback; the kernels are
    /// compiled before timing starts, see [`run`]).
    pub time_s: f64,
}

/// What a scene file says about itself in its top-level `comment` (the extreme scenes'
/// convention: `{"probes": ..., "invariant": ..., "kind": ...}`; a plain-text comment counts as
/// `probes`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SceneInfo {
    /// The file's name without its extension.
    pub name: String,
    pub path: PathBuf,
    pub kind: Option<String>,
    pub probes: Option<String>,
    pub invariant: Option<String>,
}

impl SceneInfo {
    /// Reads the comment of the scene JSON `text` (nothing if it is absent or not JSON).
    pub fn from_json(path: &Path, text: &str) -> SceneInfo {
        let mut info = SceneInfo {
            name: scene_name(path),
            path: path.to_owned(),
            ..SceneInfo::default()
        };
        let comment = serde_json::from_str::<serde_json::Value>(text)
            .ok()
            .and_then(|v| v.get("comment").cloned());
        let text_of = |v: &serde_json::Value| match v {
            serde_json::Value::String(s) => s.clone(),
            other => other.to_string(),
        };
        match comment {
            Some(serde_json::Value::Object(m)) => {
                info.kind = m.get("kind").map(text_of);
                info.probes = m.get("probes").map(text_of);
                info.invariant = m.get("invariant").map(text_of);
            }
            Some(serde_json::Value::Null) | None => {}
            Some(other) => info.probes = Some(text_of(&other)),
        }
        info
    }
}

/// The scenes measured and a row per scene and mode, scene by scene in the order given.
#[derive(Clone, Debug, PartialEq)]
pub struct Accuracy {
    /// The mode every row is compared with.
    pub reference: Mode,
    pub scenes: Vec<SceneInfo>,
    pub rows: Vec<Row>,
}

/// Every combination of device (gpu, cpu), precision (f32, f64) and algorithm (textbook,
/// robust), in that nesting order, and GPU adaptive precision (robust only).
pub fn all_modes() -> Vec<Mode> {
    let mut modes = Vec::new();
    for device in [Device::Gpu, Device::Cpu] {
        for precision in [Precision::F32, Precision::F64] {
            for algorithm in [Algorithm::Textbook, Algorithm::Robust] {
                modes.push(Mode {
                    device,
                    precision,
                    algorithm,
                });
            }
        }
        if device == Device::Gpu {
            modes.push(Mode {
                device,
                precision: Precision::Adaptive,
                algorithm: Algorithm::Robust,
            });
        }
    }
    modes
}

/// [`all_modes`] less what `gpu` cannot run: the GPU f64 modes when the adapter lacks
/// `SHADER_F64`, every GPU mode when there is no GPU.
pub fn default_modes(gpu: Option<&Gpu>) -> Vec<Mode> {
    let f64_on_gpu = gpu.is_some_and(|g| g.info().f64);
    all_modes()
        .into_iter()
        .filter(|m| match (m.device, m.precision) {
            (Device::Cpu, _) => true,
            (Device::Gpu, Precision::F32 | Precision::Adaptive) => gpu.is_some(),
            (Device::Gpu, Precision::F64) => f64_on_gpu,
        })
        .collect()
}

/// Measures every scene of `paths` in every mode of `options`, calling `progress(k, path)`
/// before scene `k` (0-based). Scenes are loaded (and so validated) before anything renders.
///
/// GPU kernels are compiled before each scene's timed renders (by rendering a 1x1 image of the
/// scene in each GPU mode: kernels are specialized per scene), so the time column compares
/// renders, not compilations.
pub fn run(
    paths: &[PathBuf],
    options: &Options,
    gpu: Option<&Gpu>,
    mut progress: impl FnMut(usize, &Path),
) -> Result<Accuracy> {
    let mut scenes = Vec::with_capacity(paths.len());
    let mut infos = Vec::with_capacity(paths.len());
    for path in paths {
        let scene = raycast::load_viewed(
            Some(path),
            options.size,
            &Default::default(),
            Default::default(),
        )?;
        let text = std::fs::read_to_string(path).map_err(|e| Error::Io {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        infos.push(SceneInfo::from_json(path, &text));
        scenes.push(scene);
    }
    let mut rows = Vec::new();
    for (k, (scene, info)) in scenes.iter().zip(&infos).enumerate() {
        progress(k, &info.path);
        warm_up(scene, options, gpu)?;
        rows.extend(measure(
            &info.name,
            scene,
            options.reference,
            &options.modes,
            gpu,
        )?);
    }
    Ok(Accuracy {
        reference: options.reference,
        scenes: infos,
        rows,
    })
}

/// Renders a 1x1 image of `scene` in each GPU mode (and the reference if it is one), so that
/// each kernel variant is compiled before timing.
fn warm_up(scene: &Scene, options: &Options, gpu: Option<&Gpu>) -> Result<()> {
    let mut tiny = scene.clone();
    tiny.camera.resolution = [1, 1];
    for &mode in options.modes.iter().chain([&options.reference]) {
        if mode.device == Device::Gpu {
            render(&tiny, mode, gpu, RenderOptions::default())?;
        }
    }
    Ok(())
}

/// One scene: the reference once, then each of `modes` compared with it.
pub fn measure(
    name: &str,
    scene: &Scene,
    reference: Mode,
    modes: &[Mode],
    gpu: Option<&Gpu>,
) -> Result<Vec<Row>> {
    let truth = render(scene, reference, gpu, RenderOptions::default())?;
    modes
        .iter()
        .map(|&mode| {
            let (images, elapsed) = timed(|| render(scene, mode, gpu, RenderOptions::default()));
            Ok(row(name, mode, &images?, &truth, elapsed.as_secs_f64()))
        })
        .collect()
}

/// The row of `mode`'s `images` against the reference's.
pub fn row(name: &str, mode: Mode, images: &AnyImages, reference: &AnyImages, time_s: f64) -> Row {
    let c = compare::compare(images, reference);
    Row {
        scene: name.to_owned(),
        mode,
        pixels: c.report.pixels,
        hit_mismatch: c.report.hit_mismatch,
        id_mismatch: c.report.id_mismatch,
        lost_hits: lost_hits(images.id(), reference.id()),
        rel_distance_max: c.report.distance.rel_max,
        normal_angle_max_deg: c.report.normal_angle_deg.max,
        non_finite: match images {
            AnyImages::F32(i) => non_finite(i),
            AnyImages::F64(i) => non_finite(i),
        },
        time_s,
    }
}

/// Pixels where `reference` hits and `ids` misses.
pub fn lost_hits(ids: &[i32], reference: &[i32]) -> usize {
    ids.iter()
        .zip(reference)
        .filter(|&(&a, &b)| a == MISS && b != MISS)
        .count()
}

/// Pixels with a NaN anywhere, an infinite normal component, or an infinite distance on a hit.
pub fn non_finite<T: Copy + Into<f64>>(images: &Images<T>) -> usize {
    (0..images.id.len())
        .filter(|&k| {
            let d: f64 = images.distance[k].into();
            let bad_distance = d.is_nan() || (images.id[k] != MISS && d.is_infinite());
            bad_distance || images.normal[k].iter().any(|&c| !c.into().is_finite())
        })
        .count()
}

/// Column headings of [`to_markdown`].
pub const COLUMNS: [&str; 9] = [
    "scene",
    "mode",
    "hit/miss mismatches",
    "id mismatches",
    "lost hits",
    "max rel. distance error",
    "normal angle max (deg)",
    "NaN/inf",
    "time (s)",
];

/// The rows as a markdown table (heading, alignment line, one line per row; numbers
/// right-aligned), ending in a newline.
pub fn to_markdown(rows: &[Row]) -> String {
    let mut table = Table::text_then_numbers(&COLUMNS, 2);
    for r in rows {
        table.row([
            cell(&r.scene),
            r.mode.to_string(),
            r.hit_mismatch.to_string(),
            r.id_mismatch.to_string(),
            r.lost_hits.to_string(),
            format_error(r.rel_distance_max),
            format_error(r.normal_angle_max_deg),
            r.non_finite.to_string(),
            format!("{:.4}", r.time_s),
        ]);
    }
    table.markdown()
}

/// The scenes as a markdown table: name (linked to its file, relative to `base` if the file
/// lies under it), kind, what it probes, its invariant.
pub fn scenes_markdown(scenes: &[SceneInfo], base: Option<&Path>) -> String {
    let mut table = Table::new(&["scene", "kind", "probes", "invariant"], &[Align::Left; 4]);
    for info in scenes {
        let link = match base.and_then(|b| relative_link(b, &info.path)) {
            Some(link) => format!("[{}]({})", cell(&info.name), link),
            None => cell(&info.name),
        };
        let text = |t: &Option<String>| t.as_deref().map_or("-".to_owned(), cell);
        table.row([
            link,
            text(&info.kind),
            text(&info.probes),
            text(&info.invariant),
        ]);
    }
    table.markdown()
}

/// `path` as a link from a document in folder `from`: `../` for every folder of `from` that is
/// not also an ancestor of `path` (both taken as given, relative to the same directory).
fn relative_link(from: &Path, path: &Path) -> Option<String> {
    if from.is_absolute() != path.is_absolute() {
        return None;
    }
    let from: Vec<_> = from.components().collect();
    let to: Vec<_> = path.components().collect();
    if from.iter().chain(&to).any(|c| {
        matches!(
            c,
            std::path::Component::ParentDir | std::path::Component::Prefix(_)
        )
    }) {
        return None;
    }
    let common = from.iter().zip(&to).take_while(|(a, b)| a == b).count();
    let mut parts: Vec<String> = vec!["..".to_owned(); from.len() - common];
    parts.extend(
        to[common..]
            .iter()
            .map(|c| c.as_os_str().to_string_lossy().into_owned()),
    );
    Some(parts.join("/"))
}

/// The markdown file `--markdown` writes: a title, the provenance line, a paragraph explaining
/// the columns, the scenes table and the results table. Links to the scene files are relative
/// to `dir`, the folder the document is written to.
pub fn document(p: &Provenance, result: &Accuracy, dir: Option<&Path>) -> String {
    let mut s = String::from("# Accuracy of every mode, scene by scene\n\n");
    s += &p.generated_by();
    s += "\n\n";
    s += &format!(
        "Each scene was rendered once in the reference mode `{}` and then in every mode below; \
         each mode is compared with the reference pixel by pixel. *hit/miss mismatches*: pixels \
         where exactly one of the two hits something. *id mismatches*: pixels where both hit, \
         but different objects. *lost hits*: pixels where the reference hits and the mode misses \
         (a subset of the hit/miss mismatches; on meshes with shared edges, cracks). *max rel. \
         distance error*: the largest |d - d_ref| / d_ref over pixels where both hit the same \
         object. *normal angle max*: the largest angle between the two normals there, in \
         degrees (`-` where no pixel hits the same object in both; `0` where they agree \
         exactly). *NaN/inf*: pixels of the mode holding a NaN, an infinite normal, or an \
         infinite distance on a hit. *time*: the mode's wall time for one render (kernels \
         compiled beforehand). Modes are `device:precision:algorithm`. The reference's own row \
         measures its determinism. What each scene probes and what must hold in it is in the \
         first table; the scenes are written by `scenes/extremes/make_meshes.py`.\n\n",
        result.reference
    );
    s += "## Scenes\n\n";
    s += &scenes_markdown(&result.scenes, dir);
    s += "\n## Results\n\n";
    s += &to_markdown(&result.rows);
    s
}

/// `raycast accuracy`: measures `scenes` in `modes` (by default [`default_modes`]) against
/// `reference`, a progress line per scene on stderr, prints the table on stdout and, with
/// `markdown`, writes the [`document`] to that file. The file's folder is checked before the
/// GPU is opened.
pub fn command(
    scenes: &[PathBuf],
    size: Option<[u32; 2]>,
    reference: Mode,
    modes: Option<Vec<Mode>>,
    markdown: Option<&Path>,
    mut say: impl FnMut(Stream, &str),
) -> Result<()> {
    if let Some(file) = markdown {
        raycast_files::check_parent_writable(file)?;
    }
    let needs_gpu = modes
        .as_ref()
        .is_none_or(|m| m.iter().any(|m| m.device == Device::Gpu))
        || reference.device == Device::Gpu;
    let gpu = needs_gpu.then(Gpu::new).transpose()?;
    let options = Options {
        size,
        reference,
        modes: modes.unwrap_or_else(|| default_modes(gpu.as_ref())),
    };
    let result = run(scenes, &options, gpu.as_ref(), |k, path| {
        let line = format!("[{}/{}] {}", k + 1, scenes.len(), path.display());
        say(Stream::Stderr, &line);
    })?;
    say(Stream::Stdout, to_markdown(&result.rows).trim_end());
    if let Some(file) = markdown {
        let text = document(&Provenance::now(gpu.as_ref()), &result, file.parent());
        raycast_files::write_file(file, text.as_bytes())?;
        say(Stream::Stderr, &format!("wrote {}", file.display()));
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
            scene: "far-sphere-1e5".into(),
            mode: mode("gpu:f32:textbook"),
            pixels: 3072,
            hit_mismatch: 12,
            id_mismatch: 0,
            lost_hits: 5,
            rel_distance_max: Some(1.234e-7),
            normal_angle_max_deg: None,
            non_finite: 0,
            time_s: 0.01234,
        }
    }

    #[test]
    fn markdown_table_has_heading_alignment_and_one_line_per_row() {
        let mut exact = sample_row();
        exact.mode = mode("cpu:f64:robust");
        exact.rel_distance_max = Some(0.0);
        exact.normal_angle_max_deg = Some(0.0);
        let md = to_markdown(&[sample_row(), exact]);
        let lines: Vec<&str> = md.lines().collect();
        assert_eq!(lines.len(), 4, "{md}");
        assert_eq!(
            lines[0],
            "| scene | mode | hit/miss mismatches | id mismatches | lost hits | \
             max rel. distance error | normal angle max (deg) | NaN/inf | time (s) |"
        );
        assert_eq!(lines[1], "|---|---|---:|---:|---:|---:|---:|---:|---:|");
        assert_eq!(
            lines[2],
            "| far-sphere-1e5 | gpu:f32:textbook | 12 | 0 | 5 | 1.2e-7 | - | 0 | 0.0123 |"
        );
        assert_eq!(
            lines[3],
            "| far-sphere-1e5 | cpu:f64:robust | 12 | 0 | 5 | 0 | 0 | 0 | 0.0123 |"
        );
        assert!(md.ends_with('\n'));
        // Every line has as many cells as the heading.
        for line in &lines {
            assert_eq!(line.matches('|').count(), COLUMNS.len() + 1, "{line}");
        }
    }

    #[test]
    fn empty_table_is_just_the_heading() {
        assert_eq!(to_markdown(&[]).lines().count(), 2);
    }

    #[test]
    fn cells_escape_pipes_and_line_breaks() {
        let mut r = sample_row();
        r.scene = "odd|name".into();
        let md = to_markdown(&[r]);
        assert!(
            md.lines().nth(2).unwrap().starts_with("| odd\\|name |"),
            "{md}"
        );
    }

    #[test]
    fn scene_comments_are_read_from_objects_or_text() {
        let path = Path::new("scenes/extremes/x.json");
        let info = SceneInfo::from_json(
            path,
            r#"{"comment": {"probes": "p", "invariant": "i", "kind": "tangent", "base": "b"},
                "camera": {}, "objects": []}"#,
        );
        assert_eq!(info.name, "x");
        assert_eq!(info.kind.as_deref(), Some("tangent"));
        assert_eq!(info.probes.as_deref(), Some("p"));
        assert_eq!(info.invariant.as_deref(), Some("i"));
        let info = SceneInfo::from_json(path, r#"{"comment": "free text"}"#);
        assert_eq!((info.kind, info.probes), (None, Some("free text".into())));
        assert_eq!(SceneInfo::from_json(path, "not json").probes, None);
    }

    #[test]
    fn scenes_table_links_relative_to_the_document() {
        let info = SceneInfo {
            name: "x".into(),
            path: "scenes/extremes/x.json".into(),
            kind: Some("fov".into()),
            probes: Some("a | b".into()),
            invariant: None,
        };
        let md = scenes_markdown(std::slice::from_ref(&info), Some(Path::new("docs")));
        assert_eq!(
            md.lines().nth(2).unwrap(),
            "| [x](../scenes/extremes/x.json) | fov | a \\| b | - |"
        );
        let md = scenes_markdown(&[info], None);
        assert!(md.lines().nth(2).unwrap().starts_with("| x | fov |"));
        assert_eq!(
            relative_link(Path::new(""), Path::new("a/b.json")).unwrap(),
            "a/b.json"
        );
        assert_eq!(relative_link(Path::new("../d"), Path::new("a.json")), None);
    }

    #[test]
    fn document_names_command_adapter_date_and_reference() {
        let p = Provenance {
            command: "raycast accuracy a.json --markdown docs/x.md".into(),
            adapter: Some(("llvmpipe".into(), "Mesa 25.0.7".into())),
            date: "2025-01-02".into(),
        };
        let result = Accuracy {
            reference: DEFAULT_REFERENCE,
            scenes: vec![],
            rows: vec![sample_row()],
        };
        let doc = document(&p, &result, None);
        assert!(doc.starts_with("# "));
        assert!(doc.contains(
            "Generated by `raycast accuracy a.json --markdown docs/x.md` on llvmpipe \
             (Mesa 25.0.7), 2025-01-02 (UTC)."
        ));
        assert!(doc.contains("reference mode `cpu:f64:robust`"));
        assert!(doc.ends_with(&to_markdown(&result.rows)));
    }

    #[test]
    fn default_modes_are_the_eight_combinations_and_adaptive() {
        let all: Vec<String> = all_modes().iter().map(Mode::to_string).collect();
        assert_eq!(all.len(), 9);
        assert_eq!(all[0], "gpu:f32:textbook");
        assert_eq!(all[4], "gpu:adaptive:robust");
        assert_eq!(all[8], "cpu:f64:robust");
        // Without a GPU only the CPU modes remain.
        let cpu: Vec<Mode> = default_modes(None);
        assert_eq!(cpu.len(), 4);
        assert!(cpu.iter().all(|m| m.device == Device::Cpu));
    }

    #[test]
    fn lost_hits_and_non_finite_pixels_are_counted() {
        assert_eq!(lost_hits(&[MISS, 0, MISS, 1], &[0, 0, MISS, MISS]), 1);
        let mut i = Images::<f32> {
            width: 4,
            height: 1,
            id: vec![MISS, 0, 0, 0],
            distance: vec![f32::INFINITY, 1.0, f32::NAN, f32::INFINITY],
            normal: vec![[0.0; 3], [0.0, 0.0, 1.0], [0.0; 3], [0.0; 3]],
            ..Images::default()
        };
        assert_eq!(non_finite(&i), 2);
        i.normal[0] = [f32::NAN, 0.0, 0.0];
        assert_eq!(non_finite(&i), 3);
    }
}
