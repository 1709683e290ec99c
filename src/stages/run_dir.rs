//! The life of a long run's directory, one for both simulators (`simulate pillar`,
//! `simulate shear` and its ramps). A fresh run refuses a directory that holds a
//! finished or an unfinished run; checkpoints go to `checkpoint.bin` (written whole
//! under a temporary name, then renamed) with the output so far in `.parts/`; after
//! each checkpoint a pending SIGINT or SIGTERM stops the run, saying where; at the end
//! the parts are merged and the manifest written, and only then are the checkpoint and
//! the parts removed. So at every instant — a kill included — the directory holds a
//! run that resumes or a finished one. What a checkpoint must match to resume is
//! `stages::resume`'s one rule.

use crate::error::{Error, Result};
use crate::interrupt::CheckpointClock;
use crate::stages::manifest::MANIFEST;
use std::path::{Path, PathBuf};

pub const CHECKPOINT: &str = "checkpoint.bin";
pub const PARTS: &str = ".parts";

/// A run's output directory and its checkpoint files.
#[derive(Debug, Clone)]
pub struct RunDir {
    pub out: PathBuf,
    pub checkpoint: PathBuf,
    pub parts: PathBuf,
}

impl RunDir {
    /// The directory, created if missing.
    pub fn create(out: &Path) -> Result<RunDir> {
        std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
        Ok(RunDir {
            out: out.to_path_buf(),
            checkpoint: out.join(CHECKPOINT),
            parts: out.join(PARTS),
        })
    }

    /// A fresh run: refused where a finished or an unfinished run would be overwritten;
    /// parts left by a run killed before its first checkpoint are cleared.
    pub fn start(&self) -> Result<()> {
        if self.out.join(MANIFEST).exists() {
            return Err(Error::param(
                "output",
                format!(
                    "{} already holds a finished run; choose another directory",
                    self.out.display()
                ),
            ));
        }
        if self.checkpoint.exists() {
            return Err(Error::param(
                "output",
                format!(
                    "{} holds an unfinished run; pass --resume to continue it, or choose another directory",
                    self.out.display()
                ),
            ));
        }
        let _ = std::fs::remove_dir_all(&self.parts);
        Ok(())
    }

    /// The checkpoint's bytes, for a resume (errors name the file).
    pub fn read(&self) -> Result<Vec<u8>> {
        crate::stages::read_checkpoint_bytes(&self.checkpoint)
    }

    /// A resumed run: parts written after the checkpoint (numbered `parts` and up) hold
    /// output the run will write again, so they go.
    pub fn resume(&self, parts: u64) -> Result<()> {
        crate::stages::simulate::tables::drop_parts_from(&self.parts, parts)
    }

    /// Saves a checkpoint made at `step` of `total` and restarts the clock; then a
    /// pending signal stops the run with an error that says where it was saved.
    /// `halt_after` is the tests' stand-in for a kill right after a checkpoint.
    pub fn save(
        &self,
        bytes: &[u8],
        step: u64,
        total: u64,
        halt_after: Option<u64>,
        clock: &mut CheckpointClock,
    ) -> Result<()> {
        crate::stages::write_checkpoint(&self.checkpoint, bytes, step, halt_after)?;
        clock.saved();
        match Error::interrupted(format!(
            "checkpoint saved at step {step} of {total} in {}",
            self.checkpoint.display()
        )) {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }

    /// After the manifest is written: the checkpoint and the parts are not needed.
    /// Without the manifest nothing is removed, so the way back is never lost first.
    pub fn finished(&self) {
        if !self.out.join(MANIFEST).exists() {
            return;
        }
        let _ = std::fs::remove_file(&self.checkpoint);
        let _ = std::fs::remove_dir_all(&self.parts);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> RunDir {
        let d = std::env::temp_dir().join(format!("pp-run-dir-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        RunDir::create(&d).unwrap()
    }

    #[test]
    fn a_fresh_run_refuses_a_finished_or_unfinished_one_and_clears_stale_parts() {
        let d = scratch("start");
        std::fs::create_dir_all(&d.parts).unwrap();
        std::fs::write(d.parts.join("tracks.0.parquet"), b"x").unwrap();
        d.start().unwrap();
        assert!(
            !d.parts.exists(),
            "parts of a run killed before its first checkpoint"
        );
        std::fs::write(&d.checkpoint, b"state").unwrap();
        let e = d.start().unwrap_err().to_string();
        assert!(
            e.contains("unfinished run") && e.contains("--resume"),
            "{e}"
        );
        std::fs::write(d.out.join(MANIFEST), b"{}").unwrap();
        let e = d.start().unwrap_err().to_string();
        assert!(e.contains("already holds a finished run"), "{e}");
        let _ = std::fs::remove_dir_all(&d.out);
    }

    #[test]
    fn checkpoint_and_parts_go_only_after_the_manifest() {
        let d = scratch("finish");
        let mut clock = CheckpointClock::new(0, 0.0);
        d.save(b"state", 10, 100, None, &mut clock).unwrap();
        std::fs::create_dir_all(&d.parts).unwrap();
        d.finished();
        assert!(
            d.checkpoint.exists() && d.parts.exists(),
            "no manifest yet: keep both"
        );
        std::fs::write(d.out.join(MANIFEST), b"{}").unwrap();
        d.finished();
        assert!(!d.checkpoint.exists() && !d.parts.exists());
        let _ = std::fs::remove_dir_all(&d.out);
    }

    #[test]
    fn a_halt_after_the_checkpoint_leaves_it_readable() {
        let d = scratch("halt");
        let mut clock = CheckpointClock::new(0, 0.0);
        let e = d.save(b"state", 10, 100, Some(5), &mut clock).unwrap_err();
        assert!(
            e.to_string()
                .contains("halted after the checkpoint at step 10"),
            "{e}"
        );
        assert_eq!(d.read().unwrap(), b"state");
        let _ = std::fs::remove_dir_all(&d.out);
    }
}
