//! Writers: [`Images`] to png, ppm or npy files. Every file of a request is encoded in memory
//! first, then written whole or not at all by `raycast_files` (the band-by-band files of
//! `stream.rs` through its registry of temporary files), so a failed render leaves no partial
//! output.

mod color;
mod depth;
mod exr;
mod npy;
mod pictures;
pub(crate) mod stream;

use std::borrow::Cow;
use std::str::FromStr;

use crate::error::{Error, Result};
use crate::images::{Images, Output, Outputs};
use crate::math::Real;
use crate::scene::Camera;

pub use self::{depth::Depth, pictures::Pictures};
pub(crate) use color::color_rgba8;
#[cfg(test)]
pub(crate) use color::pixel_coverage;
#[cfg(test)]
pub(crate) use color::{PixelCoverage, opaque, over};
pub(crate) use depth::{Depth16, camera_json, depth16_levels};
pub(crate) use npy::encode_npy;
#[cfg(test)]
pub(crate) use pictures::PALETTE;
pub(crate) use pictures::pictures;
pub(crate) use pictures::{Picture, id_color, picture_set};
pub(crate) use raycast_files::EncodedFile;

/// An output format of `raycast render --format`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// `id.png`, `depth.png`, `normal.png` (the course's mappings).
    Png,
    /// `id.ppm` (P3), `depth.ppm` (P2), `normal.ppm` (P3), ASCII, max value 255.
    Ppm,
    /// `id.npy` (int32), `distance.npy` or `z.npy` (float32/float64), `normal.npy` (HxWx3).
    Npy,
    /// `render.npz`: the npy files' arrays in one archive.
    Npz,
    /// `render.exr`: channels `Z`, `N.X`, `N.Y`, `N.Z`, `id` (and `A` with `--spp`).
    Exr,
    /// `depth16.png`: 16-bit grey, the depth (planar z unless `--depth` says otherwise) times
    /// `--depth-scale`, rounded.
    Depth16,
}

impl Format {
    /// Whether the format's files are written whole (they cannot be written in bands of rows).
    pub fn whole_only(self) -> bool {
        matches!(self, Format::Npz | Format::Exr)
    }

    pub(crate) fn name(self) -> &'static str {
        match self {
            Format::Png => "png",
            Format::Ppm => "ppm",
            Format::Npy => "npy",
            Format::Npz => "npz",
            Format::Exr => "exr",
            Format::Depth16 => "depth16",
        }
    }
}

impl std::fmt::Display for Format {
    /// Its name, as [`Format::from_str`] reads it.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Format {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        let all = [
            Format::Png,
            Format::Ppm,
            Format::Npy,
            Format::Npz,
            Format::Exr,
            Format::Depth16,
        ];
        let name = s.trim();
        all.into_iter().find(|f| f.name() == name).ok_or_else(|| {
            format!("unknown format `{name}` (expected png, ppm, npy, npz, exr or depth16)")
        })
    }
}

/// The files a render writes: in which formats, of which outputs, `color.png` composited over
/// what, and which depth.
#[derive(Clone, Debug, PartialEq)]
pub struct Encoding {
    /// The file formats written.
    pub formats: Vec<Format>,
    /// The outputs written; `color` only with png (`color.png`).
    pub outputs: Outputs,
    /// The opaque colour `color.png` is composited over (`--background`); `None`: transparent,
    /// premultiplied alpha.
    pub background: Option<[u8; 3]>,
    /// The depth the npy and npz arrays and the EXR's `Z` hold: distance by default
    /// (`distance.npy`); `--depth` sets it and `depth16`.
    pub depth: Depth,
    /// The depth `depth16.png` holds: planar z by default, what RGB-D datasets store and
    /// Open3D's `create_from_depth_image` back-projects.
    pub depth16: Depth,
    /// `depth16.png`'s levels per scene unit (`--depth-scale`).
    pub depth_scale: f64,
}

/// The files `raycast render` writes unless told otherwise: every output as PNG, `color.png`
/// transparent, `depth16.png`'s scale in millimetres for scenes in metres.
impl Default for Encoding {
    fn default() -> Encoding {
        Encoding {
            formats: vec![Format::Png],
            outputs: Outputs::ALL,
            background: None,
            depth: Depth::Distance,
            depth16: Depth::Z,
            depth_scale: 1000.0,
        }
    }
}

impl Encoding {
    /// The outputs of `list` (`--outputs`) in `formats`, or without a list every output the
    /// formats write (`color.png` with png). Colour without png, depth16 without the distance
    /// output, and exr or npz without any of id, distance and normal are errors naming
    /// `--outputs`.
    pub fn new(formats: &[Format], list: Option<&[Output]>) -> Result<Encoding> {
        let png = formats.contains(&Format::Png);
        let outputs = match list {
            None => Outputs {
                color: png,
                ..Outputs::ALL
            },
            Some(list) => Outputs::of(list),
        };
        let refuse = |option: &str, message: &str| {
            Err(Error::Argument {
                option: option.into(),
                message: message.into(),
            })
        };
        if outputs.color && !png {
            return refuse(
                "outputs color",
                "color is written as color.png only; add png to `formats`",
            );
        }
        if formats.contains(&Format::Depth16) && !outputs.distance {
            return refuse(
                "formats depth16",
                "depth16.png holds depths; add distance to `outputs`",
            );
        }
        let arrays = outputs.id || outputs.distance || outputs.normal;
        if let Some(f) = formats.iter().find(|f| f.whole_only() && !arrays) {
            return refuse(
                &format!("formats {}", f.name()),
                "holds ids, distances and normals; `outputs` asks for none of them",
            );
        }
        Ok(Encoding {
            formats: formats.to_vec(),
            outputs,
            ..Encoding::default()
        })
    }

