//! STL, binary or ASCII. Corner order (and so the normal) is kept as stored; the stored facet
//! normals are not read (the renderer computes normals from the corners, and exporters write
//! zeros or NaN there for degenerate facets).

use super::text::{self, found, show};
use super::{Parsed, Triangle, at_byte, at_line};
use crate::math::{Float, Vec3};

/// Binary STL: an 80-byte header, a little-endian u32 triangle count, then per triangle a
/// normal and three corners (12 little-endian f32) and a 2-byte attribute.
const HEADER: usize = 84;
const RECORD: usize = 50;

/// Parses STL bytes, telling binary from ASCII by [`is_ascii`].
pub(super) fn parse(bytes: &[u8]) -> Parsed<Vec<Triangle>> {
    if is_ascii(bytes) {
        ascii(bytes)
    } else {
        binary(bytes)
    }
}

/// ASCII STL starts with `solid`, but so do many binary files, whose 80-byte header is free
/// text. A file is binary if its size is exactly what its triangle count promises; otherwise a
/// NUL byte among the first 84 decides, since a binary header is often NUL-padded and the
/// count's high byte is 0 for any count below 2^24 (text has no NUL bytes).
fn is_ascii(bytes: &[u8]) -> bool {
    let starts_solid = text::without_bom(bytes)
        .trim_ascii_start()
        .starts_with(b"solid");
    starts_solid
        && binary_size(bytes) != Some(bytes.len() as u64)
        && !bytes[..bytes.len().min(HEADER)].contains(&0)
}

/// The size a binary STL must have given its triangle count, if it has a count at all.
fn binary_size(bytes: &[u8]) -> Option<u64> {
    let count = u32::from_le_bytes(bytes.get(80..HEADER)?.try_into().ok()?);
    Some(HEADER as u64 + RECORD as u64 * u64::from(count))
}

/// Parses binary STL. Bytes after the last declared triangle are ignored, as other readers do.
fn binary(bytes: &[u8]) -> Parsed<Vec<Triangle>> {
    let Some(size) = binary_size(bytes) else {
        let message = format!(
            "binary STL needs an 84-byte header and triangle count, the file has {} bytes",
            bytes.len()
        );
        return Err(at_byte(0, message));
    };
    if size > bytes.len() as u64 {
        let count = (size - HEADER as u64) / RECORD as u64;
        let message = format!(
            "binary STL declares {count} triangles ({size} bytes) but the file has {} bytes",
            bytes.len()
        );
        return Err(at_byte(HEADER, message));
    }
    // One serial pass: the time goes to reading the file and faulting in the output's pages,
    // not to decoding, so threads do not help (docs/experiments.md#tried-and-not-kept).
    let count = (size as usize - HEADER) / RECORD;
    let mut triangles = Vec::with_capacity(count);
    for (k, record) in bytes[HEADER..size as usize]
        .chunks_exact(RECORD)
        .enumerate()
    {
        let triangle = decode(record);
        if !triangle.iter().all(|c| c.is_finite()) {
            let message =
                format!("triangle {k} has a non-finite corner coordinate (NaN or infinity)");
            return Err(at_byte(HEADER + RECORD * k, message));
        }
        triangles.push(triangle);
    }
    Ok(triangles)
}

/// One binary record's three corners (bytes 12..48; the normal and attribute are skipped).
fn decode(record: &[u8]) -> Triangle {
    let f = |at: usize| f64::from(f32::from_le_bytes(record[at..at + 4].try_into().unwrap()));
    let corner = |at: usize| glam::DVec3::new(f(at), f(at + 4), f(at + 8));
    [corner(12), corner(24), corner(36)]
}

/// Parses ASCII STL, one statement per line as every writer does:
///
/// ```text
/// solid NAME
///   facet normal nx ny nz
///     outer loop
///       vertex x y z      (three times)
///     endloop
///   endfacet
/// endsolid NAME
/// ```
///
/// Several solids may follow each other. A file must end with `endsolid`, so that one cut short
/// between two facets is an error rather than a silently smaller mesh.
fn ascii(bytes: &[u8]) -> Parsed<Vec<Triangle>> {
    let mut lines = Statements::new(bytes);
    let mut triangles = Vec::new();
    while lines.solid()? {
        loop {
            let (n, word) = lines.next("'facet' or 'endsolid'")?;
            match word {
                b"facet" => triangles.push(facet(&mut lines)?),
                b"endsolid" => break,
                _ => {
                    let message = format!("expected 'facet' or 'endsolid', found '{}'", show(word));
                    return Err(at_line(n, message));
                }
            }
        }
    }
    Ok(triangles)
}

