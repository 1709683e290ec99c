//! CLI wiring for `link`: located grains into trajectories, trackpy-style.

use anyhow::{Context, Result};
use clap::Args;
use pillar_pipe::camera::LinkOptions;
use pillar_pipe::camera::link::DEFAULT_SUBNET_LIMIT;
use std::path::PathBuf;

#[derive(Args)]
pub struct LinkArgs {
    /// Located grains: CSV (or Parquet) in trackpy's columns, positions in px; x, y and
    /// frame are required.
    pub features: PathBuf,
    /// Output CSV: the features in trackpy's columns plus `particle` (read by `ingest`).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Largest distance a grain moves between frames, from where it is predicted, in px.
    #[arg(long, value_name = "PX")]
    pub search_range: f64,
    /// Frames a grain may vanish and come back as the same particle.
    #[arg(long, value_name = "FRAMES", default_value_t = 0)]
    pub memory: usize,
    /// Look for each grain at its last position, not at its last position plus its
    /// last displacement per frame.
    #[arg(long)]
    pub no_predict: bool,
    /// Largest subnet (grains competing for the same features) solved exactly; larger
    /// ones are linked greedily, shortest links first, and reported.
    #[arg(long, value_name = "PARTICLES", default_value_t = DEFAULT_SUBNET_LIMIT)]
    pub subnet_limit: usize,
    /// Print the report as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

pub fn run(a: LinkArgs) -> Result<()> {
    let opt = LinkOptions {
        search_range: a.search_range,
        memory: a.memory,
        predict: !a.no_predict,
        subnet_limit: a.subnet_limit,
    };
    let run = pillar_pipe::stages::link::run(&a.features, &a.output, &opt)
        .with_context(|| format!("link {}", a.features.display()))?;
    let r = &run.report;
    eprintln!("linked {} -> {}", run.input, run.output);
    eprintln!(
        "features      {} in {} frames; {} trajectories ({} ended before the last frame)",
        r.features, r.frames, r.trajectories, r.ended
    );
    eprintln!(
        "links         {} ({} across gaps bridged by memory)",
        r.links, r.gaps_bridged
    );
    eprintln!(
        "subnets       {} solved exactly (the largest of {} particles); {} solved greedily ({} features)",
        r.subnets_exact, r.largest_subnet, r.subnets_greedy, r.features_greedy
    );
    for w in &run.warnings {
        eprintln!("warning: {w}");
    }
    if a.json {
        println!("{}", serde_json::to_string_pretty(&run)?);
    }
    Ok(())
}
