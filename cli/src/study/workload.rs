//! `raycast workload`: the benchmark scenes written as files, so that a machine with nothing but
//! the binary (a GPU server without Python, say) can measure the same workloads as the peers:
//!
//! - `torus`: the peers' displaced torus (../shared/bench/peer_bench.py's formula: a bumpy
//!   torus of radii 1 and 0.4, `nu x nv x 2` triangles, 720 x 360 x 2 = 518,400 by default),
//!   seen by the peers' camera (eye (0, -3, 2.5), looking at the origin, up +z, vertical field
//!   of view 40 degrees);
//! - `spheres`: 100 spheres in the torus's bounding box, radii 2% to 6% of its diagonal (the
//!   peers' distribution; drawn by raycast's own seeded generator, so not the peers' spheres);
//! - `lit-bunny`: the course's ray-tracing bunny (scenes/ray-tracing/bunny.json and its mesh),
//!   for `raycast bench --lit`;
//! - `instances`: the course's bunny declared once and placed `--count` times (1,000 by
//!   default) at seeded random poses on a grid (rotations about random axes, non-uniform
//!   scales), the scene of #64's measurements, and `poses.jsonl`: 100 frames in which the
//!   first 30 bunnies turn about their axes and drift (`raycast render --poses`).
//!
//! Each is a scene file and, for the torus, a binary PLY mesh beside it (doubles: the formula's
//! vertices exactly), written whole or not at all.

use std::path::{Path, PathBuf};

use super::selftest::scenes::Rng;
use raycast::{Error, Result};
use raycast_files::{EncodedFile, check_writable, write_files};

/// The peers' torus: `nu` around the axis, `nv` around the tube.
pub const TORUS_GRID: [usize; 2] = [720, 360];

/// The workloads, as `raycast workload` names them, and what each writes: its help.
pub const WORKLOADS: [(&str, &str); 4] = [
    (
        "torus",
        "the peers' displaced torus, 518,400 triangles (or --triangles), in a binary PLY beside \
         the scene file",
    ),
    ("spheres", "100 spheres in the torus's box"),
    (
        "lit-bunny",
        "the course's ray-tracing bunny (its scene and mesh, its own camera), for `bench --lit`",
    ),
    (
        "instances",
        "the course's bunny placed --count times (1,000) at random poses on a grid, one mesh \
         declared once, and poses.jsonl: 100 frames moving 30 of them",
    ),
];

/// Bunnies the `instances` workload places unless `--count` says.
pub const INSTANCES: usize = 1000;

/// The workloads' names, comma-separated.
fn names() -> String {
    WORKLOADS.map(|(name, _)| name).join(", ")
}

/// `raycast workload`'s line in the command list.
pub fn about() -> String {
    format!("Write a benchmark scene as files: {}", names())
}

/// `raycast workload NAME`'s help: every workload and what it writes.
pub fn help() -> String {
    let each = WORKLOADS.map(|(name, what)| format!("{name}: {what}"));
    format!(
        "Which: {}. The torus and the spheres are seen by the peers' camera at --size.",
        each.join("; ")
    )
}

/// The peers' camera as a scene file's `camera`, at `resolution`.
pub fn peer_camera(resolution: [u32; 2]) -> serde_json::Value {
    let height = 2.0 * 20f64.to_radians().tan();
    let width = height * resolution[0] as f64 / resolution[1] as f64;
    serde_json::json!({
        "type": "perspective", "eye": [0, -3.0, 2.5], "look": [0, 3.0, -2.5], "up": [0, 0, 1],
        "focal_length": 1, "height": height, "width": width, "resolution": resolution,
    })
}

