//! The cell grid the pair list is built from: cells of side at least the list's reach,
//! each listing its grains ascending, so a grain's candidates are the grains of the
//! cells around it (Lees–Edwards rows seen through the shift).

use crate::dem::base::boundary::Boundary;
use crate::geom::floor_index;

/// Cells of side ≥ the list cutoff; `None` when the box is too small for a grid (then
/// every pair is tested, which for such small systems is cheap).
#[derive(Debug)]
pub(crate) struct Grid {
    ncx: usize,
    ncy: usize,
    periodic: bool,
    /// Lees–Edwards offset (0 otherwise).
    offset: f64,
    x0: f64,
    y0: f64,
    cx: f64,
    cy: f64,
    /// CSR of grain indices per cell.
    pub(crate) head: Vec<u32>,
    pub(crate) items: Vec<u32>,
}

impl Grid {
    /// The grid of the points, in the buffers `head`, `items` (and `cell`, scratch) of a
    /// previous grid when given.
    pub(crate) fn new(
        x: &[f64],
        y: &[f64],
        cut: f64,
        b: Boundary,
        (mut head, mut items): (Vec<u32>, Vec<u32>),
        cell: &mut Vec<u32>,
    ) -> Option<Grid> {
        let n = x.len();
        let (periodic, x0, y0, w, h) = match b {
            Boundary::Periodic { lx, ly } | Boundary::LeesEdwards { lx, ly, .. } => {
                (true, 0.0, 0.0, lx, ly)
            }
            Boundary::Open => {
                let f =
                    |v: &[f64], m: fn(f64, f64) -> f64, init: f64| v.iter().cloned().fold(init, m);
                let (xl, xh) = (
                    f(x, f64::min, f64::INFINITY),
                    f(x, f64::max, f64::NEG_INFINITY),
                );
                let (yl, yh) = (
                    f(y, f64::min, f64::INFINITY),
                    f(y, f64::max, f64::NEG_INFINITY),
                );
                (false, xl, yl, (xh - xl).max(cut), (yh - yl).max(cut))
            }
        };
        if !(w.is_finite() && h.is_finite() && cut > 0.0) {
            return None;
        }
        let (fx, fy) = ((w / cut).floor().max(1.0), (h / cut).floor().max(1.0));
        // A grain flung ~1e40 away (a corrupt checkpoint) asked for a grid whose cell
        // count wrapped to zero (a panic) or could not be allocated; no real packing
        // comes near 2^24 cells (N = 65,536 needs ~4e4), so the all-pairs fallback,
        // slow but exact, takes such states.
        if fx * fy > (1u64 << 24) as f64 {
            return None;
        }
        let (ncx, ncy) = (fx as usize, fy as usize);
        if periodic && (ncx < 3 || ncy < 3) || n < 16 {
            return None;
        }
        // Open grids get one more cell per side so the maximum coordinate fits.
        let (ncx, ncy) = if periodic {
            (ncx, ncy)
        } else {
            (ncx + 1, ncy + 1)
        };
        let (cx, cy) = if periodic {
            (w / ncx as f64, h / ncy as f64)
        } else {
            (cut, cut)
        };
        let mut g = Grid {
            ncx,
            ncy,
            periodic,
            offset: b.offset(),
            x0,
            y0,
            cx,
            cy,
            head: Vec::new(),
            items: Vec::new(),
        };
        head.clear();
        head.resize(ncx * ncy + 1, 0);
        items.clear();
        items.resize(n, 0);
        cell.clear();
        cell.extend((0..n).map(|i| g.cell_of_wrapped(x[i], y[i]) as u32));
        for &c in cell.iter() {
            head[c as usize + 1] += 1;
        }
        for c in 0..ncx * ncy {
            head[c + 1] += head[c];
        }
        // Fill each cell from its end (`head[c + 1]` counts down to `head[c]`), in
        // reverse grain order so each cell lists its grains ascending.
        for (i, &c) in cell.iter().enumerate().rev() {
            let c = c as usize + 1;
            head[c] -= 1;
            items[head[c] as usize] = i as u32;
        }
        // Now head[c + 1] == start of cell c: shift back.
        head.rotate_left(1);
        head[ncx * ncy] = n as u32;
        (g.head, g.items) = (head, items);
        Some(g)
    }

