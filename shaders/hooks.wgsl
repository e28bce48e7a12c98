// User shade hooks (`raycast render --shader FILE`). The user's file defines
//
//     fn shade(hit: ShadeHit) -> vec4<f32>
//
// and the kernel calls it once for every pixel, hits and misses alike (so the hook colours the
// background too); the result, clamped to [0, 1], is the pixel's RGBA in color.png.
//
// What a hook may use besides its argument, all in world coordinates and f32 whatever the
// kernel's precision:
//   - the scene's materials, lights and per-object values: object_material, object_values,
//     light_count, scene_light (below);
//   - more rays (docs/shade-hooks.md), any number of them, in loops (WGSL has no recursion):
//         fn trace(origin: vec3<f32>, direction: vec3<f32>, t_min: f32) -> ShadeHit
//     the nearest hit along origin + t direction with t >= t_min, through the same search and
//     intersection tests as the camera's rays (id -1 on a miss); and
//         fn occluded(origin: vec3<f32>, direction: vec3<f32>, t_min: f32, t_max: f32) -> bool
//     whether anything is hit with t_min <= t < t_max (shadow rays). t counts in units of
//     `direction`'s length. They are compiled into the kernel only when the hook calls them.
//     Cast a ray leaving a surface from `leave(hit, direction)` (below), not from
//     `hit.position`, which rounding may put on the surface's far side.
//
// This file is also the prelude the user's file is checked with on its own (appended after the
// user's text, so naga's line:column are the user's): keep it free of #import and #if, and in
// f32 whatever the kernel's precision. Keep the structs in sync with src/gpu/layout.rs.
struct ShadeHit {
    // Hit point in world coordinates; 0 on a miss.
    position: vec3<f32>,
    // Unit surface normal (outward for spheres, as given for planes, by corner order for
    // triangles); 0 on a miss.
    normal: vec3<f32>,
    // Distance from the ray origin to the hit in scene units; 0 on a miss.
    distance: f32,
    // Object id (index in the scene's objects); -1 on a miss.
    id: i32,
    // Unit ray direction.
    direction: vec3<f32>,
    // Ray origin in world coordinates: the eye (perspective) or the pixel's point in the eye's
    // plane (orthographic); for `trace`, the origin it was given.
    origin: vec3<f32>,
    // Pixel column and row (row 0 at the top) of the camera ray being shaded.
    pixel: vec2<u32>,
    // Image width and height in pixels.
    resolution: vec2<u32>,
    // A bound on each coordinate's error in `position` (the kernel's t and sums, then the
    // rounding to f32); 0 on a miss. `leave` moves a ray's origin off the surface by it.
    error: vec3<f32>,
}

// A point to cast a ray in `direction` from, leaving the surface of `hit`: `hit.position` moved
// off the surface along the normal, to the side `direction` goes, by the bound on its error
// (doubled, for the rounding of this sum), so that rounding alone cannot make the ray find the
// surface it leaves (shadow acne). Then any t_min > 0 will do (as pbrt offsets ray origins).
fn leave(hit: ShadeHit, direction: vec3<f32>) -> vec3<f32> {
    let off = 2.0 * dot(abs(hit.normal), hit.error);
    return hit.position + select(off, -off, dot(direction, hit.normal) < 0.0) * hit.normal;
}

// A material of the scene file's `materials` (the course's ray tracer: Blinn-Phong with a
// mirror term), the one an object names by `material`.
struct Material {
    ka: vec3<f32>,            // offset 0: ambient, RGB
    phong_exponent: f32,      // offset 12
    kd: vec3<f32>,            // offset 16: diffuse
    ks: vec3<f32>,            // offset 32: specular
    km: vec3<f32>,            // offset 48: mirror
}                             // size 64

const LIGHT_DIRECTIONAL: u32 = 0u;
const LIGHT_POINT: u32 = 1u;

// A light of the scene file's `lights`.
struct Light {
    position: vec3<f32>,      // offset 0: a point light's position (0 for a directional one)
    kind: u32,                // offset 12: LIGHT_DIRECTIONAL or LIGHT_POINT
    direction: vec3<f32>,     // offset 16: the direction a directional light travels, as given
                              //   (not normalised; 0 for a point light)
    color: vec3<f32>,         // offset 32: RGB intensity
}                             // size 48

// Per object: the index of its material (-1: none) and its own `values`.
struct HookObject {
    values: vec4<f32>,        // offset 0
    material: i32,            // offset 16
}                             // size 32

struct HookLights {
    count: u32,               // offset 0
    lights: array<Light>,     // offset 16 (at least one entry: a buffer is never empty)
}

@group(0) @binding(22) var<storage, read> hook_materials: array<Material>;
@group(0) @binding(23) var<storage, read> hook_lights: HookLights;
@group(0) @binding(24) var<storage, read> hook_objects: array<HookObject>;

// The material object `id` names in the scene file; all zero where it names none (and for a
// miss, id -1).
fn object_material(id: i32) -> Material {
    if (id < 0 || u32(id) >= arrayLength(&hook_objects)) {
        return Material();
    }
    let m = hook_objects[id].material;
    if (m < 0) {
        return Material();
    }
    return hook_materials[m];
}

// The `values` object `id` gives in the scene file (up to four numbers, the rest 0); all zero
// where it gives none (and for a miss).
fn object_values(id: i32) -> vec4<f32> {
    if (id < 0 || u32(id) >= arrayLength(&hook_objects)) {
        return vec4<f32>(0.0);
    }
    return hook_objects[id].values;
}

// How many lights the scene has.
fn light_count() -> u32 {
    return hook_lights.count;
}

// Light k (0 to light_count() - 1) in the scene file's order.
fn scene_light(k: u32) -> Light {
    return hook_lights.lights[k];
}
