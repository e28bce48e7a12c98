//! The camera frame, built on the host in f64 from the scene's camera (the lecture's formulas).
//!
//! The frame is built once; each pixel's ray is generated from it by [`camera_ray`] here and by
//! its WGSL twin in `shaders/frame.wgsl`, line for line, on the CPU and the GPU alike.

use crate::kernel::types::Ray;
use crate::math::{Real, Vec3, vec3};
use crate::scene::{Camera, Projection};

/// Hits closer than this ray parameter are ignored: `t = 1` is the image plane, so only objects
/// in front of it count (the course's `min_t`).
pub(crate) const MIN_T: f64 = 1.0;

/// An orthonormal camera frame and the image-plane geometry, in precision `T`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Frame<T> {
    pub projection: Projection,
    pub eye: Vec3<T>,
    /// Right.
    pub u: Vec3<T>,
    /// Up (re-orthogonalised).
    pub v: Vec3<T>,
    /// Backward: the camera looks along `-w`.
    pub w: Vec3<T>,
    pub focal_length: T,
    /// Image-plane size in scene units.
    pub width: T,
    pub height: T,
    pub nx: u32,
    pub ny: u32,
    pub min_t: T,
}

/// The ray through the centre of pixel (`i`, `j`) of an `nx` x `ny` image: row `i` counts from
/// the top, column `j` from the left. It reaches the image plane at t = 1.
pub(crate) fn camera_ray<T: Real>(frame: &Frame<T>, i: u32, j: u32) -> Ray<T> {
    let (nx, ny) = (frame.nx, frame.ny);
    let two = T::TWO;
    let us = frame.width * (T::from_u32(j) + T::HALF) / T::from_u32(nx) - frame.width / two;
    let vs = -(frame.height * (T::from_u32(i) + T::HALF) / T::from_u32(ny) - frame.height / two);
    let mut ray = Ray {
        origin: vec3(T::ZERO, T::ZERO, T::ZERO),
        direction: vec3(T::ZERO, T::ZERO, T::ZERO),
    };
    if frame.projection == Projection::Orthographic {
        ray.origin = frame.eye + frame.u * us + frame.v * vs;
        ray.direction = frame.w * -frame.focal_length;
    } else {
        ray.origin = frame.eye;
        ray.direction = frame.u * us + frame.v * vs - frame.w * frame.focal_length;
    }
    ray
}

impl Frame<f64> {
    /// The camera's orthonormal basis (`Camera::basis`) and image plane
    /// ([`Camera::image_plane`]) at `[nx, ny]` pixels.
    ///
    /// An image plane shifted off the viewing axis (intrinsics with an off-centre principal
    /// point) is folded into the frame, so that ray generation stays the lecture's: a
    /// perspective ray's `-d w` becomes `-d w + shift_x u + shift_y v` (so `w` is then not a unit
    /// vector), an orthographic ray's origin moves by the shift.
    pub(crate) fn new(camera: &Camera, resolution: [u32; 2]) -> Frame<f64> {
        let [u, v, w] = camera.basis().map(Vec3::from);
        let plane = camera.image_plane_at(resolution);
        let d = camera.focal_length;
        let mut frame = Frame {
            projection: camera.projection,
            eye: camera.eye.into(),
            u,
            v,
            w,
            focal_length: d,
            width: plane.width,
            height: plane.height,
            nx: resolution[0],
            ny: resolution[1],
            min_t: MIN_T,
        };
        // Only where there is a shift: adding a zero could flip the sign of a zero component.
        let [sx, sy] = plane.shift;
        if sx != 0.0 || sy != 0.0 {
            let shift = u * sx + v * sy;
            match camera.projection {
                Projection::Perspective => frame.w = w - shift / d,
                Projection::Orthographic => frame.eye = frame.eye + shift,
            }
        }
        frame
    }
}

impl<T: Real> Frame<T> {
    /// The same frame rounded to precision `U` (what the GPU receives when `U = f32`).
    pub(crate) fn cast<U: Real>(&self) -> Frame<U> {
        Frame {
            projection: self.projection,
            eye: self.eye.cast(),
            u: self.u.cast(),
            v: self.v.cast(),
            w: self.w.cast(),
            focal_length: U::from_f64(self.focal_length.to_f64()),
            width: U::from_f64(self.width.to_f64()),
            height: U::from_f64(self.height.to_f64()),
            nx: self.nx,
            ny: self.ny,
            min_t: U::from_f64(self.min_t.to_f64()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{cross, dot, length, vec3};
    use crate::scene::Lens;
    use glam::DVec3;

    fn camera(look: [f64; 3], up: [f64; 3]) -> Camera {
        Camera {
            projection: Projection::Perspective,
            eye: DVec3::new(0.0, 0.0, 5.0),
            look: DVec3::from_array(look),
            up: DVec3::from_array(up),
            focal_length: 3.0,
            lens: Lens::Size {
                width: 1.6,
                height: 0.9,
            },
            resolution: [16, 9],
            depth_white: 3.0,
        }
    }

    #[test]
    fn course_camera_gives_the_standard_basis() {
        let f = Frame::new(&camera([0.0, 0.0, -1.0], [0.0, 1.0, 0.0]), [16, 9]);
        assert_eq!(f.u, vec3(1.0, 0.0, 0.0));
        assert_eq!(f.v, vec3(0.0, 1.0, 0.0));
        assert_eq!(f.w, vec3(0.0, 0.0, 1.0));
    }

    #[test]
    fn oblique_up_is_reorthogonalised() {
        let f = Frame::new(&camera([1.0, 2.0, -3.0], [0.3, 1.0, 0.2]), [16, 9]);
        for (a, b) in [(f.u, f.v), (f.v, f.w), (f.w, f.u)] {
            assert!(dot(a, b).abs() < 1e-15);
        }
        for a in [f.u, f.v, f.w] {
            assert!((length(a) - 1.0).abs() < 1e-15);
        }
        // Right-handed, with v on the same side as up.
        assert!(length(cross(f.u, f.v) - f.w) < 1e-15);
        assert!(dot(f.v, vec3(0.3, 1.0, 0.2)) > 0.0);
    }

    #[test]
    fn an_off_centre_principal_point_moves_every_ray_to_its_pixel() {
        for projection in [Projection::Perspective, Projection::Orthographic] {
            let mut c = camera([1.0, 2.0, -3.0], [0.3, 1.0, 0.2]);
            c.projection = projection;
            c.lens = Lens::Intrinsics {
                fx: 20.0,
                fy: 18.0,
                cx: 4.25,
                cy: 6.5,
                resolution: [16, 9],
            };
            let frame = Frame::new(&c, [16, 9]);
            let (k, to_camera) = (c.intrinsics(), c.world_to_camera());
            for (i, j) in [(0, 0), (8, 15), (3, 7)] {
                let ray = camera_ray(&frame, i, j);
                let [o, d] = [ray.origin, ray.direction].map(|p| DVec3::new(p.x, p.y, p.z));
                let pixel = match projection {
                    // Any point along the ray projects to the pixel's centre.
                    Projection::Perspective => k * to_camera.transform_point3(o + 2.5 * d),
                    Projection::Orthographic => {
                        let p = to_camera.transform_point3(o + 2.5 * d);
                        k * DVec3::new(p.x, p.y, 1.0)
                    }
                };
                let pixel = pixel / pixel.z;
                assert!((pixel.x - j as f64).abs() < 1e-12, "{projection:?} {pixel}");
                assert!((pixel.y - i as f64).abs() < 1e-12, "{projection:?} {pixel}");
            }
        }
    }
}
