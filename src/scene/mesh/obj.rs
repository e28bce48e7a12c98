//! Wavefront OBJ: `v` vertices and `f` faces (polygons, fan-triangulated in corner order).
//!
//! Only geometry is read. Every other statement (`vn vt g o s usemtl mtllib l p`, and keywords
//! this reader does not know) is skipped silently, as tobj, Blender and other loaders do: OBJ
//! files carry many vendor extensions, and none of them changes the triangles.

use super::text::{self, found, show};
use super::{Parsed, Triangle, at_line, fan};
use crate::math::{Float, Vec3};

/// Parses OBJ text. Faces may only refer to vertices defined above them (the OBJ rule that
/// makes negative, relative indices meaningful).
pub(super) fn parse(bytes: &[u8]) -> Parsed<Vec<Triangle>> {
    let mut vertices: Vec<Vec3<f64>> = Vec::new();
    let mut triangles = Vec::new();
    let mut corners = Vec::new();
    for (n, line) in text::lines(text::without_bom(bytes), 1) {
        // A `#` starts a comment, also after a statement.
        let mut words = text::words(line).take_while(|w| w[0] != b'#');
        match words.next() {
            Some(b"v") => vertices.push(vertex(n, words)?),
            Some(b"f") => {
                face(n, words, vertices.len(), &mut corners)?;
                fan(&corners, &vertices, &mut triangles);
            }
            _ => {}
        }
    }
    Ok(triangles)
}

/// `v x y z`, optionally followed by `w` or by a vertex colour `r g b` (a common extension);
/// the extras must be numbers but are not used.
fn vertex<'a>(n: usize, mut words: impl Iterator<Item = &'a [u8]>) -> Parsed<Vec3<f64>> {
    let point = text::point(n, "v", &mut words, Float::F64)?;
    let mut extras = 0;
    for word in words {
        if text::parse::<f64>(word).is_none() {
            return Err(at_line(
                n,
                format!("expected a number, found '{}'", show(word)),
            ));
        }
        extras += 1;
    }
    if !matches!(extras, 0 | 1 | 3) {
        return Err(at_line(
            n,
            format!("'v' takes 3, 4 or 6 numbers, found {}", 3 + extras),
        ));
    }
    Ok(point)
}

/// `f` with corners `i`, `i/t`, `i//n` or `i/t/n`: fills `corners` with 0-based vertex indices.
/// Texture and normal indices are not read, so they are not checked either.
fn face<'a>(
    n: usize,
    words: impl Iterator<Item = &'a [u8]>,
    vertex_count: usize,
    corners: &mut Vec<usize>,
) -> Parsed<()> {
    corners.clear();
    for word in words {
        corners.push(index(n, word, vertex_count)?);
    }
    if corners.len() < 3 {
        let count = corners.len();
        return Err(at_line(
            n,
            format!("face has {count} corners, needs at least 3"),
        ));
    }
    Ok(())
}

