//! The camera emulator: grains (disks) and bars (rectangles) in pixel coordinates → one
//! grey-scale frame, with the optics and the sensor of a real camera: a soft grain edge,
//! per-grain brightness, an illumination gradient, Gaussian blur, shot and read noise,
//! 8- or 16-bit quantisation. Pure: no files; `stages::render` maps tracks to disks.
//!
//! Coordinates are trackpy's: `x` the column, `y` the row (pointing down), pixel centres
//! on whole numbers, so pixel `(row, col)` covers `[col − ½, col + ½] × [row − ½, row + ½]`.
//!
//! Each pixel's value is the *area integral* over the pixel of the scene as the lens
//! images it:
//!
//! 1. grains and bars are summed above the background (a linear scene: where two grains
//!    touch their soft edges add up, as the blur of a real image does). The lens's
//!    Gaussian blur (`blur_px`) is part of each shape, before the pixels integrate it:
//!    a flat or dome grain's edge has width √(edge² + blur²), a gaussian grain's σ² grows
//!    by blur² (its peak falls so its integral stays), a bar is the exact pixel integral
//!    of the blurred rectangle. Grains are integrated over each pixel on an n × n grid
//!    that resolves the edge (the leftover error ~ exp(−2π² n² σ²) < 1e-8), so a disk's
//!    intensity-weighted centroid sits at its true centre: within 1e-4 px for an edge
//!    of σ ≥ 0.5 px; a sharper edge (σ ≈ 0.1 px) shows the pixel locking of a real
//!    sensor, a few 1e-3 px for a 4 px grain;
//! 2. the background is added and the whole multiplied by the illumination (gradient
//!    and the frame's flicker);
//! 3. shot noise (Poisson photon counts, `photons` at full scale) and read noise
//!    (normal, `read_noise` grey levels) are drawn, and the value rounded and clamped to
//!    the bit depth's range.
//!
//! The noise of frame `k` comes from a generator seeded by `(seed, k)` only, so frames
//! rendered in any order, on any number of threads, are identical.

use super::frame::Frame;
use crate::error::{Error, Result};
use crate::rng::Rng;
use serde::{Deserialize, Serialize};
use std::sync::OnceLock;

/// How a grain's brightness falls off from its centre. Every profile peaks at the
/// grain's level (the camera's `grain_level` × the grain's brightness factor).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Profile {
    /// Uniform disk of radius r with a soft edge: the brightness falls as a Gaussian
    /// step (error function) of width `edge_px` centred a hair inside r, placed so the
    /// integrated brightness is exactly π r² × level (a backlit or evenly lit grain).
    #[default]
    Flat,
    /// A Gaussian spot, σ = r/2, peak = level (a fluorescent bead or a diffuse blob);
    /// integrated brightness π r² × level / 2 (the blur widens it and lowers the peak).
    Gaussian,
    /// A lit sphere: the flat disk's edge times (1 − c) + c·√(1 − ρ²/r²), brightest at
    /// the centre and (1 − c) of the peak at the rim, c = `dome_contrast`; integrated
    /// brightness π r² × level × (1 − c/3).
    Dome,
}

