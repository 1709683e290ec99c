//! Locating grains in a frame: the Crocker–Grier method as trackpy 0.7's `locate` does
//! it (J. C. Crocker & D. G. Grier, J. Colloid Interface Sci. 179, 298 (1996); trackpy's
//! `feature.locate`, `find.grey_dilation`, `refine.center_of_mass`,
//! `uncertainty.measure_noise` and `_static_error`), with trackpy's parameter names and
//! meanings:
//!
//! 1. band-pass: Gaussian low-pass of σ = `noise_size` minus a `smoothing_size` boxcar,
//!    values below `threshold` set to 0;
//! 2. local maxima: pixels equal to the grey dilation of the band-passed image over a
//!    square of side ⌊2·separation/√2⌋, brighter than the `percentile` of its non-zero
//!    pixels, farther than max(r, ⌊separation/2⌋ − 1, ⌊smoothing_size/2⌋) from the edges;
//! 3. refinement: centroid of the band-passed brightness in the disk of radius
//!    r = ⌊diameter/2⌋, the disk moved a pixel while the centroid is more than 0.6 px off
//!    its centre, at most `max_iterations` times;
//! 4. of two grains closer than `separation` the dimmer (smaller `mass`) is dropped;
//!    grains with `mass` ≤ `minmass` or `size` ≥ `maxsize` are dropped;
//! 5. characterisation in the same disk: `mass` (Σ band-passed), `size` (radius of
//!    gyration, √(Σ r²·I / mass)), `ecc` (|Σ I·e^{2iθ}| / (mass − centre pixel)),
//!    `signal` (peak), `raw_mass` (Σ raw), and `ep` = σ_noise / (raw_mass − N_px·black)
//!    · noise_size · √(Σ_disk x²), with black level and σ_noise measured on the raw
//!    pixels farther than r from any non-zero band-passed pixel.
//!
//! One difference, deliberate: trackpy rescales the band-passed image to the integer
//! range (0–255 for 8-bit frames) and truncates before steps 2–5, then divides `mass`
//! and `signal` by the scale; here the band-passed image stays in floating point, so
//! `mass` and `signal` are in the frame's grey levels as trackpy's are, without the
//! truncation (which biases trackpy's centroids towards flat plateaus).

use super::Feature;
use super::filters::{bandpass, dilate, give, take};
use super::frame::{Frame, read_frame_hashed};
use crate::error::{Error, Result};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// trackpy's `locate` parameters (lengths in px, brightness in the frame's grey levels).
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize, PartialEq)]
pub struct LocateParams {
    /// Feature diameter, px; odd. The refinement disk has radius ⌊diameter/2⌋.
    pub diameter: usize,
    /// Smallest integrated band-passed brightness kept (trackpy's default 0).
    pub minmass: f64,
    /// Largest radius of gyration kept, px.
    pub maxsize: Option<f64>,
    /// Smallest distance between two grains, px (default diameter + 1).
    pub separation: Option<f64>,
    /// σ of the Gaussian low-pass, px (default 1).
    pub noise_size: f64,
    /// Side of the boxcar background, px, odd (default diameter).
    pub smoothing_size: Option<usize>,
    /// Band-passed values below this are set to 0, grey levels (default 1).
    pub threshold: Option<f64>,
    /// Dark grains on a bright background.
    pub invert: bool,
    /// A local maximum must be brighter than this percentile of the non-zero
    /// band-passed pixels (default 64).
    pub percentile: f64,
    /// Keep only the `topn` brightest grains of each frame.
    pub topn: Option<usize>,
    /// Refinement steps at most (default 10).
    pub max_iterations: usize,
}

impl Default for LocateParams {
    fn default() -> Self {
        Self {
            diameter: 11,
            minmass: 0.0,
            maxsize: None,
            separation: None,
            noise_size: 1.0,
            smoothing_size: None,
            threshold: None,
            invert: false,
            percentile: 64.0,
            topn: None,
            max_iterations: 10,
        }
    }
}

fn param(name: &str, msg: impl Into<String>) -> Error {
    Error::Param {
        name: name.into(),
        msg: msg.into(),
    }
}

