// The nearest hit so far and the order of hits. CPU mirror: src/cpu/hit.rs.
#import types

const KIND_SPHERE: u32 = 0u;
const KIND_PLANE: u32 = 1u;
const KIND_TRIANGLE: u32 = 2u;

struct Hit {
    t: real,
    object: i32,          // -1: no hit
    kind: u32,
    index: u32,           // into the buffer of its kind
}

// Ties in t go to the lower object id, then the lower primitive index, so the answer does not
// depend on the order primitives are visited (the course visits objects in file order).
fn is_closer(t: real, object: u32, index: u32, best: Hit) -> bool {
    if (t == NO_HIT) {
        return false;
    }
    if (best.object < 0 || t < best.t) {
        return true;
    }
    return t == best.t && (i32(object) < best.object || (i32(object) == best.object && index < best.index));
}