/// The camera's settings. Brightness levels are fractions of the full scale (255 at 8
/// bit, 65535 at 16 bit) so a camera looks the same at either depth; noise is in grey
/// levels of the chosen depth.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Camera {
    /// Frame width, px (columns).
    pub width: usize,
    /// Frame height, px (rows).
    pub height: usize,
    /// 8 or 16.
    pub bit_depth: u8,
    pub profile: Profile,
    /// A grain's peak brightness above the background, fraction of full scale, before
    /// its brightness factor.
    pub grain_level: f64,
    /// Relative spread of the grains' brightness: grain `id`'s factor is 1 + spread·z,
    /// z standard normal drawn from (seed, id) alone, so a grain keeps its brightness
    /// in every frame (at least 0).
    pub brightness_spread: f64,
    /// Width σ of the grain's own edge (flat and dome profiles), px, before the blur:
    /// the brightness falls from 84 % to 16 % of the level between r − σ and r + σ
    /// (10–90 % over 2.56 σ). With the blur the edge is √(edge² + blur²) wide; that
    /// must be at least 1/16 px.
    pub edge_px: f64,
    /// Dome profile: rim-to-centre contrast c (0 flat … 1 dark rim).
    pub dome_contrast: f64,
    /// Background brightness, fraction of full scale.
    pub background: f64,
    /// Illumination gradient: the fractional change of the illumination from one side
    /// of the frame to the other along `gradient_angle_deg` (0.2: +10 % at one side,
    /// −10 % at the other; 0 uniform).
    pub gradient: f64,
    /// Direction in which the illumination rises, degrees from the +column axis towards
    /// the +row axis (0: brighter to the right, 90: brighter towards the bottom).
    pub gradient_angle_deg: f64,
    /// Relative frame-to-frame flicker of the illumination: frame k's illumination is
    /// multiplied by 1 + flicker·z, z standard normal from (seed, k).
    pub flicker: f64,
    /// Gaussian blur σ of the optics, px (0: none); applied to the grains and bars
    /// before the pixels integrate them.
    pub blur_px: f64,
    /// Shot noise: photons collected by a pixel at full scale (Poisson counts; the
    /// normal approximation above 30 photons); 0 turns shot noise off.
    pub photons: f64,
    /// Read noise, standard deviation in grey levels of the bit depth.
    pub read_noise: f64,
    /// Seeds the grains' brightness factors and every frame's noise.
    pub seed: u64,
}

impl Default for Camera {
    /// Frames like the shared trackpy sample's: 8 bit, background ≈ 13, grains ≈ 200
    /// with an 8 % spread, a 1 px blur and a soft edge (≈ 3 px from dark to bright),
    /// shot noise of 1000 photons at full scale and 2 grey levels of read noise. The
    /// size (0 × 0) must be set.
    fn default() -> Self {
        Camera {
            width: 0,
            height: 0,
            bit_depth: 8,
            profile: Profile::Flat,
            grain_level: 0.75,
            brightness_spread: 0.08,
            edge_px: 0.5,
            dome_contrast: 0.5,
            background: 0.05,
            gradient: 0.0,
            gradient_angle_deg: 0.0,
            flicker: 0.0,
            blur_px: 1.0,
            photons: 1000.0,
            read_noise: 2.0,
            seed: 1,
        }
    }
}

/// One grain in pixel coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Disk {
    /// Column of the centre, px.
    pub x: f64,
    /// Row of the centre, px (pointing down).
    pub y: f64,
    /// Radius, px.
    pub radius: f64,
    /// Brightness factor (1: the camera's `grain_level`); `Camera::grain_factor` gives
    /// a grain's own.
    pub brightness: f64,
}

/// An axis-aligned rectangle (a bar) in pixel coordinates: columns `x0..x1`, rows
/// `y0..y1` (continuous, pixel centres on whole numbers), `level` its brightness above
/// the background as a fraction of full scale.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Rect {
    pub x0: f64,
    pub y0: f64,
    pub x1: f64,
    pub y1: f64,
    pub level: f64,
}

/// Length units ↔ pixels: `x_px = (x − x0) · px_per_unit`, `y_px = (y0 − y) ·
/// px_per_unit` (y up in the tracks, rows down in the image).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PixelMap {
    pub px_per_unit: f64,
    /// The length-unit x at column 0.
    pub x0: f64,
    /// The length-unit y at row 0.
    pub y0: f64,
}