/// The parameters with trackpy's defaults filled in, checked.
#[derive(Debug, Clone, Copy)]
struct Resolved {
    radius: usize,
    separation: f64,
    smoothing_size: usize,
    threshold: f32,
}

impl LocateParams {
    /// An error naming the first parameter out of its domain (what `locate` checks
    /// before reading a frame).
    pub fn check(&self) -> Result<()> {
        self.resolve().map(|_| ())
    }

    fn resolve(&self) -> Result<Resolved> {
        if self.diameter < 3 || self.diameter.is_multiple_of(2) {
            return Err(param(
                "diameter",
                format!(
                    "{} px; expected an odd number of pixels, at least 3 (trackpy's rule: round up)",
                    self.diameter
                ),
            ));
        }
        let separation = self.separation.unwrap_or(self.diameter as f64 + 1.0);
        if !(separation >= 0.0) || !separation.is_finite() {
            return Err(param(
                "separation",
                format!("{separation}; expected ≥ 0 px"),
            ));
        }
        let smoothing_size = self.smoothing_size.unwrap_or(self.diameter);
        if smoothing_size.is_multiple_of(2) {
            return Err(param(
                "smoothing_size",
                format!("{smoothing_size} px; expected an odd number of pixels"),
            ));
        }
        if !(self.noise_size >= 0.0) || self.noise_size >= smoothing_size as f64 {
            return Err(param(
                "noise_size",
                format!(
                    "{} px; expected ≥ 0 and below smoothing_size ({smoothing_size} px)",
                    self.noise_size
                ),
            ));
        }
        if !(0.0..=100.0).contains(&self.percentile) {
            return Err(param(
                "percentile",
                format!("{}; expected 0 to 100", self.percentile),
            ));
        }
        if !self.minmass.is_finite() {
            return Err(param("minmass", "expected a finite number"));
        }
        if let Some(m) = self.maxsize
            && !(m > 0.0)
        {
            return Err(param("maxsize", format!("{m} px; expected > 0")));
        }
        let threshold = self.threshold.unwrap_or(1.0);
        if !threshold.is_finite() {
            return Err(param("threshold", "expected a finite number"));
        }
        if self.max_iterations == 0 {
            return Err(param("max_iterations", "expected at least 1"));
        }
        Ok(Resolved {
            radius: self.diameter / 2,
            separation,
            smoothing_size,
            threshold: threshold as f32,
        })
    }
}

/// The refinement disk: offsets (dy, dx) with dy² + dx² ≤ r², row by row.
struct Disk {
    r: i64,
    /// Row by row: dy and the half-width ⌊√(r² − dy²)⌋; the pixels (dy, dx) with
    /// dy² + dx² ≤ r², in the row-major order of the arrays below.
    spans: Vec<(i64, i64)>,
    /// dy² + dx² (trackpy's `r_squared_mask`).
    r2: Vec<f64>,
    /// cos 2θ and sin 2θ, θ = atan2(dy, dx) (trackpy's `cosmask`, `sinmask`).
    cos2: Vec<f64>,
    sin2: Vec<f64>,
    /// √(Σ dx²) over the disk (trackpy's `_root_sum_x_squared`).
    root_sum_x2: f64,
}

impl Disk {
    fn new(r: usize) -> Self {
        let r = r as i64;
        let (mut r2, mut cos2, mut sin2) = (vec![], vec![], vec![]);
        let mut sx2 = 0.0;
        for y in -r..=r {
            for x in -r..=r {
                if y * y + x * x <= r * r {
                    r2.push((y * y + x * x) as f64);
                    let t = (y as f64).atan2(x as f64);
                    cos2.push((2.0 * t).cos());
                    sin2.push((2.0 * t).sin());
                    sx2 += (x * x) as f64;
                }
            }
        }
        let spans = (-r..=r)
            .map(|y| (y, (((r * r - y * y) as f64).sqrt()).floor() as i64))
            .collect();
        Self {
            r,
            spans,
            r2,
            cos2,
            sin2,
            root_sum_x2: sx2.sqrt(),
        }
    }
    fn len(&self) -> usize {
        self.r2.len()
    }
}

