//! raycast's measurements of its inner layers (kernel variants, the BVH build, the CPU
//! mirror's traversal), which need the crate's private items and so run in its test binary.
//! `cargo test` skips them (`#[ignore]`); run one in release with its arguments in
//! `RAYCAST_MEASURE`, as a command line would take them:
//!
//! ```sh
//! RAYCAST_MEASURE="scenes/course/bunny.json --runs 7" \
//!     cargo test --release -p raycast --lib adaptive_cost -- --ignored --nocapture
//! ```
//!
//! Measurements through the public API are programs in benches/.

mod adaptive_cost;
mod build_time;
mod bvh_stats;
mod bvh_timing;
mod kernel_ab;
mod pose_cost;
mod views_cost;

/// The measurement's arguments: `RAYCAST_MEASURE` split at white space.
fn args() -> Vec<String> {
    let given = std::env::var("RAYCAST_MEASURE").unwrap_or_default();
    given.split_whitespace().map(String::from).collect()
}

/// The median of `v` (the upper one of an even count).
fn median(v: &[f64]) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}
