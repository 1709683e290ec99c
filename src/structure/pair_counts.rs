//! The pair counting behind g(r) ([`super::pair_distribution`]): every pair closer than
//! r_max visited once, from grains sorted into cells r_max/2 wide (a half stencil of 12
//! neighbouring cells and the cell itself: about a third of the candidates a cell list
//! r_max wide offers), rows of cells split over threads. Counts are integers, so the
//! result is the same for any thread count.

use crate::geom::{SimBox, Vec2};
use rayon::prelude::*;

/// More cells than this per grain and the layout is left to the caller.
const MAX_CELLS_PER_GRAIN: usize = 16;

/// Cells reached on each side: cells are at least r_max/2 wide.
const REACH: isize = 2;

/// Neighbour cells of the half stencil: each unordered pair of cells once.
const HALF_STENCIL: [(isize, isize); 12] = [
    (1, 0),
    (2, 0),
    (-2, 1),
    (-1, 1),
    (0, 1),
    (1, 1),
    (2, 1),
    (-2, 2),
    (-1, 2),
    (0, 2),
    (1, 2),
    (2, 2),
];

/// Per species of the centre (0 small, 1 large): how many neighbours lie in distance bin
/// k = ⌊|r_ij| / dr⌋, k < `bins`, around the grains with `counted` set. None where the
/// cells cannot be laid out (non-finite positions, a sheared periodic box, a periodic box
/// under five cells across); the caller then counts another way.
pub(super) fn count_pairs(
    pos: &[Vec2],
    small: &[bool],
    counted: &[bool],
    r_max: f64,
    bins: usize,
    periodic: Option<SimBox>,
) -> Option<[Vec<u64>; 2]> {
    if pos.iter().any(|p| !(p.x.is_finite() && p.y.is_finite())) {
        return None;
    }
    let half = 0.5 * r_max;
    // Origin, extent and cell counts; in a periodic box, positions wrapped into it.
    let (pts, origin, extent, period): (Vec<Vec2>, Vec2, Vec2, Option<Vec2>) = match periodic {
        Some(b) if b.xy != 0.0 => return None,
        Some(b) => (
            pos.iter().map(|&p| b.wrap(p)).collect(),
            Vec2::new(b.x_lo, b.y_lo),
            Vec2::new(b.lx, b.ly),
            Some(Vec2::new(b.lx, b.ly)),
        ),
        None => {
            let lo = pos
                .iter()
                .fold(Vec2::new(f64::INFINITY, f64::INFINITY), |a, p| {
                    Vec2::new(a.x.min(p.x), a.y.min(p.y))
                });
            let hi = pos
                .iter()
                .fold(Vec2::new(f64::NEG_INFINITY, f64::NEG_INFINITY), |a, p| {
                    Vec2::new(a.x.max(p.x), a.y.max(p.y))
                });
            (pos.to_vec(), lo, hi - lo, None)
        }
    };
    if pts.is_empty() {
        return Some([vec![0; bins], vec![0; bins]]);
    }
    let cells_along = |l: f64| ((l / half).floor() as usize).max(1);
    let (nx, ny) = (cells_along(extent.x), cells_along(extent.y));
    if period.is_some() && (nx < 5 || ny < 5) {
        return None;
    }
    // A stray grain far from the rest would make the grid huge and empty: leave such
    // layouts to the queries, whose cell list copes with them.
    if nx.saturating_mul(ny) > MAX_CELLS_PER_GRAIN * pts.len() + 1024 {
        return None;
    }
    // Cells at least r_max/2 wide (exactly L/n in a periodic box, so they tile it).
    let (cw, ch) = (
        (extent.x / nx as f64).max(half),
        (extent.y / ny as f64).max(half),
    );
    let cell_of = |p: Vec2| {
        let cx = (((p.x - origin.x) / cw) as usize).min(nx - 1);
        let cy = (((p.y - origin.y) / ch) as usize).min(ny - 1);
        cy * nx + cx
    };
    // Counting sort by cell: each cell's grains contiguous.
    let cell: Vec<usize> = pts.iter().map(|&p| cell_of(p)).collect();
    let mut start = vec![0usize; nx * ny + 1];
    for &c in &cell {
        start[c + 1] += 1;
    }
    for c in 0..nx * ny {
        start[c + 1] += start[c];
    }
    let mut next = start.clone();
    let mut order = vec![0usize; pts.len()];
    for (i, &c) in cell.iter().enumerate() {
        order[next[c]] = i;
        next[c] += 1;
    }
    let xs: Vec<f64> = order.iter().map(|&i| pts[i].x).collect();
    let ys: Vec<f64> = order.iter().map(|&i| pts[i].y).collect();
    // Bit 0: the grain is a counted centre; bit 1: it is large.
    let flags: Vec<u8> = order
        .iter()
        .map(|&i| counted[i] as u8 | ((!small[i] as u8) << 1))
        .collect();
    let dr = r_max / bins as f64;
    let r2 = r_max * r_max;
    let add = |h: &mut [Vec<u64>; 2], d2: f64, fi: u8, fj: u8| {
        if d2 < r2 {
            let k = (d2.sqrt() / dr) as usize;
            if k < bins {
                if fi & 1 == 1 {
                    h[(fi >> 1) as usize][k] += 1;
                }
                if fj & 1 == 1 {
                    h[(fj >> 1) as usize][k] += 1;
                }
            }
        }
    };
    let row = |cy: usize| -> [Vec<u64>; 2] {
        let mut h = [vec![0u64; bins], vec![0u64; bins]];
        for cx in 0..nx {
            let a = start[cy * nx + cx]..start[cy * nx + cx + 1];
            for i in a.clone() {
                for j in i + 1..a.end {
                    let (dx, dy) = (xs[j] - xs[i], ys[j] - ys[i]);
                    add(&mut h, dx * dx + dy * dy, flags[i], flags[j]);
                }
            }
            for &(ox, oy) in &HALF_STENCIL {
                let (mut bx, mut by) = (cx as isize + ox, cy as isize + oy);
                let (mut sx, mut sy) = (0.0, 0.0);
                match period {
                    Some(l) => {
                        if bx < 0 {
                            bx += nx as isize;
                            sx = -l.x;
                        } else if bx >= nx as isize {
                            bx -= nx as isize;
                            sx = l.x;
                        }
                        if by >= ny as isize {
                            by -= ny as isize;
                            sy = l.y;
                        }
                    }
                    None => {
                        if bx < 0 || bx >= nx as isize || by >= ny as isize {
                            continue;
                        }
                    }
                }
                let b = start[by as usize * nx + bx as usize]
                    ..start[by as usize * nx + bx as usize + 1];
                for i in a.clone() {
                    for j in b.clone() {
                        let (dx, dy) = (xs[j] + sx - xs[i], ys[j] + sy - ys[i]);
                        add(&mut h, dx * dx + dy * dy, flags[i], flags[j]);
                    }
                }
            }
        }
        h
    };
    debug_assert!(REACH as f64 * cw.min(ch) >= r_max * (1.0 - 1e-12));
    Some((0..ny).into_par_iter().map(row).reduce(
        || [vec![0u64; bins], vec![0u64; bins]],
        |mut a, b| {
            for s in 0..2 {
                for (x, y) in a[s].iter_mut().zip(&b[s]) {
                    *x += y;
                }
            }
            a
        },
    ))
}
