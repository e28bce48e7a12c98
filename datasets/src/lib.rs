//! # raycast-datasets
//!
//! raycast's renders to files, above the library's API: the command line's and Python's.
//!
//! - [`RenderFiles`]: one render to files, as `raycast render` asks for it (whole or in bands,
//!   supersampled, with a shade hook or a kernel file), and its [`Summary`];
//! - [`RenderViews`]: a dataset, many views ([`Views`]: a views file or an orbit) of many
//!   scenes, each view's folder written whole with its record, a run started again resuming
//!   where the last stopped; split into shares of about equal cost ([`Shard`]) for a cluster's
//!   job array, with a manifest of the whole job ([`ViewsSummary`]), and rendered view by view
//!   by a worker's [`ViewRenderer`] (`raycast.distributed`). docs/datasets.md describes them.

#![warn(missing_docs)]

mod files;
mod record;
mod views;

// The tests of the views' pipeline against single renders, with the library's test helpers.
#[cfg(test)]
#[path = "../../src/tests/common/mod.rs"]
mod common;
#[cfg(test)]
mod tests;

pub use files::{RenderFiles, STREAM_PIXELS, Summary, requested_hook};
pub use views::{RenderViews, Shard, ViewRenderer, Views, ViewsSummary};
