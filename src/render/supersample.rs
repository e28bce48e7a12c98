//! Supersampling: `N = s * s` stratified samples per pixel, reduced to one id, distance, normal
//! and a coverage alpha per pixel (`raycast render --spp N`).
//!
//! Sampling. The scene is rendered with the ordinary renderer ([`render::render`], any
//! [`Mode`]) at `s * nx` by `s * ny` pixels over the same image plane. Fine pixel
//! `(s i + a, s j + b)` then has its centre at the centre of stratum `(a, b)` of coarse pixel
//! `(i, j)` when the pixel is cut into an `s x s` grid: stratified sampling with one sample at
//! the centre of each stratum (deterministic, no jitter). No kernel change is needed.
//!
//! Reduction ([`reduce`]), per coarse pixel, over its `N` samples:
//! - `id`: the object hit by the most samples; a tie goes to the lower id; [`MISS`] when no
//!   sample hits (a pixel half covered by an object keeps the object's id).
//! - `alpha = hits / N`, the fraction of samples that hit any object (the coverage). `hits` is
//!   kept as an integer too, so the exact rational is available.
//! - `distance` and `normal`: means over the samples that hit the majority object (the one `id`
//!   names), the normal renormalised (kept zero if the mean is zero); `+inf` and zero on a miss.
//!   Averaging only over that object keeps the three images consistent: they describe one
//!   surface. Averaging over every hit would blend, at a silhouette, the depth of a foreground
//!   object with the background behind it into a depth where there is no surface at all. (On a
//!   curved surface the mean of the samples is still slightly off the surface, by the
//!   curvature across the pixel.) A pixel whose majority object is hit by one sample only
//!   keeps that sample's values bit for bit, so `N = 1` reproduces a plain render exactly.
//! - `color_sum`: the sum of `palette[id % 9]` over the hitting samples, from which
//!   `color.png` is made (see [`crate::output::PixelCoverage`]).
//! - With a shade hook, `color` ([`Images::color`]): the mean of the samples' colours, per
//!   channel, rounded to nearest (the hook ran once per sample).
//!
//! Memory: the fine render is held whole before it is reduced, `N` times the memory of a plain
//! render (20 bytes a sample in f32, 36 in f64: 640x360 at 256 spp is about 1.2 GB in f32); a
//! render that cannot fit in this machine's memory is refused before it starts
//! ([`render::memory`]). Rendering and reducing in bands of rows would bound it; that is not
//! done yet.

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::gpu::Gpu;
use crate::images::{Coverage, Images, MISS};
use crate::math::Real;
use crate::mode::Mode;
use crate::output;
use crate::render::{self, AnyImages, Request};
use crate::scene::Scene;

/// The largest `s`: `N = s * s` up to 2^24, so that sample counts are exact in f32 and
/// `255 N` fits the u32 colour sums.
pub(crate) const MAX_SIDE: u32 = 4096;

/// `s` for `spp = s * s`, or why `spp` is not allowed (one line, for `--spp`).
pub(crate) fn side(spp: u32) -> std::result::Result<u32, String> {
    let s = (spp as f64).sqrt().round() as u32;
    if spp == 0 || s.checked_mul(s) != Some(spp) {
        return Err(format!(
            "samples per pixel must be a perfect square s*s >= 1 (1, 4, 9, 16, 64, 256, ...), got {spp}"
        ));
    }
    if s > MAX_SIDE {
        return Err(format!(
            "samples per pixel can be at most {MAX_SIDE}*{MAX_SIDE}, got {spp}"
        ));
    }
    Ok(s)
}

/// One reduced pixel.
struct Pixel<T> {
    id: i32,
    distance: T,
    normal: [T; 3],
    hits: u32,
    color_sum: [u32; 3],
}

