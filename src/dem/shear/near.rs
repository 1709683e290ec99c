//! The sheared disks' near list: the pairs of the Verlet list ([`PairList`], skin 0.3
//! d_s) that are within a much thinner skin (0.01–0.05 d_s), flattened for the force
//! kernels. Rebuilding the Verlet list needs the cell grid; re-selecting from it is one
//! pass over its slots, so the near list can afford a thin skin and be re-selected
//! often, and the kernels then test about 1.9 pairs per grain instead of 2.6. The skin
//! adapts at each selection ([`Slots::skin`]): thinner when selections are rare, thicker
//! when the flow forces them within a few steps (fast shear).
//!
//! Exact: the near list keeps the Verlet list's order, holds every pair that can touch
//! before the next re-selection (the same displacement bound as the Verlet list, with
//! the thin skin) and every pair with contact history, so the forces, their order of
//! summation and the contact bookkeeping are those of the whole list.

use crate::dem::base::verlet::{
    Boundary, PairList, chunked, even_ranges, strain_since, stray_limit, strays, team_size,
};
use crate::dem::shear::params::{Collisions, angle_bin, collision_angle};

/// Extra distance beyond contact kept in the near list (d_s): the range its skin adapts
/// in, and where it starts.
pub const NEAR_SKIN_MIN: f64 = 0.01;
pub const NEAR_SKIN_MAX: f64 = 0.05;

/// Evaluations between selections below which the skin thickens, above which it thins
/// (×1.5 or ÷1.5 at a selection). A selection costs about the kernel's time for 5–10
/// evaluations; each 0.01 d_s of skin about 2 % of every evaluation (measured at
/// N = 1024, φ = 0.82: the thinnest skin was the fastest at γ̇τ_e = 1e-4, by 4–7 %).
const SELECT_SOON: u64 = 30;
const SELECT_LATE: u64 = 120;

/// The near list: slot k is the Verlet list's slot `sel[k]`, with its (i, j), 1/d_ij,
/// d_ij² and contact history (see [`History`]). Indices are checked against `n` when
/// selected, which lets the kernels index without bounds checks. The arrays are padded
/// to a multiple of eight slots with pairs that never touch (d_ij² = −1), so the AVX2
/// and AVX-512 kernels have no tail.
#[derive(Debug, Clone, Default)]
pub struct Slots {
    pub(crate) i: Vec<u32>,
    pub(crate) j: Vec<u32>,
    /// 1/d_ij = 1/(R_i + R_j) (1/d_s).
    pub(crate) inv_dij: Vec<f64>,
    /// d_ij² = (R_i + R_j)² (d_s²).
    pub(crate) dij2: Vec<f64>,
    pub(crate) hist: Vec<f64>,
    /// The Verlet-list slot of each near slot.
    sel: Vec<u32>,
    /// CSR offsets: grain a's near slots are `start[a]..start[a + 1]`.
    pub(crate) start: Vec<u32>,
    /// Real slots (the rest is padding).
    len: usize,
    pub(crate) n: usize,
    /// The Verlet list (`PairList::builds`) this selection came from; none when 0.
    builds: u64,
    /// The skin of this selection (d_s); 0 before the first.
    skin: f64,
    /// Evaluations that found the selection current since it was made.
    since: u64,
    /// Positions and Lees–Edwards offset at the selection, and its reach
    /// 2 R_max + skin (d_s).
    x_ref: Vec<f64>,
    y_ref: Vec<f64>,
    offset_ref: f64,
    reach: f64,
    /// How many times the near list was selected.
    pub selections: u64,
    /// Force sums of the AVX2 kernel (scratch).
    pub(crate) acc: Vec<crate::dem::backend::simd::Quad>,
    /// `acc` holds zeros for n grains: the packed integrator zeroes the sums as it
    /// reads them, which spares the kernel a pass.
    pub(crate) acc_zeroed: bool,
    /// The Verlet list flattened: i, 1/d_ij and d_ij per slot (d_s).
    all_i: Vec<u32>,
    all_inv_dij: Vec<f64>,
    all_dij: Vec<f64>,
    /// Per range of grains, the buffers of its selection (scratch).
    selected: Vec<Selected>,
}

