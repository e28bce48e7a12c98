// User shade hooks (`raycast render --shader FILE`). The user's file defines
//
//     fn shade(hit: ShadeHit) -> vec4<f32>
//
// and the kernel calls it once for every pixel, hits and misses alike (so the hook colours the
// background too); the result, clamped to [0, 1], is the pixel's RGBA in color.png.
// This file is also the prelude the user's file is checked with on its own (appended after the
// user's text, so naga's line:column are the user's): keep it free of #import and #if, and in
// f32 whatever the kernel's precision.
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
    // plane (orthographic).
    origin: vec3<f32>,
    // Pixel column and row (row 0 at the top).
    pixel: vec2<u32>,
    // Image width and height in pixels.
    resolution: vec2<u32>,
}
