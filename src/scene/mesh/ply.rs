//! PLY (the Stanford polygon format), ASCII or binary (either byte order).
//!
//! Read: the `x y z` of element `vertex` and the list `vertex_indices` (or `vertex_index`) of
//! element `face`, polygons fan-triangulated in corner order. Every other element and property
//! is skipped by its declared type. Coordinates keep their declared precision (`float` is
//! exact in f64, `double` is f64).

use super::text::{self, found, show};
use super::{At, ParseError, Parsed, Triangle, at_byte, at_line, fan};
use crate::math::Vec3;

/// Parses PLY bytes.
pub(super) fn parse(bytes: &[u8]) -> Parsed<Vec<Triangle>> {
    let header = Header::parse(bytes)?;
    match header.encoding {
        Encoding::Ascii => {
            let lines = text::lines(&bytes[header.body..], header.end_line + 1);
            read(&header, &mut Ascii::new(lines))
        }
        Encoding::Binary { big_endian } => {
            read(&header, &mut Binary::new(bytes, header.body, big_endian))
        }
    }
}

/// A scalar property type, by any of its two PLY names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn named(word: &[u8]) -> Option<Scalar> {
        Some(match word {
            b"char" | b"int8" => Scalar::I8,
            b"uchar" | b"uint8" => Scalar::U8,
            b"short" | b"int16" => Scalar::I16,
            b"ushort" | b"uint16" => Scalar::U16,
            b"int" | b"int32" => Scalar::I32,
            b"uint" | b"uint32" => Scalar::U32,
            b"float" | b"float32" => Scalar::F32,
            b"double" | b"float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    /// Every PLY scalar fits f64 exactly, so values travel as f64.
    fn decode(self, raw: &[u8], big_endian: bool) -> f64 {
        macro_rules! number {
            ($t:ty) => {{
                let raw = raw.try_into().expect("raw has the type's size");
                f64::from(if big_endian {
                    <$t>::from_be_bytes(raw)
                } else {
                    <$t>::from_le_bytes(raw)
                })
            }};
        }
        match self {
            Scalar::I8 => number!(i8),
            Scalar::U8 => number!(u8),
            Scalar::I16 => number!(i16),
            Scalar::U16 => number!(u16),
            Scalar::I32 => number!(i32),
            Scalar::U32 => number!(u32),
            Scalar::F32 => number!(f32),
            Scalar::F64 => number!(f64),
        }
    }

    /// Parses an ASCII value: a number in f64 whatever its declared type (text holds decimal
    /// digits, not the type's bits; the mesh is rendered from the digits the file has).
    fn parse(self, word: &[u8]) -> Option<f64> {
        match self {
            Scalar::F32 | Scalar::F64 => text::parse::<f64>(word),
            _ => text::parse::<i64>(word).map(|i| i as f64),
        }
    }

    fn kind(self) -> &'static str {
        match self {
            Scalar::F32 | Scalar::F64 => "a number",
            _ => "an integer",
        }
    }
}

#[derive(Clone, Debug, PartialEq, Eq)]
enum Property {
    Scalar {
        name: String,
        ty: Scalar,
    },
    List {
        name: String,
        count: Scalar,
        item: Scalar,
    },
}

