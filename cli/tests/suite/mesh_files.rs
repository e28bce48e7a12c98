//! Mesh files end to end: one small mesh written in every supported format loads to the same
//! triangles in the same order, a scene using it renders, and the `raycast` binary on a
//! malformed OBJ, a truncated STL or a broken PLY exits with code 2, prints one `error: ` line
//! naming the mesh file and the line or byte at fault, and writes no output.

use crate::common;

use std::path::PathBuf;
use std::process::Output;

use raycast::{Triangle, load_mesh};
use tempfile::TempDir;

/// A square pyramid: a quad base (fan-triangulated from its first corner) and four sides.
/// Dyadic coordinates, so every format and precision holds them exactly.
const POINTS: [[f64; 3]; 5] = [
    [-0.5, -0.5, -3.0],
    [0.5, -0.5, -3.0],
    [0.5, 0.5, -3.0],
    [-0.5, 0.5, -3.0],
    [0.0, 0.0, -2.25],
];
const FACES: [&[usize]; 5] = [
    &[3, 2, 1, 0],
    &[0, 1, 4],
    &[1, 2, 4],
    &[2, 3, 4],
    &[3, 0, 4],
];

/// The triangles every format must load to: faces in order, each fanned in corner order.
fn triangles() -> Vec<Triangle> {
    let p = |i: usize| POINTS[i].into();
    FACES
        .iter()
        .flat_map(|f| (1..f.len() - 1).map(|k| [p(f[0]), p(f[k]), p(f[k + 1])]))
        .collect()
}

fn obj() -> Vec<u8> {
    let mut text = String::from("# pyramid\no pyramid\n");
    for [x, y, z] in POINTS {
        text += &format!("v {x} {y} {z}\n");
    }
    text += "vn 0 0 1\n";
    for f in FACES {
        // Mixed corner forms and a relative index: all the same vertices.
        let corners: Vec<String> = f
            .iter()
            .enumerate()
            .map(|(k, i)| match k {
                0 => format!("{}", i + 1),
                1 => format!("{}//1", i + 1),
                _ => format!("{}", *i as i64 - POINTS.len() as i64),
            })
            .collect();
        text += &format!("f {}\n", corners.join(" "));
    }
    text.into_bytes()
}

fn stl_binary() -> Vec<u8> {
    let t = triangles();
    let mut bytes = b"solid pyramid (binary, whatever the header says)".to_vec();
    bytes.resize(80, 0);
    bytes.extend_from_slice(&(t.len() as u32).to_le_bytes());
    for triangle in &t {
        bytes.extend_from_slice(&[0; 12]);
        for c in triangle {
            for x in c.to_array() {
                bytes.extend_from_slice(&(x as f32).to_le_bytes());
            }
        }
        bytes.extend_from_slice(&[0; 2]);
    }
    bytes
}

fn stl_ascii() -> Vec<u8> {
    let mut text = String::from("solid pyramid\n");
    for triangle in triangles() {
        text += "  facet normal 0 0 0\n    outer loop\n";
        for c in triangle {
            text += &format!("      vertex {} {} {}\n", c.x, c.y, c.z);
        }
        text += "    endloop\n  endfacet\n";
    }
    text += "endsolid pyramid\n";
    text.into_bytes()
}

fn ply_header(format: &str) -> String {
    format!(
        "ply\nformat {format} 1.0\nelement vertex {}\nproperty float x\nproperty float y\n\
         property float z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        POINTS.len(),
        FACES.len()
    )
}

fn ply_ascii() -> Vec<u8> {
    let mut text = ply_header("ascii");
    for [x, y, z] in POINTS {
        text += &format!("{x} {y} {z}\n");
    }
    for f in FACES {
        let indices: Vec<String> = f.iter().map(|i| i.to_string()).collect();
        text += &format!("{} {}\n", f.len(), indices.join(" "));
    }
    text.into_bytes()
}

fn ply_binary() -> Vec<u8> {
    let mut bytes = ply_header("binary_little_endian").into_bytes();
    for p in POINTS {
        for x in p {
            bytes.extend_from_slice(&(x as f32).to_le_bytes());
        }
    }
    for f in FACES {
        bytes.push(f.len() as u8);
        for &i in f {
            bytes.extend_from_slice(&(i as i32).to_le_bytes());
        }
    }
    bytes
}

