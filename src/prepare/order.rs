//! The order in which query points are searched: nearby points one after another (a Morton
//! curve through their bounds), so that the points of one SIMD group, or of one thread's run,
//! visit the same BVH nodes and triangles while they are in the caches. Each point's answer
//! does not depend on the order; the results go back to the caller's order.

use rayon::prelude::*;

/// Below this many points the order is left as given: sorting would cost more than it saves.
const MIN_POINTS: usize = 4096;
/// Consecutive pairs sampled to tell whether the points already come in a spatial order.
const SAMPLES: usize = 256;
/// Bits of each coordinate in the Morton code.
const BITS: u32 = 21;

/// The indices of `points` along a Morton curve, or `None` where sorting would not pay: too
/// few points, or points that already follow each other closely (a grid row by row, an
/// image's pixels), judged from [`SAMPLES`] consecutive pairs against the spacing of the same
/// number of points spread evenly through their bounds.
pub(crate) fn spatial_order(points: &[[f64; 3]]) -> Option<Vec<u32>> {
    let n = points.len();
    if n < MIN_POINTS || n > u32::MAX as usize {
        return None;
    }
    let (lo, hi) = bounds(points);
    let diagonal = (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f64>().sqrt();
    let spacing = diagonal / (n as f64).cbrt();
    let step = (n - 1) / SAMPLES;
    let gaps: f64 = (0..SAMPLES)
        .map(|s| distance(points[s * step], points[s * step + 1]))
        .sum();
    if gaps / SAMPLES as f64 <= 2.0 * spacing {
        return None;
    }
    let scale: [f64; 3] = std::array::from_fn(|k| {
        let extent = hi[k] - lo[k];
        if extent > 0.0 {
            ((1u64 << BITS) - 1) as f64 / extent
        } else {
            0.0
        }
    });
    let mut keyed: Vec<(u64, u32)> = points
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            let cell: [u64; 3] = std::array::from_fn(|k| ((p[k] - lo[k]) * scale[k]) as u64);
            (morton(cell), i as u32)
        })
        .collect();
    keyed.par_sort_unstable();
    Some(keyed.into_iter().map(|(_, i)| i).collect())
}

/// `query` of `points` run on them in their [`spatial_order`] where that pays, its answers
/// put back in the points' own order.
pub(crate) fn in_spatial_order<R: PerPoint, E>(
    points: &[[f64; 3]],
    query: impl FnOnce(&[[f64; 3]]) -> Result<R, E>,
) -> Result<R, E> {
    match spatial_order(points) {
        None => query(points),
        Some(order) => {
            let sorted: Vec<[f64; 3]> = order.iter().map(|&k| points[k as usize]).collect();
            Ok(query(&sorted)?.unsorted(&order))
        }
    }
}

/// Answers, one per point, that can be put back in the points' own order.
pub(crate) trait PerPoint {
    /// The answers of points taken in `order` (a permutation), in the points' own order.
    fn unsorted(&self, order: &[u32]) -> Self;
}

impl<T: Copy + Default> PerPoint for Vec<T> {
    fn unsorted(&self, order: &[u32]) -> Vec<T> {
        let mut out = vec![T::default(); self.len()];
        for (&v, &i) in self.iter().zip(order) {
            out[i as usize] = v;
        }
        out
    }
}

fn bounds(points: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
    let grow = |(lo, hi): ([f64; 3], [f64; 3]), p: &[f64; 3]| {
        (
            std::array::from_fn(|k| lo[k].min(p[k])),
            std::array::from_fn(|k| hi[k].max(p[k])),
        )
    };
    let empty = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    points.iter().fold(empty, grow)
}

fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
}

/// The three coordinates' bits interleaved, x lowest.
fn morton(cell: [u64; 3]) -> u64 {
    cell.iter()
        .enumerate()
        .map(|(axis, &c)| spread(c) << axis)
        .fold(0, |a, b| a | b)
}

/// The low [`BITS`] bits of `x` moved to every third position.
fn spread(x: u64) -> u64 {
    let mut x = x & 0x1f_ffff;
    x = (x | x << 32) & 0x1f00000000ffff;
    x = (x | x << 16) & 0x1f0000ff0000ff;
    x = (x | x << 8) & 0x100f00f00f00f00f;
    x = (x | x << 4) & 0x10c30c30c30c30c3;
    (x | x << 2) & 0x1249249249249249
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_places_each_bit_every_third() {
        for bit in 0..BITS {
            assert_eq!(spread(1 << bit), 1 << (3 * bit), "bit {bit}");
        }
        assert_eq!(morton([1, 0, 0]), 1);
        assert_eq!(morton([0, 1, 0]), 2);
        assert_eq!(morton([0, 0, 1]), 4);
        assert_eq!(morton([3, 3, 3]), 63);
    }

    #[test]
    fn scattered_points_are_sorted_and_ordered_ones_left_alone() {
        // A 20^3 grid row by row: neighbours already.
        let grid: Vec<[f64; 3]> = (0..8000)
            .map(|i| [(i % 20) as f64, (i / 20 % 20) as f64, (i / 400) as f64])
            .collect();
        assert_eq!(spatial_order(&grid), None);
        assert_eq!(spatial_order(&grid[..4000]), None, "few points");
        // The same points scattered (a multiplicative permutation of the indices).
        let scattered: Vec<[f64; 3]> = (0..8000).map(|i| grid[i * 2731 % 8000]).collect();
        let order = spatial_order(&scattered).expect("scattered points are sorted");
        let mut seen = order.clone();
        seen.sort_unstable();
        assert!(seen.iter().copied().eq(0..8000), "a permutation");
        let path = |o: &[u32]| -> f64 {
            o.windows(2)
                .map(|w| distance(scattered[w[0] as usize], scattered[w[1] as usize]))
                .sum()
        };
        let given: Vec<u32> = (0..8000).collect();
        assert!(
            path(&order) < path(&given) / 5.0,
            "the curve keeps neighbours together"
        );
        let values: Vec<u32> = order.iter().map(|&i| i * 10).collect();
        assert!(
            values
                .unsorted(&order)
                .iter()
                .copied()
                .eq((0..8000).map(|i| i * 10))
        );
    }
}
