//! A compressed 8-wide BVH (#62, after Ylitie, Karras and Laine, "Efficient incoherent ray
//! traversal on GPUs through compressed wide BVHs", HPG 2017): the binary SAH tree
//! ([`super::bvh`]) collapsed into nodes of up to eight children, each child's box stored as
//! 8-bit offsets in a grid of its parent's (a power of two a step per axis), rounded outward so
//! that the box the traversal decodes in f32 holds the binary tree's box. Boxes only grow, so
//! the traversal skips no primitive the binary tree's would test: the same nearest hits.
//! The children sit in slots by direction, so that a ray visits them nearly front to back by
//! taking the slots in an order its octant gives. Leaf primitives are stored in the order the
//! nodes name them. Triangles only: a tree with spheres keeps the binary form.

use bytemuck::{Pod, Zeroable};
use rayon::prelude::*;

use super::bvh::{Bvh, BvhNode, Child, LEAF_BIT, SPHERE_LEAF, leaf_len};

/// Children a node holds at most.
pub(crate) const WIDTH: usize = 8;

/// The most primitives a node's leaves hold together: a leaf's offset among them is 5 bits
/// (`meta`, stored plus one so that 0 marks an empty slot).
const NODE_PRIMITIVES: u32 = 31;
/// The most primitives a leaf slot holds: its count less one is `meta`'s top 3 bits.
const LEAF_PRIMITIVES: u32 = 8;

/// One node: its children's boxes on a grid anchored at `origin` with a step of
/// `2^(exponents[a] - 127)` along axis `a`, child `s` spanning `origin + step * lo[a][s]` to
/// `origin + step * hi[a][s]` (decoded in f32: [`WideNode::child_box`]). 80 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub(crate) struct WideNode {
    pub origin: [f32; 3],
    /// Biased as f32 exponents are: the step is the f32 with these exponent bits.
    pub exponents: [u8; 3],
    /// Bit `s` set where slot `s` holds a node.
    pub internal: u8,
    /// The node of the first internal slot; the others follow in slot order.
    pub child_base: u32,
    /// The first primitive of the node's leaves, which follow one another.
    pub primitive_base: u32,
    /// Per slot: 0 where empty; a leaf's `(count - 1) << 5 | (offset + 1)` (its primitives from
    /// `primitive_base + offset`); a node's [`NODE_META`].
    pub meta: [u8; WIDTH],
    pub lo: [[u8; WIDTH]; 3],
    pub hi: [[u8; WIDTH]; 3],
}

const _: () = assert!(size_of::<WideNode>() == 80);

/// `meta` of a slot holding a node (nonzero: the slot is used; `internal` says it is a node).
const NODE_META: u8 = 1;

impl WideNode {
    /// Slot `s`'s box as the traversal decodes it, in f32.
    pub(crate) fn child_box(&self, s: usize) -> ([f32; 3], [f32; 3]) {
        let step = self.exponents.map(step_of);
        let lo = [0, 1, 2].map(|a| decode(self.origin[a], step[a], self.lo[a][s]));
        let hi = [0, 1, 2].map(|a| decode(self.origin[a], step[a], self.hi[a][s]));
        (lo, hi)
    }

    /// Whether slot `s` holds a node or a leaf.
    pub(crate) fn used(&self, s: usize) -> bool {
        self.meta[s] != 0
    }

    /// Whether slot `s` holds a node.
    pub(crate) fn is_node(&self, s: usize) -> bool {
        self.internal & (1 << s) != 0
    }

    /// The node in slot `s` (an internal slot).
    pub(crate) fn child_node(&self, s: usize) -> u32 {
        self.child_base + (self.internal & ((1u32 << s) - 1) as u8).count_ones()
    }

    /// The first primitive and the count of the leaf in slot `s`.
    pub(crate) fn leaf(&self, s: usize) -> (u32, u32) {
        let m = self.meta[s] as u32;
        (self.primitive_base + (m & 31) - 1, (m >> 5) + 1)
    }
}

/// The grid step of a biased exponent.
fn step_of(exponent: u8) -> f32 {
    f32::from_bits((exponent as u32) << 23)
}

/// A grid coordinate as the traversal decodes it: `origin + step * q` in f32, the product
/// exact (q < 2^8, step a power of two), the sum rounded once.
fn decode(origin: f32, step: f32, q: u8) -> f32 {
    origin + step * q as f32
}

