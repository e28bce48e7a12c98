// Per-pixel ray generation (the lecture's viewing ray). Its CPU twin: `camera_ray` in src/kernel/frame.rs.
#import types

// The ray through the centre of pixel (i, j) of an nx x ny image: row i counts from the top,
// column j from the left. It reaches the image plane at t = 1.
fn camera_ray(frame: Frame, projection: u32, nx: u32, ny: u32, i: u32, j: u32) -> Ray {
    let us = frame.width * (real(j) + 0.5) / real(nx) - frame.width / 2.0;
    let vs = -(frame.height * (real(i) + 0.5) / real(ny) - frame.height / 2.0);
    var ray: Ray;
#if RAYS_FROM_ORIGIN
    // A perspective camera whose eye is the kernel's origin (frame.eye is +0; Variant's
    // rays_from_origin): the origin as a constant lets the compiler drop every `p - ray.origin`
    // of the tests (the same values: p - 0 is p) and keep no origin in registers
    // (docs/performance.md#specialization).
    ray.origin = vec3<real>(0.0);
    ray.direction = us * frame.u + vs * frame.v - frame.focal_length * frame.w;
#else
    if (projection == PROJECTION_ORTHOGRAPHIC) {
        ray.origin = frame.eye + us * frame.u + vs * frame.v;
        ray.direction = -frame.focal_length * frame.w;
    } else {
        ray.origin = frame.eye;
        ray.direction = us * frame.u + vs * frame.v - frame.focal_length * frame.w;
    }
#endif
    return ray;
}