/// Reduces a fine render of `s * nx` by `s * ny` samples to `nx` by `ny` pixels, each from its
/// `s x s` block (module docs), with their [`Coverage`]. Panics if `s` is 0 or does not divide
/// the fine size.
pub(crate) fn reduce<T: Real>(fine: &Images<T>, s: u32) -> Images<T> {
    assert!(
        s >= 1 && fine.width.is_multiple_of(s) && fine.height.is_multiple_of(s),
        "a {}x{} image is not made of {s}x{s} blocks",
        fine.width,
        fine.height
    );
    let (w, h) = (fine.width / s, fine.height / s);
    let pixels: Vec<Pixel<T>> = (0..w as usize * h as usize)
        .into_par_iter()
        .map_init(Vec::new, |ids, k| {
            let (i, j) = ((k / w as usize) as u32, (k % w as usize) as u32);
            reduce_block(fine, s, i, j, ids)
        })
        .collect();
    let mut out = Images::new_miss(w, h, fine.focal_length);
    out.hook_rays = fine.hook_rays;
    let mut coverage = Coverage {
        spp: s * s,
        hits: Vec::with_capacity(pixels.len()),
        alpha: Vec::with_capacity(pixels.len()),
        color_sum: Vec::with_capacity(pixels.len()),
    };
    out.color = fine.color.as_ref().map(|fine_color| {
        (0..w as usize * h as usize)
            .map(|k| {
                let (i, j) = ((k / w as usize) as u32, (k % w as usize) as u32);
                mean_color(fine_color, fine.width, s, i, j)
            })
            .collect()
    });
    for (k, p) in pixels.into_iter().enumerate() {
        out.id[k] = p.id;
        out.distance[k] = p.distance;
        out.normal[k] = p.normal;
        coverage.alpha.push(p.hits as f32 / coverage.spp as f32);
        coverage.hits.push(p.hits);
        coverage.color_sum.push(p.color_sum);
    }
    out.coverage = Some(coverage);
    out
}

/// Fine-image indices of the samples of coarse pixel (`i`, `j`).
fn block(fine_width: u32, s: u32, i: u32, j: u32) -> impl Iterator<Item = usize> {
    (0..s).flat_map(move |a| {
        let row = (s * i + a) as usize * fine_width as usize;
        (0..s).map(move |b| row + (s * j + b) as usize)
    })
}

/// The mean of a block's shade-hook colours, each channel rounded to nearest (ties up).
fn mean_color(color: &[[u8; 4]], fine_width: u32, s: u32, i: u32, j: u32) -> [u8; 4] {
    let mut sum = [0u64; 4];
    for k in block(fine_width, s, i, j) {
        for (total, c) in sum.iter_mut().zip(color[k]) {
            *total += u64::from(c);
        }
    }
    let n = u64::from(s * s);
    sum.map(|c| ((2 * c + n) / (2 * n)) as u8)
}

fn reduce_block<T: Real>(fine: &Images<T>, s: u32, i: u32, j: u32, ids: &mut Vec<i32>) -> Pixel<T> {
    let mut hits = 0;
    let mut color_sum = [0u32; 3];
    ids.clear();
    for k in block(fine.width, s, i, j) {
        let id = fine.id[k];
        if id != MISS {
            hits += 1;
            let c = output::id_color(id);
            for (sum, c) in color_sum.iter_mut().zip(c) {
                *sum += u32::from(c);
            }
            ids.push(id);
        }
    }
    // The most frequent id; ascending order with a strict `>` keeps the lower id on a tie.
    ids.sort_unstable();
    let (mut best, mut best_count) = (MISS, 0usize);
    let mut run = 0;
    while run < ids.len() {
        let id = ids[run];
        let len = ids[run..].iter().take_while(|&&x| x == id).count();
        if len > best_count {
            (best, best_count) = (id, len);
        }
        run += len;
    }
    let mut pixel = Pixel {
        id: best,
        distance: T::INFINITY,
        normal: [T::ZERO; 3],
        hits,
        color_sum,
    };
    if best == MISS {
        return pixel;
    }
    let mut count = 0usize;
    let mut last = 0;
    let mut distance = 0.0;
    let mut normal = [0.0f64; 3];
    for k in block(fine.width, s, i, j).filter(|&k| fine.id[k] == best) {
        count += 1;
        last = k;
        distance += fine.distance[k].to_f64();
        for (sum, c) in normal.iter_mut().zip(fine.normal[k]) {
            *sum += c.to_f64();
        }
    }
    if count == 1 {
        // One sample: its own values, bit for bit.
        pixel.distance = fine.distance[last];
        pixel.normal = fine.normal[last];
    } else {
        let n = count as f64;
        pixel.distance = T::from_f64(distance / n);
        let mean = normal.map(|c| c / n);
        let length = mean.iter().map(|c| c * c).sum::<f64>().sqrt();
        if length > 0.0 {
            pixel.normal = mean.map(|c| T::from_f64(c / length));
        }
    }
    pixel
}

