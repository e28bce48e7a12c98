//! `tradeoff.png`: wall time against error on log axes, one labelled point per row, drawn with
//! `image` and the 8x8 bitmap font (no system fonts needed).
//!
//! Two panels share the time axis: above, the mismatch fraction (pixels with the wrong hit/miss
//! or object, over all pixels); below, the 99.9th percentile of the relative distance error.
//! An exact 0 cannot sit on a log axis: such points go in a shaded band marked `0` under each
//! panel. Colour: the scene; marker: filled disc for GPU modes, filled square for CPU modes,
//! ring for rows at more than one sample per pixel.

use image::{Rgb, RgbImage};

use super::{REFERENCE, REFERENCE_SPP, Row};
use crate::text::{GLYPH, draw_text, draw_text_scaled, text_width};
use raycast::Device;

const WIDTH: u32 = 1280;
const LEFT: u32 = 84;
const RIGHT: u32 = WIDTH - 24;
const WHITE: Rgb<u8> = Rgb([255, 255, 255]);
const INK: Rgb<u8> = Rgb([40, 40, 40]);
const GRID: Rgb<u8> = Rgb([225, 225, 225]);
const BAND: Rgb<u8> = Rgb([243, 243, 243]);
const MARKER_RADIUS: i64 = 4;
/// Scene colours, in scene order (repeating).
const SCENE_COLORS: [[u8; 3]; 7] = [
    [55, 126, 184],
    [228, 26, 28],
    [77, 175, 74],
    [152, 78, 163],
    [230, 110, 0],
    [166, 86, 40],
    [90, 90, 90],
];
/// Height of the band where exact zeros are drawn.
const ZERO_BAND: u32 = 76;

/// A log10 axis: the decades `10^lo ..= 10^hi` mapped linearly in the exponent onto the pixel
/// coordinates `p0 ..= p1` (`p1 < p0` for an upward y axis).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LogAxis {
    pub lo: i32,
    pub hi: i32,
    pub p0: f64,
    pub p1: f64,
}

impl LogAxis {
    /// The whole decades covering the positive finite `values` (at least one decade; `-1..0`
    /// when there are none), mapped onto `p0 ..= p1`.
    pub fn fit(values: impl IntoIterator<Item = f64>, p0: f64, p1: f64) -> LogAxis {
        let (mut min, mut max) = (f64::INFINITY, f64::NEG_INFINITY);
        for v in values.into_iter().filter(|v| v.is_finite() && *v > 0.0) {
            min = min.min(v);
            max = max.max(v);
        }
        let (lo, hi) = if min.is_finite() {
            // The slack keeps exact powers of ten (whose log10 may be off by an ulp) on their
            // own decade instead of adding an empty one.
            let lo = (min.log10() + 1e-9).floor() as i32;
            let hi = (max.log10() - 1e-9).ceil() as i32;
            (lo, hi.max(lo + 1))
        } else {
            (-1, 0)
        };
        LogAxis { lo, hi, p0, p1 }
    }

    /// The pixel coordinate of `value` (> 0); values outside the decades extrapolate.
    pub fn pixel(&self, value: f64) -> f64 {
        let f = (value.log10() - self.lo as f64) / (self.hi - self.lo) as f64;
        self.p0 + f * (self.p1 - self.p0)
    }
}

/// A decade's tick label: plain for 0.01 to 100, else `1e-7`.
pub fn decade_label(d: i32) -> String {
    match d {
        -2 => "0.01".into(),
        -1 => "0.1".into(),
        0 => "1".into(),
        1 => "10".into(),
        2 => "100".into(),
        d => format!("1e{d}"),
    }
}

/// An axis-aligned box, `x0..x1` by `y0..y1` (exclusive ends).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Rect {
    x0: i64,
    y0: i64,
    x1: i64,
    y1: i64,
}

