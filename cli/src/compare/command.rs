//! `raycast compare`: two renders of a scene (or of two scenes with one camera size), their
//! report as one JSON object, optional pictures, and the bounds it must stay within.

use std::path::PathBuf;

use super::{
    Comparison, color_error_picture, compare, distance_error_picture, exceeded, mismatch_picture,
};
use crate::render::{check, render, timed};
use raycast::{AnyImages, Mode};
use raycast::{Gpu, RenderOptions, Result};
use raycast_files::EncodedFile;

/// What `raycast compare` is asked for.
#[derive(Clone, Debug)]
pub struct Spec {
    pub scene: PathBuf,
    /// Side b's scene, rendered at side a's size; `None`: the same scene.
    pub b_scene: Option<PathBuf>,
    /// Overrides the scenes' resolution.
    pub size: Option<[u32; 2]>,
    /// Side a, and side b (the reference for relative errors).
    pub modes: [Mode; 2],
    /// Where to write `mismatch.png` and `distance_error.png`, if anywhere.
    pub out_dir: Option<PathBuf>,
    /// Metric bounds (`--fail-above`).
    pub bounds: Vec<(String, f64)>,
    /// A shade hook file colouring both sides' `color.png`, compared too (`--shader`).
    pub shader: Option<PathBuf>,
    /// Both sides lit by the course's ray tracer (`--lit`: the shipped hook on the GPU, its
    /// mirror on the CPU).
    pub lit: bool,
}

/// What a comparison found.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// The modes, scenes, times and the [`super::Report`], as one JSON object.
    pub json: serde_json::Value,
    /// One line per bound exceeded.
    pub exceeded: Vec<String>,
    /// The pictures written.
    pub written: Vec<PathBuf>,
}

impl Spec {
    /// Renders both sides, compares them and writes the pictures. `gpu` is needed where a
    /// side is a GPU mode.
    pub fn run(&self, gpu: Option<&Gpu>) -> Result<Outcome> {
        let scene_a = raycast::load_viewed(
            Some(&self.scene),
            self.size,
            &Default::default(),
            Default::default(),
        )?;
        let mut scene_b = match &self.b_scene {
            Some(path) => raycast::load_viewed(
                Some(path),
                self.size,
                &Default::default(),
                Default::default(),
            )?,
            None => scene_a.clone(),
        };
        // Side b must be comparable pixel for pixel.
        scene_b.camera.resolution = scene_a.camera.resolution;
        let options = RenderOptions {
            shade: raycast_datasets::requested_hook(self.lit, self.shader.as_deref())?,
            ..RenderOptions::default()
        };
        for mode in self.modes {
            check(mode, options.clone())?;
        }
        if let Some(dir) = &self.out_dir {
            raycast_files::check_writable(dir)?;
        }
        let [mode_a, mode_b] = self.modes;
        let render = |scene, mode| {
            crate::progress::cpu_rows(|progress| {
                let options = RenderOptions {
                    progress,
                    ..options.clone()
                };
                render(scene, mode, gpu, options)
            })
        };
        let (a, time_a) = timed(|| render(&scene_a, mode_a));
        let (b, time_b) = timed(|| render(&scene_b, mode_b));
        let (a, b) = (a?, b?);
        let c = compare(&a, &b);
        let mut json = serde_json::json!({
            "scene": self.scene.display().to_string(),
            "size": scene_a.camera.resolution,
            "a": {"mode": mode_a.to_string(), "time_s": time_a.as_secs_f64()},
            "b": {"mode": mode_b.to_string(), "time_s": time_b.as_secs_f64()},
        });
        if let Some(p) = &self.b_scene {
            json["b"]["scene"] = p.display().to_string().into();
        }
        let report = serde_json::to_value(&c.report).expect("a report serialises");
        if let (Some(fields), serde_json::Value::Object(report)) = (json.as_object_mut(), report) {
            fields.extend(report);
        }
        let written = match &self.out_dir {
            Some(dir) => raycast_files::write_files(dir, &pictures(&c, &a, &b))?,
            None => Vec::new(),
        };
        Ok(Outcome {
            json,
            exceeded: exceeded(&c.report, &self.bounds),
            written,
        })
    }
}

/// `mismatch.png` over side b's normals, `distance_error.png`, and where both sides have a
/// `color.png`, `color_error.png`.
fn pictures(c: &Comparison, a: &AnyImages, b: &AnyImages) -> Vec<EncodedFile> {
    let base = b.pictures().normal;
    let mut pictures = vec![
        ("mismatch.png", mismatch_picture(c, &base)),
        ("distance_error.png", distance_error_picture(c)),
    ];
    if let (Some(ca), Some(cb)) = (a.color(), b.color()) {
        pictures.push(("color_error.png", color_error_picture(c, ca, cb)));
    }
    pictures
        .into_iter()
        .map(|(name, img)| EncodedFile {
            name,
            bytes: raycast::encode_png_rgb(&img),
        })
        .collect()
}