/// The displaced torus's vertices and triangles (vertex `i * nv + j` at grid point `(i, j)`).
pub fn displaced_torus(nu: usize, nv: usize) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let (big, small) = (1.0, 0.4);
    let mut vertices = Vec::with_capacity(nu * nv);
    for i in 0..nu {
        let u = i as f64 * (std::f64::consts::TAU / nu as f64);
        for j in 0..nv {
            let v = j as f64 * (std::f64::consts::TAU / nv as f64);
            let bump = 1.0
                + 0.12 * (7.0 * u).sin() * (5.0 * v).sin()
                + 0.05 * (23.0 * u + 11.0 * v).cos()
                + 0.02 * (61.0 * u).sin() * (37.0 * v).cos();
            let r = small * bump;
            let ring = big + r * v.cos();
            vertices.push([ring * u.cos(), ring * u.sin(), r * v.sin()]);
        }
    }
    let index = |i: usize, j: usize| ((i % nu) * nv + j % nv) as u32;
    let mut first = Vec::with_capacity(nu * nv);
    let mut second = Vec::with_capacity(nu * nv);
    for i in 0..nu {
        for j in 0..nv {
            let (a, b, c, d) = (
                index(i, j),
                index(i + 1, j),
                index(i + 1, j + 1),
                index(i, j + 1),
            );
            first.push([a, b, c]);
            second.push([a, c, d]);
        }
    }
    first.extend(second);
    (vertices, first)
}

/// The torus grid for about `triangles` triangles, its cells as the peers' (nu = 2 nv).
pub fn torus_grid(triangles: usize) -> [usize; 2] {
    let nv = ((triangles as f64 / 4.0).sqrt().round() as usize).max(3);
    [2 * nv, nv]
}

/// A binary little-endian PLY of `vertices` (doubles) and `triangles`.
pub fn ply(vertices: &[[f64; 3]], triangles: &[[u32; 3]]) -> Vec<u8> {
    let header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment raycast workload\n\
         element vertex {}\nproperty double x\nproperty double y\nproperty double z\n\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        vertices.len(),
        triangles.len()
    );
    let mut bytes = Vec::with_capacity(header.len() + 24 * vertices.len() + 13 * triangles.len());
    bytes.extend_from_slice(header.as_bytes());
    for v in vertices {
        v.iter()
            .for_each(|c| bytes.extend_from_slice(&c.to_le_bytes()));
    }
    for t in triangles {
        bytes.push(3);
        t.iter()
            .for_each(|&k| bytes.extend_from_slice(&(k as i32).to_le_bytes()));
    }
    bytes
}

/// `n` spheres inside the box `[lo, hi]`, radii 2% to 6% of its diagonal.
pub fn spheres(n: usize, lo: [f64; 3], hi: [f64; 3], seed: u64) -> Vec<serde_json::Value> {
    let mut rng = Rng(seed);
    let diagonal = (0..3).map(|a| (hi[a] - lo[a]).powi(2)).sum::<f64>().sqrt();
    (0..n)
        .map(|_| {
            let center: Vec<f64> = (0..3).map(|a| rng.range(lo[a], hi[a])).collect();
            let radius = rng.range(0.02, 0.06) * diagonal;
            serde_json::json!({"type": "sphere", "center": center, "radius": radius})
        })
        .collect()
}

/// Frames of the `instances` workload's poses file, and the bunnies each moves (the first).
const POSE_FRAMES: usize = 100;
const POSED: usize = 30;

