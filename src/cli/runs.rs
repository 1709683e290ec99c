//! `pillar-pipe run` and `pillar-pipe runs`: argument types and printing only; the
//! work is in `pillar_pipe::pipeline`.

use anyhow::Result;
use clap::{Args, Subcommand};
use pillar_pipe::pipeline::slurm::SlurmOptions;
use std::path::PathBuf;

/// Where the work runs: `--executor slurm` and Slurm's options (shared by `run` and
/// `sweep`; a pipeline file's `[executor]` table gives defaults for `run`).
#[derive(Args, Debug, Clone, Default)]
pub struct ExecutorArgs {
    /// `local` (default) or `slurm`: each stage (each sweep point) not yet computed
    /// becomes a Slurm job; see README "Running on a cluster".
    #[arg(long, value_parser = ["local", "slurm"])]
    pub executor: Option<String>,
    /// sbatch --partition.
    #[arg(long)]
    pub partition: Option<String>,
    /// sbatch --account.
    #[arg(long)]
    pub account: Option<String>,
    /// sbatch --time: each job's time limit, e.g. 02:00:00.
    #[arg(long)]
    pub time: Option<String>,
    /// sbatch --mem, e.g. 4G.
    #[arg(long)]
    pub mem: Option<String>,
    /// sbatch --cpus-per-task.
    #[arg(long)]
    pub cpus_per_task: Option<u32>,
    /// A further sbatch argument, passed as it is (repeat for several): --sbatch-arg=--qos=short.
    #[arg(long = "sbatch-arg", value_name = "ARG", allow_hyphen_values = true)]
    pub sbatch_args: Vec<String>,
    /// Submit a failed job's stage again, up to N times.
    #[arg(long, value_name = "N")]
    pub retry: Option<u32>,
    /// Submit the jobs and return; `runs show ID` tells their state, and the same
    /// command attaches to them again.
    #[arg(long)]
    pub detach: bool,
}

impl ExecutorArgs {
    pub fn slurm(&self) -> SlurmOptions {
        SlurmOptions {
            partition: self.partition.clone(),
            account: self.account.clone(),
            time: self.time.clone(),
            mem: self.mem.clone(),
            cpus_per_task: self.cpus_per_task,
            sbatch_args: self.sbatch_args.clone(),
            retry: self.retry,
            detach: self.detach,
        }
    }
}

/// Run a pipeline file (pipelines/*.toml): cached stages, recorded under RUNS_DIR/<id>/.
#[derive(Args)]
pub struct RunArgs {
    pub pipeline: PathBuf,
    /// Override a key, STAGE.KEY=VALUE; STAGE is a stage name or a kind (all stages of it).
    #[arg(long = "set", value_name = "STAGE.KEY=VALUE")]
    pub set: Vec<String>,
    /// Recompute this stage (name, kind or `all`) and everything downstream of it.
    #[arg(long, value_name = "STAGE")]
    pub force: Vec<String>,
    #[arg(long)]
    pub quiet: bool,
    #[arg(long, default_value = "runs")]
    pub runs_dir: PathBuf,
    /// Validate the pipeline and show which stages are cached; run nothing.
    #[arg(long)]
    pub dry_run: bool,
    /// Check cached outputs' SHA-256 before using them (by default only their sizes).
    #[arg(long)]
    pub verify: bool,
    /// Stages computed at once by the local executor (independent stages, e.g. a
    /// sweep's grid points); default: the machine's cores. 1 runs them one by one.
    #[arg(long, short = 'j', value_parser = clap::value_parser!(u64).range(1..))]
    pub jobs: Option<u64>,
    #[command(flatten)]
    pub exec: ExecutorArgs,
}

/// `run PIPELINE`: the arguments as the pipeline runner takes them.
pub fn run(a: RunArgs) -> Result<()> {
    run_pipeline(pillar_pipe::pipeline::RunOptions {
        pipeline: a.pipeline,
        sets: a.set,
        force: a.force,
        quiet: a.quiet,
        runs_dir: a.runs_dir,
        dry_run: a.dry_run,
        verify: a.verify,
        slurm: a.exec.slurm(),
        executor: a.exec.executor,
        jobs: a.jobs.map(|j| j as usize),
    })
}

