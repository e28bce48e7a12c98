//! A caller's rays and their hits: rays given in world coordinates (origin and direction each,
//! as rows of f64 or f32), the hits a nearest-hit cast finds for them ([`Hits`]: `t` in units
//! of the ray's direction, as Open3D's `t_hit`, object id, primitive index, barycentric `u, v`
//! and geometric normal), and the checks and measures of a list (valid rays, one origin,
//! coherence). Casting them is [`crate::Accel`]'s.

use crate::error::{Error, Result};
use crate::images::MISS;
use crate::math::{Real, Vec3, length, normalize};
use glam::DVec3;

/// A ray in world coordinates. Points on it are `origin + t * direction`, `t >= 0`. Laid out
/// as six f64s, so rows of `origin, direction` (a numpy array's) are rays without copying.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Ray {
    /// Where the ray starts.
    pub origin: DVec3,
    /// Its direction, of any non-zero length: `t` is measured in units of it.
    pub direction: DVec3,
}

/// Asks Linux to back the unused capacity of `v` with transparent huge pages (where they are
/// enabled "always" or "madvise", Debian's default): the hits of 2M rays are 66 MB of fresh
/// memory each cast, whose first touches cost far less in 2 MiB pages than in 4 KiB ones
/// (docs/performance.md#ray-lists). Elsewhere, and for vectors under a few huge pages, nothing.
pub(crate) fn huge_pages<T>(v: &Vec<T>) {
    #[cfg(target_os = "linux")]
    {
        const HUGE: usize = 2 << 20;
        let start = v.as_ptr() as usize;
        let end = start + v.capacity() * size_of::<T>();
        let first = start.next_multiple_of(HUGE);
        if end >= first + 2 * HUGE {
            let len = (end - first) / HUGE * HUGE;
            // SAFETY: madvise only advises the kernel how to back these pages; they lie within
            // the vector's allocation, which is neither moved nor freed by it.
            unsafe {
                libc::madvise(first as *mut libc::c_void, len, libc::MADV_HUGEPAGE);
            }
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = v;
}

/// A caller's rays as held: [`Ray`]s, or rows of six f32s (origin, direction), numpy's float32
/// arrays as Open3D takes them, read without converting the list first (numpy's widening
/// copy would be a share of a cast). Each is read as a [`Ray`] (`RayList::get`);
/// f32 widens exactly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum RayRows<'a> {
    /// Rays in f64.
    F64(&'a [Ray]),
    /// Rows of `origin, direction` in f32.
    F32(&'a [[f32; 6]]),
}

/// A caller's rays, and whether they are an image's: row-major rows of `width` rays, as a
/// camera makes them (Open3D's `create_rays_pinhole`). The GPU traces coherent rays in packets
/// ([`Accel::intersect`](crate::Accel::intersect)), an image's in tiles of two rows, as it
/// does a camera's. A plain list is made `from` [`Ray`]s, or from rows of six f32s (origin,
/// direction: numpy's float32 arrays as Open3D takes them), which are read as they are held,
/// without converting the list first (numpy's widening copy would be a share of a cast).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayList<'a> {
    /// The rays.
    pub(crate) rays: RayRows<'a>,
    /// The width of the image they are the pixels of, row-major; `None`: a plain list.
    pub(crate) width: Option<usize>,
}

impl<'a> RayList<'a> {
    /// An image's rays, in rows of `width` (the last row may be short).
    pub fn image(rays: impl Into<RayList<'a>>, width: usize) -> RayList<'a> {
        RayList {
            width: Some(width.max(1)),
            ..rays.into()
        }
    }

    pub(crate) fn len(&self) -> usize {
        match self.rays {
            RayRows::F64(r) => r.len(),
            RayRows::F32(r) => r.len(),
        }
    }

    /// Ray `k` (`k < len()`).
    pub(crate) fn get(&self, k: usize) -> Ray {
        match self.rays {
            RayRows::F64(r) => r[k],
            RayRows::F32(r) => widen(&r[k]),
        }
    }

    /// The rays of `indices`, as a plain list.
    pub(crate) fn subset(&self, indices: &[usize]) -> Vec<Ray> {
        indices.iter().map(|&k| self.get(k)).collect()
    }
}

/// A row of six f32s as the ray it holds (exactly).
fn widen(row: &[f32; 6]) -> Ray {
    let x = row.map(f64::from);
    Ray {
        origin: DVec3::new(x[0], x[1], x[2]),
        direction: DVec3::new(x[3], x[4], x[5]),
    }
}

impl<'a> From<&'a [Ray]> for RayRows<'a> {
    fn from(rays: &'a [Ray]) -> Self {
        RayRows::F64(rays)
    }
}

impl<'a> From<&'a Vec<Ray>> for RayRows<'a> {
    fn from(rays: &'a Vec<Ray>) -> Self {
        RayRows::F64(rays)
    }
}

impl<'a> From<&'a [[f32; 6]]> for RayRows<'a> {
    fn from(rays: &'a [[f32; 6]]) -> Self {
        RayRows::F32(rays)
    }
}