/// One range's selection (see `Slots::select`): its first `len` slots.
#[derive(Debug, Clone, Default)]
struct Selected {
    i: Vec<u32>,
    j: Vec<u32>,
    inv_dij: Vec<f64>,
    dij2: Vec<f64>,
    hist: Vec<f64>,
    sel: Vec<u32>,
    len: usize,
}

impl Selected {
    /// Room for `len` slots, each written before it is read.
    fn resize(&mut self, len: usize) {
        for v in [&mut self.i, &mut self.j, &mut self.sel] {
            v.resize(len, 0);
        }
        for v in [&mut self.inv_dij, &mut self.dij2, &mut self.hist] {
            v.resize(len, 0.0);
        }
    }
}

/// See [`Slots::stray_test`]: positions at the last selection (d_s), the shear since
/// (Δγ) and the squared distance a grain may stray (d_s²).
#[derive(Debug, Clone, Copy)]
pub(crate) struct StrayTest<'a> {
    pub x_ref: &'a [f64],
    pub y_ref: &'a [f64],
    pub dgamma: f64,
    pub lim: f64,
}

impl<'a> StrayTest<'a> {
    /// The test for grains `r` alone (their references).
    pub(crate) fn range(&self, r: std::ops::Range<usize>) -> StrayTest<'a> {
        StrayTest {
            x_ref: &self.x_ref[r.clone()],
            y_ref: &self.y_ref[r],
            ..*self
        }
    }
}

/// A cache of the pair list: two simulations never differ by it.
impl PartialEq for Slots {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl Slots {
    /// Make the near list valid for the state (x, y) (d_s) in boundary `b`: re-select
    /// when the Verlet list was rebuilt, when forced by [`Slots::invalidate`], or when
    /// some grain strayed more than (skin − |Δγ| reach)/2 from the affine flow since
    /// the last selection (the bound of [`PairList::needs_rebuild_sheared`]). The
    /// Verlet list itself is checked (and rebuilt if need be) only then: between
    /// selections the kernels read the near list alone, and at a selection the Verlet
    /// list must hold every pair within R_i + R_j + skin, a stricter test than its own.
    pub fn sync(&mut self, list: &mut PairList, r: &[f64], (x, y): (&[f64], &[f64]), b: Boundary) {
        let strayed = self
            .stray_test(list.builds, r.len(), b)
            .map(|t| strays(x, y, t.x_ref, t.y_ref, t.dgamma, t.lim));
        self.sync_tested(list, r, (x, y), b, strayed);
    }

    /// As [`Slots::sync`], the stray test made by the caller: `strayed` is its answer
    /// for these positions when [`Slots::stray_test`] gave one (the packed integrator
    /// makes it as it writes them), else `None`.
    pub fn sync_tested(
        &mut self,
        list: &mut PairList,
        r: &[f64],
        (x, y): (&[f64], &[f64]),
        b: Boundary,
        strayed: Option<bool>,
    ) {
        if self.current(list, r.len(), b, strayed) {
            self.since += 1;
            return;
        }
        // Adapted only where grains (or the flow) ended the selection: after a rebuild
        // of the Verlet list behind its back (a re-sort) `since` says nothing.
        let moved = self.builds == list.builds && self.builds != 0;
        self.skin = if self.skin == 0.0 {
            NEAR_SKIN_MAX
        } else if !moved {
            self.skin
        } else if self.since < SELECT_SOON {
            (self.skin * 1.5).min(NEAR_SKIN_MAX)
        } else if self.since > SELECT_LATE {
            (self.skin / 1.5).max(NEAR_SKIN_MIN)
        } else {
            self.skin
        };
        self.since = 0;
        list.update_within(x, y, r, b, self.skin);
        self.select(list, r, (x, y), b);
    }

    /// The skin of the current selection (d_s; 0 before the first).
    pub fn skin(&self) -> f64 {
        self.skin
    }

