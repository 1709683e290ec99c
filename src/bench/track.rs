//! `pillar-pipe bench track`: the whole tracking of a rendered pillar movie, as a user
//! times it — `pillar-pipe track FRAMES -o tracks.csv …` against trackpy's `batch` +
//! `link` as a whole Python process (`bench/trackpy_track.py`, carried in the binary)
//! with the same settings and as many processes as our threads — alternating rounds,
//! medians; then both outputs scored against the movie's ground truth
//! (`camera::score`: lost, spurious, rms error, identity switches).
//!
//! The movie: the bundled experiment sample (1000 grains, `data/sample/tracks.csv`) or
//! `--input` (any tracks table or a pillar run), rendered by `render` at the shared
//! sample's scale (31.496 px/cm: large grains 20 px, small 15 px across), as lit
//! spheres (`--profile dome`).

use crate::bench::whole::median;
use crate::camera::score::{TrackingScore, Truth, score};
use crate::camera::{LinkOptions, LocateParams};
use crate::error::{Error, Result};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

const TRACKPY_SCRIPT: &str = include_str!("../../bench/trackpy_track.py");

/// The settings both trackers get.
#[derive(Debug, Clone, Serialize)]
pub struct TrackSettings {
    pub px_per_unit: f64,
    pub locate: LocateParams,
    pub link: LinkOptions,
    /// Truth and detection pair within this distance, px.
    pub match_tolerance_px: f64,
    /// trackpy's `batch(processes=…)`; our threads.
    pub processes: usize,
}

#[derive(Debug, Clone, Serialize)]
pub struct TrackBench {
    pub input: String,
    pub frames: usize,
    pub width: usize,
    pub height: usize,
    pub settings: TrackSettings,
    /// Whole `pillar-pipe track` processes, s.
    pub ours_s: Vec<f64>,
    /// Whole trackpy processes (import, read, batch, link, write), s.
    pub trackpy_s: Vec<f64>,
    /// trackpy's version and whether numba was there, or why it could not run.
    pub trackpy: std::result::Result<String, String>,
    pub ours_score: TrackingScore,
    pub trackpy_score: Option<TrackingScore>,
}

impl TrackBench {
    pub fn ours_median(&self) -> f64 {
        median(&self.ours_s)
    }
    pub fn trackpy_median(&self) -> Option<f64> {
        (!self.trackpy_s.is_empty()).then(|| median(&self.trackpy_s))
    }
}

fn read_truth(path: &Path) -> Result<Vec<Truth>> {
    let file = path.display().to_string();
    let mut rd = csv::Reader::from_path(path).map_err(|e| Error::input(&file, e.to_string()))?;
    let head = rd
        .headers()
        .map_err(|e| Error::input(&file, e.to_string()))?
        .clone();
    let col = |n: &str| {
        head.iter()
            .position(|h| h == n)
            .ok_or_else(|| Error::input(&file, format!("no '{n}' column")))
    };
    let (f, p, x, y) = (col("frame")?, col("particle")?, col("x_px")?, col("y_px")?);
    let mut out = Vec::new();
    for (line, rec) in rd.records().enumerate() {
        let rec = rec.map_err(|e| Error::input(&file, e.to_string()))?;
        let num = |i: usize| -> Result<f64> {
            rec[i].parse::<f64>().map_err(|e| Error::Value {
                file: file.clone(),
                loc: format!("line {}", line + 2),
                column: head[i].to_string(),
                msg: e.to_string(),
            })
        };
        out.push(Truth {
            frame: num(f)? as i64,
            particle: num(p)? as i64,
            x: num(x)?,
            y: num(y)?,
        });
    }
    Ok(out)
}

