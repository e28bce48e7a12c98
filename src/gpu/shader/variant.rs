//! What a kernel is specialized for: a [`Variant`] (precision, algorithm, which rays it casts
//! and what it answers, the primitive kinds, the traversal, the outputs, a shade hook) and the
//! names its `#if` blocks test ([`Variant::defines`]), which the preprocessor
//! (preprocess.rs) assembles the kernel's WGSL by.

use super::super::source::SourceKey;
use crate::algorithm::Algorithm;
use crate::images::Outputs;
use crate::math::Float;

/// The primitive kinds a kernel is compiled for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) struct Kinds {
    pub spheres: bool,
    pub planes: bool,
    pub triangles: bool,
}

impl Kinds {
    /// Every kind: the general kernel.
    pub(crate) const ALL: Kinds = Kinds {
        spheres: true,
        planes: true,
        triangles: true,
    };

    /// The kinds `scene` has (a soup counts as triangles when it has any).
    pub(crate) fn of_scene(scene: &crate::scene::Scene) -> Kinds {
        use crate::scene::Object;
        let mut k = Kinds {
            spheres: false,
            planes: false,
            triangles: false,
        };
        for object in &scene.objects {
            match object {
                Object::Sphere { .. } => k.spheres = true,
                Object::Plane { .. } => k.planes = true,
                Object::Triangle { .. } => k.triangles = true,
                Object::Soup { triangles, .. } => k.triangles |= !triangles.is_empty(),
            }
        }
        k
    }

    #[cfg(test)]
    pub(crate) fn any(&self) -> bool {
        self.spheres || self.planes || self.triangles
    }
}

/// Which rays a kernel casts (`main` in shaders/entry.wgsl).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum Casts {
    /// The camera's ray through every pixel, in tiles of image rows.
    Camera,
    /// The camera's rays of listed pixels (`PIXEL_LIST`, binding `pixel_list`).
    Pixels,
    /// A caller's rays, origin and direction each (`RAY_LIST`, binding `ray_list`), with every
    /// per-ray output: also the primitive index and barycentrics of the hit.
    Rays,
}

