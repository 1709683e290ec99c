//! CLI wiring for the simulators: `simulate pillar|shear` and `pack`.

use anyhow::{Context, Result, bail};
use clap::parser::ValueSource;
use clap::{ArgMatches, Args, FromArgMatches, Subcommand};
use pillar_pipe::stages::simulate::{SimulateOptions, run};
use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;

#[derive(Subcommand)]
pub enum SimulateCmd {
    /// Granular pillar compressed by a bar (li-granular-pillars Sec. II).
    Pillar(Given<PillarArgs>),
    /// Frictionless disks sheared with Lees–Edwards boundaries (vagberg-sheared-disks).
    Shear(Given<ShearArgs>),
}

/// Parsed arguments and the ids of those the user typed: `--resume DIR` takes every
/// option not typed from the interrupted run rather than from clap's defaults, which
/// the parsed struct alone cannot tell apart from typed values.
pub struct Given<A> {
    args: A,
    given: BTreeSet<String>,
}

impl<A: FromArgMatches + Args> FromArgMatches for Given<A> {
    fn from_arg_matches(m: &ArgMatches) -> clap::error::Result<Self> {
        // The derive's groups (the struct's own, and a flattened struct's) are "typed"
        // whenever one of their args is; only args count.
        let groups: Vec<clap::Id> = A::augment_args(clap::Command::new("args"))
            .get_groups()
            .map(|g| g.get_id().clone())
            .collect();
        let given = m
            .ids()
            .filter(|id| !groups.contains(id))
            .filter(|id| {
                matches!(
                    m.value_source(id.as_str()),
                    Some(ValueSource::CommandLine | ValueSource::EnvVariable)
                )
            })
            .map(|id| id.as_str().to_string())
            .collect();
        Ok(Given {
            args: A::from_arg_matches(m)?,
            given,
        })
    }
    fn update_from_arg_matches(&mut self, m: &ArgMatches) -> clap::error::Result<()> {
        *self = Self::from_arg_matches(m)?;
        Ok(())
    }
}

impl<A: Args> Args for Given<A> {
    fn augment_args(cmd: clap::Command) -> clap::Command {
        A::augment_args(cmd)
    }
    fn augment_args_for_update(cmd: clap::Command) -> clap::Command {
        A::augment_args_for_update(cmd)
    }
    fn group_id() -> Option<clap::Id> {
        A::group_id()
    }
}

/// For `--resume DIR`: the options with those not typed taken from the interrupted run,
/// one line saying which were, and a refusal that says how to start anew instead.
fn resume_with<O>(
    what: &str,
    dir: &std::path::Path,
    opt: O,
    given: &BTreeSet<String>,
    adopt: impl FnOnce(
        &std::path::Path,
        &O,
        &BTreeSet<String>,
    ) -> pillar_pipe::error::Result<(O, Vec<(String, serde_json::Value)>)>,
) -> Result<O> {
    let (opt, taken) = adopt(dir, &opt, given)
        .with_context(|| format!("simulate {what}: resume {}", dir.display()))?;
    let list: Vec<String> = taken.iter().map(|(k, v)| format!("{k} = {v}")).collect();
    if list.is_empty() {
        eprintln!(
            "resume      no option taken from the run: it ran with the defaults and those given"
        );
    } else {
        eprintln!(
            "resume      options taken from the run: {}",
            list.join(", ")
        );
    }
    Ok(opt)
}

/// A refused resume (options typed that differ from the run's) with how to start anew.
fn resume_refusal(what: &str, e: pillar_pipe::error::Error) -> anyhow::Error {
    match e {
        pillar_pipe::error::Error::Param { ref name, .. } if name == "resume" => anyhow::anyhow!(
            "{e}\n  leave these options out to continue the run as it was, or start a new run with them: pillar-pipe simulate {what} … -o NEW_DIR"
        ),
        e => e.into(),
    }
}

/// How a simulation runs rather than what it computes, the same for the pillar and the
/// sheared disks: where it writes, its checkpoints, resuming.
#[derive(Args)]
pub struct RunControl {
    /// Steps between checkpoints (0: none).
    #[arg(long, default_value_t = 0)]
    checkpoint_every: u64,
    /// Seconds of wall time between checkpoints (0: none): a kill loses at most this
    /// much work. SIGINT and SIGTERM always save a checkpoint before stopping.
    #[arg(long, default_value_t = 60.0, value_name = "SECONDS")]
    checkpoint_interval: f64,
    /// Continue the unfinished run in DIR from its last checkpoint.
    #[arg(long, value_name = "DIR", conflicts_with = "output")]
    resume: Option<PathBuf>,
    /// Output directory.
    #[arg(short, long)]
    output: Option<PathBuf>,
    #[arg(long)]
    quiet: bool,
    /// Testing: fail right after the first checkpoint at or past this step.
    #[arg(long, hide = true)]
    halt_after: Option<u64>,
}

