//! Verlet pair list with contact history, built from a cell grid.
//!
//! A half list (j > i) in CSR form. Each pair slot carries the tangential spring of
//! that contact (`shear`), and a rebuild carries the history of pairs that survive it,
//! so contact friction does not forget its state when the list is refreshed. Rebuilds
//! happen only when some grain has moved more than half the skin since the last build,
//! which in quasistatic loading is rare. Under Lees–Edwards shear the displacement that
//! counts is the one away from the affine flow (see [`PairList::needs_rebuild_sheared`]),
//! so the flow itself, fast at large L, forces no rebuilds.

crate::multiversion! {
/// Whether some grain strayed more than √lim from its reference position, counting
/// displacement along the affine flow Δγ y x̂ as none.
pub(crate) fn strays(x: &[f64], y: &[f64], x_ref: &[f64], y_ref: &[f64], dgamma: f64, lim: f64) -> bool {
    let n = x.len();
    let (y, x_ref, y_ref) = (&y[..n], &x_ref[..n], &y_ref[..n]);
    // Chunks without early exit vectorise; most checks find nothing. (Plain loops: an
    // iterator adapter here stayed an out-of-line call compiled for the baseline.)
    let mut c = 0;
    while c < n {
        let mut far = false;
        for i in c..(c + 256).min(n) {
            let ux = x[i] - x_ref[i] - dgamma * y_ref[i];
            let uy = y[i] - y_ref[i];
            far |= ux * ux + uy * uy > lim;
        }
        if far {
            return true;
        }
        c += 256;
    }
    false
}
}

/// Where the grains live.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Boundary {
    /// Unbounded plane (the pillar: bars and substrate confine it).
    Open,
    /// Periodic in x and y with sides `lx`, `ly` (m); minimum-image separations.
    Periodic { lx: f64, ly: f64 },
    /// Lees–Edwards: periodic, and the image above is shifted along x by `offset`
    /// (= γ L_y for accumulated strain γ; any real value, not wrapped).
    LeesEdwards { lx: f64, ly: f64, offset: f64 },
}

pub use crate::geom::{MinImage, rint};

impl Boundary {
    /// The boundary's minimum-image map (`geom::MinImage`: the project's one rule).
    pub fn image(&self) -> MinImage {
        match *self {
            Boundary::Open => MinImage::OPEN,
            Boundary::Periodic { lx, ly } => MinImage::new(lx, ly, 0.0),
            Boundary::LeesEdwards { lx, ly, offset } => MinImage::new(lx, ly, offset),
        }
    }
}

/// Shear strain of a Lees–Edwards box since its offset was `offset_ref` (0 otherwise).
pub(crate) fn strain_since(b: Boundary, offset_ref: f64) -> f64 {
    match b {
        Boundary::LeesEdwards { ly, offset, .. } => (offset - offset_ref) / ly,
        _ => 0.0,
    }
}

/// The squared displacement (from the affine flow) a grain may have made since a list
/// with skin `skin` and reach `reach` (2 R_max + skin) was made, the box having sheared by
/// `dgamma` since; `None` when none is left (the list must be remade). See
/// [`PairList::needs_rebuild_sheared`].
pub(crate) fn stray_limit(skin: f64, dgamma: f64, reach: f64) -> Option<f64> {
    let room = skin - dgamma.abs() * reach;
    (reach > 0.0 && room > 0.0).then_some(0.25 * room * room)
}

impl Boundary {
    /// Separation r_i − r_j given as raw `(dx, dy)`, mapped to its minimum image.
    #[inline(always)]
    pub fn delta(&self, dx: f64, dy: f64) -> (f64, f64) {
        self.image().of(dx, dy)
    }

    /// As [`Boundary::delta`], also returning the y image index n used for j (the
    /// image of j sits at y_j + n L_y, x_j + n offset, moving n γ̇ L_y faster along x).
    #[inline(always)]
    pub fn delta_image(&self, dx: f64, dy: f64) -> (f64, f64, f64) {
        self.image().with_index(dx, dy)
    }

    /// The Lees–Edwards offset (0 for other boundaries).
    pub fn offset(&self) -> f64 {
        match *self {
            Boundary::LeesEdwards { offset, .. } => offset,
            _ => 0.0,
        }
    }
}

#[derive(Debug, Clone, Default, PartialEq)]
pub struct PairList {
    /// CSR offsets: the partners of i are `j[start[i]..start[i+1]]`, ascending.
    pub start: Vec<u32>,
    pub j: Vec<u32>,
    /// Tangential spring displacement of each pair (m), 0 when not in contact.
    pub shear: Vec<f64>,
    /// Positions at the last build (m).
    pub x_ref: Vec<f64>,
    pub y_ref: Vec<f64>,
    /// Extra distance beyond contact kept in the list (m).
    pub skin: f64,
    /// How many times the list was built.
    pub builds: u64,
    /// Lees–Edwards offset at the last build (m).
    pub offset_ref: f64,
    /// The build's largest reach 2 R_max + skin (m); 0 before the first build (then
    /// any check asks for one). Checkpoints restore it with [`PairList::reach`].
    pub cut: f64,
    /// The previous build's arrays, reused by the next (fresh memory is slow to touch).
    pub spare: Spare,
}

