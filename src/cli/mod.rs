//! The command line: one `Args` struct per command in the module of its family, and
//! the dispatch. Commands parse, call one library function and print its report; the
//! work is in `pillar_pipe`.

pub mod analysis;
pub mod bench;
pub mod camera;
pub mod export;
pub mod force;
pub mod render;
pub mod runs;
pub mod sim;
pub mod structure;

use anyhow::Result;
use clap::{Parser, Subcommand};
use std::path::PathBuf;

#[derive(Parser)]
#[command(
    name = "pillar-pipe",
    version,
    about = "Deformation analysis and DEM simulation of 2D granular packings (granular pillars, sheared disks)"
)]
pub struct Cli {
    #[command(subcommand)]
    pub cmd: Cmd,
}

#[derive(Subcommand)]
pub enum Cmd {
    Ingest(analysis::IngestArgs),
    IngestForce(force::IngestForceArgs),
    Kinematics(analysis::KinematicsArgs),
    Fit(analysis::FitArgs),
    Compare(analysis::CompareArgs),
    Quickstart(analysis::QuickstartArgs),
    /// Run the bundled DEM (pillar; sheared disks).
    Simulate {
        #[command(subcommand)]
        what: sim::SimulateCmd,
    },
    /// Grid of sheared-disk runs (φ × Q × γ̇), `--jobs` at a time, with one summary table.
    Sweep(sim::SweepArgs),
    /// Generate a jammed bidisperse packing (li-granular-pillars Sec. II.A).
    Pack(sim::PackArgs),
    /// Locate grains in camera frames (PNG/TIFF, 8/16 bit) as trackpy's `locate`
    /// does (Crocker–Grier: band-pass, local maxima, centroid refinement), frames in
    /// parallel; writes trackpy's columns (y, x, mass, size, ecc, signal, raw_mass,
    /// ep, frame) in pixels.
    Locate(camera::LocateArgs),
    /// Link located grains (trackpy's feature columns, px) into trajectories the
    /// trackpy way (search range in px, memory in frames, prediction from each grain's
    /// last displacement); writes the features with a particle column.
    Link(camera::LinkArgs),
    /// Locate and link in one command: camera frames → trackpy's linked table
    /// (`pillar-pipe ingest` reads it). trackpy's locate and link options, px and
    /// frames.
    Track(camera::TrackArgs),
    /// Camera emulator: render tracks into grey-scale frames (PNG/TIFF) with ground truth.
    Render(render::RenderArgs),
    Run(runs::RunArgs),
    /// One task of a Slurm job array submitted by `run`/`sweep --executor slurm`.
    #[command(hide = true)]
    SlurmJob {
        spec: PathBuf,
    },
    /// Tracked pipeline runs: list, show, compare.
    Runs {
        #[command(subcommand)]
        what: runs::RunsCmd,
        #[arg(long, global = true, default_value = "runs")]
        runs_dir: PathBuf,
    },
    /// Benchmarks of the hot paths against a reference measured in the same run.
    Bench {
        #[command(subcommand)]
        what: bench::BenchCmd,
    },
    Export(export::ExportArgs),
    Gofr(structure::GofrArgs),
    Outline(structure::OutlineArgs),
    ShearLines(structure::ShearLinesArgs),
    ShearLineTracks(structure::ShearLineTracksArgs),
    Front(structure::FrontArgs),
    Sizes(structure::SizesArgs),
    BarPressure(structure::BarPressureArgs),
    EdgeStress(structure::EdgeStressArgs),
    Synth(export::SynthArgs),
}