/// The `instances` workload's scene: `mesh` (its file name and triangles) placed `count` times
/// at seeded random poses on a cubic grid, seen from beyond the grid's +z face; and its poses
/// file's lines, each frame turning the first [`POSED`] bunnies a further 3.6 degrees about
/// their axes and moving them on by a hundredth of the grid's step.
fn instances_scene(
    mesh: (&str, &[raycast::Triangle]),
    count: usize,
    resolution: [u32; 2],
) -> (serde_json::Value, String) {
    let corners = mesh.1.iter().flatten();
    let lo: [f64; 3] =
        std::array::from_fn(|a| corners.clone().map(|p| p[a]).fold(f64::MAX, f64::min));
    let hi: [f64; 3] =
        std::array::from_fn(|a| corners.clone().map(|p| p[a]).fold(f64::MIN, f64::max));
    let size = (0..3).map(|a| (hi[a] - lo[a]).powi(2)).sum::<f64>().sqrt();
    let centre: [f64; 3] = std::array::from_fn(|a| (lo[a] + hi[a]) / 2.0);
    let side = (1..)
        .find(|n| n * n * n >= count)
        .expect("a grid holds them");
    let step = 1.5 * size;
    let mut rng = Rng(64);
    let placements: Vec<_> = (0..count)
        .map(|k| {
            let cell = [k % side, k / side % side, k / (side * side)];
            let translate: Vec<f64> = (0..3)
                .map(|a| cell[a] as f64 * step - centre[a] + rng.range(-0.1, 0.1) * step)
                .collect();
            let axis = rng.point(-1.0, 1.0);
            let degrees = rng.range(0.0, 360.0);
            let scale: Vec<f64> = (0..3).map(|_| rng.range(0.6, 1.2)).collect();
            (translate, axis, degrees, scale)
        })
        .collect();
    let transform = |(translate, axis, degrees, scale): &(Vec<f64>, [f64; 3], f64, Vec<f64>),
                     frame: usize| {
        let moved: Vec<f64> = translate
            .iter()
            .map(|x| x + 0.01 * step * frame as f64)
            .collect();
        serde_json::json!({"translate": moved, "rotate": {"axis": axis,
            "degrees": degrees + 3.6 * frame as f64}, "scale": scale})
    };
    let objects: Vec<serde_json::Value> = (placements.iter())
        .map(|p| serde_json::json!({"type": "instance", "mesh": "bunny", "transform": transform(p, 0)}))
        .collect();
    let poses: String = (0..POSE_FRAMES)
        .map(|frame| {
            let transforms: Vec<serde_json::Value> = (placements.iter().take(POSED).enumerate())
                .map(|(k, p)| serde_json::json!({"object": k, "transform": transform(p, frame)}))
                .collect();
            let name = format!("f-{frame:03}");
            serde_json::json!({"name": name, "transforms": transforms}).to_string() + "\n"
        })
        .collect();
    let middle = (side - 1) as f64 * step / 2.0;
    let eye = [middle, middle, side as f64 * step * 1.5 + 2.0 * size];
    let scene = serde_json::json!({
        "comment": format!("the course's bunny placed {count} times at random poses (raycast workload)"),
        "camera": {"eye": eye, "look_at": [middle, middle, middle], "up": [0, 1, 0], "fov": 50,
                   "resolution": resolution},
        "meshes": {"bunny": {"stl": mesh.0}},
        "objects": objects,
    });
    (scene, poses)
}

