//! The library's tests below its API: a module per topic in the library's test binary (one
//! process, one lavapipe device), sharing `common` with the command line's tests.

mod common;

mod analytic;
mod bvh;
mod cameras;
mod concurrency;
mod extremes;
mod fuzz_regressions;
mod layers;
mod rays;
mod supersample;
mod tiling;