impl PixelMap {
    pub fn col(&self, x: f64) -> f64 {
        (x - self.x0) * self.px_per_unit
    }
    pub fn row(&self, y: f64) -> f64 {
        (self.y0 - y) * self.px_per_unit
    }
    pub fn px(&self, length: f64) -> f64 {
        length * self.px_per_unit
    }
    /// The map and the frame size (width, height) that hold the content box
    /// `[xmin, xmax] × [ymin, ymax]` (length units) with at least `margin_px` between it
    /// and each edge of the frame.
    pub fn fit(
        (xmin, xmax): (f64, f64),
        (ymin, ymax): (f64, f64),
        px_per_unit: f64,
        margin_px: f64,
    ) -> (PixelMap, usize, usize) {
        let s = px_per_unit;
        // The frame's left edge is column −½: the content starts `margin_px` from it.
        let map = PixelMap {
            px_per_unit: s,
            x0: xmin - (margin_px - 0.5) / s,
            y0: ymax + (margin_px - 0.5) / s,
        };
        let width = ((xmax - xmin) * s + 2.0 * margin_px).ceil().max(1.0) as usize;
        let height = ((ymax - ymin) * s + 2.0 * margin_px).ceil().max(1.0) as usize;
        (map, width, height)
    }
}

const TAG_GRAIN: u64 = 0x0067_7261_696e;
const TAG_NOISE: u64 = 0x006e_6f69_7365;
const TAG_FLICKER: u64 = 0x0066_6c69_636b;