#[derive(Clone, Debug, PartialEq, Eq)]
struct Element {
    name: String,
    count: usize,
    properties: Vec<Property>,
    /// The header line declaring it.
    line: usize,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Encoding {
    Ascii,
    Binary { big_endian: bool },
}

/// A parsed and checked header.
#[derive(Debug)]
struct Header {
    encoding: Encoding,
    elements: Vec<Element>,
    /// The line of `end_header`, and the byte offset just after it, where the body starts.
    end_line: usize,
    body: usize,
    /// Element `vertex`'s index and those of its properties `x`, `y`, `z`.
    vertex: (usize, [usize; 3]),
    /// Element `face`'s index and that of its vertex-index list.
    face: (usize, usize),
}

impl Header {
    fn parse(bytes: &[u8]) -> Parsed<Header> {
        let mut encoding = None;
        let mut elements: Vec<Element> = Vec::new();
        let mut offset = 0;
        let mut n = 0;
        loop {
            let Some(length) = bytes[offset..].iter().position(|&b| b == b'\n') else {
                return Err(at_line(n + 1, "the PLY header has no 'end_header' line"));
            };
            let line = &bytes[offset..offset + length];
            n += 1;
            offset += length + 1;
            let mut words = text::words(line);
            let first = words.next().unwrap_or_default();
            match (n, first) {
                (1, b"ply") => {}
                (1, _) => {
                    let message = format!(
                        "not a PLY file: expected 'ply', found {}",
                        found(Some(first))
                    );
                    return Err(at_line(1, message));
                }
                (_, b"format") => encoding = Some(format(n, words)?),
                (_, b"comment" | b"obj_info" | b"") => {}
                (_, b"element") => elements.push(element(n, words)?),
                (_, b"property") => {
                    let Some(element) = elements.last_mut() else {
                        return Err(at_line(n, "'property' before any 'element'"));
                    };
                    element.properties.push(property(n, words)?);
                }
                (_, b"end_header") => break,
                _ => {
                    let message = format!("unknown PLY header keyword '{}'", show(first));
                    return Err(at_line(n, message));
                }
            }
        }
        let encoding = encoding.ok_or_else(|| at_line(n, "the PLY header has no 'format' line"))?;
        let vertex = vertex_element(&elements, n)?;
        let face = face_element(&elements, n, vertex.0)?;
        Ok(Header {
            encoding,
            elements,
            end_line: n,
            body: offset,
            vertex,
            face,
        })
    }
}

/// `format ascii|binary_little_endian|binary_big_endian 1.0`.
fn format<'a>(n: usize, mut words: impl Iterator<Item = &'a [u8]>) -> Parsed<Encoding> {
    let encoding = match words.next() {
        Some(b"ascii") => Encoding::Ascii,
        Some(b"binary_little_endian") => Encoding::Binary { big_endian: false },
        Some(b"binary_big_endian") => Encoding::Binary { big_endian: true },
        other => {
            let message = format!(
                "expected 'ascii', 'binary_little_endian' or 'binary_big_endian', found {}",
                found(other)
            );
            return Err(at_line(n, message));
        }
    };
    match words.next() {
        Some(b"1.0") => Ok(encoding),
        other => Err(at_line(
            n,
            format!("expected PLY version '1.0', found {}", found(other)),
        )),
    }
}

/// `element NAME COUNT`.
fn element<'a>(n: usize, mut words: impl Iterator<Item = &'a [u8]>) -> Parsed<Element> {
    let (name, count) = (words.next(), words.next());
    let count = count.and_then(text::parse::<usize>);
    match (name, count) {
        (Some(name), Some(count)) => Ok(Element {
            name: show(name),
            count,
            properties: Vec::new(),
            line: n,
        }),
        _ => Err(at_line(n, "expected 'element NAME COUNT'")),
    }
}

/// `property TYPE NAME` or `property list COUNT_TYPE ITEM_TYPE NAME`.
fn property<'a>(n: usize, mut words: impl Iterator<Item = &'a [u8]>) -> Parsed<Property> {
    let scalar = |word: Option<&[u8]>| {
        word.and_then(Scalar::named).ok_or_else(|| {
            at_line(
                n,
                format!("expected a PLY property type, found {}", found(word)),
            )
        })
    };
    let first = words.next();
    let property = if first == Some(b"list") {
        let (count, item) = (scalar(words.next())?, scalar(words.next())?);
        words.next().map(|name| Property::List {
            name: show(name),
            count,
            item,
        })
    } else {
        let ty = scalar(first)?;
        words.next().map(|name| Property::Scalar {
            name: show(name),
            ty,
        })
    };
    property.ok_or_else(|| at_line(n, "expected a property name, found end of line"))
}