/// The wide tree: node 0 the root.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct WideBvh {
    pub nodes: Vec<WideNode>,
    /// For each primitive in the order the leaves name them, its index in the binary tree's
    /// order (the kernel's triangle buffer would hold them in this order).
    pub primitives: Vec<u32>,
    /// Levels of nodes (the root alone: 1).
    pub depth: usize,
}

impl WideBvh {
    /// The binary tree `bvh` collapsed; `None` where it holds spheres, or a leaf longer than
    /// a slot's count holds (only a leaf at the binary tree's deepest level can be).
    pub(crate) fn collapse(bvh: &Bvh) -> Option<WideBvh> {
        let root = bvh.nodes.first()?;
        let mut children = (bvh.nodes.iter()).flat_map(|n| [n.child(0), n.child(1)]);
        let unfit = |c: Child| {
            is_leaf(&c) && (c.count & SPHERE_LEAF != 0 || leaf_len(c.count) > LEAF_PRIMITIVES)
        };
        if !bvh.sphere_order.is_empty() || children.any(unfit) {
            return None;
        }
        // Breadth first, level by level, so that a node's internal children are consecutive;
        // each level's nodes drafted in parallel, then given their places in turn.
        let mut wide = WideBvh::default();
        let mut level = vec![root_child(root)];
        while !level.is_empty() {
            let drafts: Vec<Draft> = (level.par_iter())
                .map(|&binary| draft(&open(&bvh.nodes, binary)))
                .collect();
            let mut child_base = (wide.nodes.len() + drafts.len()) as u32;
            let mut next = Vec::new();
            for d in drafts {
                let node = WideNode {
                    child_base,
                    primitive_base: wide.primitives.len() as u32,
                    ..d.node
                };
                for (first, count) in d.leaves {
                    wide.primitives.extend(first..first + count);
                }
                child_base += d.internal.len() as u32;
                next.extend(d.internal);
                wide.nodes.push(node);
            }
            wide.depth += 1;
            level = next;
        }
        Some(wide)
    }

    /// Bytes on the device: the nodes, and an order entry per primitive as the binary tree has.
    pub(crate) fn bytes(&self) -> usize {
        size_of_val(&self.nodes[..]) + 4 * self.primitives.len()
    }
}

/// A node before its place in the tree: its slots and boxes (its leaves' offsets counted
/// from its first primitive), its leaves' primitives (first, count) and its children that are
/// nodes, in slot order.
struct Draft {
    node: WideNode,
    leaves: Vec<(u32, u32)>,
    internal: Vec<Child>,
}

/// The node over `children`.
fn draft(children: &[Child]) -> Draft {
    let slots = assign_slots(children);
    let (origin, exponents) = grid(children);
    let mut d = Draft {
        node: WideNode {
            origin,
            exponents,
            ..WideNode::zeroed()
        },
        leaves: Vec::new(),
        internal: Vec::new(),
    };
    let mut offset = 0;
    for (s, slot) in slots.iter().enumerate() {
        // A leaf of no primitives (a tree over one) needs no slot.
        let Some(c) = slot
            .map(|i| children[i])
            .filter(|c| !is_leaf(c) || leaf_len(c.count) > 0)
        else {
            continue;
        };
        for a in 0..3 {
            let step = step_of(exponents[a]);
            d.node.lo[a][s] = quantize_down(origin[a], step, c.lo[a]);
            d.node.hi[a][s] = quantize_up(origin[a], step, c.hi[a]);
        }
        if is_leaf(&c) {
            let count = leaf_len(c.count);
            d.leaves.push((c.reference & !LEAF_BIT, count));
            d.node.meta[s] = (((count - 1) << 5) | (offset + 1)) as u8;
            offset += count;
        } else {
            d.node.internal |= 1 << s;
            d.node.meta[s] = NODE_META;
            d.internal.push(c);
        }
    }
    d
}

fn is_leaf(c: &Child) -> bool {
    c.reference & LEAF_BIT != 0
}

/// The root as a child: its box the union of its two children's.
fn root_child(root: &BvhNode) -> Child {
    let (a, b) = (root.child(0), root.child(1));
    Child {
        lo: [0, 1, 2].map(|k| a.lo[k].min(b.lo[k])),
        hi: [0, 1, 2].map(|k| a.hi[k].max(b.hi[k])),
        reference: 0,
        count: 0,
    }
}