/// numpy's `percentile` (linear interpolation) of the non-zero values of an image of
/// whole numbers in 0..=`max`; `None` when every value is zero. A counting histogram
/// gives the two order statistics exactly, in one pass.
#[inline(never)]
fn percentile_of_nonzero(img: &[f32], p: f64, max: f32) -> Option<f32> {
    let mut hist = vec![0u32; max as usize + 1];
    for &v in img {
        hist[(v as usize).min(max as usize)] += 1;
    }
    let n: u64 = hist[1..].iter().map(|&c| u64::from(c)).sum();
    if n == 0 {
        return None;
    }
    let pos = p / 100.0 * (n - 1) as f64;
    let lo = pos.floor() as u64;
    let frac = (pos - lo as f64) as f32;
    // The value holding order statistic k (0-based) among the non-zero ones.
    let nth = |k: u64| {
        let mut seen = 0u64;
        for (v, &c) in hist.iter().enumerate().skip(1) {
            seen += u64::from(c);
            if seen > k {
                return v as f32;
            }
        }
        max
    };
    let a = nth(lo);
    if frac == 0.0 || lo + 1 >= n {
        return Some(a);
    }
    Some(a + frac * (nth(lo + 1) - a))
}

/// Horizontal distance from each pixel of a row to the nearest non-zero band-passed
/// pixel of that row, saturating at `u16::MAX`.
fn row_distance(row: &[f32], d: &mut [u16]) {
    let mut last = u16::MAX;
    for (x, v) in row.iter().enumerate() {
        last = if *v != 0.0 { 0 } else { last.saturating_add(1) };
        d[x] = last;
    }
    let mut last = u16::MAX;
    for x in (0..row.len()).rev() {
        last = if row[x] != 0.0 {
            0
        } else {
            last.saturating_add(1)
        };
        d[x] = d[x].min(last);
    }
}

/// Mean and population standard deviation of the raw pixels farther than r from
/// every non-zero band-passed pixel (trackpy's `measure_noise`: the background is
/// `~binary_dilation(bp, disk(r))`); NaN where there is too little background, as
/// there. A pixel is background when, for every row offset dy within the disk, the
/// horizontal distance to the nearest non-zero pixel of row y + dy exceeds the disk's
/// half-width there. Those distances are kept for the 2r + 1 rows in reach only.
#[inline(never)]
fn measure_noise(raw: &[f32], bp: &[f32], w: usize, r: usize) -> (f64, f64) {
    let h = bp.len() / w;
    let ri = r as i64;
    let far = u16::MAX;
    let half: Vec<u16> = (-ri..=ri)
        .map(|dy| ((((ri * ri - dy * dy) as f64).sqrt()).floor() as u64).min(u64::from(far)) as u16)
        .collect();
    let span = 2 * r + 1;
    let mut ring = vec![far; span * w];
    let mut bg = vec![1u8; w];
    let (mut n, mut s, mut s2) = (0usize, 0.0f64, 0.0f64);
    for y in 0..h as i64 {
        if y == 0 {
            for yy in 0..=ri.min(h as i64 - 1) {
                let slot = yy as usize % span;
                row_distance(
                    &bp[yy as usize * w..(yy as usize + 1) * w],
                    &mut ring[slot * w..(slot + 1) * w],
                );
            }
        } else if y + ri < h as i64 {
            let yy = (y + ri) as usize;
            let slot = yy % span;
            row_distance(
                &bp[yy * w..(yy + 1) * w],
                &mut ring[slot * w..(slot + 1) * w],
            );
        }
        // Every row in reach, whole rows at a time: u8 and a branch-free `&` so the
        // comparisons vectorise (the frame around a pillar is mostly background).
        bg.fill(1);
        for (k, dy) in (-ri..=ri).enumerate() {
            let yy = y + dy;
            if yy < 0 || yy >= h as i64 {
                continue;
            }
            let slot = yy as usize % span;
            let lim = half[k];
            for (o, &d) in bg.iter_mut().zip(&ring[slot * w..(slot + 1) * w]) {
                *o &= u8::from(d > lim);
            }
        }
        let raw_row = &raw[y as usize * w..(y as usize + 1) * w];
        // Branch-free: the mask weighs each pixel 0 or 1.
        for (&v, &b) in raw_row.iter().zip(&bg) {
            let (v, m) = (f64::from(v), f64::from(b));
            n += usize::from(b);
            s += m * v;
            s2 += m * v * v;
        }
    }
    match n {
        0 => (f64::NAN, f64::NAN),
        1 => (s, f64::NAN),
        _ => {
            let m = s / n as f64;
            (m, (s2 / n as f64 - m * m).max(0.0).sqrt())
        }
    }
}

