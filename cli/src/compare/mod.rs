//! Comparing two renders of the same scene pixel by pixel: hit/miss and id agreement, distance
//! error where both hit, normal angle error where both hit.

mod command;
mod pictures;

use serde::Serialize;

use raycast::{AnyImages, Precision};
use raycast::{Images, MISS};

pub use command::{Outcome, Spec};
pub use pictures::{color_error_picture, distance_error_picture, mismatch_picture};

/// What `raycast compare` prints (besides the modes and times).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Report {
    pub pixels: usize,
    /// Pixels where one side hits and the other misses.
    pub hit_mismatch: usize,
    /// Pixels where both hit, but different objects.
    pub id_mismatch: usize,
    /// Over pixels where both hit the same object; `None` (JSON null) when there are none.
    /// (Where they hit different objects the difference measures the scene, not the
    /// arithmetic; those pixels are counted in `id_mismatch`.)
    pub distance: DistanceError,
    /// Angle between the two normals in degrees, over pixels where both hit the same object.
    pub normal_angle_deg: AngleError,
    /// `color.png`'s RGB levels, where both sides have one (a shade hook's: `--lit`,
    /// `--shader`); `None` (JSON null) otherwise.
    pub color: Option<ColorError>,
}

/// How two `color.png`s differ, in 8-bit levels of R, G and B.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ColorError {
    /// Share of pixels whose three levels are equal.
    pub exact: f64,
    /// Share of pixels with some level more than 2 apart.
    pub beyond_2: f64,
    /// Mean |a - b| over every level of every pixel.
    pub mean_abs: f64,
    /// Largest |a - b| of any level.
    pub max: u8,
}

/// The largest difference of R, G and B levels between two RGBA pixels.
pub fn level_difference(a: [u8; 4], b: [u8; 4]) -> u8 {
    (0..3).map(|c| a[c].abs_diff(b[c])).max().unwrap_or(0)
}

/// [`ColorError`] of two colour images of one size.
pub fn color_error(a: &[[u8; 4]], b: &[[u8; 4]]) -> ColorError {
    let n = a.len().max(1) as f64;
    let (mut exact, mut beyond, mut sum, mut largest) = (0usize, 0usize, 0u64, 0u8);
    for (&pa, &pb) in a.iter().zip(b) {
        let d = level_difference(pa, pb);
        exact += usize::from(d == 0);
        beyond += usize::from(d > 2);
        largest = largest.max(d);
        sum += (0..3).map(|c| pa[c].abs_diff(pb[c]) as u64).sum::<u64>();
    }
    ColorError {
        exact: exact as f64 / n,
        beyond_2: beyond as f64 / n,
        mean_abs: sum as f64 / (3.0 * n),
        max: largest,
    }
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DistanceError {
    /// max |a - b|
    pub abs_max: Option<f64>,
    /// max |a - b| / |b|
    pub rel_max: Option<f64>,
    /// 99th and 99.9th percentile (nearest rank) of |a - b| / |b|.
    pub rel_p99: Option<f64>,
    pub rel_p999: Option<f64>,
    /// max |a - b| in units in the last place of the f32 side (side a if both or neither are
    /// f32, in its own precision).
    pub ulp_max: Option<f64>,
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AngleError {
    pub max: Option<f64>,
    pub p99: Option<f64>,
}

/// How one pixel compares.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PixelMatch {
    BothMiss,
    /// Exactly one side hits.
    HitMismatch,
    /// Both hit different objects.
    IdMismatch,
    /// Both hit the same object.
    Same,
}

/// A per-pixel comparison and its summary.
pub struct Comparison {
    pub width: u32,
    pub height: u32,
    pub report: Report,
    pub per_pixel: Vec<PixelMatch>,
    /// |a - b| / |b| where both hit the same object, else `None`.
    pub rel_error: Vec<Option<f64>>,
}

/// The fields a comparison needs, widened to f64, with the precision the values came in.
struct Side<'a> {
    id: &'a [i32],
    color: Option<&'a [[u8; 4]]>,
    distance: Vec<f64>,
    normal: Vec<[f64; 3]>,
    precision: Precision,
}

fn side<T: Copy + Into<f64>>(images: &Images<T>, precision: Precision) -> Side<'_> {
    Side {
        id: &images.id,
        color: images.color.as_deref(),
        distance: images.distance.iter().map(|&d| d.into()).collect(),
        normal: images.normal.iter().map(|n| n.map(T::into)).collect(),
        precision,
    }
}

fn any_side(images: &AnyImages) -> (Side<'_>, u32, u32) {
    match images {
        AnyImages::F32(i) => (side(i, Precision::F32), i.width, i.height),
        AnyImages::F64(i) => (side(i, Precision::F64), i.width, i.height),
    }
}

