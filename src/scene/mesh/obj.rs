//! Wavefront OBJ: `v` vertices and `f` faces (polygons, fan-triangulated in corner order),
//! and the `o` objects and `g` groups they belong to.
//!
//! Only geometry and its objects and groups are read. Every other statement (`vn vt s usemtl
//! mtllib l p`, and keywords this reader does not know) is skipped silently, as tobj, Blender
//! and other loaders do: OBJ files carry many vendor extensions, and none of them changes the
//! triangles.

use std::collections::HashMap;

use super::text::{self, found, show};
use super::{MeshPart, Parsed, Split, at_line, fan};
use crate::math::{Float, Vec3};

/// Parses OBJ text into its parts as `split` asks: the whole file; a part for each object
/// (`o`); or a part for each group (`g`) of each object, named `object/group` (or either
/// alone where the other is unnamed). An `o` or `g` holds until the next of its kind; faces
/// before the first have the empty name. Parts come in the order of their first faces, their
/// triangles in file order; a name with no faces makes no part, and a file without faces is
/// one empty part. Faces may only refer to vertices defined above them (the OBJ rule that
/// makes negative, relative indices meaningful).
pub(super) fn parse(bytes: &[u8], split: Split) -> Parsed<Vec<MeshPart>> {
    let mut vertices: Vec<Vec3<f64>> = Vec::new();
    let mut parts = Parts::default();
    let (mut object, mut group) = (String::new(), String::new());
    // The part faces go to, looked up again only after an `o` or `g`.
    let mut current = None;
    let mut corners = Vec::new();
    for (n, line) in text::lines(text::without_bom(bytes), 1) {
        // A `#` starts a comment, also after a statement.
        let mut words = text::words(line).take_while(|w| w[0] != b'#');
        match words.next() {
            Some(b"v") => vertices.push(vertex(n, words)?),
            Some(b"f") => {
                face(n, words, vertices.len(), &mut corners)?;
                let k = *current.get_or_insert_with(|| match split {
                    Split::None => parts.index("", ""),
                    Split::Objects => parts.index(&object, ""),
                    Split::Groups => parts.index(&object, &group),
                });
                fan(&corners, &vertices, &mut parts.parts[k].triangles);
            }
            Some(b"o") => (object, current) = (name(words), None),
            Some(b"g") => (group, current) = (name(words), None),
            _ => {}
        }
    }
    Ok(parts.into_parts())
}

/// The parts of a file as its faces come, by object and group name.
#[derive(Default)]
struct Parts {
    parts: Vec<MeshPart>,
    by_name: HashMap<(String, String), usize>,
}

impl Parts {
    /// The index of the part of `object` and `group`, a new part if it has none yet.
    fn index(&mut self, object: &str, group: &str) -> usize {
        let key = (object.to_owned(), group.to_owned());
        let next = self.parts.len();
        let k = *self.by_name.entry(key).or_insert(next);
        if k == next {
            let names: Vec<&str> = [object, group]
                .into_iter()
                .filter(|n| !n.is_empty())
                .collect();
            self.parts.push(MeshPart {
                name: names.join("/"),
                triangles: Vec::new(),
            });
        }
        k
    }

    fn into_parts(mut self) -> Vec<MeshPart> {
        if self.parts.is_empty() {
            self.index("", "");
        }
        self.parts
    }
}