/// The children of the wide node over binary node `node`: its two, then greedily the node
/// child of largest surface area opened into its two, while at most [`WIDTH`] children result
/// and their leaves hold at most [`NODE_PRIMITIVES`] primitives.
fn open(nodes: &[BvhNode], node: Child) -> Vec<Child> {
    let n = &nodes[node.reference as usize];
    let mut children = Vec::with_capacity(WIDTH);
    children.extend([n.child(0), n.child(1)]);
    let leaf_primitives = |c: &Child| if is_leaf(c) { leaf_len(c.count) } else { 0 };
    let mut primitives: u32 = children.iter().map(leaf_primitives).sum();
    while children.len() < WIDTH {
        // Opening a node child adds its leaf children's primitives.
        let added = |c: &Child| {
            let b = &nodes[c.reference as usize];
            leaf_primitives(&b.child(0)) + leaf_primitives(&b.child(1))
        };
        let openable = (0..children.len()).filter(|&i| {
            !is_leaf(&children[i]) && primitives + added(&children[i]) <= NODE_PRIMITIVES
        });
        let Some(i) = openable.max_by(|&i, &j| area(&children[i]).total_cmp(&area(&children[j])))
        else {
            break;
        };
        primitives += added(&children[i]);
        let b = &nodes[children[i].reference as usize];
        children[i] = b.child(0);
        children.push(b.child(1));
    }
    children
}

fn area(c: &Child) -> f64 {
    let d = [0, 1, 2].map(|k| (c.hi[k] as f64 - c.lo[k] as f64).max(0.0));
    d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
}

/// The grid of a node over `children`: its origin the low corner of their union, and per axis
/// the smallest power-of-two step whose 255 steps span the union (biased exponent).
fn grid(children: &[Child]) -> ([f32; 3], [u8; 3]) {
    let lo = [0, 1, 2].map(|a| {
        children
            .iter()
            .map(|c| c.lo[a])
            .fold(f32::INFINITY, f32::min)
    });
    let hi = [0, 1, 2].map(|a| {
        children
            .iter()
            .map(|c| c.hi[a])
            .fold(f32::NEG_INFINITY, f32::max)
    });
    let exponents = [0, 1, 2].map(|a| {
        let extent = hi[a] as f64 - lo[a] as f64;
        let guess = match extent > 0.0 {
            true => (extent / 255.0).log2().ceil() as i32 + 127,
            false => 1,
        };
        let mut e = guess.clamp(1, 254) as u8;
        // The outward rounding of the decode may need a step more.
        while e < 254
            && !children
                .iter()
                .all(|c| quantize_up_checked(lo[a], step_of(e), c.hi[a]).is_some())
        {
            e += 1;
        }
        e
    });
    (lo, exponents)
}

/// The largest grid coordinate whose decoded value is at most `x` (the origin is at most `x`).
fn quantize_down(origin: f32, step: f32, x: f32) -> u8 {
    let mut q = (((x as f64 - origin as f64) / step as f64).floor()).clamp(0.0, 255.0) as u8;
    while q > 0 && decode(origin, step, q) > x {
        q -= 1;
    }
    debug_assert!(decode(origin, step, q) <= x);
    q
}

/// The smallest grid coordinate whose decoded value is at least `x` (the grid spans it:
/// [`grid`]).
fn quantize_up(origin: f32, step: f32, x: f32) -> u8 {
    quantize_up_checked(origin, step, x).expect("the grid spans the node")
}

fn quantize_up_checked(origin: f32, step: f32, x: f32) -> Option<u8> {
    let q = ((x as f64 - origin as f64) / step as f64)
        .ceil()
        .clamp(0.0, 255.0) as u32;
    (q..=255)
        .find(|&q| decode(origin, step, q as u8) >= x)
        .map(|q| q as u8)
}