/// A seed for stream `tag`, item `k`, of the camera seeded with `seed`.
fn stream_seed(seed: u64, tag: u64, k: u64) -> u64 {
    let mut z = seed
        .wrapping_mul(0x9E37_79B9_7F4A_7C15)
        .wrapping_add(tag)
        .rotate_left(23)
        ^ k.wrapping_mul(0xD1B5_4A32_D192_ED03);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

fn param(name: &str, msg: impl Into<String>) -> Error {
    Error::param(name, msg)
}

impl Camera {
    /// The largest grey level (255 or 65535).
    pub fn full_scale(&self) -> f64 {
        if self.bit_depth == 16 { 65535.0 } else { 255.0 }
    }

    /// Grain `id`'s brightness factor: 1 + spread·z, z from (seed, id) alone.
    pub fn grain_factor(&self, id: i64) -> f64 {
        if self.brightness_spread == 0.0 {
            return 1.0;
        }
        let z = Rng::new(stream_seed(self.seed, TAG_GRAIN, id as u64)).normal();
        (1.0 + self.brightness_spread * z).max(0.0)
    }

    /// Frame `k`'s illumination factor from the flicker.
    pub fn flicker_factor(&self, frame_index: u64) -> f64 {
        if self.flicker == 0.0 {
            return 1.0;
        }
        let z = Rng::new(stream_seed(self.seed, TAG_FLICKER, frame_index)).normal();
        (1.0 + self.flicker * z).max(0.0)
    }

    /// The width σ of a flat or dome grain's edge as imaged: √(edge² + blur²), px.
    pub fn edge_sigma(&self) -> f64 {
        self.edge_px.hypot(self.blur_px)
    }

    /// Every setting within its domain; errors name the command-line flag.
    pub fn validate(&self) -> Result<()> {
        let finite_in = |name: &str, v: f64, lo: f64, hi: f64, what: &str| {
            if v.is_finite() && v >= lo && v <= hi {
                Ok(())
            } else {
                Err(param(name, format!("{v}: {what}")))
            }
        };
        if self.width == 0 || self.height == 0 {
            return Err(param("size", "the frame must be at least 1 × 1 px"));
        }
        if self.width.saturating_mul(self.height) > 1 << 28 {
            return Err(param(
                "size",
                format!(
                    "{} × {} px is too large (at most 2^28 pixels): lower --px-per-unit",
                    self.width, self.height
                ),
            ));
        }
        if self.bit_depth != 8 && self.bit_depth != 16 {
            return Err(param(
                "bit-depth",
                format!("{}: expected 8 or 16", self.bit_depth),
            ));
        }
        finite_in(
            "level",
            self.grain_level,
            0.0,
            1e6,
            "a fraction of full scale ≥ 0",
        )?;
        finite_in(
            "spread",
            self.brightness_spread,
            0.0,
            10.0,
            "expected 0 ≤ spread ≤ 10",
        )?;
        finite_in("edge", self.edge_px, 0.0, 1e3, "an edge width σ in px, ≥ 0")?;
        finite_in(
            "dome-contrast",
            self.dome_contrast,
            0.0,
            1.0,
            "expected 0 ≤ c ≤ 1",
        )?;
        finite_in(
            "background",
            self.background,
            0.0,
            1e6,
            "a fraction of full scale ≥ 0",
        )?;
        finite_in(
            "gradient",
            self.gradient,
            0.0,
            2.0,
            "expected 0 ≤ gradient ≤ 2 (fractional change across the frame)",
        )?;
        finite_in(
            "gradient-angle",
            self.gradient_angle_deg,
            -1e6,
            1e6,
            "degrees",
        )?;
        finite_in(
            "flicker",
            self.flicker,
            0.0,
            10.0,
            "expected 0 ≤ flicker ≤ 10",
        )?;
        finite_in("blur", self.blur_px, 0.0, 1e3, "a Gaussian σ in px, ≥ 0")?;
        if self.profile != Profile::Gaussian && self.edge_sigma() < 1.0 / 16.0 {
            return Err(param(
                "edge",
                format!(
                    "√(edge² + blur²) = {} px: the grain edge must be at least 1/16 px wide (raise --edge or --blur); the pixel integration resolves no sharper edge",
                    self.edge_sigma()
                ),
            ));
        }
        finite_in(
            "photons",
            self.photons,
            0.0,
            1e15,
            "photons at full scale, ≥ 0 (0: no shot noise)",
        )?;
        finite_in("read-noise", self.read_noise, 0.0, 1e9, "grey levels, ≥ 0")?;
        Ok(())
    }
}

/// The standard normal CDF Φ(t) on `[−T, T]` at `STEPS` points per unit, symmetric to
/// rounding (Φ(−t) = 1 − Φ(t)), so a soft edge built on it loses no brightness.
struct PhiTable {
    v: Vec<f64>,
}

const PHI_T: f64 = 6.0;
const PHI_STEPS: f64 = 256.0;
/// A grain's edge is drawn out to ±4.5 σ (Φ(−4.5) = 3.4e-6 of the level).
const EDGE_CUT: f64 = 4.5;

impl PhiTable {
    fn get() -> &'static PhiTable {
        static T: OnceLock<PhiTable> = OnceLock::new();
        T.get_or_init(|| {
            let n = (PHI_T * PHI_STEPS) as usize;
            let h = 1.0 / PHI_STEPS;
            let pdf = |t: f64| (-0.5 * t * t).exp() / (2.0 * std::f64::consts::PI).sqrt();
            // ∫₀ᵗ φ by Simpson's rule on 8 sub-intervals per step.
            let mut half = vec![0.0; n + 1];
            for k in 0..n {
                let (a, m) = (k as f64 * h, 8);
                let s = h / m as f64;
                let mut acc = pdf(a) + pdf(a + h);
                for j in 1..m {
                    acc += pdf(a + j as f64 * s) * if j % 2 == 1 { 4.0 } else { 2.0 };
                }
                half[k + 1] = half[k] + acc * s / 3.0;
            }
            // The tail beyond T (1e-9) is put back so Φ(T) = 1 exactly.
            let scale = 0.5 / half[n];
            let mut v = vec![0.0; 2 * n + 1];
            for k in 0..=n {
                v[n + k] = 0.5 + half[k] * scale;
                v[n - k] = 0.5 - half[k] * scale;
            }
            PhiTable { v }
        })
    }
    #[inline]
    fn at(&self, t: f64) -> f64 {
        // The table's ends are 0 and 1: beyond them t is clamped (NaN becomes 0).
        let last = (self.v.len() - 1) as f64 - 1e-9;
        let u = ((t + PHI_T) * PHI_STEPS).clamp(0.0, last);
        let i = u as usize;
        let f = u - i as f64;
        self.v[i] + (self.v[i + 1] - self.v[i]) * f
    }
}

