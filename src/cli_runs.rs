//! `pillar-pipe run` and `pillar-pipe runs`: argument types and printing only; the
//! work is in `pillar_pipe::pipeline`.

use anyhow::Result;
use clap::Subcommand;

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
        if quiet {
            return;
        }
        let what = match e.status {
            Status::Running => "running".to_string(),
            Status::Cached => format!("cached     {}", shown(e.dir)),
            Status::Computed => format!("computed   {:.2} s -> {}", e.elapsed_s, shown(e.dir)),
            Status::WouldRun => format!("would run  {}", shown(e.dir)),
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
            let m = runs::find(dir, &id)?;
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
    }
    Ok(())
}
