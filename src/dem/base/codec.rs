//! Exact binary checkpoints: every f64 is stored bit for bit, so a resumed run
//! continues with the very numbers an uninterrupted one would have had. The encoder,
//! decoder and the parts both scenarios store (grains, the pair list with its history,
//! and their consistency check); each scenario writes its own state with them.

use crate::dem::base::grains::Grains;
use crate::dem::base::verlet::PairList;

#[derive(Default)]
pub struct Enc(pub Vec<u8>);

impl Enc {
    pub fn u64(&mut self, v: u64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    pub fn f64(&mut self, v: f64) {
        self.u64(v.to_bits());
    }
    pub fn bytes(&mut self, b: &[u8]) {
        self.u64(b.len() as u64);
        self.0.extend_from_slice(b);
    }
    pub fn f64s(&mut self, v: &[f64]) {
        self.u64(v.len() as u64);
        v.iter().for_each(|&x| self.f64(x));
    }
    pub fn i64s(&mut self, v: &[i64]) {
        self.u64(v.len() as u64);
        v.iter().for_each(|&x| self.u64(x as u64));
    }
    pub fn u32s(&mut self, v: &[u32]) {
        self.u64(v.len() as u64);
        v.iter().for_each(|&x| self.u64(x as u64));
    }
    pub fn i32s(&mut self, v: &[i32]) {
        self.u64(v.len() as u64);
        v.iter().for_each(|&x| self.u64(x as i64 as u64));
    }
}

pub struct Dec<'a> {
    b: &'a [u8],
    pos: usize,
}

impl<'a> Dec<'a> {
    pub fn new(b: &'a [u8]) -> Self {
        Dec { b, pos: 0 }
    }
    /// A decoder past a header of `skip` bytes that were checked apart, so that its
    /// errors give positions in the whole file.
    pub fn after(b: &'a [u8], skip: usize) -> Self {
        Dec {
            b,
            pos: skip.min(b.len()),
        }
    }
    /// The current byte offset, for error messages.
    pub fn pos(&self) -> usize {
        self.pos
    }
    /// Error for bytes left over after the last field.
    pub fn trailing(&self) -> String {
        format!(
            "trailing bytes after the checkpoint (byte {} of {})",
            self.pos,
            self.b.len()
        )
    }
    fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        if self.pos + n > self.b.len() {
            return Err(format!(
                "truncated at byte {} (wanted {n} more of {})",
                self.pos,
                self.b.len()
            ));
        }
        let s = &self.b[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }
    pub fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(
            self.take(8)?.try_into().expect("8 bytes"),
        ))
    }
    pub fn f64(&mut self) -> Result<f64, String> {
        Ok(f64::from_bits(self.u64()?))
    }
    fn len(&mut self) -> Result<usize, String> {
        let n = self.u64()? as usize;
        if n > self.b.len() {
            return Err(format!("implausible length {n} at byte {}", self.pos));
        }
        Ok(n)
    }
    pub fn bytes(&mut self) -> Result<Vec<u8>, String> {
        let n = self.len()?;
        Ok(self.take(n)?.to_vec())
    }
    pub fn f64s(&mut self) -> Result<Vec<f64>, String> {
        let n = self.len()?;
        (0..n).map(|_| self.f64()).collect()
    }
    pub fn i64s(&mut self) -> Result<Vec<i64>, String> {
        let n = self.len()?;
        (0..n).map(|_| self.u64().map(|v| v as i64)).collect()
    }
    pub fn u32s(&mut self) -> Result<Vec<u32>, String> {
        let n = self.len()?;
        (0..n).map(|_| self.u64().map(|v| v as u32)).collect()
    }
    pub fn i32s(&mut self) -> Result<Vec<i32>, String> {
        let n = self.len()?;
        (0..n)
            .map(|_| self.u64().map(|v| v as i64 as i32))
            .collect()
    }
    pub fn done(&self) -> bool {
        self.pos == self.b.len()
    }
}

/// Grains, in the order both simulators' checkpoints store them.
pub fn enc_grains(e: &mut Enc, g: &Grains) {
    e.i64s(&g.id);
    e.i32s(&g.species);
    for v in [
        &g.radius, &g.mass, &g.inertia, &g.x, &g.y, &g.vx, &g.vy, &g.ax, &g.ay, &g.theta, &g.omega,
    ] {
        e.f64s(v);
    }
}