/// What a kernel is specialized for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) struct Variant {
    pub precision: Float,
    pub algorithm: Algorithm,
    /// The device has f64 shaders: an f32 robust kernel rechecks near-zero triangle edge
    /// functions exactly in f64.
    pub f64_available: bool,
    /// The device has 64-bit integers: a kernel that loads per ray loads its nodes and
    /// triangles as 64-bit words ([`Variant::wide_loads`]).
    pub int64_available: bool,
    /// Also decide, per pixel, whether hit/miss and id are certain (robust set only; the
    /// first pass of adaptive precision).
    pub certainty: bool,
    /// Which rays the kernel casts: the camera's over tiles of rows, the camera's for a list of
    /// pixels (the re-cast of adaptive precision), or a caller's list of rays.
    pub casts: Casts,
    /// Count every intersection along each ray instead of finding the nearest (`COUNT`; ray
    /// lists only: `out_count`).
    pub count: bool,
    /// Find the primitive nearest each listed ray's origin instead of a hit (`CLOSEST`; ray
    /// lists only, their directions unused): `out_surface` holds the closest point and its
    /// distance, `out_primitive` and `out_uv` its primitive and barycentrics.
    pub closest: bool,
    /// Answer whether each ray hits anything from `min_t` to `params.max_t` instead of its
    /// nearest hit (`OCCLUDED`; ray lists only: `out_occluded`, one word a ray).
    pub occluded: bool,
    /// Every ray starts at the kernel's origin: the camera's rays (or listed pixels') of a
    /// perspective camera whose eye is that origin, as in the robust set
    /// ([`crate::gpu::Gpu::scene_variant`]; the dispatch clears it for a caller's rays, or where
    /// `crate::prepare::Prepared::camera_rays_from_origin` does not hold). The kernel then
    /// makes each ray's origin the constant zero (`RAYS_FROM_ORIGIN`, shaders/frame.wgsl).
    pub rays_from_origin: bool,
    /// Every ray of a caller's list starts at the same point, the first one's origin
    /// ([`crate::rays::one_origin`]; the dispatch clears it for other sources). The kernel reads
    /// that origin once for all of them, and a packet's origins as that one point (`LIST_ORIGIN`,
    /// shaders/bindings.wgsl `listed_origin`), as the camera's are the constant zero.
    pub list_origin: bool,
    /// The primitive kinds compiled in; code for the others is left out.
    pub kinds: Kinds,
    /// Spheres and triangles are found through a BVH (src/prepare/bvh.rs) instead of brute force.
    pub bvh: bool,
    /// The BVH names the scene's instances, each mesh held once in its own coordinates, and
    /// the traversal (ray by ray) moves rays into them (`INSTANCES`; #64,
    /// [`Variant::with_instances`]).
    pub instances: bool,
    /// The device has subgroups of at least 8 invocations: the rays of a subgroup traverse the
    /// BVH together, sharing node fetches ([`Variant::uses_packets`]).
    pub packets: bool,
    /// Subgroups are exactly `crate::gpu::PACKET_LANES` invocations: packets vote by butterflies of
    /// constant-xor shuffles (`EIGHT_LANES`, shaders/traverse_packet.wgsl `packet_any`), which llvmpipe
    /// compiles to permutes instead of a loop over the lanes.
    pub eight_lanes: bool,
    /// The most rays a lane casts ([`Variant::lane_rays`]): [`MAX_LANE_RAYS`], or fewer for a
    /// render too small to repay a longer kernel's compile ([`Variant::for_rays`]).
    pub lane_rays_limit: u8,
    /// Storage bindings the triangles, and the BVH nodes, are split into (1 to
    /// `MAX_CHUNKS`): meshes larger than one binding.
    pub chunks: u8,
    /// log2 of the triangles (or nodes) per chunk.
    pub chunk_bits: u8,
    /// Entries of the BVH traversal's stack (`BVH_STACK`): `prepare::bvh::MAX_DEPTH`
    /// until the dispatch sizes it to the prepared tree ([`crate::prepare::bvh::Bvh::stack_entries`]).
    /// WGSL zero-fills the stack of every invocation, so entries the tree cannot use cost time
    /// (docs/experiments.md#why-packets-share-fetches-by-hand).
    pub bvh_stack: u8,
    /// The scene's planes, where there are 1 to [`MAX_CONSTANT_PLANES`] (`CONSTANT_PLANES`,
    /// `PLANE_COUNT`), else 0 (a loop to `params.plane_count`). Loops over the planes then
    /// have a constant trip count, which lavapipe unrolls into loads at constant offsets, one
    /// scalar load each rather than a loop over the lanes (docs/performance.md#specialization).
    pub planes: u8,
    /// What the kernel computes and writes: `id` (`out_id`), `distance` and `normal`
    /// (`out_surface`; the distance alone `out_distance`), `color` (`out_color`, the shade hook's; set exactly when `shade` is);
    /// the rest is left out.
    pub outputs: Outputs,
    /// The user's shade hook compiled in (its source is registered in [`crate::gpu::hooks`] under this
    /// key), called for every pixel to write `out_color`.
    pub shade: Option<SourceKey>,
    /// The shade hook casts rays of its own (`trace`, `occluded`: `HOOK_RAYS`,
    /// shaders/shade.wgsl). With packets, a hook's ray is cast in a packet of its subgroup's
    /// where every lane of it casts one at the same call, and ray by ray where some lane does
    /// not: a packet's node fetches and votes need every lane (`RAY_BY_RAY`).
    pub hook_rays: bool,
    /// A complete kernel from the user (`render --kernel FILE`, [`crate::gpu::kernel`]) runs instead
    /// of the assembled one: its source is registered under this key, and the rest of the
    /// variant says what the host binds and reads back for it.
    pub kernel: Option<SourceKey>,
    /// Compiled as given: the dispatch neither sizes the traversal stack nor fixes the plane
    /// loops to the scene it renders, so that one kernel serves many scenes (tests comparing
    /// traversals over many scenes; each kernel is a compile). The stack must still hold the
    /// scene's tree and a constant plane count match its planes ([`crate::gpu::dispatch`]
    /// checks both).
    pub as_given: bool,
}

/// The most rays a lane of a packet kernel casts ([`Variant::lane_rays`]).
pub(crate) const MAX_LANE_RAYS: u8 = 8;
/// Renders of at least this many rays cast four rays a lane ([`Variant::for_rays`]): 1920x1080
/// and more.
pub(crate) const FOUR_LANE_RAYS: u64 = 2_000_000;
/// Renders of at least this many rays cast eight rays a lane ([`Variant::for_rays`]): 3840x2160
/// and more.
pub(crate) const EIGHT_LANE_RAYS: u64 = 8_000_000;

/// The most planes a kernel is compiled for the number of ([`Variant::planes`]).
pub(crate) const MAX_CONSTANT_PLANES: usize = 8;