/// Runs one parsed command.
pub fn dispatch(cmd: Cmd) -> Result<()> {
    pillar_pipe::dem::backend::simd::cap_from_env().map_err(anyhow::Error::msg)?;
    match cmd {
        Cmd::Ingest(a) => analysis::ingest(a),
        Cmd::IngestForce(a) => force::ingest_force(a),
        Cmd::Kinematics(a) => analysis::kinematics(a),
        Cmd::Fit(a) => analysis::fit(a),
        Cmd::Compare(a) => analysis::compare(a),
        Cmd::Quickstart(a) => analysis::quickstart(a),
        Cmd::Simulate { what } => sim::simulate(what),
        Cmd::Sweep(a) => sim::sweep(a),
        Cmd::Pack(a) => sim::pack(a),
        Cmd::Locate(a) => camera::locate(a),
        Cmd::Link(a) => camera::link(a),
        Cmd::Track(a) => camera::track(a),
        Cmd::Render(a) => render::run(a),
        Cmd::Run(a) => runs::run(a),
        Cmd::SlurmJob { spec } => {
            std::process::exit(pillar_pipe::pipeline::slurm::job::main(&spec));
        }
        Cmd::Runs { what, runs_dir } => runs::runs(what, &runs_dir),
        Cmd::Bench { what } => bench::bench(what),
        Cmd::Export(a) => export::export(a),
        Cmd::Gofr(a) => structure::gofr(a),
        Cmd::Outline(a) => structure::outline(a),
        Cmd::ShearLines(a) => structure::shear_lines(a),
        Cmd::ShearLineTracks(a) => structure::shear_line_tracks(a),
        Cmd::Front(a) => structure::front(a),
        Cmd::Sizes(a) => structure::sizes(a),
        Cmd::BarPressure(a) => structure::bar_pressure(a),
        Cmd::EdgeStress(a) => structure::edge_stress(a),
        Cmd::Synth(a) => export::synth(a),
    }
}

pub use pillar_pipe::pipeline::params::parse_pair;

/// Where a command and a pipeline stage kind do the same work, their options are one
/// set: the same names (a flag `--rc-over-d` is the key `rc_over_d`) and the same
/// defaults. `fit` shares one struct; the others keep two and this test holds them
/// together, listing each difference with the reason it exists.
#[cfg(test)]
mod option_drift {
    use super::Cli;
    use clap::CommandFactory;
    use pillar_pipe::pipeline::Kind;
    use pillar_pipe::pipeline::params::rust_defaults;
    use serde_json::Value as Json;
    use std::collections::BTreeMap;