impl Rect {
    fn overlaps(&self, o: &Rect) -> bool {
        self.x0 < o.x1 && o.x0 < self.x1 && self.y0 < o.y1 && o.y0 < self.y1
    }
    fn inside(&self, o: &Rect) -> bool {
        self.x0 >= o.x0 && self.x1 <= o.x1 && self.y0 >= o.y0 && self.y1 <= o.y1
    }
}

fn put(img: &mut RgbImage, x: i64, y: i64, c: Rgb<u8>) {
    if x >= 0 && y >= 0 && (x as u32) < img.width() && (y as u32) < img.height() {
        img.put_pixel(x as u32, y as u32, c);
    }
}

fn fill(img: &mut RgbImage, r: Rect, c: Rgb<u8>) {
    for y in r.y0..r.y1 {
        for x in r.x0..r.x1 {
            put(img, x, y, c);
        }
    }
}

fn hline(img: &mut RgbImage, x0: i64, x1: i64, y: i64, c: Rgb<u8>, dash: bool) {
    for x in x0..=x1 {
        if !dash || (x / 4) % 2 == 0 {
            put(img, x, y, c);
        }
    }
}

fn vline(img: &mut RgbImage, x: i64, y0: i64, y1: i64, c: Rgb<u8>) {
    for y in y0..=y1 {
        put(img, x, y, c);
    }
}

