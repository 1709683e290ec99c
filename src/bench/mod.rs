//! Benchmarks of the hot paths, each against a reference measured in the same run
//! (`pillar-pipe bench …`; never timed unit tests). This file holds the kinematics
//! kernel's; the others have a module each.

pub mod dem;
pub mod fit;
pub mod gofr;
pub mod pack;
pub mod track;
pub mod whole;

use crate::error::{Error, Result};
use crate::geom::{Mat2, Vec2};
use crate::kinematics::{Convention, KinematicsParams, frame_pair_columns};
use crate::neighbors::{CellList, Cutoff};
use crate::synth::{bidisperse_packing, two_frame_tracks};
use serde::Serialize;
use std::time::Instant;

#[derive(Debug, Clone, Serialize)]
pub struct KinematicsBench {
    pub n: usize,
    pub threads: usize,
    /// Best of `reps` wall times for one frame pair, s.
    pub seconds: f64,
    pub particles_per_s: f64,
    /// Reference in the same run: building the cell list and counting neighbours
    /// (the floor any method pays), s.
    pub neighbour_pass_seconds: f64,
    /// The synthetic pair's particles relabelled into no spatial order.
    pub shuffled: bool,
}

fn best_of<F: FnMut()>(reps: usize, mut f: F) -> f64 {
    (0..reps.max(1))
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

/// One frame pair of `n` particles (affine map + noise), timed with `threads` threads.
/// One synthetic pair of about `n` particles, its rows in lattice order or (`shuffled`)
/// relabelled into no spatial order, as a shuffled dump or this tool's pillar tracks.
pub fn bench_kinematics(
    n: usize,
    threads: usize,
    reps: usize,
    shuffled: bool,
) -> Result<KinematicsBench> {
    let p = bidisperse_packing(n, 1.0, 0.1, 1);
    let mut t = two_frame_tracks(&p, Mat2::new(1.0, 0.02, 0.0, 0.99), 0.01, 2);
    if shuffled {
        t = crate::synth::relabelled(&t);
    }
    let mut b = bench_kinematics_tracks(&t, 1.25, Convention::Paper, threads, reps)?;
    b.shuffled = shuffled;
    Ok(b)
}

/// The first two frames of `t` (e.g. the frames OVITO is timed on), R_c = `rc`.
pub fn bench_kinematics_tracks(
    t: &crate::tracks::Tracks,
    rc: f64,
    convention: Convention,
    threads: usize,
    reps: usize,
) -> Result<KinematicsBench> {
    let fr = t.frame_ranges();
    if fr.len() < 2 {
        return Err(Error::Other("need two frames to time a frame pair".into()));
    }
    let a = t.view(fr[0].0, fr[0].1.clone());
    let b = t.view(fr[1].0, fr[1].1.clone());
    let params = KinematicsParams { rc, convention };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| Error::Other(format!("thread pool: {e}")))?;
    let mut err = None;
    let seconds = pool.install(|| {
        best_of(reps, || {
            if let Err(e) = frame_pair_columns(&a, &b, 1.0, &params) {
                err = Some(e);
            }
        })
    });
    if let Some(e) = err {
        return Err(e);
    }
    let pos: Vec<Vec2> = (0..a.len()).map(|i| a.pos(i)).collect();
    let neighbour_pass_seconds = best_of(reps, || {
        let cl = CellList::new(&pos, rc, Cutoff::Strict, None).expect("cell list");
        let mut c = 0usize;
        for &q in &pos {
            cl.for_each_within(q, |_, _| c += 1);
        }
        std::hint::black_box(c);
    });
    Ok(KinematicsBench {
        n: a.len(),
        threads,
        seconds,
        particles_per_s: a.len() as f64 / seconds,
        neighbour_pass_seconds,
        shuffled: false,
    })
}

/// Peak resident memory of this process so far (VmHWM), bytes; 0 where unavailable.
pub fn peak_rss_bytes() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<u64>().ok())
        })
        .map_or(0, |kb| kb * 1024)
}

/// Write a trackpy-shaped CSV of `rows` rows (frames of 1000 particles) to `path`.
pub fn write_trackpy_csv(path: &std::path::Path, rows: usize, seed: u64) -> Result<()> {
    use std::io::Write;
    let f = std::fs::File::create(path).map_err(|e| Error::io(path, e))?;
    let mut w = std::io::BufWriter::with_capacity(1 << 20, f);
    let mut rng = crate::rng::Rng::new(seed);
    let per = 1000usize;
    // A jittered 40 × 25 lattice of spacing 18 px (D = 20 px): a packing, as in a movie.
    let base: Vec<(f64, f64, f64)> = (0..per)
        .map(|i| {
            let large = rng.uniform() < 0.5;
            (
                20.0 + 18.0 * (i % 40) as f64 + 9.0 * ((i / 40) % 2) as f64 + rng.uniform(),
                20.0 + 15.6 * (i / 40) as f64 + rng.uniform(),
                if large { 5.2 } else { 3.9 },
            )
        })
        .collect();
    writeln!(w, "y,x,mass,size,ecc,signal,raw_mass,ep,frame,particle")
        .map_err(|e| Error::io(path, e))?;
    for r in 0..rows {
        let (frame, i) = (r / per, r % per);
        let (x, y, s) = base[i];
        let jx = 0.3 * rng.normal();
        let jy = 0.3 * rng.normal();
        writeln!(
            w,
            "{:.6},{:.6},{:.4},{:.5},{:.5},{:.4},{:.1},{:.6},{frame},{i}",
            y + jy + 0.01 * frame as f64,
            x + jx,
            2000.0 + 100.0 * rng.uniform(),
            s + 0.1 * rng.normal(),
            0.05 * rng.uniform(),
            40.0 + rng.uniform(),
            9000.0 + 500.0 * rng.uniform(),
            0.002 * rng.uniform(),
        )
        .map_err(|e| Error::io(path, e))?;
    }
    w.flush().map_err(|e| Error::io(path, e))
}

/// One timed ingest-side measurement, run in a child process so peak memory is its own.
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct IngestChild {
    pub mode: String,
    pub seconds: f64,
    pub peak_rss_bytes: u64,
    pub rows: usize,
}

/// `polars`: polars' own CSV reader, all columns, types inferred (the reference).
/// `ingest`: our ingest stage, CSV → validated canonical Parquet.
pub fn ingest_child(mode: &str, csv: &std::path::Path) -> Result<IngestChild> {
    use polars::prelude::*;
    let t = Instant::now();
    let rows = match mode {
        "polars" => CsvReadOptions::default()
            .with_has_header(true)
            .try_into_reader_with_file_path(Some(csv.to_path_buf()))
            .and_then(|r| r.finish())
            .map_err(|e| Error::polars("polars read", e))?
            .height(),
        "ingest" => {
            let out = csv.with_extension("bench.parquet");
            let opt = crate::stages::ingest::IngestOptions {
                format: Some(crate::stages::ingest::Format::Trackpy),
                px_per_unit: Some(31.496063),
                unit: Some("cm".into()),
                frame_time: Some(15.0),
                keep_detached: true,
                ..Default::default()
            };
            let r = crate::stages::ingest::run(csv, &out, &opt)?;
            let _ = std::fs::remove_file(&out);
            let _ = std::fs::remove_file(crate::io::sidecar_path(&out));
            r.summary.rows
        }
        m => return Err(Error::param("mode", format!("unknown bench mode {m}"))),
    };
    Ok(IngestChild {
        mode: mode.into(),
        seconds: t.elapsed().as_secs_f64(),
        peak_rss_bytes: peak_rss_bytes(),
        rows,
    })
}