    struct Pair {
        command: &'static [&'static str],
        kind: Kind,
        /// Flags with no pipeline key: where the output goes, how it prints, how the
        /// run proceeds (a stage's output path and printing belong to the runner).
        cli_only: &'static [&'static str],
        /// Keys with no flag: the input stage (a path on the command line) and the like.
        pipeline_only: &'static [&'static str],
        /// The same option under another name: (flag, key).
        renamed: &'static [(&'static str, &'static str)],
        /// Defaults that differ on purpose: (key, why).
        default_differs: &'static [(&'static str, &'static str)],
    }

    fn pairs() -> Vec<Pair> {
        // Say how a command prints and runs; a stage's output path and printing belong
        // to the runner.
        const RUN: [&str; 6] = ["output", "quiet", "json", "timings", "overwrite", "resume"];
        let run_and = |more: &'static [&'static str]| -> &'static [&'static str] {
            Box::leak(
                RUN.iter()
                    .chain(more)
                    .copied()
                    .collect::<Vec<_>>()
                    .into_boxed_slice(),
            )
        };
        vec![
            Pair {
                command: &["fit"],
                kind: Kind::Fit,
                // `input` is a path here, a stage there; the scatter table is a stage's
                // fixed output.
                cli_only: run_and(&["input", "scatter"]),
                pipeline_only: &["input"],
                renamed: &[],
                default_differs: &[],
            },
            Pair {
                command: &["ingest"],
                kind: Kind::Ingest,
                // --fps is --frame-time's reciprocal, a typing aid.
                cli_only: run_and(&["fps"]),
                // The force sensor is its own command, `ingest-force`.
                pipeline_only: &["force"],
                renamed: &[],
                default_differs: &[],
            },
            Pair {
                command: &["kinematics"],
                kind: Kind::Kinematics,
                // --lag N is --lags N; a stage's later stages read every column.
                cli_only: run_and(&["lag", "columns"]),
                pipeline_only: &[],
                renamed: &[("tracks", "input")],
                // The command asks for the lag; a stage takes one frame.
                default_differs: &[("lags", "--lag is required on the command line")],
            },
            Pair {
                command: &["simulate", "pillar"],
                kind: Kind::Simulate,
                // Threads and a halt for tests say how it runs; --param is --set's
                // other spelling.
                cli_only: run_and(&["threads", "halt_after"]),
                // A stage is a pipeline's; the command line gives its file as --packing.
                pipeline_only: &["packing_stage"],
                renamed: &[("param", "set")],
                default_differs: &[],
            },
            Pair {
                command: &["simulate", "shear"],
                kind: Kind::Shear,
                // A ramp is a stage kind of its own; --from starts from a ramp's state.
                // Threads say how it runs (a pipeline's run side by side, one core each).
                cli_only: run_and(&[
                    "threads",
                    "halt_after",
                    "from",
                    "ramp",
                    "kappa",
                    "rate_end",
                    "window",
                ]),
                pipeline_only: &[],
                renamed: &[],
                default_differs: &[],
            },
            Pair {
                command: &["sweep"],
                kind: Kind::Sweep,
                // Where the work runs: a pipeline's [executor] table and `run`'s flags.
                cli_only: run_and(&[
                    "jobs",
                    "executor",
                    "partition",
                    "account",
                    "time",
                    "mem",
                    "cpus_per_task",
                    "sbatch_arg",
                    "retry",
                    "detach",
                ]),
                pipeline_only: &[],
                renamed: &[],
                default_differs: &[],
            },
            Pair {
                command: &["render"],
                kind: Kind::Render,
                cli_only: run_and(&[]),
                pipeline_only: &[],
                renamed: &[("tracks", "input")],
                default_differs: &[(
                    "px_per_unit",
                    "required on both sides: a flag without a default, a key whose 0 is refused at load",
                )],
            },
            Pair {
                command: &["track"],
                kind: Kind::Track,
                cli_only: run_and(&[]),
                // The stage also converts to canonical tracks as `ingest` does; the
                // command writes trackpy's pixel table, which `ingest` then converts.
                pipeline_only: &[
                    "input",
                    "px_per_unit",
                    "origin_px",
                    "unit",
                    "frame_time",
                    "radii",
                    "bar_speed",
                ],
                renamed: &[("no_predict", "predict")],
                default_differs: &[
                    (
                        "predict",
                        "--no-predict is predict = false: both default to predicting",
                    ),
                    (
                        "diameter",
                        "required on both sides: a flag without a default, a key whose 0 is refused at load",
                    ),
                    (
                        "search_range",
                        "required on both sides: a flag without a default, a key whose 0 is refused at load",
                    ),
                    (
                        "frames",
                        "positional on the command line, a folder key in a pipeline",
                    ),
                ],
            },
            Pair {
                command: &["pack"],
                kind: Kind::Pack,
                // The serial reference is a benchmark's.
                cli_only: run_and(&["serial"]),
                pipeline_only: &[],
                renamed: &[],
                default_differs: &[],
            },
            Pair {
                command: &["gofr"],
                kind: Kind::Gofr,
                cli_only: run_and(&["input"]),
                pipeline_only: &["input"],
                renamed: &[],
                default_differs: &[],
            },
            Pair {
                command: &["outline"],
                kind: Kind::Outline,
                // `against` is a path here, a stage there.
                cli_only: run_and(&["input"]),
                pipeline_only: &["input"],
                renamed: &[],
                default_differs: &[(
                    "against",
                    "a path on the command line, a stage in a pipeline",
                )],
            },
            Pair {
                command: &["shear-lines"],
                kind: Kind::ShearLines,
                cli_only: run_and(&[]),
                pipeline_only: &[],
                renamed: &[("kinematics", "input")],
                default_differs: &[(
                    "input",
                    "positional: a path on the command line, a stage in a pipeline",
                )],
            },
            Pair {
                command: &["shear-line-tracks"],
                kind: Kind::ShearLineTracks,
                cli_only: run_and(&[]),
                pipeline_only: &[],
                renamed: &[("kinematics", "input")],
                default_differs: &[(
                    "input",
                    "positional: a path on the command line, a stage in a pipeline",
                )],
            },
            Pair {
                command: &["bar-pressure"],
                kind: Kind::BarPressure,
                cli_only: run_and(&[]),
                pipeline_only: &[],
                renamed: &[("run", "input")],
                default_differs: &[(
                    "input",
                    "positional: a run folder on the command line, a stage in a pipeline",
                )],
            },
            Pair {
                command: &["edge-stress"],
                kind: Kind::EdgeStress,
                cli_only: run_and(&[]),
                pipeline_only: &[],
                renamed: &[("run", "input")],
                default_differs: &[(
                    "input",
                    "positional: a run folder on the command line, a stage in a pipeline",
                )],
            },
            Pair {
                command: &["compare"],
                kind: Kind::Compare,
                cli_only: run_and(&[]),
                pipeline_only: &[],
                renamed: &[],
                default_differs: &[
                    (
                        "a",
                        "positional: a path on the command line, a stage in a pipeline",
                    ),
                    (
                        "b",
                        "positional: a path on the command line, a stage in a pipeline",
                    ),
                ],
            },
        ]
    }

    /// Each flag's key (`--rc-over-d` → `rc_over_d`, a positional by its id) and its
    /// default as clap states it.
    fn flags(path: &[&str]) -> BTreeMap<String, Option<String>> {
        let mut cmd = Cli::command();
        cmd.build();
        let mut c = &cmd;
        for p in path {
            c = c
                .get_subcommands()
                .find(|s| s.get_name() == *p)
                .unwrap_or_else(|| panic!("no command {p}"));
        }
        c.get_arguments()
            .filter(|a| a.get_id() != "help" && a.get_id() != "version")
            .map(|a| {
                let key = a
                    .get_long()
                    .map(|l| l.replace('-', "_"))
                    .unwrap_or_else(|| a.get_id().to_string());
                let def = a
                    .get_default_values()
                    .first()
                    .map(|v| v.to_string_lossy().into_owned());
                (key, def)
            })
            .collect()
    }

    /// A pipeline default as the command line would type it.
    fn typed(v: &Json) -> Option<String> {
        match v {
            Json::Null => None,
            // A required key's placeholder (an input stage's name).
            Json::String(s) if s.is_empty() => None,
            Json::String(s) => Some(s.clone()),
            Json::Array(a) if a.is_empty() => None,
            Json::Object(o) if o.is_empty() => None,
            Json::Array(a) => Some(
                a.iter()
                    .map(|x| typed(x).unwrap_or_default())
                    .collect::<Vec<_>>()
                    .join(","),
            ),
            other => Some(other.to_string()),
        }
    }

    fn same_default(cli: &str, pipeline: &str) -> bool {
        match (cli.parse::<f64>(), pipeline.parse::<f64>()) {
            (Ok(a), Ok(b)) => a == b,
            _ => cli == pipeline,
        }
    }

    #[test]
    fn every_command_with_a_stage_kind_shares_its_option_names_and_defaults() {
        let mut problems = Vec::new();
        for p in pairs() {
            let name = p.command.join(" ");
            let cli = flags(p.command);
            let Json::Object(keys) = rust_defaults(p.kind) else {
                panic!("{name}: defaults are not a table")
            };
            let to_key = |f: &str| {
                p.renamed
                    .iter()
                    .find(|(a, _)| *a == f)
                    .map_or(f.to_string(), |(_, k)| k.to_string())
            };
            for (flag, def) in &cli {
                if p.cli_only.contains(&flag.as_str()) {
                    continue;
                }
                let key = to_key(flag);
                let Some(v) = keys.get(&key) else {
                    problems.push(format!("{name}: --{flag} has no pipeline key {key}"));
                    continue;
                };
                if p.default_differs.iter().any(|(k, _)| *k == key) {
                    continue;
                }
                match (def.as_deref(), typed(v)) {
                    (None, None) => {}
                    (Some(a), Some(b)) if same_default(a, &b) => {}
                    (a, b) => problems.push(format!(
                        "{name}: --{flag} defaults to {a:?} on the command line, {key} to {b:?} in a pipeline"
                    )),
                }
            }
            let flag_keys: Vec<String> = cli.keys().map(|f| to_key(f)).collect();
            for key in keys.keys() {
                if !p.pipeline_only.contains(&key.as_str()) && !flag_keys.contains(key) {
                    problems.push(format!("{name}: pipeline key {key} has no flag"));
                }
            }
        }
        assert!(problems.is_empty(), "{}", problems.join("\n"));
    }
}
