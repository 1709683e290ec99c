//! Ground-truth tracks for tests and benchmarks: a bidisperse 50:50 packing on a
//! jittered triangular lattice, mapped by a known affine transform F plus optional
//! Gaussian non-affine displacements. Under F alone every particle's exact J is F,
//! D²min = 0 and η^s follows from F (`kinematics::strain_from_j`).

use crate::geom::{Mat2, SimBox, Vec2};
use crate::rng::Rng;
use crate::tracks::{FrameBox, LARGE, SMALL, Tracks, TracksMeta};

/// Diameter ratio of Li et al.'s grains: d/D = 0.47625/0.635 = 3/4.
pub const SMALL_OVER_LARGE: f64 = 0.75;

/// Particles of one synthetic configuration.
#[derive(Debug, Clone)]
pub struct SynthPacking {
    pub pos: Vec<Vec2>,
    /// Radius, length unit (D = 1 unless scaled).
    pub radius: Vec<f64>,
    pub species: Vec<i32>,
    /// Lattice spacing (length unit) and the periodic box the lattice tiles exactly.
    pub spacing: f64,
    pub simbox: SimBox,
}

/// About `n` particles of large diameter `d_large` on a triangular lattice of spacing
/// 0.918 D (the area fraction ≈ 0.84 of a bidisperse 50:50 packing with d = 3D/4),
/// each moved by a uniform random offset of up to `jitter` × spacing per axis. The
/// lattice has an even number of rows so that it tiles its periodic box.
pub fn bidisperse_packing(n: usize, d_large: f64, jitter: f64, seed: u64) -> SynthPacking {
    let a = 0.918 * d_large;
    let h = a * 3f64.sqrt() / 2.0;
    let nx = ((n as f64 * h / a).sqrt().round() as usize).max(2);
    let mut ny = n.div_ceil(nx).max(2);
    ny += ny % 2;
    let mut rng = Rng::new(seed);
    let mut pos = Vec::with_capacity(nx * ny);
    let mut radius = Vec::with_capacity(nx * ny);
    let mut species = Vec::with_capacity(nx * ny);
    for r in 0..ny {
        for c in 0..nx {
            let x0 = (c as f64 + 0.5 * (r % 2) as f64) * a;
            let y0 = r as f64 * h;
            let jx = jitter * a * (2.0 * rng.uniform() - 1.0);
            let jy = jitter * a * (2.0 * rng.uniform() - 1.0);
            pos.push(Vec2::new(x0 + jx, y0 + jy));
            let large = rng.uniform() < 0.5;
            species.push(if large { LARGE } else { SMALL });
            radius.push(0.5 * d_large * if large { 1.0 } else { SMALL_OVER_LARGE });
        }
    }
    SynthPacking {
        pos,
        radius,
        species,
        spacing: a,
        simbox: SimBox {
            x_lo: -0.25 * a,
            y_lo: -0.5 * h,
            lx: nx as f64 * a,
            ly: ny as f64 * h,
            xy: 0.0,
            periodic_x: true,
            periodic_y: true,
        },
    }
}

/// Positions after the affine map `f` about `origin` plus Gaussian displacements of
/// standard deviation `noise` per axis (length unit).
pub fn deform(pos: &[Vec2], f: Mat2, origin: Vec2, noise: f64, seed: u64) -> Vec<Vec2> {
    let mut rng = Rng::new(seed ^ 0x9e37_79b9_7f4a_7c15);
    pos.iter()
        .map(|&p| {
            let mut q = origin + f * (p - origin);
            if noise > 0.0 {
                q += Vec2::new(noise * rng.normal(), noise * rng.normal());
            }
            q
        })
        .collect()
}

