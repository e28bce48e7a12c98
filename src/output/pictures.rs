//! The course's picture mappings (id palette, depth grey, normal colour) and their png and
//! ASCII ppm encodings. Mappings are evaluated in f64 whatever the render precision.

use image::ImageEncoder;

use super::EncodedFile;
use crate::images::{Images, MISS, Outputs};
use crate::math::Real;

/// Object colours, `palette[id % 9]` (the course's).
pub(crate) const PALETTE: [[u8; 3]; 9] = [
    [228, 26, 28],
    [55, 126, 184],
    [77, 175, 74],
    [152, 78, 163],
    [255, 127, 0],
    [255, 255, 51],
    [166, 86, 40],
    [247, 129, 191],
    [153, 153, 153],
];

/// Palette colour of an object id; black for a miss.
pub(crate) fn id_color(id: i32) -> [u8; 3] {
    if id == MISS {
        [0, 0, 0]
    } else {
        PALETTE[id as usize % PALETTE.len()]
    }
}

/// `255 * min(1, focal_length / distance)` truncated toward zero; 0 for a miss (+inf).
pub(crate) fn depth_level(distance: f64, focal_length: f64) -> u8 {
    if !distance.is_finite() {
        return 0;
    }
    (255.0 * (focal_length / distance).min(1.0)) as u8
}

/// Each channel `255 * (n * 0.5 + 0.5)` truncated toward zero (a miss has n = 0 but is black).
pub(crate) fn normal_color(id: i32, n: [f64; 3]) -> [u8; 3] {
    if id == MISS {
        return [0, 0, 0];
    }
    n.map(|c| (255.0 * (c * 0.5 + 0.5)) as u8)
}

/// The three course pictures as 8-bit channels, row-major from the top row.
#[derive(Clone, Debug, PartialEq)]
pub struct Pictures {
    /// Pixels per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// RGB, 3 bytes a pixel.
    pub id: Vec<u8>,
    /// Grey, 1 byte a pixel.
    pub depth: Vec<u8>,
    /// RGB, 3 bytes a pixel.
    pub normal: Vec<u8>,
}

/// Maps `images` to the course's id, depth and normal pictures. A pixel's normal picture is
/// black where its id is a miss and its normal zero: a render without ids (`--outputs normal`)
/// still tells hits by their unit normals.
pub(crate) fn pictures<T: Real>(images: &Images<T>) -> Pictures {
    let n = images.len();
    let mut p = Pictures {
        width: images.width,
        height: images.height,
        id: vec![0; 3 * n],
        depth: vec![0; n],
        normal: vec![0; 3 * n],
    };
    // A loop per picture: the depth and normal mappings then run on whole vectors of pixels
    // (the same f64 operations, so the same bytes), as a dataset's every view needs them.
    for (id, &object) in p.id.chunks_exact_mut(3).zip(&images.id) {
        id.copy_from_slice(&id_color(object));
    }
    for (depth, &distance) in p.depth.iter_mut().zip(&images.distance) {
        *depth = depth_level(distance.to_f64(), images.focal_length);
    }
    let pixels = p.normal.chunks_exact_mut(3).zip(&images.normal);
    for ((normal, n), &object) in pixels.zip(&images.id) {
        let n = n.map(T::to_f64);
        let hit = object != MISS || n != [0.0; 3];
        normal.copy_from_slice(&normal_color(if hit { object.max(0) } else { MISS }, n));
    }
    p
}

pub(super) fn png(
    width: u32,
    height: u32,
    pixels: &[u8],
    color: image::ExtendedColorType,
) -> Vec<u8> {
    let mut bytes = Vec::new();
    image::codecs::png::PngEncoder::new(&mut bytes)
        .write_image(pixels, width, height, color)
        .expect("encoding a png into memory cannot fail");
    bytes
}

/// A picture file before encoding: its name and pixels, row-major from the top row,
/// `channels` a pixel (1 grey, 3 RGB, 4 RGBA) of `bits` each: 8, or 16 (grey only), whose
/// samples are big-endian (PNG's order).
pub(crate) struct Picture {
    pub name: &'static str,
    pub width: u32,
    pub height: u32,
    pub channels: usize,
    pub bits: u8,
    pub pixels: Vec<u8>,
}

impl Picture {
    /// An 8-bit picture.
    pub(crate) fn new(
        name: &'static str,
        width: u32,
        height: u32,
        channels: usize,
        pixels: Vec<u8>,
    ) -> Self {
        Picture {
            name,
            width,
            height,
            channels,
            bits: 8,
            pixels,
        }
    }

