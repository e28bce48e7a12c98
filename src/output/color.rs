//! The colour picture `color.png`: each object's palette colour weighted by how much of the
//! pixel it covers, as RGBA with premultiplied alpha, optionally composited "over" an opaque
//! background colour.
//!
//! A pixel of `N` samples of which `H` hit an object has coverage `alpha = H / N` and
//! premultiplied colour `c = (sum over the hitting samples of palette[id % 9]) / N`: the
//! coverage-weighted mix of the objects seen in it. When one object covers the pixel (alone,
//! with misses around it) that is `palette[id % 9] * alpha`, "the object's palette colour
//! times its coverage"; where several objects share a pixel each contributes its own colour
//! times its own share, rather than the majority object's colour taking all of the coverage.
//!
//! Compositing is Porter and Duff's "over" on premultiplied colours (the lecture's):
//! `c_o = c_a + c_b (1 - alpha_a)`, `alpha_o = alpha_a + alpha_b (1 - alpha_a)`, see [`over`].
//!
//! Conversion to 8 bits rounds to nearest, ties upward, and is exact: every value is a
//! rational with denominator `N` (palette levels and background levels are integers), so the
//! encoder computes `round(C / N)` in integers, not in floating point. A premultiplied channel
//! never exceeds its alpha after rounding, since `C <= 255 H` and rounding is monotone.

use super::pictures::id_color;
use crate::images::{Images, MISS};
use crate::math::Real;

// Rgba, over, opaque and PixelCoverage::rgba are the f64 reference formulas that the tests
// hold `PixelCoverage::to_rgba8`'s integer arithmetic to.

/// A premultiplied RGBA colour, each component in `[0, 1]`: `[r*a, g*a, b*a, a]`.
#[cfg(test)]
pub(crate) type Rgba = [f64; 4];

/// Porter-Duff "over" of premultiplied colours: `a` in front of `b`.
/// `c_o = c_a + c_b (1 - alpha_a)` per colour channel, `alpha_o = alpha_a + alpha_b (1 - alpha_a)`.
#[cfg(test)]
pub(crate) fn over(a: Rgba, b: Rgba) -> Rgba {
    let k = 1.0 - a[3];
    [
        a[0] + b[0] * k,
        a[1] + b[1] * k,
        a[2] + b[2] * k,
        a[3] + b[3] * k,
    ]
}

/// An opaque colour given in 8-bit levels, as a premultiplied `Rgba` (alpha 1).
#[cfg(test)]
pub(crate) fn opaque(rgb: [u8; 3]) -> Rgba {
    [
        rgb[0] as f64 / 255.0,
        rgb[1] as f64 / 255.0,
        rgb[2] as f64 / 255.0,
        1.0,
    ]
}

/// `num / den` rounded to the nearest integer, ties upward (exact, in integers).
fn round_div(num: u64, den: u64) -> u8 {
    ((2 * num + den) / (2 * den)).min(255) as u8
}

/// One pixel of coverage: `hits` of `spp` samples hit an object, and `color_sum` is the sum of
/// `palette[id % 9]` over those samples (8-bit levels).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct PixelCoverage {
    pub spp: u32,
    pub hits: u32,
    pub color_sum: [u32; 3],
}

impl PixelCoverage {
    /// The exact premultiplied colour as an `Rgba` in `[0, 1]` (`color_sum / (255 N)`,
    /// `hits / N`), rounded to f64.
    #[cfg(test)]
    pub(crate) fn rgba(&self) -> Rgba {
        let n = self.spp as f64;
        [
            self.color_sum[0] as f64 / (255.0 * n),
            self.color_sum[1] as f64 / (255.0 * n),
            self.color_sum[2] as f64 / (255.0 * n),
            self.hits as f64 / n,
        ]
    }

    /// The 8-bit RGBA of `color.png`: premultiplied `round(C / N)`, alpha `round(255 H / N)`;
    /// with a `background`, `over` it: `round((C + bg (N - H)) / N)` and alpha 255. Exact (module
    /// docs).
    pub(crate) fn to_rgba8(self, background: Option<[u8; 3]>) -> [u8; 4] {
        let n = self.spp as u64;
        let h = self.hits as u64;
        debug_assert!(h <= n);
        if n == 1 {
            // One sample: every division below is by 1 (a pixel of a dataset's color.png).
            let k = 1 - self.hits;
            let level = |c: u32, bg: u8| (c + u32::from(bg) * k).min(255) as u8;
            let c = self.color_sum;
            return match background {
                None => [
                    level(c[0], 0),
                    level(c[1], 0),
                    level(c[2], 0),
                    255 * h as u8,
                ],
                Some(bg) => [
                    level(c[0], bg[0]),
                    level(c[1], bg[1]),
                    level(c[2], bg[2]),
                    255,
                ],
            };
        }
        let c = self.color_sum.map(|c| c as u64);
        match background {
            None => [
                round_div(c[0], n),
                round_div(c[1], n),
                round_div(c[2], n),
                round_div(255 * h, n),
            ],
            Some(bg) => {
                let k = n - h;
                [
                    round_div(c[0] + bg[0] as u64 * k, n),
                    round_div(c[1] + bg[1] as u64 * k, n),
                    round_div(c[2] + bg[2] as u64 * k, n),
                    255,
                ]
            }
        }
    }
}