#[derive(Subcommand)]
pub enum RunsCmd {
    /// Every run, oldest first.
    List,
    /// One run (id, unique id prefix, or `latest`).
    Show {
        id: String,
        /// Print the manifest.
        #[arg(long)]
        json: bool,
    },
    /// Metrics and changed parameters of runs side by side.
    Compare {
        #[arg(required = true, num_args = 2..)]
        ids: Vec<String>,
    },
    /// Check cached stage outputs against their recorded sizes and SHA-256: the stages
    /// of one run (default `latest`) or, with --all, every cache entry. A damaged entry
    /// is moved aside (so no run serves it) and the command fails.
    Verify {
        /// Run id, unique id prefix, or `latest`.
        #[arg(conflicts_with = "all")]
        id: Option<String>,
        /// Every entry in RUNS_DIR/cache, not one run's stages.
        #[arg(long)]
        all: bool,
    },
}

/// A path relative to the working directory when it lies below it (shorter to read).
fn shown(p: &std::path::Path) -> String {
    std::env::current_dir()
        .ok()
        .and_then(|c| p.strip_prefix(c).ok().map(|r| r.display().to_string()))
        .unwrap_or_else(|| p.display().to_string())
}

pub fn run_pipeline(opt: pillar_pipe::pipeline::RunOptions) -> Result<()> {
    use pillar_pipe::pipeline::{runner::Status, runs};
    let quiet = opt.quiet;
    let mut print = |e: &pillar_pipe::pipeline::StageEvent| {
        // What concerns the cache's integrity or why the run stalls goes to stderr,
        // also with --quiet.
        let (name, note) = (&e.stage.name, e.note.as_deref().unwrap_or(""));
        match e.status {
            Status::Waiting => {
                return eprintln!("waiting for stage '{name}' (computed by {note})");
            }
            Status::BrokeLock => {
                return eprintln!("broke the stale lock of stage '{name}': {note}");
            }
            Status::Damaged => {
                return eprintln!("warning: cached stage '{name}' is damaged, recomputing: {note}");
            }
            Status::Unverifiable => {
                return eprintln!(
                    "warning: cached stage '{name}' cannot be verified, recomputing: {note}"
                );
            }
            _ if quiet => return,
            _ => {}
        }
        let what = match e.status {
            Status::Running if note.is_empty() => "running".to_string(),
            Status::Running => format!("running    {note}"),
            Status::Queued => format!("queued     {note}"),
            Status::Retrying => format!("retrying   {note}"),
            Status::Computed if !note.is_empty() => format!(
                "computed   {:.2} s, {note} -> {}",
                e.elapsed_s,
                shown(e.dir)
            ),
            Status::Cached => format!("cached     {}", shown(e.dir)),
            Status::Computed => format!("computed   {:.2} s -> {}", e.elapsed_s, shown(e.dir)),
            Status::WouldRun => format!("would run  {}", shown(e.dir)),
            _ => return,
        };
        println!(
            "[{}/{}] {:24} {:10} {what}",
            e.index,
            e.total,
            e.stage.name,
            e.stage.kind.name()
        );
    };
    // Errors name the file (validation) or the stage (a failed stage) themselves.
    let m = pillar_pipe::pipeline::run(&opt, &mut print)?;
    if m.status == "submitted" {
        let jobs = m.stages.iter().filter(|s| s.slurm.is_some()).count();
        println!(
            "run {}: {jobs} stage(s) submitted to Slurm; `pillar-pipe runs show {}` tells their state, \
             and running the pipeline again attaches to them",
            m.run_id, m.run_id
        );
        return Ok(());
    }
    if opt.dry_run {
        println!(
            "pipeline {} is valid ({} stages); nothing run",
            m.pipeline.name,
            m.parameters.len()
        );
        return Ok(());
    }
    let (computed, cached) = pillar_pipe::pipeline::views::cache_counts(&m);
    let dir = opt.runs_dir.join(&m.run_id);
    println!(
        "run {}: {computed} computed, {cached} cached, {:.1} s",
        m.run_id, m.elapsed_s
    );
    if let Some(r) = &m.report {
        println!("report   {}", dir.join(r).display());
    }
    println!("manifest {}", dir.join(runs::MANIFEST).display());
    Ok(())
}