/// Locates the grains of one frame (trackpy's `locate` on it), in row-major order of
/// their first local maximum.
pub fn locate(frame: &Frame, frame_no: i64, p: &LocateParams) -> Result<Vec<Feature>> {
    let rs = p.resolve()?;
    let (w, h) = (frame.width, frame.height);
    let raw: std::borrow::Cow<[f32]> = if p.invert {
        let m = frame.max_value();
        frame.pixels.iter().map(|v| m - v).collect()
    } else {
        std::borrow::Cow::Borrowed(&frame.pixels)
    };
    if w == 0 || h == 0 {
        return Ok(Vec::new());
    }
    let bp = bandpass(&raw, w, p.noise_size, rs.smoothing_size, rs.threshold);
    // Maxima are picked as trackpy picks them, on the band-passed image scaled to the
    // frame's integer range and truncated (`convert_to_int`): the percentile and the
    // plateaus of that image decide which grains are candidates (a float image would
    // set the threshold half a level higher and lose dim grains trackpy keeps). The
    // centroids and masses are then taken on the unrounded image.
    let peak = bp.iter().copied().fold(0.0f32, f32::max);
    let scale = if peak > 0.0 {
        frame.max_value() / peak
    } else {
        1.0
    };
    // bp ≥ 0, so truncation is the floor (and, unlike `floor`, vectorises).
    let mut q = take(0);
    q.extend(bp.iter().map(|&v| (v * scale) as i32 as f32));
    let Some(level) = percentile_of_nonzero(&q, p.percentile, frame.max_value()) else {
        give(q);
        give(bp);
        return Ok(Vec::new());
    };
    let box_side = (2.0 * rs.separation / std::f64::consts::SQRT_2) as usize;
    let dil = dilate(&q, w, box_side);
    let sep_half = (rs.separation / 2.0).floor() as i64 - 1;
    let margin = (rs.radius as i64)
        .max(sep_half)
        .max((rs.smoothing_size / 2) as i64);
    let disk = Disk::new(rs.radius);
    let mut found = Vec::new();
    for y in margin..h as i64 - margin {
        for x in margin..w as i64 - margin {
            let i = y as usize * w + x as usize;
            if q[i] > level && q[i] == dil[i] {
                found.push(refine(&raw, &bp, w, h, &disk, y, x, p.max_iterations));
            }
        }
    }
    give(dil);
    give(q);
    drop_close(&mut found, rs.separation);
    found.retain(|f| f.mass > p.minmass && p.maxsize.is_none_or(|m| f.size < m));
    if let Some(n) = p.topn
        && found.len() > n
    {
        let mut order: Vec<usize> = (0..found.len()).collect();
        order.sort_by(|&a, &b| found[b].mass.total_cmp(&found[a].mass).then(a.cmp(&b)));
        let mut keep = vec![false; found.len()];
        order[..n].iter().for_each(|&i| keep[i] = true);
        let mut k = keep.iter();
        found.retain(|_| *k.next().unwrap_or(&false));
    }
    if !found.is_empty() {
        let (black, noise) = measure_noise(&raw, &bp, w, rs.radius);
        let npx = disk.len() as f64;
        for f in &mut found {
            f.ep = noise / (f.raw_mass - npx * black) * p.noise_size * disk.root_sum_x2;
        }
    }
    give(bp);
    for f in &mut found {
        f.frame = frame_no;
    }
    Ok(found)
}