/// Every format of the pyramid, by file name.
fn pyramid_files() -> [(&'static str, Vec<u8>); 5] {
    [
        ("pyramid.obj", obj()),
        ("pyramid.stl", stl_binary()),
        ("pyramid-ascii.stl", stl_ascii()),
        ("pyramid-ascii.ply", ply_ascii()),
        ("pyramid.ply", ply_binary()),
    ]
}

#[test]
fn every_format_loads_the_same_triangles_in_the_same_order() {
    let dir = tempfile::tempdir().unwrap();
    for (name, bytes) in pyramid_files() {
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        let loaded = load_mesh(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(loaded, triangles(), "{name}");
    }
}

/// A scratch folder with a scene whose only object is the soup `kind: name`; `out` (not
/// created) is where output goes.
struct Case {
    dir: TempDir,
    scene: PathBuf,
    out: PathBuf,
}

impl Case {
    fn new(kind: &str, name: &str, mesh: &[u8]) -> Case {
        let dir = tempfile::tempdir().unwrap();
        let scene = dir.path().join("scene.json");
        let json = format!(
            r#"{{"camera": {{"eye": [0, 0, 0], "look": [0, 0, -1], "up": [0, 1, 0],
                "focal_length": 1, "width": 0.5, "height": 0.5, "resolution": [16, 16]}},
                "objects": [{{"type": "soup", "{kind}": "{name}"}}]}}"#
        );
        std::fs::write(&scene, json).unwrap();
        std::fs::write(dir.path().join(name), mesh).unwrap();
        let out = dir.path().join("out");
        Case { dir, scene, out }
    }

    fn run(&self) -> Output {
        common::raycast()
            .arg("render")
            .arg(&self.scene)
            .arg("-o")
            .arg(&self.out)
            .output()
            .expect("the raycast binary runs")
    }

    /// Runs, checks the failure contract and that the one line starts with `error: MESH: AT`
    /// (the mesh's path, then `line N: ` or `byte N: `); returns the line.
    fn fail(&self, name: &str, at: &str) -> String {
        let output = self.run();
        let stderr = String::from_utf8(output.stderr).expect("stderr is UTF-8");
        assert_eq!(output.status.code(), Some(2), "stderr:\n{stderr}");
        assert!(output.stdout.is_empty(), "nothing on stdout on failure");
        assert_eq!(stderr.lines().count(), 1, "one line, got:\n{stderr}");
        let mesh = self.dir.path().join(name);
        let prefix = format!("error: {}: {at}", mesh.display());
        assert!(
            stderr.starts_with(&prefix),
            "want `{prefix}...`, got: {stderr}"
        );
        assert!(!self.out.exists(), "no output folder may be created");
        stderr.trim_end().to_owned()
    }
}

#[test]
fn malformed_obj_names_its_line() {
    let mut text = String::from_utf8(obj()).unwrap();
    text += "f 1 2 57\n"; // line 14: 5 vertices only
    let case = Case::new("obj", "pyramid.obj", text.as_bytes());
    let message = case.fail("pyramid.obj", "line 14: ");
    assert!(
        message.ends_with("face index 57 but only 5 vertices so far"),
        "{message}"
    );

    let text = "v 0 0 -1\nv 1 0 -1\nv 0 1 -1\nv 1 1 oops\nf 1 2 3\n";
    let case = Case::new("obj", "bad.obj", text.as_bytes());
    let message = case.fail("bad.obj", "line 4: ");
    assert!(
        message.ends_with("expected 3 numbers after 'v', found 'oops'"),
        "{message}"
    );
}

#[test]
fn truncated_stl_names_its_byte() {
    let bytes = stl_binary();
    let cut = &bytes[..bytes.len() - 30];
    let case = Case::new("stl", "pyramid.stl", cut);
    let message = case.fail("pyramid.stl", "byte 84: ");
    let want = format!(
        "binary STL declares 6 triangles (384 bytes) but the file has {} bytes",
        cut.len()
    );
    assert!(message.ends_with(&want), "{message}");

    let text = String::from_utf8(stl_ascii()).unwrap();
    let cut = &text[..text.find("    endloop").unwrap()];
    let case = Case::new("stl", "cut.stl", cut.as_bytes());
    let lines = cut.lines().count();
    let message = case.fail("cut.stl", &format!("line {}: ", lines + 1));
    assert!(
        message.ends_with("expected 'endloop', found end of file"),
        "{message}"
    );
}