    /// Start the next selection at `skin` (d_s, within the adaptive range): for tests
    /// that the skin changes no number.
    pub fn set_skin(&mut self, skin: f64) {
        self.skin = skin.clamp(NEAR_SKIN_MIN, NEAR_SKIN_MAX);
        // A forced selection (not ended by grains) keeps the skin.
        self.builds = 0;
    }

    /// Whether the selection holds for n grains in boundary `b` whose stray test
    /// ([`Slots::stray_test`]) answered `strayed`; else `sync_tested` re-selects, and
    /// reads the positions.
    pub fn current(&self, list: &PairList, n: usize, b: Boundary, strayed: Option<bool>) -> bool {
        strayed == Some(false) && self.stray_test(list.builds, n, b).is_some()
    }

    /// The stray test that keeps this selection for n grains in boundary `b`: some
    /// grain strayed when (x − x_ref − Δγ y_ref)² + (y − y_ref)² > `lim` (d_s²). `None`
    /// when the list must be re-selected whatever the positions.
    /// (`builds`: the Verlet list's `PairList::builds`.)
    pub(crate) fn stray_test(&self, builds: u64, n: usize, b: Boundary) -> Option<StrayTest<'_>> {
        let dgamma = strain_since(b, self.offset_ref);
        let current = self.builds == builds
            && self.builds != 0
            && self.n == n
            && self.x_ref.len() == n
            && self.y_ref.len() == n;
        let lim = stray_limit(self.skin, dgamma, self.reach).filter(|_| current)?;
        Some(StrayTest {
            x_ref: &self.x_ref,
            y_ref: &self.y_ref,
            dgamma,
            lim,
        })
    }

    /// Forget the selection (the Verlet list's history was changed behind its back).
    pub fn invalidate(&mut self) {
        self.builds = 0;
    }