impl RunControl {
    /// The run's directory and whether it is resumed: exactly one of -o and --resume.
    fn dir(&self) -> Result<(PathBuf, bool)> {
        match (&self.output, &self.resume) {
            (Some(o), None) => Ok((o.clone(), false)),
            (None, Some(r)) => Ok((r.clone(), true)),
            _ => bail!("give the output directory: -o DIR (new run) or --resume DIR"),
        }
    }
}

#[derive(Args)]
pub struct PillarArgs {
    /// Grains in a generated packing.
    #[arg(long, default_value_t = 1000, conflicts_with = "packing")]
    n: usize,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Start from this packing (canonical tracks in cm/mm/m; first frame), e.g. from
    /// `pillar-pipe pack` or an experiment's ingested tracks.
    #[arg(long)]
    packing: Option<PathBuf>,
    /// paper: Sec. II.C values; fast: k_n = 1 N/mm, δt = 4e-5 s, bar 10× faster.
    #[arg(long, default_value = "fast")]
    preset: String,
    /// Override a model parameter (SI units), e.g. --param k_n=5000 --param mu_g=0.3.
    #[arg(long = "param", value_parser = parse_kv)]
    params: Vec<(String, f64)>,
    /// Grain–grain normal law: linear (F = k_n δ, the paper's Eq. 4) or hertz
    /// (F = k δ^{3/2}; k = --param k_hertz=…, by default matched to the linear law at the
    /// force unit m g μ). Bars use the same law with twice the stiffness.
    #[arg(long, default_value = "linear", value_name = "LAW")]
    normal_law: pillar_pipe::dem::pillar::params::NormalLawName,
    /// Final strain ε = ΔH/H0.
    #[arg(long, default_value_t = 0.3)]
    strain: f64,
    /// Steps between output frames (default R/(15 v_c) of simulated time).
    #[arg(long)]
    output_every: Option<u64>,
    /// Output frames between per-grain force snapshots.
    #[arg(long, default_value_t = 5)]
    forces_every: u64,
    #[command(flatten)]
    run: RunControl,
    /// Print the report as JSON.
    #[arg(long)]
    json: bool,
    /// Threads (default: one per core, at most one per 256 grains; any count gives the
    /// same numbers).
    #[arg(long, default_value_t = 0)]
    threads: usize,
}

fn parse_kv(s: &str) -> std::result::Result<(String, f64), String> {
    let (k, v) = s
        .split_once('=')
        .ok_or_else(|| format!("expected NAME=VALUE, got '{s}'"))?;
    let v: f64 = v.trim().parse().map_err(|e| format!("'{v}': {e}"))?;
    Ok((k.trim().to_string(), v))
}

/// The options a `simulate pillar` command line means (the same struct a pipeline's
/// `simulate` stage deserialises; `tests` below checks the defaults agree).
fn pillar_options(a: PillarArgs) -> Result<(PathBuf, SimulateOptions)> {
    let (out, resume) = a.run.dir()?;
    let opt = SimulateOptions {
        n: a.n,
        seed: a.seed,
        packing: a.packing,
        packing_stage: None,
        preset: a.preset,
        set: a.params.into_iter().collect::<BTreeMap<_, _>>(),
        normal_law: a.normal_law,
        strain: a.strain,
        output_every: a.output_every,
        forces_every: a.forces_every,
        checkpoint_every: a.run.checkpoint_every,
        checkpoint_interval: a.run.checkpoint_interval,
        resume,
        quiet: a.run.quiet,
        halt_after: a.run.halt_after,
        threads: a.threads,
    };
    Ok((out, opt))
}