#[test]
fn broken_ply_names_its_line_or_byte() {
    let text = String::from_utf8(ply_ascii())
        .unwrap()
        .replace("3 1 2 4", "3 1 2 9");
    let case = Case::new("ply", "pyramid.ply", text.as_bytes());
    let message = case.fail("pyramid.ply", "line 17: ");
    assert!(
        message.ends_with("face 2 has vertex index 9 but there are only 5 vertices"),
        "{message}"
    );

    let bytes = ply_binary();
    let case = Case::new("ply", "cut.ply", &bytes[..bytes.len() - 1]);
    let last_face = bytes.len() - (1 + 3 * 4);
    case.fail(
        "cut.ply",
        &format!("byte {last_face}: face 4 of 5 runs past"),
    );
}

#[test]
fn a_ply_soup_renders() {
    let case = Case::new("ply", "pyramid.ply", &ply_binary());
    let output = case.run();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(0), "stderr:\n{stderr}");
    let written: Vec<PathBuf> = std::fs::read_dir(&case.out)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert!(
        written
            .iter()
            .any(|p| p.extension() == Some("png".as_ref())),
        "{written:?}"
    );
}

/// A tetrahedron-like fan of four triangles whose coordinates have decimal digits f32 cannot
/// hold, `offset` added to every coordinate, written as OBJ text in f64 (`{}` prints the
/// shortest digits that read back to the same f64).
fn decimal_mesh(offset: f64) -> (String, Vec<[f64; 3]>) {
    let points = [
        [0.1, 0.2, -3.3],
        [0.7, -0.3, -3.1],
        [-0.45, 0.35, -2.9],
        [0.05, -0.6, -3.7],
        [0.3, 0.55, -2.7],
    ]
    .map(|p| p.map(|x: f64| x + offset));
    let mut text = String::new();
    for [x, y, z] in points {
        text += &format!("v {x} {y} {z}\n");
    }
    text += "f 1 2 3\nf 1 3 4\nf 1 4 5\nf 2 4 3\n";
    (text, points.to_vec())
}

/// A scene of `objects` seen by a perspective camera at `eye` looking down -z.
fn camera_scene(eye: [f64; 3], objects: &str) -> String {
    format!(
        r#"{{"camera": {{"type": "perspective", "eye": {eye:?}, "look": [0, 0, -1],
            "up": [0, 1, 0], "focal_length": 1, "width": 1.6, "height": 1.2,
            "resolution": [64, 48]}}, "objects": [{objects}]}}"#
    )
}

fn render(dir: &std::path::Path, json: &str, mode: &str) -> raycast::AnyImages {
    let path = dir.join("scene.json");
    std::fs::write(&path, json).unwrap();
    let scene = raycast::Scene::load(&path).unwrap();
    let mode: raycast::Mode = mode.parse().unwrap();
    common::render_in(&scene, mode, raycast::RenderOptions::default()).unwrap()
}

/// Distances (f64) and whether each pixel hits.
fn distances(images: &raycast::AnyImages) -> Vec<f64> {
    use raycast::AnyImages;
    match images {
        AnyImages::F32(i) => i.distance.iter().map(|&d| f64::from(d)).collect(),
        AnyImages::F64(i) => i.distance.clone(),
    }
}