/// The rest of a facet after its `facet normal` line.
fn facet(lines: &mut Statements) -> Parsed<Triangle> {
    lines.keyword("'outer loop'", b"outer")?;
    let mut corners = [glam::DVec3::ZERO; 3];
    for corner in &mut corners {
        *corner = lines.vertex()?.into();
    }
    lines.keyword("'endloop'", b"endloop")?;
    lines.keyword("'endfacet'", b"endfacet")?;
    Ok(corners)
}

/// The non-blank lines of an ASCII STL file, read by their first word.
struct Statements<'a> {
    lines: Box<dyn Iterator<Item = (usize, &'a [u8])> + 'a>,
    /// The number of the last line read, for end-of-file errors.
    last: usize,
    /// The words after the first of the line last read.
    rest: &'a [u8],
}

impl<'a> Statements<'a> {
    fn new(bytes: &'a [u8]) -> Self {
        Statements {
            lines: Box::new(text::lines(text::without_bom(bytes), 1)),
            last: 0,
            rest: b"",
        }
    }

    /// The next statement's line number and first word; `expected` describes it for the error
    /// at the end of the file.
    fn next(&mut self, expected: &str) -> Parsed<(usize, &'a [u8])> {
        self.next_or_end()
            .ok_or_else(|| at_line(self.last, format!("expected {expected}, found end of file")))
    }

    fn next_or_end(&mut self) -> Option<(usize, &'a [u8])> {
        for (n, line) in self.lines.by_ref() {
            self.last = n;
            let mut rest = line;
            if let Some(word) = text::next_word(&mut rest) {
                self.rest = rest;
                return Some((n, word));
            }
        }
        None
    }

    /// Reads a statement that must start with `word` (what follows it is not checked).
    fn keyword(&mut self, expected: &str, word: &[u8]) -> Parsed<()> {
        let (n, first) = self.next(expected)?;
        if first != word {
            let message = format!("expected {expected}, found '{}'", show(first));
            return Err(at_line(n, message));
        }
        Ok(())
    }

    /// Whether another solid starts (`false` at the end of the file).
    fn solid(&mut self) -> Parsed<bool> {
        match self.next_or_end() {
            None => Ok(false),
            Some((_, b"solid")) => Ok(true),
            Some((n, word)) => Err(at_line(
                n,
                format!("expected 'solid', found '{}'", show(word)),
            )),
        }
    }