#[derive(Args)]
pub struct ShearArgs {
    #[arg(long, default_value_t = 1024)]
    n: usize,
    /// Packing fraction φ (Eq. 11).
    #[arg(long, default_value_t = 0.82)]
    phi: f64,
    /// Quality factor Q = τ_d/τ_e (k_d = 1/Q).
    #[arg(long, default_value_t = 1.0)]
    q: f64,
    /// Strain rate γ̇ τ_e.
    #[arg(long, default_value_t = 1e-4)]
    rate: f64,
    #[arg(long, value_enum, default_value = "cdrot")]
    model: pillar_pipe::dem::shear::Dissipation,
    /// Total strain γ.
    #[arg(long, default_value_t = 10.0)]
    strain: f64,
    /// Δt/τ_e (default 0.05; 0.01 for Q < 0.5).
    #[arg(long)]
    dt: Option<f64>,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Steps between trajectory frames (default every 0.05 strain).
    #[arg(long)]
    output_every: Option<u64>,
    /// Steps between samples of the series.
    #[arg(long, default_value_t = pillar_pipe::stages::shear::SAMPLE_EVERY)]
    sample_every: u64,
    /// Fraction of the run discarded before averaging.
    #[arg(long, default_value_t = 0.25)]
    transient: f64,
    /// Blocks the averaged part is cut into for the error bars (≥ 2).
    #[arg(long, default_value_t = 10)]
    blocks: usize,
    /// Strain-rate ramp up|down (Eqs. 38–41): γ̇ × 10^{±κ̃} every τ_e, from --rate to
    /// --rate-end; writes ramp.parquet (means over --window τ_e).
    #[arg(long)]
    ramp: Option<String>,
    /// κ̃ = κ τ_e / ln 10 (Eq. 39).
    #[arg(long, default_value_t = 1e-5)]
    kappa: f64,
    #[arg(long)]
    rate_end: Option<f64>,
    /// Ramp averaging window (τ_e).
    #[arg(long, default_value_t = 1000.0)]
    window: f64,
    /// Start the ramp where the ramp in DIR ended (its state.bin: same N, φ, Q, model,
    /// Δt; velocities rescaled to --rate), as the paper's cycles do; else random positions.
    #[arg(long, value_name = "DIR", requires = "ramp")]
    from: Option<PathBuf>,
    #[command(flatten)]
    run: RunControl,
    /// Threads (default: one per core, at most one per 4096 disks; any count gives the
    /// same numbers).
    #[arg(long, default_value_t = 0)]
    threads: usize,
}

#[derive(Args)]
pub struct PackArgs {
    #[command(flatten)]
    params: pillar_pipe::pipeline::kinds::pack::PackParams,
    #[arg(short, long)]
    output: PathBuf,
    /// One serial force sum, grains in the order drawn; with `--f-tol 0`, the packer
    /// before 2026-11-27 bit for bit (the reference of `bench pack`). Below 2049 grains
    /// it changes nothing.
    #[arg(long)]
    serial: bool,
    #[arg(long)]
    quiet: bool,
}

pub fn simulate(cmd: SimulateCmd) -> Result<()> {
    let Given { args: a, given } = match cmd {
        SimulateCmd::Pillar(a) => a,
        SimulateCmd::Shear(s) => return shear(s),
    };
    let json = a.json;
    let (out, mut opt) = pillar_options(a)?;
    if opt.resume {
        let given = given
            .into_iter()
            .map(|id| if id == "params" { "set".into() } else { id })
            .collect();
        opt = resume_with(
            "pillar",
            &out,
            opt,
            &given,
            pillar_pipe::stages::simulate::options_for_resume,
        )?;
    }
    let rep = run(&out, &opt)
        .map_err(|e| resume_refusal("pillar", e))
        .with_context(|| format!("simulate pillar into {}", out.display()))?;
    if json {
        println!("{}", serde_json::to_string_pretty(&rep)?);
        return Ok(());
    }
    println!(
        "pillar      {} grains, {} steps, {} frames, {:.1} s ({:.1} ns per particle-step)",
        rep.n,
        rep.steps,
        rep.frames,
        rep.elapsed_s,
        1e9 * rep.elapsed_s / (rep.n as f64 * rep.steps.max(1) as f64)
    );
    match rep.mean_flow_stress {
        Some(s) => println!("flow stress ⟨σ⟩(0.05 ≤ ε ≤ 0.2) = {s:.4} N/m"),
        None => println!("flow stress not reported (the run stopped before ε = 0.2)"),
    }
    for (name, p) in &rep.tables {
        println!("wrote       {name:14} {}", p.display());
    }
    println!(
        "wrote       manifest       {}",
        out.join("manifest.json").display()
    );
    Ok(())
}

pub fn pack(a: PackArgs) -> Result<()> {
    let p = &a.params;
    let rep = pillar_pipe::stages::pack::run(&a.output, p, a.serial, a.quiet)
        .with_context(|| format!("pack into {}", a.output.display()))?;
    println!("{rep}");
    Ok(())
}

