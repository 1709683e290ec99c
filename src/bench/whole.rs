//! The kinematics command as a user times it (`pillar-pipe bench kinematics-whole`):
//! the whole `pillar-pipe kinematics` process on one frame pair from a file, against
//! OVITO's Atomic Strain as a whole Python process on the same frames
//! (`bench/ovito_whole.py`: start, import, load, compute, save D²min), run alternately,
//! medians reported; ours both writing every column and writing D²min only
//! (`--columns d2min`, what the OVITO script saves). Peak memory of each process from `wait4`.

use crate::error::{Error, Result};
use crate::geom::Mat2;
use crate::stages::timing::Phase;
use crate::synth::{bidisperse_packing, two_frame_tracks};
use serde::Serialize;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// The OVITO side, carried in the binary so the bench needs no checkout.
const OVITO_SCRIPT: &str = include_str!("../../bench/ovito_whole.py");

#[derive(Debug, Clone, Serialize)]
pub struct WholeRun {
    pub seconds: f64,
    pub peak_rss_bytes: u64,
    /// User + system CPU time of the process (s): on a shared machine the figure that
    /// other processes disturb least.
    pub cpu_seconds: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct WholeBench {
    pub n: usize,
    pub reps: usize,
    /// Every run of `pillar-pipe kinematics` (every column), in order.
    pub ours: Vec<WholeRun>,
    /// Every run of `pillar-pipe kinematics --columns d2min`: what OVITO's script saves.
    pub ours_d2min: Vec<WholeRun>,
    /// Every OVITO run (one after each of ours); empty without OVITO.
    pub ovito: Vec<WholeRun>,
    /// Why there is no OVITO reference, when there is none.
    pub ovito_missing: Option<String>,
    /// Our phases (`stages::kinematics::PHASES`) in one more run.
    pub phases: Vec<Phase>,
    /// Size of our output table, bytes.
    pub output_bytes: u64,
    /// Size of our `--columns d2min` table, bytes.
    pub d2min_output_bytes: u64,
    /// In-memory size of our output table's columns, bytes.
    pub output_table_bytes: u64,
}

pub fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    match s.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => s[n / 2],
        n => 0.5 * (s[n / 2 - 1] + s[n / 2]),
    }
}

impl WholeBench {
    pub fn ours_median(&self) -> f64 {
        median(&self.ours.iter().map(|r| r.seconds).collect::<Vec<_>>())
    }
    pub fn ours_d2min_median(&self) -> f64 {
        median(
            &self
                .ours_d2min
                .iter()
                .map(|r| r.seconds)
                .collect::<Vec<_>>(),
        )
    }
    pub fn ovito_median(&self) -> Option<f64> {
        (!self.ovito.is_empty())
            .then(|| median(&self.ovito.iter().map(|r| r.seconds).collect::<Vec<_>>()))
    }
    pub fn ours_peak(&self) -> u64 {
        self.ours
            .iter()
            .map(|r| r.peak_rss_bytes)
            .max()
            .unwrap_or(0)
    }
}

/// A `.npy` file of one little-endian column (`descr`: `<f8` or `<i8`).
pub(crate) fn write_npy(
    path: &Path,
    descr: &str,
    bytes: impl Iterator<Item = [u8; 8]>,
    n: usize,
) -> Result<()> {
    let mut header = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': ({n},), }}");
    // Magic (6) + version (2) + length (2) + header + '\n', padded to 64 bytes.
    while (10 + header.len() + 1) % 64 != 0 {
        header.push(' ');
    }
    header.push('\n');
    let f = std::fs::File::create(path).map_err(|e| Error::io(path, e))?;
    let mut w = std::io::BufWriter::with_capacity(1 << 20, f);
    let mut put = |b: &[u8]| w.write_all(b).map_err(|e| Error::io(path, e));
    put(b"\x93NUMPY\x01\x00")?;
    put(&(header.len() as u16).to_le_bytes())?;
    put(header.as_bytes())?;
    for b in bytes {
        put(&b)?;
    }
    w.flush().map_err(|e| Error::io(path, e))
}

