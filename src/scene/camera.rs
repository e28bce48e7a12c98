//! The scene's camera in one form, whichever way the scene file describes it (the course's
//! focal length and image-plane size, a field of view, or pixel intrinsics), and the image plane
//! and pixel intrinsics it has at a given resolution. Host math in f64 with glam.

use glam::{DMat3, DMat4, DVec3};

use super::MAX_MAGNITUDE;
use crate::error::{Error, Result};

/// Perspective (rays from the eye) or orthographic (parallel rays from the image plane).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Projection {
    /// Rays from the eye.
    Perspective,
    /// Parallel rays from the image plane.
    Orthographic,
}

/// How the image plane's extent is given.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Lens {
    /// The course's: the image plane's size in scene units, whatever the resolution.
    Size {
        /// Width in scene units.
        width: f64,
        /// Height in scene units.
        height: f64,
    },
    /// A vertical field of view in degrees (in (0, 180)); the width follows the resolution's
    /// aspect ratio, so pixels stay square at any `--size`.
    Fov {
        /// The vertical field of view.
        degrees: f64,
    },
    /// Pixel intrinsics (OpenCV's convention: pixel (column j, row i) has its centre at
    /// (j, i)) for an image of `resolution` pixels. Another resolution keeps the same image
    /// plane, with the intrinsics scaled to its pixels.
    Intrinsics {
        /// Focal length in pixels, horizontally.
        fx: f64,
        /// Focal length in pixels, vertically.
        fy: f64,
        /// Principal point, column.
        cx: f64,
        /// Principal point, row.
        cy: f64,
        /// The image size the intrinsics are for.
        resolution: [u32; 2],
    },
}

/// The validated camera.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    /// Perspective or orthographic.
    pub projection: Projection,
    /// The eye's position.
    pub eye: DVec3,
    /// The viewing direction (not a point).
    pub look: DVec3,
    /// Need not be perpendicular to `look`; not parallel to it.
    pub up: DVec3,
    /// The distance from the eye to the image plane, where rays have t = 1: nothing nearer is
    /// drawn (the course's `d`; a field-of-view or intrinsics camera's `near`).
    pub focal_length: f64,
    /// How the image plane's extent is given.
    pub lens: Lens,
    /// Pixels `[nx, ny]`.
    pub resolution: [u32; 2],
    /// The distance `depth.png` shows white: the focal length for the course's cameras.
    pub depth_white: f64,
}

/// The image plane at the camera's resolution, in scene units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ImagePlane {
    /// Width in scene units.
    pub width: f64,
    /// Height in scene units.
    pub height: f64,
    /// Where the image's centre is on the plane, from the point straight ahead of the eye,
    /// along the frame's right and up vectors: zero but for intrinsics whose principal point
    /// is off the image's centre.
    pub shift: [f64; 2],
}

impl Camera {
    /// Pixels of the image, `nx * ny`: the camera's rays at one sample per pixel.
    pub(crate) fn pixel_count(&self) -> u64 {
        let [nx, ny] = self.resolution;
        nx as u64 * ny as u64
    }

    /// The image plane at [`Camera::resolution`].
    pub(crate) fn image_plane(&self) -> ImagePlane {
        self.image_plane_at(self.resolution)
    }

    /// The image plane at `[nx, ny]` pixels.
    pub(crate) fn image_plane_at(&self, resolution: [u32; 2]) -> ImagePlane {
        let [nx, ny] = resolution.map(f64::from);
        let d = self.focal_length;
        match self.lens {
            Lens::Size { width, height } => ImagePlane {
                width,
                height,
                shift: [0.0, 0.0],
            },
            Lens::Fov { degrees } => {
                let height = 2.0 * d * (degrees.to_radians() / 2.0).tan();
                ImagePlane {
                    width: height * nx / ny,
                    height,
                    shift: [0.0, 0.0],
                }
            }
            Lens::Intrinsics {
                fx,
                fy,
                cx,
                cy,
                resolution: [gx, gy],
            } => {
                let [gx, gy] = [f64::from(gx), f64::from(gy)];
                // The image centre is at ((n - 1) / 2) in OpenCV's pixel coordinates.
                ImagePlane {
                    width: d * gx / fx,
                    height: d * gy / fy,
                    shift: [
                        d * ((gx - 1.0) / 2.0 - cx) / fx,
                        d * (cy - (gy - 1.0) / 2.0) / fy,
                    ],
                }
            }
        }
    }