/// The most chunks a kernel binds for triangles, and for nodes.
pub(crate) const MAX_CHUNKS: u8 = 4;

/// The chunks `scene`'s triangles and BVH nodes need at `chunk_bits` (a BVH over n
/// primitives has fewer than n nodes), at most `MAX_CHUNKS`: a scene needing more is refused
/// before rendering.
pub(crate) fn chunks_for(scene: &crate::scene::Scene, chunk_bits: u8) -> u8 {
    let n = crate::prepare::bvh::bounded_count(scene).max(1) as u64;
    n.div_ceil(1 << chunk_bits).min(MAX_CHUNKS as u64) as u8
}

/// log2 of the elements per chunk for a device whose storage bindings hold `max_binding`
/// bytes: every chunk of BVH nodes (64 bytes) or triangles (40 bytes in f32, 80 in f64) fits
/// one binding.
pub(crate) fn chunk_bits_for(max_binding: u64, precision: Float) -> u8 {
    use crate::kernel::layout::GpuTriangle;
    let node = size_of::<crate::prepare::bvh::BvhNode>();
    let largest = match precision {
        Float::F32 => node.max(size_of::<GpuTriangle<f32>>()),
        Float::F64 => node.max(size_of::<GpuTriangle<f64>>()),
    } as u64;
    (max_binding / largest).max(1).ilog2().min(31) as u8
}

impl Variant {
    pub(crate) fn new(precision: Float, algorithm: Algorithm) -> Variant {
        Variant {
            precision,
            algorithm,
            f64_available: true,
            int64_available: false,
            certainty: false,
            casts: Casts::Camera,
            count: false,
            closest: false,
            occluded: false,
            rays_from_origin: false,
            list_origin: false,
            kinds: Kinds::ALL,
            bvh: false,
            instances: false,
            packets: false,
            eight_lanes: false,
            lane_rays_limit: MAX_LANE_RAYS,
            chunks: 1,
            chunk_bits: chunk_bits_for(128 << 20, precision),
            bvh_stack: crate::prepare::bvh::MAX_DEPTH as u8,
            planes: 0,
            outputs: Outputs::GEOMETRY,
            shade: None,
            hook_rays: false,
            kernel: None,
            as_given: false,
        }
    }

    /// This variant with the traversal stack `bvh` needs (MAX_DEPTH entries without one).
    pub(crate) fn with_stack_for(self, bvh: Option<&crate::prepare::bvh::Bvh>) -> Variant {
        Variant {
            bvh_stack: bvh.map_or(crate::prepare::bvh::MAX_DEPTH as u8, |b| b.stack_entries()),
            ..self
        }
    }

    /// This variant compiled for a scene of `planes` planes ([`Variant::planes`]).
    pub(crate) fn with_planes(self, planes: usize) -> Variant {
        Variant {
            planes: if planes <= MAX_CONSTANT_PLANES {
                planes as u8
            } else {
                0
            },
            ..self
        }
    }

    /// This variant compiled for `kinds` only.
    pub(crate) fn with_kinds(self, kinds: Kinds) -> Variant {
        Variant { kinds, ..self }
    }

    /// This variant writing only `outputs` (`color` only where a shade hook is set; without
    /// `color` the hook is dropped).
    pub(crate) fn with_outputs(self, outputs: Outputs) -> Variant {
        let color = outputs.color && self.shade.is_some();
        Variant {
            outputs: Outputs { color, ..outputs },
            shade: self.shade.filter(|_| color),
            hook_rays: self.hook_rays && color,
            ..self
        }
    }

    /// This variant calling the shade hook registered under `key` for every pixel and writing
    /// its colour; `traces`: the hook casts rays ([`Variant::hook_rays`]).
    pub(crate) fn with_shade(self, key: SourceKey, traces: bool) -> Variant {
        Variant {
            shade: Some(key),
            hook_rays: traces,
            outputs: Outputs {
                color: true,
                ..self.outputs
            },
            ..self
        }
    }