/// Spacing of floats of `precision` at `x` (the ulp of |x|).
fn ulp(x: f64, precision: Precision) -> f64 {
    let x = x.abs();
    match precision {
        Precision::F32 => {
            let f = x as f32;
            (f32::from_bits(f.to_bits() + 1) - f) as f64
        }
        _ => f64::from_bits(x.to_bits() + 1) - x,
    }
}

/// Angle between two unit-ish vectors in degrees, accurate for tiny angles.
fn angle_deg(a: [f64; 3], b: [f64; 3]) -> f64 {
    let cross = [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ];
    let sin = (cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]).sqrt();
    let cos = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    sin.atan2(cos).to_degrees()
}

/// Nearest-rank percentile `q` (0..1] of `values`, which it sorts.
fn percentile(values: &mut [f64], q: f64) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    values.sort_by(f64::total_cmp);
    let rank = ((q * values.len() as f64).ceil() as usize).clamp(1, values.len());
    Some(values[rank - 1])
}

fn max(values: &[f64]) -> Option<f64> {
    values.iter().copied().reduce(f64::max)
}

/// Compares `a` with `b` (the reference for relative errors). Both must have the same size.
pub fn compare(a: &AnyImages, b: &AnyImages) -> Comparison {
    let (sa, width, height) = any_side(a);
    let (sb, wb, hb) = any_side(b);
    assert_eq!((width, height), (wb, hb), "compared images differ in size");
    let ulp_side = if sa.precision == Precision::F32 || sb.precision != Precision::F32 {
        &sa
    } else {
        &sb
    };
    let n = sa.id.len();
    let mut per_pixel = Vec::with_capacity(n);
    let mut rel_error = vec![None; n];
    let (mut hit_mismatch, mut id_mismatch) = (0, 0);
    let (mut abs, mut rel, mut ulps, mut angles) = (vec![], vec![], vec![], vec![]);
    for (k, rel_error_k) in rel_error.iter_mut().enumerate() {
        let (ia, ib) = (sa.id[k], sb.id[k]);
        let m = match (ia == MISS, ib == MISS) {
            (true, true) => PixelMatch::BothMiss,
            (true, false) | (false, true) => PixelMatch::HitMismatch,
            (false, false) if ia != ib => PixelMatch::IdMismatch,
            _ => PixelMatch::Same,
        };
        per_pixel.push(m);
        match m {
            PixelMatch::HitMismatch => hit_mismatch += 1,
            PixelMatch::IdMismatch => id_mismatch += 1,
            _ => {}
        }
        if m != PixelMatch::Same {
            continue;
        }
        let (da, db) = (sa.distance[k], sb.distance[k]);
        let e = (da - db).abs();
        abs.push(e);
        let r = e / db.abs();
        rel.push(r);
        *rel_error_k = Some(r);
        ulps.push(e / ulp(ulp_side.distance[k], ulp_side.precision));
        angles.push(angle_deg(sa.normal[k], sb.normal[k]));
    }
    let report = Report {
        pixels: n,
        hit_mismatch,
        id_mismatch,
        distance: DistanceError {
            abs_max: max(&abs),
            rel_max: max(&rel),
            rel_p99: percentile(&mut rel.clone(), 0.99),
            rel_p999: percentile(&mut rel, 0.999),
            ulp_max: max(&ulps),
        },
        normal_angle_deg: AngleError {
            max: max(&angles),
            p99: percentile(&mut angles, 0.99),
        },
        color: sa.color.zip(sb.color).map(|(a, b)| color_error(a, b)),
    };
    Comparison {
        width,
        height,
        report,
        per_pixel,
        rel_error,
    }
}

/// The metric names `--fail-above` accepts, as dotted paths into the report's JSON.
pub const METRICS: [&str; 12] = [
    "hit_mismatch",
    "id_mismatch",
    "distance.abs_max",
    "distance.rel_max",
    "distance.rel_p99",
    "distance.rel_p999",
    "distance.ulp_max",
    "normal_angle_deg.max",
    "normal_angle_deg.p99",
    "color.beyond_2",
    "color.mean_abs",
    "color.max",
];