/// Renders `scene` in `mode` with `spp` samples per pixel (a perfect square, else an
/// [`Error::Argument`] naming `samples_per_pixel`) and reduces it (module docs): images with their
/// [`Coverage`]. `spp = 1` is a plain [`render::render`] with coverage. The fine render is held
/// whole: `spp` times the memory of a plain one.
#[cfg(test)]
pub(crate) fn supersample(
    scene: &Scene,
    mode: Mode,
    gpu: Option<&Gpu>,
    spp: u32,
    progress: Option<&render::Progress>,
) -> Result<AnyImages> {
    supersample_request(scene, mode, gpu, spp, progress, &Request::default(), false)
}

/// [`supersample`] producing what `request` asks for. Above one sample per pixel the ids are
/// rendered whatever the request: the reduction is by majority id.
pub(crate) fn supersample_request(
    scene: &Scene,
    mode: Mode,
    gpu: Option<&Gpu>,
    spp: u32,
    progress: Option<&render::Progress>,
    request: &Request,
    timed: bool,
) -> Result<AnyImages> {
    let render = |scene: &Scene, request: &Request, s: u32| {
        let (images, kernel_s) = render::dispatch(scene, mode, gpu, progress, request, timed)?;
        let mut images = images.reduce(s);
        images.set_kernel_s(kernel_s);
        Ok(images)
    };
    if spp == 1 {
        // Before sample_scene, which copies the scene (meshes included).
        return render(scene, request, 1);
    }
    let shaded = request.shade.is_some() && request.outputs.color;
    let size = scene.camera.resolution;
    render::memory::check_whole_render(size, spp, mode.precision, shaded, false)?;
    let (fine_scene, s) = sample_scene(scene, spp)?;
    let fine_request = sample_request(request, spp);
    let fine = render(&fine_scene, &fine_request, s);
    let fine = fine.map_err(|e| match e {
        Error::Argument { option, message } => Error::Argument {
            option: format!("samples_per_pixel {spp}"),
            message: format!(
                "the render of {s}x{s} samples per pixel: {}: {message}",
                crate::error::named(&option)
            ),
        },
        other => other,
    })?;
    Ok(fine)
}

/// The scene whose pixels are the samples of `scene` at `spp` samples per pixel (module docs),
/// and `s = sqrt(spp)`; an [`Error::Argument`] naming `samples_per_pixel` when `spp` is not a perfect
/// square or the sample image would be too large.
pub(crate) fn sample_scene(scene: &Scene, spp: u32) -> Result<(Scene, u32)> {
    let s = side(spp).map_err(|message| Error::Argument {
        option: "samples_per_pixel".into(),
        message,
    })?;
    let [nx, ny] = scene.camera.resolution;
    let too_big = || Error::Argument {
        option: format!("samples_per_pixel {spp}"),
        message: format!("{nx}x{ny} pixels times {s}x{s} samples overflow the image size"),
    };
    let mut fine = scene.clone();
    fine.camera.resolution = [
        nx.checked_mul(s).ok_or_else(too_big)?,
        ny.checked_mul(s).ok_or_else(too_big)?,
    ];
    Ok((fine, s))
}

/// What the render of the samples is asked for at `spp` samples per pixel: `request`, with
/// the ids above one sample (the reduction is by majority id).
pub(crate) fn sample_request(request: &Request, spp: u32) -> Request {
    let mut r = request.clone();
    r.outputs.id |= spp > 1;
    r
}

/// How far a render at `spp` samples per pixel is from a high-spp reference.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
#[cfg(test)]
pub(crate) struct SppError {
    pub spp: u32,
    /// Mean over all pixels of `|alpha - alpha_ref|` (alphas as exact `hits / spp`).
    pub alpha_mean_abs: f64,
    /// Largest `|alpha - alpha_ref|`.
    pub alpha_max_abs: f64,
    /// Fraction of pixels whose id differs from the reference's (hit against miss included).
    pub id_mismatch: f64,
    /// Wall time of the render and its reduction.
    pub time_s: f64,
}