    /// Column and row of a point in the primary cell (positions may be unwrapped:
    /// crossing the y boundary n times shifts x by −n·offset).
    fn col_row(&self, x: f64, y: f64) -> (i64, i64) {
        let (mut x, mut y) = (x, y);
        if self.periodic {
            let h = self.cy * self.ncy as f64;
            let n = ((y - self.y0) / h).floor();
            y -= n * h;
            x -= n * self.offset;
        }
        let cx = floor_index((x - self.x0) / self.cx) as i64;
        let cy = floor_index((y - self.y0) / self.cy) as i64;
        if self.periodic {
            (
                cx.rem_euclid(self.ncx as i64),
                cy.rem_euclid(self.ncy as i64),
            )
        } else {
            (
                cx.clamp(0, self.ncx as i64 - 1),
                cy.clamp(0, self.ncy as i64 - 1),
            )
        }
    }

    fn cell_of_wrapped(&self, x: f64, y: f64) -> usize {
        let (cx, cy) = self.col_row(x, y);
        cy as usize * self.ncx + cx as usize
    }

    /// The ranges of `items` of the cells around the point (at most 9); returns how
    /// many. Rows across the y boundary are seen through the Lees–Edwards shift, so their
    /// columns are re-centred on the point's shifted x.
    pub(crate) fn neighbour_cells(&self, x: f64, y: f64, out: &mut [(u32, u32); 9]) -> usize {
        let mut count = 0;
        let (cx, cy) = self.col_row(x, y);
        for dy in -1..=1 {
            let mut ny = cy + dy;
            let mut ccx = cx;
            if self.periodic {
                let wrap = if ny < 0 {
                    -1.0
                } else if ny >= self.ncy as i64 {
                    1.0
                } else {
                    0.0
                };
                if wrap != 0.0 && self.offset != 0.0 {
                    // The point's image seen from the row on the other side.
                    let (wx, _) = self.col_row_raw(x, y);
                    let shifted = wx - wrap * self.offset;
                    ccx = floor_index((shifted - self.x0) / self.cx) as i64;
                }
                ny = ny.rem_euclid(self.ncy as i64);
            } else if ny < 0 || ny >= self.ncy as i64 {
                continue;
            }
            // The row's cells around the column: consecutive cells list their grains
            // consecutively, so a run of columns that does not wrap is one range.
            let row = ny as usize * self.ncx;
            let mut push = |from: usize, to: usize| {
                out[count] = (self.head[row + from], self.head[row + to + 1]);
                count += 1;
            };
            let last = self.ncx as i64 - 1;
            if !self.periodic {
                let (lo, hi) = ((ccx - 1).max(0), (ccx + 1).min(last));
                if lo <= hi {
                    push(lo as usize, hi as usize);
                }
            } else if self.ncx < 3 {
                // (`new` makes no periodic grid this narrow; kept for its own sake.)
                let c = ccx.rem_euclid(self.ncx as i64) as usize;
                push(c, c);
            } else if (1..last).contains(&ccx) {
                push((ccx - 1) as usize, (ccx + 1) as usize);
            } else {
                // Wrapping columns (a shifted row's column may be anywhere, up to
                // i64's ends for an absurd offset: wrapping arithmetic, as rem_euclid
                // then takes any value).
                for dx in [-1, 0, 1] {
                    let nx = ccx.wrapping_add(dx).rem_euclid(self.ncx as i64) as usize;
                    push(nx, nx);
                }
            }
        }
        count
    }

    /// The point mapped into the primary cell (x, y), Lees–Edwards aware.
    fn col_row_raw(&self, x: f64, y: f64) -> (f64, f64) {
        let h = self.cy * self.ncy as f64;
        let w = self.cx * self.ncx as f64;
        let n = ((y - self.y0) / h).floor();
        let (x, y) = (x - n * self.offset, y - n * h);
        (x - ((x - self.x0) / w).floor() * w, y)
    }
}