/// Finds element `vertex` and its scalar properties `x`, `y`, `z`.
fn vertex_element(elements: &[Element], end_line: usize) -> Parsed<(usize, [usize; 3])> {
    let Some(v) = elements.iter().position(|e| e.name == "vertex") else {
        return Err(at_line(
            end_line,
            "the PLY header declares no 'element vertex'",
        ));
    };
    let mut xyz = [0; 3];
    for (axis, name) in xyz.iter_mut().zip(["x", "y", "z"]) {
        let is_it = |p: &Property| matches!(p, Property::Scalar { name: m, .. } if m == name);
        *axis = elements[v]
            .properties
            .iter()
            .position(is_it)
            .ok_or_else(|| {
                let message = format!("element 'vertex' has no scalar property '{name}'");
                at_line(elements[v].line, message)
            })?;
    }
    Ok((v, xyz))
}

/// Finds element `face`, after `vertex` (which this reader needs first), and its index list.
fn face_element(elements: &[Element], end_line: usize, vertex: usize) -> Parsed<(usize, usize)> {
    let Some(f) = elements.iter().position(|e| e.name == "face") else {
        let message = "the PLY header declares no 'element face' (a point cloud is not a mesh)";
        return Err(at_line(end_line, message));
    };
    let face = &elements[f];
    if f < vertex {
        let message =
            "element 'face' comes before element 'vertex'; this reader needs the vertices first";
        return Err(at_line(face.line, message));
    }
    let is_it = |p: &Property| matches!(p, Property::List { name, .. } if name == "vertex_indices" || name == "vertex_index");
    let list = face.properties.iter().position(is_it).ok_or_else(|| {
        at_line(
            face.line,
            "element 'face' has no list property 'vertex_indices'",
        )
    })?;
    Ok((f, list))
}

/// The body, read one value at a time in declaration order, ASCII or binary.
trait Body {
    /// Starts record `index` of `element` (in ASCII, its line).
    fn start(&mut self, element: &Element, index: usize) -> Parsed<()>;
    /// The next value, declared as `ty` for `property`.
    fn value(&mut self, ty: Scalar, property: &str) -> Parsed<f64>;
    /// Ends the record (in ASCII, nothing may follow on its line).
    fn finish(&mut self) -> Parsed<()>;
    /// Where the current record starts, for errors about what it holds.
    fn here(&self) -> At;
}

/// Reads all elements; returns the faces' triangles.
fn read(header: &Header, body: &mut impl Body) -> Parsed<Vec<Triangle>> {
    let mut vertices = Vec::new();
    let mut triangles = Vec::new();
    let mut values = Vec::new();
    for (e, element) in header.elements.iter().enumerate() {
        if e == header.vertex.0 {
            vertices = read_vertices(body, element, header.vertex.1)?;
        } else if e == header.face.0 {
            triangles = read_faces(body, element, header.face.1, &vertices)?;
        } else if !element.properties.is_empty() {
            for k in 0..element.count {
                body.start(element, k)?;
                read_record(body, element, &mut values, |_, _| Ok(()))?;
            }
        }
        // An element without properties takes no bytes, whatever its count (an ASCII body
        // skips blank lines): counting through 10^13 empty records would hang.
    }
    Ok(triangles)
}

/// Reads one record's values in order, passing each property's index and values to `take`.
/// `values` is scratch space, kept by the caller so that records allocate nothing.
fn read_record(
    body: &mut impl Body,
    element: &Element,
    values: &mut Vec<f64>,
    mut take: impl FnMut(usize, &[f64]) -> Parsed<()>,
) -> Parsed<()> {
    for (i, property) in element.properties.iter().enumerate() {
        values.clear();
        match property {
            Property::Scalar { name, ty } => values.push(body.value(*ty, name)?),
            Property::List { name, count, item } => {
                let length = body.value(*count, name)?;
                if !(length >= 0.0 && length.fract() == 0.0) {
                    let message = format!("list '{name}' has length {length}");
                    return Err(ParseError::at(body.here(), message));
                }
                for _ in 0..length as usize {
                    values.push(body.value(*item, name)?);
                }
            }
        }
        take(i, values)?;
    }
    body.finish()
}