/// The RGBA bytes (4 a pixel, row-major) of `color.png` for `images`: each pixel's coverage
/// ([`pixel_coverage`]) over `background`.
pub(crate) fn color_rgba8<T: Real>(images: &Images<T>, background: Option<[u8; 3]>) -> Vec<u8> {
    let mut rgba = vec![0u8; 4 * images.id.len()];
    let pixels = rgba.chunks_exact_mut(4);
    // Two plain loops rather than one over either kind of pixel: this runs for every pixel of
    // every view of a dataset.
    match &images.coverage {
        Some(c) => {
            for (out, (&hits, &color_sum)) in pixels.zip(c.hits.iter().zip(&c.color_sum)) {
                let spp = c.spp;
                out.copy_from_slice(
                    &PixelCoverage {
                        spp,
                        hits,
                        color_sum,
                    }
                    .to_rgba8(background),
                );
            }
        }
        None => {
            // One sample a pixel: its colour is one of ten, each object's palette entry's or
            // a miss's, found once.
            let colour = |id| one_sample(id).to_rgba8(background);
            let palette: [[u8; 4]; 9] = std::array::from_fn(|k| colour(k as i32));
            let miss = colour(MISS);
            for (out, &id) in pixels.zip(&images.id) {
                let rgba = match id {
                    MISS => &miss,
                    id => &palette[id as usize % palette.len()],
                };
                out.copy_from_slice(rgba);
            }
        }
    }
    rgba
}

/// The coverage of a pixel of one sample of object `id`: covered by its palette colour, or
/// not at all by a miss.
fn one_sample(id: i32) -> PixelCoverage {
    PixelCoverage {
        spp: 1,
        hits: u32::from(id != MISS),
        color_sum: id_color(id).map(u32::from),
    }
}

