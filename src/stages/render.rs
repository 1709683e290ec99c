//! `pillar-pipe render`: the camera emulator as a stage. Tracks (any table `ingest`
//! reads) → a folder of frames (`frame_00000.png`, …), `ground_truth.csv` (every grain's
//! true centre in pixels and in the tracks' units) and `camera.json` (the settings, the
//! pixel mapping, the input's SHA-256). The pixels come from `camera::render`.
//!
//! One mapping serves every frame: `x_px = (x − x0)·s`, `y_px = (y0 − y)·s` with `s` the
//! pixels per length unit and (x0, y0) chosen so every rendered grain (and bar) sits at
//! least the margin inside the frame. Frames are rendered in parallel; each frame's
//! noise depends only on the seed and its tracks frame number, so the output is the
//! same on any number of threads, and frame 4 is the same image with `--every 1` or 2.
//!
//! Each file is written under a temporary name and renamed when complete;
//! `camera.json` is written last, so a folder with it holds a complete movie.

use crate::camera::render::{Camera, Disk, PixelMap, Rect, render_frame};
use crate::camera::write_frame;
use crate::error::{Error, Result};
use crate::io::csvdiag::Expect;
use crate::io::table::read_table;
use crate::io::{atomic_write, atomic_write_str, sha256_file};
use crate::stages::ingest::{Format, IngestOptions, apply_settings, detect, read_input};
use crate::tracks::Tracks;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The columns of `ground_truth.csv`, in order (`data_schema/ground_truth.schema.json`;
/// `tests/it/ingest.rs` checks the two agree).
pub const GROUND_TRUTH_COLUMNS: [&str; 9] = [
    "frame",
    "particle",
    "species",
    "x_px",
    "y_px",
    "radius_px",
    "x",
    "y",
    "radius",
];

/// Frame image format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ImageFormat {
    #[default]
    Png,
    Tiff,
}

impl ImageFormat {
    pub fn ext(self) -> &'static str {
        match self {
            ImageFormat::Png => "png",
            ImageFormat::Tiff => "tif",
        }
    }
}

#[derive(Debug, Clone)]
pub struct RenderOptions {
    /// Pixels per length unit of the tracks.
    pub px_per_unit: f64,
    /// Render every N-th frame (frame numbers first, first + N, …).
    pub every: i64,
    pub format: ImageFormat,
    /// The camera; a width or height of 0 is fitted to the content plus the margin.
    pub camera: Camera,
    /// Least distance between the content and the frame's edges, px.
    pub margin_px: f64,
    /// Draw the bars of a pillar run (`bar_forces.parquet` beside the tracks).
    pub bars: bool,
    /// Bar thickness in the tracks' length unit (default: two large-grain diameters).
    pub bar_thickness: Option<f64>,
    /// Bar brightness above the background, fraction of full scale.
    pub bar_level: f64,
    /// Replace the frames, ground truth and camera.json of an earlier render.
    pub overwrite: bool,
    pub quiet: bool,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            px_per_unit: 1.0,
            every: 1,
            format: ImageFormat::Png,
            camera: Camera::default(),
            margin_px: 20.0,
            bars: true,
            bar_thickness: None,
            bar_level: 0.25,
            overwrite: false,
            quiet: false,
        }
    }
}

#[derive(Debug, Clone, Serialize)]
pub struct RenderReport {
    pub output: PathBuf,
    pub frames: usize,
    pub width: usize,
    pub height: usize,
    /// Grains drawn, summed over the frames.
    pub grains: usize,
    pub bars: bool,
    pub elapsed_s: f64,
    pub warnings: Vec<String>,
}

/// The bars of a pillar run, one (top face, bottom face) per tracks frame, length unit.
struct Bars {
    source: PathBuf,
    faces: Vec<(f64, f64)>,
    thickness: f64,
    x_range: (f64, f64),
}

/// The tracks file behind `input`: a pillar run's folder stands for its tracks.
fn tracks_path(input: &Path) -> PathBuf {
    if input.is_dir() {
        input.join("tracks.parquet")
    } else {
        input.to_path_buf()
    }
}

fn is_frame_file(name: &str) -> bool {
    let Some(rest) = name.strip_prefix("frame_") else {
        return false;
    };
    let Some((num, ext)) = rest.split_once('.') else {
        return false;
    };
    !num.is_empty()
        && num.bytes().all(|b| b.is_ascii_digit())
        && matches!(ext, "png" | "tif" | "tiff")
}