    fn select(&mut self, list: &PairList, r: &[f64], (x, y): (&[f64], &[f64]), b: Boundary) {
        let n = r.len();
        let total = list.j.len();
        // Checked on every selection (the list's fields are public): the kernels index
        // with these without bounds checks.
        assert!(
            n > 0
                && x.len() == n
                && y.len() == n
                && list.start.len() == n + 1
                && list.start[n] as usize == total
                && list.shear.len() == total
                && list.j.iter().all(|&v| (v as usize) < n),
            "pair list does not match the grains"
        );
        if self.builds != list.builds || self.n != n || self.all_i.len() != total {
            self.all_i.clear();
            for a in 0..n {
                let len = (list.start[a + 1] - list.start[a]) as usize;
                self.all_i.extend(std::iter::repeat_n(a as u32, len));
            }
            let pairs = || self.all_i.iter().zip(&list.j);
            let dij = |(&a, &c): (&u32, &u32)| r[a as usize] + r[c as usize];
            self.all_dij.clear();
            self.all_dij.extend(pairs().map(dij));
            self.all_inv_dij.clear();
            self.all_inv_dij
                .extend(self.all_dij.iter().map(|d| 1.0 / d));
        }
        let delta = b.image();
        // Ranges of grains select apart (on the threads the Verlet list was lent, if
        // any) and join in order: the same list.
        let team = list.spare.team.as_deref();
        let ranges = even_ranges(n, team_size(team));
        let select_range = |ks: std::ops::Range<usize>, out: &mut Selected| {
            out.resize(ks.len());
            // Every Verlet slot is written at m and kept by advancing m: whether it is
            // near is a coin flip a branch would mispredict.
            let mut m = 0;
            for k in ks {
                let (a, c) = (self.all_i[k] as usize, list.j[k] as usize);
                let (dx, dy) = delta.of(x[a] - x[c], y[a] - y[c]);
                let dij = self.all_dij[k];
                let reach = dij + self.skin;
                let h = list.shear[k];
                // Pairs with history stay, however far: their contact ends here.
                // (Written as "not beyond" so a NaN separation stays in, as the
                // straight loop sees it.)
                let keep = !(dx * dx + dy * dy >= reach * reach) | (h != 0.0);
                out.i[m] = a as u32;
                out.j[m] = c as u32;
                out.inv_dij[m] = self.all_inv_dij[k];
                out.dij2[m] = dij * dij;
                out.hist[m] = h;
                out.sel[m] = k as u32;
                m += keep as usize;
            }
            out.len = m;
        };
        let mut parts = std::mem::take(&mut self.selected);
        if ranges.len() == 1 {
            // One range: straight into the list's own arrays.
            let mut out = Selected {
                i: std::mem::take(&mut self.i),
                j: std::mem::take(&mut self.j),
                inv_dij: std::mem::take(&mut self.inv_dij),
                dij2: std::mem::take(&mut self.dij2),
                hist: std::mem::take(&mut self.hist),
                sel: std::mem::take(&mut self.sel),
                len: 0,
            };
            select_range(0..total, &mut out);
            parts.clear();
            parts.push(out);
        } else {
            // Each range's buffers are kept for the next selection (fresh memory is
            // slow to touch).
            parts.resize_with(ranges.len(), Default::default);
            let items = ranges
                .iter()
                .map(|g| list.start[g.start] as usize..list.start[g.end] as usize)
                .zip(parts.iter_mut())
                .collect();
            chunked(team, items, |(ks, out)| select_range(ks, out));
        }
        let m: usize = parts.iter().map(|p| p.len).sum();
        if ranges.len() == 1 {
            let out = parts.pop().expect("one range");
            (self.i, self.j, self.inv_dij) = (out.i, out.j, out.inv_dij);
            (self.dij2, self.hist, self.sel) = (out.dij2, out.hist, out.sel);
        } else {
            for v in [&mut self.i, &mut self.j, &mut self.sel] {
                v.clear();
            }
            for v in [&mut self.inv_dij, &mut self.dij2, &mut self.hist] {
                v.clear();
            }
            for p in &parts {
                let m = p.len;
                self.i.extend_from_slice(&p.i[..m]);
                self.j.extend_from_slice(&p.j[..m]);
                self.inv_dij.extend_from_slice(&p.inv_dij[..m]);
                self.dij2.extend_from_slice(&p.dij2[..m]);
                self.hist.extend_from_slice(&p.hist[..m]);
                self.sel.extend_from_slice(&p.sel[..m]);
            }
        }
        self.selected = parts;
        // Padding (pairs that never touch) up to a multiple of eight; the arrays keep
        // the Verlet list's length, rounded up to eight.
        let padded = total.next_multiple_of(8);
        for v in [&mut self.i, &mut self.j, &mut self.sel] {
            v.truncate(m);
            v.resize(padded, 0);
        }
        for (v, pad) in [
            (&mut self.inv_dij, 0.0),
            (&mut self.dij2, -1.0),
            (&mut self.hist, 0.0),
        ] {
            v.truncate(m);
            v.resize(padded, pad);
        }
        self.len = m;
        self.start.clear();
        self.start.resize(n + 1, 0);
        for &a in &self.i[..m] {
            self.start[a as usize + 1] += 1;
        }
        for a in 0..n {
            self.start[a + 1] += self.start[a];
        }
        let padded = m.next_multiple_of(8);
        self.x_ref.clear();
        self.x_ref.extend_from_slice(x);
        self.y_ref.clear();
        self.y_ref.extend_from_slice(y);
        self.offset_ref = b.offset();
        self.reach = 2.0 * r.iter().cloned().fold(0.0, f64::max) + self.skin;
        debug_assert!(self.i.len() >= padded && self.j.len() >= padded);
        self.n = n;
        self.builds = list.builds;
        self.selections += 1;
    }

    /// Run `f` with the near list's contact history, written through to the Verlet
    /// list's `all` (its `shear`).
    pub fn with_history<R>(
        &mut self,
        all: &mut [f64],
        f: impl FnOnce(&mut Self, &mut History) -> R,
    ) -> R {
        let mut near = std::mem::take(&mut self.hist);
        let sel = std::mem::take(&mut self.sel);
        let r = f(
            self,
            &mut History {
                near: &mut near,
                sel: &sel,
                all,
                log: None,
            },
        );
        (self.hist, self.sel) = (near, sel);
        r
    }