/// Σ v and Σ v·dx over one row of the disk (dx = −half … half), in four interleaved
/// partial sums so the additions do not wait on each other (a fixed order: the same
/// result on every machine and thread count).
#[inline]
fn row_moments(row: &[f32], half: i64) -> (f64, f64) {
    let (mut s, mut sw) = ([0.0f64; 4], [0.0f64; 4]);
    let mut chunks = row.chunks_exact(4);
    let mut dx = -half as f64;
    for c in &mut chunks {
        for l in 0..4 {
            let v = f64::from(c[l]);
            s[l] += v;
            sw[l] += v * (dx + l as f64);
        }
        dx += 4.0;
    }
    for (l, &v) in chunks.remainder().iter().enumerate() {
        let v = f64::from(v);
        s[l] += v;
        sw[l] += v * (dx + l as f64);
    }
    (
        (s[0] + s[1]) + (s[2] + s[3]),
        (sw[0] + sw[1]) + (sw[2] + sw[3]),
    )
}

/// trackpy's `_numba_refine_2D_c` for one maximum at (y, x).
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn refine(
    raw: &[f32],
    bp: &[f32],
    w: usize,
    h: usize,
    disk: &Disk,
    mut cy: i64,
    mut cx: i64,
    max_iterations: usize,
) -> Feature {
    const SHIFT: f64 = 0.6;
    let r = disk.r;
    let px = |y: i64, x: i64| f64::from(bp[y as usize * w + x as usize]);
    let (mut oy, mut ox, mut mass) = (0.0, 0.0, 0.0);
    let (mut sy, mut sx) = (cy, cx);
    for _ in 0..max_iterations {
        sy = cy;
        sx = cx;
        let (mut my, mut mx) = (0.0, 0.0);
        mass = 0.0;
        // Row spans of the disk: per row the sum and the dx-weighted sum.
        for &(dy, half) in &disk.spans {
            let start = (cy + dy) as usize * w + (cx - half) as usize;
            let (s, sw) = row_moments(&bp[start..=start + 2 * half as usize], half);
            my += s * dy as f64;
            mx += sw;
            mass += s;
        }
        if mass <= 0.0 {
            oy = 0.0;
            ox = 0.0;
            break;
        }
        oy = my / mass;
        ox = mx / mass;
        if oy.abs() < SHIFT && ox.abs() < SHIFT {
            break;
        }
        if oy > SHIFT {
            cy += 1;
        } else if oy < -SHIFT {
            cy -= 1;
        }
        if ox > SHIFT {
            cx += 1;
        } else if ox < -SHIFT {
            cx -= 1;
        }
        cy = cy.clamp(r, h as i64 - 1 - r);
        cx = cx.clamp(r, w as i64 - 1 - r);
    }
    let (mut rg, mut e1, mut e2, mut signal, mut raw_mass) = (0.0, 0.0, 0.0, 0.0f64, 0.0);
    // The disk's pixels in its row-major order: k runs along with the spans.
    let mut k = 0;
    for &(dy, half) in &disk.spans {
        let start = (sy + dy) as usize * w + (sx - half) as usize;
        let len = 2 * half as usize + 1;
        let (bp_row, raw_row) = (&bp[start..start + len], &raw[start..start + len]);
        let (r2, c2, s2) = (
            &disk.r2[k..k + len],
            &disk.cos2[k..k + len],
            &disk.sin2[k..k + len],
        );
        for j in 0..len {
            let v = f64::from(bp_row[j]);
            rg += r2[j] * v;
            e1 += c2[j] * v;
            e2 += s2[j] * v;
            signal = signal.max(v);
            raw_mass += f64::from(raw_row[j]);
        }
        k += len;
    }
    let centre = px(sy, sx);
    Feature {
        frame: 0,
        x: sx as f64 + ox,
        y: sy as f64 + oy,
        mass,
        size: (rg / mass).sqrt(),
        ecc: (e1 * e1 + e2 * e2).sqrt() / (mass - centre + 1e-6),
        signal,
        raw_mass,
        ep: f64::NAN,
    }
}

