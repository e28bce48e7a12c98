//! The command line's integration tests: one binary (one process, one lavapipe device), a module per topic.

#[path = "../../../src/tests/common/mod.rs"]
mod common;
#[path = "../serving/mod.rs"]
mod serving;

mod adaptive;
mod bench_cli;
mod cli_compare;
mod cli_errors;
mod course;
mod cpu_reference;
mod faults;
mod formats;
mod gpu_check;
mod instances;
mod interrupt;
mod kernel_file;
mod mesh_files;
mod no_f64_device;
mod outputs;
mod ray_tracing;
mod selftest;
mod serve;
mod shader_hooks;
mod specializations;
mod specialized_kernels;
mod streaming;
mod supersample;
mod tradeoff;
mod views;