impl<'a> From<RayRows<'a>> for RayList<'a> {
    fn from(rays: RayRows<'a>) -> Self {
        RayList { rays, width: None }
    }
}

/// A plain list of rays held as any of [`RayRows`]' forms.
macro_rules! ray_list_from {
    ($($held:ty),*) => {$(
        impl<'a> From<$held> for RayList<'a> {
            fn from(rays: $held) -> Self {
                RayList::from(RayRows::from(rays))
            }
        }
    )*};
}
ray_list_from!(&'a [Ray], &'a Vec<Ray>, &'a [[f32; 6]]);

impl<'a, const N: usize> From<&'a [Ray; N]> for RayList<'a> {
    fn from(rays: &'a [Ray; N]) -> Self {
        RayList::from(RayRows::F64(rays))
    }
}

impl<'a, const N: usize> From<&'a [Ray; N]> for RayRows<'a> {
    fn from(rays: &'a [Ray; N]) -> Self {
        RayRows::F64(rays)
    }
}

/// The primitive index of a miss (Open3D's `INVALID_ID`).
pub const INVALID_ID: u32 = u32::MAX;

/// Per-ray results of a cast, in list order, in the precision `T` of the kernel that cast them.
/// A nearest-hit cast fills every field but `count`; a counting cast only `count`.
#[derive(Clone, Debug, PartialEq)]
pub struct Hits<T> {
    /// Where the ray hits, in units of its direction's length: `+inf` on a miss.
    pub t: Vec<T>,
    /// Object id ([`MISS`] on a miss).
    pub id: Vec<i32>,
    /// The primitive's index within its object (a mesh's triangle; 0 for other objects),
    /// [`INVALID_ID`] on a miss.
    pub primitive: Vec<u32>,
    /// Barycentric `(u, v)` of a triangle hit: the hit point is `(1 - u - v) a + u b + v c`.
    /// Zero on a miss, a sphere or a plane.
    pub uv: Vec<[T; 2]>,
    /// Unit geometric normal (by corner order for triangles, outward for spheres, as given for
    /// planes); zero on a miss.
    pub normal: Vec<[T; 3]>,
    /// Surfaces crossed (a counting cast).
    pub count: Vec<u32>,
}

impl<T: Real> Hits<T> {
    /// `n` misses, or with `counting` `n` zero counts.
    pub(crate) fn new(n: usize, counting: bool) -> Hits<T> {
        let per_ray = if counting { 0 } else { n };
        Hits {
            t: vec![T::INFINITY; per_ray],
            id: vec![MISS; per_ray],
            primitive: vec![INVALID_ID; per_ray],
            uv: vec![[T::ZERO; 2]; per_ray],
            normal: vec![[T::ZERO; 3]; per_ray],
            count: vec![0; if counting { n } else { 0 }],
        }
    }

    /// No rays yet, room for `n` (read in order: [`crate::gpu::dispatch::run`]), in huge
    /// pages where the system gives them ([`huge_pages`]).
    pub(crate) fn with_capacity(n: usize, counting: bool) -> Hits<T> {
        let per_ray = if counting { 0 } else { n };
        let hits = Hits {
            t: Vec::with_capacity(per_ray),
            id: Vec::with_capacity(per_ray),
            primitive: Vec::with_capacity(per_ray),
            uv: Vec::with_capacity(per_ray),
            normal: Vec::with_capacity(per_ray),
            count: Vec::with_capacity(if counting { n } else { 0 }),
        };
        huge_pages(&hits.t);
        huge_pages(&hits.id);
        huge_pages(&hits.primitive);
        huge_pages(&hits.uv);
        huge_pages(&hits.normal);
        huge_pages(&hits.count);
        hits
    }

    /// Records a hit of ray `k`.
    pub(crate) fn set(
        &mut self,
        k: usize,
        id: i32,
        t: T,
        normal: [T; 3],
        primitive: u32,
        uv: [T; 2],
    ) {
        self.id[k] = id;
        self.t[k] = t;
        self.normal[k] = normal;
        self.primitive[k] = primitive;
        self.uv[k] = uv;
    }
}

