//! Decision margins: how far a pixel's f64 decisions lie from the point where a lower-precision
//! robust kernel could decide otherwise.
//!
//! For every decision the robust nearest-hit search makes for a pixel, the quantity it tests
//! (a discriminant, an edge function, `d.n`, `t - min_t`, the gap between two hits) is divided
//! by a bound on that quantity's error in the kernel's precision: `K * eps * S`, where
//! `eps * S` is the first-order error bound (the running error bound of its sums of products,
//! with the rounding of the inputs to the kernel's precision) and `K = 2` a safety factor for
//! the neglected higher-order terms. A ratio of at least 1 means the kernel must decide as
//! exact arithmetic does.
//!
//! Scales used (all in the robust set's camera-relative coordinates, ray `o + t d`):
//! - sphere hit/miss: `r^2 - |l|^2`, `S = r^2 + 2 |l|^2 + 24 |l| |f| + 128 eps |f|^2` (`f = o - c`, `l` the
//!   perpendicular from the centre to the ray line). `l = f - (b/a) d` cancels from `|f|`
//!   down to `|l|`, so its error is absolute, about `7 eps |f|` (the dot products, the
//!   division, the subtraction), plus `eps |f|` from rounding the centre and `2.6 eps |f|` from
//!   the direction's rounding: `|l|^2` is off by about `2 |l| * 11 eps |f|`, plus that error's
//!   square `121 eps^2 |f|^2`, which dominates where `|l|` is smaller than the error (a sphere
//!   smaller than an ulp of its distance);
//! - plane hit/miss: `d.n` against the parallel cutoff `4 eps |d|`, `S = 4 |d|` (the dot
//!   product's `3 eps |d|` and the rounding of `n` and `d`);
//! - triangle edge `e = x1 y2 - y1 x2` in the sheared frame: `S = 2 ((|x1|+|z1|)(|y2|+|z2|) +
//!   (|y1|+|z1|)(|x2|+|z2|))` (vertex rounding, the shear `x - s z`, products and their
//!   difference each add about `eps` times those magnitudes); a miss is certain when one edge
//!   is certainly on the outside, a hit when all three are certainly inside;
//! - `t >= min_t` and the order of two hits: `|t - min_t|` and `|t1 - t2|` against
//!   `eps (16 + 8 K cond) t` per t involved (16 eps is the conservative start test's own
//!   allowance; a computed t is good to about 8 eps times a condition factor): `cond` is
//!   `1 + |f|^2 / |c|` for sphere roots, whose `c = |f|^2 - r^2` cancels when the eye is near
//!   the surface, `1 + |d| / |d.n|` for planes seen at a grazing angle, 1 for triangles.
//!
//! These first-order bounds hold only while the kernel's arithmetic stays in f32's normal
//! range (`shaders/certainty.wgsl` makes the same assumptions and the same checks). Every
//! bound adds `UNDERFLOW_SLACK`, what flushing the results below that range to zero can lose;
//! a decision whose intermediates would overflow f32 (`fits_f32`), or a ray direction whose
//! inverse would, has margin 0; and so does a sphere seen along a direction whose squared
//! length underflows. Margins are judged in kernel units (`Prepared`): the host's rescale
//! decides which magnitudes the kernel meets.

use crate::kernel::frame::camera_ray;
use crate::kernel::types::{Frame, Ray};
use crate::math::{Vec3, dot, length};
use crate::prepare::Primitives;

/// Safety factor `K` over the first-order error bounds.
pub(crate) const K: f64 = 2.0;

/// Margins of one pixel ([`crate::Cpu::certain_in_f32`]): each at least 1 means that decision
/// is certain in the kernel's precision.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Margins {
    /// Whether the pixel hits anything.
    pub hit: f64,
    /// Which object is nearest (infinite for a pixel that certainly misses).
    pub id: f64,
}

impl Margins {
    /// Whether both decisions are certain: an f32 render must make them as exact arithmetic
    /// does.
    pub(crate) fn certain(&self) -> bool {
        self.hit >= 1.0 && self.id >= 1.0
    }
}

/// One primitive's verdict on a ray.
struct Candidate {
    /// Exact-arithmetic (f64) decision.
    hits: bool,
    /// Margin of that decision (>= 1: certain).
    margin: f64,
    /// Where it hits, or where it would hit if the decision flipped.
    t: f64,
    /// Relative error bound factor of `t` (times eps).
    t_condition: f64,
    object: u32,
}

/// 2^-120: what the kernel's operations behind one tested quantity can lose to results below
/// f32's normal range being flushed to zero (`UNDERFLOW_SLACK` in shaders/certainty.wgsl).
const UNDERFLOW_SLACK: f64 = 7.52316384526264e-37;