    /// `camera.json` for a render of `camera` in this encoding.
    pub(crate) fn camera_json(&self, camera: &Camera) -> EncodedFile {
        let depth16 = self.formats.contains(&Format::Depth16).then_some(Depth16 {
            depth: self.depth16,
            scale: self.depth_scale,
        });
        camera_json(camera, self.depth, depth16)
    }

    /// The depths the files of `images` hold, rows `first_row..` of an image `camera` renders.
    pub(crate) fn depths<'a, T: Real>(
        &self,
        images: &'a Images<T>,
        camera: &Camera,
        first_row: u32,
    ) -> Depths<'a, T> {
        let has = |f: &[Format]| self.formats.iter().any(|x| f.contains(x));
        let of = |depth: Depth| depth.of(images, camera, first_row);
        // Planar z costs a pass over the image: made only for the files that hold it.
        let arrays = match has(&[Format::Npy, Format::Npz, Format::Exr]) {
            true => of(self.depth),
            false => Cow::Borrowed(images.distance.as_slice()),
        };
        let depth16 =
            (has(&[Format::Depth16]) && self.depth16 != self.depth).then(|| of(self.depth16));
        Depths { arrays, depth16 }
    }
}

/// The depths of one image (or band) as an [`Encoding`] writes them.
pub(crate) struct Depths<'a, T: Clone> {
    /// The npy and npz arrays' and the EXR's ([`Encoding::depth`]).
    arrays: Cow<'a, [T]>,
    /// `depth16.png`'s ([`Encoding::depth16`]) where it differs from the arrays'.
    depth16: Option<Cow<'a, [T]>>,
}

impl<T: Clone> Depths<'_, T> {
    fn arrays(&self) -> &[T] {
        &self.arrays
    }

    fn depth16(&self) -> &[T] {
        self.depth16.as_deref().unwrap_or(&self.arrays)
    }
}

/// Encodes `images`, a render of `camera`, as `encoding` asks, in each of its formats:
/// `id.*`; `depth.png`, `depth.ppm`, `distance.npy` or `z.npy`; `normal.*`; `color.png` (the
/// shade hook's RGBA as it returned it, where [`Images::color`] holds it; else the palette by
/// coverage, premultiplied alpha, or opaque over the background, see
/// [`PixelCoverage::to_rgba8`]); for supersampled images with ids, `alpha.npy` (float32,
/// H x W); `render.npz`, `render.exr`, `depth16.png`; and `camera.json`.
pub(crate) fn encode<T: Real>(
    images: &Images<T>,
    encoding: &Encoding,
    camera: &Camera,
) -> Vec<EncodedFile> {
    let depths = encoding.depths(images, camera, 0);
    let mut files: Vec<EncodedFile> = (encoding.formats.iter())
        .flat_map(|&f| encode_format(images, f, encoding, &depths))
        .collect();
    files.push(encoding.camera_json(camera));
    files
}

/// The files of one format (see [`encode`]); `depths` holds the images' depths as `encoding`
/// asks for them.
pub(super) fn encode_format<T: Real>(
    images: &Images<T>,
    format: Format,
    encoding: &Encoding,
    depths: &Depths<T>,
) -> Vec<EncodedFile> {
    let depth = depths.arrays();
    let outputs = encoding.outputs;
    match format {
        // Each picture compressed on a thread of its own: the writer of a dataset's views
        // keeps pace with the renders.
        Format::Png => {
            use rayon::prelude::*;
            let pictures = png_pictures(images, outputs, encoding.background);
            pictures.par_iter().map(Picture::to_png).collect()
        }
        Format::Ppm => pictures::encode_ppm(images, outputs),
        Format::Npy => npy::encode_all(images, outputs, encoding.depth, depth),
        Format::Npz => vec![npy::encode_npz(&npy::encode_all(
            images,
            outputs,
            encoding.depth,
            depth,
        ))],
        Format::Exr => vec![exr::encode_exr(images, depth, outputs)],
        Format::Depth16 => {
            let picture = depth16_picture(images, depths.depth16(), encoding.depth_scale);
            vec![picture.to_png()]
        }
    }
}

/// `depth16.png` as a picture ([`depth16_levels`]).
pub(super) fn depth16_picture<T: Real>(images: &Images<T>, depth: &[T], scale: f64) -> Picture {
    let levels = depth16_levels(depth, scale);
    Picture {
        name: "depth16.png",
        width: images.width,
        height: images.height,
        channels: 1,
        bits: 16,
        pixels: levels.iter().flat_map(|l| l.to_be_bytes()).collect(),
    }
}

/// The png pictures of `images` before encoding: those of `outputs` (see [`encode`]).
pub(crate) fn png_pictures<T: Real>(
    images: &Images<T>,
    outputs: Outputs,
    background: Option<[u8; 3]>,
) -> Vec<Picture> {
    let mut set = picture_set(images, outputs, pictures::PNG_NAMES);
    if outputs.color {
        let rgba = match &images.color {
            Some(hook) => hook.iter().flatten().copied().collect(),
            None => color_rgba8(images, background),
        };
        set.push(Picture::new(
            "color.png",
            images.width,
            images.height,
            4,
            rgba,
        ));
    }
    set
}

/// PNG bytes of an RGB image.
pub fn encode_png_rgb(img: &image::RgbImage) -> Vec<u8> {
    pictures::png(
        img.width(),
        img.height(),
        img.as_raw(),
        image::ExtendedColorType::Rgb8,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_parse() {
        assert_eq!("npy".parse::<Format>(), Ok(Format::Npy));
        assert!("jpg".parse::<Format>().unwrap_err().contains("jpg"));
    }
}