/// Two-frame open-boundary tracks: frame 0 the packing, frame 1 after `f` and noise.
/// Particle ids are 0..n, frame time 1, unit "D" when `d_large` is 1.
pub fn two_frame_tracks(p: &SynthPacking, f: Mat2, noise: f64, seed: u64) -> Tracks {
    let centre = Vec2::new(
        p.simbox.x_lo + 0.5 * p.simbox.lx,
        p.simbox.y_lo + 0.5 * p.simbox.ly,
    );
    let next = deform(&p.pos, f, centre, noise, seed);
    let n = p.pos.len();
    let mut t = Tracks {
        meta: TracksMeta {
            length_unit: "D".into(),
            time_unit: "s".into(),
            frame_time: Some(1.0),
            ..Default::default()
        },
        ..Default::default()
    };
    for (frame, ps) in [(0i64, &p.pos), (1, &next)] {
        for (i, q) in ps.iter().enumerate() {
            t.frame.push(frame);
            t.particle.push(i as i64);
            t.x.push(q.x);
            t.y.push(q.y);
            t.radius.push(p.radius[i]);
        }
    }
    t.species = Some([p.species.clone(), p.species.clone()].concat());
    t.time = Some((0..2 * n).map(|r| (r / n) as f64).collect());
    t
}

/// Periodic two-frame tracks under Lees–Edwards shear: frame k holds the lattice
/// sheared by γ_k (x += γ_k (y − y_lo)) and moved up by s_k, wrapped into a box with
/// offset γ_k L_y; γ_0 = `gamma0`, s_0 = 0, γ_1 = `gamma0 + gamma`, s_1 = `shift_y`.
/// Between the frames every particle's exact J is [[1, γ], [0, 1]] and D²min = 0, and
/// particles crossing the y boundary are remapped with the Lees–Edwards offset.
pub fn sheared_periodic_tracks(p: &SynthPacking, gamma0: f64, gamma: f64, shift_y: f64) -> Tracks {
    let b = p.simbox;
    let mut t = two_frame_tracks(p, Mat2::IDENTITY, 0.0, 0);
    let n = p.pos.len();
    let mut boxes = Vec::new();
    for (frame, g, s) in [(0usize, gamma0, 0.0), (1, gamma0 + gamma, shift_y)] {
        let bk = SimBox { xy: g * b.ly, ..b };
        for i in 0..n {
            let q = Vec2::new(p.pos[i].x + g * (p.pos[i].y - b.y_lo), p.pos[i].y + s);
            let w = bk.wrap(q);
            t.x[frame * n + i] = w.x;
            t.y[frame * n + i] = w.y;
        }
        boxes.push(FrameBox::from_simbox(frame as i64, &bk));
    }
    t.meta.boxes = boxes;
    t
}

/// `t` with its particles relabelled by a random permutation of their ids (seeded, so
/// always the same; rows re-sorted by the new ids): the same frames, with rows in no
/// spatial order, as in a shuffled dump. Ids are distinct values in 0..=max; with a
/// negative id, or fewer than two, `t` is returned as it is.
pub fn relabelled(t: &Tracks) -> Tracks {
    let ids = match t.particle.iter().min() {
        Some(&lo) if lo >= 0 => t.particle.iter().max().map_or(0, |&m| m as usize + 1),
        _ => 0,
    };
    if ids < 2 {
        return t.clone();
    }
    // Fisher–Yates.
    let mut perm: Vec<i64> = (0..ids as i64).collect();
    let mut rng = Rng::new(0x5eed);
    for k in (1..ids).rev() {
        perm.swap(k, rng.below(k + 1));
    }
    let new_id = |id: i64| perm[id as usize];
    let mut rows: Vec<usize> = (0..t.len()).collect();
    rows.sort_by_key(|&r| (t.frame[r], new_id(t.particle[r])));
    let pick = |v: &[f64]| rows.iter().map(|&r| v[r]).collect::<Vec<f64>>();
    Tracks {
        frame: rows.iter().map(|&r| t.frame[r]).collect(),
        particle: rows.iter().map(|&r| new_id(t.particle[r])).collect(),
        x: pick(&t.x),
        y: pick(&t.y),
        radius: pick(&t.radius),
        time: t.time.as_deref().map(pick),
        species: t
            .species
            .as_ref()
            .map(|s| rows.iter().map(|&r| s[r]).collect()),
        theta: t.theta.as_deref().map(pick),
        meta: t.meta.clone(),
    }
}