/// The smallest non-zero direction component whose inverse the kernel's box test can form
/// (`SMALLEST_INVERTIBLE` in shaders/certainty.wgsl).
const SMALLEST_INVERTIBLE: f64 = 7.52316384526264e-37;

/// Whether every magnitude in `values` stays within f32's range, with room for the sums and
/// roundings that follow.
fn fits_f32(values: &[f64]) -> bool {
    values.iter().all(|x| x.abs() <= f32::MAX as f64 / 16.0)
}

fn bound(eps: f64, scale: f64) -> f64 {
    K * (eps * scale + UNDERFLOW_SLACK)
}

/// Margin of `t >= min_t` for a t with relative error `eps * t_condition`.
fn start_margin(t: f64, min_t: f64, eps: f64, t_condition: f64) -> f64 {
    (t - min_t).abs() / (eps * (16.0 + 8.0 * K * t_condition) * t.abs() + UNDERFLOW_SLACK)
}

/// The verdict on a primitive whose arithmetic leaves f32's range: uncertain, and placed at
/// t = 0, nearer than any hit, as the kernel does with a t it cannot trust.
fn out_of_range(hits: bool) -> Candidate {
    Candidate {
        hits,
        margin: 0.0,
        t: if hits { f64::MIN_POSITIVE } else { 0.0 },
        t_condition: 1.0,
        object: 0,
    }
}

/// The verdict on a surface the ray meets at `t`: a hit if `t` is beyond the start, certain when
/// both the start test and the surface's own test (`surface_margin`) are; a miss certain when
/// the start test is.
fn started(t: f64, min_t: f64, eps: f64, t_condition: f64, surface_margin: f64) -> Candidate {
    let margin_t = start_margin(t, min_t, eps, t_condition);
    let hits = t >= min_t;
    let margin = if hits {
        surface_margin.min(margin_t)
    } else {
        margin_t
    };
    Candidate {
        hits,
        margin,
        t,
        t_condition,
        object: 0,
    }
}

fn sphere(ray: &Ray<f64>, center: Vec3<f64>, radius: f64, min_t: f64, eps: f64) -> Candidate {
    let f = ray.origin - center;
    let d = ray.direction;
    let a = dot(d, d);
    let b = dot(f, d);
    let l = f - d * (b / a);
    let r2 = radius * radius;
    let l2 = dot(l, l);
    let ff = dot(f, f);
    let scale = r2 + 2.0 * l2 + 24.0 * l2.sqrt() * ff.sqrt() + 128.0 * eps * ff;
    let margin_disc = (r2 - l2).abs() / bound(eps, scale);
    let c = ff - r2;
    let half = ((r2 - l2).max(0.0) / a).sqrt();
    let (near, far) = (-b / a - half, -b / a + half);
    let in_range = a >= f32::MIN_POSITIVE as f64 && fits_f32(&[b, ff, r2, scale, near, far]);
    if !in_range {
        return out_of_range(r2 >= l2 && far >= min_t);
    }
    // Of the roots q/a and c/q, the smaller in magnitude is c/q, whose c = |f|^2 - r^2
    // cancels when the eye is near the surface.
    let c_condition = 1.0 + ff / c.abs().max(f64::MIN_POSITIVE);
    if r2 < l2 {
        let t = -b / a;
        return Candidate {
            hits: false,
            margin: margin_disc,
            t,
            t_condition: 1.0,
            object: 0,
        };
    }
    let condition = |t: f64, other: f64| {
        if t.abs() <= other.abs() {
            c_condition
        } else {
            1.0
        }
    };
    // The kernel takes the near root if beyond min_t, else the far one: either way the same
    // object, so the hit is certain when the discriminant and the far root's start test are.
    let far_margin = start_margin(far, min_t, eps, condition(far, near));
    let hits = far >= min_t;
    let t = if near >= min_t { near } else { far };
    let t_condition = condition(t, if near >= min_t { far } else { near });
    let margin = if hits {
        margin_disc.min(far_margin)
    } else {
        far_margin
    };
    Candidate {
        hits,
        margin,
        t,
        t_condition,
        object: 0,
    }
}

fn plane(ray: &Ray<f64>, point: Vec3<f64>, normal: Vec3<f64>, min_t: f64, eps: f64) -> Candidate {
    let d = ray.direction;
    let denominator = dot(d, normal);
    let cutoff = 4.0 * eps * length(d);
    let margin_parallel = (denominator.abs() - cutoff).abs() / bound(eps, length(d));
    let t = dot(point - ray.origin, normal) / denominator;
    if dot(d, d) < f32::MIN_POSITIVE as f64 || (denominator.abs() > cutoff && !fits_f32(&[t])) {
        return out_of_range(denominator != 0.0 && t >= min_t);
    }
    let t_condition = 1.0 + length(d) / denominator.abs().max(f64::MIN_POSITIVE);
    if denominator.abs() <= cutoff || !t.is_finite() {
        return Candidate {
            hits: false,
            margin: margin_parallel,
            t: f64::INFINITY,
            t_condition,
            object: 0,
        };
    }
    started(t, min_t, eps, t_condition, margin_parallel)
}

