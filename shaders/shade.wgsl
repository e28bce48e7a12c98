// The kernel's side of shade hooks (shaders/hooks.wgsl): a hit as the hook sees it, and the rays
// a hook casts (HOOK_RAYS: `trace` and `occluded`, compiled in only when the hook calls one).
// CPU mirror: src/cpu/shade.rs.
#import types
#import bindings
#import nearest
#import hooks

// The camera ray's pixel, (column, row), while its hook runs: what `trace` reports as `pixel`.
var<private> shading_pixel: vec2<u32>;

// The hook's view of a hit of `ray` (a camera ray, or one the hook cast), in world coordinates
// and f32 whatever the kernel's precision. `surface` holds the normal and distance (zero on a
// miss).
fn shade_hit(ray: Ray, hit: Hit, surface: vec4<real>) -> ShadeHit {
    var h: ShadeHit;
    h.id = select(hit.object, -1, hit.object < 0);
    h.direction = vec3<f32>(normalize(ray.direction));
    h.origin = vec3<f32>(params.origin + ray.origin * params.unit);
    h.pixel = shading_pixel;
    h.resolution = vec2<u32>(params.nx, params.ny);
    if (hit.object >= 0) {
        let along = hit.t * ray.direction;
        let world = params.origin + (ray.origin + along) * params.unit;
        h.position = vec3<f32>(world);
        h.normal = vec3<f32>(surface.xyz);
        h.distance = f32(surface.w);
        h.error = position_error(along, ray.origin, world, h.position);
    }
    return h;
}

// A bound on each coordinate's error in a hit's world position: t's relative error
// (T_TOLERANCE, the robust set's bound) and the rounding of t * direction, of its sum with the
// ray's origin `start` and of the world point `world` (kernel units scaled exactly), then
// `position`'s rounding to f32.
fn position_error(along: vec3<real>, start: vec3<real>, world: vec3<real>, position: vec3<f32>) -> vec3<f32> {
    let kernel = abs(along) * (T_TOLERANCE + 2.0 * EPS) + abs(start) * EPS;
    let f32_eps = 1.1920929e-7;
    return vec3<f32>(kernel * params.unit + abs(world) * EPS) + abs(position) * f32_eps;
}
#if HOOK_RAYS

// Rays the hooks of one invocation cast, added to hook_ray_count once its pixel is shaded.
var<private> hook_rays: u32;
// Every ray the hooks of a dispatch cast (`raycast bench` reports them as secondary rays).
@group(0) @binding(25) var<storage, read_write> hook_ray_count: atomic<u32>;

// A hook's ray in the kernel's coordinates: measured from params.origin and scaled by
// 1 / params.unit, a power of two, so that t means what it means to the hook (as
// Prepared::kernel_ray does for a caller's rays).
fn hook_ray(origin: vec3<f32>, direction: vec3<f32>) -> Ray {
    let scale = 1.0 / params.unit;
    return Ray((vec3<real>(origin) - params.origin) * scale, vec3<real>(direction) * scale);
}

// The nearest hit along origin + t direction, t >= t_min (shaders/hooks.wgsl).
fn trace(origin: vec3<f32>, direction: vec3<f32>, t_min: f32) -> ShadeHit {
    hook_rays += 1u;
    let ray = hook_ray(origin, direction);
    let hit = nearest_hit(ray, real(t_min));
    var surface = vec4<real>(0.0);
    if (hit.object >= 0) {
        // As the camera's rays (write_pixel in entry.wgsl): back to world units exactly.
        surface = vec4<real>(hit_normal(ray, hit), hit.t * length(ray.direction) * params.unit);
    }
    return shade_hit(ray, hit, surface);
}

// Whether anything is hit along origin + t direction with t_min <= t < t_max
// (shaders/hooks.wgsl). The search culls what lies beyond t_max (an infinite t_max is f32's
// largest).
fn occluded(origin: vec3<f32>, direction: vec3<f32>, t_min: f32, t_max: f32) -> bool {
    hook_rays += 1u;
    let far = min(real(t_max), T_FAR);
    let hit = nearest_hit_before(hook_ray(origin, direction), real(t_min), far);
    return hit.object >= 0 && hit.t < far;
}

// Adds the rays this invocation's hooks cast to hook_ray_count.
fn count_hook_rays() {
    if (hook_rays > 0u) {
        atomicAdd(&hook_ray_count, hook_rays);
        hook_rays = 0u;
    }
}
#endif