    /// A size or shift of the image plane beyond [`MAX_MAGNITUDE`] (or not finite), which
    /// intrinsics or a field of view can give where the course's fields cannot.
    pub(crate) fn oversized_plane(&self) -> Option<f64> {
        let plane = self.image_plane();
        let values = [plane.width, plane.height, plane.shift[0], plane.shift[1]];
        values
            .into_iter()
            .find(|x| !(x.is_finite() && x.abs() <= MAX_MAGNITUDE))
    }

    /// The orthonormal frame: right `u = normalize(look x up)`, up `v = w x u`, backward
    /// `w = -look / |look|` (the lecture's formulas, in this order of operations).
    pub(crate) fn basis(&self) -> [DVec3; 3] {
        let w = -(self.look / self.look.length());
        let side = self.look.cross(self.up);
        let u = side / side.length();
        [u, w.cross(u), w]
    }

    /// The pixel intrinsics `K` at [`Camera::resolution`], OpenCV's convention (pixel (j, i)
    /// centred at (j, i); camera x right, y down, z forward). Perspective: pixel = K (x/z,
    /// y/z, 1). Orthographic: pixel = K (x, y, 1), x and y in scene units (no division by z).
    pub(crate) fn intrinsics(&self) -> DMat3 {
        let plane = self.image_plane();
        let [nx, ny] = self.resolution.map(f64::from);
        // Pixels per scene unit on the image plane, and per unit of x/z behind it.
        let (px, py) = (nx / plane.width, ny / plane.height);
        let depth = match self.projection {
            Projection::Perspective => self.focal_length,
            Projection::Orthographic => 1.0,
        };
        let cx = (nx - 1.0) / 2.0 - plane.shift[0] * px;
        let cy = (ny - 1.0) / 2.0 + plane.shift[1] * py;
        DMat3::from_cols(
            DVec3::new(px * depth, 0.0, 0.0),
            DVec3::new(0.0, py * depth, 0.0),
            DVec3::new(cx, cy, 1.0),
        )
    }

    /// World to camera coordinates with OpenCV's axes (x right, y down, z forward).
    pub(crate) fn world_to_camera(&self) -> DMat4 {
        let [u, v, w] = self.basis();
        let rotation = DMat3::from_cols(u, -v, -w).transpose();
        let mut m = DMat4::from_mat3(rotation);
        m.w_axis = (-(rotation * self.eye)).extend(1.0);
        m
    }

    /// Camera coordinates (OpenCV's axes) to world: columns right, down, forward and the eye.
    pub(crate) fn camera_to_world(&self) -> DMat4 {
        let [u, v, w] = self.basis();
        DMat4::from_cols(
            u.extend(0.0),
            (-v).extend(0.0),
            (-w).extend(0.0),
            self.eye.extend(1.0),
        )
    }
}

/// Camera settings from the command line (`--eye`, `--look-at`, `--up`, `--fov`), which
/// replace those of the scene's camera or of a mesh's default view.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CameraOverrides {
    /// The eye's position.
    pub eye: Option<DVec3>,
    /// The point looked at.
    pub look_at: Option<DVec3>,
    /// The up direction.
    pub up: Option<DVec3>,
    /// Vertical field of view, degrees.
    pub fov: Option<f64>,
}

/// The default view of a mesh rendered directly: from the front (+z), right (+x) and above
/// (+y), up +y, in this direction from the centre of its bounding box.
pub(crate) const MESH_VIEW_DIRECTION: DVec3 = DVec3::new(0.6, 0.5, 1.0);
/// The default view's vertical field of view, degrees.
pub(crate) const MESH_VIEW_FOV: f64 = 40.0;

impl CameraOverrides {
    pub(crate) fn is_empty(&self) -> bool {
        *self == CameraOverrides::default()
    }

    fn refuse(option: &str, message: impl Into<String>) -> Error {
        Error::Argument {
            option: option.into(),
            message: message.into(),
        }
    }