/// Render the movie into `dir`, then `rounds` alternating whole runs of each tracker.
pub fn bench_track(
    exe: &Path,
    input: &Path,
    settings: &TrackSettings,
    rounds: usize,
    dir: &Path,
    python: &str,
) -> Result<TrackBench> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let tracks = if input.is_dir() {
        input.to_path_buf()
    } else {
        let t = dir.join("movie.tracks.parquet");
        let mut opt = crate::stages::ingest::IngestOptions::default();
        crate::stages::ingest::apply_settings(input, &mut opt)?;
        crate::stages::ingest::run(input, &t, &opt)?;
        t
    };
    let frames = dir.join("frames");
    let render = crate::stages::render::run(
        &tracks,
        &frames,
        &crate::stages::render::RenderOptions {
            px_per_unit: settings.px_per_unit,
            // Lit spheres, as in the shared sample's movie: Crocker–Grier needs a peak,
            // and a flat disk's band-passed centre is a plateau that trackpy and we
            // both lose about one grain in eight on.
            camera: crate::camera::render::Camera {
                profile: crate::camera::render::Profile::Dome,
                ..Default::default()
            },
            overwrite: true,
            quiet: true,
            ..Default::default()
        },
    )?;
    let script = dir.join("trackpy_track.py");
    std::fs::write(&script, TRACKPY_SCRIPT).map_err(|e| Error::io(&script, e))?;
    let (l, k) = (&settings.locate, &settings.link);
    let ours_out = dir.join("ours.csv");
    let tp_out = dir.join("trackpy.csv");
    let ours_cmd = || {
        let mut c = Command::new(exe);
        c.arg("track")
            .arg(&frames)
            .arg("-o")
            .arg(&ours_out)
            .args(["--diameter", &l.diameter.to_string()])
            .args(["--minmass", &l.minmass.to_string()])
            .args(["--noise-size", &l.noise_size.to_string()])
            .args(["--search-range", &k.search_range.to_string()])
            .args(["--memory", &k.memory.to_string()])
            .arg("--quiet")
            .env("RAYON_NUM_THREADS", settings.processes.to_string());
        if let Some(s) = l.separation {
            c.args(["--separation", &s.to_string()]);
        }
        if !k.predict {
            c.arg("--no-predict");
        }
        c
    };
    let tp_cmd = || {
        let mut c = Command::new(python);
        c.arg(&script)
            .arg(&frames)
            .arg(&tp_out)
            .arg(l.diameter.to_string())
            .arg(l.minmass.to_string())
            .arg(l.separation.unwrap_or(l.diameter as f64 + 1.0).to_string())
            .arg(l.noise_size.to_string())
            .arg(k.search_range.to_string())
            .arg(k.memory.to_string())
            .arg(settings.processes.to_string());
        c
    };
    let time = |mut c: Command, what: &str| -> Result<(f64, String)> {
        let t0 = Instant::now();
        let o = c
            .output()
            .map_err(|e| Error::Other(format!("{what}: cannot start: {e}")))?;
        let s = t0.elapsed().as_secs_f64();
        if !o.status.success() {
            return Err(Error::Other(format!(
                "{what} failed: {}",
                String::from_utf8_lossy(&o.stderr).trim()
            )));
        }
        Ok((s, String::from_utf8_lossy(&o.stdout).into_owned()))
    };
    let mut trackpy: std::result::Result<String, String> = Err("not run".into());
    let (mut ours_s, mut trackpy_s) = (Vec::new(), Vec::new());
    let bar = crate::stages::progress(rounds as u64, "track runs", false);
    for round in 0..rounds {
        // trackpy first, then ours, as a user's alternating script; a missing trackpy
        // is said once and ours is still timed.
        if round == 0 || trackpy.is_ok() {
            match time(tp_cmd(), "trackpy") {
                Ok((s, out)) => {
                    trackpy_s.push(s);
                    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap_or_default();
                    trackpy = Ok(format!(
                        "trackpy {} (numba: {})",
                        v["trackpy"].as_str().unwrap_or("?"),
                        v["numba"]
                    ));
                }
                Err(e) => trackpy = Err(e.to_string()),
            }
        }
        ours_s.push(time(ours_cmd(), "pillar-pipe track")?.0);
        bar.inc(1);
    }
    bar.finish_and_clear();
    let truth = read_truth(&frames.join("ground_truth.csv"))?;
    let tol = settings.match_tolerance_px;
    let (f, p) = crate::io::features::read_linked(&ours_out)?;
    let ours_score = score(&truth, &f, Some(&p), tol);
    let trackpy_score = if trackpy.is_ok() {
        let (f, p) = crate::io::features::read_linked(&tp_out)?;
        Some(score(&truth, &f, Some(&p), tol))
    } else {
        None
    };
    Ok(TrackBench {
        input: input.display().to_string(),
        frames: render.frames,
        width: render.width,
        height: render.height,
        settings: settings.clone(),
        ours_s,
        trackpy_s,
        trackpy,
        ours_score,
        trackpy_score,
    })
}

/// The default movie's tracks: the bundled sample.
pub fn default_input() -> PathBuf {
    crate::stages::quickstart::bundled_sample()
}