fn shear(a: Given<ShearArgs>) -> Result<()> {
    use pillar_pipe::stages::shear::run;
    let Given { args: a, given } = a;
    let (out, mut opt) = shear_options(a)?;
    if opt.resume {
        opt = resume_with(
            "shear",
            &out,
            opt,
            &given,
            pillar_pipe::stages::shear::options_for_resume,
        )?;
    }
    let rep = run(&out, &opt)
        .map_err(|e| resume_refusal("shear", e))
        .with_context(|| format!("simulate shear into {}", out.display()))?;
    println!(
        "shear       {} disks, φ = {}, Q = {}, γ̇ = {:e}, {:?}: {} steps, {} frames, {:.1} s",
        opt.n, opt.phi, opt.q, opt.rate, opt.model, rep.steps, rep.frames, rep.elapsed_s
    );
    for (k, v) in &rep.summary {
        println!("  {k:30} {:>12.5e} ± {:.2e}", v.mean, v.err);
    }
    let tables = if opt.ramp.is_some() {
        "{ramp, series, tracks}.parquet, state.bin"
    } else {
        "{series, tracks, profile, fields, collision_angles, contact_velocities}.parquet"
    };
    println!(
        "wrote       {}/{tables}, summary.json, manifest.json",
        out.display()
    );
    Ok(())
}

/// The options a `simulate shear` command line means (checked against
/// `ShearOptions::default` in `tests` below).
fn shear_options(a: ShearArgs) -> Result<(PathBuf, pillar_pipe::stages::shear::ShearOptions)> {
    use pillar_pipe::stages::shear::ShearOptions;
    let (out, resume) = a.run.dir()?;
    let opt = ShearOptions {
        n: a.n,
        phi: a.phi,
        q: a.q,
        rate: a.rate,
        model: a.model,
        strain: a.strain,
        dt: a.dt,
        seed: a.seed,
        output_every: a.output_every,
        sample_every: a.sample_every,
        transient: a.transient,
        blocks: a.blocks,
        ramp: a.ramp,
        kappa: a.kappa,
        rate_end: a.rate_end,
        window: a.window,
        checkpoint_every: a.run.checkpoint_every,
        checkpoint_interval: a.run.checkpoint_interval,
        resume,
        quiet: a.run.quiet,
        halt_after: a.run.halt_after,
        from_state: a.from.map(|d| d.join(pillar_pipe::stages::shear::STATE)),
        threads: a.threads,
    };
    Ok((out, opt))
}

#[derive(Args)]
pub struct SweepArgs {
    #[arg(long, value_delimiter = ',', required = true)]
    phi: Vec<f64>,
    #[arg(long, value_delimiter = ',', required = true)]
    q: Vec<f64>,
    #[arg(long, value_delimiter = ',', required = true)]
    rate: Vec<f64>,
    #[arg(long, default_value_t = 1024)]
    n: usize,
    #[arg(long, value_enum, default_value = "cdrot")]
    model: pillar_pipe::dem::shear::Dissipation,
    #[arg(long, default_value_t = 10.0)]
    strain: f64,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Δt/τ_e (default 0.05; 0.01 for Q < 0.5).
    #[arg(long)]
    dt: Option<f64>,
    /// Steps between trajectory frames (default every 0.05 strain).
    #[arg(long)]
    output_every: Option<u64>,
    /// Steps between samples of the series.
    #[arg(long, default_value_t = pillar_pipe::stages::shear::SAMPLE_EVERY)]
    sample_every: u64,
    /// Fraction of each run discarded before averaging.
    #[arg(long, default_value_t = 0.25)]
    transient: f64,
    /// Blocks each run's averaged part is cut into for the error bars (≥ 2).
    #[arg(long, default_value_t = 10)]
    blocks: usize,
    /// Checkpoint each run every this many steps (0: none); a rerun resumes them.
    #[arg(long, default_value_t = 0)]
    checkpoint_every: u64,
    /// Seconds of wall time between each run's checkpoints (0: none). SIGINT and
    /// SIGTERM always make the runs under way save one before the sweep stops.
    #[arg(long, default_value_t = 60.0, value_name = "SECONDS")]
    checkpoint_interval: f64,
    /// Runs at a time (each is single-threaded; default: the cores).
    #[arg(long)]
    jobs: Option<usize>,
    #[arg(short, long)]
    output: PathBuf,
    #[arg(long)]
    quiet: bool,
    #[command(flatten)]
    exec: crate::cli::runs::ExecutorArgs,
}

