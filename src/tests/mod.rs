//! The library's tests below its API: a module per topic in the library's test binary (one
//! process, one lavapipe device), sharing `common` with the command line's tests.

pub(crate) mod common;
mod kernels;

mod adaptive;
mod analytic;
mod bvh;
mod cameras;
mod concurrency;
mod extremes;
mod fuzz_regressions;
mod hooks;
mod layers;
mod measure;
mod no_f64_device;
mod orbits;
mod points;
mod rays;
mod specialized_kernels;
mod supersample;
mod tiling;
mod timing;
mod wide_subgroups;