/// An OBJ is read at the precision of its digits: f64 renders of it (CPU and GPU) give exactly
/// the distances of the same triangles written as scene `triangle` objects, which the scene
/// reader parses in f64. (Read in f32, the vertices would move by up to 2e-8 relative.)
#[test]
fn f64_renders_of_an_obj_use_the_numbers_in_the_file() {
    let dir = TempDir::new().unwrap();
    let (text, points) = decimal_mesh(0.0);
    std::fs::write(dir.path().join("mesh.obj"), text).unwrap();
    let soup = camera_scene([0.0, 0.0, 0.0], r#"{"type": "soup", "obj": "mesh.obj"}"#);
    let corner = |i: usize| format!("{:?}", points[i]);
    let loose: Vec<String> = [[0, 1, 2], [0, 2, 3], [0, 3, 4], [1, 3, 2]]
        .iter()
        .map(|t| {
            format!(
                r#"{{"type": "triangle", "corners": [{}, {}, {}]}}"#,
                corner(t[0]),
                corner(t[1]),
                corner(t[2])
            )
        })
        .collect();
    let loose = camera_scene([0.0, 0.0, 0.0], &loose.join(", "));
    for mode in ["cpu:f64:robust", "gpu:f64:robust", "cpu:f64:textbook"] {
        let a = distances(&render(dir.path(), &soup, mode));
        let b = distances(&render(dir.path(), &loose, mode));
        assert!(a.iter().any(|d| d.is_finite()), "{mode}: the mesh is seen");
        let differ = a.iter().zip(&b).filter(|(x, y)| x != y).count();
        assert_eq!(differ, 0, "{mode}: pixels whose distance differs");
    }
}

/// A mesh 1e6 from the origin, written in f64 text, renders in robust f32 like the same mesh
/// at the origin seen from the same relative eye: the host subtracts the eye in f64 before
/// rounding to f32, so the ids are identical and the distances agree to f32 rounding of the
/// local scale. (Read in f32, its vertices would move by up to 0.03.)
#[test]
fn a_mesh_far_from_the_origin_renders_like_one_at_the_origin() {
    let offset = 1e6 + 0.3;
    let dir = TempDir::new().unwrap();
    let mut renders = Vec::new();
    for (name, shift) in [("near", 0.0), ("far", offset)] {
        let (text, _) = decimal_mesh(shift);
        let file = format!("{name}.obj");
        std::fs::write(dir.path().join(&file), text).unwrap();
        let json = camera_scene(
            [shift; 3],
            &format!(r#"{{"type": "soup", "obj": "{file}"}}"#),
        );
        let images = render(dir.path(), &json, "gpu:f32:robust");
        let raycast::AnyImages::F32(images) = images else {
            panic!("an f32 render gives f32 images")
        };
        renders.push(images);
    }
    let (near, far) = (&renders[0], &renders[1]);
    assert!(near.id.iter().any(|&id| id >= 0), "the mesh is seen");
    assert_eq!(near.id, far.id, "ids");
    for (k, (a, b)) in near.distance.iter().zip(&far.distance).enumerate() {
        if a.is_finite() {
            // Two f32 roundings of the vertices (about 4e-7 of their size, 3.7) and the
            // distance's own.
            assert!(
                (a - b).abs() <= 4.0 * f32::EPSILON * a,
                "pixel {k}: {a} vs {b}"
            );
        }
    }
}

/// Squares facing +z on the plane z = 0, y in [-0.5, 0.5], each by its x range: two OBJ objects
/// of two groups each, and (`square.stl`) one more.
const SQUARES: [(f64, f64); 5] = [
    (-3.0, -2.0),
    (-1.5, -0.5),
    (0.5, 1.5),
    (2.0, 3.0),
    (4.0, 5.0),
];

/// The OBJ of the first four squares: `o left` with groups `a` and `b`, `o right` with `a`
/// and `c`.
fn squares_obj() -> String {
    let mut text = String::new();
    let names = ["o left\ng a", "g b", "o right\ng a", "g c"];
    for (k, (name, (x0, x1))) in names.iter().zip(SQUARES).enumerate() {
        text += &format!("{name}\nv {x0} -0.5 0\nv {x1} -0.5 0\nv {x1} 0.5 0\nv {x0} 0.5 0\n");
        let v = 4 * k + 1;
        text += &format!("f {} {} {} {}\n", v, v + 1, v + 2, v + 3);
    }
    text
}

/// The fifth square as ASCII STL.
fn square_stl() -> String {
    let (x0, x1) = SQUARES[4];
    let facet = |[a, b, c]: [[f64; 2]; 3]| {
        let v = |[x, y]: [f64; 2]| format!("      vertex {x} {y} 0\n");
        format!(
            "  facet normal 0 0 1\n    outer loop\n{}{}{}    endloop\n  endfacet\n",
            v(a),
            v(b),
            v(c)
        )
    };
    let [p, q, r, s] = [[x0, -0.5], [x1, -0.5], [x1, 0.5], [x0, 0.5]];
    format!(
        "solid square\n{}{}endsolid square\n",
        facet([p, q, r]),
        facet([p, r, s])
    )
}

/// `id.npy`'s ids, row by row.
pub(crate) fn id_npy(dir: &std::path::Path) -> Vec<i32> {
    let bytes = std::fs::read(dir.join("id.npy")).unwrap();
    let header = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    let data = &bytes[10 + header..];
    data.chunks(4)
        .map(|c| i32::from_le_bytes(c.try_into().unwrap()))
        .collect()
}

/// The camera the split tests render with: from (0, 0, 6) looking down -z, 60 degrees
/// vertically, 192x72 pixels; `K` as camera.json gives it, focal length and centre.
const EYE_Z: f64 = 6.0;
const SIZE: [usize; 2] = [192, 72];

/// Checks every pixel of a render of the squares into `dir`: it hits exactly where its centre
/// lies inside a square (by more than 1e-6), and then carries `ids[k]` of square `k`; every
/// id of `ids` appears. The pixel's centre on the plane z = 0 follows from camera.json's `K`.
fn check_square_ids(dir: &std::path::Path, ids: &[i32]) {
    let text = std::fs::read_to_string(dir.join("camera.json")).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    let k = |r: usize, c: usize| json["K"][r][c].as_f64().unwrap();
    let (fx, fy, cx, cy) = (k(0, 0), k(1, 1), k(0, 2), k(1, 2));
    let found = id_npy(dir);
    assert_eq!(found.len(), SIZE[0] * SIZE[1]);
    let mut seen = vec![0; ids.len()];
    for (p, &id) in found.iter().enumerate() {
        let (i, j) = ((p / SIZE[0]) as f64, (p % SIZE[0]) as f64);
        let (x, y) = ((j - cx) / fx * EYE_Z, -(i - cy) / fy * EYE_Z);
        let inside = |lo: f64, hi: f64, v: f64| v > lo + 1e-6 && v < hi - 1e-6;
        let outside = |lo: f64, hi: f64, v: f64| v < lo - 1e-6 || v > hi + 1e-6;
        let square = (SQUARES[..ids.len()].iter()).position(|&(x0, x1)| inside(x0, x1, x));
        match square {
            Some(s) if inside(-0.5, 0.5, y) => {
                assert_eq!(id, ids[s], "pixel ({i}, {j}) on square {s}");
                seen[s] += 1;
            }
            _ if outside(-0.5, 0.5, y)
                && (SQUARES[..ids.len()].iter()).all(|&(x0, x1)| outside(x0, x1, x)) =>
            {
                assert_eq!(id, -1, "pixel ({i}, {j}) is off every square");
            }
            _ => {} // within 1e-6 of an edge
        }
    }
    assert!(
        seen.iter().all(|&n| n >= 50),
        "pixels of each square: {seen:?}"
    );
}

/// `raycast render ARGS --device cpu --format npy --size 192x72 -o DIR`; panics unless it
/// succeeds.
fn render_npy(dir: &std::path::Path, args: &[&str]) -> TempDir {
    let out = tempfile::tempdir_in(dir).unwrap();
    let size = format!("{}x{}", SIZE[0], SIZE[1]);
    let output = common::raycast()
        .arg("render")
        .args(args)
        .args(["--device", "cpu", "--format", "npy", "--size", &size, "-o"])
        .arg(out.path())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "render {args:?}:\n{stderr}");
    out
}

#[test]
fn obj_objects_and_groups_render_with_ids_of_their_own() {
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("squares.obj");
    std::fs::write(&obj, squares_obj()).unwrap();
    std::fs::write(dir.path().join("square.stl"), square_stl()).unwrap();
    let obj = obj.to_str().unwrap();
    let view = ["--eye", "0,0,6", "--look-at", "0,0,0", "--fov", "60"];
    // A mesh file given as the scene: each `o` by default, each `g` of each `o`, or whole.
    for (split, ids) in [
        (&[][..], &[0, 0, 1, 1][..]),
        (&["--split", "objects"], &[0, 0, 1, 1]),
        (&["--split", "groups"], &[0, 1, 2, 3]),
        (&["--split", "none"], &[0, 0, 0, 0]),
    ] {
        let out = render_npy(dir.path(), &[&[obj][..], &view, split].concat());
        check_square_ids(out.path(), ids);
    }
    // A scene file renders several meshes together, each split as its soup says.
    let scene = dir.path().join("together.json");
    let camera =
        format!(r#"{{"eye": [0, 0, {EYE_Z}], "look": [0, 0, -1], "up": [0, 1, 0], "fov": 60}}"#);
    for (split, ids) in [("groups", &[0, 1, 2, 3, 4]), ("objects", &[0, 0, 1, 1, 2])] {
        let json = format!(
            r#"{{"camera": {camera}, "objects": [
                {{"type": "soup", "obj": "squares.obj", "split": "{split}"}},
                {{"type": "soup", "stl": "square.stl"}}]}}"#
        );
        std::fs::write(&scene, json).unwrap();
        let out = render_npy(dir.path(), &[scene.to_str().unwrap()]);
        check_square_ids(out.path(), ids);
    }
}

#[test]
fn several_mesh_files_without_views_point_to_a_scene_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let output = common::raycast()
        .args(["render", "a.obj", "b.stl", "-o", out.to_str().unwrap()])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("2 scene files given") && stderr.contains("soups of one scene file"),
        "{stderr}"
    );
    assert!(!out.exists());
}