/// One grain's radial profile f(ρ) in [0, 1].
struct Shape<'a> {
    profile: Profile,
    phi: &'a PhiTable,
    /// Samples per pixel side.
    n: usize,
    /// Flat, dome: the edge's centre; gaussian: unused.
    r_edge: f64,
    inv_sigma: f64,
    /// Dome: 1/r²; gaussian: 1/(2σ²).
    k2: f64,
    /// Gaussian: the peak (1 unless blurred).
    peak: f64,
    contrast: f64,
    /// f = 0 beyond this distance.
    reach: f64,
    /// Flat: f = 1 within this distance (0 otherwise).
    inner: f64,
}

impl<'a> Shape<'a> {
    fn new(cam: &Camera, r: f64, phi: &'a PhiTable) -> Self {
        // The dome's √ has a kink at the rim that the edge only softens: 4 × 4 at least.
        let (n, s) = sampling(
            cam.edge_sigma(),
            if cam.profile == Profile::Dome { 4 } else { 1 },
        );
        // Φ((r_e − ρ)/σ) integrates to π r_e² + π σ²: r_e keeps the brightness π r².
        let r_edge = (r * r - s * s).max(0.25 * r * r).sqrt();
        match cam.profile {
            Profile::Flat | Profile::Dome => Shape {
                profile: cam.profile,
                phi,
                n,
                r_edge,
                inv_sigma: 1.0 / s,
                k2: 1.0 / (r * r),
                peak: 1.0,
                contrast: cam.dome_contrast,
                reach: r_edge + EDGE_CUT * s,
                inner: if cam.profile == Profile::Flat {
                    (r_edge - EDGE_CUT * s).max(0.0)
                } else {
                    0.0
                },
            },
            Profile::Gaussian => {
                // A Gaussian blurred by a Gaussian: the variances add, the integral stays.
                let sg0 = 0.5 * r;
                let (n, sg) = sampling(sg0.hypot(cam.blur_px), 1);
                Shape {
                    profile: Profile::Gaussian,
                    phi,
                    n,
                    r_edge,
                    inv_sigma: 0.0,
                    k2: 0.5 / (sg * sg),
                    peak: (sg0 * sg0) / (sg * sg),
                    contrast: 0.0,
                    reach: 5.0 * sg,
                    inner: 0.0,
                }
            }
        }
    }

    /// Adds `amp` × the disk's pixel-integrated profile to `buf`, with the profile's
    /// function inlined into the sampling loop.
    fn add(&self, buf: &mut [f32], w: usize, h: usize, d: &Disk, amp: f64) {
        let n = self.n;
        let (phi, re, is) = (self.phi, self.r_edge, self.inv_sigma);
        let (k2, c, peak) = (self.k2, self.contrast, self.peak);
        match self.profile {
            Profile::Flat => add_disk(buf, w, h, d, amp, self, n, |r2: f64| {
                phi.at((re - r2.sqrt()) * is)
            }),
            Profile::Dome => add_disk(buf, w, h, d, amp, self, n, |r2: f64| {
                let e = phi.at((re - r2.sqrt()) * is);
                e * (1.0 - c + c * (1.0 - r2 * k2).max(0.0).sqrt())
            }),
            Profile::Gaussian => add_disk(buf, w, h, d, amp, self, n, |r2: f64| {
                peak * (-r2 * k2).exp()
            }),
        }
    }
}

/// A pixel's own variance per axis, px²: its box integral of a profile whose edge is
/// σ wide is, to a few 1e-3 of the level where σ ≥ 0.9 px, the profile with the edge
/// √(σ² + 1/12) wide sampled at the pixel's centre.
const PIXEL_VAR: f64 = 1.0 / 12.0;

