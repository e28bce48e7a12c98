// Shared types of the ray-casting kernel.
// Keep in sync with src/gpu/layout.rs (a test checks sizes and offsets against naga's layout).

const PROJECTION_PERSPECTIVE: u32 = 0u;
const PROJECTION_ORTHOGRAPHIC: u32 = 1u;

// Returned by the intersect_* functions when the ray misses. Valid hits have t >= min_t >= 1,
// and WGSL may assume no infinities exist, so a negative sentinel stands for "no hit".
const NO_HIT: f32 = -1.0;

// The largest finite f32: the initial "nearest so far" distance.
const T_FAR: f32 = 3.40282347e+38;

struct Frame {
    eye: vec3<f32>,       // offset 0
    projection: u32,      // offset 12
    u: vec3<f32>,         // offset 16
    nx: u32,              // offset 28
    v: vec3<f32>,         // offset 32
    ny: u32,              // offset 44
    w: vec3<f32>,         // offset 48
    focal_length: f32,    // offset 60
    width: f32,           // offset 64
    height: f32,          // offset 68
    min_t: f32,           // offset 72
    _pad: u32,            // offset 76
}                         // size 80

struct Ray {
    origin: vec3<f32>,
    direction: vec3<f32>,
}

struct Sphere {
    center: vec3<f32>,    // offset 0
    radius: f32,          // offset 12
    object: u32,          // offset 16
    _pad0: u32,           // offset 20
    _pad1: u32,           // offset 24
    _pad2: u32,           // offset 28
}                         // size 32

struct Plane {
    point: vec3<f32>,     // offset 0
    object: u32,          // offset 12
    normal: vec3<f32>,    // offset 16
    _pad: u32,            // offset 28
}                         // size 32

struct Triangle {
    a: vec3<f32>,         // offset 0
    object: u32,          // offset 12
    b: vec3<f32>,         // offset 16
    _pad0: u32,           // offset 28
    c: vec3<f32>,         // offset 32
    _pad1: u32,           // offset 44
}                         // size 48
