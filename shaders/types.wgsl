// Shared types of the ray-casting kernel. `real` is f32 or f64: the host prepends
// `alias real = ...;` (the `precision` module) when it assembles the kernel.
// Keep in sync with src/gpu/layout.rs (a test checks sizes and offsets against naga's layout,
// in both precisions). Offsets below are f32 / f64.
#import precision

const PROJECTION_PERSPECTIVE: u32 = 0u;
const PROJECTION_ORTHOGRAPHIC: u32 = 1u;

// Returned by the intersect_* functions when the ray misses. Valid hits have t >= min_t >= 1,
// and WGSL may assume no infinities exist, so a negative sentinel stands for "no hit".
const NO_HIT: real = -1.0;

// The largest finite f32: the initial "nearest so far" distance.
const T_FAR: real = 3.40282347e+38;

// Conservative `t >= min_t`: a hit within its own error bound of the ray's start is no hit.
// T_TOLERANCE (16 EPS, from the precision module) bounds the relative error of a computed t.
fn is_beyond(t: real, min_t: real) -> bool {
    return t - T_TOLERANCE * abs(t) >= min_t;
}

struct Frame {
    eye: vec3<real>,      // offset 0 / 0
    focal_length: real,   // offset 12 / 24
    u: vec3<real>,        // offset 16 / 32: right
    width: real,          // offset 28 / 56: image-plane size in scene units
    v: vec3<real>,        // offset 32 / 64: up
    height: real,         // offset 44 / 88
    w: vec3<real>,        // offset 48 / 96: backward (the camera looks along -w)
    min_t: real,          // offset 60 / 120
}                         // size 64 / 128

struct Ray {
    origin: vec3<real>,
    direction: vec3<real>,
}

struct Sphere {
    center: vec3<real>,   // offset 0
    radius: real,         // offset 12 / 24
}                         // size 16 / 32

struct Plane {
    point: vec3<real>,    // offset 0
    _pad0: real,          // offset 12 / 24
    normal: vec3<real>,   // offset 16 / 32: unit length
    _pad1: real,          // offset 28 / 56
}                         // size 32 / 64

struct Triangle {
    a: vec3<real>,        // offset 0
    _pad0: real,          // offset 12 / 24
    b: vec3<real>,        // offset 16 / 32
    _pad1: real,          // offset 28 / 56
    c: vec3<real>,        // offset 32 / 64
    _pad2: real,          // offset 44 / 88
}                         // size 48 / 96

#if CERTAINTY
// The certainty test of adaptive precision (CPU mirror: src/cpu/margin.rs, with the same
// bounds). Each robust intersect_* function records here whether the decision it just made
// (hit or miss) is certain, where it hits or would hit, and the condition factor of that t.
var<private> decision_certain: bool;
var<private> decision_t: real;
var<private> decision_t_condition: real;

// Safety factor over the first-order error bounds.
const MARGIN_K: real = 2.0;

fn decide(certain: bool, t: real, t_condition: real) {
    decision_certain = certain;
    decision_t = t;
    decision_t_condition = t_condition;
}

// |q| exceeds MARGIN_K times its first-order error bound EPS * scale: its sign is certain.
fn is_certain(q: real, scale: real) -> bool {
    return abs(q) >= MARGIN_K * EPS * scale;
}

// The conservative start test decides as exact arithmetic would.
fn start_certain(t: real, min_t: real, t_condition: real) -> bool {
    return abs(t - min_t) >= EPS * (16.0 + 8.0 * MARGIN_K * t_condition) * abs(t);
}

// Two hits are certainly in this order.
fn gap_certain(t1: real, c1: real, t2: real, c2: real) -> bool {
    return abs(t2 - t1) >= EPS * (16.0 + 8.0 * MARGIN_K * max(c1, c2)) * (abs(t1) + abs(t2));
}
#endif
