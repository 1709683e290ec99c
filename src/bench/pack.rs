//! The packer as a user times it (`pillar-pipe bench pack`): the whole `pillar-pipe pack`
//! process (li-granular-pillars Sec. II.A) as it runs by default, against the same
//! binary's `--serial --f-tol 0` (the packer as it was until 2026-11-27, bit for bit the
//! old packings: one serial force sum, the paper's energy rule alone), alternating,
//! seed by seed. Under the energy rule the minimisations near jamming stop on the first
//! CG step whose energy change is below 1e-12 of the energy, so a seed's iteration
//! count is close to a random draw: compare medians over several seeds, and the CPU
//! time on a shared machine.

use crate::bench::whole::{WholeRun, median, timed};
use crate::error::{Error, Result};
use serde::Serialize;
use std::path::Path;
use std::process::Command;

#[derive(Debug, Clone, Serialize)]
pub struct PackRun {
    pub seed: u64,
    /// `default` or `reference` (`--serial --f-tol 0`).
    pub variant: String,
    pub run: WholeRun,
    /// From the packing's metadata: jammed φ, box growths, CG iterations, force
    /// evaluations.
    pub phi: f64,
    pub growth_steps: u64,
    pub cg_iterations: u64,
    pub force_evaluations: u64,
    /// The force-balance tolerance the packing recorded (0: the energy rule alone).
    pub f_tol: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct PackBench {
    pub n: usize,
    /// Threads of our runs (`RAYON_NUM_THREADS`, else the machine's cores).
    pub threads: usize,
    /// Every run in the order made: for each seed the default, then the reference.
    pub runs: Vec<PackRun>,
}

impl PackBench {
    fn of(&self, variant: &str) -> impl Iterator<Item = &PackRun> {
        self.runs.iter().filter(move |r| r.variant == variant)
    }
    /// Median wall and CPU seconds and mean φ of one variant's runs.
    pub fn summary(&self, variant: &str) -> (f64, f64, f64) {
        let wall: Vec<f64> = self.of(variant).map(|r| r.run.seconds).collect();
        let cpu: Vec<f64> = self.of(variant).map(|r| r.run.cpu_seconds).collect();
        let phi: Vec<f64> = self.of(variant).map(|r| r.phi).collect();
        (
            median(&wall),
            median(&cpu),
            phi.iter().sum::<f64>() / phi.len().max(1) as f64,
        )
    }
}

/// `exe pack --n n` for each seed, as by default then as the reference, into
/// `dir`; `threads` is passed on as `RAYON_NUM_THREADS` when given.
pub fn bench_pack(
    exe: &Path,
    n: usize,
    seeds: &[u64],
    threads: Option<usize>,
    dir: &Path,
) -> Result<PackBench> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let mut runs = Vec::new();
    let bar = crate::stages::progress(seeds.len() as u64, "pack runs", false);
    for &seed in seeds {
        for variant in ["default", "reference"] {
            let out = dir.join(format!("pack_{n}_{seed}_{variant}.parquet"));
            let mut c = Command::new(exe);
            c.arg("pack")
                .args(["--n", &n.to_string(), "--seed", &seed.to_string()])
                .args(["--quiet", "-o"])
                .arg(&out);
            if variant == "reference" {
                c.args(["--serial", "--f-tol", "0"]);
            }
            if let Some(t) = threads {
                c.env("RAYON_NUM_THREADS", t.to_string());
            }
            let run = timed(&mut c)?;
            let meta = out.with_extension("parquet.meta.json");
            let text = std::fs::read_to_string(&meta).map_err(|e| Error::io(&meta, e))?;
            let v: serde_json::Value = serde_json::from_str(&text)
                .map_err(|e| Error::Other(format!("{}: {e}", meta.display())))?;
            let s = &v["summary"];
            runs.push(PackRun {
                seed,
                variant: variant.into(),
                run,
                phi: s["phi"].as_f64().unwrap_or(f64::NAN),
                growth_steps: s["growth_steps"].as_u64().unwrap_or(0),
                cg_iterations: s["cg_iterations"].as_u64().unwrap_or(0),
                force_evaluations: s["force_evaluations"].as_u64().unwrap_or(0),
                f_tol: v["provenance"]["parameters"]["protocol"]["f_tol"]
                    .as_f64()
                    .unwrap_or(f64::NAN),
            });
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    Ok(PackBench {
        n,
        threads: threads.unwrap_or_else(rayon::current_num_threads),
        runs,
    })
}