    /// A thread's tables for grains `lo..hi` (the near list's CSR runs of those grains,
    /// a contiguous range of its slots): `own`, those slots in order, and `imports`, in
    /// order, the slots of earlier grains whose partner j lies in `lo..hi`. Evaluated
    /// in that order, imports first, they add to each grain of the range every term it
    /// gets, in the near list's order: the same sums bit for bit as one pass over the
    /// list. (The import slots are also evaluated by their owner's thread: a few
    /// duplicated pairs, against waiting.) Returns the first slot of `own` in the list.
    pub(crate) fn split_into(
        &self,
        (lo, hi): (usize, usize),
        own: &mut Slots,
        imports: &mut Slots,
    ) -> usize {
        let (k0, k1) = (self.start[lo] as usize, self.start[hi] as usize);
        own.clear_table();
        own.extend_from(self, k0..k1);
        own.pad(lo);
        imports.clear_table();
        for k in 0..k0 {
            let j = self.j[k] as usize;
            if (lo..hi).contains(&j) {
                imports.extend_from(self, k..k + 1);
            }
        }
        imports.pad(lo);
        for t in [&mut *own, &mut *imports] {
            t.n = self.n;
        }
        k0
    }

    fn clear_table(&mut self) {
        self.i.clear();
        self.j.clear();
        self.inv_dij.clear();
        self.dij2.clear();
        self.hist.clear();
    }

    fn extend_from(&mut self, from: &Slots, r: std::ops::Range<usize>) {
        self.i.extend_from_slice(&from.i[r.clone()]);
        self.j.extend_from_slice(&from.j[r.clone()]);
        self.inv_dij.extend_from_slice(&from.inv_dij[r.clone()]);
        self.dij2.extend_from_slice(&from.dij2[r.clone()]);
        self.hist.extend_from_slice(&from.hist[r]);
    }

    /// Padded to a multiple of eight with slots (g, g) that never touch (as `select`
    /// pads, on a grain of the thread's own, so that their ±0.0 terms land there).
    fn pad(&mut self, g: usize) {
        self.len = self.i.len();
        let padded = self.len.next_multiple_of(8);
        self.i.resize(padded, g as u32);
        self.j.resize(padded, g as u32);
        self.inv_dij.resize(padded, 0.0);
        self.dij2.resize(padded, -1.0);
        self.hist.resize(padded, 0.0);
    }

    /// Copy the near list's current histories of slots `k0..` into this table's
    /// (`split_into`'s `own`).
    pub(crate) fn copy_history(&mut self, from: &Slots, k0: usize) {
        let len = self.len;
        self.hist[..len].copy_from_slice(&from.hist[k0..k0 + len]);
    }

    /// The pairs (i, j) of the near list, in order.
    pub fn pairs(&self) -> impl Iterator<Item = (u32, u32)> + '_ {
        self.i[..self.len]
            .iter()
            .copied()
            .zip(self.j[..self.len].iter().copied())
    }

    /// Slots (padding excluded).
    pub fn len(&self) -> usize {
        self.len
    }
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// The contact history of the near slots (0, or 1 + the time the contact began), each
/// change written through to the Verlet list's (so that list is always current).
pub struct History<'a> {
    pub near: &'a mut [f64],
    sel: &'a [u32],
    all: &'a mut [f64],
    /// A thread's evaluation: events are logged, not applied, and applied afterwards in
    /// slot order (`Collisions` sums durations, whose rounding depends on the order).
    log: Option<&'a mut Vec<Event>>,
}

/// A contact event a thread met (see [`History::logging`]): near slot `k` of its table,
/// with what [`History::update`] was given.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Event {
    pub k: usize,
    pub touch: bool,
    pub d: (f64, f64),
    pub dv: (f64, f64),
}

impl<'a> History<'a> {
    /// A history that reads `near` (a thread's copy of its slots' histories) and logs
    /// each event into `log` instead of applying it.
    pub(crate) fn logging(near: &'a mut [f64], log: &'a mut Vec<Event>) -> Self {
        History {
            near,
            sel: &[],
            all: &mut [],
            log: Some(log),
        }
    }
}

