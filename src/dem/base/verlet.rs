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

pub use crate::dem::base::boundary::Boundary;
pub use crate::geom::{MinImage, rint};

use crate::dem::base::cell_grid::Grid;
use std::sync::Mutex;

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
    /// Per part of a build, its lists (kept for the next).
    segs: Vec<Segment>,
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

    /// Build the list: all pairs closer than R_i + R_j + skin (on the team of
    /// `spare.team` where lent, one part of the grains a thread).
    pub fn build(&mut self, x: &[f64], y: &[f64], r: &[f64], b: Boundary) {
        let parts = team_size(self.spare.team.as_deref());
        let plan = self.begin_build(x, y, r, b, parts);
        let list = &*self;
        chunked(plan.team.as_deref(), (0..plan.parts()).collect(), |k| {
            list.list_part(&plan, k, x, y, r)
        });
        self.finish_build(plan, x, y);
    }

    /// The first step of a build in `parts` parts (ranges of grains): the cell grid.
    /// Each part is then listed by [`PairList::list_part`], on any thread, in any
    /// order, and [`PairList::finish_build`] joins them in order: a grain's partners
    /// depend on nothing but the grid, so any number of parts gives the same list.
    /// The list stays the old one until the build is finished.
    pub fn begin_build(
        &mut self,
        x: &[f64],
        y: &[f64],
        r: &[f64],
        b: Boundary,
        parts: usize,
    ) -> PendingBuild {
        let Spare {
            start,
            j,
            shear,
            head,
            items,
            mut cell,
            team,
            segs,
        } = std::mem::take(&mut self.spare);
        let cut = self.reach(r);
        let grid = Grid::new(x, y, cut, b, (head, items), &mut cell);
        let ranges = even_ranges(x.len(), parts);
        let mut segs = segs;
        segs.resize_with(ranges.len(), Default::default);
        // An unlisted part must not pass for listed with the last build's lists.
        segs.iter_mut().for_each(|s| s.ends.clear());
        PendingBuild {
            grid,
            ranges,
            open: b == Boundary::Open,
            delta: b.image(),
            skin: self.skin,
            cut,
            offset: b.offset(),
            segs: segs.into_iter().map(Mutex::new).collect(),
            fresh: (start, j, shear),
            cell,
            team,
        }
    }

    /// Part `k` of a build begun by [`PairList::begin_build`] (on the same positions
    /// and radii): its grains' partners, sorted, each with the tangential spring this
    /// list holds for that pair (0 for a new pair). Reads only; a part beyond the
    /// build's is nothing.
    pub fn list_part(&self, plan: &PendingBuild, k: usize, x: &[f64], y: &[f64], r: &[f64]) {
        let Some(grains) = plan.ranges.get(k).cloned() else {
            return;
        };
        let n = x.len();
        let mut seg = plan.segs[k].lock().expect("a part's lists");
        let Segment { js, ends, shear } = &mut *seg;
        js.clear();
        ends.clear();
        ends.push(0);
        // An open plane needs no image: its own loop (one compiled per closure),
        // without the rounding.
        let sizes = (x, y, r, plan.skin);
        if plan.open {
            list_grains(
                plan.grid.as_ref(),
                grains.clone(),
                sizes,
                |dx, dy| (dx, dy),
                js,
                ends,
            );
        } else {
            let d = plan.delta;
            list_grains(
                plan.grid.as_ref(),
                grains.clone(),
                sizes,
                |dx, dy| d.of(dx, dy),
                js,
                ends,
            );
        }
        // Carry the history of surviving pairs (both partner lists are sorted by j).
        shear.clear();
        shear.resize(js.len(), 0.0);
        if self.start.len() == n + 1 {
            for (g, i) in grains.enumerate() {
                let old = self.start[i] as usize..self.start[i + 1] as usize;
                let mut o = old.start;
                for m in ends[g] as usize..ends[g + 1] as usize {
                    while o < old.end && self.j[o] < js[m] {
                        o += 1;
                    }
                    if o < old.end && self.j[o] == js[m] {
                        shear[m] = self.shear[o];
                    }
                }
            }
        }
    }

    /// Join the listed parts of `plan` in order into this list (positions as given
    /// to [`PairList::begin_build`]).
    ///
    /// # Panics
    /// If a part was not listed.
    pub fn finish_build(&mut self, plan: PendingBuild, x: &[f64], y: &[f64]) {
        let PendingBuild {
            grid,
            ranges,
            segs,
            fresh: (mut start, mut js, mut shear),
            cut,
            offset,
            cell,
            team,
            ..
        } = plan;
        let mut segs: Vec<Segment> = segs
            .into_iter()
            .map(|s| s.into_inner().expect("a part's lists"))
            .collect();
        assert!(
            ranges.len() == segs.len()
                && ranges
                    .iter()
                    .zip(&segs)
                    .all(|(r, s)| s.ends.len() == r.len() + 1)
                && ranges.last().is_none_or(|r| r.end == x.len()),
            "finish_build: every part listed"
        );
        if let [one] = &mut segs[..] {
            // One part: its lists are the list (its buffers take the old ones'
            // place for the next build).
            std::mem::swap(&mut start, &mut one.ends);
            std::mem::swap(&mut js, &mut one.js);
            std::mem::swap(&mut shear, &mut one.shear);
        } else {
            start.clear();
            js.clear();
            shear.clear();
            start.push(0);
            for s in &segs {
                let base = js.len() as u32;
                js.extend_from_slice(&s.js);
                shear.extend_from_slice(&s.shear);
                start.extend(s.ends[1..].iter().map(|e| base + e));
            }
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
            segs,
        };
        self.cut = cut;
        self.x_ref.clear();
        self.x_ref.extend_from_slice(x);
        self.y_ref.clear();
        self.y_ref.extend_from_slice(y);
        self.offset_ref = offset;
        self.builds += 1;
    }
}

