//! NumPy `.npy` (format version 1.0) encoding of the raw render buffers.

use super::{Depth, EncodedFile};
use crate::images::{Images, Outputs};
use crate::math::{Float, Real};

/// Encodes little-endian `data` with NumPy dtype `descr` (e.g. `<f4`) and `shape`.
pub(crate) fn encode_npy(descr: &str, shape: &[usize], data: &[u8]) -> Vec<u8> {
    let dims: Vec<String> = shape.iter().map(usize::to_string).collect();
    let shape = if dims.len() == 1 {
        format!("({},)", dims[0])
    } else {
        format!("({})", dims.join(", "))
    };
    let mut header = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape}, }}");
    // Magic (6) + version (2) + header length (2) + header + '\n' is padded to 64 bytes.
    let unpadded = 10 + header.len() + 1;
    header.push_str(&" ".repeat(unpadded.next_multiple_of(64) - unpadded));
    header.push('\n');
    let mut out = Vec::with_capacity(10 + header.len() + data.len());
    out.extend_from_slice(b"\x93NUMPY\x01\x00");
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    out.extend_from_slice(data);
    out
}

/// Little-endian bytes of a float slice, with the matching NumPy dtype.
fn float_bytes<T: Real>(values: impl Iterator<Item = T>) -> (&'static str, Vec<u8>) {
    if T::PRECISION == Float::F32 {
        let v: Vec<u8> = values
            .flat_map(|x| (x.to_f64() as f32).to_le_bytes())
            .collect();
        ("<f4", v)
    } else {
        (
            "<f8",
            values.flat_map(|x| x.to_f64().to_le_bytes()).collect(),
        )
    }
}

/// `id.npy` (int32, -1 on a miss), `distance.npy` or `z.npy` (`depth`'s name and values, +inf
/// on a miss), `normal.npy` (HxWx3, 0 on a miss), those of `outputs` only, and for
/// supersampled images with ids `alpha.npy` (float32); floats are float32 for f32 renders and
/// float64 for f64 renders.
pub(super) fn encode_all<T: Real>(
    images: &Images<T>,
    outputs: Outputs,
    kind: Depth,
    depth: &[T],
) -> Vec<EncodedFile> {
    let (h, w) = (images.height as usize, images.width as usize);
    let mut files = Vec::new();
    if outputs.id {
        let ids: Vec<u8> = images.id.iter().flat_map(|i| i.to_le_bytes()).collect();
        files.push(EncodedFile {
            name: "id.npy",
            bytes: encode_npy("<i4", &[h, w], &ids),
        });
    }
    if outputs.distance {
        let (dtype, values) = float_bytes(depth.iter().copied());
        files.push(EncodedFile {
            name: kind.npy_name(),
            bytes: encode_npy(dtype, &[h, w], &values),
        });
    }
    if outputs.normal {
        let (dtype, normal) = float_bytes(images.normal.iter().flatten().copied());
        files.push(EncodedFile {
            name: "normal.npy",
            bytes: encode_npy(dtype, &[h, w, 3], &normal),
        });
    }
    if let (Some(c), true) = (&images.coverage, outputs.id) {
        let bytes: Vec<u8> = c.alpha.iter().flat_map(|a| a.to_le_bytes()).collect();
        files.push(EncodedFile {
            name: "alpha.npy",
            bytes: encode_npy("<f4", &[h, w], &bytes),
        });
    }
    files
}

/// `render.npz`: `files` (npy) in one uncompressed zip archive, as `numpy.savez` writes it
/// (`numpy.load` names each array by its file name without `.npy`). ZIP64 where an array
/// passes 4 GiB.
pub(super) fn encode_npz(files: &[EncodedFile]) -> EncodedFile {
    use std::io::Write;
    let mut zip = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    for file in files {
        let options = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Stored)
            .large_file(file.bytes.len() as u64 >= u32::MAX as u64);
        let written = zip
            .start_file(file.name, options)
            .and_then(|()| zip.write_all(&file.bytes).map_err(Into::into));
        written.expect("zipping into memory cannot fail");
    }
    let bytes = zip.finish().expect("zipping into memory cannot fail");
    EncodedFile {
        name: "render.npz",
        bytes: bytes.into_inner(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_is_padded_to_64_bytes() {
        let bytes = encode_npy("<i4", &[2, 3], &[0; 24]);
        assert_eq!(&bytes[..8], b"\x93NUMPY\x01\x00");
        let header_len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
        assert_eq!((10 + header_len) % 64, 0);
        let header = std::str::from_utf8(&bytes[10..10 + header_len]).unwrap();
        assert!(header.contains("'shape': (2, 3)"), "{header}");
        assert!(header.ends_with('\n'));
        assert_eq!(bytes.len(), 10 + header_len + 24);
    }
}
