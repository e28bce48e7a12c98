// Per-pixel ray generation (the lecture's viewing ray). CPU mirror: src/cpu/camera.rs.
#import types

// Row i counts from the top, column j from the left; the ray passes through the pixel centre
// and reaches the image plane at t = 1.
fn camera_ray(frame: Frame, i: u32, j: u32) -> Ray {
    let us = frame.width * (f32(j) + 0.5) / f32(frame.nx) - frame.width / 2.0;
    let vs = -(frame.height * (f32(i) + 0.5) / f32(frame.ny) - frame.height / 2.0);
    var ray: Ray;
    if (frame.projection == PROJECTION_ORTHOGRAPHIC) {
        ray.origin = frame.eye + us * frame.u + vs * frame.v;
        ray.direction = -frame.focal_length * frame.w;
    } else {
        ray.origin = frame.eye;
        ray.direction = us * frame.u + vs * frame.v - frame.focal_length * frame.w;
    }
    return ray;
}