/// One face corner's vertex index: 1-based, or negative to count back from the last vertex
/// defined so far (-1 is the last).
fn index(n: usize, word: &[u8], vertex_count: usize) -> Parsed<usize> {
    let position = word.split(|&b| b == b'/').next().unwrap_or_default();
    let Some(i) = text::integer(position) else {
        let message = format!("expected a vertex index, found {}", found(Some(word)));
        return Err(at_line(n, message));
    };
    let resolved = match i {
        1.. => usize::try_from(i - 1).ok(),
        ..0 => usize::try_from(i.unsigned_abs())
            .ok()
            .and_then(|back| vertex_count.checked_sub(back)),
        0 => return Err(at_line(n, "face index 0 (OBJ indices start at 1)")),
    };
    resolved.filter(|&k| k < vertex_count).ok_or_else(|| {
        at_line(
            n,
            format!("face index {i} but only {vertex_count} vertices so far"),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f64, y: f64, z: f64) -> Vec3<f64> {
        Vec3::from_array([x, y, z])
    }

    fn err(text: &str) -> String {
        parse(text.as_bytes()).unwrap_err().to_string()
    }

    #[test]
    fn quad_becomes_a_fan_in_corner_order() {
        let text = b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";
        let t = parse(text).unwrap();
        let [a, b, c, d] = [v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.), v(0., 1., 0.)];
        assert_eq!(t, vec![[a, b, c], [a, c, d]]);
    }

    #[test]
    fn all_corner_forms_and_relative_indices() {
        let text = "# comment\r\nmtllib x.mtl\no thing\nv 1 2 3\nv 4 5 6 1.0\nvt 0 0\nvn 0 0 1\n\
                    v -7.5 8e1 9 0.1 0.2 0.3\ng part\nusemtl m\ns off\nf 1/1 2//1 3/1/1\n\
                    f -3 -2 -1 # trailing comment\nl 1 2\np 1\nfoo bar\n";
        let t = parse(text.as_bytes()).unwrap();
        let tri = [v(1., 2., 3.), v(4., 5., 6.), v(-7.5, 80., 9.)];
        assert_eq!(t, vec![tri, tri]);
    }

    #[test]
    fn relative_indices_count_from_the_last_vertex_so_far() {
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 0 0 1\nf -4 -1 -2\n";
        let t = parse(text.as_bytes()).unwrap();
        assert_eq!(t[1], [v(0., 0., 0.), v(0., 0., 1.), v(0., 1., 0.)]);
    }

    #[test]
    fn coordinates_are_read_in_f64() {
        let t = parse(b"v 0.1 0.2 1000000.3\nv 0 0 0\nv 1 1 1\nf 1 2 3\n").unwrap();
        assert_eq!(t[0][0], Vec3::from_array([0.1, 0.2, 1000000.3]));
    }

    #[test]
    fn empty_file_has_no_triangles() {
        assert_eq!(parse(b""), Ok(vec![]));
        assert_eq!(parse(b"\xEF\xBB\xBFv 1 2 3\n"), Ok(vec![]));
    }

    #[test]
    fn index_out_of_range_names_line_and_count() {
        let text = "v 0 0 0\nv 1 0 0\n\nv 0 1 0\nf 1 2 57\n";
        assert_eq!(
            err(text),
            "line 5: face index 57 but only 3 vertices so far"
        );
        // A forward reference is out of range too.
        assert_eq!(
            err("v 0 0 0\nf 1 2 3\nv 1 0 0\nv 0 1 0\n"),
            "line 2: face index 2 but only 1 vertices so far"
        );
        assert_eq!(
            err("v 0 0 0\nv 0 0 0\nv 0 0 0\nf 1 2 -4\n"),
            "line 4: face index -4 but only 3 vertices so far"
        );
        assert_eq!(
            err("v 0 0 0\nf 0 1 1\n"),
            "line 2: face index 0 (OBJ indices start at 1)"
        );
        assert_eq!(
            err("f 99999999999999999999 1 1\n"),
            "line 1: expected a vertex index, found '99999999999999999999'"
        );
    }

    #[test]
    fn face_needs_three_corners() {
        let text = "v 0 0 0\nv 1 0 0\nf 1 2\n";
        assert_eq!(err(text), "line 3: face has 2 corners, needs at least 3");
        assert_eq!(err("f\n"), "line 1: face has 0 corners, needs at least 3");
    }

    #[test]
    fn bad_numbers_name_line_and_word() {
        assert_eq!(
            err("v 0 0 0\nv 1 x 0\n"),
            "line 2: expected 3 numbers after 'v', found 'x'"
        );
        assert_eq!(
            err("v 0 0\n"),
            "line 1: expected 3 numbers after 'v', found end of line"
        );
        assert_eq!(err("v 0 0 0 w\n"), "line 1: expected a number, found 'w'");
        assert_eq!(
            err("v 0 0 0 1 2\n"),
            "line 1: 'v' takes 3, 4 or 6 numbers, found 5"
        );
        assert_eq!(
            err("v 0 0 0\nf 1 a/1 1\n"),
            "line 2: expected a vertex index, found 'a/1'"
        );
    }

    #[test]
    fn non_finite_coordinates_are_errors() {
        assert_eq!(
            err("v 0 0 0\nv inf 0 0\n"),
            "line 2: coordinate 'inf' is not a finite 64-bit float"
        );
        assert_eq!(
            err("v 0 NaN 0\n"),
            "line 1: coordinate 'NaN' is not a finite 64-bit float"
        );
    }
}
