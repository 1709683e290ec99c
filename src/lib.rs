//! pillar-pipe: deformation analysis (Li et al., granular pillars) and DEM simulation
//! (granular pillars; Vågberg et al., sheared disks) of 2D disordered granular packings.
//!
//! Dependencies point one way: `geom` ← `tracks` ← `neighbors` ← `kinematics`, `fit`;
//! `io` (polars) and `stages` sit on top; `main.rs` only parses arguments and wires.

// `!(x > 0.0)` is how this crate rejects NaN along with out-of-range values; the
// suggested rewrite with partial_cmp hides that intent.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod bench;
pub mod camera;
pub mod error;
pub mod fit;
pub mod geom;
pub mod interrupt;
pub mod io;
pub mod kinematics;
pub mod neighbors;
pub mod pipeline;
pub mod rng;
pub mod schema;
pub mod stages;
pub mod stats;
pub mod structure;
pub mod synth;
pub mod tracks;

pub use error::{Error, Result};
pub mod dem;