/// The error of `mode` at each of `spps` samples per pixel against `reference` at
/// `reference_spp` (e.g. `cpu:f64:robust` at 256), on `scene` at its resolution: mean and
/// largest absolute alpha error and the fraction of pixels whose majority id differs. The
/// reference stands in for the exact coverage (its own error is at most one stratum of
/// `1 / reference_spp` per stratum the boundary crosses). `gpu` is needed for GPU modes.
#[cfg(test)]
pub(crate) fn spp_errors(
    scene: &Scene,
    mode: Mode,
    spps: &[u32],
    reference: Mode,
    reference_spp: u32,
    gpu: Option<&Gpu>,
) -> Result<Vec<SppError>> {
    let truth = supersample(scene, reference, gpu, reference_spp, None)?;
    let alpha = |x: &AnyImages| -> Vec<f64> {
        let c = x.coverage().expect("supersampled images have coverage");
        let n = c.spp as f64;
        c.hits.iter().map(|&h| h as f64 / n).collect()
    };
    let truth_alpha = alpha(&truth);
    let pixels = truth_alpha.len().max(1) as f64;
    let mut rows = Vec::new();
    for &spp in spps {
        let (result, elapsed) = render::timed(|| supersample(scene, mode, gpu, spp, None));
        let result = result?;
        let errors: Vec<f64> = alpha(&result)
            .iter()
            .zip(&truth_alpha)
            .map(|(a, b)| (a - b).abs())
            .collect();
        let mismatches = result
            .id()
            .iter()
            .zip(truth.id())
            .filter(|(a, b)| a != b)
            .count();
        rows.push(SppError {
            spp,
            alpha_mean_abs: errors.iter().sum::<f64>() / pixels,
            alpha_max_abs: errors.iter().copied().fold(0.0, f64::max),
            id_mismatch: mismatches as f64 / pixels,
            time_s: elapsed.as_secs_f64(),
        });
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cov(r: &Images<f32>) -> &Coverage {
        r.coverage.as_ref().expect("reduced images have coverage")
    }

    /// A `w x h` fine image from per-sample ids; hits get distance `10 + id` and normal +z.
    fn fine(w: u32, h: u32, ids: &[i32]) -> Images<f32> {
        let mut img = Images::new_miss(w, h, 1.0);
        for (k, &id) in ids.iter().enumerate() {
            img.id[k] = id;
            if id != MISS {
                img.distance[k] = 10.0 + id as f32;
                img.normal[k] = [0.0, 0.0, 1.0];
            }
        }
        img
    }

    #[test]
    fn only_perfect_squares_are_sample_counts() {
        for (spp, s) in [
            (1, 1),
            (4, 2),
            (9, 3),
            (16, 4),
            (64, 8),
            (256, 16),
            (65536, 256),
        ] {
            assert_eq!(side(spp), Ok(s));
        }
        for spp in [0, 2, 3, 5, 8, 15, 17, 255, u32::MAX] {
            assert!(side(spp).unwrap_err().contains("perfect square"), "{spp}");
        }
        assert_eq!(side(MAX_SIDE * MAX_SIDE), Ok(MAX_SIDE));
        assert!(side(4097 * 4097).unwrap_err().contains("at most"));
    }

    #[test]
    fn blocks_reduce_to_majority_id_coverage_and_means() {
        // Two coarse pixels of 2x2 samples, side by side (fine image 4x2):
        //   row 0:  0  0 | -1  1
        //   row 1:  1 -1 | -1 -1
        let img = fine(4, 2, &[0, 0, -1, 1, 1, -1, -1, -1]);
        let r = reduce(&img, 2);
        assert_eq!((r.width, r.height, cov(&r).spp), (2, 1, 4));
        assert_eq!(r.id, [0, 1]);
        assert_eq!(cov(&r).hits, [3, 1]);
        assert_eq!(cov(&r).alpha, [0.75, 0.25]);
        // Means over the majority object's samples only: object 0's two samples.
        assert_eq!(r.distance, [10.0, 11.0]);
        assert_eq!(r.normal, [[0.0, 0.0, 1.0]; 2]);
        let [red, blue] = [output::PALETTE[0], output::PALETTE[1]].map(|c| c.map(u32::from));
        let two_red_one_blue: Vec<u32> = (0..3).map(|c| 2 * red[c] + blue[c]).collect();
        assert_eq!(cov(&r).color_sum[0].to_vec(), two_red_one_blue);
        assert_eq!(cov(&r).color_sum[1], blue);
    }

    #[test]
    fn ties_go_to_the_lower_id_and_misses_stay_misses() {
        // 2 samples of object 3, 2 of object 2: object 2 wins.
        let r = reduce(&fine(2, 2, &[3, 2, 2, 3]), 2);
        assert_eq!(r.id, [2]);
        assert_eq!(r.distance, [12.0]);
        assert_eq!(cov(&r).hits, [4]);
        assert_eq!(cov(&r).alpha, [1.0]);
        // A block of misses: MISS, +inf, zero normal, alpha 0.
        let r = reduce(&fine(3, 3, &[-1; 9]), 3);
        assert_eq!(r.id, [MISS]);
        assert_eq!(r.distance, [f32::INFINITY]);
        assert_eq!(r.normal, [[0.0; 3]]);
        assert_eq!(
            (cov(&r).hits[0], cov(&r).alpha[0], cov(&r).color_sum[0]),
            (0, 0.0, [0; 3])
        );
        // 1 of 9: alpha is 1/9 rounded to f32; hits keeps it exact.
        let mut ids = [-1; 9];
        ids[4] = 7;
        let r = reduce(&fine(3, 3, &ids), 3);
        assert_eq!(
            (r.id[0], cov(&r).hits[0], cov(&r).alpha[0]),
            (7, 1, 1.0 / 9.0)
        );
    }

    #[test]
    fn distances_average_and_normals_renormalise() {
        // Two samples of object 4 on the top row, misses below.
        let mut img = fine(2, 2, &[4, 4, -1, -1]);
        img.distance[..2].copy_from_slice(&[1.0, 2.0]);
        img.normal[..2].copy_from_slice(&[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
        let r = reduce(&img, 2);
        assert_eq!(r.distance, [1.5]);
        let h = std::f32::consts::FRAC_1_SQRT_2;
        let n = r.normal[0];
        assert!((n[0] - h).abs() < 1e-7 && (n[1] - h).abs() < 1e-7 && n[2] == 0.0);
        // Opposite normals average to zero: kept zero, not NaN.
        img.normal[1] = [-1.0, 0.0, 0.0];
        assert_eq!(reduce(&img, 2).normal, [[0.0; 3]]);
    }

    #[test]
    fn one_sample_per_pixel_is_the_plain_render() {
        let mut img = fine(3, 2, &[0, -1, 2, 9, 1, -1]);
        img.normal[0] = [0.6, 0.8, 1e-30];
        img.distance[2] = 0.1 + 0.2;
        let r = reduce(&img, 1);
        // The coverage of one sample per pixel is what the writers assume without one.
        assert_eq!(output::pixel_coverage(&r), output::pixel_coverage(&img));
        assert_eq!(cov(&r).alpha, [1.0, 0.0, 1.0, 1.0, 1.0, 0.0]);
        assert_eq!(
            Images {
                coverage: None,
                ..r
            },
            img
        );
    }

    #[test]
    fn hook_colours_average_per_block() {
        let mut img = fine(4, 2, &[0; 8]);
        let mut color = vec![[0u8; 4]; 8];
        // Left block: 10, 20, 30, 41 in red -> 101 / 4 = 25.25 -> 25; alpha 255 everywhere.
        for (k, r) in [(0, 10), (1, 20), (4, 30), (5, 41)] {
            color[k] = [r, 0, 255, 255];
        }
        // Right block: one white sample of four -> 63.75 -> 64.
        color[3] = [255; 4];
        img.color = Some(color);
        let r = reduce(&img, 2);
        assert_eq!(r.color, Some(vec![[25, 0, 255, 255], [64; 4]]));
        assert_eq!(reduce(&fine(2, 2, &[0; 4]), 2).color, None);
    }

    #[test]
    #[should_panic(expected = "not made of 2x2 blocks")]
    fn reduce_needs_whole_blocks() {
        reduce(&fine(3, 2, &[0; 6]), 2);
    }
}
