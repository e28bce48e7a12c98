//! Triangle-mesh files: STL (binary or ASCII) and OBJ (polygons fan-triangulated).

use std::io::Cursor;
use std::path::Path;

use super::Triangle;
use crate::error::{Error, Result};
use crate::math::Vec3;

/// Loads a mesh by extension: `.obj` as OBJ, anything else as STL.
pub fn load_mesh(path: &Path) -> Result<Vec<Triangle>> {
    let bytes = std::fs::read(path).map_err(|e| Error::Mesh {
        file: path.to_owned(),
        message: format!("cannot read mesh file: {e}"),
    })?;
    let is_obj = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("obj"));
    if is_obj {
        parse_obj(&bytes, path)
    } else {
        parse_stl(&bytes, path)
    }
}

/// Parses STL bytes; corner order (and so the normal) is kept as stored.
pub fn parse_stl(bytes: &[u8], path: &Path) -> Result<Vec<Triangle>> {
    let fail = |message: String| Error::Mesh {
        file: path.to_owned(),
        message,
    };
    let mut cursor = Cursor::new(bytes);
    let reader = stl_io::create_stl_reader(&mut cursor)
        .map_err(|e| fail(format!("not a valid STL file: {e}")))?;
    let mut triangles = Vec::new();
    for (k, t) in reader.enumerate() {
        let t = t.map_err(|e| fail(format!("corrupt STL at triangle {k}: {e}")))?;
        triangles.push(t.vertices.map(|v| Vec3::from_array(v.0.map(f64::from))));
    }
    Ok(triangles)
}

/// Parses OBJ text; every face becomes a fan of triangles in its corner order.
pub fn parse_obj(bytes: &[u8], path: &Path) -> Result<Vec<Triangle>> {
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    let (models, _) =
        tobj::load_obj_buf(
            &mut Cursor::new(bytes),
            &options,
            |_| Ok(Default::default()),
        )
        .map_err(|e| Error::Mesh {
            file: path.to_owned(),
            message: format!("not a valid OBJ file: {e}"),
        })?;
    let mut triangles = Vec::new();
    for model in &models {
        let m = &model.mesh;
        let corner = |i: u32| {
            let i = i as usize * 3;
            let p = &m.positions;
            Vec3::from_array([p[i], p[i + 1], p[i + 2]].map(f64::from))
        };
        for f in m.indices.chunks_exact(3) {
            triangles.push([corner(f[0]), corner(f[1]), corner(f[2])]);
        }
    }
    Ok(triangles)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn obj_quad_becomes_two_triangles_in_corner_order() {
        let text = b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";
        let t = parse_obj(text, Path::new("quad.obj")).unwrap();
        assert_eq!(t.len(), 2);
        assert_eq!(t[0][1], Vec3::from_array([1.0, 0.0, 0.0]));
        assert_eq!(t[1][2], Vec3::from_array([0.0, 1.0, 0.0]));
    }

    #[test]
    fn truncated_binary_stl_is_an_error() {
        let mut bytes = vec![0u8; 80];
        bytes.extend_from_slice(&5u32.to_le_bytes());
        bytes.extend_from_slice(&[0u8; 60]);
        let err = parse_stl(&bytes, Path::new("bad.stl")).unwrap_err();
        assert!(err.to_string().starts_with("bad.stl: "), "{err}");
    }
}
