//! The library's integration tests: one binary (one process, one lavapipe device), a module per topic.

mod common;

mod analytic;
mod bvh;
mod cameras;
mod concurrency;
mod extremes;
mod fuzz_regressions;
mod layers;
mod rays;
mod tiling;
