//! Pictures of a comparison that a person reads at a glance: where the two renders disagree,
//! and how large the distance error is, with a labelled colour bar.

use image::{Rgb, RgbImage};

use super::{Comparison, PixelMatch};
use crate::text::draw_text;

const HIT_MISMATCH: Rgb<u8> = Rgb([255, 0, 255]);
const ID_MISMATCH: Rgb<u8> = Rgb([0, 255, 255]);
const ZERO_ERROR: Rgb<u8> = Rgb([60, 60, 60]);
const TEXT: Rgb<u8> = Rgb([255, 255, 255]);
/// Height of one line of the 8x8 font, with spacing.
const LINE: u32 = 12;

/// The render (`base`, RGB bytes of the comparison's size, e.g. side b's normal picture)
/// dimmed, with hit/miss mismatches in magenta and id mismatches in cyan, and a legend with
/// their counts below it.
pub fn mismatch_picture(c: &Comparison, base: &[u8]) -> RgbImage {
    let (w, h) = (c.width, c.height);
    let mut img = RgbImage::new(w.max(260), h + 2 * LINE);
    for (k, m) in c.per_pixel.iter().enumerate() {
        let (x, y) = (k as u32 % w, k as u32 / w);
        let color = match m {
            PixelMatch::HitMismatch => HIT_MISMATCH,
            PixelMatch::IdMismatch => ID_MISMATCH,
            _ => Rgb([0, 1, 2].map(|i| (base[3 * k + i] as u32 * 35 / 100) as u8)),
        };
        img.put_pixel(x, y, color);
    }
    let r = &c.report;
    draw_text(
        &mut img,
        2,
        h + 2,
        &format!("hit/miss mismatch: {}", r.hit_mismatch),
        HIT_MISMATCH,
    );
    draw_text(
        &mut img,
        2,
        h + 2 + LINE,
        &format!("id mismatch: {}", r.id_mismatch),
        ID_MISMATCH,
    );
    img
}

/// A blue-cyan-green-yellow-red ramp, `s` in 0..=1.
fn ramp(s: f64) -> Rgb<u8> {
    const STOPS: [[f64; 3]; 5] = [
        [40.0, 40.0, 255.0],
        [0.0, 220.0, 255.0],
        [40.0, 220.0, 40.0],
        [255.0, 230.0, 0.0],
        [255.0, 30.0, 30.0],
    ];
    let s = s.clamp(0.0, 1.0) * (STOPS.len() - 1) as f64;
    let i = (s.floor() as usize).min(STOPS.len() - 2);
    let f = s - i as f64;
    Rgb([0, 1, 2].map(|c| (STOPS[i][c] * (1.0 - f) + STOPS[i + 1][c] * f).round() as u8))
}

/// The decade range [lo, hi] of log10 of the positive errors (at least one decade wide).
fn decades(errors: &[Option<f64>]) -> (i32, i32) {
    let positive = errors.iter().flatten().copied().filter(|e| *e > 0.0);
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for e in positive {
        lo = lo.min(e);
        hi = hi.max(e);
    }
    if !lo.is_finite() {
        return (-16, -15);
    }
    let (lo, hi) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    (lo, hi.max(lo + 1))
}

/// A heatmap of a comparison's `w x h` pixels under a title, with a colour bar of [`ramp`] on
/// the right (its top the ramp's top) and below the bar a grey swatch for "no error".
struct Heatmap {
    img: RgbImage,
    /// Where the pixels start, below the title.
    top: u32,
    bar_x: u32,
    bar_w: u32,
    bar_len: u32,
}

impl Heatmap {
    fn new(w: u32, h: u32, title: &str) -> Heatmap {
        let top = LINE + 2;
        let panel = 96;
        let bar_h = h.max(10 * LINE);
        let mut img = RgbImage::new((w + panel).max(360), top + bar_h);
        draw_text(&mut img, 2, 2, title, TEXT);
        let (bar_x, bar_w, bar_len) = (w + 8, 16, bar_h - 2 * LINE);
        for dy in 0..bar_len {
            let color = ramp(1.0 - dy as f64 / (bar_len - 1).max(1) as f64);
            for dx in 0..bar_w {
                img.put_pixel(bar_x + dx, top + dy, color);
            }
        }
        let swatch_y = top + bar_len + 4;
        for dy in 0..8 {
            for dx in 0..bar_w {
                img.put_pixel(bar_x + dx, swatch_y + dy, ZERO_ERROR);
            }
        }
        let mut map = Heatmap {
            img,
            top,
            bar_x,
            bar_w,
            bar_len,
        };
        map.label(swatch_y, "0");
        map
    }