    /// The names `#if` tests: `F64` (real is f64), `ROBUST`, `RECHECK_F64` (robust f32
    /// kernel on a device with f64), `CERTAINTY` (robust, with the certainty test),
    /// `PIXEL_LIST` (cast listed pixels only), `RAY_LIST` (cast a caller's rays), `COUNT`
    /// (count intersections), `OCCLUDED` (whether anything is hit up to `max_t`), `RAYS_FROM_ORIGIN` (every ray starts at the kernel's origin),
    /// `LIST_ORIGIN` (every listed ray starts at the first one's origin), `SPHERES`, `PLANES`,
    /// `TRIANGLES` (kinds compiled in), `BVH` (spheres and triangles through the BVH),
    /// `RAY_BY_RAY` (BVH traversed ray by ray: no packets, or a hook's rays where its subgroup
    /// is not whole), `PACKETS` (BVH traversed by subgroups together,
    /// [`Variant::uses_packets`]), `EIGHT_LANES` (packets of subgroups of exactly 8),
    /// `WIDE_LOADS` and `WIDE_TRIANGLES` (nodes, and f32 triangles, loaded as 64-bit words,
    /// [`Variant::wide_loads`]),
    /// `CHUNKS_2..4` (triangles and nodes in several bindings), `CONSTANT_PLANES` (loops over
    /// the planes to `PLANE_COUNT`), and for the outputs: `ID` (`out_id` written), `SURFACE`
    /// (`out_surface` written: the normal asked for, with the distance), `DISTANCE_ALONE`
    /// (`out_distance` written: the distance without the normal), `NORMAL` and `DISTANCE`
    /// (computed: asked for, or for the hook), `USER_SHADE` (the shade hook is called and
    /// `out_color` written), `HOOK_RAYS` (and casts rays of its own).
    pub(crate) fn defines(&self) -> Vec<&'static str> {
        let mut d = Vec::new();
        let o = self.outputs;
        let shade = self.shade.is_some() && o.color;
        let hook_rays = shade && self.hook_rays;
        if self.precision == Float::F64 {
            d.push("F64");
        }
        if self.algorithm == Algorithm::Robust {
            d.push("ROBUST");
            if self.precision == Float::F32 && self.f64_available {
                d.push("RECHECK_F64");
            }
            if self.certainty {
                d.push("CERTAINTY");
            }
        }
        match self.casts {
            Casts::Camera => {}
            Casts::Pixels => d.push("PIXEL_LIST"),
            Casts::Rays => d.push("RAY_LIST"),
        }
        if self.count {
            d.push("COUNT");
        }
        if self.closest {
            d.push("CLOSEST");
        }
        if self.occluded {
            d.push("OCCLUDED");
        }
        if self.rays_from_origin {
            d.push("RAYS_FROM_ORIGIN");
        }
        if self.list_origin && self.casts == Casts::Rays {
            d.push("LIST_ORIGIN");
        }
        if self.planes > 0 {
            d.push("CONSTANT_PLANES");
        }
        for (k, name) in [(2, "CHUNKS_2"), (3, "CHUNKS_3"), (4, "CHUNKS_4")] {
            if self.chunks >= k {
                d.push(name);
            }
        }
        if self.uses_bvh() {
            d.push("BVH");
            if self.instances {
                d.push("INSTANCES");
            }
            if !self.uses_packets() || hook_rays {
                d.push("RAY_BY_RAY");
            }
            if self.wide_loads() {
                d.push("WIDE_LOADS");
            }
            if self.uses_packets() {
                d.push("PACKETS");
                if self.eight_lanes {
                    d.push("EIGHT_LANES");
                }
                if self.lane_rays() > 1 {
                    d.push("LANES");
                }
            }
        }
        if self.wide_loads() && self.precision == Float::F32 {
            d.push("WIDE_TRIANGLES");
        }
        for (present, name) in [
            (self.kinds.spheres, "SPHERES"),
            (self.kinds.planes, "PLANES"),
            (self.kinds.triangles, "TRIANGLES"),
        ] {
            if present {
                d.push(name);
            }
        }
        for (present, name) in [
            (o.id, "ID"),
            (o.normal, "SURFACE"),
            (o.distance && !o.normal, "DISTANCE_ALONE"),
            (o.normal || shade, "NORMAL"),
            (o.distance || shade, "DISTANCE"),
            (shade, "USER_SHADE"),
            (hook_rays, "HOOK_RAYS"),
        ] {
            if present {
                d.push(name);
            }
        }
        d
    }
}

impl Variant {
    /// Whether the kernel traverses a BVH: asked for, and something bounded to put in it.
    pub(crate) fn uses_bvh(&self) -> bool {
        self.bvh && (self.kinds.spheres || self.kinds.triangles)
    }

    /// How the scene is prepared for this kernel: through a BVH exactly when it traverses one.
    pub(crate) fn search(&self) -> crate::prepare::bvh::Search {
        match self.uses_bvh() {
            true => crate::prepare::bvh::Search::Bvh,
            false => crate::prepare::bvh::Search::BruteForce,
        }
    }