/// Writes workload `name` into `dir` at `resolution` (`triangles`: the torus's size; `count`:
/// the instances') and returns the scene file's path.
pub fn write(
    name: &str,
    dir: &Path,
    resolution: [u32; 2],
    triangles: Option<usize>,
    count: Option<usize>,
) -> Result<PathBuf> {
    let [nu, nv] = triangles.map_or(TORUS_GRID, torus_grid);
    let scene = |comment: String, objects: Vec<serde_json::Value>| {
        let json = serde_json::json!({
            "comment": comment, "camera": peer_camera(resolution), "objects": objects,
        });
        serde_json::to_vec_pretty(&json).expect("a scene serialises")
    };
    let files = match name {
        "torus" => {
            let (vertices, faces) = displaced_torus(nu, nv);
            let comment = format!(
                "the peers' displaced torus, {nu} x {nv} x 2 = {} triangles (raycast workload)",
                faces.len()
            );
            let mesh = serde_json::json!({"type": "soup", "ply": "torus.ply"});
            vec![
                EncodedFile {
                    name: "torus.ply",
                    bytes: ply(&vertices, &faces),
                },
                EncodedFile {
                    name: "torus.json",
                    bytes: scene(comment, vec![mesh]),
                },
            ]
        }
        "spheres" => {
            let (vertices, _) = displaced_torus(nu, nv);
            let lo =
                std::array::from_fn(|a| vertices.iter().map(|v| v[a]).fold(f64::MAX, f64::min));
            let hi =
                std::array::from_fn(|a| vertices.iter().map(|v| v[a]).fold(f64::MIN, f64::max));
            let comment = "100 spheres in the displaced torus's box (raycast workload)".to_owned();
            vec![EncodedFile {
                name: "spheres.json",
                bytes: scene(comment, spheres(100, lo, hi, 0)),
            }]
        }
        "lit-bunny" => {
            let file = |name: &'static str| -> Result<EncodedFile> {
                let path = format!("scenes/ray-tracing/{name}");
                let bytes = super::selftest::data::file(&path)?.to_vec();
                Ok(EncodedFile { name, bytes })
            };
            vec![file("bunny.stl")?, file("bunny.json")?]
        }
        "instances" => {
            let bytes = super::selftest::data::file("scenes/course/bunny.stl")?.to_vec();
            let parts = raycast::parse_mesh(&bytes, Path::new("bunny.stl"), Default::default())?;
            let mesh: Vec<raycast::Triangle> =
                parts.into_iter().flat_map(|p| p.triangles).collect();
            let (json, poses) =
                instances_scene(("bunny.stl", &mesh), count.unwrap_or(INSTANCES), resolution);
            vec![
                EncodedFile {
                    name: "bunny.stl",
                    bytes,
                },
                EncodedFile {
                    name: "poses.jsonl",
                    bytes: poses.into_bytes(),
                },
                EncodedFile {
                    name: "instances.json",
                    bytes: serde_json::to_vec_pretty(&json).expect("a scene serialises"),
                },
            ]
        }
        _ => {
            return Err(Error::Argument {
                option: "workload".into(),
                message: format!("`{name}` is none of {}", names()),
            });
        }
    };
    check_writable(dir)?;
    let written = write_files(dir, &files)?;
    Ok(written.last().expect("a scene file").clone())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_torus_is_closed_and_has_the_peers_size() {
        let (v, t) = displaced_torus(TORUS_GRID[0], TORUS_GRID[1]);
        assert_eq!((v.len(), t.len()), (259_200, 518_400));
        // Closed: every edge is shared by exactly two triangles, in opposite directions.
        let (v, t) = displaced_torus(12, 6);
        let mut edges = std::collections::HashMap::new();
        for tri in &t {
            for k in 0..3 {
                *edges.entry((tri[k], tri[(k + 1) % 3])).or_insert(0) += 1;
            }
        }
        assert!(
            edges
                .iter()
                .all(|(&(a, b), &n)| n == 1 && edges.get(&(b, a)) == Some(&1))
        );
        assert!(v.iter().all(|p| p[2].abs() < 0.4 * 1.2));
        assert_eq!(torus_grid(5_000_000), [2236, 1118]);
    }

    /// The list the help is made from and the workloads `write` knows are the same.
    #[test]
    fn every_listed_workload_is_written() {
        let dir = tempfile::tempdir().unwrap();
        for (name, _) in WORKLOADS {
            write(name, dir.path(), [8, 8], Some(8), Some(3)).unwrap();
        }
        assert!(write("cube", dir.path(), [8, 8], None, None).is_err());
    }

    /// The instances workload loads as `count` objects of the bunny's triangles each, every
    /// one placed differently.
    #[test]
    fn the_instances_workload_places_count_bunnies() {
        let dir = tempfile::tempdir().unwrap();
        let path = write("instances", dir.path(), [16, 9], None, Some(27)).unwrap();
        let scene = raycast::Scene::load(&path).unwrap();
        assert!(scene.warnings.is_empty());
        let meshes: Vec<&Vec<raycast::Triangle>> = (scene.objects.iter())
            .map(|o| match o {
                raycast::Object::Soup { triangles, .. } => triangles,
                other => panic!("{other:?}"),
            })
            .collect();
        assert_eq!(meshes.len(), 27);
        assert!(meshes.iter().all(|t| t.len() == 1000));
        let firsts: std::collections::BTreeSet<String> =
            meshes.iter().map(|t| format!("{:?}", t[0])).collect();
        assert_eq!(firsts.len(), 27);
        // Its poses: 100 frames, each moving the first 27 (fewer than 30) bunnies.
        let poses = dir.path().join("poses.jsonl");
        let views =
            raycast::parse_poses(&std::fs::read_to_string(&poses).unwrap(), &poses).unwrap();
        assert_eq!(views.len(), POSE_FRAMES);
        for view in &views {
            let moved: Vec<usize> = view.transforms.iter().map(|(k, _)| *k).collect();
            assert_eq!(moved, (0..27).collect::<Vec<_>>(), "{}", view.name);
            view.camera(&poses, &scene).unwrap();
        }
        assert_ne!(views[0].transforms, views[1].transforms);
    }
}