/// Sub-samples per pixel side and the edge width σ to sample: one sample of the edge
/// widened by the pixel's variance where the edge is wide, else n × n samples with
/// n σ ≥ 1 (the grid's leftover error in the moments ~ exp(−2π² n² σ²) < 1e-8).
fn sampling(sigma: f64, min_n: usize) -> (usize, f64) {
    if min_n <= 1 && sigma * sigma + PIXEL_VAR >= 0.81 {
        (1, (sigma * sigma + PIXEL_VAR).sqrt())
    } else {
        (
            ((1.0 / sigma).ceil() as usize).clamp(min_n.max(2), 16),
            sigma,
        )
    }
}

/// Adds `amp` × the pixel integrals of the radial profile `f(ρ²)` (zero beyond the
/// shape's reach, one within its inner radius) centred on the disk to `buf`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn add_disk(
    buf: &mut [f32],
    w: usize,
    h: usize,
    d: &Disk,
    amp: f64,
    shape: &Shape,
    n: usize,
    f: impl Fn(f64) -> f64,
) {
    let reach = shape.reach;
    if !(d.x.is_finite() && d.y.is_finite())
        || d.x + reach < -0.5
        || d.y + reach < -0.5
        || d.x - reach > w as f64 - 0.5
        || d.y - reach > h as f64 - 0.5
    {
        return;
    }
    let c0 = (d.x - reach).round().max(0.0) as usize;
    let c1 = ((d.x + reach).round().max(0.0) as usize).min(w - 1);
    let r0 = (d.y - reach).round().max(0.0) as usize;
    let r1 = ((d.y + reach).round().max(0.0) as usize).min(h - 1);
    let reach2 = reach * reach;
    let inner2 = shape.inner * shape.inner;
    let inv_n2 = 1.0 / (n * n) as f64;
    let offs: Vec<f64> = (0..n).map(|k| -0.5 + (k as f64 + 0.5) / n as f64).collect();
    let mut dx2 = vec![0.0; n];
    for row in r0..=r1 {
        let dy = row as f64 - d.y;
        let ny = (dy.abs() - 0.5).max(0.0);
        let fy = dy.abs() + 0.5;
        let line = &mut buf[row * w..(row + 1) * w];
        for (col, px) in line.iter_mut().enumerate().take(c1 + 1).skip(c0) {
            let dx = col as f64 - d.x;
            let nx = (dx.abs() - 0.5).max(0.0);
            if nx * nx + ny * ny >= reach2 {
                continue;
            }
            let fx = dx.abs() + 0.5;
            let v = if fx * fx + fy * fy <= inner2 {
                1.0
            } else {
                for (k, o) in offs.iter().enumerate() {
                    let t = dx + o;
                    dx2[k] = t * t;
                }
                let mut acc = 0.0;
                for oy in &offs {
                    let t = dy + oy;
                    let ty2 = t * t;
                    for &tx2 in &dx2 {
                        let r2 = tx2 + ty2;
                        if r2 < reach2 {
                            acc += f(r2);
                        }
                    }
                }
                acc * inv_n2
            };
            *px += (amp * v) as f32;
        }
    }
}

/// Ψ(t) = t Φ(t) + φ(t), the antiderivative of Φ.
fn psi(phi: &PhiTable, t: f64) -> f64 {
    if t >= PHI_T {
        return t;
    }
    if t <= -PHI_T {
        return 0.0;
    }
    t * phi.at(t) + (-0.5 * t * t).exp() / (2.0 * std::f64::consts::PI).sqrt()
}

/// The integral over `[c − ½, c + ½]` of the interval `[a, b]` blurred by a Gaussian
/// of σ (σ = 0: the length of the overlap).
fn coverage(phi: &PhiTable, a: f64, b: f64, c: f64, sigma: f64) -> f64 {
    let (p, q) = (c - 0.5, c + 0.5);
    if sigma <= 0.0 {
        return (b.min(q) - a.max(p)).max(0.0);
    }
    // ∫ₚ^q Φ((b − u)/σ) − Φ((a − u)/σ) du.
    let g = |e: f64| sigma * (psi(phi, (e - p) / sigma) - psi(phi, (e - q) / sigma));
    (g(b) - g(a)).max(0.0)
}