    /// Whether the kernel is assembled from shaders/ alone: no user hook, no user kernel. Only
    /// such kernels are compiled without wgpu's runtime checks (`create_pipeline`).
    pub(crate) fn is_ours(&self) -> bool {
        self.shade.is_none() && self.kernel.is_none()
    }

    /// Whether the BVH is traversed by packets: asked for, through a BVH, and over image tiles,
    /// whose neighbouring pixels have coherent rays, or over a caller's rays (whose owner says
    /// whether they are coherent), for the nearest hit. Listed pixels are scattered.
    pub(crate) fn uses_packets(&self) -> bool {
        let coherent = match self.casts {
            Casts::Camera => true,
            Casts::Rays => !self.count && !self.closest,
            Casts::Pixels => false,
        };
        self.packets && self.uses_bvh() && coherent && !self.instances
    }

    /// This variant walking `scene`'s instances in their meshes' coordinates
    /// ([`Variant::instances`]) where it places meshes and the kernel finds nearest hits ray by
    /// ray: the camera's, listed pixels' and a caller's rays, the certainty pass too
    /// (certainty.wgsl's `place_certainty` counts the map's rounding). Not packets (which would
    /// have to move every lane's ray at once), a user's hook or kernel, or a count, closest-point
    /// or occlusion kernel.
    pub(crate) fn with_instances(self, scene: &crate::scene::Scene) -> Variant {
        let instances = !scene.instances.is_empty()
            && self.uses_bvh()
            && !self.uses_packets()
            && self.is_ours()
            && !(self.count || self.closest || self.occluded);
        Variant { instances, ..self }
    }

    /// Whether the kernel loads BVH nodes, and in f32 triangles, as 64-bit words (`WIDE_LOADS`,
    /// `WIDE_TRIANGLES`, shaders/bindings.wgsl): where it loads them per ray, without packets,
    /// and assembled from shaders/ alone (a user's hook may read the bindings). On llvmpipe each
    /// load of a per-lane offset is a loop over the lanes, so a node in two loads rather than
    /// four and a triangle in three rather than five cost fewer loops
    /// (docs/performance.md#incoherent-rays).
    pub(crate) fn wide_loads(&self) -> bool {
        self.int64_available && !self.uses_packets() && self.is_ours()
    }

    /// How many rays each invocation casts, so that a packet is 8 times that many and every
    /// node and primitive fetched serves them all (`LANES`, `LANE_RAYS`,
    /// shaders/traverse_lanes.wgsl `traverse_bvh_lanes`): wherever packets are used (the camera's rays, a caller's) on
    /// subgroups of exactly 8, eight (one subgroup in eight then casts the rays of its whole
    /// workgroup, 8x8 pixels of the camera's), or two with the certainty pass, which keeps each
    /// ray's record in private state and swaps the second's in around its work; else one.
    /// With packet intervals a visit costs the same whatever the packet's size, so the more
    /// rays share it the better (docs/performance.md#eight-rays-a-lane).
    /// At most `lane_rays_limit` ([`Variant::for_rays`]).
    pub(crate) fn lane_rays(&self) -> u32 {
        let most = match (self.uses_packets() && self.eight_lanes, self.certainty) {
            (false, _) => 1,
            // A hook's rays go one a lane: more would lengthen its kernel for no gain on its
            // camera rays (docs/experiments.md#a-hooks-rays).
            _ if self.hook_rays => 1,
            // With its records swapped per ray, the certainty pass's kernel grows faster per
            // ray: one ray a lane where a render is too small for four.
            (true, true) if self.lane_rays_limit < 4 => 1,
            (true, true) => 2,
            (true, false) => MAX_LANE_RAYS as u32,
        };
        most.min(self.lane_rays_limit.max(1) as u32)
    }

    /// This variant for a render of `rays` rays in one process: at most two rays a lane below
    /// `FOUR_LANE_RAYS` rays (the certainty pass one), four below `EIGHT_LANE_RAYS`, else
    /// eight (the certainty pass two). Each ray a lane lengthens the kernel that llvmpipe
    /// translates in every process, even with Mesa's shader cache warm, which only a render of
    /// many rays repays (docs/performance.md#eight-rays-a-lane).
    /// `raycast bench`, Python's casts and ray lists keep eight: they trace the same kernel
    /// many times.
    pub(crate) fn for_rays(self, rays: u64) -> Variant {
        let lane_rays_limit = match rays {
            r if r < FOUR_LANE_RAYS => 2,
            r if r < EIGHT_LANE_RAYS => 4,
            _ => MAX_LANE_RAYS,
        };
        let limited = Variant {
            lane_rays_limit,
            ..self
        };
        // Only where the kernel changes, so that one kernel has one key in the pipeline cache.
        match limited.lane_rays() == self.lane_rays() {
            true => self,
            false => limited,
        }
    }
}