/// trackpy's `where_close` + drop: of every pair closer than `separation`, the one
/// with the smaller mass goes (equal masses: the one nearer the top left).
fn drop_close(found: &mut Vec<Feature>, separation: f64) {
    if separation <= 0.0 || found.len() < 2 {
        return;
    }
    let cut = separation * (1.0 - 1e-7);
    let cell = separation;
    let key = |f: &Feature| ((f.x / cell).floor() as i64, (f.y / cell).floor() as i64);
    let mut grid: std::collections::HashMap<(i64, i64), Vec<usize>> = Default::default();
    for (i, f) in found.iter().enumerate() {
        grid.entry(key(f)).or_default().push(i);
    }
    let mut drop = vec![false; found.len()];
    for (i, a) in found.iter().enumerate() {
        let (kx, ky) = key(a);
        for gx in kx - 1..=kx + 1 {
            for gy in ky - 1..=ky + 1 {
                let Some(cands) = grid.get(&(gx, gy)) else {
                    continue;
                };
                for &j in cands {
                    if j <= i {
                        continue;
                    }
                    let b = &found[j];
                    if (a.x - b.x).hypot(a.y - b.y) < cut {
                        let loser = if a.mass > b.mass {
                            j
                        } else if b.mass > a.mass {
                            i
                        } else if a.x + a.y > b.x + b.y {
                            j
                        } else {
                            i
                        };
                        drop[loser] = true;
                    }
                }
            }
        }
    }
    let mut d = drop.iter();
    found.retain(|_| !*d.next().unwrap_or(&false));
}

/// What locating a movie found.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct LocateReport {
    pub frames: usize,
    pub width: usize,
    pub height: usize,
    pub bit_depth: u8,
    pub features: usize,
    pub per_frame_min: usize,
    pub per_frame_max: usize,
    /// SHA-256 of each frame file, in frame order.
    pub frame_sha256: Vec<String>,
}

/// Locates every frame (frame numbers 0, 1, … in the order given), frames in
/// parallel; the result does not depend on the thread count. Every frame must have the
/// first one's size and bit depth. `on_frame` is called after each frame (progress).
pub fn locate_frames(
    paths: &[PathBuf],
    p: &LocateParams,
    on_frame: &(dyn Fn() + Sync),
) -> Result<(Vec<Feature>, LocateReport)> {
    p.resolve()?;
    let Some(first_path) = paths.first() else {
        return Err(param("FRAMES", "no frames given"));
    };
    let first = read_frame_hashed(first_path)?;
    let shape = (first.0.width, first.0.height, first.0.bit_depth);
    let per_frame: Vec<(Vec<Feature>, String)> = paths
        .par_iter()
        .enumerate()
        .map(|(i, path)| {
            let (frame, hash) = if i == 0 {
                first.clone()
            } else {
                read_frame_hashed(path)?
            };
            check_shape(path, &frame, first_path, shape)?;
            let out = locate(&frame, i as i64, p)?;
            give(frame.pixels);
            on_frame();
            Ok((out, hash))
        })
        .collect::<Result<_>>()?;
    let (per_frame, frame_sha256): (Vec<Vec<Feature>>, Vec<String>) = per_frame.into_iter().unzip();
    let counts: Vec<usize> = per_frame.iter().map(Vec::len).collect();
    let report = LocateReport {
        frames: paths.len(),
        width: shape.0,
        height: shape.1,
        bit_depth: shape.2,
        features: counts.iter().sum(),
        per_frame_min: counts.iter().copied().min().unwrap_or(0),
        per_frame_max: counts.iter().copied().max().unwrap_or(0),
        frame_sha256,
    };
    Ok((per_frame.into_iter().flatten().collect(), report))
}

fn check_shape(path: &Path, f: &Frame, first: &Path, shape: (usize, usize, u8)) -> Result<()> {
    if (f.width, f.height, f.bit_depth) != shape {
        return Err(Error::Input {
            file: path.display().to_string(),
            msg: format!(
                "a {}×{} {}-bit frame; the movie's first frame ({}) is {}×{} {}-bit: every frame must have the same size and depth",
                f.width,
                f.height,
                f.bit_depth,
                first.display(),
                shape.0,
                shape.1,
                shape.2
            ),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests;
