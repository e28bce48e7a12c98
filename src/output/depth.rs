//! The depth the files hold (distance from the ray's origin, or planar z), `depth16.png`, and
//! `camera.json`: what other tools need to go back from pixels and depths to 3D points.
//!
//! `depth16.png` holds planar z unless asked otherwise, as every RGB-D dataset's depth images
//! do (and as Open3D's `create_from_depth_image` reads them); the float arrays hold distance
//! unless asked otherwise, so `distance.npy` means what it always has.

use std::borrow::Cow;
use std::str::FromStr;

use glam::{DMat3, DMat4};
use rayon::prelude::*;
use serde_json::json;

use super::EncodedFile;
use crate::images::Images;
use crate::kernel::frame::Frame;
use crate::math::{Real, length};
use crate::scene::{Camera, Lens, Projection};

/// Which depth a file holds: the npy and npz arrays (`distance.npy` or `z.npy`) and the EXR's
/// `Z` ([`super::Encoding::depth`]), or `depth16.png` ([`super::Encoding::depth16`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Depth {
    /// Euclidean distance from the ray's origin to the hit (`distance.npy`).
    #[default]
    Distance,
    /// Planar depth along the viewing axis, from the eye's plane (`z.npy`): what OpenCV and
    /// Open3D back-project with the intrinsics.
    Z,
}

impl FromStr for Depth {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s.trim() {
            "distance" => Ok(Depth::Distance),
            "z" => Ok(Depth::Z),
            other => Err(format!("unknown depth `{other}` (expected distance or z)")),
        }
    }
}

impl Depth {
    /// The npy file's name.
    pub(crate) fn npy_name(self) -> &'static str {
        match self {
            Depth::Distance => "distance.npy",
            Depth::Z => "z.npy",
        }
    }

    /// The name `--depth` and `camera.json` give it.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Depth::Distance => "distance",
            Depth::Z => "z",
        }
    }

    /// The depth of every pixel of `images`, rows `first_row..` of an image `camera` renders
    /// (a band's rows start below the top): the distance as rendered, or planar z. A pixel's
    /// ray reaches the image plane at t = 1 and its z grows by the focal length per unit of t,
    /// so z = distance * d / |direction| (the direction in f64 from the camera's frame; an
    /// orthographic ray's length is d: z is the distance). A miss stays `+inf`.
    pub(crate) fn of<'a, T: Real>(
        self,
        images: &'a Images<T>,
        camera: &Camera,
        first_row: u32,
    ) -> Cow<'a, [T]> {
        if self == Depth::Distance || camera.projection == Projection::Orthographic {
            return Cow::Borrowed(&images.distance);
        }
        let frame = Frame::new(camera, camera.resolution);
        let width = images.width as usize;
        (images.distance.par_iter().enumerate())
            .map(|(k, &distance)| {
                let (i, j) = ((k / width) as u32 + first_row, (k % width) as u32);
                let ray = crate::kernel::frame::camera_ray(&frame, i, j);
                let scale = frame.focal_length / length(ray.direction);
                T::from_f64(distance.to_f64() * scale)
            })
            .collect::<Vec<T>>()
            .into()
    }
}

/// `depth16.png`: 16-bit grey, `round(depth * scale)` (half away from zero) on a hit, 0 on a
/// miss and where that is beyond 65535.
pub(crate) fn depth16_levels<T: Real>(depth: &[T], scale: f64) -> Vec<u16> {
    depth
        .iter()
        .map(|d| {
            let level = (d.to_f64() * scale).round();
            if (0.0..=65535.0).contains(&level) {
                level as u16
            } else {
                0
            }
        })
        .collect()
}

fn rows3(m: DMat3) -> [[f64; 3]; 3] {
    let t = m.transpose().to_cols_array_2d();
    [t[0], t[1], t[2]]
}

fn rows4(m: DMat4) -> [[f64; 4]; 4] {
    m.transpose().to_cols_array_2d()
}

/// What `depth16.png` holds, where one is written: its depth and its levels per scene unit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Depth16 {
    pub depth: Depth,
    pub scale: f64,
}

/// `camera.json`: the render's size, pixel intrinsics `K` and extrinsics in OpenCV's
/// convention (docs/cli.md#camerajson), which depth the arrays hold (`depth`) and
/// `depth16.png` holds where it is written, and the camera as the scene describes it.
pub(crate) fn camera_json(camera: &Camera, depth: Depth, depth16: Option<Depth16>) -> EncodedFile {
    let [nx, ny] = camera.resolution;
    let projection = match camera.projection {
        Projection::Perspective => "perspective",
        Projection::Orthographic => "orthographic",
    };
    let mut scene = json!({
        "type": projection,
        "eye": camera.eye.to_array(),
        "look": camera.look.to_array(),
        "up": camera.up.to_array(),
        "resolution": camera.resolution,
    });
    match camera.lens {
        Lens::Size { width, height } => {
            scene["focal_length"] = json!(camera.focal_length);
            scene["width"] = json!(width);
            scene["height"] = json!(height);
        }
        Lens::Fov { degrees } => {
            scene["fov"] = json!(degrees);
            scene["near"] = json!(camera.focal_length);
        }
        Lens::Intrinsics {
            fx,
            fy,
            cx,
            cy,
            resolution,
        } => {
            scene["intrinsics"] = json!({"fx": fx, "fy": fy, "cx": cx, "cy": cy});
            scene["near"] = json!(camera.focal_length);
            scene["resolution"] = json!(resolution);
        }
    }
    let mut value = json!({
        "width": nx,
        "height": ny,
        "projection": projection,
        "K": rows3(camera.intrinsics()),
        "world_to_camera": rows4(camera.world_to_camera()),
        "camera_to_world": rows4(camera.camera_to_world()),
        "depth": depth.name(),
        "near": camera.focal_length,
        "scene_camera": scene,
    });
    if let Some(Depth16 { depth, scale }) = depth16 {
        value["depth16"] = json!(depth.name());
        value["depth16_scale"] = json!(scale);
    }
    // One line a field, matrices by rows.
    let fields: Vec<String> = (value.as_object().expect("an object").iter())
        .map(|(key, v)| format!("  {}: {v}", serde_json::Value::from(key.as_str())))
        .collect();
    let bytes = format!("{{\n{}\n}}\n", fields.join(",\n")).into_bytes();
    EncodedFile {
        name: "camera.json",
        bytes,
    }
}
