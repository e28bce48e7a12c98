//! The shape of the BVH of a scene that places meshes (#64's instances): each mesh's own tree,
//! built once in the mesh's coordinates whatever its placements, and a tree over the
//! instances' boxes above them, one tree in the kernel's layout ([`Bvh`]) whose boxes are then
//! fitted as any topology's are ([`Bvh::fit`]). A new pose of the instances builds only the top
//! tree; the triangles, in world space, are the flattened scene's, so every hit is its hit.

use std::sync::Arc;

use bytemuck::Zeroable;
use glam::DVec3;

use super::{
    Aabb, Bvh, BvhNode, Child, Extent, INSTANCE_BIT, InstanceRoot, Instanced, Item, LEAF_BIT,
    MANY_LEAF, MAX_DEPTH, MeshSpan, Policy, SPHERE_LEAF, Topology, Tree, build_tree, depth_of,
    leaf_len, leaf_word, round_down, round_up,
};
use crate::prepare::shared;
use crate::scene::{Mesh, Object, Placement, Scene, moved_box};

/// A mesh's own tree (triangles only, object 0) and its bounds, in the mesh's coordinates.
#[derive(Debug)]
pub(crate) struct MeshTree {
    bvh: Bvh,
    bounds: Option<(DVec3, DVec3)>,
    /// A leaf holds more triangles than a count word names with an object ([`MANY_LEAF`]):
    /// a traversal could not give them an instance's object, so no tree names its instances.
    many_leaf: bool,
}

impl MeshTree {
    pub(crate) fn build(mesh: &Mesh) -> MeshTree {
        let soup = [Object::Soup {
            path: mesh.path.clone(),
            triangles: mesh.triangles.clone(),
        }];
        let bvh = Topology::of_objects(&soup).0;
        let many_leaf =
            (bvh.nodes.iter()).any(|n| [n.count0, n.count1].iter().any(|c| c & MANY_LEAF != 0));
        MeshTree {
            bvh,
            bounds: mesh.bounds(),
            many_leaf,
        }
    }
}

/// A subtree of `bvh` joined into the tree: its leaves over `bvh.triangle_order`, whose
/// entries are `global` indices, and `object`, where all its triangles are one object's.
struct Group<'a> {
    bvh: &'a Bvh,
    root: Subtree,
    global: Global<'a>,
    object: Option<u32>,
    /// The instance a leaf names instead ([`instanced`]).
    instance: Option<u32>,
}

/// How a group's triangle indices map to the scene's: an instance's from its object's first
/// triangle on, the other objects' through a list.
#[derive(Clone, Copy)]
enum Global<'a> {
    From(u32),
    Listed(&'a [u32]),
}

/// The topology of `scene`'s BVH built from its meshes' trees, or none where it places no mesh
/// or the joined tree would be deeper than [`MAX_DEPTH`].
pub(super) fn build(scene: &Scene) -> Option<Topology> {
    join(scene, false)
}

/// [`build`] with each instance named by its leaf of the top tree ([`INSTANCE_BIT`]) rather
/// than its mesh's tree copied there: each mesh's tree and triangles are laid out once, after
/// the top tree, in the mesh's coordinates ([`Instanced`]), and a traversal moves the ray into
/// them. (A tree over copies costs every copy's triangles and nodes; this, one mesh's.)
pub(super) fn instanced(scene: &Scene) -> Option<Topology> {
    join(scene, true)
}

/// [`build`], or with `by_reference` [`instanced`].
fn join(scene: &Scene, by_reference: bool) -> Option<Topology> {
    let placed = placements(scene);
    if placed.is_empty() {
        return None;
    }
    let trees = per_mesh(placed.iter().copied(), shared::mesh_tree);
    if by_reference && trees.iter().any(|t| t.many_leaf) {
        return None;
    }
    let firsts = first_triangles(scene);
    let rest = shared::rest_tree(scene, || Rest::of(scene, &placed, &firsts));
    let [rest_spheres, rest_triangles] = kind_roots(&rest.tree);

    let mut groups: Vec<Group> = (placed.iter().zip(&trees).enumerate())
        .map(|(k, (p, tree))| Group {
            bvh: &tree.bvh,
            root: kind_roots(&tree.bvh)[1].expect("a placed mesh has triangles"),
            global: Global::From(firsts[p.object]),
            object: Some(p.object as u32),
            instance: by_reference.then_some(k as u32),
        })
        .collect();
    let mut boxes: Vec<(DVec3, DVec3)> = (placed.iter().zip(&trees))
        .map(|(p, tree)| {
            moved_box(
                tree.bounds.expect("a placed mesh has triangles"),
                &p.transform,
            )
        })
        .collect();
    if let (Some(root), Some(bounds)) = (rest_triangles, rest.bounds) {
        groups.push(Group {
            bvh: &rest.tree,
            root,
            global: Global::Listed(&rest.triangles),
            object: None,
            instance: None,
        });
        boxes.push(bounds);
    }

    let mut joined = Joined {
        nodes: Vec::new(),
        triangle_order: Vec::new(),
    };
    let top = top_tree(&boxes);
    // A lone instance named by reference is no node: it goes under a root of its own.
    let one_inner = groups.len() > 1
        || (groups[0].root.root.reference & LEAF_BIT == 0 && groups[0].instance.is_none());
    let pair = rest_spheres.is_some() || !one_inner;
    if pair {
        joined.nodes.push(BvhNode::zeroed());
    }
    let spheres = rest_spheres.map(|root| joined.copy(&rest.tree, root, 0, None));
    let triangles = joined.flatten_top(&top, &groups);
    if pair {
        let empty = Child {
            lo: [0.0; 3],
            hi: [0.0; 3],
            reference: LEAF_BIT,
            count: 0,
        };
        joined.nodes[0] = BvhNode::new(spheres.unwrap_or(empty), triangles);
    }
    let instanced = by_reference.then(|| Instanced {
        firsts: firsts.clone(),
        ..joined.meshes_once(scene, &placed, &groups, &trees)
    });
    let depth = match &instanced {
        Some(i) => {
            // Each mesh's depth once, not once an instance.
            let mesh_depths: Vec<usize> = (i.meshes.iter())
                .map(|m| depth_of(&joined.nodes, m.root as usize))
                .collect();
            instanced_depth(&joined.nodes, i, &mesh_depths, 0)
        }
        None => depth_of(&joined.nodes, 0),
    };
    (depth <= MAX_DEPTH).then(|| {
        Topology(Bvh {
            nodes: joined.nodes,
            sphere_order: rest.tree.sphere_order.clone(),
            triangle_order: joined.triangle_order,
            depth,
            instanced,
        })
    })
}

