//! `render.exr`: the render's arrays as the channels of one OpenEXR file (what Mitsuba's AOVs
//! give), losslessly compressed (ZIP).

use exr::prelude as x;
use exr::prelude::WritableImage;

use super::EncodedFile;
use crate::images::{Images, Outputs};
use crate::math::Real;

/// Channels `Z` (`depth`, f32, `+inf` on a miss), `N.X`, `N.Y`, `N.Z` (f32, 0 on a miss), `id`
/// (u32, the object id, 0xFFFFFFFF on a miss) and, for supersampled images, `A` (f32
/// coverage), those of `outputs`. An f64 render's values are rounded to f32 (OpenEXR has no
/// f64 samples); an f32 render's are the npy files' exactly.
pub(crate) fn encode_exr<T: Real>(
    images: &Images<T>,
    depth: &[T],
    outputs: Outputs,
) -> EncodedFile {
    let f32s = |values: &mut dyn Iterator<Item = T>| {
        x::FlatSamples::F32(values.map(|v| v.to_f64() as f32).collect())
    };
    let mut channels = Vec::new();
    if outputs.distance {
        channels.push(x::AnyChannel::new("Z", f32s(&mut depth.iter().copied())));
    }
    if outputs.normal {
        for (k, name) in ["N.X", "N.Y", "N.Z"].into_iter().enumerate() {
            let samples = f32s(&mut images.normal.iter().map(|n| n[k]));
            channels.push(x::AnyChannel::new(name, samples));
        }
    }
    if outputs.id {
        let ids = images.id.iter().map(|&id| id as u32).collect();
        channels.push(x::AnyChannel::new("id", x::FlatSamples::U32(ids)));
        if let Some(coverage) = &images.coverage {
            let alpha = x::FlatSamples::F32(coverage.alpha.clone());
            channels.push(x::AnyChannel::new("A", alpha));
        }
    }
    // Data, not colour: no channel is a hint for perceptual (lossy) compression.
    for channel in &mut channels {
        channel.quantize_linearly = false;
    }
    let size = (images.width as usize, images.height as usize);
    let layer = x::Layer::new(
        size,
        x::LayerAttributes::default(),
        x::Encoding::SMALL_LOSSLESS,
        x::AnyChannels::sort(x::SmallVec::from_vec(channels)),
    );
    let mut bytes = std::io::Cursor::new(Vec::new());
    x::Image::from_layer(layer)
        .write()
        .to_buffered(&mut bytes)
        .expect("encoding an EXR into memory cannot fail");
    EncodedFile {
        name: "render.exr",
        bytes: bytes.into_inner(),
    }
}