/// The value of a metric (`None` when there was nothing to measure, e.g. no common hits).
pub fn metric(report: &Report, name: &str) -> Option<f64> {
    let d = &report.distance;
    let n = &report.normal_angle_deg;
    match name {
        "hit_mismatch" => Some(report.hit_mismatch as f64),
        "id_mismatch" => Some(report.id_mismatch as f64),
        "distance.abs_max" => d.abs_max,
        "distance.rel_max" => d.rel_max,
        "distance.rel_p99" => d.rel_p99,
        "distance.rel_p999" => d.rel_p999,
        "distance.ulp_max" => d.ulp_max,
        "normal_angle_deg.max" => n.max,
        "normal_angle_deg.p99" => n.p99,
        "color.beyond_2" => report.color.as_ref().map(|c| c.beyond_2),
        "color.mean_abs" => report.color.as_ref().map(|c| c.mean_abs),
        "color.max" => report.color.as_ref().map(|c| c.max as f64),
        _ => None,
    }
}

/// The bounds of `bounds` that `report` exceeds, as `name = value > bound`.
pub fn exceeded(report: &Report, bounds: &[(String, f64)]) -> Vec<String> {
    bounds
        .iter()
        .filter_map(|(name, bound)| {
            let value = metric(report, name)?;
            (value > *bound).then(|| format!("{name} = {value} > {bound}"))
        })
        .collect()
}

/// Parses `K=V` (one bound of `--fail-above`), checking that K is a known metric.
pub fn parse_bound(s: &str) -> Result<(String, f64), String> {
    let (k, v) = s
        .split_once('=')
        .ok_or_else(|| format!("expected METRIC=VALUE, got `{s}`"))?;
    let k = k.trim();
    if !METRICS.contains(&k) {
        return Err(format!(
            "unknown metric `{k}` (known: {})",
            METRICS.join(", ")
        ));
    }
    let v: f64 = v
        .trim()
        .parse()
        .map_err(|_| format!("`{v}` is not a number (in `{s}`)"))?;
    Ok((k.to_owned(), v))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn images(ids: &[i32], distance: &[f64]) -> AnyImages {
        AnyImages::F64(Images {
            width: ids.len() as u32,
            height: 1,
            id: ids.to_vec(),
            distance: distance.to_vec(),
            normal: vec![[0.0, 0.0, 1.0]; ids.len()],
            ..Images::default()
        })
    }

    #[test]
    fn counts_each_kind_of_mismatch() {
        let inf = f64::INFINITY;
        let a = images(&[-1, 0, 1, 2, 2], &[inf, 1.0, 2.0, 3.0, 4.0]);
        let b = images(&[-1, -1, 1, 3, 2], &[inf, inf, 2.5, 3.0, 4.0]);
        let r = compare(&a, &b).report;
        assert_eq!((r.pixels, r.hit_mismatch, r.id_mismatch), (5, 1, 1));
        assert_eq!(r.distance.abs_max, Some(0.5));
        assert_eq!(r.distance.rel_max, Some(0.2));
        assert_eq!(r.normal_angle_deg.max, Some(0.0));
    }

    #[test]
    fn nothing_in_common_gives_null_errors() {
        let inf = f64::INFINITY;
        let r = compare(&images(&[-1], &[inf]), &images(&[0], &[1.0])).report;
        assert_eq!(r.distance.rel_max, None);
        let json = serde_json::to_string(&r).unwrap();
        assert!(json.contains("\"rel_max\":null"), "{json}");
    }

    #[test]
    fn percentiles_are_nearest_rank() {
        let mut v: Vec<f64> = (1..=1000).map(f64::from).collect();
        assert_eq!(percentile(&mut v, 0.99), Some(990.0));
        assert_eq!(percentile(&mut v, 0.999), Some(999.0));
    }

    #[test]
    fn ulps_of_f32() {
        assert_eq!(ulp(1.0, Precision::F32), f32::EPSILON as f64);
        assert_eq!(ulp(1.0, Precision::F64), f64::EPSILON);
    }

    #[test]
    fn small_angles_are_accurate() {
        let t: f64 = 1e-9;
        let a = angle_deg([1.0, 0.0, 0.0], [t.cos(), t.sin(), 0.0]);
        assert!((a - t.to_degrees()).abs() < 1e-20);
    }

    #[test]
    fn bounds_parse_and_gate() {
        assert!(
            parse_bound("bogus=1")
                .unwrap_err()
                .contains("unknown metric")
        );
        let bound = parse_bound("id_mismatch=3").unwrap();
        let inf = f64::INFINITY;
        let a = images(&[0, 0, 0, 0], &[1.0; 4]);
        let b = images(&[1, 1, 1, -1], &[1.0, 1.0, 1.0, inf]);
        let r = compare(&a, &b).report;
        assert_eq!((r.id_mismatch, r.hit_mismatch), (3, 1));
        // 3 is not above the bound 3; it is above 2.
        assert!(exceeded(&r, std::slice::from_ref(&bound)).is_empty());
        let tighter = parse_bound("id_mismatch=2").unwrap();
        assert_eq!(exceeded(&r, &[tighter]).len(), 1);
    }
}
