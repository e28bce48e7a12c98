//! The BVH's far-field data for generalized winding numbers (Jacobson et al. 2013, in the fast
//! form of Barill et al. 2018): per child of every node, the triangles' area-weighted normal
//! sum, its centre and a radius that bounds the subtree. Seen from farther than
//! [`FAR_FIELD`] radii, a subtree's triangles together subtend the solid angle of one dipole
//! at its centre (`src/cpu/winding.rs`).

use super::Primitives;
use super::bvh::{BvhNode, Child, LEAF_BIT, SPHERE_LEAF, leaf_len};
use crate::math::{Vec3, cross, length, vec3};

/// A subtree's dipole: its area-weighted normal sum (half the cross products), the
/// area-weighted centre of its triangles, and the distance from that centre to the farthest
/// corner of its box.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Dipole {
    pub normal: Vec3<f64>,
    pub centre: Vec3<f64>,
    pub radius: f64,
}

/// How many radii from a subtree's centre its dipole stands for it. The first-order
/// expansion's error falls with the square of radius over distance; at 3 the winding numbers
/// stay within docs/distance.md's tolerance (docs/experiments.md#winding-numbers-far-field). A
/// second-order term (Barill et al.'s) made them worse: on a curved patch it is no larger than
/// the third-order term it leaves out.
pub(crate) const FAR_FIELD: f64 = 3.0;

/// The dipoles of both children of every node of `nodes`, over `prims` (f64, kernel
/// coordinates).
pub(crate) fn dipoles(nodes: &[BvhNode], prims: &Primitives<f64>) -> Vec<[Dipole; 2]> {
    let mut out = vec![[Dipole::default(); 2]; nodes.len()];
    if !nodes.is_empty() {
        fill(nodes, prims, 0, &mut out);
    }
    out
}

/// Fills the dipoles of node `node`'s children (and below); returns the node's own moments:
/// normal sum, area-weighted centre sum, area.
fn fill(
    nodes: &[BvhNode],
    prims: &Primitives<f64>,
    node: usize,
    out: &mut [[Dipole; 2]],
) -> Moments {
    let mut total = Moments::default();
    for k in 0..2 {
        let child = nodes[node].child(k);
        let moments = if child.reference & LEAF_BIT != 0 {
            leaf_moments(prims, &child)
        } else {
            fill(nodes, prims, child.reference as usize, out)
        };
        out[node][k] = moments.dipole(&child);
        total = total.plus(moments);
    }
    total
}

/// Sums over triangles: the area-weighted normal (half cross products), the area-weighted
/// centroids and the area.
#[derive(Clone, Copy, Default)]
struct Moments {
    normal: Vec3<f64>,
    centre: Vec3<f64>,
    area: f64,
}

impl Moments {
    fn plus(self, o: Moments) -> Moments {
        Moments {
            normal: self.normal + o.normal,
            centre: self.centre + o.centre,
            area: self.area + o.area,
        }
    }

    /// The dipole of a child with these moments, its radius bounding its box from the centre
    /// (the box centre where it has no area).
    fn dipole(self, child: &Child) -> Dipole {
        let lo = Vec3::from_array(child.lo.map(f64::from));
        let hi = Vec3::from_array(child.hi.map(f64::from));
        let centre = match self.area > 0.0 {
            true => self.centre * (1.0 / self.area),
            false => (lo + hi) * 0.5,
        };
        let far = |k: usize| {
            (centre.get(k) - lo.get(k))
                .abs()
                .max((hi.get(k) - centre.get(k)).abs())
        };
        Dipole {
            normal: self.normal,
            centre,
            radius: length(vec3(far(0), far(1), far(2))),
        }
    }
}

/// The moments of a leaf's triangles (a sphere leaf's are zero: a closed surface's normals
/// cancel).
fn leaf_moments(prims: &Primitives<f64>, leaf: &Child) -> Moments {
    let mut m = Moments::default();
    if leaf.count & SPHERE_LEAF != 0 {
        return m;
    }
    let first = (leaf.reference & !LEAF_BIT) as usize;
    for t in &prims.triangles[first..first + leaf_len(leaf.count) as usize] {
        let n = cross(t.b - t.a, t.c - t.a) * 0.5;
        let area = length(n);
        m.normal = m.normal + n;
        m.centre = m.centre + (t.a + t.b + t.c) * (area / 3.0);
        m.area += area;
    }
    m
}
