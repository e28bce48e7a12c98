//! Meshes declared once and placed by instances (#64), end to end: an instanced scene renders
//! exactly as the same scene with every copy written out as a soup (transforms exact in f64,
//! a mirrored copy with its corners in reverse order); a mesh declared and never placed is a
//! warning; bad instances are one `error:` line, exit code 2 and no output.

use crate::common;

use common::assert_no_files;

use tempfile::TempDir;

/// A tetrahedron, dyadic coordinates.
const CORNERS: [[f64; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.25, 0.25, 0.75],
];
const FACES: [[usize; 3]; 4] = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]];

/// An OBJ of triangles, one vertex line a corner.
fn obj(triangles: &[[[f64; 3]; 3]]) -> String {
    let mut text = String::new();
    for t in triangles {
        for [x, y, z] in t {
            text += &format!("v {x:?} {y:?} {z:?}\n");
        }
    }
    for k in 0..triangles.len() {
        text += &format!("f {} {} {}\n", 3 * k + 1, 3 * k + 2, 3 * k + 3);
    }
    text
}

fn tetrahedron() -> Vec<[[f64; 3]; 3]> {
    FACES.iter().map(|f| f.map(|i| CORNERS[i])).collect()
}

const CAMERA: &str = r#""camera": {"eye": [0.5, 0.5, 6], "look": [0, 0, -1], "up": [0, 1, 0],
    "focal_length": 2, "width": 1.6, "height": 1.2, "resolution": [64, 48]}"#;

/// Renders `scene` (JSON, written beside `files`) to npy ids and distances; returns them.
fn render(dir: &TempDir, name: &str, scene: &str, files: &[(String, String)]) -> Vec<Vec<u8>> {
    for (file, text) in files {
        std::fs::write(dir.path().join(file), text).unwrap();
    }
    let path = dir.path().join(format!("{name}.json"));
    std::fs::write(&path, scene).unwrap();
    let out = dir.path().join(name);
    let run = common::raycast()
        .args([
            "render",
            path.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ])
        .args(["--format", "npy", "--outputs", "id,distance,normal"])
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    ["id.npy", "distance.npy", "normal.npy"]
        .map(|f| std::fs::read(out.join(f)).unwrap())
        .to_vec()
}

/// Three copies, by a matrix, by translate and scale, and mirrored, render as the same copies
/// written out; the mirrored copy's normals face out as the written-out one's (corners
/// reversed) do.
#[test]
fn instances_render_as_their_copies_written_out() {
    let dir = tempfile::tempdir().unwrap();
    let placed = |f: &dyn Fn([f64; 3]) -> [f64; 3], mirror: bool| {
        let t: Vec<[[f64; 3]; 3]> = (tetrahedron().iter())
            .map(|t| {
                let [a, b, c] = t.map(f);
                if mirror { [a, c, b] } else { [a, b, c] }
            })
            .collect();
        obj(&t)
    };
    let copies = [
        placed(&|[x, y, z]| [2.0 * x - 1.5, 0.5 * y + 1.0, z], false),
        placed(
            &|[x, y, z]| [0.5 * x + 0.25, 0.5 * y - 1.0, 0.5 * z + 0.125],
            false,
        ),
        placed(&|[x, y, z]| [-x + 2.5, y, z], true),
    ];
    let soups: Vec<(String, String)> = (copies.iter().enumerate())
        .map(|(k, t)| (format!("copy{k}.obj"), t.clone()))
        .collect();
    let written = format!(
        r#"{{{CAMERA}, "objects": [{}]}}"#,
        (0..3)
            .map(|k| format!(r#"{{"type": "soup", "obj": "copy{k}.obj"}}"#))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let instanced = format!(
        r#"{{{CAMERA}, "meshes": {{"tet": {{"obj": "tet.obj"}}}}, "objects": [
            {{"type": "instance", "mesh": "tet", "transform": [[2, 0, 0, -1.5], [0, 0.5, 0, 1], [0, 0, 1, 0], [0, 0, 0, 1]]}},
            {{"type": "instance", "mesh": "tet", "transform": {{"translate": [0.25, -1, 0.125], "scale": 0.5}}}},
            {{"type": "instance", "mesh": "tet", "transform": {{"translate": [2.5, 0, 0], "scale": [-1, 1, 1]}}}}]}}"#
    );
    let a = render(&dir, "written", &written, &soups);
    let b = render(
        &dir,
        "instanced",
        &instanced,
        &[("tet.obj".into(), obj(&tetrahedron()))],
    );
    assert_eq!(a, b);
    // Every copy is seen: ids 0, 1 and 2 in the id image (int32 after the npy header).
    let ids = &b[0];
    let header = 10 + u16::from_le_bytes([ids[8], ids[9]]) as usize;
    let seen: std::collections::BTreeSet<i32> = (ids[header..].chunks(4))
        .map(|c| i32::from_le_bytes(c.try_into().unwrap()))
        .collect();
    assert!([0, 1, 2].iter().all(|k| seen.contains(k)), "{seen:?}");
}

