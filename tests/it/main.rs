//! The integration tests, one binary (each test file a module): the library and the
//! polars it links are linked once instead of once per file. Each module drives the CLI
//! as a user does, or the library where a test needs its insides.

mod common;

mod architecture;
mod camera_link;
mod camera_pipeline;
mod camera_render;
mod camera_track;
mod fit;
mod force;
mod fuzz;
mod ingest;
mod interrupt;
mod kinematics;
mod physics;
mod pipeline;
mod pipeline_cache;
mod pipeline_failures;
mod python;
mod ramp_pipeline;
mod regression;
mod report;
mod shear;
mod shear_lines;
mod shear_pipeline;
mod simulate;
mod size_scan;
mod slurm;
mod structure;