fn triangle(ray: &Ray<f64>, corners: [Vec3<f64>; 3], min_t: f64, eps: f64) -> Candidate {
    // Two equal corners stay equal after any rounding: the kernel's edge functions then sum to
    // exactly zero and it always misses.
    let [a, b, c] = corners;
    if a == b || b == c || c == a {
        let (margin, t, t_condition) = (f64::INFINITY, f64::INFINITY, 1.0);
        return Candidate {
            hits: false,
            margin,
            t,
            t_condition,
            object: 0,
        };
    }
    let d = ray.direction;
    let ad = d.abs();
    let kz = if ad.x >= ad.y && ad.x >= ad.z {
        0
    } else if ad.y >= ad.z {
        1
    } else {
        2
    };
    let (mut kx, mut ky) = ((kz + 1) % 3, (kz + 2) % 3);
    if d.get(kz) < 0.0 {
        std::mem::swap(&mut kx, &mut ky);
    }
    let (sx, sy, sz) = (
        d.get(kx) / d.get(kz),
        d.get(ky) / d.get(kz),
        1.0 / d.get(kz),
    );
    let p = corners.map(|c| c - ray.origin);
    let x = p.map(|q| q.get(kx) - sx * q.get(kz));
    let y = p.map(|q| q.get(ky) - sy * q.get(kz));
    let z = p.map(|q| q.get(kz));
    // Edge opposite corner k runs from corner k+1 to corner k+2: (value, margin). An edge
    // whose error scale overflows f32 is uncertain.
    let edge = |k: usize| {
        let (i, j) = ((k + 2) % 3, (k + 1) % 3);
        let e = x[i] * y[j] - y[i] * x[j];
        let scale = 2.0
            * ((x[i].abs() + z[i].abs()) * (y[j].abs() + z[j].abs())
                + (y[i].abs() + z[i].abs()) * (x[j].abs() + z[j].abs()));
        let margin = if fits_f32(&[scale]) {
            e.abs() / bound(eps, scale)
        } else {
            0.0
        };
        (e, margin)
    };
    let edges = [edge(0), edge(1), edge(2)];
    let determinant: f64 = edges.iter().map(|(e, _)| e).sum();
    // The kernel's t: each edge times its corner's sz * z, summed, over the determinant. Where
    // that overflows f32, the kernel knows nothing of where the triangle is hit.
    let terms = [0, 1, 2].map(|k| edges[k].0 * (sz * z[k]));
    let t = terms.iter().sum::<f64>() / determinant;
    let t_known = determinant != 0.0 && fits_f32(&terms) && fits_f32(&[t]);
    let inside = edges.iter().all(|(e, _)| *e >= 0.0) || edges.iter().all(|(e, _)| *e <= 0.0);
    if inside && determinant != 0.0 && !t_known {
        return out_of_range(t >= min_t);
    }
    let t_condition = 1.0;
    if !inside || determinant == 0.0 {
        // Certain miss when some edge is certainly on the wrong side.
        let positive = determinant >= 0.0;
        let margin = edges
            .iter()
            .filter(|(e, _)| (*e < 0.0) == positive && *e != 0.0)
            .map(|(_, m)| *m)
            .fold(0.0, f64::max);
        // Seen edge-on, or beyond f32's range, a flipped decision could hit anywhere.
        let t = if t_known { t } else { 0.0 };
        return Candidate {
            hits: false,
            margin,
            t,
            t_condition,
            object: 0,
        };
    }
    let edge_margin = edges.iter().map(|(_, m)| *m).fold(f64::INFINITY, f64::min);
    started(t, min_t, eps, t_condition, edge_margin)
}

/// The margins of pixel (`i`, `j`) for a robust kernel running with machine epsilon `eps`
/// (`f32::EPSILON as f64` for the f32 kernel), judged in f64 from the robust set's f64
/// primitives and frame.
pub(crate) fn pixel_margins(
    frame: &Frame<f64>,
    prims: &Primitives<f64>,
    i: u32,
    j: u32,
    eps: f64,
) -> Margins {
    let ray = camera_ray(frame, i, j);
    let min_t = frame.min_t;
    let d = ray.direction.to_array();
    if d.iter().any(|&x| x != 0.0 && x.abs() < SMALLEST_INVERTIBLE) {
        return Margins { hit: 0.0, id: 0.0 };
    }
    let mut candidates = Vec::new();
    for (s, &object) in prims.spheres.iter().zip(&prims.sphere_objects) {
        candidates.push(Candidate {
            object,
            ..sphere(&ray, s.center, s.radius, min_t, eps)
        });
    }
    for (p, &object) in prims.planes.iter().zip(&prims.plane_objects) {
        candidates.push(Candidate {
            object,
            ..plane(&ray, p.point, p.normal, min_t, eps)
        });
    }
    for (tri, &object) in prims.triangles.iter().zip(&prims.triangle_objects) {
        candidates.push(Candidate {
            object,
            ..triangle(&ray, [tri.a, tri.b, tri.c], min_t, eps)
        });
    }
    margins_of(&candidates, eps)
}