/// Adds `amp` × the pixel integrals of the rectangle blurred by σ.
fn add_rect(buf: &mut [f32], w: usize, h: usize, r: &Rect, amp: f64, sigma: f64) {
    let (x0, x1) = (r.x0.min(r.x1), r.x0.max(r.x1));
    let (y0, y1) = (r.y0.min(r.y1), r.y0.max(r.y1));
    if !(x0.is_finite() && x1.is_finite() && y0.is_finite() && y1.is_finite()) {
        return;
    }
    let phi = PhiTable::get();
    let pad = EDGE_CUT * sigma + 1.0;
    let clampi = |v: f64, n: usize| v.round().clamp(0.0, (n - 1) as f64) as usize;
    let (c0, c1) = (clampi(x0 - pad, w), clampi(x1 + pad, w));
    let (r0, r1) = (clampi(y0 - pad, h), clampi(y1 + pad, h));
    let cx: Vec<f64> = (c0..=c1)
        .map(|c| coverage(phi, x0, x1, c as f64, sigma))
        .collect();
    for row in r0..=r1 {
        let cy = coverage(phi, y0, y1, row as f64, sigma);
        if cy == 0.0 {
            continue;
        }
        let line = &mut buf[row * w..(row + 1) * w];
        for (px, c) in line[c0..=c1].iter_mut().zip(&cx) {
            *px += (amp * cy * c) as f32;
        }
    }
}

/// The 256-layer ziggurat of the standard normal (Marsaglia & Tsang 2000, in Doornik's
/// 2005 form): layer edges `x` (x[0] the base strip's width, x[256] = 0).
struct Ziggurat {
    x: [f64; 257],
}

const ZIG_R: f64 = 3.654_152_885_361_009;
const ZIG_V: f64 = 0.004_928_673_233_99;

impl Ziggurat {
    fn get() -> &'static Ziggurat {
        static Z: OnceLock<Ziggurat> = OnceLock::new();
        Z.get_or_init(|| {
            let f = |x: f64| (-0.5 * x * x).exp();
            let mut x = [0.0; 257];
            x[0] = ZIG_V / f(ZIG_R);
            x[1] = ZIG_R;
            for i in 2..256 {
                x[i] = (-2.0 * (ZIG_V / x[i - 1] + f(x[i - 1])).ln()).sqrt();
            }
            x[256] = 0.0;
            Ziggurat { x }
        })
    }
}

/// Standard normals (ziggurat: one 64-bit draw for 99 % of them) and Poisson counts.
struct Normals {
    rng: Rng,
    zig: &'static Ziggurat,
}

impl Normals {
    fn new(seed: u64) -> Self {
        Normals {
            rng: Rng::new(seed),
            zig: Ziggurat::get(),
        }
    }
    #[inline]
    fn next(&mut self) -> f64 {
        let x = &self.zig.x;
        loop {
            let bits = self.rng.next_u64();
            let i = (bits & 0xff) as usize;
            // Uniform in (−1, 1) from the 53 high bits.
            let u = 2.0 * ((bits >> 11) as f64 * (1.0 / (1u64 << 53) as f64)) - 1.0;
            let z = u * x[i];
            if z.abs() < x[i + 1] {
                return z;
            }
            if i == 0 {
                // The tail beyond R (Marsaglia 1964).
                loop {
                    let a = -(1.0 - self.rng.uniform()).ln() / ZIG_R;
                    let b = -(1.0 - self.rng.uniform()).ln();
                    if 2.0 * b > a * a {
                        return if u < 0.0 { -(ZIG_R + a) } else { ZIG_R + a };
                    }
                }
            }
            // The wedge between layers i and i + 1.
            let f0 = (-0.5 * (x[i] * x[i] - z * z)).exp();
            let f1 = (-0.5 * (x[i + 1] * x[i + 1] - z * z)).exp();
            if f1 + self.rng.uniform() * (f0 - f1) < 1.0 {
                return z;
            }
        }
    }
    /// A Poisson count of mean `m` (small m: Knuth's product of uniforms).
    fn poisson(&mut self, m: f64) -> f64 {
        let l = (-m).exp();
        let (mut k, mut p) = (0.0, self.rng.uniform());
        while p > l {
            k += 1.0;
            p *= self.rng.uniform();
        }
        k
    }
}

