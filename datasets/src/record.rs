//! The record of what a dataset view's files were rendered with, `job.json` in its folder
//! (docs/datasets.md#resuming-and-forcing): a run started again skips a view only if its
//! folder holds every file and a record equal to the one it would write, and renders the
//! others again, so that a view never keeps files of other options or of a changed scene.
//!
//! The record holds what changes the files: raycast's version, the options (size, device,
//! precision as asked, algorithm, samples, bands, how a mesh file splits into objects, the
//! hook's and the kernel file's text, the encoding), a digest of the scene (its file and the mesh files it loads) and the view's
//! camera as rendered (its size among its fields). Not the paths: a job given absolute paths
//! (as `raycast.distributed` gives its workers) writes the same records. Not the adapter: a
//! job resumed on another GPU keeps the views the first one rendered.

use std::path::Path;

use serde_json::{Value, json};

use raycast::{Camera, Object, Scene};
use raycast::{Device, Error, Result, ShadeHook};

use crate::files::RenderFiles;

/// The record's file name in a view's folder.
pub(crate) const RECORD: &str = "job.json";

/// The record's fields that depend on the options alone, not on the scene or the view: what
/// the manifest compares without loading the scenes.
const JOB_FIELDS: [&str; 2] = ["raycast", "options"];

/// What a view's folder holds, against the record the job would write there.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Found {
    /// No folder.
    Missing,
    /// A folder of another job: a file or the record is missing, or the record differs.
    Stale,
    /// Every file, with the same record.
    Complete,
}

/// The options of `render` that change a view's files, with raycast's version: the part of
/// every view's record that the whole job shares. Reads the shade hook and the kernel file.
pub(crate) fn job_part(render: &RenderFiles) -> Result<Value> {
    let device = match render.device {
        Device::Gpu => "gpu",
        Device::Cpu => "cpu",
    };
    let precision = match render.precision {
        None => "default".to_owned(),
        Some(p) => p.to_string(),
    };
    let text = |path: Option<&Path>| -> Result<Value> {
        path.map_or(Ok(Value::Null), |p| {
            let bytes = std::fs::read(p).map_err(|e| Error::Io {
                path: p.to_path_buf(),
                message: format!("cannot read: {e}"),
            })?;
            Ok(digest([&bytes[..]]).into())
        })
    };
    let shader = match render.lit {
        true => digest([ShadeHook::raytrace()?.source.as_bytes()]).into(),
        false => text(render.shader.as_deref())?,
    };
    Ok(json!({
        // The library's version, which this crate shares.
        "raycast": env!("CARGO_PKG_VERSION"),
        "options": {
            // Also in the camera, but the manifest compares the options alone.
            "size": render.size,
            "device": device,
            "precision": precision,
            "algorithm": render.algorithm.to_string(),
            "spp": render.spp,
            "band_rows": render.band_rows,
            // A mesh file's objects: its ids.
            "split": format!("{:?}", render.split),
            "lit": render.lit,
            "shader": shader,
            "kernel": text(render.kernel.as_deref())?,
            // Debug: every field, including those added later.
            "encoding": format!("{:?}", render.encoding),
        },
    }))
}

/// The record of a view of `scene` (digest [`scene_digest`]) seen by `camera`, its instances
/// moved by `transforms` (a pose's), in a job whose shared part is `job` ([`job_part`]).
pub(crate) fn view_record(
    job: &Value,
    scene: &str,
    camera: &Camera,
    transforms: &[(usize, glam::DAffine3)],
) -> Value {
    let mut record = job.clone();
    record["scene"] = scene.into();
    // Debug: every field of the camera (its size, depth.png's white), exact for floats.
    record["camera"] = format!("{camera:?}").into();
    if !transforms.is_empty() {
        record["transforms"] = format!("{transforms:?}").into();
    }
    record
}

/// `record` as its file holds it.
pub(crate) fn encode(record: &Value) -> Vec<u8> {
    let mut text = serde_json::to_string_pretty(record).expect("a record serialises");
    text.push('\n');
    text.into_bytes()
}