/// Every variant a device may build: both precisions, both algorithms, with and without f64
/// (and 64-bit integers: [`Variant::wide_loads`]), the robust ones with and without the certainty test, and the list ones, with and
/// without a BVH (per ray, and where they may, [`Variant::uses_packets`], by packets, with
/// subgroup votes or on 8-lane subgroups) and in one or several chunks; the plain ones also with each output alone
/// and with none.
#[cfg(test)]
pub(crate) fn all_variants() -> Vec<Variant> {
    let mut v = Vec::new();
    for precision in [Float::F32, Float::F64] {
        for algorithm in [Algorithm::Textbook, Algorithm::Robust] {
            for f64_available in [true, false] {
                // A caller's rays from many points, and from one (a pinhole camera's).
                // The list's query: nearest hit, count, closest primitive or occlusion.
                let [nearest, count, closest, occluded] = [
                    (false, false, false),
                    (true, false, false),
                    (false, true, false),
                    (false, false, true),
                ];
                for (certainty, casts, (count, closest, occluded), list_origin) in [
                    (false, Casts::Camera, nearest, false),
                    (true, Casts::Camera, nearest, false),
                    (false, Casts::Pixels, nearest, false),
                    (false, Casts::Rays, nearest, false),
                    (false, Casts::Rays, nearest, true),
                    (true, Casts::Rays, nearest, true),
                    (false, Casts::Rays, count, true),
                    (false, Casts::Rays, closest, false),
                    (false, Casts::Rays, closest, true),
                    (false, Casts::Rays, occluded, false),
                    (false, Casts::Rays, occluded, true),
                ] {
                    let impossible = precision == Float::F64 && !f64_available;
                    if impossible || certainty && algorithm != Algorithm::Robust {
                        continue;
                    }
                    let plain = Variant {
                        precision,
                        algorithm,
                        f64_available,
                        // With f64 and without: the per-ray kernels with WIDE_LOADS and
                        // without each go through the whole matrix.
                        int64_available: f64_available,
                        certainty,
                        casts,
                        count,
                        closest,
                        occluded,
                        // As robust perspective renders set it (the textbook set covers the
                        // camera's general rays).
                        rays_from_origin: casts != Casts::Rays && algorithm == Algorithm::Robust,
                        list_origin,
                        kinds: Kinds::ALL,
                        bvh: false,
                        instances: false,
                        packets: false,
                        eight_lanes: false,
                        lane_rays_limit: MAX_LANE_RAYS,
                        chunks: 1,
                        chunk_bits: 9,
                        bvh_stack: crate::prepare::bvh::MAX_DEPTH as u8,
                        planes: 0,
                        outputs: Outputs::GEOMETRY,
                        shade: None,
                        hook_rays: false,
                        kernel: None,
                        as_given: false,
                    };
                    let traversals = [
                        (false, false, false),
                        (true, false, false),
                        (true, true, false),
                        (true, true, true),
                    ];
                    let listed = casts != Casts::Camera;
                    let probe = Variant {
                        bvh: true,
                        packets: true,
                        ..plain
                    };
                    let traversals = &traversals[..if probe.uses_packets() { 4 } else { 2 }];
                    for &(bvh, packets, eight_lanes) in traversals {
                        // Closest-point kernels share the chunked loads: one and all chunks.
                        let chunk_counts = [1, 2, MAX_CHUNKS].into_iter();
                        for chunks in chunk_counts.filter(|&c| !closest || c != 2) {
                            // The planes' loops to a constant (Variant::planes) with all chunks.
                            let planes = if chunks == MAX_CHUNKS { 5 } else { 0 };
                            v.push(Variant {
                                bvh,
                                packets,
                                eight_lanes,
                                chunks,
                                planes,
                                ..plain
                            });
                        }
                        // The lighter kernels of smaller renders (Variant::for_rays).
                        for lane_rays_limit in [2, 4].into_iter().filter(|_| eight_lanes) {
                            v.push(Variant {
                                bvh,
                                packets,
                                eight_lanes,
                                lane_rays_limit,
                                ..plain
                            });
                        }
                    }
                    if !(count || closest || occluded) {
                        // Instances walked in their meshes' coordinates, ray by ray, in one
                        // chunk and in all (#64): camera renders, adaptive precision's
                        // certainty pass and its listed pixels cast again, a caller's rays.
                        for chunks in [1, MAX_CHUNKS] {
                            v.push(Variant {
                                bvh: true,
                                instances: true,
                                chunks,
                                ..plain
                            });
                        }
                    }
                    if !certainty && !listed {
                        for outputs in OUTPUT_SUBSETS {
                            v.push(plain.with_outputs(outputs));
                            let bvh = Variant {
                                bvh: true,
                                packets: true,
                                ..plain
                            };
                            v.push(bvh.with_outputs(outputs));
                        }
                    }
                }
            }
        }
    }
    v
}