    /// Pixel `k` of a `w`-wide image in `color`.
    fn put(&mut self, k: usize, w: u32, color: Rgb<u8>) {
        let (x, y) = (k as u32 % w, k as u32 / w + self.top);
        self.img.put_pixel(x, y, color);
    }

    /// `text` beside the bar at height `y`.
    fn label(&mut self, y: u32, text: &str) {
        draw_text(&mut self.img, self.bar_x + self.bar_w + 4, y, text, TEXT);
    }
}

/// Relative distance error |a - b| / |b| per pixel on a log colour scale, exact agreement in
/// grey, pixels not hit by both on the same object in black; a colour bar with its decades on
/// the right.
pub fn distance_error_picture(c: &Comparison) -> RgbImage {
    let (w, h) = (c.width, c.height);
    let (lo, hi) = decades(&c.rel_error);
    let span = (hi - lo) as f64;
    let mut map = Heatmap::new(w, h, "relative distance error |a-b|/|b|");
    for (k, e) in c.rel_error.iter().enumerate() {
        let color = match e {
            None => Rgb([0, 0, 0]),
            Some(e) if *e == 0.0 => ZERO_ERROR,
            Some(e) => ramp((e.log10() - lo as f64) / span),
        };
        map.put(k, w, color);
    }
    // The decades: hi at the top of the bar, lo at its bottom.
    let (top, bar_len) = (map.top, map.bar_len);
    let step = ((hi - lo) as u32).div_ceil(bar_len / LINE).max(1) as i32;
    let mut d = hi;
    while d >= lo {
        let y = top + ((hi - d) as f64 / span * (bar_len - 1) as f64) as u32;
        map.label(
            y.saturating_sub(4).min(top + bar_len - 8),
            &format!("1e{d}"),
        );
        d -= step;
    }
    map.img
}

/// Levels at which [`color_error_picture`]'s ramp tops out.
const COLOR_RAMP_LEVELS: u8 = 16;

/// Per pixel, the largest difference of `color.png`'s R, G and B levels between the sides
/// (`a`, `b`, RGBA of the comparison's size): equal in grey, 1 to 16 levels and more from blue
/// to red, with a labelled bar on the right.
pub fn color_error_picture(c: &Comparison, a: &[[u8; 4]], b: &[[u8; 4]]) -> RgbImage {
    let (w, h) = (c.width, c.height);
    let mut map = Heatmap::new(w, h, "color.png: max |a-b| of R, G, B (levels)");
    let scale = |d: u8| (d.min(COLOR_RAMP_LEVELS) - 1) as f64 / (COLOR_RAMP_LEVELS - 1) as f64;
    for (k, (&pa, &pb)) in a.iter().zip(b).enumerate() {
        let d = super::level_difference(pa, pb);
        map.put(k, w, if d == 0 { ZERO_ERROR } else { ramp(scale(d)) });
    }
    let (top, bar_len) = (map.top, map.bar_len);
    map.label(top, &format!(">={COLOR_RAMP_LEVELS}"));
    map.label(top + bar_len - 8, "1");
    map.img
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decades_cover_the_errors() {
        assert_eq!(
            decades(&[Some(3e-7), None, Some(0.0), Some(2e-4)]),
            (-7, -3)
        );
        assert_eq!(decades(&[Some(1e-5)]), (-5, -4));
        assert_eq!(decades(&[None]), (-16, -15));
    }

    #[test]
    fn ramp_ends() {
        assert_eq!(ramp(0.0), Rgb([40, 40, 255]));
        assert_eq!(ramp(1.0), Rgb([255, 30, 30]));
    }
}