/// Runs `raycast render` on `scene` (with the tetrahedron as tet.obj) in a scratch folder:
/// what it printed, and where its output would be.
fn run(scene: &str) -> (std::process::Output, std::path::PathBuf, TempDir) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("tet.obj"), obj(&tetrahedron())).unwrap();
    let path = dir.path().join("scene.json");
    std::fs::write(&path, scene).unwrap();
    let out = dir.path().join("out");
    let output = common::raycast()
        .args([
            "render",
            path.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    (output, out, dir)
}

#[test]
fn a_mesh_never_placed_is_a_warning() {
    let scene = format!(
        r#"{{{CAMERA}, "meshes": {{"tet": {{"obj": "tet.obj"}}, "spare": {{"obj": "tet.obj"}}}},
            "objects": [{{"type": "instance", "mesh": "tet"}}]}}"#
    );
    let (output, out, _dir) = run(&scene);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(
        stderr.contains("warning: ")
            && stderr.contains("meshes.spare is declared but no instance places it"),
        "{stderr}"
    );
    assert!(out.join("id.png").exists());
}

#[test]
fn bad_instances_are_one_line_naming_the_field() {
    let cases = [
        (
            r#"{"type": "instance", "mesh": "tett"}"#,
            "objects[0].mesh: unknown mesh `tett`, did you mean `tet`?",
        ),
        (
            r#"{"type": "instance", "mesh": "tet", "transform": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 0], [0, 0, 0, 1]]}"#,
            "objects[0].transform: is singular",
        ),
        (
            r#"{"type": "instance", "mesh": "tet", "transform": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [1, 0, 0, 1]]}"#,
            "objects[0].transform[3]: the last row must be [0, 0, 0, 1]",
        ),
        (
            r#"{"type": "instance", "mesh": "tet", "transform": {"scale": [1, 0, 1]}}"#,
            "objects[0].transform.scale: must not be 0",
        ),
        (
            r#"{"type": "instance", "mesh": "tet", "transform": {"rotate": {"axis": [0, 0, 0], "degrees": 30}}}"#,
            "objects[0].transform.rotate.axis: must be a non-zero vector",
        ),
        (
            r#"{"type": "instance", "mesh": "tet", "transform": {"translate": [1e30, 0, 0]}}"#,
            "objects[0].transform.translate[0]: magnitude",
        ),
        (
            r#"{"type": "instance", "mesh": "tet", "transform": {"move": [1, 0, 0]}}"#,
            "expected a 4x4 matrix (four rows of four numbers) or an object of \"translate\", \"rotate\" and \"scale\"",
        ),
    ];
    for (object, expected) in cases {
        let scene = format!(
            r#"{{{CAMERA}, "meshes": {{"tet": {{"obj": "tet.obj"}}}}, "objects": [{object}]}}"#
        );
        let (output, out, _dir) = run(&scene);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{stderr}");
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert!(
            stderr.starts_with("error: ") && stderr.contains("scene.json"),
            "{stderr}"
        );
        assert!(
            stderr.contains(expected),
            "`{expected}` missing from: {stderr}"
        );
        assert_no_files(&out);
    }
}
