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

// The largest magnitude among v's components.
fn max_component(v: vec3<real>) -> real {
    let a = abs(v);
    return max(a.x, max(a.y, a.z));
}

// Conservative `t >= min_t`: a hit within its own error bound of the ray's start is no hit.
// T_TOLERANCE (16 EPS, from the precision module) bounds the relative error of a computed t
// where the ray is not grazing; a grazing ray's t is off by up to about 1 / cos EPS, which the
// certainty test accounts for (grazing_condition in shaders/triangle.wgsl).
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

// An instance as a traversal enters it (instance_at, shaders/bindings.wgsl): the rows of the
// map from the kernel's coordinates to its mesh's (a row [x, y, z, w] gives one mesh
// coordinate, x k.x + y k.y + z k.z + w), the node its mesh's tree starts at, and its object.
struct Instance {
    r0: vec4<real>,
    r1: vec4<real>,
    r2: vec4<real>,
    root: u32,
    object: u32,
}

// `ray` in `instance`'s mesh coordinates: its direction moved but not normalised, so that the
// point at t along it is the kernel ray's point at t, placed.
fn instance_ray(ray: Ray, instance: Instance) -> Ray {
    let o = ray.origin;
    let d = ray.direction;
    let origin = vec3<real>(row_point(instance.r0, o), row_point(instance.r1, o), row_point(instance.r2, o));
    let direction = vec3<real>(row_vector(instance.r0, d), row_vector(instance.r1, d), row_vector(instance.r2, d));
    return Ray(origin, direction);
}

fn row_point(r: vec4<real>, p: vec3<real>) -> real {
    return r.x * p.x + r.y * p.y + r.z * p.z + r.w;
}

fn row_vector(r: vec4<real>, v: vec3<real>) -> real {
    return r.x * v.x + r.y * v.y + r.z * v.z;
}

// Whether `instance`'s placement mirrors (its map's determinant is negative, as its inverse's is).
fn mirrors(instance: Instance) -> bool {
    return dot(instance.r0.xyz, cross(instance.r1.xyz, instance.r2.xyz)) < 0.0;
}

// A normal `n` in `instance`'s mesh coordinates as a direction in the kernel's, not
// normalised: by the transpose of the rows' map (the inverse transpose of the placement's).
fn instance_normal(n: vec3<real>, instance: Instance) -> vec3<real> {
    return instance.r0.xyz * n.x + instance.r1.xyz * n.y + instance.r2.xyz * n.z;
}

// A ray's frame for the watertight triangle test (triangle.wgsl), the same for every triangle,
// so computed once per ray: the axes permuted so that z is the direction's largest component,
// and the shear that takes the direction to +z.
struct Shear {
    kx: u32,
    ky: u32,
    kz: u32,
    sx: real,
    sy: real,
    sz: real,
}

fn shear_of(d: vec3<real>) -> Shear {
    let ad = abs(d);
    var kz = 2u;
    if (ad.x >= ad.y && ad.x >= ad.z) {
        kz = 0u;
    } else if (ad.y >= ad.z) {
        kz = 1u;
    }
    var kx = (kz + 1u) % 3u;
    var ky = (kx + 1u) % 3u;
    // Keep the winding (and so the sign convention) when the ray points down its main axis.
    if (d[kz] < 0.0) {
        let swap = kx;
        kx = ky;
        ky = swap;
    }
    return Shear(kx, ky, kz, d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]);
}

struct Sphere {
    center: vec3<real>,   // offset 0
    radius: real,         // offset 12 / 24
}                         // size 16 / 32

struct Plane {
    point: vec3<real>,    // offset 0
    object: id_word,      // offset 12 / 24: its object's id (plane_object), read with the plane
                          //   rather than by a load of its own from `objects`
    normal: vec3<real>,   // offset 16 / 32: unit length
    _pad1: real,          // offset 28 / 56
}                         // size 32 / 64

// The id of the object plane `plane` belongs to.
fn plane_object(plane: Plane) -> u32 {
#if F64
    return plane.object.x;
#else
    return plane.object;
#endif
}

struct Triangle {
    a: vec3<real>,
    b: vec3<real>,
    c: vec3<real>,
}

// A caller's ray as the ray list holds it (RAY_LIST), in kernel coordinates.
struct StoredRay {
    origin: vec3<real>,   // offset 0
    _pad0: real,          // offset 12 / 24
    direction: vec3<real>,// offset 16 / 32
    _pad1: real,          // offset 28 / 56
}                         // size 32 / 64

// A triangle as the buffers hold it: packed, without the padding of vec3, and one real of
// padding, so that it is five pairs of reals (bindings.wgsl).
struct StoredTriangle {
    a: array<real, 3>,    // offset 0
    b: array<real, 3>,    // offset 12 / 24
    c: array<real, 3>,    // offset 24 / 48
    _pad: real,           // offset 36 / 72
}                         // size 40 / 80
