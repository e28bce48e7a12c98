//! Line and word splitting and number parsing shared by the text formats (OBJ, ASCII STL,
//! ASCII PLY). They work on bytes, not `str`: a comment or name in Latin-1 must not make a file
//! unreadable, and only the words that are parsed as numbers need to be UTF-8 (ASCII).

use std::str::FromStr;

use super::{Parsed, at_line};
use crate::math::{Float, Vec3};

/// The lines of `bytes` with their 1-based numbers, counting from `first`, without the line
/// break (`\n` or `\r\n`). A file ending in a line break yields a last, empty line: end-of-file
/// errors then point just past the last line, which is where the missing text belongs.
pub(super) fn lines(bytes: &[u8], first: usize) -> impl Iterator<Item = (usize, &[u8])> {
    bytes
        .split(|&b| b == b'\n')
        .enumerate()
        .map(move |(i, line)| (first + i, line.strip_suffix(b"\r").unwrap_or(line)))
}

/// `bytes` without a UTF-8 byte-order mark, which some Windows tools write before text.
pub(super) fn without_bom(bytes: &[u8]) -> &[u8] {
    bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes)
}

/// The whitespace-separated words of a line.
pub(super) fn words(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    line.split(u8::is_ascii_whitespace)
        .filter(|w| !w.is_empty())
}

/// Takes the next whitespace-separated word off the front of `rest`.
pub(super) fn next_word<'a>(rest: &mut &'a [u8]) -> Option<&'a [u8]> {
    let line = rest.trim_ascii_start();
    let end = line
        .iter()
        .position(u8::is_ascii_whitespace)
        .unwrap_or(line.len());
    let (word, tail) = line.split_at(end);
    *rest = tail;
    (!word.is_empty()).then_some(word)
}

/// Parses a whole word as a `T` (Rust's own parsers: correctly rounded floats, which also accept
/// `inf` and `nan`, so callers check finiteness themselves).
pub(super) fn parse<T: FromStr>(word: &[u8]) -> Option<T> {
    std::str::from_utf8(word).ok()?.parse().ok()
}

/// Parses a whole word as a decimal integer with an optional sign. Hand-written because OBJ
/// faces hold twice as many indices as there are coordinates, and skipping the UTF-8 check and
/// generic parser of `str::parse` makes them cheap.
pub(super) fn integer(word: &[u8]) -> Option<i64> {
    let (negative, digits) = match word {
        [b'-', rest @ ..] => (true, rest),
        [b'+', rest @ ..] => (false, rest),
        _ => (false, word),
    };
    if digits.is_empty() {
        return None;
    }
    let mut value: i64 = 0;
    for &d in digits {
        if !d.is_ascii_digit() {
            return None;
        }
        value = value.checked_mul(10)?.checked_add(i64::from(d - b'0'))?;
    }
    Some(if negative { -value } else { value })
}

/// A word as an error message quotes it: lossy UTF-8, long words cut short.
pub(super) fn show(word: &[u8]) -> String {
    const MAX: usize = 32;
    let text = String::from_utf8_lossy(word);
    match text.char_indices().nth(MAX) {
        Some((cut, _)) => format!("{}...", &text[..cut]),
        None => text.into_owned(),
    }
}

/// The next word quoted for "expected ..., found X" messages, or `end of line`.
pub(super) fn found(word: Option<&[u8]>) -> String {
    word.map_or_else(|| "end of line".to_owned(), |w| format!("'{}'", show(w)))
}

