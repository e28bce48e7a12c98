//! The result of a render: per-pixel object id, distance and normal, in row-major order
//! (row 0 at the top). Both the GPU kernel and the CPU reference produce this.

use std::str::FromStr;

use crate::math::Real;

/// Id of a pixel whose ray hits nothing.
pub const MISS: i32 = -1;

/// The outputs of one pixel (a miss: id [`MISS`], distance `+inf`, normal zero).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Pixel<T> {
    /// Object index, or [`MISS`].
    pub id: i32,
    /// Distance from the ray's origin to the hit.
    pub distance: T,
    /// Unit surface normal at the hit.
    pub normal: [T; 3],
}

/// Per-pixel render outputs in precision `T` (`f32` from the GPU, `f32` or `f64` from the CPU);
/// the default is an image of no pixels.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Images<T> {
    /// Pixels per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Object index, or [`MISS`].
    pub id: Vec<i32>,
    /// Euclidean distance from the ray origin to the hit, `t * |dir|`; `+inf` on a miss.
    pub distance: Vec<T>,
    /// Unit surface normal at the hit (outward for spheres, as stored for planes, by corner
    /// order for triangles); zero on a miss.
    pub normal: Vec<[T; 3]>,
    /// The camera's focal length: the distance that `depth.png` maps to full white.
    pub focal_length: f64,
    /// RGBA, 8 bits a channel, from the user's shade hook (`--shader`), when one ran.
    pub color: Option<Vec<[u8; 4]>>,
    /// The rays the shade hook cast beyond the camera's (`trace`, `occluded`), when it cast
    /// any.
    pub hook_rays: Option<u64>,
    /// How much of each pixel its samples covered, when the images were supersampled
    /// ([`crate::RenderOptions::samples_per_pixel`] above 1); `None` for one ray per pixel.
    pub coverage: Option<Coverage>,
    /// The GPU kernel's time in seconds, for a render asked to be timed
    /// ([`crate::RenderOptions::timed`]) on a device with timestamp queries.
    pub kernel_s: Option<f64>,
    /// The fraction of pixels adaptive precision cast again in f64 (`None` for other
    /// precisions).
    pub recast_fraction: Option<f64>,
    /// Whether adaptive precision cast those pixels again on the GPU (else on the CPU).
    pub recast_on_gpu: bool,
    /// Wall-clock seconds of each stage of a render asked to be timed
    /// ([`crate::RenderOptions::timed`]) in f32 or f64 at one sample per pixel (`None` for
    /// others).
    pub stages: Option<Stages>,
}

/// Wall-clock seconds of the stages of one render ([`crate::Images::stages`]), and the GPU
/// kernel's time. A CPU render has a build and a trace only.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Stages {
    /// Primitives rounded for the GPU, the BVH built (when the kernel uses one).
    pub build_s: f64,
    /// The kernel pipeline made (0 when it was cached).
    pub compile_s: f64,
    /// The scene's buffers laid out, created and filled on the device (0 when they were
    /// resident already).
    pub upload_s: f64,
    /// Every tile dispatched and read back (on the CPU: every pixel found, and coloured).
    pub trace_s: f64,
    /// The kernel's GPU time summed over tiles (timestamp queries), where the device has them.
    pub kernel_s: Option<f64>,
    /// Of `trace_s`: the inputs (a list of pixels or rays) written for the device.
    pub write_s: f64,
    /// Of `trace_s`: the host waiting for the device (the kernel and the copies that the
    /// host's work did not overlap).
    pub wait_s: f64,
    /// Of `trace_s`: the outputs read from mapped memory into the layout they are delivered
    /// in.
    pub convert_s: f64,
    /// The GPU's time copying the outputs to memory the host maps, summed over tiles
    /// (timestamps inside command encoders); `None` where the host maps the kernel's outputs
    /// themselves or the device has no such timestamps.
    pub copy_s: Option<f64>,
    /// Bytes of output read back from the device.
    pub readback_bytes: u64,
    /// The rays the shade hook cast (`trace`, `occluded`), where it casts any.
    pub hook_rays: Option<u64>,
    /// Nodes of the BVH the render went through (`None`: brute force).
    pub bvh_nodes: Option<usize>,
    /// How a GPU kernel's rays walked the BVH: in packets (`Some(true)`) or ray by ray
    /// (`Some(false)`); `None` on the CPU or without a BVH.
    pub packets: Option<bool>,
    /// Bytes of the geometry as the render held it, per triangle (`None` without triangles):
    /// each triangle as laid out for the device (on the GPU 40 bytes in f32, 80 in f64; on the
    /// CPU 36 and 72), an object id of 4 bytes per sphere, plane and triangle, and the BVH (64
    /// bytes a node and 4 per sphere and triangle) where the render used one.
    pub bytes_per_triangle: Option<f64>,
}