fn drain(p: Option<impl std::io::Read>) -> String {
    let mut s = String::new();
    if let Some(mut p) = p {
        let _ = p.read_to_string(&mut s);
    }
    s
}

/// Run `cmd`, return its wall time and peak resident memory (`wait4`).
pub(crate) fn timed(cmd: &mut Command) -> Result<WholeRun> {
    let what = format!("{cmd:?}");
    let t = Instant::now();
    let child = cmd
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .map_err(|e| Error::Other(format!("{what}: {e}")))?;
    let pid = child.id() as libc::pid_t;
    // Drain the pipes on their own threads so a chatty child cannot block.
    let mut child = child;
    let (out, err) = (child.stdout.take(), child.stderr.take());
    let (stdout, stderr, status, rusage) = std::thread::scope(|sc| {
        let o = sc.spawn(|| drain(out));
        let e = sc.spawn(|| drain(err));
        let mut status = 0;
        // SAFETY: rusage is plain old data, zero is a valid value; wait4 fills it.
        let mut ru: libc::rusage = unsafe { std::mem::zeroed() };
        // SAFETY: `pid` is our own child, not yet waited for (std's `Child` is dropped
        // without `wait`, which never reaps it).
        let r = unsafe { libc::wait4(pid, &mut status, 0, &mut ru) };
        (
            o.join().unwrap_or_default(),
            e.join().unwrap_or_default(),
            (r == pid).then_some(status),
            ru,
        )
    });
    let seconds = t.elapsed().as_secs_f64();
    let ok = status.is_some_and(|s| libc::WIFEXITED(s) && libc::WEXITSTATUS(s) == 0);
    if !ok {
        return Err(Error::Other(format!(
            "{what} failed ({status:?}):\n{stdout}\n{stderr}"
        )));
    }
    let _ = stdout;
    Ok(WholeRun {
        seconds,
        peak_rss_bytes: rusage.ru_maxrss as u64 * 1024,
        cpu_seconds: [rusage.ru_utime, rusage.ru_stime]
            .iter()
            .map(|t| t.tv_sec as f64 + 1e-6 * t.tv_usec as f64)
            .sum(),
    })
}

/// Whether `python` can import OVITO; the reason when it cannot.
fn ovito_available(python: &str) -> std::result::Result<(), String> {
    match Command::new(python).args(["-c", "import ovito"]).output() {
        Ok(o) if o.status.success() => Ok(()),
        Ok(o) => Err(format!(
            "{python} cannot import ovito (pip install ovito): {}",
            String::from_utf8_lossy(&o.stderr)
                .lines()
                .last()
                .unwrap_or("")
        )),
        Err(e) => Err(format!("{python} not runnable: {e}")),
    }
}