/// Reads the three coordinates after `keyword` (`vertex` in STL, `v` in OBJ) on line `n`, in
/// `precision`: f32 for STL, the precision its format stores; f64 for OBJ, so that a mesh is
/// rendered from the numbers its file holds (an f32 read would move a vertex 1e6 from the
/// origin by up to 0.03).
pub(super) fn point<'a>(
    n: usize,
    keyword: &str,
    words: &mut impl Iterator<Item = &'a [u8]>,
    precision: Float,
) -> Parsed<Vec3<f64>> {
    let mut xyz = [0.0; 3];
    for x in &mut xyz {
        let word = words.next();
        let value = word.and_then(|w| match precision {
            Float::F32 => parse::<f32>(w).map(f64::from),
            Float::F64 => parse::<f64>(w),
        });
        let value = value.ok_or_else(|| {
            at_line(
                n,
                format!(
                    "expected 3 numbers after '{keyword}', found {}",
                    found(word)
                ),
            )
        })?;
        if !value.is_finite() {
            let word = show(word.unwrap_or_default());
            let bits = match precision {
                Float::F32 => 32,
                Float::F64 => 64,
            };
            return Err(at_line(
                n,
                format!("coordinate '{word}' is not a finite {bits}-bit float"),
            ));
        }
        *x = value;
    }
    Ok(Vec3::from_array(xyz))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_are_numbered_and_lose_their_breaks() {
        let got: Vec<_> = lines(b"a\r\nb\n\nc", 1).collect();
        let want: Vec<(usize, &[u8])> = vec![(1, b"a"), (2, b"b"), (3, b""), (4, b"c")];
        assert_eq!(got, want);
        assert_eq!(lines(b"x\n", 7).last(), Some((8, &b""[..])));
    }

    #[test]
    fn words_split_on_any_ascii_whitespace() {
        let got: Vec<_> = words(b" v\t1  2\x0c3 ").collect();
        assert_eq!(got, vec![&b"v"[..], b"1", b"2", b"3"]);
    }

    #[test]
    fn next_word_walks_a_line() {
        let mut rest = &b"  ab\tc "[..];
        assert_eq!(next_word(&mut rest), Some(&b"ab"[..]));
        assert_eq!(next_word(&mut rest), Some(&b"c"[..]));
        assert_eq!(next_word(&mut rest), None);
        assert_eq!(next_word(&mut rest), None);
    }

    #[test]
    fn integers_like_str_parse() {
        for word in [
            "0",
            "17",
            "-3",
            "+4",
            "9223372036854775807",
            "-9223372036854775807",
        ] {
            assert_eq!(integer(word.as_bytes()), word.parse().ok(), "{word}");
        }
        for word in [
            "",
            "-",
            "+",
            "1.5",
            "1e3",
            "x",
            "9223372036854775808",
            "--1",
            "1/2",
        ] {
            assert_eq!(integer(word.as_bytes()), None, "{word}");
        }
    }

    #[test]
    fn shown_words_are_cut_short() {
        assert_eq!(show(b"abc"), "abc");
        assert_eq!(show(&[b'x'; 40]), format!("{}...", "x".repeat(32)));
        assert_eq!(show(b"\xff"), "\u{fffd}");
    }

    #[test]
    fn points_need_three_finite_numbers() {
        let read = |line: &[u8]| point(3, "vertex", &mut words(line), Float::F32);
        assert_eq!(
            read(b"1 -2.5 3e2"),
            Ok(Vec3::from_array([1.0, -2.5, 300.0]))
        );
        // Rounded to f32 in f32 (STL), kept in f64 (OBJ).
        assert_eq!(read(b"0.1 0 0").unwrap().x, f64::from(0.1f32));
        let read_f64 = |line: &[u8]| point(3, "v", &mut words(line), Float::F64);
        assert_eq!(
            read_f64(b"0.1 1e6 -3e300").unwrap(),
            Vec3::from_array([0.1, 1e6, -3e300])
        );
        assert_eq!(
            read_f64(b"1e400 0 0").unwrap_err().to_string(),
            "line 3: coordinate '1e400' is not a finite 64-bit float"
        );
        let err = |line: &[u8]| read(line).unwrap_err().to_string();
        assert_eq!(
            err(b"1 abc 3"),
            "line 3: expected 3 numbers after 'vertex', found 'abc'"
        );
        assert_eq!(
            err(b"1 2"),
            "line 3: expected 3 numbers after 'vertex', found end of line"
        );
        assert_eq!(
            err(b"1 nan 3"),
            "line 3: coordinate 'nan' is not a finite 32-bit float"
        );
        assert_eq!(
            err(b"1e39 0 0"),
            "line 3: coordinate '1e39' is not a finite 32-bit float"
        );
    }
}
