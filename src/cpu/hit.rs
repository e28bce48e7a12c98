//! Mirror of shaders/hit.wgsl: the nearest hit so far and the order of hits.

use crate::kernel::types::no_hit;
use crate::math::Real;

pub(crate) const KIND_SPHERE: u32 = 0;
pub(crate) const KIND_PLANE: u32 = 1;
pub(crate) const KIND_TRIANGLE: u32 = 2;

#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Hit<T> {
    pub t: T,
    /// -1: no hit.
    pub object: i32,
    pub kind: u32,
    /// Into the list of its kind.
    pub index: u32,
    /// The instance whose mesh holds the triangle, in its list (`Primitives::instances`), or
    /// [`NO_INSTANCE`] (`hit_instance` in WGSL, a private variable beside the hit).
    pub instance: u32,
}

/// [`Hit::instance`] of a primitive no instance places.
pub(crate) const NO_INSTANCE: u32 = u32::MAX;

/// Ties in t go to the lower object id, then the lower primitive index, so the answer does not
/// depend on the order primitives are visited.
pub(crate) fn is_closer<T: Real>(t: T, object: u32, index: u32, best: &Hit<T>) -> bool {
    if t == no_hit() {
        return false;
    }
    if best.object < 0 || t < best.t {
        return true;
    }
    t == best.t
        && ((object as i32) < best.object || (object as i32 == best.object && index < best.index))
}
