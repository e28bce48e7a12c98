// Ambient occlusion: each hit is as bright as the share of a hemisphere of short rays around
// its normal that escape, so creases and contact points darken. AO_RAYS rays a hit, cosine-
// weighted about the normal, in directions that differ from pixel to pixel (a hash of it), so
// that their noise is fine-grained rather than banded. Misses are white.
//
//     raycast render scenes/ray-tracing/bunny.json --shader shaders/examples/ambient-occlusion.wgsl

// Rays a hit casts.
const AO_RAYS: u32 = 16u;
// How far a ray looks for what occludes it, in scene units.
const AO_RADIUS: f32 = 0.3;

fn shade(hit: ShadeHit) -> vec4<f32> {
    if (hit.id < 0) {
        return vec4<f32>(1.0);
    }
    // The normal facing the camera ray, so a plane or triangle seen from behind works too.
    let n = select(hit.normal, -hit.normal, dot(hit.normal, hit.direction) > 0.0);
    let frame = ao_basis(n);
    var seed = ao_hash(hit.pixel.x * 1973u + hit.pixel.y * 9277u);
    var open = 0u;
    for (var k = 0u; k < AO_RAYS; k++) {
        seed = ao_hash(seed);
        let u1 = f32(seed & 0xFFFFu) / 65536.0;
        let u2 = f32(seed >> 16u) / 65536.0;
        // Cosine-weighted: a uniform point on the unit disc lifted onto the hemisphere.
        let r = sqrt(u1);
        let phi = 6.2831853 * u2;
        let d = r * cos(phi) * frame[0] + r * sin(phi) * frame[1] + sqrt(max(0.0, 1.0 - u1)) * n;
        if (!occluded(leave(hit, d), d, 0.0, AO_RADIUS)) {
            open++;
        }
    }
    let ao = f32(open) / f32(AO_RAYS);
    return vec4<f32>(vec3<f32>(ao), 1.0);
}

// Two unit vectors that make a right-handed frame with unit `n` (Frisvad's construction,
// with the pole handled by a sign).
fn ao_basis(n: vec3<f32>) -> array<vec3<f32>, 2> {
    let s = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    return array<vec3<f32>, 2>(
        vec3<f32>(1.0 + s * n.x * n.x * a, s * b, -s * n.x),
        vec3<f32>(b, s + n.y * n.y * a, -n.y),
    );
}

// A 32-bit integer hash (lowbias32).
fn ao_hash(x: u32) -> u32 {
    var h = x;
    h ^= h >> 16u;
    h *= 0x7feb352du;
    h ^= h >> 15u;
    h *= 0x846ca68bu;
    h ^= h >> 16u;
    return h;
}