/// Per-pixel coverage of a supersampled render, row-major like the images.
#[derive(Clone, Debug, PartialEq)]
pub struct Coverage {
    /// Samples per pixel, `s * s`.
    pub spp: u32,
    /// Number of samples of the pixel that hit some object.
    pub hits: Vec<u32>,
    /// `hits / spp` as f32 (the division of two integers, correctly rounded: exact when `spp`
    /// is a power of two).
    pub alpha: Vec<f32>,
    /// Sum of `palette[id % 9]` (8-bit levels) over the samples that hit, from which
    /// `color.png` is made.
    pub color_sum: Vec<[u32; 3]>,
}

impl<T: Real> Images<T> {
    /// An image of `width * height` misses.
    pub(crate) fn new_miss(width: u32, height: u32, focal_length: f64) -> Self {
        let n = width as usize * height as usize;
        Images {
            width,
            height,
            id: vec![MISS; n],
            distance: vec![T::INFINITY; n],
            normal: vec![[T::ZERO; 3]; n],
            focal_length,
            color: None,
            hook_rays: None,
            coverage: None,
            kernel_s: None,
            recast_fraction: None,
            recast_on_gpu: false,
            stages: None,
        }
    }

    /// Number of pixels.
    pub(crate) fn len(&self) -> usize {
        self.id.len()
    }

    /// The outputs of pixel `k` (row-major index).
    pub(crate) fn pixel(&self, k: usize) -> Pixel<T> {
        Pixel {
            id: self.id[k],
            distance: self.distance[k],
            normal: self.normal[k],
        }
    }

    /// Row-major index of pixel (`row`, `col`).
    #[cfg(test)]
    pub(crate) fn index(&self, row: u32, col: u32) -> usize {
        row as usize * self.width as usize + col as usize
    }
}

/// One output of a render, as `raycast render --outputs` names it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Output {
    /// Object ids: `id.png`, `id.ppm`, `id.npy` (and `alpha.npy` with `--spp`).
    Id,
    /// Distances: `depth.png`, `depth.ppm`, `distance.npy`.
    Distance,
    /// Normals: `normal.png`, `normal.ppm`, `normal.npy`.
    Normal,
    /// `color.png`: palette colours by coverage, or the user's shade hook.
    Color,
}

impl FromStr for Output {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s.trim() {
            "id" => Ok(Output::Id),
            "distance" => Ok(Output::Distance),
            "normal" => Ok(Output::Normal),
            "color" => Ok(Output::Color),
            other => Err(format!(
                "unknown output `{other}` (expected id, distance, normal or color)"
            )),
        }
    }
}

/// Which outputs a render produces. An output not asked for is neither computed by the GPU
/// kernel nor read back, and keeps the value of a miss in [`Images`]: id [`MISS`], distance
/// `+inf`, normal zero, no colour. (Another output may need it computed all the same: the
/// palette `color.png` and supersampling need the ids.)
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Outputs {
    /// The object ids (`id.png`, `id.npy`).
    pub id: bool,
    /// The distances (`depth.png`, `distance.npy`, `depth16.png`).
    pub distance: bool,
    /// The normals (`normal.png`, `normal.npy`).
    pub normal: bool,
    /// The colours (`color.png`): a shade hook's, or the ids' palette.
    pub color: bool,
}

impl Outputs {
    /// Every output.
    pub(crate) const ALL: Outputs = Outputs {
        id: true,
        distance: true,
        normal: true,
        color: true,
    };

    /// Id, distance and normal: what [`Images`] holds without a shade hook.
    pub(crate) const GEOMETRY: Outputs = Outputs {
        color: false,
        ..Outputs::ALL
    };

    /// No output ([`Outputs::default`]).
    pub(crate) const NONE: Outputs = Outputs {
        id: false,
        distance: false,
        normal: false,
        color: false,
    };

    /// The outputs of a list (`--outputs id,normal`).
    pub(crate) fn of(list: &[Output]) -> Outputs {
        let mut o = Outputs::NONE;
        for output in list {
            match output {
                Output::Id => o.id = true,
                Output::Distance => o.distance = true,
                Output::Normal => o.normal = true,
                Output::Color => o.color = true,
            }
        }
        o
    }
}

/// Every output, as a render makes them unless told otherwise ([`crate::RenderOptions`]).
impl Default for Outputs {
    fn default() -> Outputs {
        Outputs::ALL
    }
}