fn read_vertices(
    body: &mut impl Body,
    element: &Element,
    xyz: [usize; 3],
) -> Parsed<Vec<Vec3<f64>>> {
    let mut vertices = Vec::with_capacity(element.count.min(1 << 24));
    let mut values = Vec::new();
    for k in 0..element.count {
        body.start(element, k)?;
        let mut point = [0.0; 3];
        read_record(body, element, &mut values, |i, values| {
            if let Some(axis) = xyz.iter().position(|&p| p == i) {
                point[axis] = values[0];
            }
            Ok(())
        })?;
        let point = Vec3::from_array(point);
        if !point.is_finite() {
            let message = format!("vertex {k} has a non-finite coordinate (NaN or infinity)");
            return Err(ParseError::at(body.here(), message));
        }
        vertices.push(point);
    }
    Ok(vertices)
}

fn read_faces(
    body: &mut impl Body,
    element: &Element,
    list: usize,
    vertices: &[Vec3<f64>],
) -> Parsed<Vec<Triangle>> {
    let mut triangles = Vec::with_capacity(element.count.min(1 << 24));
    let mut corners = Vec::new();
    let mut values = Vec::new();
    for k in 0..element.count {
        body.start(element, k)?;
        let here = body.here();
        read_record(body, element, &mut values, |i, values| {
            if i == list {
                corners.clear();
                for &index in values {
                    corners.push(vertex_index(here, k, index, vertices.len())?);
                }
            }
            Ok(())
        })?;
        if corners.len() < 3 {
            let message = format!("face {k} has {} corners, needs at least 3", corners.len());
            return Err(ParseError::at(here, message));
        }
        fan(&corners, vertices, &mut triangles);
    }
    Ok(triangles)
}

fn vertex_index(here: At, face: usize, index: f64, count: usize) -> Parsed<usize> {
    if index >= 0.0 && index < count as f64 && index.fract() == 0.0 {
        return Ok(index as usize);
    }
    let message =
        format!("face {face} has vertex index {index} but there are only {count} vertices");
    Err(ParseError::at(here, message))
}

/// An ASCII body: one record per line (as every writer does), blank lines skipped.
struct Ascii<'a, L> {
    lines: L,
    /// The current record's line and its words not read yet.
    line: usize,
    rest: &'a [u8],
    /// The current record's element and index, for messages (`vertex 17`).
    element: String,
    index: usize,
}

impl<'a, L: Iterator<Item = (usize, &'a [u8])>> Ascii<'a, L> {
    fn new(lines: L) -> Self {
        Ascii {
            lines,
            line: 0,
            rest: b"",
            element: String::new(),
            index: 0,
        }
    }
}

impl<'a, L: Iterator<Item = (usize, &'a [u8])>> Body for Ascii<'a, L> {
    fn start(&mut self, element: &Element, index: usize) -> Parsed<()> {
        for (n, line) in self.lines.by_ref() {
            self.line = n;
            if !line.trim_ascii().is_empty() {
                self.rest = line;
                if index == 0 {
                    self.element.clone_from(&element.name);
                }
                self.index = index;
                return Ok(());
            }
        }
        let message = format!(
            "expected {} {index} of {}, found end of file",
            element.name, element.count
        );
        Err(at_line(self.line, message))
    }

    fn value(&mut self, ty: Scalar, property: &str) -> Parsed<f64> {
        let word = text::next_word(&mut self.rest);
        word.and_then(|w| ty.parse(w)).ok_or_else(|| {
            let message = format!(
                "{} {}: expected {} for '{property}', found {}",
                self.element,
                self.index,
                ty.kind(),
                found(word)
            );
            at_line(self.line, message)
        })
    }

    fn finish(&mut self) -> Parsed<()> {
        match text::next_word(&mut self.rest) {
            None => Ok(()),
            extra => {
                let message = format!(
                    "{} {}: expected end of line, found {}",
                    self.element,
                    self.index,
                    found(extra)
                );
                Err(at_line(self.line, message))
            }
        }
    }

    fn here(&self) -> At {
        At::Line(self.line)
    }
}

