//! Mirror of shaders/examples/raytrace.wgsl, line for line: the course's ray tracer as a shade
//! hook (ambient, Blinn-Phong from point and directional lights with hard shadows, mirror
//! reflections to five bounces), written against `super::shade`. In f64 it is the model's
//! truth, which reproduces the instructor's render of sphere-and-plane byte for byte.

use super::shade::{LIGHT_POINT, Material, ShadeHit, Shading, leave};
use crate::math::{Real, Vec3, dot, length, normalize};

/// `RAYTRACE_EPSILON`.
const RAYTRACE_EPSILON: f64 = 1e-6;
/// `RAYTRACE_HITS`.
const RAYTRACE_HITS: usize = 6;
/// `RAYTRACE_FAR`: f32's largest.
const RAYTRACE_FAR: f64 = f32::MAX as f64;

/// `shade`.
pub(crate) fn shade<T: Real, const ROBUST: bool>(
    s: &mut Shading<'_, T, ROBUST>,
    hit: ShadeHit<T>,
) -> [T; 4] {
    let zero = Vec3::splat(T::ZERO);
    let mut own = [zero; RAYTRACE_HITS];
    let mut mirror = [zero; RAYTRACE_HITS];
    let mut hits = 0;
    let mut h = hit;
    loop {
        if h.id < 0 {
            break;
        }
        let m = s.object_material(h.id);
        own[hits] = blinn_phong(s, &h, &m);
        mirror[hits] = m.km;
        hits += 1;
        if hits == RAYTRACE_HITS || m.km == zero {
            break;
        }
        let r = reflect_unit(h.direction, h.normal);
        h = s.trace(leave(&h, r), r, T::from_f64(RAYTRACE_EPSILON));
    }
    let mut colour = zero;
    for k in (1..=hits).rev() {
        colour = own[k - 1] + mirror[k - 1].times(colour);
    }
    let level =
        |c: T| (T::from_f64(255.0) * c.max(T::ZERO).min(T::ONE)).floor() / T::from_f64(255.0);
    [level(colour.x), level(colour.y), level(colour.z), T::ONE]
}

/// `reflect_unit`: d - 2 (d.n) n.
fn reflect_unit<T: Real>(d: Vec3<T>, n: Vec3<T>) -> Vec3<T> {
    d - n * (T::TWO * dot(d, n))
}

/// `blinn_phong`.
fn blinn_phong<T: Real, const ROBUST: bool>(
    s: &mut Shading<'_, T, ROBUST>,
    h: &ShadeHit<T>,
    m: &Material<T>,
) -> Vec3<T> {
    let mut colour = m.ka * T::from_f64(0.1);
    let v = -h.direction;
    for k in 0..s.light_count() {
        let light = s.scene_light(k);
        let l;
        let mut max_t = T::from_f64(RAYTRACE_FAR);
        if light.kind == LIGHT_POINT {
            let to_light = light.position - h.position;
            max_t = length(to_light);
            l = to_light / max_t;
        } else {
            l = -light.direction / length(light.direction);
        }
        if s.occluded(leave(h, l), l, T::from_f64(RAYTRACE_EPSILON), max_t) {
            continue;
        }
        let half_way = normalize(v + l);
        colour = colour
            + (m.kd.times(light.color) * dot(h.normal, l).max(T::ZERO)
                + m.ks.times(light.color)
                    * dot(h.normal, half_way).max(T::ZERO).powf(m.phong_exponent));
    }
    colour
}

/// The colours of every pixel of a prepared scene shaded by [`shade`] (`color.png`, as
/// `pack4x8unorm` stores the GPU's), and the rays the hook cast beyond the camera's.
pub(crate) fn render<T: Real>(prepared: &crate::prepare::Prepared<T>) -> (Vec<[u8; 4]>, u64) {
    use rayon::prelude::*;
    let robust = prepared.algorithm == crate::algorithm::Algorithm::Robust;
    let scene = super::shade::HookScene::new(&prepared.lighting, prepared.objects);
    let [nx, ny] = prepared.resolution();
    let pixels: Vec<([u8; 4], u64)> = (0..nx as usize * ny as usize)
        .into_par_iter()
        .map(|k| {
            let pixel = [k as u32 % nx, k as u32 / nx];
            match robust {
                true => shade_pixel(&mut Shading::<T, true>::new(prepared, &scene, pixel)),
                false => shade_pixel(&mut Shading::<T, false>::new(prepared, &scene, pixel)),
            }
        })
        .collect();
    let rays = pixels.iter().map(|(_, r)| r).sum();
    (pixels.into_iter().map(|(c, _)| c).collect(), rays)
}

/// One pixel's colour and the rays its hook cast.
fn shade_pixel<T: Real, const ROBUST: bool>(s: &mut Shading<'_, T, ROBUST>) -> ([u8; 4], u64) {
    let hit = s.camera_hit();
    let colour = shade(s, hit);
    (super::shade::pack_unorm(colour), s.rays)
}