/// The name an `o` or `g` statement gives: its words, one space apart (`g a b` puts faces in
/// groups `a` and `b` at once; they are one part, `a b`).
fn name<'a>(words: impl Iterator<Item = &'a [u8]>) -> String {
    let words: Vec<_> = words.map(String::from_utf8_lossy).collect();
    words.join(" ")
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
    use crate::scene::Triangle;

    fn v(x: f64, y: f64, z: f64) -> glam::DVec3 {
        glam::DVec3::new(x, y, z)
    }

    fn err(text: &str) -> String {
        parse(text.as_bytes(), Split::Objects)
            .unwrap_err()
            .to_string()
    }

    /// The triangles of a file read whole.
    fn triangles(bytes: &[u8]) -> Vec<Triangle> {
        let mut parts = parse(bytes, Split::None).unwrap();
        assert_eq!(parts.len(), 1);
        parts.pop().unwrap().triangles
    }

    #[test]
    fn quad_becomes_a_fan_in_corner_order() {
        let text = b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";
        let t = triangles(text);
        let [a, b, c, d] = [v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.), v(0., 1., 0.)];
        assert_eq!(t, vec![[a, b, c], [a, c, d]]);
    }

    #[test]
    fn all_corner_forms_and_relative_indices() {
        let text = "# comment\r\nmtllib x.mtl\no thing\nv 1 2 3\nv 4 5 6 1.0\nvt 0 0\nvn 0 0 1\n\
                    v -7.5 8e1 9 0.1 0.2 0.3\ng part\nusemtl m\ns off\nf 1/1 2//1 3/1/1\n\
                    f -3 -2 -1 # trailing comment\nl 1 2\np 1\nfoo bar\n";
        let t = triangles(text.as_bytes());
        let tri = [v(1., 2., 3.), v(4., 5., 6.), v(-7.5, 80., 9.)];
        assert_eq!(t, vec![tri, tri]);
    }

    #[test]
    fn relative_indices_count_from_the_last_vertex_so_far() {
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 0 0 1\nf -4 -1 -2\n";
        let t = triangles(text.as_bytes());
        assert_eq!(t[1], [v(0., 0., 0.), v(0., 0., 1.), v(0., 1., 0.)]);
    }

    #[test]
    fn coordinates_are_read_in_f64() {
        let t = triangles(b"v 0.1 0.2 1000000.3\nv 0 0 0\nv 1 1 1\nf 1 2 3\n");
        assert_eq!(t[0][0], Vec3::from_array([0.1, 0.2, 1000000.3]).into());
    }

    #[test]
    fn empty_file_is_one_part_without_triangles() {
        for split in [Split::None, Split::Objects, Split::Groups] {
            for text in [&b""[..], b"\xEF\xBB\xBFv 1 2 3\n", b"o a\ng b\nv 1 2 3\n"] {
                let parts = parse(text, split).unwrap();
                assert_eq!(parts.len(), 1);
                assert_eq!((parts[0].name.as_str(), parts[0].triangles.len()), ("", 0));
            }
        }
    }

    /// Each part's name and its triangles' first corners' x.
    fn parts(text: &str, split: Split) -> Vec<(String, Vec<f64>)> {
        let parts = parse(text.as_bytes(), split).unwrap();
        (parts.into_iter())
            .map(|p| (p.name, p.triangles.iter().map(|t| t[0].x).collect()))
            .collect()
    }

    /// Faces of two objects, each of two groups, one group entered twice; each face's first
    /// vertex tells it apart (v k is at x = k).
    const OBJECTS_AND_GROUPS: &str = "v 1 0 0\nv 2 0 0\nv 3 0 0\nv 4 0 0\nv 5 0 0\nv 6 0 0\n\
        f 1 2 3\no cube\ng top\nf 2 3 4\ng side wall\nf 3 4 5\ng top\nf 4 5 6\n\
        o tetra\nf 5 6 1\ng\nf 6 1 2\no cube\nf 1 3 5\n";

    #[test]
    fn each_object_is_a_part_in_the_order_of_its_first_face() {
        let named = |n: &str, x: &[f64]| (n.to_owned(), x.to_vec());
        assert_eq!(
            parts(OBJECTS_AND_GROUPS, Split::Objects),
            [
                named("", &[1.]),
                named("cube", &[2., 3., 4., 1.]),
                named("tetra", &[5., 6.]),
            ]
        );
        // A group holds across `o`; `g` alone is the unnamed group.
        assert_eq!(
            parts(OBJECTS_AND_GROUPS, Split::Groups),
            [
                named("", &[1.]),
                named("cube/top", &[2., 4.]),
                named("cube/side wall", &[3.]),
                named("tetra/top", &[5.]),
                named("tetra", &[6.]),
                named("cube", &[1.]),
            ]
        );
        assert_eq!(
            parts(OBJECTS_AND_GROUPS, Split::None),
            [named("", &[1., 2., 3., 4., 5., 6., 1.])]
        );
        // Names without faces make no parts.
        let text = "o empty\ng nothing\nv 0 0 0\nv 1 0 0\nv 0 1 0\no full\nf 1 2 3\no last\n";
        assert_eq!(parts(text, Split::Groups), [named("full/nothing", &[0.])]);
    }

    #[test]
    fn errors_name_the_line_whatever_the_split() {
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\no a\nf 1 2 3\no b\ng c\nf 1 2 4\n";
        for split in [Split::None, Split::Objects, Split::Groups] {
            let message = parse(text.as_bytes(), split).unwrap_err().to_string();
            assert_eq!(message, "line 8: face index 4 but only 3 vertices so far");
        }
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