    /// A `vertex x y z` statement.
    fn vertex(&mut self) -> Parsed<Vec3<f64>> {
        self.keyword("'vertex'", b"vertex")?;
        let n = self.last;
        let mut words = text::words(self.rest);
        let point = text::point(n, "vertex", &mut words, Float::F32)?;
        if let Some(extra) = words.next() {
            let message = format!(
                "expected end of line after 3 numbers, found {}",
                found(Some(extra))
            );
            return Err(at_line(n, message));
        }
        Ok(point)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A binary STL of `corners` (one triangle per 9 numbers), header text `header`.
    fn binary_stl(header: &[u8], corners: &[[f32; 9]]) -> Vec<u8> {
        let mut bytes = header.to_vec();
        bytes.resize(80, b' ');
        bytes.extend_from_slice(&(corners.len() as u32).to_le_bytes());
        for t in corners {
            bytes.extend_from_slice(&[0u8; 12]);
            for x in t {
                bytes.extend_from_slice(&x.to_le_bytes());
            }
            bytes.extend_from_slice(&[0u8; 2]);
        }
        bytes
    }

    const TWO: [[f32; 9]; 2] = [
        [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0],
        [0.5, -1.25, 3.0, 1e-3, 2.0, -0.0, 7.0, 8.0, 9.0],
    ];

    fn two_triangles() -> Vec<Triangle> {
        TWO.iter()
            .map(|t| {
                let c = |k: usize| glam::DVec3::from([t[k], t[k + 1], t[k + 2]].map(f64::from));
                [c(0), c(3), c(6)]
            })
            .collect()
    }

    const ASCII: &str = "solid two\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n\
        \x20  vertex 1 0 0\n   vertex 0 1 0\n  endloop\n endfacet\n\
        \x20facet normal nan nan nan\r\n  outer loop\n   vertex 0.5 -1.25 3\n\
        \x20  vertex 1e-3 2 -0\n   vertex 7 8 9\n  endloop\n endfacet\nendsolid two\n";

    #[test]
    fn binary_corners_exact_and_in_order() {
        let t = parse(&binary_stl(b"made by hand", &TWO)).unwrap();
        assert_eq!(t, two_triangles());
    }

    #[test]
    fn binary_with_a_solid_header_is_binary_when_the_size_fits() {
        // Binary files often start with `solid` in their free-text header.
        let bytes = binary_stl(b"solid but binary", &TWO);
        assert_eq!(parse(&bytes).unwrap(), two_triangles());
        // Trailing bytes after the last triangle: still binary (NUL in the count), ignored.
        let mut padded = bytes.clone();
        padded.extend_from_slice(b"junk");
        assert_eq!(parse(&padded).unwrap(), two_triangles());
        // A wrong size and no NUL byte up front: text, read (and failing) as ASCII.
        let err = parse(b"solid x\n facet normal 0 0 1\n  inner loop\n").unwrap_err();
        assert_eq!(
            err.to_string(),
            "line 3: expected 'outer loop', found 'inner'"
        );
    }

    #[test]
    fn ascii_corners_exact_and_in_order() {
        assert_eq!(parse(ASCII.as_bytes()).unwrap(), two_triangles());
        // Several solids, blank lines, no name, CRLF.
        let two = ASCII.replace("endsolid two\n", "endsolid\r\n\r\nsolid\nendsolid\n");
        assert_eq!(parse(two.as_bytes()).unwrap(), two_triangles());
        assert_eq!(parse(b"solid empty\nendsolid empty"), Ok(vec![]));
    }

    #[test]
    fn truncated_binary_names_the_sizes() {
        let mut bytes = binary_stl(b"", &TWO);
        bytes[80..84].copy_from_slice(&1000u32.to_le_bytes());
        let err = parse(&bytes).unwrap_err().to_string();
        assert_eq!(
            err,
            "byte 84: binary STL declares 1000 triangles (50084 bytes) but the file has 184 bytes"
        );
        let err = parse(&[1, 2, 3]).unwrap_err().to_string();
        assert_eq!(
            err,
            "byte 0: binary STL needs an 84-byte header and triangle count, the file has 3 bytes"
        );
    }

    #[test]
    fn non_finite_binary_coordinate_names_the_triangle() {
        let mut corners = TWO;
        corners[1][4] = f32::NAN;
        let err = parse(&binary_stl(b"", &corners)).unwrap_err().to_string();
        assert_eq!(
            err,
            "byte 134: triangle 1 has a non-finite corner coordinate (NaN or infinity)"
        );
        corners[0][0] = f32::NEG_INFINITY;
        let err = parse(&binary_stl(b"", &corners)).unwrap_err().to_string();
        assert!(err.starts_with("byte 84: triangle 0 "), "{err}");
    }

    fn ascii_err(from: &str, to: &str) -> String {
        assert_eq!(ASCII.matches(from).count(), 1, "{from}");
        parse(ASCII.replacen(from, to, 1).as_bytes())
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn ascii_errors_name_the_line() {
        assert_eq!(
            ascii_err("vertex 1 0 0", "vertex 1 abc 0"),
            "line 5: expected 3 numbers after 'vertex', found 'abc'"
        );
        assert_eq!(
            ascii_err("vertex 7 8 9", "vertex 7 8"),
            "line 13: expected 3 numbers after 'vertex', found end of line"
        );
        assert_eq!(
            ascii_err("vertex 7 8 9", "vertex 7 8 9 10"),
            "line 13: expected end of line after 3 numbers, found '10'"
        );
        assert_eq!(
            ascii_err("vertex 0.5 -1.25 3", "vertex 0.5 inf 3"),
            "line 11: coordinate 'inf' is not a finite 32-bit float"
        );
        assert_eq!(
            ascii_err("   vertex 0 1 0\n", ""),
            "line 6: expected 'vertex', found 'endloop'"
        );
        assert_eq!(
            ascii_err(
                "  outer loop\n   vertex 0 0 0",
                "  outside\n   vertex 0 0 0"
            ),
            "line 3: expected 'outer loop', found 'outside'"
        );
        assert_eq!(
            ascii_err("endsolid two\n", "facet\n"),
            "line 17: expected 'outer loop', found end of file"
        );
        assert_eq!(
            ascii_err("endsolid two\n", ""),
            "line 16: expected 'facet' or 'endsolid', found end of file"
        );
        assert_eq!(
            ascii_err("endsolid two\n", "endsolid two\nvertex 1 2 3\n"),
            "line 17: expected 'solid', found 'vertex'"
        );
        assert_eq!(
            ascii_err(" endfacet\nendsolid", " endfacet\nend solid"),
            "line 16: expected 'facet' or 'endsolid', found 'end'"
        );
    }

    #[test]
    fn ascii_cut_in_a_vertex_line() {
        let cut = b"solid broken\n facet normal 0 0 1\n  outer loop\n   vertex 0 0\n";
        let err = parse(cut).unwrap_err().to_string();
        assert_eq!(
            err,
            "line 4: expected 3 numbers after 'vertex', found end of line"
        );
    }
}
