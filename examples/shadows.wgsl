// A shade hook that lights each hit by the scene's lights and casts a shadow ray to each:
// examples/shadows.rs renders it. Misses are a flat sky.
fn shade(hit: ShadeHit) -> vec4<f32> {
    if (hit.id < 0) {
        return vec4<f32>(0.6, 0.7, 0.9, 1.0);
    }
    // The normal facing the camera, so planes and triangles seen from behind are lit too.
    let n = select(hit.normal, -hit.normal, dot(hit.normal, hit.direction) > 0.0);
    var light = vec3<f32>(0.1);
    for (var k = 0u; k < light_count(); k++) {
        let l = scene_light(k);
        // A point light's direction and distance, or a directional light's, infinitely far.
        let to_light = select(-l.direction, l.position - hit.position, l.kind == LIGHT_POINT);
        let far = select(1e30, 1.0, l.kind == LIGHT_POINT);
        let cosine = dot(n, normalize(to_light));
        if (cosine > 0.0 && !occluded(leave(hit, to_light), to_light, 0.0, far)) {
            light += cosine * l.color;
        }
    }
    return vec4<f32>(min(light, vec3<f32>(1.0)), 1.0);
}
