//! Stages: each reads its inputs through `io`, runs the kernels, writes its outputs
//! atomically with provenance, and returns a report. The CLI and the pipeline runner
//! both call these; neither does any work of its own.

pub mod ingest;

/// Tool name and version recorded in every output.
pub const TOOL: &str = "pillar-pipe";
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