/// [`depth_of`] of a tree naming instances: an instance's child as deep as its mesh's tree
/// (`mesh_depths`) under a node.
fn instanced_depth(
    nodes: &[BvhNode],
    instanced: &Instanced,
    mesh_depths: &[usize],
    node: usize,
) -> usize {
    (0..2)
        .map(|k| nodes[node].child(k).reference)
        .map(|r| match (r & LEAF_BIT != 0, r & INSTANCE_BIT != 0) {
            (true, _) => 1,
            (false, true) => {
                let mesh = instanced.instances[(r & !INSTANCE_BIT) as usize].mesh;
                1 + mesh_depths[mesh as usize]
            }
            (false, false) => 1 + instanced_depth(nodes, instanced, mesh_depths, r as usize),
        })
        .max()
        .unwrap_or(0)
}

/// Seconds to build the tree over `scene`'s instances alone (their meshes' boxes moved), the
/// one part of a frame's work that a traversal moving rays into the meshes' coordinates would
/// keep (#64's must-hold of 2 ms for 1,000 instances; src/tests/measure/pose_cost.rs).
#[cfg(test)]
pub(crate) fn top_tree_seconds(scene: &Scene) -> f64 {
    // The meshes' own boxes are the meshes' trees' (MeshTree::bounds), made once.
    let bounds = per_mesh(&scene.instances, |mesh| mesh.bounds());
    let clock = std::time::Instant::now();
    let boxes: Vec<(DVec3, DVec3)> = (scene.instances.iter().zip(bounds))
        .filter_map(|(p, b)| Some(moved_box(b?, &p.transform)))
        .collect();
    std::hint::black_box(top_tree(&boxes));
    clock.elapsed().as_secs_f64()
}

/// The objects of a scene other than its instances, as the joined tree takes them. They do not
/// change when the instances move, so this is kept from pose to pose where the renders share
/// what depends on the objects ([`shared::rest_tree`]): a large static mesh among moving ones
/// is built once.
#[derive(Debug)]
pub(crate) struct Rest {
    /// Their tree, built as if each instance's soup were empty: their ids, and the spheres'
    /// indices, are the scene's.
    tree: Bvh,
    /// The scene's indices of their triangles, in order.
    triangles: Vec<u32>,
    /// The box of their triangles, if they have any.
    bounds: Option<(DVec3, DVec3)>,
}

impl Rest {
    /// The objects of `scene` other than the instances `placed`; `firsts`: each object's first
    /// triangle index ([`first_triangles`]).
    fn of(scene: &Scene, placed: &[&Placement], firsts: &[u32]) -> Rest {
        let mut is_placed = vec![false; scene.objects.len()];
        placed.iter().for_each(|p| is_placed[p.object] = true);
        let empty = Object::Soup {
            path: Default::default(),
            triangles: Vec::new(),
        };
        let rest: Vec<&Object> = (scene.objects.iter().zip(&is_placed))
            .map(|(o, &placed)| if placed { &empty } else { o })
            .collect();
        let triangles = (rest.iter().zip(firsts))
            .flat_map(|(o, &first)| first..first + triangle_count(o))
            .collect();
        let triangle_objects =
            (rest.iter()).filter(|o| matches!(o, Object::Triangle { .. } | Object::Soup { .. }));
        Rest {
            tree: Topology::of_objects(rest.iter().copied()).0,
            triangles,
            bounds: crate::scene::bounds(triangle_objects.copied()),
        }
    }
}

/// For each of `placed`, `make` of its mesh, made once for each mesh however many place it.
fn per_mesh<'a, T: Clone>(
    placed: impl IntoIterator<Item = &'a Placement>,
    mut make: impl FnMut(&Arc<Mesh>) -> T,
) -> Vec<T> {
    let mut made: Vec<(&Arc<Mesh>, T)> = Vec::new();
    (placed.into_iter())
        .map(
            |p| match made.iter().find(|(m, _)| Arc::ptr_eq(m, &p.mesh)) {
                Some((_, t)) => t.clone(),
                None => {
                    let t = make(&p.mesh);
                    made.push((&p.mesh, t.clone()));
                    t
                }
            },
        )
        .collect()
}

/// The placements of `scene` whose object is the soup its mesh places (a caller may have
/// changed the objects since), one an object, of meshes with triangles.
fn placements(scene: &Scene) -> Vec<&Placement> {
    let mut seen = vec![false; scene.objects.len()];
    (scene.instances.iter())
        .filter(|p| {
            let fits = matches!(scene.objects.get(p.object),
                Some(Object::Soup { triangles, .. }) if triangles.len() == p.mesh.triangles.len());
            let first = fits && !std::mem::replace(&mut seen[p.object], true);
            first && !p.mesh.triangles.is_empty()
        })
        .collect()
}

/// Each object's first triangle index in the scene's order.
fn first_triangles(scene: &Scene) -> Vec<u32> {
    (scene.objects.iter())
        .scan(0, |next, o| {
            Some(std::mem::replace(next, *next + triangle_count(o)))
        })
        .collect()
}