/// The hits of a cast in the precision it ran in: f32 for f32 and adaptive casts, f64 for f64.
#[derive(Clone, Debug, PartialEq)]
pub enum AnyHits {
    /// From f32 and adaptive casts.
    F32(Hits<f32>),
    /// From f64 casts.
    F64(Hits<f64>),
}

impl AnyHits {
    /// The object each ray hit, or [`crate::images::MISS`].
    pub fn id(&self) -> &[i32] {
        match self {
            AnyHits::F32(h) => &h.id,
            AnyHits::F64(h) => &h.id,
        }
    }

    /// `t` of every ray, widened to f64.
    pub fn t_f64(&self) -> Vec<f64> {
        match self {
            AnyHits::F32(h) => h.t.iter().map(|&t| t as f64).collect(),
            AnyHits::F64(h) => h.t.clone(),
        }
    }
}

/// Rays of a sampled packet: 8 consecutive ones, or a 4x2 tile of an image's (a part of the
/// GPU's packets, which on lavapipe are 64 rays: 8x8 of an image's).
const PACKET: usize = 8;

/// How far apart the rays of sampled packets may be (see [`packet_spread`]) for the list to be
/// traced in packets: between the jitter at which packets still won on the torus and that at
/// which one by one did, well above a camera's spread (docs/experiments.md#what-paid).
const COHERENT_SPREAD: f64 = 0.02;

/// How far the sampled packets' rays may stray from a smooth progression (see
/// [`packet_roughness`]) for the list to be traced in packets. The GPU's packets (64 rays on
/// lavapipe) test each box against the interval of their rays, which jitter widens far beyond
/// the rays' own paths, while a camera's smooth spread leaves it tight: set between the
/// roughness at which packets still won on the torus and that at which they lost
/// (docs/experiments.md#what-paid).
const COHERENT_ROUGHNESS: f64 = 0.015;

/// Whether `list`'s rays are coherent: in most of up to 64 packets sampled through the list
/// (`PACKET`), the rays lie within `COHERENT_SPREAD` of each other
/// (`packet_spread`, origins measured against `extent`, the scene's size) and stray at most
/// `COHERENT_ROUGHNESS` from a smooth progression along the rows (`packet_roughness`).
pub(crate) fn coherent(list: RayList<'_>, extent: f64) -> bool {
    let n = list.len();
    let packets = n.div_ceil(PACKET);
    if packets == 0 {
        return true;
    }
    let samples = packets.min(64);
    let (mut spreads, mut roughness): (Vec<f64>, Vec<f64>) = (0..samples)
        .map(|s| {
            let first = s * packets / samples * PACKET;
            let (members, row): (Vec<Ray>, usize) = match list.width {
                // The 4x2 tile whose top-left ray is nearest `first`, in two rows of 4.
                Some(w) if w >= 4 => {
                    let (row, column) = (first / w / 2 * 2, (first % w).min(w - 4));
                    let members = (0..2)
                        .flat_map(|i| (0..4).map(move |j| (row + i) * w + column + j))
                        .filter(|&k| k < n)
                        .map(|k| list.get(k))
                        .collect();
                    (members, 4)
                }
                _ => (
                    (first..(first + PACKET).min(n))
                        .map(|k| list.get(k))
                        .collect(),
                    PACKET,
                ),
            };
            (
                packet_spread(&members, extent),
                packet_roughness(&members, row, extent),
            )
        })
        .unzip();
    spreads.sort_by(f64::total_cmp);
    roughness.sort_by(f64::total_cmp);
    spreads[samples / 2] <= COHERENT_SPREAD && roughness[samples / 2] <= COHERENT_ROUGHNESS
}

/// Whether every ray of `list` starts where the first one does, bit for bit (a pinhole
/// camera's rays, `create_rays_pinhole`'s): the GPU then reads that origin once for all
/// (`gpu::shader::Variant::list_origin`). Checked in parallel runs, each stopping at its
/// first other origin.
pub(crate) fn one_origin(list: RayList<'_>) -> bool {
    use rayon::prelude::*;
    const RUN: usize = 1 << 14;
    fn all_at<T: Sync, K: PartialEq + Sync>(rows: &[T], key: impl Fn(&T) -> K + Sync) -> bool {
        rows.first().is_some_and(|first| {
            let origin = key(first);
            rows.par_chunks(RUN)
                .all(|run| run.iter().all(|row| key(row) == origin))
        })
    }
    match list.rays {
        RayRows::F64(rays) => all_at(rays, |r| r.origin.to_array().map(f64::to_bits)),
        RayRows::F32(rows) => all_at(rows, |r| [r[0], r[1], r[2]].map(f32::to_bits)),
    }
}