/// One frame pair of about `n` particles (affine map + noise, as `bench kinematics`),
/// written as canonical tracks (ours) and `.npy` columns (OVITO's) under `dir`; then
/// `reps` alternating runs of `exe kinematics` and of OVITO with `python`.
pub fn bench_kinematics_whole(
    exe: &Path,
    n: usize,
    reps: usize,
    dir: &Path,
    python: &str,
) -> Result<WholeBench> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let p = bidisperse_packing(n, 1.0, 0.1, 1);
    let t = two_frame_tracks(&p, Mat2::new(1.0, 0.02, 0.0, 0.99), 0.01, 2);
    let tracks: PathBuf = dir.join("pair.parquet");
    crate::io::write_tracks(&t, &tracks)?;
    for (k, (_, r)) in t.frame_ranges().into_iter().enumerate().take(2) {
        let m = r.len();
        write_npy(
            &dir.join(format!("x{k}.npy")),
            "<f8",
            t.x[r.clone()].iter().map(|v| v.to_le_bytes()),
            m,
        )?;
        write_npy(
            &dir.join(format!("y{k}.npy")),
            "<f8",
            t.y[r.clone()].iter().map(|v| v.to_le_bytes()),
            m,
        )?;
        write_npy(
            &dir.join(format!("id{k}.npy")),
            "<i8",
            t.particle[r].iter().map(|v| v.to_le_bytes()),
            m,
        )?;
    }
    let script = dir.join("ovito_whole.py");
    std::fs::write(&script, OVITO_SCRIPT).map_err(|e| Error::io(&script, e))?;
    let ovito_missing = ovito_available(python).err();
    let out = dir.join("pair.kinematics.parquet");
    let out_d2min = dir.join("pair.d2min.parquet");
    // Both of our runs, every column (with its report, for the phases) and D²min only.
    let ours_cmd = |d2min_only: bool| {
        let mut c = Command::new(exe);
        c.arg("kinematics")
            .arg(&tracks)
            .args(["--lag", "1", "--quiet", "--json"]);
        if d2min_only {
            c.args(["--columns", "d2min", "-o"]).arg(&out_d2min);
        } else {
            c.arg("-o").arg(&out);
        }
        c
    };
    let (mut ours, mut ours_d2min, mut ovito) = (Vec::new(), Vec::new(), Vec::new());
    let bar = crate::stages::progress(reps as u64, "whole runs", false);
    // Each of our runs follows an OVITO run, as in a user's alternating script: the
    // memory a process has just freed costs the next one its first touches (see
    // docs/performance.md); the first one follows an untimed OVITO run.
    let ovito_cmd = || {
        let mut c = Command::new(python);
        c.arg(&script).arg(dir).arg(dir.join("d2min.npy"));
        c
    };
    if ovito_missing.is_none() {
        timed(&mut ovito_cmd())?;
    }
    for _ in 0..reps.max(1) {
        for (d2min_only, runs) in [(false, &mut ours), (true, &mut ours_d2min)] {
            runs.push(timed(&mut ours_cmd(d2min_only))?);
            if ovito_missing.is_none() {
                ovito.push(timed(&mut ovito_cmd())?);
            }
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    // The phases of one more run (its own numbers, not one of the timed runs).
    let o = ours_cmd(false)
        .output()
        .map_err(|e| Error::Other(format!("kinematics: {e}")))?;
    let rep: serde_json::Value = serde_json::from_slice(&o.stdout)
        .map_err(|e| Error::Other(format!("kinematics --json: {e}")))?;
    let phases = rep["timings"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(|p| {
                    let name = p["name"].as_str()?;
                    let name = crate::stages::kinematics::PHASES
                        .into_iter()
                        .find(|&n| n == name)
                        .unwrap_or("other");
                    Some(Phase {
                        name,
                        seconds: p["seconds"].as_f64()?,
                    })
                })
                .collect()
        })
        .unwrap_or_default();
    let output_bytes = std::fs::metadata(&out)
        .map_err(|e| Error::io(&out, e))?
        .len();
    let d2min_output_bytes = std::fs::metadata(&out_d2min)
        .map_err(|e| Error::io(&out_d2min, e))?
        .len();
    let rows = rep["rows"].as_u64().unwrap_or(0);
    // 20 eight-byte columns, two of four bytes, a boolean and a 16-byte string view.
    let output_table_bytes = rows * (20 * 8 + 2 * 4 + 1 + 16);
    Ok(WholeBench {
        n: t.frame_ranges().first().map_or(0, |(_, r)| r.len()),
        reps,
        ours,
        ours_d2min,
        ovito,
        ovito_missing,
        phases,
        output_bytes,
        d2min_output_bytes,
        output_table_bytes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn npy_header_is_what_numpy_reads() {
        let dir = std::env::temp_dir().join(format!("pp-npy-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("a.npy");
        write_npy(&p, "<f8", [1.5f64, -2.0].iter().map(|v| v.to_le_bytes()), 2).unwrap();
        let b = std::fs::read(&p).unwrap();
        let hlen = u16::from_le_bytes([b[8], b[9]]) as usize;
        assert_eq!((10 + hlen) % 64, 0, "data aligned to 64 bytes");
        let header = std::str::from_utf8(&b[10..10 + hlen]).unwrap();
        assert!(header.starts_with("{'descr': '<f8', 'fortran_order': False, 'shape': (2,), }"));
        assert!(header.ends_with('\n'));
        assert_eq!(
            &b[10 + hlen..],
            [1.5f64.to_le_bytes(), (-2.0f64).to_le_bytes()].concat()
        );
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn median_of_odd_and_even() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
        assert!(median(&[]).is_nan());
    }
}
