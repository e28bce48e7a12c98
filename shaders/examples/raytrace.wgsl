// The course's ray tracer (its lit follow-up to ray casting) as a shade hook: ambient light,
// Blinn-Phong shading from point and directional lights with hard shadows, and mirror
// reflections, five at most. The model is exactly the course's (docs/shade-hooks.md); the scene
// file's `materials`, `lights` and per-object `material` supply its numbers. Its CPU mirror,
// line for line, is src/cpu/raytrace.rs (`raycast render --lit --device cpu`).
//
//     raycast render scenes/ray-tracing/sphere-and-plane.json --shader shaders/examples/raytrace.wgsl
//
// (`--lit` is the same hook.)

// Shadow and reflected rays count hits from this far along, as the course's do. They start
// off the surface by its error bound (`leave`, shaders/hooks.wgsl): in f32 a hit point is off
// the surface by more than 1e-6 / |t| allows for, and without it the sphere of sphere-and-plane
// shadows itself in speckles.
const RAYTRACE_EPSILON: f32 = 1e-6;
// Hits along one path: the camera ray's and five reflections.
const RAYTRACE_HITS: u32 = 6u;
// A directional light's shadow ray searches this far (all of f32).
const RAYTRACE_FAR: f32 = 3.40282347e+38;

fn shade(hit: ShadeHit) -> vec4<f32> {
    // The course's recursion unrolled: each hit's own light and mirror coefficient along the
    // path, then folded from the last hit back, colour_k = own_k + km_k * colour_(k+1), so that
    // the sums are evaluated in the recursion's order.
    var own: array<vec3<f32>, RAYTRACE_HITS>;
    var mirror: array<vec3<f32>, RAYTRACE_HITS>;
    var hits = 0u;
    var h = hit;
    loop {
        if (h.id < 0) {
            break;
        }
        let m = object_material(h.id);
        own[hits] = blinn_phong(h, m);
        mirror[hits] = m.km;
        hits++;
        // A material without a mirror term reflects nothing: no ray to cast.
        if (hits == RAYTRACE_HITS || all(m.km == vec3<f32>(0.0))) {
            break;
        }
        let r = reflect_unit(h.direction, h.normal);
        h = trace(leave(h, r), r, RAYTRACE_EPSILON);
    }
    var colour = vec3<f32>(0.0);
    for (var k = hits; k > 0u; k--) {
        colour = own[k - 1u] + mirror[k - 1u] * colour;
    }
    // 255 * clamp(colour, 0, 1) truncated toward zero, as the course writes its pixels.
    return vec4<f32>(floor(255.0 * clamp(colour, vec3<f32>(0.0), vec3<f32>(1.0))) / 255.0, 1.0);
}

// The mirror direction of unit direction `d` about normal `n`: d - 2 (d.n) n.
fn reflect_unit(d: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    return d - 2.0 * dot(d, n) * n;
}

// Ambient plus, for each light not shadowed, diffuse and specular.
fn blinn_phong(h: ShadeHit, m: Material) -> vec3<f32> {
    var colour = 0.1 * m.ka;
    let v = -h.direction;
    for (var k = 0u; k < light_count(); k++) {
        let light = scene_light(k);
        // Unit direction from the hit towards the light, and how far along it the light is.
        var l: vec3<f32>;
        var max_t = RAYTRACE_FAR;
        if (light.kind == LIGHT_POINT) {
            let to_light = light.position - h.position;
            max_t = length(to_light);
            l = to_light / max_t;
        } else {
            l = -light.direction / length(light.direction);
        }
        if (occluded(leave(h, l), l, RAYTRACE_EPSILON, max_t)) {
            continue;
        }
        let half_way = normalize(v + l);
        colour += m.kd * light.color * max(0.0, dot(h.normal, l))
            + m.ks * light.color * pow(max(0.0, dot(h.normal, half_way)), m.phong_exponent);
    }
    return colour;
}