/// The partners j > i closer than R_i + R_j + skin of each grain i of `grains`, sorted,
/// onto `js`, and the end of each grain's onto `ends`; `image` maps a separation to its
/// nearest image. Without a grid every later grain is a candidate.
fn list_grains(
    grid: Option<&Grid>,
    grains: std::ops::Range<usize>,
    (x, y, r, skin): (&[f64], &[f64], &[f64], f64),
    image: impl Fn(f64, f64) -> (f64, f64),
    js: &mut Vec<u32>,
    ends: &mut Vec<u32>,
) {
    let n = x.len();
    let mut cand: Vec<u32> = vec![0; 64];
    let mut cells = [(0, 0); 9];
    for i in grains {
        let count = match grid {
            Some(g) => g.neighbour_cells(x[i], y[i], &mut cells),
            None => {
                cells[0] = (i as u32 + 1, n as u32);
                1
            }
        };
        // Every candidate is written and kept only by advancing `m`: whether j > i and
        // whether it is in reach are coin flips a branch would mispredict.
        let mut m = 0;
        for &(a, b) in &cells[..count] {
            for q in a as usize..b as usize {
                let j = match grid {
                    Some(g) => g.items[q] as usize,
                    None => q,
                };
                let (dx, dy) = image(x[i] - x[j], y[i] - y[j]);
                let c = r[i] + r[j] + skin;
                if m == cand.len() {
                    cand.push(0);
                }
                cand[m] = j as u32;
                m += ((j > i) & (dx * dx + dy * dy < c * c)) as usize;
            }
        }
        let found = &mut cand[..m];
        found.sort_unstable();
        js.extend_from_slice(found);
        ends.push(js.len() as u32);
    }
}

/// A build of the list under way ([`PairList::begin_build`]): the grid, the parts'
/// ranges of grains and what each part has listed.
#[derive(Debug)]
pub struct PendingBuild {
    grid: Option<Grid>,
    ranges: Vec<std::ops::Range<usize>>,
    /// No periodic axis (`delta` is then the identity).
    open: bool,
    delta: MinImage,
    skin: f64,
    cut: f64,
    /// The Lees–Edwards offset the list is built at (m; 0 for other boundaries).
    offset: f64,
    /// One per part, each locked only by the thread listing it.
    segs: Vec<Mutex<Segment>>,
    /// The buffers the list will be built in (the previous build's).
    fresh: (Vec<u32>, Vec<u32>, Vec<f64>),
    cell: Vec<u32>,
    team: Option<std::sync::Arc<crate::dem::backend::team::Team>>,
}

impl PendingBuild {
    /// Parts to list.
    pub fn parts(&self) -> usize {
        self.ranges.len()
    }
}

/// A part's partners (`js`), the end of each grain's within them after a leading 0
/// (`ends`), and their springs (`shear`).
#[derive(Debug, Clone, Default)]
struct Segment {
    js: Vec<u32>,
    ends: Vec<u32>,
    shear: Vec<f64>,
}

#[cfg(test)]
mod tests;
