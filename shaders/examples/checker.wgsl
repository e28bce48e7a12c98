// World-space checkerboard: space is cut into cubes of CHECKER_SIZE, coloured alternately,
// and each hit takes the colour of the cube it lies in. The pattern is fixed in the scene
// (hit.position is in world coordinates), whatever the camera does. Misses are dark blue.
//
//     raycast render scenes/course/two-spheres-and-plane.json --shader shaders/examples/checker.wgsl

const CHECKER_SIZE = 0.5;

fn shade(hit: ShadeHit) -> vec4<f32> {
    if (hit.id < 0) {
        return vec4<f32>(0.05, 0.07, 0.20, 1.0);
    }
    // A step into the surface first, so that a surface lying on a cube face (the plane y = -1)
    // does not flicker between the two cubes with the rounding of each hit.
    let cell = floor((hit.position - 1e-3 * hit.normal) / CHECKER_SIZE);
    let odd = (i32(cell.x) + i32(cell.y) + i32(cell.z)) % 2 != 0;
    let colour = select(vec3<f32>(0.92, 0.92, 0.88), vec3<f32>(0.80, 0.20, 0.25), odd);
    // Headlight: lit from the eye, darker where the surface turns away.
    let light = 0.35 + 0.65 * abs(dot(hit.normal, hit.direction));
    return vec4<f32>(colour * light, 1.0);
}