pub fn dec_grains(d: &mut Dec) -> Result<Grains, String> {
    let mut g = Grains {
        id: d.i64s()?,
        species: d.i32s()?,
        ..Default::default()
    };
    for v in [
        &mut g.radius,
        &mut g.mass,
        &mut g.inertia,
        &mut g.x,
        &mut g.y,
        &mut g.vx,
        &mut g.vy,
        &mut g.ax,
        &mut g.ay,
        &mut g.theta,
        &mut g.omega,
    ] {
        *v = d.f64s()?;
    }
    Ok(g)
}

/// The invariants a step relies on, checked once at load so that a corrupt checkpoint
/// is refused instead of indexing past an array in the first step: every per-grain array
/// has one entry per grain, the pair list is well-formed CSR over those grains, and the
/// grains are physical (finite state, positive finite radius, mass and inertia).
pub fn check_state(g: &Grains, l: &PairList) -> Result<(), String> {
    let n = g.len();
    let per_grain = [
        ("species", g.species.len()),
        ("radius", g.radius.len()),
        ("mass", g.mass.len()),
        ("inertia", g.inertia.len()),
        ("x", g.x.len()),
        ("y", g.y.len()),
        ("vx", g.vx.len()),
        ("vy", g.vy.len()),
        ("ax", g.ax.len()),
        ("ay", g.ay.len()),
        ("theta", g.theta.len()),
        ("omega", g.omega.len()),
    ];
    if let Some((name, len)) = per_grain.iter().find(|(_, len)| *len != n) {
        return Err(format!(
            "grain array '{name}' has {len} entries for {n} grains"
        ));
    }
    for (name, v) in [("x", &g.x), ("y", &g.y), ("vx", &g.vx), ("vy", &g.vy)] {
        if let Some(i) = v.iter().position(|x| !x.is_finite()) {
            return Err(format!("grain {i}: {name} = {} is not finite", v[i]));
        }
    }
    for (name, v) in [
        ("radius", &g.radius),
        ("mass", &g.mass),
        ("inertia", &g.inertia),
    ] {
        if let Some(i) = v.iter().position(|&x| !(x > 0.0 && x.is_finite())) {
            return Err(format!(
                "grain {i}: {name} = {} must be > 0 and finite",
                v[i]
            ));
        }
    }
    let bad = |what: String| Err(format!("pair list: {what}"));
    if l.start.len() != n + 1 || l.start.first().is_some_and(|&s| s != 0) {
        return bad(format!("{} offsets for {n} grains", l.start.len()));
    }
    if let Some(i) = (0..n).find(|&i| l.start[i] > l.start[i + 1]) {
        return bad(format!("offsets decrease at grain {i}"));
    }
    if l.start[n] as usize != l.j.len() || l.shear.len() != l.j.len() {
        return bad(format!(
            "{} partners and {} springs for offsets ending at {}",
            l.j.len(),
            l.shear.len(),
            l.start[n]
        ));
    }
    if let Some(k) = l.j.iter().position(|&j| j as usize >= n) {
        return bad(format!("entry {k} names grain {} of {n}", l.j[k]));
    }
    // A list never built has no reference positions.
    if !((l.x_ref.is_empty() && l.y_ref.is_empty()) || (l.x_ref.len() == n && l.y_ref.len() == n)) {
        return bad(format!(
            "{} and {} reference positions for {n} grains",
            l.x_ref.len(),
            l.y_ref.len()
        ));
    }
    if !(l.skin.is_finite() && l.skin >= 0.0) {
        return bad(format!("skin {} must be >= 0 and finite", l.skin));
    }
    Ok(())
}

/// A pair list with its contact history (the Lees–Edwards offset at the build is the
/// shear checkpoint's own addition).
pub fn enc_list(e: &mut Enc, l: &PairList) {
    e.u32s(&l.start);
    e.u32s(&l.j);
    for v in [&l.shear, &l.x_ref, &l.y_ref] {
        e.f64s(v);
    }
    e.f64(l.skin);
    e.u64(l.builds);
}

pub fn dec_list(d: &mut Dec) -> Result<PairList, String> {
    Ok(PairList {
        start: d.u32s()?,
        j: d.u32s()?,
        shear: d.f64s()?,
        x_ref: d.f64s()?,
        y_ref: d.f64s()?,
        skin: d.f64()?,
        builds: d.u64()?,
        offset_ref: 0.0,
        cut: 0.0,
        spare: Default::default(),
    })
}
