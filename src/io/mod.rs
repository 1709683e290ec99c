//! File formats: everything that touches polars or the file system for tables.
//! To add an input format: a module that turns the file into `Tracks` (plus notes for
//! the summary), and a variant in `Format` with its detection rule.

pub mod atomic;
pub mod csvdiag;
pub mod export;
pub mod fastcsv;
pub mod features;
pub mod format;
pub mod hash;
pub mod kinematics_io;
pub mod lammps;
pub mod parquet_guard;
pub mod sink;
pub mod table;
pub mod trackpy;
pub mod tracks_io;

pub use atomic::{
    atomic_write, atomic_write_bytes, atomic_write_str, sidecar_path, write_with_sidecar,
};
pub use hash::sha256_file;
pub use tracks_io::{read_tracks, write_tracks};
