// Depth fog: each object in a colour of its own, lit by one distant light, fading
// exponentially into the sky colour with distance. Misses are the sky.
//
//     raycast render scenes/course/two-spheres-and-plane.json --shader shaders/examples/fog.wgsl

const FOG_SKY = vec3<f32>(0.72, 0.82, 0.95);
// Fraction of light lost per scene unit: half of it after ln(2) / 0.08 = 8.7 units.
const FOG_DENSITY = 0.08;

// A few distinct colours, by object id.
fn object_colour(id: i32) -> vec3<f32> {
    let colours = array<vec3<f32>, 4>(
        vec3<f32>(0.85, 0.25, 0.20),
        vec3<f32>(0.20, 0.45, 0.80),
        vec3<f32>(0.35, 0.70, 0.30),
        vec3<f32>(0.90, 0.65, 0.15),
    );
    return colours[u32(id) % 4u];
}

fn shade(hit: ShadeHit) -> vec4<f32> {
    if (hit.id < 0) {
        return vec4<f32>(FOG_SKY, 1.0);
    }
    let light = normalize(vec3<f32>(0.4, 1.0, 0.6));
    let lit = object_colour(hit.id) * (0.3 + 0.7 * max(dot(hit.normal, light), 0.0));
    // Beer-Lambert: the share of the surface's light that reaches the eye.
    let through = exp(-FOG_DENSITY * hit.distance);
    return vec4<f32>(mix(FOG_SKY, lit, through), 1.0);
}