    /// The PNG colour type of its pixels.
    pub(crate) fn png_color(&self) -> image::ExtendedColorType {
        use image::ExtendedColorType::{L8, L16, Rgb8, Rgba8};
        match (self.channels, self.bits) {
            (1, 16) => L16,
            (1, _) => L8,
            (3, _) => Rgb8,
            _ => Rgba8,
        }
    }

    pub(crate) fn to_png(&self) -> EncodedFile {
        let native: Vec<u8>;
        let pixels = match self.bits {
            // The encoder takes 16-bit samples in the machine's order.
            16 => {
                native = (self.pixels.chunks_exact(2))
                    .flat_map(|b| u16::from_be_bytes([b[0], b[1]]).to_ne_bytes())
                    .collect();
                &native
            }
            _ => &self.pixels,
        };
        EncodedFile {
            name: self.name,
            bytes: png(self.width, self.height, pixels, self.png_color()),
        }
    }

    /// ASCII netpbm: `P3` for RGB, `P2` for grey.
    pub(crate) fn to_ppm(&self) -> EncodedFile {
        let magic = if self.channels == 1 { "P2" } else { "P3" };
        EncodedFile {
            name: self.name,
            bytes: ppm(magic, self.width, self.height, self.channels, &self.pixels),
        }
    }
}

/// The id, depth and normal pictures of `outputs` only, named `names` (in that order).
pub(crate) fn picture_set<T: Real>(
    images: &Images<T>,
    outputs: Outputs,
    names: [&'static str; 3],
) -> Vec<Picture> {
    let Pictures {
        width,
        height,
        id,
        depth,
        normal,
    } = pictures(images);
    [
        (outputs.id, names[0], 3, id),
        (outputs.distance, names[1], 1, depth),
        (outputs.normal, names[2], 3, normal),
    ]
    .into_iter()
    .filter(|(wanted, ..)| *wanted)
    .map(|(_, name, channels, pixels)| Picture::new(name, width, height, channels, pixels))
    .collect()
}

/// The names of the png pictures and of the ppm ones.
pub(crate) const PNG_NAMES: [&str; 3] = ["id.png", "depth.png", "normal.png"];
const PPM_NAMES: [&str; 3] = ["id.ppm", "depth.ppm", "normal.ppm"];

/// ASCII netpbm: `P3` (RGB) or `P2` (grey), max value 255, one pixel per line.
fn ppm(magic: &str, width: u32, height: u32, channels: usize, pixels: &[u8]) -> Vec<u8> {
    use std::fmt::Write;
    let mut s = format!("{magic}\n{width} {height}\n255\n");
    for px in pixels.chunks_exact(channels) {
        let line: Vec<String> = px.iter().map(u8::to_string).collect();
        let _ = writeln!(s, "{}", line.join(" "));
    }
    s.into_bytes()
}

/// `id.ppm`, `depth.ppm` and `normal.ppm`, those of `outputs` only.
pub(super) fn encode_ppm<T: Real>(images: &Images<T>, outputs: Outputs) -> Vec<EncodedFile> {
    let set = picture_set(images, outputs, PPM_NAMES);
    set.iter().map(Picture::to_ppm).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn course_spot_values_map_as_documented() {
        // sphere-and-plane (359, 320): the plane, normal (0, 1, 0) -> 127, 255, 127.
        assert_eq!(normal_color(1, [0.0, 1.0, 0.0]), [127, 255, 127]);
        // Inside a sphere looking at its back: outward normal (0, 0, -1) -> 127, 127, 0.
        assert_eq!(normal_color(4, [0.0, 0.0, -1.0]), [127, 127, 0]);
        assert_eq!(id_color(0), [228, 26, 28]);
        assert_eq!(id_color(10), [55, 126, 184]);
        assert_eq!(depth_level(3.0, 3.0), 255);
        assert_eq!(depth_level(6.0, 3.0), 127);
        assert_eq!(depth_level(f64::INFINITY, 3.0), 0);
    }

    #[test]
    fn normals_without_ids_are_told_from_misses_by_length() {
        let mut images = Images::<f32>::new_miss(3, 1, 1.0);
        images.normal[1] = [0.0, 1.0, 0.0];
        images.id[2] = 4;
        let p = pictures(&images);
        // A miss, a hit known only by its normal, a hit known by its id (zero normal).
        assert_eq!(p.normal, [0, 0, 0, 127, 255, 127, 127, 127, 127]);
    }

    #[test]
    fn ppm_is_ascii_with_header() {
        let bytes = ppm("P2", 2, 1, 1, &[0, 255]);
        assert_eq!(String::from_utf8(bytes).unwrap(), "P2\n2 1\n255\n0\n255\n");
    }
}
