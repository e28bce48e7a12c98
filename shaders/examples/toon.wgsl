// Toon shading from normals: the diffuse light quantised into three flat bands, and a hard
// white highlight where the normal is close to the half vector between light and eye.
// Misses are white paper.
//
//     raycast render scenes/course/two-spheres-and-plane.json --shader shaders/examples/toon.wgsl

const TOON_LIGHT = vec3<f32>(-0.5, 1.0, 0.8);

fn toon_colour(id: i32) -> vec3<f32> {
    let colours = array<vec3<f32>, 3>(
        vec3<f32>(0.95, 0.55, 0.20),
        vec3<f32>(0.30, 0.55, 0.90),
        vec3<f32>(0.55, 0.80, 0.45),
    );
    return colours[u32(id) % 3u];
}

fn shade(hit: ShadeHit) -> vec4<f32> {
    if (hit.id < 0) {
        return vec4<f32>(1.0, 1.0, 1.0, 1.0);
    }
    let light = normalize(TOON_LIGHT);
    let half_vector = normalize(light - hit.direction);
    if (dot(hit.normal, half_vector) > 0.985) {
        return vec4<f32>(1.0, 1.0, 1.0, 1.0);
    }
    let d = max(dot(hit.normal, light), 0.0);
    // Three bands: lit, half-lit, shadow.
    let band = select(select(0.35, 0.65, d > 0.25), 1.0, d > 0.75);
    return vec4<f32>(toon_colour(hit.id) * band, 1.0);
}
