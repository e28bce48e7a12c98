//! Text on pictures: ASCII in the public-domain 8x8 bitmap font of the `font8x8` crate, so that
//! labelled pictures need no system fonts.

use image::{Rgb, RgbImage};

/// Width and height of one character cell at scale 1, in pixels.
pub const GLYPH: u32 = 8;

/// Draws ASCII `text` with the 8x8 font, top-left at (x, y), clipped to the image. Characters
/// outside ASCII are drawn blank.
pub fn draw_text(img: &mut RgbImage, x: u32, y: u32, text: &str, color: Rgb<u8>) {
    draw_text_scaled(img, x, y, text, color, 1);
}

/// [`draw_text`] with each font pixel drawn as a `scale x scale` square.
pub fn draw_text_scaled(
    img: &mut RgbImage,
    x: u32,
    y: u32,
    text: &str,
    color: Rgb<u8>,
    scale: u32,
) {
    let scale = scale.max(1);
    for (k, ch) in text.chars().enumerate() {
        let glyph = font8x8::legacy::BASIC_LEGACY
            .get(ch as usize)
            .copied()
            .unwrap_or([0; 8]);
        let x0 = x + GLYPH * scale * k as u32;
        for (row, bits) in glyph.iter().enumerate() {
            for col in 0..GLYPH {
                if bits >> col & 1 == 0 {
                    continue;
                }
                for dy in 0..scale {
                    for dx in 0..scale {
                        let (px, py) = (x0 + col * scale + dx, y + row as u32 * scale + dy);
                        if px < img.width() && py < img.height() {
                            img.put_pixel(px, py, color);
                        }
                    }
                }
            }
        }
    }
}

/// Width of `text` in pixels at `scale`.
pub fn text_width(text: &str, scale: u32) -> u32 {
    text.chars().count() as u32 * GLYPH * scale.max(1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_is_drawn_inside_its_cells_and_clipped() {
        let white = Rgb([255, 255, 255]);
        let mut img = RgbImage::new(20, 10);
        draw_text(&mut img, 1, 1, "A", white);
        let lit: Vec<(u32, u32)> = img
            .enumerate_pixels()
            .filter(|(_, _, p)| **p == white)
            .map(|(x, y, _)| (x, y))
            .collect();
        assert!(!lit.is_empty());
        assert!(
            lit.iter()
                .all(|&(x, y)| (1..9).contains(&x) && (1..9).contains(&y))
        );
        // Scaled twice and running off the edge: no panic, only pixels inside.
        draw_text_scaled(&mut img, 15, 5, "AB", white, 2);
        assert_eq!(text_width("AB", 2), 32);
        assert_eq!(text_width("tradeoff", 1), 64);
    }
}
