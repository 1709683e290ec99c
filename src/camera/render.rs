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
mod tests {
    use super::*;

    fn quiet(w: usize, h: usize) -> Camera {
        Camera {
            width: w,
            height: h,
            bit_depth: 16,
            background: 0.0,
            photons: 0.0,
            read_noise: 0.0,
            brightness_spread: 0.0,
            ..Camera::default()
        }
    }

    /// (Σ v, Σ v·x, Σ v·y) of the frame above `bg` grey levels.
    fn moments(f: &Frame, bg: f64) -> (f64, f64, f64) {
        let (mut m, mut mx, mut my) = (0.0, 0.0, 0.0);
        for row in 0..f.height {
            for col in 0..f.width {
                let v = f.at(row, col) as f64 - bg;
                m += v;
                mx += v * col as f64;
                my += v * row as f64;
            }
        }
        (m, mx / m, my / m)
    }

    #[test]
    fn a_disk_sits_at_its_sub_pixel_centre_with_its_brightness() {
        let positions = [
            (30.0, 31.0),
            (30.37, 25.81),
            (31.5, 30.5),
            (29.93, 32.12),
            (30.25, 30.75),
        ];
        for profile in [Profile::Flat, Profile::Dome, Profile::Gaussian] {
            for (edge, blur) in [(0.5, 1.0), (0.25, 0.0), (1.0, 0.0), (0.1, 0.6)] {
                for r in [7.5, 10.0, 4.3] {
                    for &(x, y) in &positions {
                        let cam = Camera {
                            profile,
                            edge_px: edge,
                            blur_px: blur,
                            ..quiet(64, 64)
                        };
                        let d = Disk {
                            x,
                            y,
                            radius: r,
                            brightness: 1.0,
                        };
                        let f = render_frame(&[d], &[], &cam, 0).unwrap();
                        let (m, cx, cy) = moments(&f, 0.0);
                        let what =
                            format!("{profile:?} edge {edge} blur {blur} r {r} at ({x}, {y})");
                        assert!(
                            (cx - x).abs() < 0.01 && (cy - y).abs() < 0.01,
                            "{what}: centroid ({cx}, {cy})"
                        );
                        let level = cam.grain_level * 65535.0;
                        let expect = std::f64::consts::PI
                            * r
                            * r
                            * level
                            * match profile {
                                Profile::Flat => 1.0,
                                Profile::Dome => 1.0 - cam.dome_contrast / 3.0,
                                Profile::Gaussian => 0.5,
                            };
                        // The dome's edge cuts its rim: its integral is that of the sharp
                        // dome only where the edge is narrow beside the radius.
                        if profile != Profile::Dome || cam.edge_sigma() / r < 0.07 {
                            let tol = if profile == Profile::Dome { 0.02 } else { 0.01 };
                            assert!(
                                (m / expect - 1.0).abs() < tol,
                                "{what}: integral {m} vs {expect}"
                            );
                        }
                        if profile == Profile::Flat {
                            // The plateau is the level, the peak of every profile too.
                            let peak = f.pixels.iter().copied().fold(0.0f32, f32::max) as f64;
                            if r > 5.0 && blur < 1.0 {
                                assert!((peak / level - 1.0).abs() < 1e-3, "{what}: peak {peak}");
                            }
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn one_sample_of_the_widened_edge_is_the_pixel_integral() {
        // The fast path (an edge ≥ 0.9 px wide): each pixel against a 32 × 32 box
        // integral of the edge as the lens makes it.
        let phi = PhiTable::get();
        for (edge, blur, r) in [(0.5, 1.0, 7.5), (0.9, 0.0, 10.0), (0.3, 1.5, 4.0)] {
            let cam = Camera {
                edge_px: edge,
                blur_px: blur,
                ..quiet(40, 40)
            };
            assert_eq!(Shape::new(&cam, r, phi).n, 1);
            let (x, y) = (19.37, 20.81);
            let d = Disk {
                x,
                y,
                radius: r,
                brightness: 1.0,
            };
            let f = render_frame(&[d], &[], &cam, 0).unwrap();
            let s = cam.edge_sigma();
            let re = (r * r - s * s).sqrt();
            let level = cam.grain_level * 65535.0;
            let mut worst: f64 = 0.0;
            for row in 0..40 {
                for col in 0..40 {
                    let mut acc = 0.0;
                    for i in 0..32 {
                        for j in 0..32 {
                            let px = col as f64 - 0.5 + (j as f64 + 0.5) / 32.0;
                            let py = row as f64 - 0.5 + (i as f64 + 0.5) / 32.0;
                            acc += phi.at((re - (px - x).hypot(py - y)) / s);
                        }
                    }
                    let want = acc / 1024.0 * level;
                    worst = worst.max((f.at(row, col) as f64 - want).abs() / level);
                }
            }
            assert!(
                worst < 3e-3,
                "edge {edge} blur {blur}: off by {worst} of the level"
            );
        }
    }

    #[test]
    fn eight_bit_quantisation_keeps_the_centre() {
        let cam = Camera {
            bit_depth: 8,
            background: 0.05,
            ..quiet(48, 48)
        };
        let d = Disk {
            x: 23.71,
            y: 24.33,
            radius: 7.5,
            brightness: 1.0,
        };
        let f = render_frame(&[d], &[], &cam, 0).unwrap();
        let (m, cx, cy) = moments(&f, (0.05f64 * 255.0).round());
        assert!(
            (cx - d.x).abs() < 0.01 && (cy - d.y).abs() < 0.01,
            "({cx}, {cy})"
        );
        let expect = std::f64::consts::PI * 7.5 * 7.5 * 0.75 * 255.0;
        assert!((m / expect - 1.0).abs() < 0.01, "{m} vs {expect}");
    }

    #[test]
    fn the_same_seed_gives_the_same_frame_another_seed_other_noise() {
        let disks: Vec<Disk> = (0..12)
            .map(|i| Disk {
                x: 10.0 + 13.3 * (i % 4) as f64,
                y: 12.0 + 15.1 * (i / 4) as f64,
                radius: 6.0,
                brightness: 1.0,
            })
            .collect();
        let cam = Camera {
            width: 64,
            height: 60,
            ..Camera::default()
        };
        let a = render_frame(&disks, &[], &cam, 3).unwrap();
        let b = render_frame(&disks, &[], &cam, 3).unwrap();
        assert_eq!(a, b);
        let c = render_frame(
            &disks,
            &[],
            &Camera {
                seed: 2,
                ..cam.clone()
            },
            3,
        )
        .unwrap();
        let differ = a
            .pixels
            .iter()
            .zip(&c.pixels)
            .filter(|(p, q)| p != q)
            .count();
        assert!(differ > a.pixels.len() / 2, "only {differ} pixels differ");
        // Another frame of the same camera has other noise as well.
        let d = render_frame(&disks, &[], &cam, 4).unwrap();
        assert!(
            a.pixels
                .iter()
                .zip(&d.pixels)
                .filter(|(p, q)| p != q)
                .count()
                > a.pixels.len() / 2
        );
        // With the noise off the seed only sets the grains' brightness.
        let q = Camera {
            photons: 0.0,
            read_noise: 0.0,
            brightness_spread: 0.0,
            ..cam.clone()
        };
        assert_eq!(
            render_frame(&disks, &[], &q, 3).unwrap(),
            render_frame(
                &disks,
                &[],
                &Camera {
                    seed: 9,
                    ..q.clone()
                },
                4
            )
            .unwrap()
        );
    }

    fn mean_std(v: &[f32]) -> (f64, f64) {
        let n = v.len() as f64;
        let m = v.iter().map(|&x| x as f64).sum::<f64>() / n;
        let var = v.iter().map(|&x| (x as f64 - m).powi(2)).sum::<f64>() / (n - 1.0);
        (m, var.sqrt())
    }

    #[test]
    fn normals_are_standard_normal() {
        let mut g = Normals::new(5);
        let n = 2_000_000;
        let z: Vec<f64> = (0..n).map(|_| g.next()).collect();
        let m = z.iter().sum::<f64>() / n as f64;
        let var = z.iter().map(|v| (v - m).powi(2)).sum::<f64>() / n as f64;
        let k4 = z.iter().map(|v| (v - m).powi(4)).sum::<f64>() / n as f64 / (var * var);
        assert!(
            m.abs() < 0.003 && (var - 1.0).abs() < 0.004,
            "mean {m} var {var}"
        );
        assert!((k4 - 3.0).abs() < 0.03, "kurtosis {k4}");
        // Tail fractions against 2Φ(−t): the layers, the wedges and the tail.
        for (t, p) in [
            (0.5, 0.617_075),
            (1.0, 0.317_311),
            (2.0, 0.045_500),
            (3.0, 0.002_700),
            (3.8, 1.446_8e-4),
        ] {
            let got = z.iter().filter(|v| v.abs() > t).count() as f64 / n as f64;
            let se = (p * (1.0 - p) / n as f64).sqrt();
            assert!(
                (got - p).abs() < 5.0 * se,
                "P(|z| > {t}) = {got}, expected {p}"
            );
        }
    }

    #[test]
    fn noise_has_the_set_statistics() {
        // Read noise alone on a flat background (8 bit: rounding adds 1/12 to the variance).
        let cam = Camera {
            width: 256,
            height: 256,
            background: 0.4,
            photons: 0.0,
            read_noise: 3.0,
            ..quiet(1, 1)
        };
        let cam = Camera {
            bit_depth: 8,
            ..cam
        };
        let f = render_frame(&[], &[], &cam, 0).unwrap();
        let (m, s) = mean_std(&f.pixels);
        assert!((m - 0.4 * 255.0).abs() < 0.1, "mean {m}");
        let expect = (9.0f64 + 1.0 / 12.0).sqrt();
        assert!(
            (s / expect - 1.0).abs() < 0.05,
            "read noise std {s} vs {expect}"
        );
        // Shot noise alone at 16 bit: variance v · full / photons.
        let cam = Camera {
            bit_depth: 16,
            read_noise: 0.0,
            photons: 2000.0,
            ..cam
        };
        let f = render_frame(&[], &[], &cam, 1).unwrap();
        let (m, s) = mean_std(&f.pixels);
        let expect = (0.4 * 65535.0 * 65535.0 / 2000.0f64).sqrt();
        assert!((m / (0.4 * 65535.0) - 1.0).abs() < 1e-3, "mean {m}");
        assert!(
            (s / expect - 1.0).abs() < 0.05,
            "shot noise std {s} vs {expect}"
        );
        // Few photons: Poisson counts (mean = variance = 5 photons, whole numbers).
        let cam = Camera {
            photons: 100.0,
            background: 0.05,
            ..cam
        };
        let f = render_frame(&[], &[], &cam, 2).unwrap();
        let per = 65535.0 / 100.0;
        let counts: Vec<f32> = f.pixels.iter().map(|&v| (v as f64 / per) as f32).collect();
        assert!(counts.iter().all(|&c| (c - c.round()).abs() < 1e-3));
        let (m, s) = mean_std(&counts);
        assert!(
            (m - 5.0).abs() < 0.05 && (s * s / 5.0 - 1.0).abs() < 0.05,
            "Poisson mean {m} var {}",
            s * s
        );
        // Both together add in quadrature.
        let cam = Camera {
            photons: 1000.0,
            read_noise: 200.0,
            background: 0.3,
            ..cam
        };
        let f = render_frame(&[], &[], &cam, 3).unwrap();
        let (_, s) = mean_std(&f.pixels);
        let expect = (0.3 * 65535.0 * 65535.0 / 1000.0 + 200.0f64 * 200.0).sqrt();
        assert!((s / expect - 1.0).abs() < 0.05, "std {s} vs {expect}");
    }

    #[test]
    fn quantisation_ranges_of_8_and_16_bit() {
        let disks = [
            Disk {
                x: 20.0,
                y: 20.0,
                radius: 8.0,
                brightness: 1.0,
            },
            Disk {
                x: 45.0,
                y: 20.0,
                radius: 8.0,
                brightness: 3.0,
            }, // saturates
        ];
        let mut by_depth = Vec::new();
        for depth in [8u8, 16] {
            let cam = Camera {
                width: 64,
                height: 40,
                bit_depth: depth,
                background: 0.0,
                read_noise: 5.0,
                ..Camera::default()
            };
            let f = render_frame(&disks, &[], &cam, 0).unwrap();
            let full = if depth == 8 { 255.0 } else { 65535.0 };
            assert_eq!(f.bit_depth, depth);
            assert!(
                f.pixels
                    .iter()
                    .all(|&v| v == v.round() && (0.0..=full).contains(&v))
            );
            assert_eq!(f.max_value(), full);
            assert_eq!(f.at(20, 45), full, "saturated grain clips at full scale");
            assert_eq!(
                f.pixels.iter().copied().fold(f32::MAX, f32::min),
                0.0,
                "noise clips at 0"
            );
            by_depth.push(f);
        }
        // The same scene: 16-bit levels are 257 × the 8-bit ones (up to noise).
        let (a, b) = (by_depth[0].at(20, 20) as f64, by_depth[1].at(20, 20) as f64);
        assert!((b / 257.0 - a).abs() < 12.0, "{a} vs {b}");
    }

    #[test]
    fn frames_are_identical_on_one_and_four_threads() {
        use rayon::prelude::*;
        let disks: Vec<Disk> = (0..30)
            .map(|i| Disk {
                x: 8.0 + 9.7 * (i % 6) as f64,
                y: 8.0 + 10.3 * (i / 6) as f64,
                radius: 4.5,
                brightness: 0.8 + 0.01 * i as f64,
            })
            .collect();
        let cam = Camera {
            width: 70,
            height: 60,
            flicker: 0.1,
            gradient: 0.2,
            ..Camera::default()
        };
        let render = |threads: usize| -> Vec<Frame> {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| {
                    (0..8u64)
                        .into_par_iter()
                        .map(|k| render_frame(&disks, &[], &cam, k).unwrap())
                        .collect()
                })
        };
        assert_eq!(render(1), render(4));
    }

    #[test]
    fn grain_factors_are_per_grain_and_spread_as_set() {
        let cam = Camera {
            brightness_spread: 0.1,
            ..Camera::default()
        };
        let f: Vec<f64> = (0..4000).map(|id| cam.grain_factor(id)).collect();
        assert_eq!(cam.grain_factor(17), f[17]);
        let n = f.len() as f64;
        let m = f.iter().sum::<f64>() / n;
        let s = (f.iter().map(|v| (v - m).powi(2)).sum::<f64>() / n).sqrt();
        assert!(
            (m - 1.0).abs() < 0.01 && (s / 0.1 - 1.0).abs() < 0.05,
            "{m} {s}"
        );
        assert_ne!(
            Camera {
                seed: 2,
                ..cam.clone()
            }
            .grain_factor(17),
            f[17]
        );
    }

    #[test]
    fn gradient_bars_and_bad_settings() {
        // A 20 % gradient to the right: the right edge 20 % brighter than the left.
        let cam = Camera {
            width: 101,
            height: 11,
            background: 0.5,
            gradient: 0.2,
            ..quiet(1, 1)
        };
        let f = render_frame(&[], &[], &cam, 0).unwrap();
        let (l, r) = (f.at(5, 0) as f64, f.at(5, 100) as f64);
        assert!(((r - l) / (0.5 * 65535.0) - 0.2).abs() < 1e-4, "{l} {r}");
        // A bar covers its pixels exactly, by area at its edges.
        let cam = Camera {
            blur_px: 0.0,
            ..quiet(20, 10)
        };
        let bar = Rect {
            x0: 2.25,
            y0: 1.5,
            x1: 15.5,
            y1: 4.0,
            level: 0.5,
        };
        let f = render_frame(&[], &[bar], &cam, 0).unwrap();
        let total: f64 = f.pixels.iter().map(|&v| v as f64).sum();
        assert!(
            (total / (13.25 * 2.5 * 0.5 * 65535.0) - 1.0).abs() < 1e-4,
            "{total}"
        );
        assert_eq!(f.at(3, 8), (0.5f64 * 65535.0).round() as f32);
        assert_eq!(f.at(3, 2), (0.25f64 * 0.5 * 65535.0).round() as f32);
        // Blurred, it keeps its brightness and its centre, and spreads as the blur says.
        let cam_b = Camera {
            blur_px: 1.5,
            ..quiet(40, 30)
        };
        let bar = Rect {
            x0: 8.25,
            y0: 10.5,
            x1: 30.5,
            y1: 18.0,
            level: 0.5,
        };
        let f = render_frame(&[], &[bar], &cam_b, 0).unwrap();
        let (m, cx, cy) = moments(&f, 0.0);
        assert!(
            (m / (22.25 * 7.5 * 0.5 * 65535.0) - 1.0).abs() < 1e-4,
            "{m}"
        );
        assert!(
            (cx - 19.375).abs() < 1e-3 && (cy - 14.25).abs() < 1e-3,
            "({cx}, {cy})"
        );
        // Half the level on the edge line x = 30.5 (the pixels at 30 and 31 straddle it).
        let edge = 0.5 * (f.at(14, 30) + f.at(14, 31)) as f64 / (0.5 * 65535.0);
        assert!((edge - 0.5).abs() < 0.02, "{edge}");
        assert!(f.at(14, 36) > 0.0 && f.at(14, 36) < f.at(14, 33));
        for (bad, flag) in [
            (
                Camera {
                    bit_depth: 12,
                    ..cam.clone()
                },
                "bit-depth",
            ),
            (
                Camera {
                    blur_px: -1.0,
                    ..cam.clone()
                },
                "blur",
            ),
            (
                Camera {
                    read_noise: f64::NAN,
                    ..cam.clone()
                },
                "read-noise",
            ),
            (
                Camera {
                    edge_px: 0.0,
                    blur_px: 0.0,
                    ..cam.clone()
                },
                "edge",
            ),
            (
                Camera {
                    width: 0,
                    ..cam.clone()
                },
                "size",
            ),
        ] {
            let e = render_frame(&[], &[], &bad, 0).unwrap_err().to_string();
            assert!(e.contains(flag), "{e}");
        }
    }

    #[test]
    fn pixel_map_fits_the_content_within_the_margin() {
        let (map, w, h) = PixelMap::fit((-2.0, 10.0), (1.0, 25.0), 31.5, 20.0);
        assert_eq!(
            (w, h),
            (
                (12.0f64 * 31.5 + 40.0).ceil() as usize,
                (24.0f64 * 31.5 + 40.0).ceil() as usize
            )
        );
        assert!((map.col(-2.0) + 0.5 - 20.0).abs() < 1e-9);
        assert!(w as f64 - 0.5 - map.col(10.0) >= 20.0 - 1e-9);
        assert!((map.row(25.0) + 0.5 - 20.0).abs() < 1e-9);
        assert!(h as f64 - 0.5 - map.row(1.0) >= 20.0 - 1e-9);
        assert!(map.row(1.0) > map.row(2.0), "y up in the tracks, rows down");
    }
}