fn margins_of(candidates: &[Candidate], eps: f64) -> Margins {
    let nearest = candidates
        .iter()
        .filter(|c| c.hits)
        .min_by(|a, b| a.t.total_cmp(&b.t).then(a.object.cmp(&b.object)));
    let Some(best) = nearest else {
        // A miss is certain when every primitive certainly misses.
        let hit = candidates
            .iter()
            .map(|c| c.margin)
            .fold(f64::INFINITY, f64::min);
        return Margins {
            hit,
            id: f64::INFINITY,
        };
    };
    // A hit is certain when some hit is certain.
    let hit = candidates
        .iter()
        .filter(|c| c.hits)
        .map(|c| c.margin)
        .fold(0.0, f64::max);
    // The nearest object is certain when its own hit is, and no other object could come
    // before it: another hit by a certain gap, a miss certainly (or behind it anyway).
    let mut id = best.margin;
    for c in candidates.iter().filter(|c| c.object != best.object) {
        let gap_bound =
            eps * (16.0 + K * c.t_condition.max(best.t_condition)) * (best.t.abs() + c.t.abs());
        let gap = (c.t - best.t).abs() / gap_bound;
        // A miss that might turn into a hit matters only if that hit could come first.
        let m = if c.hits {
            gap
        } else if c.t > best.t {
            c.margin.max(gap)
        } else {
            c.margin
        };
        id = id.min(m);
    }
    Margins { hit, id }
}

/// The margins of every pixel, row-major.
pub(crate) fn margins(frame: &Frame<f64>, prims: &Primitives<f64>, eps: f64) -> Vec<Margins> {
    use rayon::prelude::*;
    (0..frame.ny)
        .into_par_iter()
        .flat_map_iter(|i| (0..frame.nx).map(move |j| pixel_margins(frame, prims, i, j, eps)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::vec3;

    fn ray(origin: [f64; 3], direction: [f64; 3]) -> Ray<f64> {
        Ray {
            origin: Vec3::from_array(origin),
            direction: Vec3::from_array(direction),
        }
    }

    #[test]
    fn sphere_margin_shrinks_towards_the_silhouette() {
        let eps = f32::EPSILON as f64;
        let c = vec3(0.0, 0.0, -10.0);
        let centre = sphere(&ray([0.0; 3], [0.0, 0.0, -1.0]), c, 1.0, 1.0, eps);
        let edge = sphere(&ray([0.0; 3], [0.0999999, 0.0, -1.0]), c, 1.0, 1.0, eps);
        assert!(centre.hits && centre.margin > 1e3);
        assert!(edge.hits && edge.margin < centre.margin);
    }

    #[test]
    fn triangle_edge_ray_is_uncertain_and_interior_certain() {
        let eps = f32::EPSILON as f64;
        let corners = [
            vec3(-1.0, -1.0, -5.0),
            vec3(1.0, -1.0, -5.0),
            vec3(0.0, 1.0, -5.0),
        ];
        let inside = triangle(&ray([0.0; 3], [0.0, 0.0, -1.0]), corners, 1.0, eps);
        let on_edge = triangle(&ray([0.0; 3], [0.0, -0.2, -1.0]), corners, 1.0, eps);
        assert!(inside.hits && inside.margin > 1.0);
        assert!(on_edge.margin < 1.0);
    }

    #[test]
    fn a_triangle_whose_t_overflows_f32_is_uncertain() {
        let eps = f32::EPSILON as f64;
        let corners = |s: f64| [vec3(-s, -s, -s), vec3(s, -s, -s), vec3(0.0, s, -s)];
        let near = triangle(&ray([0.0; 3], [0.0, 0.0, -1.0]), corners(1e6), 1.0, eps);
        // Edges near 1e36 times z near 1e18: the kernel's t overflows.
        let far = triangle(&ray([0.0; 3], [0.0, 0.0, -1.0]), corners(1e18), 1.0, eps);
        assert!(near.hits && near.margin > 1.0);
        assert!(far.hits && far.margin == 0.0);
    }

    #[test]
    fn far_miss_is_certain() {
        let eps = f32::EPSILON as f64;
        let c = vec3(0.0, 0.0, -10.0);
        let miss = sphere(&ray([0.0; 3], [1.0, 0.0, -1.0]), c, 1.0, 1.0, eps);
        assert!(!miss.hits && miss.margin > 1.0);
    }
}