/// Buffers kept between builds; never part of a list's value.
#[derive(Debug, Clone, Default)]
pub struct Spare {
    start: Vec<u32>,
    j: Vec<u32>,
    shear: Vec<f64>,
    /// The cell grid's `head`, `items` and per-grain cell.
    head: Vec<u32>,
    items: Vec<u32>,
    cell: Vec<u32>,
    /// Threads to build on (the sheared disks' steps lend their team): the same list.
    pub team: Option<std::sync::Arc<crate::dem::backend::team::Team>>,
    /// Per range of grains, its partners and CSR ends (`build`'s scratch).
    segs: Vec<(Vec<u32>, Vec<u32>)>,
}

pub(crate) use crate::dem::backend::team::{chunked, team_size};

/// 0..n in `parts` ranges of about equal size.
pub(crate) fn even_ranges(n: usize, parts: usize) -> Vec<std::ops::Range<usize>> {
    let parts = parts.clamp(1, n.max(1));
    (0..parts)
        .map(|t| n * t / parts..n * (t + 1) / parts)
        .collect()
}

impl PartialEq for Spare {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl PairList {
    pub fn new(skin: f64) -> Self {
        PairList {
            skin,
            start: vec![0],
            ..Default::default()
        }
    }

    pub fn len(&self) -> usize {
        self.j.len()
    }
    pub fn is_empty(&self) -> bool {
        self.j.is_empty()
    }

    /// Whether some grain moved more than skin/2 since the last build (or none yet).
    pub fn needs_rebuild(&self, x: &[f64], y: &[f64]) -> bool {
        self.needs_rebuild_sheared(x, y, 0.0)
    }

    /// As [`PairList::needs_rebuild`] when the box was sheared by `dgamma` since the
    /// build (Lees–Edwards; positions unwrapped, so a grain's affine displacement is
    /// Δγ y x̂ at any height). With u_i = Δr_i − Δγ y_i,ref x̂, every image of every
    /// pair separation d evolves as A d₀ + u_i − u_j with A = [[1, Δγ], [0, 1]], and
    /// |A d₀| ≥ (1 − |Δγ|) |d₀|: a pair that was not in the list (|d₀| ≥ R_i + R_j +
    /// skin) cannot touch while 2 max |u| < skin − |Δγ| (2 R_max + skin).
    pub fn needs_rebuild_sheared(&self, x: &[f64], y: &[f64], dgamma: f64) -> bool {
        self.needs_rebuild_within(x, y, dgamma, 0.0)
    }

    /// As [`PairList::needs_rebuild_sheared`], for a list that must also hold every
    /// pair closer than R_i + R_j + `margin` (m): the skin left for motion is less.
    pub fn needs_rebuild_within(&self, x: &[f64], y: &[f64], dgamma: f64, margin: f64) -> bool {
        match stray_limit(self.skin - margin, dgamma, self.cut) {
            Some(lim) if self.x_ref.len() == x.len() => {
                strays(x, y, &self.x_ref, &self.y_ref, dgamma, lim)
            }
            _ => true,
        }
    }

    /// Rebuild if needed; returns whether it did.
    pub fn update(&mut self, x: &[f64], y: &[f64], r: &[f64], b: Boundary) -> bool {
        self.update_within(x, y, r, b, 0.0)
    }

    /// Rebuild unless the list holds every pair closer than R_i + R_j + `margin` (m);
    /// returns whether it did.
    pub fn update_within(
        &mut self,
        x: &[f64],
        y: &[f64],
        r: &[f64],
        b: Boundary,
        margin: f64,
    ) -> bool {
        let dgamma = strain_since(b, self.offset_ref);
        if self.needs_rebuild_within(x, y, dgamma, margin) {
            self.build(x, y, r, b);
            true
        } else {
            false
        }
    }

    /// The largest pair distance the list holds, 2 R_max + skin (m).
    pub fn reach(&self, r: &[f64]) -> f64 {
        2.0 * r.iter().cloned().fold(0.0, f64::max) + self.skin
    }