    /// The values checked: finite, within the scene's limits, a field of view in (0, 180).
    pub(crate) fn check(&self) -> Result<()> {
        for (option, v) in [
            ("eye", self.eye),
            ("look_at", self.look_at),
            ("up", self.up),
        ] {
            if let Some(v) = v
                && !(v.is_finite() && v.abs().max_element() <= MAX_MAGNITUDE)
            {
                return Err(Self::refuse(
                    option,
                    format!("needs finite numbers of magnitude at most {MAX_MAGNITUDE:e}"),
                ));
            }
        }
        if self.up == Some(DVec3::ZERO) {
            return Err(Self::refuse("up", "must be a non-zero vector"));
        }
        if let Some(fov) = self.fov
            && !(fov > 0.0 && fov < 180.0)
        {
            return Err(Self::refuse(
                "fov",
                format!("must be between 0 and 180 degrees, both excluded (got {fov})"),
            ));
        }
        Ok(())
    }

    /// `camera` with these settings: the eye moved (looking the same way unless `look_at` is
    /// given), looking at `look_at`, `up` replaced, and the image plane given by `fov` (the
    /// focal length kept as the distance rays start at). Refuses values out of range, and an
    /// up direction parallel to the viewing direction, naming the setting.
    pub fn apply(&self, camera: &Camera) -> Result<Camera> {
        self.check()?;
        let mut c = camera.clone();
        if let Some(eye) = self.eye {
            c.eye = eye;
        }
        if let Some(target) = self.look_at {
            c.look = target - c.eye;
            if c.look == DVec3::ZERO {
                return Err(Self::refuse(
                    "look_at",
                    "is the eye: no direction to look in",
                ));
            }
        }
        if let Some(up) = self.up {
            c.up = up;
        }
        if c.look.normalize().cross(c.up.normalize()).length() <= 1e-12 {
            // The option that set the last of the two directions.
            let given = [
                ("up", self.up.is_some()),
                ("look_at", self.look_at.is_some()),
            ];
            let option = given.iter().find(|(_, g)| *g).map_or("eye", |(o, _)| o);
            return Err(Self::refuse(
                option,
                "leaves the up direction parallel to the viewing direction",
            ));
        }
        if let Some(degrees) = self.fov {
            if c.projection == Projection::Orthographic {
                return Err(Self::refuse("fov", "needs a perspective camera"));
            }
            c.lens = Lens::Fov { degrees };
            if let Some(x) = c.oversized_plane() {
                return Err(Self::refuse(
                    "fov",
                    format!(
                        "gives an image plane of size {x:e}, beyond the supported {MAX_MAGNITUDE:e}"
                    ),
                ));
            }
        }
        Ok(c)
    }

    /// The default view of objects within `bounds` at `resolution` pixels, with these
    /// settings: looking at the box's centre (or `look_at`) from [`MESH_VIEW_DIRECTION`], far
    /// enough for the box's bounding sphere to fit the image (or from `eye`), up +y (or `up`),
    /// vertical field of view [`MESH_VIEW_FOV`] (or `fov`).
    pub(crate) fn framing(
        &self,
        bounds: Option<(DVec3, DVec3)>,
        resolution: [u32; 2],
    ) -> Result<Camera> {
        self.check()?;
        let (lo, hi) = bounds.unwrap_or((DVec3::splat(-1.0), DVec3::splat(1.0)));
        let target = self.look_at.unwrap_or((lo + hi) / 2.0);
        let radius = ((hi - lo).length() / 2.0).max(f64::MIN_POSITIVE);
        let degrees = self.fov.unwrap_or(MESH_VIEW_FOV);
        let [nx, ny] = resolution.map(f64::from);
        let half_height = (degrees.to_radians() / 2.0).tan();
        let half_angle = half_height.min(half_height * nx / ny).atan();
        let eye = self.eye.unwrap_or(
            (lo + hi) / 2.0 + MESH_VIEW_DIRECTION.normalize() * (radius / half_angle.sin()),
        );
        let framed = Camera {
            projection: Projection::Perspective,
            eye,
            look: target - eye,
            up: DVec3::Y,
            focal_length: default_near(eye, bounds),
            lens: Lens::Fov { degrees },
            resolution,
            depth_white: default_depth_white(eye, bounds),
        };
        if framed.look == DVec3::ZERO {
            return Err(Self::refuse("eye", "is the point looked at"));
        }
        // The eye and the field of view are the framed camera's already.
        let settings = CameraOverrides {
            eye: None,
            fov: None,
            ..*self
        };
        settings.apply(&framed)
    }
}