pub fn sweep(a: SweepArgs) -> Result<()> {
    use pillar_pipe::stages::shear::ShearOptions;
    use pillar_pipe::stages::sweep::{SweepOptions, run_sweep};
    let jobs = a
        .jobs
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let base = ShearOptions {
        n: a.n,
        model: a.model,
        strain: a.strain,
        seed: a.seed,
        dt: a.dt,
        output_every: a.output_every,
        sample_every: a.sample_every,
        transient: a.transient,
        blocks: a.blocks,
        checkpoint_every: a.checkpoint_every,
        checkpoint_interval: a.checkpoint_interval,
        quiet: true,
        ..Default::default()
    };
    let opt = SweepOptions {
        phi: a.phi,
        q: a.q,
        rate: a.rate,
        base,
        jobs,
        quiet: a.quiet,
    };
    match a.exec.executor.as_deref() {
        Some("slurm") => {
            if a.exec.detach {
                bail!("sweep --executor slurm waits for its jobs (--detach is for `run`)");
            }
            let mut say = |line: &str| {
                if !a.quiet {
                    println!("{line}");
                }
            };
            let r = pillar_pipe::pipeline::slurm::sweep::run_sweep(
                &a.output,
                &opt,
                &a.exec.slurm(),
                &mut say,
            )
            .with_context(|| format!("sweep into {}", a.output.display()))?;
            println!(
                "sweep       {} runs ({} submitted to Slurm, {} attached, {} already finished)\nwrote       {}",
                r.report.runs,
                r.submitted,
                r.attached,
                r.report.runs - r.submitted - r.attached,
                r.report.table.display()
            );
            return Ok(());
        }
        _ if a.exec.slurm() != Default::default() => {
            bail!("--partition, --time, ... apply to --executor slurm")
        }
        _ => {}
    }
    let rep =
        run_sweep(&a.output, &opt).with_context(|| format!("sweep into {}", a.output.display()))?;
    println!(
        "sweep       {} runs ({} already finished, read back), {} at a time\nwrote       {}",
        rep.runs,
        rep.reused,
        jobs,
        rep.table.display()
    );
    Ok(())
}

/// A stage's options are defined once, as a struct with its defaults
/// (`SimulateOptions`, `ShearOptions`), which pipeline files deserialise; the command
/// line states its defaults again for `--help`. These tests fail when the two drift.
#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cmd {
        #[command(subcommand)]
        cmd: SimulateCmd,
    }

    /// The options as JSON, without what says how a run proceeds rather than what it
    /// computes (and which a command line sets by its form, `-o` or `--resume`).
    fn physics(v: impl serde::Serialize, run_only: &[&str]) -> serde_json::Value {
        let mut v = serde_json::to_value(v).unwrap();
        for k in run_only {
            v.as_object_mut().unwrap().remove(*k);
        }
        v
    }

    #[test]
    fn simulate_pillar_command_line_defaults_are_the_options_defaults() {
        let Cmd { cmd } = Cmd::parse_from(["t", "pillar", "-o", "x"]);
        let SimulateCmd::Pillar(a) = cmd else {
            panic!("pillar")
        };
        let (_, opt) = pillar_options(a.args).unwrap();
        let skip = ["resume", "quiet", "threads", "halt_after"];
        assert_eq!(
            physics(&opt, &skip),
            physics(SimulateOptions::default(), &skip),
            "simulate pillar: the command line's defaults differ from SimulateOptions::default()"
        );
    }

    #[test]
    fn simulate_shear_command_line_defaults_are_the_options_defaults() {
        use pillar_pipe::stages::shear::ShearOptions;
        let Cmd { cmd } = Cmd::parse_from(["t", "shear", "-o", "x"]);
        let SimulateCmd::Shear(a) = cmd else {
            panic!("shear")
        };
        let (_, opt) = shear_options(a.args).unwrap();
        let skip = ["resume", "quiet", "threads", "halt_after"];
        assert_eq!(
            physics(&opt, &skip),
            physics(ShearOptions::default(), &skip),
            "simulate shear: the command line's defaults differ from ShearOptions::default()"
        );
    }

    /// Only what was typed counts as given: defaults, including those of flags, are
    /// left to the interrupted run.
    #[test]
    fn given_holds_the_typed_options_only() {
        let Cmd { cmd } = Cmd::parse_from([
            "t", "pillar", "--strain", "0.5", "--param", "k_n=3", "--quiet", "--resume", "d",
        ]);
        let SimulateCmd::Pillar(a) = cmd else {
            panic!("pillar")
        };
        let want: BTreeSet<String> = ["strain", "params", "quiet", "resume"]
            .into_iter()
            .map(String::from)
            .collect();
        assert_eq!(a.given, want);
        let Cmd { cmd } = Cmd::parse_from(["t", "shear", "--resume", "d"]);
        let SimulateCmd::Shear(a) = cmd else {
            panic!("shear")
        };
        assert_eq!(a.given, BTreeSet::from(["resume".to_string()]));
    }
}