/// The coverage of each pixel of `images`, row-major: their [`crate::images::Coverage`] when
/// supersampled, else one sample per pixel ([`one_sample`]).
#[cfg(test)]
pub(crate) fn pixel_coverage<T: Real>(images: &Images<T>) -> Vec<PixelCoverage> {
    match &images.coverage {
        Some(c) => (c.hits.iter().zip(&c.color_sum))
            .map(|(&hits, &color_sum)| PixelCoverage {
                spp: c.spp,
                hits,
                color_sum,
            })
            .collect(),
        None => images.id.iter().map(|&id| one_sample(id)).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Rgba, b: Rgba) -> bool {
        a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-15)
    }

    #[test]
    fn over_matches_the_formula_on_hand_computed_pixels() {
        // Opaque front: the back does not show.
        assert_eq!(
            over([0.2, 0.3, 0.4, 1.0], [1.0, 1.0, 1.0, 1.0]),
            [0.2, 0.3, 0.4, 1.0]
        );
        // Transparent front: the back shows unchanged.
        assert_eq!(
            over([0.0, 0.0, 0.0, 0.0], [0.5, 0.25, 1.0, 1.0]),
            [0.5, 0.25, 1.0, 1.0]
        );
        // Half-covered red (premultiplied 0.5, 0, 0, 0.5) over opaque blue:
        // c = (0.5, 0, 0) + (0, 0, 1) * 0.5 = (0.5, 0, 0.5), alpha = 0.5 + 1 * 0.5 = 1.
        assert_eq!(
            over([0.5, 0.0, 0.0, 0.5], [0.0, 0.0, 1.0, 1.0]),
            [0.5, 0.0, 0.5, 1.0]
        );
        // Quarter-covered white over a half-transparent green (premultiplied 0, 0.5, 0, 0.5):
        // c = (0.25, 0.25, 0.25) + (0, 0.5, 0) * 0.75 = (0.25, 0.625, 0.25),
        // alpha = 0.25 + 0.5 * 0.75 = 0.625.
        assert!(close(
            over([0.25, 0.25, 0.25, 0.25], [0.0, 0.5, 0.0, 0.5]),
            [0.25, 0.625, 0.25, 0.625]
        ));
        // "over" is associative on premultiplied colours.
        let (a, b, c) = (
            [0.1, 0.2, 0.05, 0.3],
            [0.4, 0.0, 0.3, 0.6],
            [0.2, 0.7, 0.1, 0.9],
        );
        assert!(close(over(over(a, b), c), over(a, over(b, c))));
    }

    #[test]
    fn one_sample_takes_the_general_formula() {
        let general = |p: PixelCoverage, bg: Option<[u8; 3]>| {
            let c = p.color_sum.map(|c| c as u64);
            let h = p.hits as u64;
            match bg {
                None => [
                    round_div(c[0], 1),
                    round_div(c[1], 1),
                    round_div(c[2], 1),
                    round_div(255 * h, 1),
                ],
                Some(bg) => [0, 1, 2]
                    .map(|i| round_div(c[i] + bg[i] as u64 * (1 - h), 1))
                    .into_iter()
                    .chain([255])
                    .collect::<Vec<_>>()
                    .try_into()
                    .unwrap(),
            }
        };
        for hits in [0, 1] {
            for color_sum in [[0, 0, 0], [228, 26, 28], [255, 255, 255], [7, 0, 200]] {
                let p = PixelCoverage {
                    spp: 1,
                    hits,
                    color_sum,
                };
                for bg in [
                    None,
                    Some([0, 0, 0]),
                    Some([255, 255, 255]),
                    Some([1, 2, 3]),
                ] {
                    assert_eq!(p.to_rgba8(bg), general(p, bg), "{p:?} {bg:?}");
                }
            }
        }
    }

    #[test]
    fn round_div_rounds_to_nearest() {
        assert_eq!(round_div(255, 2), 128);
        assert_eq!(round_div(254, 2), 127);
        assert_eq!(round_div(10, 9), 1);
        assert_eq!(round_div(14, 9), 2);
    }

    #[test]
    fn pixels_are_premultiplied_and_composite_over_the_background() {
        let red = [228, 26, 28];
        // One object covering 1 of 4 samples: palette * 1/4, alpha 1/4.
        let p = PixelCoverage {
            spp: 4,
            hits: 1,
            color_sum: red,
        };
        // 228/4 = 57, 26/4 = 6.5 -> 7, 28/4 = 7, 255/4 = 63.75 -> 64.
        assert_eq!(p.to_rgba8(None), [57, 7, 7, 64]);
        // Over white: c = 228/4 + 255 * 3/4 = 57 + 191.25 = 248.25 -> 248; 26/4 + 191.25 = 197.75
        // -> 198;
        // 28/4 + 191.25 = 198.25 -> 198.
        assert_eq!(p.to_rgba8(Some([255, 255, 255])), [248, 198, 198, 255]);
        // The exact integer path agrees with `over` in f64 to within rounding.
        for bg in [[255, 255, 255], [0, 0, 0], [10, 200, 77]] {
            let expected = over(p.rgba(), opaque(bg));
            let got = p.to_rgba8(Some(bg));
            for k in 0..4 {
                assert!((got[k] as f64 - 255.0 * expected[k]).abs() <= 0.5 + 1e-9);
            }
        }
        // Miss: transparent black, or the background itself.
        let miss = PixelCoverage {
            spp: 9,
            hits: 0,
            color_sum: [0; 3],
        };
        assert_eq!(miss.to_rgba8(None), [0, 0, 0, 0]);
        assert_eq!(miss.to_rgba8(Some([1, 2, 3])), [1, 2, 3, 255]);
        // Full coverage by one object: its palette colour, whatever the background.
        let full = PixelCoverage {
            spp: 9,
            hits: 9,
            color_sum: red.map(|c| 9 * c),
        };
        assert_eq!(full.to_rgba8(None), [228, 26, 28, 255]);
        assert_eq!(full.to_rgba8(Some([0, 255, 0])), [228, 26, 28, 255]);
        // Two objects sharing a pixel: the mean of their colours.
        let blue = [55, 126, 184];
        let mixed = PixelCoverage {
            spp: 4,
            hits: 4,
            color_sum: [
                2 * red[0] + 2 * blue[0],
                2 * red[1] + 2 * blue[1],
                2 * red[2] + 2 * blue[2],
            ],
        };
        // (228+55)/2 = 141.5 -> 142, (26+126)/2 = 76, (28+184)/2 = 106.
        assert_eq!(mixed.to_rgba8(None), [142, 76, 106, 255]);
    }
}