/// Refuses to mix with an earlier render unless `overwrite`, which removes its frames.
fn prepare_output(out: &Path, overwrite: bool) -> Result<()> {
    if out.exists() && !out.is_dir() {
        return Err(Error::io(
            out,
            std::io::Error::other("exists and is not a folder; -o names the frames' folder"),
        ));
    }
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let rd = std::fs::read_dir(out).map_err(|e| Error::io(out, e))?;
    let mut old = Vec::new();
    for e in rd.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if is_frame_file(&name) || name == "ground_truth.csv" || name == "camera.json" {
            old.push(e.path());
        }
    }
    if old.is_empty() {
        return Ok(());
    }
    if !overwrite {
        return Err(Error::input(
            out.display(),
            format!(
                "holds an earlier render ({} files such as {}); pass --overwrite to replace it or choose another -o",
                old.len(),
                old[0].file_name().unwrap_or_default().to_string_lossy()
            ),
        ));
    }
    for p in old {
        std::fs::remove_file(&p).map_err(|e| Error::io(&p, e))?;
    }
    Ok(())
}

/// Reads the tracks at `path` as `ingest` would (its settings file beside the input
/// applies; trackpy files without a scale are kept in pixels).
fn read_any(path: &Path) -> Result<(Tracks, Format, Vec<String>)> {
    let mut opt = IngestOptions::default();
    apply_settings(path, &mut opt)?;
    let format = match opt.format.unwrap_or(Format::Auto) {
        Format::Auto => detect(path)?,
        f => f,
    };
    if format == Format::Trackpy && opt.px_per_unit.is_none() && opt.unit.is_none() {
        opt.unit = Some("px".into());
    }
    let (t, warnings, _) = read_input(path, format, &opt)?;
    Ok((t, format, warnings))
}

/// A pillar run's bar faces for each tracks frame, from `bar_forces.parquet` beside the
/// tracks (matched by time when the tracks have times, else by row = frame).
fn read_bars(tracks_file: &Path, t: &Tracks, opt: &RenderOptions) -> Result<Option<Bars>> {
    let dir = tracks_file.parent().unwrap_or(Path::new("."));
    let path = dir.join("bar_forces.parquet");
    if !opt.bars || !path.is_file() {
        return Ok(None);
    }
    let tab = read_table(
        &path,
        &[
            ("time", Expect::Float),
            ("top_y", Expect::Float),
            ("bottom_y", Expect::Float),
        ],
    )?;
    let (time, top, bottom) = (tab.f64("time")?, tab.f64("top_y")?, tab.f64("bottom_y")?);
    if time.is_empty() {
        return Ok(None);
    }
    let frames = t.frame_ranges();
    let mut faces = Vec::with_capacity(frames.len());
    for (k, (f, r)) in frames.iter().enumerate() {
        let i = match &t.time {
            Some(tt) => {
                let tf = tt[r.start];
                // Nearest bar row in time (the run writes one per frame).
                let j = time.partition_point(|&v| v < tf);
                [j.saturating_sub(1), j.min(time.len() - 1)]
                    .into_iter()
                    .min_by(|&a, &b| (time[a] - tf).abs().total_cmp(&(time[b] - tf).abs()))
                    .expect("two candidates")
            }
            None => usize::try_from(*f).unwrap_or(k).min(time.len() - 1),
        };
        faces.push((top[i], bottom[i]));
    }
    let d = t.large_diameter().unwrap_or(0.0);
    let thickness = opt.bar_thickness.unwrap_or(2.0 * d);
    if !(thickness > 0.0 && thickness.is_finite()) {
        return Err(Error::param(
            "bar-thickness",
            format!("{thickness}: must be > 0 (length unit)"),
        ));
    }
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for i in 0..t.len() {
        lo = lo.min(t.x[i] - t.radius[i]);
        hi = hi.max(t.x[i] + t.radius[i]);
    }
    Ok(Some(Bars {
        source: path,
        faces,
        thickness,
        x_range: (lo - d, hi + d),
    }))
}