/// How far a packet's rays stray from a smooth progression along its rows of `row` rays: the
/// largest second difference of neighbouring unit directions, plus that of origins in units of
/// `extent`. A camera's rays change smoothly and stray little; jitter raises it in
/// proportion.
fn packet_roughness(rays: &[Ray], row: usize, extent: f64) -> f64 {
    let direction = |r: &Ray| normalize(Vec3::from(r.direction));
    let origin = |r: &Ray| Vec3::from(r.origin);
    rays.chunks(row)
        .flat_map(|run| run.windows(3))
        .map(|w| {
            length(direction(&w[0]) - direction(&w[1]) * 2.0 + direction(&w[2]))
                + length(origin(&w[0]) - origin(&w[1]) * 2.0 + origin(&w[2])) / extent
        })
        .fold(0.0, f64::max)
}

/// How far the rays of a packet are from its first: the largest distance between unit
/// directions (about the angle, in radians) plus that between origins in units of `extent`.
fn packet_spread(rays: &[Ray], extent: f64) -> f64 {
    let direction = |r: &Ray| normalize(Vec3::from(r.direction));
    let first = &rays[0];
    rays.iter()
        .map(|r| {
            length(direction(r) - direction(first))
                + length(Vec3::from(r.origin) - Vec3::from(first.origin)) / extent
        })
        .fold(0.0, f64::max)
}

pub(crate) fn argument(option: &str, message: String) -> Error {
    Error::Argument {
        option: option.into(),
        message,
    }
}

/// A finite point (or vector) of at most 1e18 in magnitude, as a scene file requires.
pub(crate) fn check_point(p: &[f64; 3], what: &str) -> Result<()> {
    match bad_coordinate(p) {
        Some(x) => Err(argument(what, out_of_range(x))),
        None => Ok(()),
    }
}

/// Every point finite and of at most 1e18 in magnitude, the first bad one named
/// (`points[k]`).
pub(crate) fn check_points(points: &[[f64; 3]]) -> Result<()> {
    for (k, p) in points.iter().enumerate() {
        check_point(p, &format!("points[{k}]"))?;
    }
    Ok(())
}

/// A coordinate of `p` that is NaN or beyond 1e18 in magnitude.
fn bad_coordinate(p: &[f64; 3]) -> Option<f64> {
    p.iter()
        .copied()
        .find(|x| x.is_nan() || x.abs() > crate::scene::MAX_MAGNITUDE)
}

fn out_of_range(x: f64) -> String {
    format!("{x} is not a finite number of at most 1e18 in magnitude")
}

/// Every ray finite and of a non-zero direction, the first bad one named. GPU casts check as
/// they write the list ([`is_valid`] in [`crate::gpu::dispatch`], calling this only to name
/// a bad ray): a pass of its own would read the whole list's memory once more.
pub(crate) fn check_rays(rays: RayList<'_>) -> Result<()> {
    match (0..rays.len()).find(|&k| !is_valid(&rays.get(k))) {
        Some(k) => check_ray(k, &rays.get(k)),
        None => Ok(()),
    }
}

/// Whether a ray is finite (within 1e18) and of a non-zero direction, without branches.
pub(crate) fn is_valid(ray: &Ray) -> bool {
    let within = |p: &[f64; 3]| {
        p.iter()
            .fold(true, |ok, x| ok & (x.abs() <= crate::scene::MAX_MAGNITUDE))
    };
    within(&ray.origin.to_array())
        & within(&ray.direction.to_array())
        & (ray.direction != DVec3::ZERO)
}

/// Ray `k` finite and of a non-zero direction (its name formatted only on an error).
fn check_ray(k: usize, ray: &Ray) -> Result<()> {
    if let Some(x) = bad_coordinate(&ray.origin.to_array()) {
        return Err(argument(&format!("rays[{k}] origin"), out_of_range(x)));
    }
    if let Some(x) = bad_coordinate(&ray.direction.to_array()) {
        return Err(argument(&format!("rays[{k}] direction"), out_of_range(x)));
    }
    if ray.direction == [0.0; 3].into() {
        return Err(argument(
            &format!("rays[{k}] direction"),
            "must not be zero".into(),
        ));
    }
    Ok(())
}
