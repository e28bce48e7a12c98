//! Generalized winding numbers (Jacobson et al. 2013): the solid angle the surfaces subtend at
//! a point over 4 pi. A closed, outward-facing mesh gives 1 inside and 0 outside, exactly up to
//! rounding; an open or self-intersecting one a number in between that still says which side
//! a point is on where ray parity fails. Triangles near the point are summed exactly (Van
//! Oosterom and Strackee's formula), far subtrees of the BVH by their dipoles (Barill et al.
//! 2018, `crate::prepare::winding`). Spheres count 1 inside; a plane bounds a half-space and
//! counts 1 behind its normal. CPU only, in f64.

use std::f64::consts::PI;

use super::traverse::BVH_STACK;
use crate::kernel::types::Triangle;
use crate::math::{Vec3, cross, dot, length};
use crate::prepare::Primitives;
use crate::prepare::bvh::{BvhNode, LEAF_BIT, SPHERE_LEAF, leaf_len};
use crate::prepare::winding::{Dipole, FAR_FIELD};

/// The solid angle triangle `t` subtends at `p` over 4 pi, positive where its normal (by corner
/// order) points away from `p`.
pub(crate) fn triangle_winding(p: Vec3<f64>, t: &Triangle<f64>) -> f64 {
    let (a, b, c) = (t.a - p, t.b - p, t.c - p);
    let (la, lb, lc) = (length(a), length(b), length(c));
    let det = dot(a, cross(b, c));
    let div = la * lb * lc + dot(a, b) * lc + dot(b, c) * la + dot(c, a) * lb;
    det.atan2(div) / (2.0 * PI)
}

/// A dipole's solid angle at `p` over 4 pi.
fn dipole_winding(p: Vec3<f64>, d: &Dipole) -> f64 {
    let r = d.centre - p;
    let l = length(r);
    dot(r, d.normal) / (4.0 * PI * l * l * l)
}

fn sphere_winding(p: Vec3<f64>, prims: &Primitives<f64>, k: usize) -> f64 {
    let s = &prims.spheres[k];
    if length(p - s.center) < s.radius {
        1.0
    } else {
        0.0
    }
}

/// The winding number at `p` (kernel coordinates) of every primitive of `prims`, through the
/// BVH and its `dipoles` where there are both, else summed exactly.
pub(crate) fn winding_number(
    p: Vec3<f64>,
    prims: &Primitives<f64>,
    dipoles: Option<&[[Dipole; 2]]>,
) -> f64 {
    let behind = |pl: &crate::kernel::types::Plane<f64>| dot(p - pl.point, pl.normal) < 0.0;
    let planes = prims.planes.iter().filter(|pl| behind(pl)).count() as f64;
    match (&prims.bvh, dipoles) {
        (Some(bvh), Some(dipoles)) => planes + in_bvh(p, prims, &bvh.nodes, dipoles),
        _ => {
            let spheres: f64 = (0..prims.spheres.len())
                .map(|k| sphere_winding(p, prims, k))
                .sum();
            let triangles: f64 = prims.triangles.iter().map(|t| triangle_winding(p, t)).sum();
            planes + spheres + triangles
        }
    }
}

fn leaf_winding(p: Vec3<f64>, prims: &Primitives<f64>, first: u32, count: u32) -> f64 {
    let range = first as usize..(first + leaf_len(count)) as usize;
    match count & SPHERE_LEAF != 0 {
        true => range.map(|k| sphere_winding(p, prims, k)).sum(),
        false => prims.triangles[range]
            .iter()
            .map(|t| triangle_winding(p, t))
            .sum(),
    }
}

fn in_bvh(
    p: Vec3<f64>,
    prims: &Primitives<f64>,
    nodes: &[BvhNode],
    dipoles: &[[Dipole; 2]],
) -> f64 {
    let mut stack = [0u32; BVH_STACK * 2];
    let mut sp = 0;
    let mut node = 0u32;
    let mut w = 0.0;
    loop {
        let n = &nodes[node as usize];
        for (k, d) in dipoles[node as usize].iter().enumerate() {
            let child = n.child(k);
            if child.reference & LEAF_BIT != 0 {
                w += leaf_winding(p, prims, child.reference & !LEAF_BIT, child.count);
            } else if length(d.centre - p) > FAR_FIELD * d.radius {
                w += dipole_winding(p, d);
            } else {
                // Depth first, so at most one waiting node per level.
                stack[sp] = child.reference;
                sp += 1;
            }
        }
        if sp == 0 {
            return w;
        }
        sp -= 1;
        node = stack[sp];
    }
}