/// Id, distance and normal each alone, and none of them.
#[cfg(test)]
const OUTPUT_SUBSETS: [Outputs; 4] = [
    Outputs {
        id: true,
        ..Outputs::NONE
    },
    Outputs {
        distance: true,
        ..Outputs::NONE
    },
    Outputs {
        normal: true,
        ..Outputs::NONE
    },
    Outputs::NONE,
];

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::shader::{ENTRY_POINT, kernel_source, validate};

    /// Several rays a lane only where a subgroup of 8 can take its neighbours' rays, for the
    /// camera's rays and a caller's (not their counts): eight, two with the certainty pass (its
    /// record swap serves two); the kernel then traces through the lanes' traversal, with a
    /// field per ray in `LaneRays`.
    #[test]
    fn several_rays_a_lane_only_for_packets_of_eight() {
        let lanes = Variant {
            bvh: true,
            packets: true,
            eight_lanes: true,
            ..Variant::new(Float::F32, Algorithm::Robust)
        };
        let listed = Variant {
            casts: Casts::Rays,
            ..lanes
        };
        let f64 = Variant {
            precision: Float::F64,
            ..lanes
        };
        let certainty = Variant {
            certainty: true,
            ..lanes
        };
        let four = lanes.for_rays(FOUR_LANE_RAYS);
        let two = lanes.for_rays(FOUR_LANE_RAYS - 1);
        let eight = lanes.for_rays(EIGHT_LANE_RAYS);
        let certain_four = certainty.for_rays(FOUR_LANE_RAYS);
        // Kernels of one ray a lane whatever the size keep their key.
        let per_ray = Variant {
            eight_lanes: false,
            ..lanes
        };
        assert_eq!(per_ray.for_rays(1), per_ray);
        let certain_small = certainty.for_rays(FOUR_LANE_RAYS - 1);
        assert_eq!(certain_small.lane_rays(), 1);
        assert!(!certain_small.defines().contains(&"LANES"));
        for (variant, rays) in [
            (lanes, 8),
            (listed, 8),
            (f64, 8),
            (certainty, 2),
            (two, 2),
            (four, 4),
            (eight, 8),
            (lanes.for_rays(EIGHT_LANE_RAYS - 1), 4),
            (certain_four, 2),
        ] {
            assert_eq!(variant.lane_rays(), rays, "{variant:?}");
            assert!(variant.defines().contains(&"LANES"));
            let (module, _) = validate(&kernel_source(&variant).unwrap(), "kernel").unwrap();
            let named = |name: &str| {
                module
                    .functions
                    .iter()
                    .any(|(_, f)| f.name.as_deref() == Some(name))
            };
            assert!(named("traverse_bvh_lanes") && named("nearest_hit_lanes"));
            let fields = module.types.iter().find_map(|(_, t)| match &t.inner {
                naga::TypeInner::Struct { members, .. }
                    if t.name.as_deref() == Some("LaneRays") =>
                {
                    Some(members.len())
                }
                _ => None,
            });
            assert_eq!(fields, Some(rays as usize), "{variant:?}");
        }
        for other in [
            Variant {
                eight_lanes: false,
                ..lanes
            },
            Variant {
                casts: Casts::Rays,
                count: true,
                ..lanes
            },
            Variant {
                casts: Casts::Pixels,
                ..lanes
            },
            Variant {
                bvh: false,
                ..lanes
            },
        ] {
            assert_eq!(other.lane_rays(), 1, "{other:?}");
            assert!(!other.defines().contains(&"LANES"), "{other:?}");
        }
    }

    /// A kernel contains no function of an absent kind (checked on the naga module) and still
    /// validates, for all eight combinations.
    #[test]
    fn absent_kinds_are_not_compiled_in() {
        for bits in 0..8u8 {
            let kinds = Kinds {
                spheres: bits & 1 != 0,
                planes: bits & 2 != 0,
                triangles: bits & 4 != 0,
            };
            for base in [
                Variant::new(Float::F32, Algorithm::Robust),
                Variant::new(Float::F64, Algorithm::Textbook),
                Variant {
                    certainty: true,
                    ..Variant::new(Float::F32, Algorithm::Robust)
                },
            ] {
                let variant = base.with_kinds(kinds);
                let source = kernel_source(&variant).unwrap();
                let (module, _) = validate(&source, format!("{variant:?}")).unwrap();
                let names: Vec<&str> = module
                    .functions
                    .iter()
                    .filter_map(|(_, f)| f.name.as_deref())
                    .collect();
                let globals: Vec<&str> = module
                    .global_variables
                    .iter()
                    .filter_map(|(_, g)| g.name.as_deref())
                    .collect();
                for (present, function, buffer) in [
                    (kinds.spheres, "intersect_sphere", "spheres"),
                    (kinds.planes, "intersect_plane", "planes"),
                    (kinds.triangles, "intersect_triangle", "triangles"),
                ] {
                    assert_eq!(
                        names.contains(&function),
                        present,
                        "{function} in {variant:?}"
                    );
                    assert_eq!(
                        globals.contains(&buffer),
                        present,
                        "{buffer} in {variant:?}"
                    );
                }
            }
        }
    }

    /// The names of the functions the entry point calls, directly or through the functions it
    /// calls (in any nested block).
    fn called_functions(module: &naga::Module) -> Vec<String> {
        type Handles = Vec<naga::Handle<naga::Function>>;
        fn walk(block: &naga::Block, out: &mut Handles) {
            use naga::Statement as S;
            for statement in block.iter() {
                match statement {
                    S::Call { function, .. } => out.push(*function),
                    S::Block(b) => walk(b, out),
                    S::If { accept, reject, .. } => {
                        walk(accept, out);
                        walk(reject, out);
                    }
                    S::Switch { cases, .. } => cases.iter().for_each(|c| walk(&c.body, out)),
                    S::Loop {
                        body, continuing, ..
                    } => {
                        walk(body, out);
                        walk(continuing, out);
                    }
                    _ => {}
                }
            }
        }
        let entry = module
            .entry_points
            .iter()
            .find(|e| e.name == ENTRY_POINT)
            .expect("the kernel has its entry point");
        let mut pending = Vec::new();
        walk(&entry.function.body, &mut pending);
        let mut seen: Handles = Vec::new();
        while let Some(f) = pending.pop() {
            if !seen.contains(&f) {
                seen.push(f);
                walk(&module.functions[f].body, &mut pending);
            }
        }
        seen.iter()
            .filter_map(|&f| module.functions[f].name.clone())
            .collect()
    }

    /// A kernel asked for distances only calls no normal function and binds no id buffer; one
    /// asked for normals does call them (checked on the naga module).
    #[test]
    fn outputs_not_asked_for_are_not_computed() {
        let normal_functions = [
            "hit_normal",
            "sphere_normal",
            "plane_normal",
            "triangle_normal",
        ];
        for base in [
            Variant::new(Float::F32, Algorithm::Robust),
            Variant::new(Float::F64, Algorithm::Textbook),
        ] {
            for (outputs, normals) in [
                (OUTPUT_SUBSETS[1], false), // distance only
                (OUTPUT_SUBSETS[0], false), // id only
                (OUTPUT_SUBSETS[2], true),  // normal only
                (Outputs::GEOMETRY, true),
            ] {
                let variant = base.with_outputs(outputs);
                let (module, _) = validate(&kernel_source(&variant).unwrap(), "kernel").unwrap();
                let called = called_functions(&module);
                let calls = |f: &str| called.iter().any(|c| c == f);
                assert!(calls("nearest_hit"), "{called:?}");
                if normals {
                    assert!(calls("hit_normal"), "{variant:?}");
                } else {
                    for f in normal_functions {
                        assert!(!calls(f), "{f} called in {variant:?}");
                    }
                }
                let globals: Vec<&str> = module
                    .global_variables
                    .iter()
                    .filter_map(|(_, g)| g.name.as_deref())
                    .collect();
                assert_eq!(globals.contains(&"out_id"), outputs.id, "{variant:?}");
                assert_eq!(
                    globals.contains(&"out_surface"),
                    outputs.normal,
                    "{variant:?}"
                );
                assert_eq!(
                    globals.contains(&"out_distance"),
                    outputs.distance && !outputs.normal,
                    "{variant:?}"
                );
            }
        }
    }
}
