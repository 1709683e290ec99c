//! Stages: each reads its inputs through `io`, runs the kernels, writes its outputs
//! atomically with provenance, and returns a report. The CLI and the pipeline runner
//! both call these; neither does any work of its own.

pub mod force;
pub mod front;
pub mod ingest;

/// Tool name and version recorded in every output.
pub const TOOL: &str = "pillar-pipe";
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

pub mod kinematics;
pub mod locate;
pub mod manifest;
pub mod outline;

/// A progress bar on stderr with ETA, hidden with `quiet` or when stderr is not a
/// terminal (indicatif's default), so scripts and CI logs stay clean.
pub fn progress(len: u64, what: &str, quiet: bool) -> indicatif::ProgressBar {
    if quiet || PROGRESS_HIDDEN.get() {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(len);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{msg:12} [{bar:40}] {pos}/{len} ETA {eta}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar.set_message(what.to_string());
    bar
}
thread_local! {
    static PROGRESS_HIDDEN: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Hide the progress bars of the stages run on this thread (the local executor's, for a
/// stage that runs beside others, whose bars would overwrite each other). Unlike a
/// stage's `quiet` option, which some stages record, this changes no output.
pub fn hide_progress_on_this_thread() {
    PROGRESS_HIDDEN.set(true);
}

pub mod bar_pressure;
pub mod compare;
pub mod datasets;
pub mod edge_stress;
pub mod export;
pub mod fit;
pub mod gofr;
pub mod grid;
pub mod line_tracks;
pub mod link;
pub mod pack;
pub mod quickstart;
pub mod render;
pub mod report;
pub mod resume;
pub mod run_dir;
pub mod shear;
pub mod shear_lines;
pub mod simulate;
pub mod size_analysis;
pub mod sizes;
pub mod sweep;
pub mod timing;
pub mod track;

/// A checkpoint's bytes for `--resume`, or an error naming the file.
pub(crate) fn read_checkpoint_bytes(ckpt: &std::path::Path) -> crate::error::Result<Vec<u8>> {
    std::fs::read(ckpt).map_err(|e| {
        crate::error::Error::input(
            ckpt.display(),
            format!("cannot resume: no checkpoint here ({e})"),
        )
    })
}

/// Write a simulation checkpoint atomically; with `halt_after` (tests of resuming) stop
/// the run with an error once `step` has reached it.
pub(crate) fn write_checkpoint(
    path: &std::path::Path,
    bytes: &[u8],
    step: u64,
    halt_after: Option<u64>,
) -> crate::error::Result<()> {
    crate::io::atomic_write_bytes(path, bytes)?;
    if halt_after.is_some_and(|h| step >= h) {
        return Err(crate::error::Error::Other(format!(
            "halted after the checkpoint at step {step} (testing)"
        )));
    }
    Ok(())
}
