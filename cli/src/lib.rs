//! The `raycast` command's parts that are more than parsing options: comparing two renders, the
//! studies (accuracy, tradeoff, specializations, bench, self-test, workloads), their pictures
//! and progress bars. A client of the `raycast` library; `main.rs` is the `clap` front end.

pub mod compare;
pub mod progress;
pub mod study;
pub mod text;