/// Which child goes in each slot: slot `s` faces the octant whose axes' signs are `s`'s bits
/// (bit `a` set: towards -a), and children are placed greedily, the pair of child and slot with
/// the lowest cost first, a child's cost for slot `s` how far its centre lies along `s`'s
/// direction from the node's centre. A ray of octant `o` (bit `a` set where its direction's
/// component `a` is negative) then visits slot `k ^ o` `k`-th, nearer children first.
fn assign_slots(children: &[Child]) -> [Option<usize>; WIDTH] {
    let centre = |c: &Child| [0, 1, 2].map(|a| (c.lo[a] as f64 + c.hi[a] as f64) / 2.0);
    let n = centre(&Child {
        lo: [0, 1, 2].map(|a| {
            children
                .iter()
                .map(|c| c.lo[a])
                .fold(f32::INFINITY, f32::min)
        }),
        hi: [0, 1, 2].map(|a| {
            children
                .iter()
                .map(|c| c.hi[a])
                .fold(f32::NEG_INFINITY, f32::max)
        }),
        reference: 0,
        count: 0,
    });
    let mut costs = [(0.0f64, 0u8, 0u8); WIDTH * WIDTH];
    for (i, c) in children.iter().enumerate() {
        let m = centre(c);
        for s in 0..WIDTH {
            let cost: f64 = (0..3)
                .map(|a| {
                    let sign = if s & (1 << a) != 0 { -1.0 } else { 1.0 };
                    sign * (m[a] - n[a])
                })
                .sum();
            costs[i * WIDTH + s] = (cost, i as u8, s as u8);
        }
    }
    let costs = &mut costs[..children.len() * WIDTH];
    costs.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
    let mut slots = [None; WIDTH];
    let mut placed = [false; WIDTH];
    for &(_, i, s) in costs.iter() {
        let (i, s) = (i as usize, s as usize);
        if !placed[i] && slots[s].is_none() {
            slots[s] = Some(i);
            placed[i] = true;
        }
    }
    slots
}

#[cfg(test)]
mod tests {
    use super::*;

    fn child(lo: [f32; 3], hi: [f32; 3]) -> Child {
        Child {
            lo,
            hi,
            reference: LEAF_BIT,
            count: 1,
        }
    }

    /// Decoded boxes hold the children's, however the bounds fall on the grid: awkward
    /// magnitudes, a flat axis, a child far from the origin.
    #[test]
    fn decoded_boxes_hold_the_childrens() {
        let mut seed = 9u64;
        let mut next = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) as f32
        };
        for scale in [1e-6f32, 0.3, 1.0, 7.5, 1e5] {
            for _ in 0..200 {
                let children: Vec<Child> = (0..8)
                    .map(|k| {
                        let lo = [next(), next() * 3.0, 1.0 + (k as f32) * 0.1].map(|x| x * scale);
                        let hi = [lo[0] + next() * scale, lo[1] + next() * scale, lo[2]];
                        child(lo, hi)
                    })
                    .collect();
                let node = draft(&children).node;
                let slots = assign_slots(&children);
                for (s, slot) in slots.iter().enumerate() {
                    let c = children[slot.unwrap()];
                    let (lo, hi) = node.child_box(s);
                    for a in 0..3 {
                        assert!(
                            lo[a] <= c.lo[a] && hi[a] >= c.hi[a],
                            "{scale} {a}: {lo:?} {hi:?} {c:?}"
                        );
                    }
                }
            }
        }
    }

    /// A leaf longer than a slot holds (as at the binary tree's deepest level) leaves the
    /// scene to the binary tree rather than being cut short.
    #[test]
    fn a_leaf_too_long_for_a_slot_keeps_the_binary_tree() {
        let tree = |count: u32| {
            let leaf = |first| Child {
                lo: [0.0; 3],
                hi: [1.0; 3],
                reference: LEAF_BIT | first,
                count,
            };
            Bvh {
                nodes: vec![BvhNode::new(leaf(0), leaf(20))],
                triangle_order: (0..40).collect(),
                depth: 1,
                ..Bvh::default()
            }
        };
        assert!(WideBvh::collapse(&tree(8)).is_some());
        assert!(WideBvh::collapse(&tree(crate::prepare::bvh::MANY_LEAF | 20)).is_none());
    }

    /// A ray heading towards +x, +y, +z visits the child nearest the low corner first, and
    /// one heading the other way the farthest.
    #[test]
    fn slots_face_their_octants() {
        let cube = |x: f32, y: f32, z: f32| child([x, y, z], [x + 1.0, y + 1.0, z + 1.0]);
        let children: Vec<Child> = (0..8)
            .map(|k| {
                cube(
                    (k & 1) as f32 * 2.0,
                    (k >> 1 & 1) as f32 * 2.0,
                    (k >> 2) as f32 * 2.0,
                )
            })
            .collect();
        let slots = assign_slots(&children);
        assert_eq!(slots[0], Some(0));
        assert_eq!(slots[7], Some(7));
        for (s, slot) in slots.iter().enumerate() {
            assert_eq!(*slot, Some(s), "slot {s}");
        }
    }
}
