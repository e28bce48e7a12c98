//! Files written band by band, for images too large to hold whole (a 16384 x 16384 render is
//! 5 GiB of f32 images): each band of rows is mapped by the same code as a whole image (png:
//! [`super::png_pictures`], raw pixels fed to a streaming png encoder; ppm and npy:
//! [`super::encode`], whose bodies are appended after the whole image's header),
//! so the streamed files have exactly the pixels (and for ppm and npy, the bytes) of the
//! whole-image ones. As with [`raycast_files::write_files`], everything goes to temporary names
//! first (registered in [`raycast_files::pending`], for removal at an interruption) and is
//! renamed into place only when every file is complete: none or all.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use super::{
    EncodedFile, Encoding, Format, Picture, depth16_picture, encode_format, encode_npy,
    png_pictures,
};
use crate::error::{Error, Result};
use crate::images::Images;
use crate::math::Real;
use crate::scene::Camera;
use raycast_files::pending;

/// One file being written: its final path, its temporary path, its encoder.
struct Stream {
    path: PathBuf,
    tmp: PathBuf,
    sink: Sink,
}

enum Sink {
    /// Rows of raw pixels into a PNG encoder of the whole image's size.
    Png(Box<png::StreamWriter<'static, BufWriter<File>>>),
    /// The bodies (after the header) of the bands' files.
    Raw(BufWriter<File>),
}

/// One file of a band: a png picture's raw pixels, or another format's encoded bytes.
enum BandFile {
    Picture(Picture),
    Encoded(EncodedFile),
}

impl BandFile {
    fn name(&self) -> &'static str {
        match self {
            BandFile::Picture(p) => p.name,
            BandFile::Encoded(f) => f.name,
        }
    }
}

/// Writes the files of a render band by band (see the module docs).
pub(crate) struct BandWriter {
    dir: PathBuf,
    width: u32,
    height: u32,
    encoding: Encoding,
    camera: Camera,
    streams: Vec<Stream>,
    rows_written: u32,
}

impl BandWriter {
    /// A writer for a render of `camera` (at its resolution) into `dir`; files open with the
    /// first band. Formats written whole only ([`Format::whole_only`]) are an error naming
    /// `formats`.
    pub(crate) fn new(dir: &Path, encoding: &Encoding, camera: &Camera) -> Result<BandWriter> {
        if let Some(f) = encoding.formats.iter().find(|f| f.whole_only()) {
            return Err(Error::Argument {
                option: format!("formats {}", f.name()),
                message: "is written whole, not in bands of rows (`band_rows`, or images above 16,777,216 pixels)".into(),
            });
        }
        let [width, height] = camera.resolution;
        Ok(BandWriter {
            dir: dir.to_owned(),
            width,
            height,
            encoding: encoding.clone(),
            camera: camera.clone(),
            streams: Vec::new(),
            rows_written: 0,
        })
    }

    /// The band's files, in the same order for every band: png pictures (and depth16.png) as
    /// raw pixels, the other formats encoded.
    fn band_files<T: Real>(&self, band: &Images<T>) -> Vec<BandFile> {
        let encoding = &self.encoding;
        let depths = encoding.depths(band, &self.camera, self.rows_written);
        let mut files = Vec::new();
        for &format in &encoding.formats {
            match format {
                Format::Png => {
                    let set = png_pictures(band, encoding.outputs, encoding.background);
                    files.extend(set.into_iter().map(BandFile::Picture));
                }
                Format::Depth16 => files.push(BandFile::Picture(depth16_picture(
                    band,
                    depths.depth16(),
                    encoding.depth_scale,
                ))),
                _ => {
                    let encoded = encode_format(band, format, encoding, &depths);
                    files.extend(encoded.into_iter().map(BandFile::Encoded));
                }
            }
        }
        files
    }

    /// Appends the next band of rows (from the top, in order).
    /// Bands are never supersampled.
    pub(crate) fn write_band<T: Real>(&mut self, band: &Images<T>) -> Result<()> {
        let files = self.band_files(band);
        if self.streams.is_empty() {
            // One by one, so that those opened are removed (Drop) if a later one fails.
            for f in &files {
                let stream = self.open(f)?;
                self.streams.push(stream);
            }
        }
        for (stream, file) in self.streams.iter_mut().zip(&files) {
            let io = |e: std::io::Error| Error::io(&stream.tmp, format!("cannot write: {e}"));
            match (&mut stream.sink, file) {
                (Sink::Png(w), BandFile::Picture(p)) => w.write_all(&p.pixels).map_err(io)?,
                (Sink::Raw(w), BandFile::Encoded(f)) => w.write_all(body(f)).map_err(io)?,
                _ => unreachable!("every band has the same files in the same order"),
            }
        }
        self.rows_written += band.height;
        Ok(())
    }