/// How many triangles `object` adds to the scene's list.
fn triangle_count(object: &Object) -> u32 {
    match object {
        Object::Triangle { .. } => 1,
        Object::Soup { triangles, .. } => triangles.len() as u32,
        Object::Sphere { .. } | Object::Plane { .. } => 0,
    }
}

/// The subtrees of `bvh`'s spheres and triangles (as [`Bvh::from_boxes`] lays them out), each
/// where it has primitives.
fn kind_roots(bvh: &Bvh) -> [Option<Subtree>; 2] {
    let root = &bvh.nodes[0];
    let has = |c: Child| c.reference & LEAF_BIT == 0 || leaf_len(c.count) > 0;
    let (c0, c1) = (root.child(0), root.child(1));
    let end = bvh.nodes.len();
    let whole = Subtree {
        root: Child {
            lo: [0.0; 3],
            hi: [0.0; 3],
            reference: 0,
            count: 0,
        },
        end,
    };
    let one_kind = bvh.sphere_order.is_empty() || bvh.triangle_order.is_empty();
    if one_kind && has(c0) && has(c1) {
        // One kind's inner root is the tree's.
        let kind = usize::from(bvh.sphere_order.is_empty());
        let mut roots = [None, None];
        roots[kind] = Some(whole);
        return roots;
    }
    // A root over the two kinds: the spheres' nodes come first, up to the triangles' root.
    let spheres_end = match c1.reference & LEAF_BIT {
        0 => c1.reference as usize,
        _ => end,
    };
    [
        has(c0).then_some(Subtree {
            root: c0,
            end: spheres_end,
        }),
        has(c1).then_some(Subtree { root: c1, end }),
    ]
}

/// A subtree of a tree: its root as the parent stores it, a leaf or `nodes[root..end]`.
#[derive(Clone, Copy)]
struct Subtree {
    root: Child,
    end: usize,
}

/// The tree over the groups' `boxes` (world coordinates), a group a leaf: the SAH build,
/// told that a split always pays, and leaves it could not split (groups centred alike, or at
/// the depth limit) halved.
fn top_tree(boxes: &[(DVec3, DVec3)]) -> (Aabb, Tree) {
    let centre = boxes
        .iter()
        .fold(DVec3::ZERO, |c, (lo, hi)| c + 0.5 * (*lo + *hi))
        / boxes.len() as f64;
    let mut items: Vec<Item> = (boxes.iter().enumerate())
        .map(|(index, (lo, hi))| Item {
            lo: (*lo - centre).to_array().map(round_down),
            hi: (*hi - centre).to_array().map(round_up),
            index: index as u32,
        })
        .collect();
    let policy = Policy {
        traversal_cost: f64::NEG_INFINITY,
        all_axes: true,
    };
    let extent = Extent::of(&items);
    let (bounds, tree) = build_tree(&mut items, 0, 1, extent, policy);
    let order: Vec<usize> = items.iter().map(|i| i.index as usize).collect();
    (bounds, one_a_leaf(tree, &order))
}

/// `tree` with every leaf of several items halved until each holds one, and each leaf's
/// `start` the group (`order` maps a position to it).
fn one_a_leaf(tree: Tree, order: &[usize]) -> Tree {
    match tree {
        Tree::Leaf { start, len: 1 } => Tree::Leaf {
            start: order[start],
            len: 1,
        },
        Tree::Leaf { start, len } => {
            let half = len / 2;
            let side = |start, len| (Aabb::EMPTY, one_a_leaf(Tree::Leaf { start, len }, order));
            Tree::Inner(Box::new([
                side(start, half),
                side(start + half, len - half),
            ]))
        }
        Tree::Inner(children) => {
            let [(b0, t0), (b1, t1)] = *children;
            Tree::Inner(Box::new([
                (b0, one_a_leaf(t0, order)),
                (b1, one_a_leaf(t1, order)),
            ]))
        }
    }
}

/// The joined tree as it is laid out.
struct Joined {
    nodes: Vec<BvhNode>,
    triangle_order: Vec<u32>,
}

impl Joined {
    /// Appends the top tree's nodes, each leaf the group it names, and returns its root as its
    /// parent stores it. (Boxes are left to [`Bvh::fit`].)
    fn flatten_top(&mut self, (_, tree): &(Aabb, Tree), groups: &[Group]) -> Child {
        match tree {
            Tree::Leaf { start, .. } => {
                let g = &groups[*start];
                if let Some(instance) = g.instance {
                    return Child {
                        lo: [0.0; 3],
                        hi: [0.0; 3],
                        reference: INSTANCE_BIT | instance,
                        count: 0,
                    };
                }
                let base = self.triangle_order.len() as u32;
                let order = &g.bvh.triangle_order;
                match g.global {
                    Global::From(first) => {
                        (self.triangle_order).extend(order.iter().map(|&k| first + k))
                    }
                    Global::Listed(list) => {
                        (self.triangle_order).extend(order.iter().map(|&k| list[k as usize]))
                    }
                }
                self.copy(g.bvh, g.root, base, g.object)
            }
            Tree::Inner(children) => {
                let at = self.nodes.len();
                self.nodes.push(BvhNode::zeroed());
                let c0 = self.flatten_top(&children[0], groups);
                let c1 = self.flatten_top(&children[1], groups);
                self.nodes[at] = BvhNode::new(c0, c1);
                Child {
                    lo: [0.0; 3],
                    hi: [0.0; 3],
                    reference: at as u32,
                    count: 0,
                }
            }
        }
    }