    /// Build the list: all pairs closer than R_i + R_j + skin.
    pub fn build(&mut self, x: &[f64], y: &[f64], r: &[f64], b: Boundary) {
        let n = x.len();
        let Spare {
            mut start,
            j: mut js,
            mut shear,
            head,
            items,
            mut cell,
            team,
            segs: mut segments,
        } = std::mem::take(&mut self.spare);
        start.clear();
        js.clear();
        start.push(0u32);
        let cut = self.reach(r);
        self.cut = cut;
        let grid = Grid::new(x, y, cut, b, (head, items), &mut cell);
        let delta = b.image();
        let skin = self.skin;
        // Each grain's partners depend on nothing but the grid: ranges of grains are
        // listed apart (on threads, where lent) and joined in order.
        let ranges = even_ranges(n, team_size(team.as_deref()));
        // A range's partners onto `js`, the end of each grain's onto `ends` (offsets
        // within `js`).
        let list_range =
            |grains: std::ops::Range<usize>, js: &mut Vec<u32>, ends: &mut Vec<u32>| {
                let mut seg: Vec<u32> = vec![0; 64];
                let mut cells = [(0, 0); 9];
                for i in grains {
                    let count = match &grid {
                        Some(g) => g.neighbour_cells(x[i], y[i], &mut cells),
                        None => {
                            cells[0] = (i as u32 + 1, n as u32);
                            1
                        }
                    };
                    let ranges = &cells[..count];
                    // Every candidate is written and kept only by advancing `m`: whether j > i
                    // and whether it is in reach are coin flips a branch would mispredict.
                    let mut m = 0;
                    for &(a, b) in ranges {
                        for q in a as usize..b as usize {
                            let j = match &grid {
                                Some(g) => g.items[q] as usize,
                                None => q,
                            };
                            let (dx, dy) = delta.of(x[i] - x[j], y[i] - y[j]);
                            let c = r[i] + r[j] + skin;
                            if m == seg.len() {
                                seg.push(0);
                            }
                            seg[m] = j as u32;
                            m += ((j > i) & (dx * dx + dy * dy < c * c)) as usize;
                        }
                    }
                    let seg = &mut seg[..m];
                    seg.sort_unstable();
                    js.extend_from_slice(seg);
                    ends.push(js.len() as u32);
                }
            };
        if ranges.len() == 1 {
            // One range: straight into the list (`start` holds its leading 0).
            list_range(0..n, &mut js, &mut start);
        } else {
            // Each range's buffers are kept for the next build.
            segments.resize_with(ranges.len(), Default::default);
            let items = ranges.iter().cloned().zip(segments.iter_mut()).collect();
            chunked(team.as_deref(), items, |(grains, (js, ends))| {
                js.clear();
                ends.clear();
                list_range(grains, js, ends);
            });
            for (part, ends) in &segments {
                let base = js.len() as u32;
                js.extend_from_slice(part);
                start.extend(ends.iter().map(|e| base + e));
            }
        }
        // Carry the history of surviving pairs (both segments are sorted by j).
        shear.clear();
        shear.resize(js.len(), 0.0);
        if self.start.len() == n + 1 {
            let (old_start, old_j, old_shear) = (&self.start, &self.j, &self.shear);
            let mut pieces = Vec::with_capacity(ranges.len());
            let mut rest = &mut shear[..];
            for g in &ranges {
                let (a, b) = rest.split_at_mut((start[g.end] - start[g.start]) as usize);
                pieces.push((g.clone(), a));
                rest = b;
            }
            let (start, js) = (&start, &js);
            chunked(team.as_deref(), pieces, |(grains, piece)| {
                let base = start[grains.start] as usize;
                for i in grains {
                    let (old, new) = (
                        old_start[i] as usize..old_start[i + 1] as usize,
                        start[i] as usize..start[i + 1] as usize,
                    );
                    let mut k = old.start;
                    for m in new {
                        while k < old.end && old_j[k] < js[m] {
                            k += 1;
                        }
                        if k < old.end && old_j[k] == js[m] {
                            piece[m - base] = old_shear[k];
                        }
                    }
                }
            });
        }
        let (head, items) = grid.map(|g| (g.head, g.items)).unwrap_or_default();
        self.spare = Spare {
            start: std::mem::replace(&mut self.start, start),
            j: std::mem::replace(&mut self.j, js),
            shear: std::mem::replace(&mut self.shear, shear),
            head,
            items,
            cell,
            team,
            segs: segments,
        };
        self.x_ref.clear();
        self.x_ref.extend_from_slice(x);
        self.y_ref.clear();
        self.y_ref.extend_from_slice(y);
        self.offset_ref = b.offset();
        self.builds += 1;
    }
}

/// Cells of side ≥ the list cutoff; `None` when the box is too small for a grid (then
/// every pair is tested, which for such small systems is cheap).
struct Grid {
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
    head: Vec<u32>,
    items: Vec<u32>,
}

impl Grid {
    /// The grid of the points, in the buffers `head`, `items` (and `cell`, scratch) of a
    /// previous grid when given.
    fn new(
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
        let cx = ((x - self.x0) / self.cx).floor() as i64;
        let cy = ((y - self.y0) / self.cy).floor() as i64;
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
    fn neighbour_cells(&self, x: f64, y: f64, out: &mut [(u32, u32); 9]) -> usize {
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
                    ccx = ((shifted - self.x0) / self.cx).floor() as i64;
                }
                ny = ny.rem_euclid(self.ncy as i64);
            } else if ny < 0 || ny >= self.ncy as i64 {
                continue;
            }
            let span: &[i64] = if self.periodic && self.ncx < 3 {
                &[0]
            } else {
                &[-1, 0, 1]
            };
            for &dx in span {
                let mut nx = ccx + dx;
                if self.periodic {
                    nx = nx.rem_euclid(self.ncx as i64);
                } else if nx < 0 || nx >= self.ncx as i64 {
                    continue;
                }
                let c = ny as usize * self.ncx + nx as usize;
                out[count] = (self.head[c], self.head[c + 1]);
                count += 1;
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