/// What `folder` holds against `expected`, a view whose files are `names`; with `job_only`,
/// only the fields shared by the job are compared (the manifest's check).
pub(crate) fn found(folder: &Path, names: &[String], expected: &Value, job_only: bool) -> Found {
    if !folder.is_dir() {
        return Found::Missing;
    }
    let held = std::fs::read(folder.join(RECORD))
        .ok()
        .and_then(|bytes| serde_json::from_slice::<Value>(&bytes).ok());
    let same = held.is_some_and(|held| match job_only {
        true => JOB_FIELDS.iter().all(|k| held.get(k) == expected.get(k)),
        false => &held == expected,
    });
    match same && names.iter().all(|n| folder.join(n).is_file()) {
        true => Found::Complete,
        false => Found::Stale,
    }
}

/// A digest of the scene `scene` loaded from `path` (the built-in scene without one): of its
/// file's bytes and of each mesh file it loads.
pub(crate) fn scene_digest(path: Option<&Path>, scene: &Scene) -> Result<String> {
    let Some(path) = path else {
        return Ok(digest(raycast::DEFAULT_SCENE_FILES));
    };
    let read = |p: &Path| {
        std::fs::read(p).map_err(|e| Error::Io {
            path: p.to_path_buf(),
            message: format!("cannot read: {e}"),
        })
    };
    let mut files = vec![read(path)?];
    if !raycast::is_mesh_file(path) {
        let base = path.parent().unwrap_or(Path::new(""));
        for object in &scene.objects {
            if let Object::Soup { path, .. } = object {
                files.push(read(&base.join(path))?);
            }
        }
    }
    Ok(digest(files.iter().map(Vec::as_slice)))
}

/// A 128-bit digest of `parts` (each prefixed with its length, so that they cannot run into
/// one another), in hex: two multiply-rotate lanes over 8-byte words, each step a bijection
/// of the word, finished by MurmurHash3's mixer. It tells files apart, as a checksum does; it
/// is not meant to resist someone forging a collision.
fn digest<'a>(parts: impl IntoIterator<Item = &'a [u8]>) -> String {
    let mut lanes = [0x243F_6A88_85A3_08D3u64, 0x1319_8A2E_0370_7344];
    let mut word = |w: u64| {
        lanes[0] = (lanes[0] ^ w)
            .wrapping_mul(0x9E37_79B9_7F4A_7C15)
            .rotate_left(29);
        lanes[1] = (lanes[1] ^ w.rotate_left(32))
            .wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
            .rotate_left(31);
    };
    for part in parts {
        word(part.len() as u64);
        let mut words = part.chunks_exact(8);
        for w in &mut words {
            word(u64::from_le_bytes(w.try_into().expect("8 bytes")));
        }
        let mut last = [0u8; 8];
        last[..words.remainder().len()].copy_from_slice(words.remainder());
        word(u64::from_le_bytes(last));
    }
    let mix = |mut h: u64| {
        h ^= h >> 33;
        h = h.wrapping_mul(0xFF51_AFD7_ED55_8CCD);
        h ^= h >> 33;
        h = h.wrapping_mul(0xC4CE_B9FE_1A85_EC53);
        h ^ (h >> 33)
    };
    format!("{:016x}{:016x}", mix(lanes[0]), mix(lanes[1] ^ lanes[0]))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The digest tells apart inputs that differ in one bit, in where parts split, or in a
    /// trailing zero byte; it is the same for the same input.
    #[test]
    fn digests_tell_apart_what_differs_by_a_bit_a_split_or_a_zero() {
        let base: Vec<u8> = (0..1000u32).map(|k| (k * 7 % 251) as u8).collect();
        let one = digest([&base[..]]);
        assert_eq!(one, digest([&base[..]]));
        assert_eq!(one.len(), 32);
        let mut seen = std::collections::HashSet::from([one.clone()]);
        for bit in 0..base.len() * 8 {
            let mut flipped = base.clone();
            flipped[bit / 8] ^= 1 << (bit % 8);
            assert!(seen.insert(digest([&flipped[..]])), "bit {bit}");
        }
        assert!(seen.insert(digest([&base[..500], &base[500..]])));
        let mut zero = base.clone();
        zero.push(0);
        assert!(seen.insert(digest([&zero[..]])));
        assert!(seen.insert(digest([&[0u8; 0][..]])));
        assert!(seen.insert(digest([&[0u8][..]])));
    }
}