/// A straight line (Bresenham).
fn line(img: &mut RgbImage, (mut x0, mut y0): (i64, i64), (x1, y1): (i64, i64), c: Rgb<u8>) {
    let (dx, dy) = ((x1 - x0).abs(), -(y1 - y0).abs());
    let (sx, sy) = (if x0 < x1 { 1 } else { -1 }, if y0 < y1 { 1 } else { -1 });
    let mut err = dx + dy;
    loop {
        put(img, x0, y0, c);
        if x0 == x1 && y0 == y1 {
            break;
        }
        let e2 = 2 * err;
        if e2 >= dy {
            err += dy;
            x0 += sx;
        }
        if e2 <= dx {
            err += dx;
            y0 += sy;
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Marker {
    Disc,
    Square,
    Ring,
}

fn marker_of(row: &Row) -> Marker {
    match (row.spp > 1, row.mode.device) {
        (true, _) => Marker::Ring,
        (false, Device::Gpu) => Marker::Disc,
        (false, Device::Cpu) => Marker::Square,
    }
}

fn draw_marker(img: &mut RgbImage, x: i64, y: i64, m: Marker, c: Rgb<u8>) {
    let r = MARKER_RADIUS;
    for dy in -r - 1..=r + 1 {
        for dx in -r - 1..=r + 1 {
            let d2 = dx * dx + dy * dy;
            let on = match m {
                Marker::Disc => d2 <= r * r + 1,
                Marker::Square => dx.abs() <= r && dy.abs() <= r,
                Marker::Ring => d2 <= (r + 1) * (r + 1) + 1 && d2 >= (r - 1) * (r - 1),
            };
            if on {
                put(img, x + dx, y + dy, c);
            }
        }
    }
}

fn scene_color(rows: &[Row], scene: &str) -> Rgb<u8> {
    let mut names: Vec<&str> = Vec::new();
    for r in rows {
        if !names.contains(&r.scene.as_str()) {
            names.push(&r.scene);
        }
    }
    let k = names.iter().position(|n| *n == scene).unwrap_or(0);
    Rgb(SCENE_COLORS[k % SCENE_COLORS.len()])
}

/// One panel: a log y axis over `top..top + height` and a zero band below it.
struct Panel<'a> {
    title: &'a str,
    top: u32,
    height: u32,
    /// The row's y value; `None`: not drawn.
    value: fn(&Row) -> Option<f64>,
}

impl Panel<'_> {
    fn bottom(&self) -> u32 {
        self.top + self.height + ZERO_BAND
    }
}

/// Draws one panel's frame, grid, y ticks and its points with labels.
fn draw_panel(img: &mut RgbImage, rows: &[Row], x: &LogAxis, p: &Panel) {
    let (top, log_bottom, bottom) = (p.top, p.top + p.height, p.bottom());
    draw_text(img, LEFT, top - 14, p.title, INK);
    let values: Vec<Option<f64>> = rows.iter().map(p.value).collect();
    let y = LogAxis::fit(
        values.iter().flatten().copied(),
        (log_bottom - 6) as f64,
        (top + 6) as f64,
    );
    let (l, r) = (LEFT as i64, RIGHT as i64);
    // Zero band, grid, ticks.
    fill(
        img,
        Rect {
            x0: l,
            y0: log_bottom as i64,
            x1: r,
            y1: bottom as i64,
        },
        BAND,
    );
    hline(img, l, r, log_bottom as i64, INK, true);
    draw_text(
        img,
        LEFT - 6 - GLYPH,
        log_bottom + ZERO_BAND / 2 - 4,
        "0",
        INK,
    );
    for d in y.lo..=y.hi {
        let py = y.pixel(10f64.powi(d)).round() as i64;
        hline(img, l + 1, r - 1, py, GRID, false);
        hline(img, l - 5, l, py, INK, false);
        let label = decade_label(d);
        let w = text_width(&label, 1);
        draw_text(img, LEFT - 8 - w, (py - 4).max(0) as u32, &label, INK);
        if d < y.hi && y.hi - y.lo <= 8 {
            for m in 2..10 {
                let py = y.pixel(m as f64 * 10f64.powi(d)).round() as i64;
                hline(img, l - 3, l, py, INK, false);
            }
        }
    }
    for d in x.lo..=x.hi {
        let px = x.pixel(10f64.powi(d)).round() as i64;
        vline(img, px, top as i64 + 1, log_bottom as i64 - 1, GRID);
        vline(img, px, bottom as i64, bottom as i64 + 5, INK);
        if d < x.hi {
            for m in 2..10 {
                let px = x.pixel(m as f64 * 10f64.powi(d)).round() as i64;
                vline(img, px, bottom as i64, bottom as i64 + 3, INK);
            }
        }
    }
    // Frame.
    hline(img, l, r, top as i64, INK, false);
    hline(img, l, r, bottom as i64, INK, false);
    vline(img, l, top as i64, bottom as i64, INK);
    vline(img, r, top as i64, bottom as i64, INK);

    // Points, then labels placed where they overlap neither a point nor another label.
    let zero_y = (log_bottom + ZERO_BAND / 2) as i64;
    let points: Vec<(usize, i64, i64)> = values
        .iter()
        .enumerate()
        .filter_map(|(k, v)| {
            let v = (*v)?;
            let py = if v > 0.0 {
                y.pixel(v).round() as i64
            } else {
                zero_y
            };
            Some((k, x.pixel(rows[k].wall_s).round() as i64, py))
        })
        .collect();
    // A label stays in its point's part: the log area, or the zero band.
    let log_area = Rect {
        x0: l + 2,
        y0: top as i64 + 2,
        x1: r - 1,
        y1: log_bottom as i64 - 1,
    };
    let band_area = Rect {
        y0: log_bottom as i64 + 2,
        y1: bottom as i64 - 1,
        ..log_area
    };
    let reach = MARKER_RADIUS + 2;
    let mut taken: Vec<Rect> = points
        .iter()
        .map(|&(_, px, py)| Rect {
            x0: px - reach,
            y0: py - reach,
            x1: px + reach + 1,
            y1: py + reach + 1,
        })
        .collect();
    for &(k, px, py) in &points {
        draw_marker(
            img,
            px,
            py,
            marker_of(&rows[k]),
            scene_color(rows, &rows[k].scene),
        );
    }
    for &(k, px, py) in &points {
        let label = rows[k].label();
        let color = scene_color(rows, &rows[k].scene);
        let w = text_width(&label, 1) as i64;
        let h = GLYPH as i64;
        let at = |x0: i64, dy: i64| Rect {
            x0,
            y0: py - h / 2 + dy,
            x1: x0 + w,
            y1: py - h / 2 + dy + h,
        };
        let right = px + reach + 1;
        let left = px - reach - 1 - w;
        let mut candidates = vec![at(right, 0), at(left, 0)];
        for step in 1..=6 {
            for dy in [-10 * step, 10 * step] {
                candidates.push(at(right, dy));
                candidates.push(at(left, dy));
            }
        }
        let area = if py == zero_y { band_area } else { log_area };
        // The first candidate inside the area that overlaps nothing; failing that, the one
        // inside it that overlaps least.
        let overlap = |c: &Rect| -> i64 {
            taken
                .iter()
                .filter(|t| t.overlaps(c))
                .map(|t| (c.x1.min(t.x1) - c.x0.max(t.x0)) * (c.y1.min(t.y1) - c.y0.max(t.y0)))
                .sum()
        };
        let inside: Vec<Rect> = candidates.into_iter().filter(|c| c.inside(&area)).collect();
        let chosen = inside
            .iter()
            .copied()
            .find(|c| overlap(c) == 0)
            .or_else(|| inside.iter().copied().min_by_key(|c| overlap(c)))
            .unwrap_or(at(right, 0));
        if (chosen.y0 + h / 2 - py).abs() > h / 2 {
            // A leader from the point to the label's near edge.
            let lx = if chosen.x0 > px {
                chosen.x0 - 1
            } else {
                chosen.x1
            };
            let faint = Rgb(color.0.map(|c| ((c as u32 + 2 * 255) / 3) as u8));
            line(img, (px, py), (lx, chosen.y0 + h / 2), faint);
            draw_marker(img, px, py, marker_of(&rows[k]), color);
        }
        draw_text(
            img,
            chosen.x0.max(0) as u32,
            chosen.y0.max(0) as u32,
            &label,
            color,
        );
        taken.push(chosen);
    }
}

/// The plot of `rows` (module docs), titled, with `subtitle` (where and how it was measured)
/// under the title and a legend at the bottom.
pub fn plot(rows: &[Row], subtitle: &str) -> RgbImage {
    let a = Panel {
        title: "pixels with the wrong hit/miss or object, fraction of all pixels (log)",
        top: 78,
        height: 330,
        value: |r| Some(r.mismatch_fraction()),
    };
    let b = Panel {
        title: "relative distance error |d - d_ref| / d_ref, 99.9th percentile (log)",
        top: a.bottom() + 40,
        height: 250,
        value: |r| r.rel_p999,
    };
    let axis_y = b.bottom() + 10;
    let legend_y = axis_y + 40;
    let height = legend_y + 3 * 14 + 8;
    let mut img = RgbImage::from_pixel(WIDTH, height, WHITE);
    draw_text_scaled(
        &mut img,
        LEFT,
        10,
        "raycast tradeoff: wall time against error",
        INK,
        2,
    );
    draw_text(&mut img, LEFT, 34, subtitle, INK);
    draw_text(
        &mut img,
        LEFT,
        48,
        &format!("errors against {REFERENCE}; rings: at N spp, against it at {REFERENCE_SPP} spp"),
        INK,
    );
    let x = LogAxis::fit(
        rows.iter().map(|r| r.wall_s),
        (LEFT + 14) as f64,
        (RIGHT - 14) as f64,
    );
    draw_panel(&mut img, rows, &x, &a);
    draw_panel(&mut img, rows, &x, &b);
    for d in x.lo..=x.hi {
        let label = decade_label(d);
        let px = x.pixel(10f64.powi(d)).round() as i64;
        let w = text_width(&label, 1) as i64;
        draw_text(&mut img, (px - w / 2).max(0) as u32, axis_y, &label, INK);
    }
    let x_title = "wall time per frame, seconds (log)";
    let w = text_width(x_title, 1);
    draw_text(&mut img, (LEFT + RIGHT - w) / 2, axis_y + 16, x_title, INK);
    // Legend: scenes by colour, then markers.
    let mut lx = LEFT as i64;
    let mut seen: Vec<&str> = Vec::new();
    for r in rows {
        if seen.contains(&r.scene.as_str()) {
            continue;
        }
        seen.push(&r.scene);
        let c = scene_color(rows, &r.scene);
        draw_marker(&mut img, lx + 5, legend_y as i64 + 4, Marker::Disc, c);
        draw_text(&mut img, lx as u32 + 14, legend_y, &r.scene, c);
        lx += 14 + text_width(&r.scene, 1) as i64 + 24;
    }
    let y2 = legend_y + 16;
    let mut lx = LEFT as i64;
    for (m, text) in [
        (Marker::Disc, "GPU".to_owned()),
        (Marker::Square, "CPU".to_owned()),
        (
            Marker::Ring,
            "gpu:f32:robust at N samples per pixel".to_owned(),
        ),
    ] {
        draw_marker(&mut img, lx + 5, y2 as i64 + 4, m, INK);
        draw_text(&mut img, lx as u32 + 14, y2, &text, INK);
        lx += 14 + text_width(&text, 1) as i64 + 24;
    }
    img
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_axis_covers_whole_decades() {
        let a = LogAxis::fit([3e-5, 0.0, f64::NAN, 2e-2], 0.0, 100.0);
        assert_eq!((a.lo, a.hi), (-5, -1));
        // Exact powers of ten stay on their own decade.
        let a = LogAxis::fit([1e-3, 1e-1], 0.0, 1.0);
        assert_eq!((a.lo, a.hi), (-3, -1));
        // One value: one decade; none: a default.
        let a = LogAxis::fit([5.0], 0.0, 1.0);
        assert_eq!((a.lo, a.hi), (0, 1));
        let a = LogAxis::fit([1.0], 0.0, 1.0);
        assert_eq!((a.lo, a.hi), (0, 1));
        let a = LogAxis::fit([0.0], 0.0, 1.0);
        assert_eq!((a.lo, a.hi), (-1, 0));
    }

    #[test]
    fn log_axis_maps_decades_linearly() {
        // x: 1e-3 .. 1e1 onto 100 .. 500.
        let x = LogAxis {
            lo: -3,
            hi: 1,
            p0: 100.0,
            p1: 500.0,
        };
        assert!((x.pixel(1e-3) - 100.0).abs() < 1e-9);
        assert!((x.pixel(1e1) - 500.0).abs() < 1e-9);
        assert!((x.pixel(0.1) - 300.0).abs() < 1e-9);
        assert!((x.pixel(10f64.sqrt()) - 450.0).abs() < 1e-9);
        // y points up: the top decade at the smaller pixel coordinate.
        let y = LogAxis {
            lo: -6,
            hi: 0,
            p0: 400.0,
            p1: 100.0,
        };
        assert!((y.pixel(1e-6) - 400.0).abs() < 1e-9);
        assert!((y.pixel(1.0) - 100.0).abs() < 1e-9);
        assert!((y.pixel(1e-3) - 250.0).abs() < 1e-9);
        assert!(y.pixel(2e-3) < y.pixel(1e-3));
    }

    #[test]
    fn decade_labels() {
        assert_eq!(decade_label(-2), "0.01");
        assert_eq!(decade_label(0), "1");
        assert_eq!(decade_label(-7), "1e-7");
        assert_eq!(decade_label(3), "1e3");
    }

    #[test]
    fn boxes_overlap_only_when_they_share_area() {
        let a = Rect {
            x0: 0,
            y0: 0,
            x1: 10,
            y1: 10,
        };
        let touching = Rect {
            x0: 10,
            y0: 0,
            x1: 20,
            y1: 10,
        };
        let crossing = Rect {
            x0: 9,
            y0: 9,
            x1: 20,
            y1: 20,
        };
        assert!(!a.overlaps(&touching));
        assert!(a.overlaps(&crossing));
        assert!(!touching.inside(&a));
    }
}