    /// Completes every file and renames them into place; returns their paths.
    pub(crate) fn finish(mut self) -> Result<Vec<PathBuf>> {
        if self.rows_written != self.height {
            return Err(Error::Device(format!(
                "streamed {} of {} rows",
                self.rows_written, self.height
            )));
        }
        let streams = std::mem::take(&mut self.streams);
        let mut temps: Vec<PathBuf> = streams.iter().map(|s| s.tmp.clone()).collect();
        let mut done = Vec::new();
        // camera.json, whole, among the files placed together.
        let camera = self.encoding.camera_json(&self.camera);
        let camera_path = self.dir.join(camera.name);
        let camera_tmp = pending::temp_path(&camera_path)?;
        temps.push(camera_tmp.clone());
        let written = pending::create(&camera_tmp)
            .and_then(|mut f| f.write_all(&camera.bytes).and_then(|()| f.flush()));
        if let Err(e) = written {
            pending::discard(temps.iter().map(PathBuf::as_path));
            return Err(Error::io(&camera_tmp, format!("cannot write: {e}")));
        }
        done.push((camera_tmp, camera_path));
        for s in streams {
            let finished = match s.sink {
                Sink::Png(w) => w.finish().map_err(|e| e.to_string()),
                Sink::Raw(mut w) => w.flush().map_err(|e| e.to_string()),
            };
            if let Err(e) = finished {
                pending::discard(temps.iter().map(PathBuf::as_path));
                return Err(Error::io(&s.tmp, format!("cannot write: {e}")));
            }
            done.push((s.tmp, s.path));
        }
        pending::place_all(&done)?;
        Ok(done.into_iter().map(|(_, path)| path).collect())
    }

    /// Opens `file`'s stream at the whole image's size, writing its header; on failure nothing
    /// is left behind.
    fn open(&self, file: &BandFile) -> Result<Stream> {
        let path = self.dir.join(file.name());
        let tmp = pending::temp_path(&path)?;
        let sink = pending::create(&tmp)
            .map_err(|e| e.to_string())
            .and_then(|f| self.start(file, BufWriter::new(f)));
        match sink {
            Ok(sink) => Ok(Stream { path, tmp, sink }),
            Err(e) => {
                pending::discard([tmp.as_path()]);
                Err(Error::io(&tmp, format!("cannot write: {e}")))
            }
        }
    }

    /// The encoder of `file` writing into `out`, its header written.
    fn start(
        &self,
        file: &BandFile,
        mut out: BufWriter<File>,
    ) -> std::result::Result<Sink, String> {
        Ok(match file {
            BandFile::Picture(p) => {
                let mut encoder = png::Encoder::new(out, self.width, self.height);
                encoder.set_color(match p.channels {
                    1 => png::ColorType::Grayscale,
                    3 => png::ColorType::Rgb,
                    _ => png::ColorType::Rgba,
                });
                encoder.set_depth(match p.bits {
                    16 => png::BitDepth::Sixteen,
                    _ => png::BitDepth::Eight,
                });
                let writer = encoder.write_header().map_err(|e| e.to_string())?;
                let stream = writer.into_stream_writer().map_err(|e| e.to_string())?;
                Sink::Png(Box::new(stream))
            }
            BandFile::Encoded(f) => {
                out.write_all(&self.header(f)).map_err(|e| e.to_string())?;
                Sink::Raw(out)
            }
        })
    }

    /// The header of the whole image's file, `file` being a band's.
    fn header(&self, file: &EncodedFile) -> Vec<u8> {
        let (w, h) = (self.width, self.height);
        if file.name.ends_with(".npy") {
            let header = npy_header(&file.bytes);
            let descr = header
                .split("'descr': '")
                .nth(1)
                .and_then(|s| s.split('\'').next())
                .unwrap_or("<f4");
            // The band's shape with the whole image's rows: (rows, W) or (rows, W, 3).
            let mut shape: Vec<usize> = header
                .split("'shape': (")
                .nth(1)
                .and_then(|s| s.split(')').next())
                .unwrap_or("")
                .split(',')
                .filter_map(|d| d.trim().parse().ok())
                .collect();
            if let Some(rows) = shape.first_mut() {
                *rows = h as usize;
            }
            encode_npy(descr, &shape, &[])
        } else {
            // ppm: "P3\nW H\n255\n" with the band's magic.
            let magic = String::from_utf8_lossy(&file.bytes[..2]).into_owned();
            format!("{magic}\n{w} {h}\n255\n").into_bytes()
        }
    }
}

impl Drop for BandWriter {
    /// An unfinished render leaves no file behind.
    fn drop(&mut self) {
        pending::discard(self.streams.iter().map(|s| s.tmp.as_path()));
    }
}

/// The text of an npy file's header.
fn npy_header(bytes: &[u8]) -> String {
    let len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    String::from_utf8_lossy(&bytes[10..10 + len]).into_owned()
}

/// What follows the header: for npy the raw values, for ppm the pixel lines.
fn body(file: &EncodedFile) -> &[u8] {
    let b = &file.bytes;
    if file.name.ends_with(".npy") {
        let len = u16::from_le_bytes([b[8], b[9]]) as usize;
        &b[10 + len..]
    } else {
        // Past the three header lines of a ppm.
        let mut newlines = b.iter().enumerate().filter(|(_, c)| **c == b'\n');
        let third = newlines.nth(2).map_or(b.len(), |(k, _)| k + 1);
        &b[third..]
    }
}