/// The image plane's distance for a camera that gives none (a field of view or intrinsics
/// without `near`): 1/1000 of the distance from `eye` to the farthest corner of `bounds`, the
/// box of the scene's objects ([`super::bounds`]), so that only what is that close to the eye
/// is cut away; 1/1000 of a unit without objects.
pub(crate) fn default_near(eye: DVec3, bounds: Option<(DVec3, DVec3)>) -> f64 {
    let farthest = bounds.map_or(0.0, |(lo, hi)| farthest_corner(eye, lo, hi));
    if farthest > 0.0 {
        farthest / 1000.0
    } else {
        1e-3
    }
}

/// The distance from `eye` to the farthest corner of the box from `lo` to `hi`.
fn farthest_corner(eye: DVec3, lo: DVec3, hi: DVec3) -> f64 {
    (eye - lo).abs().max((eye - hi).abs()).length()
}

/// The distance `depth.png` shows white for a camera other than the course's (whose focal
/// length it is): the distance from `eye` to the box of the scene's objects, or from inside it
/// 1/8 of the distance to its farthest corner; 1 without objects.
pub(crate) fn default_depth_white(eye: DVec3, bounds: Option<(DVec3, DVec3)>) -> f64 {
    let Some((lo, hi)) = bounds else {
        return 1.0;
    };
    let outside = (lo - eye).max(eye - hi).max(DVec3::ZERO).length();
    let white = if outside > 0.0 {
        outside
    } else {
        farthest_corner(eye, lo, hi) / 8.0
    };
    if white > 0.0 { white } else { 1.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera(lens: Lens, resolution: [u32; 2]) -> Camera {
        Camera {
            projection: Projection::Perspective,
            eye: DVec3::new(1.0, 2.0, 3.0),
            look: DVec3::new(0.3, -0.2, -1.0),
            up: DVec3::Y,
            focal_length: 2.0,
            lens,
            resolution,
            depth_white: 2.0,
        }
    }

    #[test]
    fn intrinsics_round_trip_through_the_image_plane() {
        let lens = Lens::Intrinsics {
            fx: 500.0,
            fy: 480.0,
            cx: 300.5,
            cy: 170.25,
            resolution: [640, 360],
        };
        let k = camera(lens, [640, 360]).intrinsics();
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs().max(1.0);
        assert!(close(k.x_axis.x, 500.0) && close(k.y_axis.y, 480.0));
        assert!(close(k.z_axis.x, 300.5) && close(k.z_axis.y, 170.25));
        // Twice the pixels over the same image plane: twice the focal lengths in pixels, and
        // the principal point where the same ray goes.
        let k2 = camera(lens, [1280, 720]).intrinsics();
        assert!(close(k2.x_axis.x, 1000.0) && close(k2.y_axis.y, 960.0));
        assert!(close(k2.z_axis.x, 2.0 * (300.5 + 0.5) - 0.5));
        assert!(close(k2.z_axis.y, 2.0 * (170.25 + 0.5) - 0.5));
    }

    #[test]
    fn a_field_of_view_keeps_square_pixels() {
        let c = camera(Lens::Fov { degrees: 90.0 }, [200, 100]);
        let plane = c.image_plane();
        assert!((plane.height - 4.0).abs() < 1e-12);
        assert_eq!(plane.width, 2.0 * plane.height);
        let k = c.intrinsics();
        assert!((k.x_axis.x - k.y_axis.y).abs() < 1e-9);
        assert_eq!([k.z_axis.x, k.z_axis.y], [99.5, 49.5]);
    }

    #[test]
    fn camera_to_world_puts_forward_along_look_and_down_opposite_up() {
        let c = camera(Lens::Fov { degrees: 40.0 }, [4, 3]);
        let m = c.camera_to_world();
        let forward = m.transform_vector3(DVec3::Z);
        assert!((forward - c.look.normalize()).length() < 1e-15);
        assert!(m.transform_vector3(DVec3::Y).dot(c.up) < 0.0);
        let back = c.world_to_camera() * m;
        assert!(back.abs_diff_eq(DMat4::IDENTITY, 1e-14));
        assert_eq!(m.transform_point3(DVec3::ZERO), c.eye);
    }
}