/// Renders `input` (a tracks table or a pillar run's folder) into `out`.
pub fn run(input: &Path, out: &Path, opt: &RenderOptions) -> Result<RenderReport> {
    let t0 = std::time::Instant::now();
    if !(opt.px_per_unit > 0.0 && opt.px_per_unit.is_finite()) {
        return Err(Error::param(
            "px-per-unit",
            format!(
                "{}: must be > 0 (pixels per length unit of the tracks)",
                opt.px_per_unit
            ),
        ));
    }
    if opt.every < 1 {
        return Err(Error::param("every", format!("{}: must be ≥ 1", opt.every)));
    }
    if !(opt.margin_px >= 0.0 && opt.margin_px.is_finite()) {
        return Err(Error::param(
            "margin",
            format!("{}: must be ≥ 0 px", opt.margin_px),
        ));
    }
    if !(opt.bar_level >= 0.0 && opt.bar_level.is_finite()) {
        return Err(Error::param(
            "bar-level",
            format!("{}: a fraction of full scale ≥ 0", opt.bar_level),
        ));
    }
    // Settings other than the size are checked before any work.
    Camera {
        width: 1,
        height: 1,
        ..opt.camera.clone()
    }
    .validate()?;
    let file = tracks_path(input);
    if !file.exists() {
        return Err(Error::io(
            &file,
            std::io::Error::new(std::io::ErrorKind::NotFound, "input file not found"),
        ));
    }
    let hasher = {
        let file = file.clone();
        std::thread::spawn(move || {
            crate::io::hash::lower_this_thread_priority();
            sha256_file(&file)
        })
    };
    let (t, format, mut warnings) = read_any(&file)?;
    if t.is_empty() {
        return Err(Error::input(file.display(), "no rows: nothing to render"));
    }
    let bars = read_bars(&file, &t, opt)?;

    // The frames to render.
    let ranges = t.frame_ranges();
    let first = ranges[0].0;
    let chosen: Vec<(usize, i64, std::ops::Range<usize>)> = ranges
        .iter()
        .enumerate()
        .filter(|(_, (f, _))| (f - first) % opt.every == 0)
        .map(|(k, (f, r))| (k, *f, r.clone()))
        .collect();

    // One mapping for every frame: the content box over all of them.
    let (mut xr, mut yr) = (
        (f64::INFINITY, f64::NEG_INFINITY),
        (f64::INFINITY, f64::NEG_INFINITY),
    );
    for (_, _, r) in &chosen {
        for i in r.clone() {
            let (x, y, rad) = (t.x[i], t.y[i], t.radius[i]);
            xr = (xr.0.min(x - rad), xr.1.max(x + rad));
            yr = (yr.0.min(y - rad), yr.1.max(y + rad));
        }
    }
    if let Some(b) = &bars {
        xr = (xr.0.min(b.x_range.0), xr.1.max(b.x_range.1));
        for (k, _, _) in &chosen {
            let (top, bottom) = b.faces[*k];
            yr = (yr.0.min(bottom - b.thickness), yr.1.max(top + b.thickness));
        }
    }
    if !(xr.0.is_finite() && xr.1.is_finite() && yr.0.is_finite() && yr.1.is_finite()) {
        return Err(Error::input(
            file.display(),
            "no finite positions and radii to render",
        ));
    }
    let (map, fit_w, fit_h) = PixelMap::fit(xr, yr, opt.px_per_unit, opt.margin_px);
    let mut cam = opt.camera.clone();
    if cam.width == 0 {
        cam.width = fit_w;
    }
    if cam.height == 0 {
        cam.height = fit_h;
    }
    if cam.width < fit_w || cam.height < fit_h {
        warnings.push(format!(
            "the frame ({} × {} px) is smaller than the content plus the margin ({fit_w} × {fit_h} px): grains beyond the edges are cut",
            cam.width, cam.height
        ));
    }
    cam.validate()?;

    prepare_output(out, opt.overwrite)?;
    let ext = opt.format.ext();
    let name = |k: usize| format!("frame_{k:05}.{ext}");
    let bar = crate::stages::progress(chosen.len() as u64, "render", opt.quiet);
    let scale = opt.px_per_unit;
    let cam_ref = &cam;
    chosen
        .par_iter()
        .enumerate()
        .try_for_each(|(img, (k, f, r))| -> Result<()> {
            if crate::interrupt::requested().is_some()
                && let Some(e) = Error::interrupted(format!(
                "render into {}: frames written so far are complete; render again with --overwrite",
                out.display()
            )) {
                return Err(e);
            }
            let disks: Vec<Disk> = r
                .clone()
                .map(|i| Disk {
                    x: map.col(t.x[i]),
                    y: map.row(t.y[i]),
                    radius: t.radius[i] * scale,
                    brightness: cam_ref.grain_factor(t.particle[i]),
                })
                .collect();
            let rects: Vec<Rect> = match &bars {
                Some(b) => {
                    let (top, bottom) = b.faces[*k];
                    let (x0, x1) = (map.col(b.x_range.0), map.col(b.x_range.1));
                    vec![
                        Rect {
                            x0,
                            x1,
                            y0: map.row(top + b.thickness),
                            y1: map.row(top),
                            level: opt.bar_level,
                        },
                        Rect {
                            x0,
                            x1,
                            y0: map.row(bottom),
                            y1: map.row(bottom - b.thickness),
                            level: opt.bar_level,
                        },
                    ]
                }
                None => Vec::new(),
            };
            let frame = render_frame(&disks, &rects, cam_ref, *f as u64)?;
            write_frame(&frame, &out.join(name(img)))?;
            bar.inc(1);
            Ok(())
        })?;
    bar.finish_and_clear();

    // The ground truth: every drawn grain, image frame numbers.
    let gt = out.join("ground_truth.csv");
    atomic_write(&gt, |fh| {
        let mut w = std::io::BufWriter::new(fh);
        let io = |e| Error::io(&gt, e);
        writeln!(w, "{}", GROUND_TRUTH_COLUMNS.join(",")).map_err(io)?;
        for (img, (_, _, r)) in chosen.iter().enumerate() {
            for i in r.clone() {
                let sp = t
                    .species
                    .as_ref()
                    .map(|s| s[i].to_string())
                    .unwrap_or_default();
                writeln!(
                    w,
                    "{img},{},{sp},{},{},{},{},{},{}",
                    t.particle[i],
                    map.col(t.x[i]),
                    map.row(t.y[i]),
                    t.radius[i] * scale,
                    t.x[i],
                    t.y[i],
                    t.radius[i]
                )
                .map_err(io)?;
            }
        }
        w.flush().map_err(io)
    })?;

    let frame_interval = t
        .meta
        .frame_time
        .or_else(|| {
            // From the time column: the median step between consecutive frames.
            let tt = t.time.as_ref()?;
            let mut steps: Vec<f64> = ranges
                .windows(2)
                .map(|w| (tt[w[1].1.start] - tt[w[0].1.start]) / (w[1].0 - w[0].0) as f64)
                .filter(|v| v.is_finite())
                .collect();
            steps.sort_by(f64::total_cmp);
            (!steps.is_empty()).then(|| steps[steps.len() / 2])
        })
        .map(|dt| dt * opt.every as f64);
    if frame_interval.is_none() {
        warnings.push("the tracks have no frame time: frame_interval is null".into());
    }
    let sha = hasher
        .join()
        .map_err(|_| Error::Other("the hashing thread panicked".into()))??;
    let grains: usize = chosen.iter().map(|(_, _, r)| r.len()).sum();
    let record = serde_json::json!({
        "tool": crate::stages::TOOL,
        "tool_version": crate::stages::VERSION,
        "input": file.display().to_string(),
        "input_format": format!("{format:?}").to_lowercase(),
        "input_sha256": sha,
        "camera": &cam,
        "seed": cam.seed,
        "pixel_map": {
            "px_per_unit": map.px_per_unit,
            "x0": map.x0,
            "y0": map.y0,
            "x_px": "(x - x0) * px_per_unit",
            "y_px": "(y0 - y) * px_per_unit",
            "convention": "x_px is the column, y_px the row (pointing down), pixel centres on whole numbers",
        },
        "margin_px": opt.margin_px,
        "length_unit": t.meta.length_unit,
        "time_unit": t.meta.time_unit,
        "bar_speed": t.meta.bar_speed,
        "frame_interval": frame_interval,
        "every": opt.every,
        "frames": chosen.len(),
        "source_frames": chosen.iter().map(|(_, f, _)| *f).collect::<Vec<_>>(),
        "files": format!("frame_%05d.{ext}"),
        "image_format": opt.format,
        "ground_truth": "ground_truth.csv",
        "bars": bars.as_ref().map(|b| serde_json::json!({
            "source": b.source.display().to_string(),
            "thickness": b.thickness,
            "x_range": [b.x_range.0, b.x_range.1],
            "level": opt.bar_level,
        })),
        "warnings": &warnings,
    });
    atomic_write_str(
        &out.join("camera.json"),
        &serde_json::to_string_pretty(&record).expect("json"),
    )?;
    Ok(RenderReport {
        output: out.to_path_buf(),
        frames: chosen.len(),
        width: cam.width,
        height: cam.height,
        grains,
        bars: bars.is_some(),
        elapsed_s: t0.elapsed().as_secs_f64(),
        warnings,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_file_names() {
        assert!(is_frame_file("frame_00000.png"));
        assert!(is_frame_file("frame_123456.tif"));
        assert!(!is_frame_file("frame_.png"));
        assert!(!is_frame_file("frame_0001a.png"));
        assert!(!is_frame_file("notes.png"));
        assert!(!is_frame_file("frame_00001.jpg"));
    }
}