impl History<'_> {
    /// Near slot k at time `now` (τ_e), whose pair touches or not (separation (dx, dy),
    /// d_s; relative velocity `dv()`, d_s/τ_e, asked for only at an event): see
    /// [`contact_event`].
    #[inline]
    pub fn update(
        &mut self,
        k: usize,
        touch: bool,
        d: (f64, f64),
        dv: impl FnOnce() -> (f64, f64),
        now: f64,
        coll: &mut Collisions,
    ) {
        let h = self.near[k];
        if touch != (h != 0.0) {
            if let Some(log) = self.log.as_mut() {
                let dv = dv();
                log.push(Event { k, touch, d, dv });
                return;
            }
            let new = contact_event(h, touch, d, dv(), now, coll);
            self.near[k] = new;
            self.all[self.sel[k] as usize] = new;
        }
    }
}

/// A pair's contact history `h` (0, or 1 + the time the contact began) at time `now`
/// (τ_e), the pair touching or not (separation r_ij = (dx, dy), d_s; relative velocity
/// v_ij = `dv`, d_s/τ_e, the image's Lees–Edwards velocity included): a contact that
/// begins gets its start time, one that ends adds its duration; both count, and their
/// collision angle ϑ (Eq. 27) goes into the making or breaking histogram. Returns the
/// new history.
#[inline]
pub fn contact_event(
    h: f64,
    touch: bool,
    d: (f64, f64),
    dv: (f64, f64),
    now: f64,
    coll: &mut Collisions,
) -> f64 {
    if touch == (h != 0.0) {
        return h;
    }
    let bin = collision_angle(d, dv).map(angle_bin);
    let hist = if touch {
        &mut coll.angle_making
    } else {
        &mut coll.angle_breaking
    };
    match bin {
        Some(b) => hist[b] += 1,
        None => coll.angle_undefined += 1,
    }
    if touch {
        coll.begun += 1;
        1.0 + now
    } else {
        coll.ended_at(h - 1.0, now);
        0.0
    }
}

/// Called by the kernels as the force sums of grains `range` are complete (every slot
/// with such a grain done), with those sums and the near list: each range once, in
/// order, together covering every grain. The held sums may be read and changed (the
/// packed integrator corrects those grains and zeroes their sums while the kernel goes
/// on with the rest: its memory traffic then overlaps the kernel's arithmetic).
pub(crate) type Done<'a> =
    &'a mut dyn FnMut(std::ops::Range<usize>, &mut [crate::dem::backend::simd::Quad], &Slots);

/// The least grains per [`Done`] call but the last: fewer calls, each long enough for
/// its loops (48–96 measured 2 % faster than a call per block of slots).
pub(crate) const DONE_MIN: usize = 48;

/// Contact events of the `count` slots from k on (`touch` bits, separations `dx`, `dy`
/// and Lees–Edwards image numbers `img` by lane; see `History::update`), the relative
/// velocities read from the packed (v_x, v_y, ω, R) records `vel` as the kernels form
/// them. Out of line: rare, and inlined it would crowd the hot loop's registers.
#[cold]
#[inline(never)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn contact_events(
    k: usize,
    count: usize,
    touch: u32,
    (dx, dy, img): (&[f64], &[f64], &[f64]),
    (slots, vel, shear_v): (&Slots, &[crate::dem::backend::simd::Quad], f64),
    hist: &mut History,
    now: f64,
    coll: &mut Collisions,
) {
    for l in 0..count {
        let dv = || {
            let (i, j) = (slots.i[k + l] as usize, slots.j[k + l] as usize);
            let (vi, vj) = (vel[i].0, vel[j].0);
            // As the pair loop's `Motion`: j's image moves img·γ̇L faster along x.
            (vi[0] - vj[0] - img[l] * shear_v, vi[1] - vj[1])
        };
        hist.update(k + l, touch >> l & 1 == 1, (dx[l], dy[l]), dv, now, coll);
    }
}
