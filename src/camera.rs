//! The camera frame, built on the host in f64 from the scene's camera (the lecture's formulas).
//!
//! Ray generation from the frame runs per pixel in `shaders/camera.wgsl` and its CPU mirror
//! `src/cpu/camera.rs`; this module only builds the orthonormal basis once.

use crate::math::{Real, Vec3, cross, length, normalize};
use crate::scene::{Camera, Projection};

/// Hits closer than this ray parameter are ignored: `t = 1` is the image plane, so only objects
/// in front of it count (the course's `min_t`).
pub const MIN_T: f64 = 1.0;

/// An orthonormal camera frame and the image-plane geometry, in precision `T`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame<T> {
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

impl Frame<f64> {
    /// `w = -look/|look|`, `u = normalize(look x up)`, `v = w x u`; `[nx, ny]` pixels.
    ///
    /// `up` need not be perpendicular to `look`: `v` is rebuilt from `w` and `u`.
    pub fn new(camera: &Camera, resolution: [u32; 2]) -> Frame<f64> {
        let w = -(camera.look / length(camera.look));
        let u = normalize(cross(camera.look, camera.up));
        let v = cross(w, u);
        Frame {
            projection: camera.projection,
            eye: camera.eye,
            u,
            v,
            w,
            focal_length: camera.focal_length,
            width: camera.width,
            height: camera.height,
            nx: resolution[0],
            ny: resolution[1],
            min_t: MIN_T,
        }
    }
}

impl<T: Real> Frame<T> {
    /// The same frame rounded to precision `U` (what the GPU receives when `U = f32`).
    pub fn cast<U: Real>(&self) -> Frame<U> {
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
    use crate::math::{dot, vec3};

    fn camera(look: [f64; 3], up: [f64; 3]) -> Camera {
        Camera {
            projection: Projection::Perspective,
            eye: vec3(0.0, 0.0, 5.0),
            look: Vec3::from_array(look),
            up: Vec3::from_array(up),
            focal_length: 3.0,
            width: 1.6,
            height: 0.9,
            resolution: [16, 9],
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
}