    /// Lays out, after the top tree, each mesh `placed` places once: its tree (under a node of
    /// its own where it is one leaf) and its triangles' indices in the mesh. `groups` are the
    /// instances' (then the other objects'), `trees` their meshes' trees.
    fn meshes_once(
        &mut self,
        scene: &Scene,
        placed: &[&Placement],
        groups: &[Group],
        trees: &[Arc<MeshTree>],
    ) -> Instanced {
        let rest_triangles = self.triangle_order.len() as u32;
        let mut meshes: Vec<MeshSpan> = Vec::new();
        let mut instances = Vec::with_capacity(placed.len());
        let index: std::collections::HashMap<*const Placement, u32> = (scene.instances.iter())
            .enumerate()
            .map(|(k, q)| (q as *const Placement, k as u32))
            .collect();
        for ((p, g), tree) in placed.iter().zip(groups).zip(trees) {
            let placement = index[&(*p as *const Placement)];
            let same =
                |m: &MeshSpan| Arc::ptr_eq(&scene.instances[m.placement as usize].mesh, &p.mesh);
            let mesh = match meshes.iter().position(same) {
                Some(k) => k,
                None => {
                    let first = self.triangle_order.len() as u32;
                    self.triangle_order.extend(&g.bvh.triangle_order);
                    let mut root = self.copy(g.bvh, g.root, first, None);
                    if root.reference & LEAF_BIT != 0 {
                        let empty = Child {
                            reference: LEAF_BIT,
                            count: 0,
                            ..root
                        };
                        self.nodes.push(BvhNode::new(root, empty));
                        root.reference = self.nodes.len() as u32 - 1;
                    }
                    meshes.push(MeshSpan {
                        placement,
                        first,
                        len: g.bvh.triangle_order.len() as u32,
                        root: root.reference,
                        bounds: tree.bounds.expect("a placed mesh has triangles"),
                    });
                    meshes.len() - 1
                }
            };
            instances.push(InstanceRoot {
                placement,
                root: meshes[mesh].root,
                mesh: mesh as u32,
            });
        }
        Instanced {
            instances,
            meshes,
            rest_triangles,
            firsts: Vec::new(),
        }
    }