pub fn runs(what: RunsCmd, dir: &std::path::Path) -> Result<()> {
    use pillar_pipe::pipeline::{runs, views};
    match what {
        RunsCmd::List => print!("{}", views::list_text(&runs::list(dir)?)),
        RunsCmd::Show { id, json } => {
            let mut m = runs::find(dir, &id)?;
            if m.status == "submitted" {
                pillar_pipe::pipeline::slurm::head::refresh(&mut m, dir);
            }
            if json {
                println!("{}", serde_json::to_string_pretty(&m)?);
            } else {
                print!("{}", views::show_text(&m, dir));
            }
        }
        RunsCmd::Compare { ids } => {
            let ms = ids
                .iter()
                .map(|id| runs::find(dir, id))
                .collect::<pillar_pipe::Result<Vec<_>>>()?;
            print!("{}", views::compare_text(&ms));
        }
        RunsCmd::Verify { id, all } => verify(id, all, dir)?,
    }
    Ok(())
}

/// `runs verify`: one line per entry, the damaged ones moved aside; fails if any was.
fn verify(id: Option<String>, all: bool, dir: &std::path::Path) -> Result<()> {
    use pillar_pipe::pipeline::cache::{Cache, Verdict};
    use pillar_pipe::pipeline::runs;
    let cache = Cache {
        dir: dir.join("cache"),
    };
    // (label, entry name, key the run expects)
    let mut todo: Vec<(String, String, Option<String>)> = Vec::new();
    if all {
        let (live, _) = cache.entries()?;
        todo.extend(live.into_iter().map(|n| (n.clone(), n, None)));
    } else {
        let m = runs::find(dir, id.as_deref().unwrap_or("latest"))?;
        println!("run {}", m.run_id);
        for st in &m.stages {
            let name = std::path::Path::new(&st.dir)
                .file_name()
                .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
            todo.push((st.name.clone(), name, Some(st.key.clone())));
        }
    }
    let label = |(l, n, _): &(String, String, Option<String>)| {
        if all { l.clone() } else { format!("{l} ({n})") }
    };
    let width = todo
        .iter()
        .map(|t| label(t).chars().count())
        .max()
        .unwrap_or(0);
    let mut damaged = 0;
    for t in &todo {
        let (name, key) = (&t.1, &t.2);
        let c = cache.verify_entry(name, key.as_deref())?;
        let line = match &c.verdict {
            Verdict::Ok(r) => format!(
                "OK            {} files, sha256",
                r.output_files.as_ref().map_or(0, |f| f.len())
            ),
            Verdict::Missing => "MISSING       not in the cache (cleared?)".into(),
            Verdict::Unverifiable(why) => format!("UNVERIFIABLE  {why}; never served"),
            Verdict::Damaged(what) => {
                damaged += 1;
                let fate = match &c.moved {
                    Ok(to) => format!("moved to {}", shown(to)),
                    Err(why) => why.clone(),
                };
                format!("DAMAGED       {what}; {fate}")
            }
        };
        println!("{:width$}  {line}", label(t));
    }
    for a in &cache.entries()?.1 {
        println!("kept aside    {}", shown(&cache.dir.join(a)));
    }
    if damaged > 0 {
        anyhow::bail!(
            "{damaged} damaged cache entr{} (moved aside; the next run recomputes them)",
            if damaged == 1 { "y" } else { "ies" }
        );
    }
    Ok(())
}
