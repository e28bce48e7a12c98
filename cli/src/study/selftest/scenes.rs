//! Seeded scenes and rays, the same on every run and every machine: the self-test's random
//! scenes and ray lists, which the integration tests use too.

use std::path::Path;

use raycast::Ray;
use raycast::{MeshPart, Scene, Triangle};

/// The course's six scenes, by name.
pub const COURSE_SCENES: [&str; 6] = [
    "bunny",
    "inside-a-sphere",
    "sphere-and-plane",
    "sphere-packing",
    "triangle",
    "two-spheres-and-plane",
];

/// A small deterministic generator (SplitMix64).
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn point(&mut self, lo: f64, hi: f64) -> [f64; 3] {
        [self.range(lo, hi), self.range(lo, hi), self.range(lo, hi)]
    }
    /// A direction uniform on the unit sphere.
    pub fn direction(&mut self) -> [f64; 3] {
        let z = self.range(-1.0, 1.0);
        let phi = self.range(0.0, std::f64::consts::TAU);
        let s = (1.0 - z * z).sqrt();
        [s * phi.cos(), s * phi.sin(), z]
    }
}

/// A seeded random scene: spheres, a plane (even seeds), loose triangles and one closed mesh
/// (a UV sphere whose edges are all shared), seen by a perspective camera from outside.
pub fn random_scene(seed: u64, resolution: [u32; 2]) -> Scene {
    let mut rng = Rng(seed);
    let mut objects = Vec::new();
    for _ in 0..6 {
        let c = rng.point(-2.0, 2.0);
        objects.push(format!(
            r#"{{"type": "sphere", "center": {c:?}, "radius": {}}}"#,
            rng.range(0.1, 0.8)
        ));
    }
    // Even seeds add a plane (which fills the background); odd seeds leave misses.
    for _ in 0..(1 - seed % 2) {
        let p = rng.point(-3.0, 3.0);
        let n = rng.point(-1.0, 1.0);
        objects.push(format!(
            r#"{{"type": "plane", "point": {p:?}, "normal": {n:?}}}"#
        ));
    }
    for _ in 0..5 {
        let c = rng.point(-2.0, 2.0);
        let corners: Vec<[f64; 3]> = (0..3)
            .map(|_| {
                let d = rng.point(-0.7, 0.7);
                [c[0] + d[0], c[1] + d[1], c[2] + d[2]]
            })
            .collect();
        objects.push(format!(r#"{{"type": "triangle", "corners": {corners:?}}}"#));
    }
    objects.push(r#"{"type": "soup", "obj": "mesh.obj"}"#.to_owned());
    let eye = [rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), 7.0];
    let json = format!(
        r#"{{"camera": {{"eye": {eye:?}, "look": [0, 0, -1], "up": [0, 1, 0],
            "focal_length": 2, "width": 1.6, "height": 1.2, "resolution": {resolution:?}}},
            "objects": [{}]}}"#,
        objects.join(",\n")
    );
    let center = rng.point(-1.5, 1.5);
    let radius = rng.range(0.5, 1.2);
    Scene::from_json(&json, Path::new("random.json"), &mut |_, _| {
        let triangles = sphere_mesh(center, radius, 12, 8);
        Ok(vec![MeshPart {
            name: String::new(),
            triangles,
        }])
    })
    .expect("a random scene is a valid scene")
}

/// A closed UV-sphere mesh: every edge is shared by two triangles.
pub fn sphere_mesh(c: [f64; 3], r: f64, slices: usize, stacks: usize) -> Vec<Triangle> {
    let p = |i: usize, j: usize| {
        let theta = std::f64::consts::PI * j as f64 / stacks as f64;
        let phi = 2.0 * std::f64::consts::PI * (i % slices) as f64 / slices as f64;
        [
            c[0] + r * theta.sin() * phi.cos(),
            c[1] + r * theta.cos(),
            c[2] + r * theta.sin() * phi.sin(),
        ]
        .into()
    };
    let mut t = Vec::new();
    for j in 0..stacks {
        for i in 0..slices {
            let (a, b, cc, d) = (p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1));
            if j > 0 {
                t.push([a, b, cc]);
            }
            if j + 1 < stacks {
                t.push([a, cc, d]);
            }
        }
    }
    t
}

/// A pinhole camera's rays from `eye` looking down -z, `w` by `h` pixels, row-major, its image
/// `span` wide at distance 1 (and 3/4 of that high).
pub fn pinhole_rays(eye: [f64; 3], w: usize, h: usize, span: f64) -> Vec<Ray> {
    let mut rays = Vec::with_capacity(w * h);
    for i in 0..h {
        for j in 0..w {
            let x = (j as f64 + 0.5) / w as f64 - 0.5;
            let y = 0.5 - (i as f64 + 0.5) / h as f64;
            rays.push(Ray {
                origin: eye.into(),
                direction: [span * x, 0.75 * span * y, -1.0].into(),
            });
        }
    }
    rays
}

/// `rays`, each starting `by` times its direction further along itself: rays from as many
/// origins.
pub fn moved_along(rays: &[Ray], by: f64) -> Vec<Ray> {
    let moved = |r: &Ray| Ray {
        origin: std::array::from_fn(|a| r.origin[a] + by * r.direction[a]).into(),
        ..*r
    };
    rays.iter().map(moved).collect()
}

/// `n` incoherent rays: origins uniform in the cube [-`half`, `half`]^3, directions uniform on
/// the sphere.
pub fn incoherent_rays(n: usize, half: f64, seed: u64) -> Vec<Ray> {
    let mut rng = Rng(seed);
    (0..n)
        .map(|_| Ray {
            origin: rng.point(-half, half).into(),
            direction: rng.direction().into(),
        })
        .collect()
}