    /// Appends `subtree` of `bvh`, its leaves' primitives moved on by `base`, their object set
    /// to `object` where given; returns its root as its parent now stores it.
    fn copy(&mut self, bvh: &Bvh, subtree: Subtree, base: u32, object: Option<u32>) -> Child {
        let root = subtree.root;
        let moved = |c: Child, from: u32, to: u32| -> Child {
            if c.reference & LEAF_BIT == 0 {
                return Child {
                    reference: c.reference - from + to,
                    ..c
                };
            }
            let len = leaf_len(c.count);
            if len == 0 {
                return c;
            }
            let count = match object {
                Some(o) if c.count & MANY_LEAF == 0 => {
                    leaf_word(c.count & SPHERE_LEAF, len as usize, o)
                }
                _ => c.count,
            };
            Child {
                reference: LEAF_BIT | ((c.reference & !LEAF_BIT) + base),
                count,
                ..c
            }
        };
        let at = self.nodes.len() as u32;
        if root.reference & LEAF_BIT != 0 {
            return moved(root, 0, at);
        }
        let from = root.reference;
        (self.nodes).extend(
            bvh.nodes[from as usize..subtree.end]
                .iter()
                .map(|n| BvhNode::new(moved(n.child(0), from, at), moved(n.child(1), from, at))),
        );
        moved(root, from, at)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::algorithm::Algorithm;
    use crate::images::Images;
    use crate::prepare::bvh::Search;
    use crate::prepare::bvh::{grown, primitive_boxes};
    use crate::prepare::{ObjectIds, kernel_frame, kernel_origin};
    use crate::{Cpu, RenderOptions};

    /// A mesh of `n` small triangles on a wavy sheet, in its own coordinates.
    fn sheet(n: usize) -> Vec<crate::scene::Triangle> {
        (0..n)
            .map(|k| {
                let (x, y) = ((k % 17) as f64 * 0.1, (k / 17) as f64 * 0.1);
                let z = 0.3 * (3.0 * x).sin() * (2.0 * y).cos();
                [
                    DVec3::new(x, y, z),
                    DVec3::new(x + 0.1, y, z),
                    DVec3::new(x, y + 0.1, z + 0.05),
                ]
            })
            .collect()
    }

    /// Instances of two meshes (a mirror among them), among spheres, a plane, a triangle and
    /// a soup, seen from in front.
    fn placed_scene(resolution: [u32; 2]) -> Scene {
        let json = format!(
            r#"{{"camera": {{"eye": [0.8, 0.8, 6], "look": [0, 0, -1], "up": [0, 1, 0],
                "focal_length": 1, "width": 1.6, "height": 1.2, "resolution": {resolution:?}}},
              "meshes": {{"a": {{"obj": "a.obj"}}, "b": {{"obj": "b.obj"}}}},
              "objects": [
                {{"type": "sphere", "center": [1.5, 1.5, -1], "radius": 0.3}},
                {{"type": "instance", "mesh": "a", "transform": {{"translate": [-0.5, 0, 0]}}}},
                {{"type": "plane", "point": [0, 0, -3], "normal": [0, 0, 1]}},
                {{"type": "instance", "mesh": "b", "transform": {{"translate": [-1.2, -0.8, 0.3],
                  "rotate": {{"axis": [1, 1, 0], "degrees": 30}}, "scale": [1, 2, 0.5]}}}},
                {{"type": "triangle", "corners": [[0, 0, 0.5], [1, 0, 0.5], [0, 1, 0.4]]}},
                {{"type": "instance", "mesh": "a", "transform": [[-1, 0, 0, 2], [0, 1, 0, 0.4],
                  [0, 0, 1, -0.2], [0, 0, 0, 1]]}},
                {{"type": "soup", "obj": "c.obj"}},
                {{"type": "sphere", "center": [0, 1.8, 0], "radius": 0.2}}
              ]}}"#
        );
        Scene::from_json(&json, std::path::Path::new("s.json"), &mut |name, _| {
            let n = match name {
                "a.obj" => 300,
                "b.obj" => 5,
                _ => 40,
            };
            Ok(crate::scene::MeshPart::whole(sheet(n)))
        })
        .unwrap()
    }

    /// The CPU render of `scene` in `T` through the joined tree ([`build`]; the flattened
    /// scene's own tree where it places no mesh).
    fn joined_render<T: crate::math::Real>(scene: &Scene) -> Images<T> {
        let prepared = crate::prepare::Prepared::new(scene, Algorithm::Robust, Search::Bvh);
        crate::cpu::render_prepared(&prepared, &std::sync::atomic::AtomicU32::new(0))
    }

    /// The ids of `scene`'s CPU renders through the joined tree in f32 and in f64, each the
    /// render of the flattened scene (its instances forgotten: one tree over every copy), bit
    /// for bit.
    fn ids_as_flattened(scene: &Scene) -> Vec<Vec<i32>> {
        let flattened = Scene {
            instances: Vec::new(),
            ..scene.clone()
        };
        let f32s = joined_render::<f32>(scene);
        assert_eq!(f32s, joined_render(&flattened), "f32");
        let f64s = joined_render::<f64>(scene);
        assert_eq!(f64s, joined_render(&flattened), "f64");
        vec![f32s.id, f64s.id]
    }

    /// The joined tree, fitted to a camera, holds every triangle once, inside every box on its
    /// path, its leaves naming their object; each instance's nodes are its mesh's.
    #[test]
    fn the_meshes_trees_join_under_the_instances_tree() {
        let scene = placed_scene([8, 6]);
        assert_eq!(scene.instances.len(), 3);
        let joined = build(&scene).expect("a scene of instances is joined");
        let flat = Topology::of_objects(&scene.objects);
        assert_eq!(joined.0.sphere_order, flat.0.sphere_order);
        let trees = [300, 5].map(|n| {
            MeshTree::build(&Mesh {
                path: "m".into(),
                triangles: sheet(n),
            })
        });
        let mesh_nodes = 2 * trees[0].bvh.nodes.len() + trees[1].bvh.nodes.len();
        assert!(
            joined.0.nodes.len() > mesh_nodes,
            "{}",
            joined.0.nodes.len()
        );
        let bvh = Bvh::fit(&joined, &scene, Algorithm::Robust);
        let origin = kernel_origin(&scene, Algorithm::Robust);
        let far = crate::math::length(kernel_frame(&scene, Algorithm::Robust).eye);
        let (_, triangles) = primitive_boxes(&scene.objects, origin);
        super::super::tests::check(
            &bvh,
            &grown(triangles, far),
            &ObjectIds::of(&scene).triangles,
        );
    }

    /// Scenes of instances alone, one or two of a mesh of one triangle (a tree that is one
    /// leaf), three or 300: each joined tree holds every triangle once, inside its boxes, and
    /// finds the flattened scene's hits.
    #[test]
    fn instances_alone_of_meshes_large_and_small_join() {
        for (triangles, copies) in [(1, 1), (1, 2), (3, 1), (300, 1), (300, 2)] {
            let objects: Vec<String> = (0..copies)
                .map(|k| {
                    format!(r#"{{"type": "instance", "mesh": "a", "transform": {{"translate": [{k}, 0, 0]}}}}"#)
                })
                .collect();
            let json = format!(
                r#"{{"camera": {{"eye": [0.5, 0.5, 4], "look": [0, 0, -1], "up": [0, 1, 0],
                    "focal_length": 1, "width": 1.6, "height": 1.2, "resolution": [32, 24]}},
                  "meshes": {{"a": {{"obj": "a.obj"}}}}, "objects": [{}]}}"#,
                objects.join(",")
            );
            let scene = Scene::from_json(&json, std::path::Path::new("s.json"), &mut |_, _| {
                Ok(crate::scene::MeshPart::whole(sheet(triangles)))
            })
            .unwrap();
            let case = format!("{copies} of {triangles}");
            let joined = build(&scene).expect(&case);
            let bvh = Bvh::fit(&joined, &scene, Algorithm::Robust);
            let origin = kernel_origin(&scene, Algorithm::Robust);
            let far = crate::math::length(kernel_frame(&scene, Algorithm::Robust).eye);
            let (_, boxes) = primitive_boxes(&scene.objects, origin);
            let ids = ObjectIds::of(&scene).triangles;
            super::super::tests::check(&bvh, &grown(boxes, far), &ids);
            let flattened = Scene {
                instances: Vec::new(),
                ..scene.clone()
            };
            let images = joined_render::<f64>(&scene);
            assert_eq!(images, joined_render(&flattened), "{case}");
            let hit = (0..copies as i32).filter(|k| images.id.contains(k)).count();
            assert!(triangles < 300 || hit == copies, "{case}: {hit} seen");
            // Moved into the meshes' coordinates (a mesh's tree of one leaf under a node of
            // its own), the same objects.
            let options = RenderOptions {
                precision: Some(crate::Precision::F64),
                ..RenderOptions::default()
            };
            let crate::AnyImages::F64(instanced) = Cpu.render(&scene, &options).unwrap() else {
                panic!("an f64 render")
            };
            assert_eq!(instanced.id, images.id, "{case}");
        }
    }

    /// Renders through the joined tree are the flattened scene's, bit for bit, in both
    /// precisions: the same triangles, found by a tree of another shape.
    #[test]
    fn renders_through_the_joined_tree_are_the_flattened_scenes() {
        for ids in ids_as_flattened(&placed_scene([64, 48])) {
            for object in [1, 3, 5] {
                assert!(ids.contains(&object), "instance {object} is seen");
            }
        }
    }

    /// 100 copies of a mesh at seeded random poses (rotations about random axes, non-uniform
    /// scales, translations up to 1e3), seen from afar: the joined tree's renders are the
    /// flattened scene's in both precisions, and most copies are seen.
    #[test]
    fn a_hundred_copies_far_apart_render_as_the_flattened_scene() {
        let scene = hundred_copies();
        assert!(build(&scene).is_some());
        for ids in ids_as_flattened(&scene) {
            let seen: std::collections::BTreeSet<i32> =
                ids.into_iter().filter(|&i| i >= 0).collect();
            assert!(seen.len() >= 50, "{} copies seen", seen.len());
        }
    }

    /// Rays moved into the meshes' coordinates ([`instanced`]: each mesh held once) find the
    /// flattened scene's hits: in f64 the same object on every pixel, the distance within
    /// 1e-12 relative and the normal within 1e-12; in f32 the f64 object on every pixel whose
    /// f32 decisions are certain ([`crate::Cpu::certain_in_f32`]), the distance within 1e-5
    /// relative and the normal within 1e-4. On instances of two meshes (one of 5 triangles: a
    /// tree of one leaf, a mirror among them) among spheres, a plane, a triangle and a soup,
    /// also scaled by 2^40 (a kernel unit other than 1: the instances' maps compose it); and
    /// 100 copies at random poses, far from the camera.
    #[test]
    fn rays_moved_into_the_meshes_find_the_flattened_scenes_hits() {
        use crate::prepare::Prepared;
        use std::sync::atomic::AtomicU32;
        let scaled = placed_scene([64, 48]).scaled_by_pow2(40);
        assert_eq!(
            crate::prepare::unit_exponent(&scaled),
            40,
            "a kernel unit of 2^40"
        );
        for (name, scene) in [
            ("placed", placed_scene([64, 48])),
            ("hundred", hundred_copies()),
            ("scaled", scaled),
        ] {
            let flattened = Scene {
                instances: Vec::new(),
                ..scene.clone()
            };
            let rows = AtomicU32::new(0);
            let flat: Images<f64> = crate::cpu::render_prepared(
                &Prepared::new(&flattened, Algorithm::Robust, Search::Bvh),
                &rows,
            );
            let f64s: Images<f64> =
                crate::cpu::render_prepared(&Prepared::instanced(&scene, Algorithm::Robust), &rows);
            let f32s: Images<f32> =
                crate::cpu::render_prepared(&Prepared::instanced(&scene, Algorithm::Robust), &rows);
            let prepared = Prepared::<f32>::instanced(&scene, Algorithm::Robust);
            let held = prepared
                .bvh()
                .and_then(|b| b.instanced.as_ref())
                .expect(name);
            assert_eq!(held.instances.len(), scene.instances.len(), "{name}");
            let certain = Cpu.certain_in_f32(&scene);
            let seen: std::collections::BTreeSet<i32> =
                flat.id.iter().copied().filter(|&i| i >= 0).collect();
            assert!(seen.len() >= 5, "{name}: {} objects seen", seen.len());
            for (k, &id) in flat.id.iter().enumerate() {
                assert_eq!(f64s.id[k], id, "{name}: pixel {k} in f64");
                if certain[k][1] {
                    assert_eq!(f32s.id[k], id, "{name}: pixel {k} in f32");
                }
                if id < 0 || f32s.id[k] != id {
                    continue;
                }
                let d = flat.distance[k];
                assert!(
                    (f64s.distance[k] - d).abs() <= 1e-12 * d,
                    "{name}: pixel {k}"
                );
                assert!(
                    (f64::from(f32s.distance[k]) - d).abs() <= 1e-5 * d,
                    "{name}: pixel {k}"
                );
                let n = flat.normal[k];
                let off = |m: [f64; 3]| (0..3).map(|j| (m[j] - n[j]).abs()).fold(0.0, f64::max);
                assert!(
                    off(f64s.normal[k]) <= 1e-12,
                    "{name}: pixel {k}: {:?} {n:?}",
                    f64s.normal[k]
                );
                assert!(
                    off(f32s.normal[k].map(f64::from)) <= 1e-4,
                    "{name}: pixel {k}"
                );
            }
        }
    }

    /// The GPU kernel walking instances in their meshes' coordinates ray by ray (`INSTANCES`)
    /// renders as its CPU mirror: in f32 the same object on every pixel, distances within
    /// 1e-5 relative and normals within 1e-4 (the kernel may fuse what the mirror rounds
    /// twice); in f64 within 1e-12; also scaled by 2^40.
    #[test]
    fn the_kernel_walks_instances_as_its_mirror_does() {
        let gpu = crate::tests::common::gpu();
        let mut precisions = vec![(crate::Precision::F32, 1e-5, 1e-4)];
        if gpu.has_f64() {
            precisions.push((crate::Precision::F64, 1e-12, 1e-12));
        }
        // Also at a kernel unit of 2^40, which the instances' maps compose.
        let scenes = [
            placed_scene([64, 48]),
            placed_scene([64, 48]).scaled_by_pow2(40),
        ];
        let cases = scenes
            .iter()
            .flat_map(|s| precisions.iter().map(move |p| (s, *p)));
        for (scene, (precision, distance, normal)) in cases {
            let scene = scene.clone();
            let options = RenderOptions {
                precision: Some(precision),
                tuning: crate::Tuning {
                    packets: Some(false),
                    ..crate::Tuning::default()
                },
                timed: true,
                ..RenderOptions::default()
            };
            let variant = options
                .request()
                .kernel_variant(gpu, &scene, options.mode(crate::Device::Gpu))
                .unwrap();
            assert!(variant.instances, "{precision:?}");
            let on_gpu = gpu.render(&scene, &options).unwrap();
            let on_cpu = Cpu.render(&scene, &options).unwrap();
            let (a, b) = (widened(on_gpu), widened(on_cpu));
            assert_eq!(a.0, b.0, "{precision:?}");
            for k in (0..a.0.len()).filter(|&k| a.0[k] >= 0) {
                let d = b.1[k];
                assert!(
                    (a.1[k] - d).abs() <= distance * d,
                    "{precision:?} pixel {k}"
                );
                let off = (0..3)
                    .map(|j| (a.2[k][j] - b.2[k][j]).abs())
                    .fold(0.0, f64::max);
                assert!(
                    off <= normal,
                    "{precision:?} pixel {k}: {:?} {:?}",
                    a.2[k],
                    b.2[k]
                );
            }
            for object in [1, 3, 5] {
                assert!(
                    a.0.contains(&object),
                    "{precision:?}: instance {object} seen"
                );
            }
        }
    }

    /// A render's ids, distances and normals, in f64.
    #[allow(clippy::type_complexity)]
    fn widened(images: crate::AnyImages) -> (Vec<i32>, Vec<f64>, Vec<[f64; 3]>) {
        match images {
            crate::AnyImages::F32(i) => (
                i.id,
                i.distance.into_iter().map(f64::from).collect(),
                i.normal.into_iter().map(|n| n.map(f64::from)).collect(),
            ),
            crate::AnyImages::F64(i) => (i.id, i.distance, i.normal),
        }
    }

    /// 100 copies of a 60-triangle mesh at seeded random poses (rotations about random axes,
    /// non-uniform scales, translations up to 1e3), seen from 4,000 away.
    fn hundred_copies() -> Scene {
        let camera = r#"{"eye": [0, 0, 4000], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 40,
            "resolution": [128, 96]}"#;
        let scale = |_, rng: &mut crate::tests::common::Rng| [0; 3].map(|_| rng.range(60.0, 200.0));
        sheet_copies([100, 60], 7, 1e3, scale, camera)
    }

    /// 40 copies of a sheet, each squashed along one axis by 10^-1 to 10^-4 and turned at
    /// random: maps whose rounding moves a ray's shear far more than a rotation's does, some
    /// beyond what certainty.wgsl's `PLACED_SKEW_LIMIT` lets the mesh's boxes absorb.
    fn squashed_copies() -> Scene {
        let camera = r#"{"eye": [0.3, 0.2, 5], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 45,
            "resolution": [96, 72]}"#;
        let scale = |k: usize, _: &mut crate::tests::common::Rng| {
            let mut scale = [1.0; 3];
            scale[k % 3] = 10f64.powi(-1 - (k as i32 / 3) % 4);
            scale
        };
        sheet_copies([40, 80], 11, 1.5, scale, camera)
    }

    /// `count` copies of a sheet of `triangles` triangles, seen by `camera` (the scene
    /// format's): copy k turned about a random axis, scaled by `scale(k, ..)` and moved by up
    /// to `reach` along each axis, from the seed `seed`.
    fn sheet_copies(
        [count, triangles]: [usize; 2],
        seed: u64,
        reach: f64,
        scale: impl Fn(usize, &mut crate::tests::common::Rng) -> [f64; 3],
        camera: &str,
    ) -> Scene {
        let mut rng = crate::tests::common::Rng(seed);
        let objects: Vec<String> = (0..count)
            .map(|k| {
                let t: Vec<f64> = (0..3).map(|_| rng.range(-reach, reach)).collect();
                let axis: Vec<f64> = (0..3).map(|_| rng.range(-1.0, 1.0)).collect();
                let scale = scale(k, &mut rng);
                format!(
                    r#"{{"type": "instance", "mesh": "a", "transform": {{"translate": {t:?},
                        "rotate": {{"axis": {axis:?}, "degrees": {}}}, "scale": {scale:?}}}}}"#,
                    rng.range(0.0, 360.0)
                )
            })
            .collect();
        let json = format!(
            r#"{{"camera": {camera}, "meshes": {{"a": {{"obj": "a.obj"}}}}, "objects": [{}]}}"#,
            objects.join(",")
        );
        Scene::from_json(&json, std::path::Path::new("s.json"), &mut |_, _| {
            Ok(crate::scene::MeshPart::whole(sheet(triangles)))
        })
        .unwrap()
    }

    /// Triangles squashed to slivers 10^-3 high, turned 40 degrees about their long edge and
    /// seen face on, so closely that a pixel is about 10^-7 of the distance: moving a ray into
    /// its mesh stretches the rounding of the ray's height by 10^3, and the pixels along the
    /// edge decide hit or miss by less than that.
    fn zoomed_sliver() -> Scene {
        let (sin, cos) = 40f64.to_radians().sin_cos();
        let json = format!(
            r#"{{"camera": {{"eye": [0.5, {}, {}], "look_at": [0.5, 0, 0], "up": [0, {cos}, {sin}],
                "fov": 0.00009, "resolution": [64, 48]}},
              "meshes": {{"a": {{"obj": "a.obj"}}}},
              "objects": [{{"type": "instance", "mesh": "a", "transform": {{
                "rotate": {{"axis": [1, 0, 0], "degrees": 40}}, "scale": [1, 0.001, 1]}}}}]}}"#,
            -3.0 * sin,
            3.0 * cos
        );
        Scene::from_json(&json, std::path::Path::new("s.json"), &mut |_, _| {
            // Sixteen along the edge: enough for a tree.
            let along = |k: usize| DVec3::X * (k as f64 / 16.0);
            let fan = (0..16).map(|k| [along(k), along(k + 1), along(k) + DVec3::Y]);
            Ok(crate::scene::MeshPart::whole(fan.collect()))
        })
        .unwrap()
    }

    /// Adaptive precision walks the instances in their meshes, its certainty pass counting the
    /// maps' rounding, and gives the flattened scene's f64 ids on every pixel, its uncertain
    /// pixels cast again on the CPU and (on two of them, where the GPU has f64) on the GPU.
    #[test]
    fn adaptive_renders_through_instances_give_the_flattened_scenes_f64_ids() {
        use crate::render::adaptive;
        let gpu = crate::tests::common::gpu();
        let scenes = [
            ("placed", placed_scene([64, 48])),
            ("hundred", hundred_copies()),
            ("scaled", placed_scene([64, 48]).scaled_by_pow2(40)),
            ("squashed", squashed_copies()),
            ("sliver", zoomed_sliver()),
        ];
        for (name, scene) in scenes {
            // Ray by ray, as hardware GPUs cast (lavapipe casts these many rays in packets).
            let variant = crate::gpu::shader::Variant {
                packets: false,
                ..adaptive::certainty_variant(gpu, &scene)
            }
            .with_instances(&scene);
            assert!(variant.instances, "{name}");
            let flattened = Scene {
                instances: Vec::new(),
                ..scene.clone()
            };
            let flat: Images<f64> = crate::cpu::render_prepared(
                &crate::prepare::Prepared::new(&flattened, Algorithm::Robust, Search::Bvh),
                &std::sync::atomic::AtomicU32::new(0),
            );
            // The GPU's f64 recast (a kernel compiled per scene) on the mixed scene and the
            // sliver, re-cast wholly.
            let on_gpu = (gpu.has_f64() && matches!(name, "placed" | "sliver")).then_some(0);
            for cpu_recast in [Some(usize::MAX), on_gpu].into_iter().flatten() {
                let (first, prepared) =
                    adaptive::certainty_pass_as(gpu, &scene, variant, false).unwrap();
                assert!(prepared.walks_instances(), "{name}");
                // The sliver's f32 pass alone gets some pixels wrong: its certainty is tested.
                let f32_wrong = (0..flat.id.len()).filter(|&k| first.images.id[k] != flat.id[k]);
                assert!(name != "sliver" || f32_wrong.count() > 0);
                let a = adaptive::recast(gpu, &scene, first, &prepared, false, cpu_recast).unwrap();
                let wrong = (0..flat.id.len()).filter(|&k| a.images.id[k] != flat.id[k]);
                assert_eq!(
                    wrong.count(),
                    0,
                    "{name}, recast on the GPU: {}",
                    a.recast_on_gpu
                );
                println!(
                    "{name}: {:.4} recast (on the GPU: {})",
                    a.recast_fraction(),
                    a.recast_on_gpu
                );
            }
        }
    }

    /// A scene file's instances committed for queries ([`crate::Geometry::from_scene`]) give
    /// the flattened scene's hits, ray for ray.
    #[test]
    fn queries_of_a_scene_of_instances_are_the_flattened_scenes() {
        let scene = placed_scene([8, 6]);
        let flattened = Scene {
            instances: Vec::new(),
            ..scene.clone()
        };
        let rays: Vec<crate::Ray> = (0..400)
            .map(|k| crate::Ray {
                origin: scene.camera.eye,
                direction: DVec3::new(
                    (k % 20) as f64 * 0.2 - 2.5,
                    (k / 20) as f64 * 0.2 - 2.2,
                    -6.0,
                ),
            })
            .collect();
        let cast = |scene: &Scene| {
            let accel = Cpu
                .commit(&crate::Geometry::from_scene(scene), crate::Precision::F64)
                .unwrap();
            let hits = accel.intersect(&rays[..]).unwrap();
            (hits.id().to_vec(), hits.t_f64())
        };
        let (ids, t) = cast(&scene);
        assert_eq!((ids.clone(), t), cast(&flattened));
        assert!([1, 3, 5].iter().all(|o| ids.contains(o)), "{ids:?}");
    }

    /// A pose builds the joined tree again from the trees kept: the meshes' and the other
    /// objects', built at the first render; and renders as the scene placed so.
    #[test]
    fn a_pose_keeps_the_meshes_and_the_other_objects_trees() {
        let scene = placed_scene([32, 24]);
        let mut viewer = crate::Viewer::from(scene.clone());
        let camera = scene.camera.clone();
        viewer.render(camera.clone(), joined_render::<f64>);
        let rest = viewer
            .shared()
            .rest()
            .cloned()
            .expect("the other objects' tree is kept");
        let joined = viewer
            .shared()
            .topology()
            .cloned()
            .expect("the joined tree is kept");
        let moved = glam::DAffine3::from_translation(DVec3::new(0.3, -0.2, 0.1));
        viewer.pose(&[(5, moved)]).unwrap();
        assert!(
            viewer.shared().topology().is_none(),
            "a pose forgets the joined tree"
        );
        let seen = viewer.render(camera, joined_render::<f64>);
        assert!(Arc::ptr_eq(&rest, viewer.shared().rest().unwrap()));
        assert!(!Arc::ptr_eq(&joined, viewer.shared().topology().unwrap()));
        let mut placed = scene.clone();
        let p = (placed.instances.iter_mut())
            .find(|p| p.object == 5)
            .unwrap();
        p.transform = moved;
        placed.objects[5] = Object::Soup {
            path: p.mesh.path.clone(),
            triangles: crate::scene::place(&p.mesh.triangles, &moved),
        };
        assert_eq!(seen, joined_render(&placed));
    }

    /// A placement whose object no longer is its mesh's soup is built as any soup.
    #[test]
    fn a_changed_object_is_no_longer_an_instance() {
        let mut scene = placed_scene([8, 6]);
        let Object::Soup { triangles, .. } = &mut scene.objects[1] else {
            panic!("object 1 is a soup")
        };
        triangles.pop();
        assert_eq!(placements(&scene).len(), 2);
        scene.objects.truncate(1);
        assert!(build(&scene).is_none());
    }
}