/// A binary body, read from the whole file so offsets are the file's.
struct Binary<'a> {
    bytes: &'a [u8],
    big_endian: bool,
    /// The next byte to read and where the current record started.
    offset: usize,
    start: usize,
    /// The current record, for the message when the file ends inside it.
    element: String,
    index: usize,
    count: usize,
}

impl<'a> Binary<'a> {
    fn new(bytes: &'a [u8], body: usize, big_endian: bool) -> Self {
        Binary {
            bytes,
            big_endian,
            offset: body,
            start: body,
            element: String::new(),
            index: 0,
            count: 0,
        }
    }
}

impl Body for Binary<'_> {
    fn start(&mut self, element: &Element, index: usize) -> Parsed<()> {
        self.start = self.offset;
        if index == 0 {
            self.element.clone_from(&element.name);
            self.count = element.count;
        }
        self.index = index;
        Ok(())
    }

    fn value(&mut self, ty: Scalar, _property: &str) -> Parsed<f64> {
        let end = self.offset + ty.size();
        let Some(raw) = self.bytes.get(self.offset..end) else {
            let message = format!(
                "{} {} of {} runs past the end of the file ({} bytes)",
                self.element,
                self.index,
                self.count,
                self.bytes.len()
            );
            return Err(at_byte(self.start, message));
        };
        self.offset = end;
        Ok(ty.decode(raw, self.big_endian))
    }

    fn finish(&mut self) -> Parsed<()> {
        Ok(())
    }

    fn here(&self) -> At {
        At::Byte(self.start)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f64, y: f64, z: f64) -> glam::DVec3 {
        glam::DVec3::new(x, y, z)
    }

    /// The mesh every happy-path file below holds: a quad (two triangles) and a triangle.
    fn expected() -> Vec<Triangle> {
        let p = [
            v(0.0, 0.0, 0.0),
            v(1.5, 0.0, -2.0),
            v(1.5, 1.0, 0.0),
            v(0.0, 1.0, 0.1),
            v(-3.0, 1e-3, 7.0),
        ];
        vec![[p[0], p[1], p[2]], [p[0], p[2], p[3]], [p[4], p[3], p[2]]]
    }

    const ASCII: &str = "ply\r\nformat ascii 1.0\ncomment made by hand\n\
        element vertex 5\nproperty float x\nproperty float y\nproperty float z\n\
        property uchar red\nproperty list uchar float extra\n\
        element face 2\nproperty list uchar int vertex_indices\nproperty int flags\n\
        element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n\
        0 0 0 255 0\n1.5 0 -2 0 2 1.0 2.0\n1.5 1 0 7 0\n\n0 1 0.1 7 0\n-3 1e-3 7 7 0\n\
        4 0 1 2 3 9\n3 4 3 2 0\n0 1\n";

    fn ascii_err(from: &str, to: &str) -> String {
        assert_eq!(ASCII.matches(from).count(), 1, "{from}");
        parse(ASCII.replacen(from, to, 1).as_bytes())
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn ascii_corners_exact_and_in_order() {
        assert_eq!(parse(ASCII.as_bytes()).unwrap(), expected());
    }

    /// The same mesh in binary: double coordinates, a `vertex_index` list of ushort count and
    /// uint items, extra properties before and after it.
    fn binary(big_endian: bool) -> Vec<u8> {
        let order = if big_endian { "big" } else { "little" };
        let mut bytes = format!(
            "ply\nformat binary_{order}_endian 1.0\nelement vertex 5\nproperty double x\n\
             property double y\nproperty double z\nproperty short s\nelement face 2\n\
             property char c\nproperty list ushort uint vertex_index\nproperty float f\n\
             end_header\n"
        )
        .into_bytes();
        let mut put = |raw: &[u8]| {
            let mut raw = raw.to_vec();
            if big_endian {
                raw.reverse();
            }
            bytes.extend_from_slice(&raw);
        };
        let points: [[f64; 3]; 5] = [
            [0.0, 0.0, 0.0],
            [1.5, 0.0, -2.0],
            [1.5, 1.0, 0.0],
            [0.0, 1.0, 0.1],
            [-3.0, 1e-3, 7.0],
        ];
        for p in points {
            for x in p {
                put(&x.to_le_bytes());
            }
            put(&(-1i16).to_le_bytes());
        }
        for face in [&[0u32, 1, 2, 3][..], &[4, 3, 2]] {
            put(&[0x7f]);
            put(&(face.len() as u16).to_le_bytes());
            for i in face {
                put(&i.to_le_bytes());
            }
            put(&1.0f32.to_le_bytes());
        }
        bytes
    }

    #[test]
    fn binary_corners_exact_and_in_order() {
        assert_eq!(parse(&binary(false)).unwrap(), expected());
        assert_eq!(parse(&binary(true)).unwrap(), expected());
    }

    /// An element without properties takes no bytes, however many it declares (the fuzzer
    /// found 2 * 10^13 of them hanging the reader: tests/data/fuzz/ply).
    #[test]
    fn elements_without_properties_take_no_bytes() {
        let header = "end_header\n";
        let empty = "element nothing 20000000000000\nend_header\n";
        let bytes = binary(false);
        let text = String::from_utf8_lossy(&bytes);
        let at = text.find(header).unwrap();
        let mut with_empty = bytes[..at].to_vec();
        with_empty.extend_from_slice(empty.as_bytes());
        with_empty.extend_from_slice(&bytes[at + header.len()..]);
        assert_eq!(parse(&with_empty).unwrap(), expected());
        let ascii = ASCII.replace("end_header\n", empty);
        assert_eq!(parse(ascii.as_bytes()).unwrap(), expected());
    }

    /// Offsets into [`binary`]: the body, a vertex record (3 doubles and a short), and where
    /// face 1 starts (face 0: char, ushort, 4 uints, float).
    fn body_of(bytes: &[u8]) -> usize {
        bytes
            .windows(11)
            .position(|w| w == b"end_header\n")
            .unwrap()
            + 11
    }
    const VERTEX: usize = 26;
    const FACE0: usize = 1 + 2 + 16 + 4;

    #[test]
    fn binary_errors_name_the_byte() {
        let bytes = binary(false);
        let body = body_of(&bytes);
        let faces = body + 5 * VERTEX;

        let err = parse(&bytes[..bytes.len() - 1]).unwrap_err().to_string();
        let want = format!(
            "byte {}: face 1 of 2 runs past the end of the file ({} bytes)",
            faces + FACE0,
            bytes.len() - 1
        );
        assert_eq!(err, want);

        let mut bad = bytes.clone();
        let index = faces + FACE0 + 1 + 2 + 4; // face 1, its second index
        bad[index..index + 4].copy_from_slice(&5u32.to_le_bytes());
        let err = parse(&bad).unwrap_err().to_string();
        let want = format!(
            "byte {}: face 1 has vertex index 5 but there are only 5 vertices",
            faces + FACE0
        );
        assert_eq!(err, want);

        let mut bad = bytes.clone();
        bad[faces + 1..faces + 3].copy_from_slice(&2u16.to_le_bytes());
        let err = parse(&bad).unwrap_err().to_string();
        assert!(
            err.starts_with(&format!("byte {faces}: face 0 has 2 corners")),
            "{err}"
        );

        let mut bad = bytes.clone();
        let y3 = body + 3 * VERTEX + 8;
        bad[y3..y3 + 8].copy_from_slice(&f64::INFINITY.to_le_bytes());
        let err = parse(&bad).unwrap_err().to_string();
        let want = format!(
            "byte {}: vertex 3 has a non-finite coordinate (NaN or infinity)",
            body + 3 * VERTEX
        );
        assert_eq!(err, want);
    }

    #[test]
    fn ascii_errors_name_the_line() {
        assert_eq!(
            ascii_err("1.5 1 0 7 0", "1.5 abc 0 7 0"),
            "line 19: vertex 2: expected a number for 'y', found 'abc'"
        );
        assert_eq!(
            ascii_err("1.5 1 0 7 0", "1.5 1 0 7"),
            "line 19: vertex 2: expected an integer for 'extra', found end of line"
        );
        assert_eq!(
            ascii_err("1.5 1 0 7 0", "1.5 1 0 7 0 8"),
            "line 19: vertex 2: expected end of line, found '8'"
        );
        assert_eq!(
            ascii_err("1.5 1 0 7 0", "1.5 1 nan 7 0"),
            "line 19: vertex 2 has a non-finite coordinate (NaN or infinity)"
        );
        assert_eq!(
            ascii_err("3 4 3 2 0", "3 4 3 5 0"),
            "line 24: face 1 has vertex index 5 but there are only 5 vertices"
        );
        assert_eq!(
            ascii_err("3 4 3 2 0", "3 4 3 -1 0"),
            "line 24: face 1 has vertex index -1 but there are only 5 vertices"
        );
        assert_eq!(
            ascii_err("3 4 3 2 0", "2 4 3 0"),
            "line 24: face 1 has 2 corners, needs at least 3"
        );
        assert_eq!(
            ascii_err("3 4 3 2 0\n0 1\n", "3 4 3 2 0\n"),
            "line 25: expected edge 0 of 1, found end of file"
        );
    }

    #[test]
    fn header_errors_name_the_line() {
        assert_eq!(
            parse(b"solid\n").unwrap_err().to_string(),
            "line 1: not a PLY file: expected 'ply', found 'solid'"
        );
        assert_eq!(
            ascii_err("format ascii 1.0", "format binary 1.0"),
            "line 2: expected 'ascii', 'binary_little_endian' or 'binary_big_endian', found 'binary'"
        );
        assert_eq!(
            ascii_err("format ascii 1.0", "format ascii 2.0"),
            "line 2: expected PLY version '1.0', found '2.0'"
        );
        assert_eq!(
            ascii_err("property float z\n", "property float w\n"),
            "line 4: element 'vertex' has no scalar property 'z'"
        );
        assert_eq!(
            ascii_err("property float y", "property half y"),
            "line 6: expected a PLY property type, found 'half'"
        );
        assert_eq!(
            ascii_err("vertex_indices", "corners"),
            "line 10: element 'face' has no list property 'vertex_indices'"
        );
        assert_eq!(
            ascii_err("element vertex 5", "element vertex five"),
            "line 4: expected 'element NAME COUNT'"
        );
        assert_eq!(
            ascii_err("comment made by hand", "coment made by hand"),
            "line 3: unknown PLY header keyword 'coment'"
        );
        assert_eq!(
            ascii_err("comment made by hand\n", "property int a\n"),
            "line 3: 'property' before any 'element'"
        );
        assert_eq!(
            ascii_err("end_header", "end_head"),
            "line 16: unknown PLY header keyword 'end_head'"
        );
        assert_eq!(
            parse(b"ply\nformat ascii 1.0\nelement vertex 0\n")
                .unwrap_err()
                .to_string(),
            "line 4: the PLY header has no 'end_header' line"
        );
        assert_eq!(
            parse(b"ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nend_header\n")
                .unwrap_err()
                .to_string(),
            "line 7: the PLY header declares no 'element face' (a point cloud is not a mesh)"
        );
        assert_eq!(
            parse(b"ply\nformat ascii 1.0\nelement face 0\nproperty list uchar int vertex_indices\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nend_header\n")
                .unwrap_err()
                .to_string(),
            "line 3: element 'face' comes before element 'vertex'; this reader needs the vertices first"
        );
    }
}