/// Below this many photons a pixel's count is drawn from the Poisson law itself.
const POISSON_BELOW: f64 = 30.0;

/// Renders one frame: `disks` and `rects` in pixel coordinates, frame `frame_index`'s
/// noise (deterministic from the camera's seed and `frame_index`). The settings are
/// checked first (`Camera::validate`).
pub fn render_frame(
    disks: &[Disk],
    rects: &[Rect],
    cam: &Camera,
    frame_index: u64,
) -> Result<Frame> {
    cam.validate()?;
    let (w, h) = (cam.width, cam.height);
    let full = cam.full_scale();
    let mut buf = vec![0.0f32; w * h];
    let phi = PhiTable::get();
    // Grains of one radius share their shape.
    let mut shape: Option<(f64, Shape)> = None;
    for d in disks {
        if !(d.radius > 0.0 && d.radius.is_finite() && d.brightness > 0.0) {
            continue;
        }
        if shape.as_ref().is_none_or(|(r, _)| *r != d.radius) {
            shape = Some((d.radius, Shape::new(cam, d.radius, phi)));
        }
        let (_, s) = shape.as_ref().expect("set above");
        s.add(&mut buf, w, h, d, cam.grain_level * d.brightness * full);
    }
    for r in rects {
        if r.level > 0.0 {
            add_rect(&mut buf, w, h, r, r.level * full, cam.blur_px);
        }
    }

    let flicker = cam.flicker_factor(frame_index);
    let (dx, dy) = {
        let a = cam.gradient_angle_deg.to_radians();
        let (c, s) = (a.cos(), a.sin());
        let span = (w as f64 - 1.0) * c.abs() + (h as f64 - 1.0) * s.abs();
        if cam.gradient == 0.0 || span <= 0.0 {
            (0.0, 0.0)
        } else {
            (cam.gradient * c / span, cam.gradient * s / span)
        }
    };
    let (cx, cy) = ((w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0);
    let bg = cam.background * full;
    let mut normals = Normals::new(stream_seed(cam.seed, TAG_NOISE, frame_index));
    let (photons, read2) = (cam.photons, cam.read_noise * cam.read_noise);
    let grey_per_photon = if photons > 0.0 { full / photons } else { 0.0 };
    let mut pixels = buf;
    for row in 0..h {
        let illum_row = flicker * (1.0 + dy * (row as f64 - cy));
        let line = &mut pixels[row * w..(row + 1) * w];
        for (col, p) in line.iter_mut().enumerate() {
            let illum = illum_row + flicker * dx * (col as f64 - cx);
            let v = ((*p as f64 + bg) * illum).max(0.0);
            let mut out = v;
            let mut var = read2;
            if photons > 0.0 {
                let m = v / grey_per_photon;
                if m < POISSON_BELOW {
                    out = normals.poisson(m) * grey_per_photon;
                } else {
                    var += v * grey_per_photon;
                }
            }
            if var > 0.0 {
                out += var.sqrt() * normals.next();
            }
            *p = out.round().clamp(0.0, full) as f32;
        }
    }
    Ok(Frame {
        width: w,
        height: h,
        bit_depth: cam.bit_depth,
        pixels,
    })
}

#[cfg(test)]
mod tests;
