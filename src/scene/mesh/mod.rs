//! Triangle-mesh files: STL (binary or ASCII), OBJ and PLY (ASCII or binary), polygons
//! fan-triangulated in corner order.
//!
//! The parsers are our own: a whole file is read into memory and parsed from the buffer, so
//! meshes of millions of triangles load in well under a second, and every error names where in
//! the file it is, as `line N: ...` (text) or `byte N: ...` (binary), after the file name.

mod obj;
mod ply;
mod stl;
mod text;

use std::fmt;
use std::path::Path;
use std::str::FromStr;

use super::Triangle;
use crate::error::{Error, Result};
use crate::math::Vec3;

/// Which parts of a mesh file become objects of their own, each with its id: OBJ files name
/// objects (`o`) and groups (`g`); an STL or PLY file is always one object. A scene file's
/// soup names it in lower case (`"split": "groups"`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Split {
    /// Each object (`o`) of an OBJ file.
    #[default]
    Objects,
    /// Each group (`g`) of each object of an OBJ file.
    Groups,
    /// The whole file is one object.
    None,
}

impl Split {
    /// Its name in scene files and on the command line.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Split::Objects => "objects",
            Split::Groups => "groups",
            Split::None => "none",
        }
    }
}

impl FromStr for Split {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        let all = [Split::Objects, Split::Groups, Split::None];
        let name = s.trim();
        (all.into_iter().find(|x| x.name() == name))
            .ok_or_else(|| format!("unknown split `{name}` (expected objects, groups or none)"))
    }
}

/// One object of a mesh file ([`Split`]).
#[derive(Clone, Debug, PartialEq)]
pub struct MeshPart {
    /// Its OBJ names: the object's, `object/group` for a group, "" for a whole file.
    pub name: String,
    /// Its triangles, in the file's order.
    pub triangles: Vec<Triangle>,
}

impl MeshPart {
    /// A whole file's triangles as its one part.
    pub(crate) fn whole(triangles: Vec<Triangle>) -> Vec<MeshPart> {
        vec![MeshPart {
            name: String::new(),
            triangles,
        }]
    }
}

/// Loads a mesh by extension: `.obj` as OBJ, `.ply` as PLY, anything else as STL; all of its
/// triangles, in the file's order.
pub fn load_mesh(path: &Path) -> Result<Vec<Triangle>> {
    let mut parts = load_mesh_parts(path, Split::None)?;
    Ok(parts.pop().map(|p| p.triangles).unwrap_or_default())
}

/// Loads a mesh as [`load_mesh`] does, in the parts `split` asks for (at least one).
pub(crate) fn load_mesh_parts(path: &Path, split: Split) -> Result<Vec<MeshPart>> {
    let bytes = std::fs::read(path).map_err(|e| Error::Mesh {
        file: path.to_owned(),
        message: format!("cannot read mesh file: {e}"),
    })?;
    parse_mesh(&bytes, path, split)
}

/// Parses a mesh file's `bytes`, by the extension of `path` as [`load_mesh`] does, in the
/// parts `split` asks for (at least one; [`Split::None`]: the whole file as one part); `path`
/// names the file in errors.
pub fn parse_mesh(bytes: &[u8], path: &Path, split: Split) -> Result<Vec<MeshPart>> {
    let parsed = match Format::of(path) {
        Format::Stl => stl::parse(bytes).map(MeshPart::whole),
        Format::Obj => obj::parse(bytes, split),
        Format::Ply => ply::parse(bytes).map(MeshPart::whole),
    };
    parsed.map_err(|e| e.in_file(path))
}

/// The mesh formats, chosen by file extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Stl,
    Obj,
    Ply,
}

impl Format {
    fn of(path: &Path) -> Format {
        let is = |ext: &str| {
            path.extension()
                .is_some_and(|e| e.eq_ignore_ascii_case(ext))
        };
        if is("obj") {
            Format::Obj
        } else if is("ply") {
            Format::Ply
        } else {
            Format::Stl
        }
    }
}

/// Where in a mesh file a problem is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum At {
    /// 1-based line of a text file or text header.
    Line(usize),
    /// 0-based byte offset into a binary file.
    Byte(usize),
}

/// A parse failure: its place and what is wrong there.
#[derive(Clone, Debug, PartialEq, Eq)]
struct ParseError {
    at: At,
    message: String,
}

type Parsed<T> = std::result::Result<T, ParseError>;

fn at_line(line: usize, message: impl Into<String>) -> ParseError {
    ParseError::at(At::Line(line), message)
}

fn at_byte(byte: usize, message: impl Into<String>) -> ParseError {
    ParseError::at(At::Byte(byte), message)
}

impl ParseError {
    fn at(at: At, message: impl Into<String>) -> ParseError {
        ParseError {
            at,
            message: message.into(),
        }
    }

    fn in_file(self, path: &Path) -> Error {
        Error::Mesh {
            file: path.to_owned(),
            message: self.to_string(),
        }
    }
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.at {
            At::Line(n) => write!(f, "line {n}: {}", self.message),
            At::Byte(n) => write!(f, "byte {n}: {}", self.message),
        }
    }
}

/// Appends the fan triangulation of one polygon, given by its corners' indices into `vertices`
/// (already checked): corners 0 1 2 3 become (0,1,2), (0,2,3), the order OBJ and PLY writers
/// and other loaders assume, which keeps every triangle's winding (and so its normal).
fn fan(corners: &[usize], vertices: &[Vec3<f64>], triangles: &mut Vec<Triangle>) {
    let corner = |k: usize| glam::DVec3::from(vertices[corners[k]]);
    for k in 1..corners.len().saturating_sub(1) {
        triangles.push([corner(0), corner(k), corner(k + 1)]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn format_by_extension_defaults_to_stl() {
        assert_eq!(Format::of(Path::new("a/b.OBJ")), Format::Obj);
        assert_eq!(Format::of(Path::new("b.ply")), Format::Ply);
        assert_eq!(Format::of(Path::new("b.stl")), Format::Stl);
        assert_eq!(Format::of(Path::new("bunny")), Format::Stl);
    }

    #[test]
    fn errors_start_with_their_place_after_the_file() {
        let err = at_byte(84, "bad").in_file(Path::new("m.stl"));
        assert_eq!(err.to_string(), "m.stl: byte 84: bad");
        let err = at_line(7, "bad").in_file(Path::new("m.obj"));
        assert_eq!(err.to_string(), "m.obj: line 7: bad");
    }

    #[test]
    fn fan_keeps_corner_order() {
        let v = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ]
        .map(Vec3::from_array);
        let mut t = Vec::new();
        fan(&[0, 1, 2, 3], &v, &mut t);
        let v = v.map(glam::DVec3::from);
        assert_eq!(t, vec![[v[0], v[1], v[2]], [v[0], v[2], v[3]]]);
    }

    #[test]
    fn unreadable_file_is_an_error_naming_it() {
        let err = load_mesh(Path::new("/nonexistent/x.obj")).unwrap_err();
        assert!(
            err.to_string()
                .starts_with("/nonexistent/x.obj: cannot read mesh file: "),
            "{err}"
        );
    }
}
