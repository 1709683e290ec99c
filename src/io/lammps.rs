//! LAMMPS text dumps (`dump custom`/`atom`): repeated snapshots of
//! `ITEM: TIMESTEP`, `ITEM: NUMBER OF ATOMS`, `ITEM: BOX BOUNDS [xy xz yz] pp pp pp`,
//! `ITEM: ATOMS id type x y ...`. Positions from unwrapped `xu yu` (or `xsu ysu`), else
//! wrapped `x y` (or scaled `xs ys`, triclinic aware) unwrapped with the image flags
//! `ix iy` where the dump has them; radius from `radius` or `diameter`; orthogonal or
//! triclinic (`xy` tilt = Lees–Edwards offset) boxes. Frame = snapshot index.
//!
//! Unwrapping follows LAMMPS' own (`Domain::unmap`), with each snapshot's box vectors
//! a = (lx, 0), b = (xy, ly): r_u = r + ix·a + iy·b. A wrapped track jumps by a box
//! length where its grain crosses a boundary, and, across the sheared boundary, loses
//! the Lees–Edwards image velocity n_y·γ̇·ly; so a dump without flags or unwrapped
//! columns is read wrapped with a warning (in `TracksMeta::warnings`).

use crate::error::{Error, Result};
use crate::tracks::{FrameBox, LARGE, RowLocator, SMALL, Tracks, TracksMeta, finalize};
use std::io::BufRead;
use std::path::Path;

#[derive(Debug, Clone, Default)]
pub struct LammpsOptions {
    pub unit: Option<String>,
    /// Time between snapshots (s or reduced).
    pub frame_time: Option<f64>,
    /// Radii by type (type 1 small, type 2 large) when the dump has no radius column.
    pub radii: Option<(f64, f64)>,
}

struct Lines<R> {
    inner: std::io::Lines<R>,
    line: usize,
    file: String,
}

impl<R: BufRead> Lines<R> {
    fn next(&mut self) -> Result<Option<String>> {
        match self.inner.next() {
            None => Ok(None),
            Some(Ok(l)) => {
                self.line += 1;
                Ok(Some(l))
            }
            Some(Err(e)) => Err(Error::input(
                &self.file,
                format!("line {}: {e}", self.line + 1),
            )),
        }
    }
    fn need(&mut self, what: &str) -> Result<String> {
        self.next()?.ok_or_else(|| {
            Error::input(
                &self.file,
                format!(
                    "dump cut off after line {}: expected {what} (snapshot incomplete)",
                    self.line
                ),
            )
        })
    }
    fn err(&self, column: &str, msg: String) -> Error {
        Error::Value {
            file: self.file.clone(),
            loc: format!("line {}", self.line),
            column: column.into(),
            msg,
        }
    }
}

fn num(l: &Lines<impl BufRead>, s: &str, col: &str) -> Result<f64> {
    s.parse::<f64>()
        .map_err(|_| l.err(col, format!("malformed number '{s}'")))
}

pub fn read_lammps(path: &Path, opt: &LammpsOptions) -> Result<Tracks> {
    let file = path.display().to_string();
    let f = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut l = Lines {
        inner: std::io::BufReader::new(f).lines(),
        line: 0,
        file: file.clone(),
    };
    let mut t = Tracks::default();
    let mut lines_of_rows = Vec::new();
    let mut boxes = Vec::new();
    let mut species = Vec::new();
    let mut snapshot = 0i64;
    let mut first_timestep = None;
    let mut timesteps = Vec::new();
    let mut wrapped_dirs = std::collections::BTreeSet::new();
    while let Some(head) = l.next()? {
        if head.trim().is_empty() {
            continue;
        }
        if !head.starts_with("ITEM: TIMESTEP") {
            return Err(l.err(
                "(item)",
                format!("expected 'ITEM: TIMESTEP', found '{head}'"),
            ));
        }
        let ts = l.need("the timestep")?;
        let ts: i64 = ts
            .trim()
            .parse()
            .map_err(|_| l.err("timestep", format!("malformed timestep '{ts}'")))?;
        first_timestep.get_or_insert(ts);
        timesteps.push(ts);
        let h = l.need("ITEM: NUMBER OF ATOMS")?;
        if !h.starts_with("ITEM: NUMBER OF ATOMS") {
            return Err(l.err(
                "(item)",
                format!("expected 'ITEM: NUMBER OF ATOMS', found '{h}'"),
            ));
        }
        let n = l.need("the number of atoms")?;
        let n: usize = n
            .trim()
            .parse()
            .map_err(|_| l.err("number of atoms", format!("malformed count '{n}'")))?;
        let bh = l.need("ITEM: BOX BOUNDS")?;
        if !bh.starts_with("ITEM: BOX BOUNDS") {
            return Err(l.err(
                "(item)",
                format!("expected 'ITEM: BOX BOUNDS', found '{bh}'"),
            ));
        }
        let triclinic = bh.contains("xy");
        let flags: Vec<&str> = bh
            .split_whitespace()
            .skip(3)
            .filter(|w| !matches!(*w, "xy" | "xz" | "yz"))
            .collect();
        let mut b = [[0.0; 3]; 3];
        for row in b.iter_mut() {
            let s = l.need("a box bounds line")?;
            let w: Vec<&str> = s.split_whitespace().collect();
            if w.len() < if triclinic { 3 } else { 2 } {
                return Err(l.err("box bounds", format!("expected bounds, found '{s}'")));
            }
            for (k, v) in w.iter().take(3).enumerate() {
                row[k] = num(&l, v, "box bounds")?;
            }
        }
        let xy = if triclinic { b[0][2] } else { 0.0 };
        let xz = if triclinic { b[1][2] } else { 0.0 };
        let yz = if triclinic { b[2][2] } else { 0.0 };
        // Triclinic dumps give the bounding box; recover the true lo/hi (LAMMPS docs).
        let xlo = b[0][0] - [0.0, xy, xz, xy + xz].into_iter().fold(f64::MAX, f64::min);
        let xhi = b[0][1] - [0.0, xy, xz, xy + xz].into_iter().fold(f64::MIN, f64::max);
        let ylo = b[1][0] - 0f64.min(yz);
        let yhi = b[1][1] - 0f64.max(yz);
        let periodic = |k: usize| flags.get(k).is_some_and(|f| *f == "pp");
        boxes.push(FrameBox {
            frame: snapshot,
            x_lo: xlo,
            y_lo: ylo,
            lx: xhi - xlo,
            ly: yhi - ylo,
            xy,
            periodic_x: periodic(0),
            periodic_y: periodic(1),
        });
        let ah = l.need("ITEM: ATOMS")?;
        let cols: Vec<&str> = match ah.strip_prefix("ITEM: ATOMS") {
            Some(c) => c.split_whitespace().collect(),
            None => return Err(l.err("(item)", format!("expected 'ITEM: ATOMS', found '{ah}'"))),
        };
        let find = |names: &[&str]| names.iter().find_map(|n| cols.iter().position(|c| c == n));
        let id =
            find(&["id"]).ok_or_else(|| l.err("id", "ATOMS header has no 'id' column".into()))?;
        // Unwrapped columns first: they need no flags and are what LAMMPS itself
        // computes from them.
        let pick = |x: &str, y: &str| find(&[x]).zip(find(&[y]));
        let (xi, yi, scaled, unwrapped) = if let Some((a, b)) = pick("xu", "yu") {
            (a, b, false, true)
        } else if let Some((a, b)) = pick("xsu", "ysu") {
            (a, b, true, true)
        } else if let Some((a, b)) = pick("x", "y") {
            (a, b, false, false)
        } else if let Some((a, b)) = pick("xs", "ys") {
            (a, b, true, false)
        } else {
            return Err(Error::MissingColumns {
                file: file.clone(),
                missing: vec!["x y (or xu yu, xs ys, xsu ysu)".into()],
                found: cols.iter().map(|s| s.to_string()).collect(),
                expected: vec!["id".into(), "x".into(), "y".into()],
            });
        };
        let (ixi, iyi) = if unwrapped {
            (None, None)
        } else {
            (find(&["ix"]), find(&["iy"]))
        };
        // A periodic direction whose crossings nothing records: positions stay wrapped.
        if !unwrapped {
            if periodic(0) && ixi.is_none() {
                wrapped_dirs.insert("x (no ix)");
            }
            if periodic(1) && iyi.is_none() {
                wrapped_dirs.insert("y (no iy)");
            }
        }
        let (lx, ly) = (xhi - xlo, yhi - ylo);
        let ri = find(&["radius"]);
        let di = find(&["diameter"]);
        let ty = find(&["type"]);
        if ri.is_none() && di.is_none() && (opt.radii.is_none() || ty.is_none()) {
            return Err(Error::input(
                &file,
                format!(
                    "line {}: no radius or diameter column; pass --radii SMALL,LARGE (type 1 small, type 2 large) and dump 'type'",
                    l.line
                ),
            ));
        }
        for _ in 0..n {
            let s = l.need("an atom line")?;
            let w: Vec<&str> = s.split_whitespace().collect();
            if w.len() != cols.len() {
                return Err(l.err(
                    "(row)",
                    format!(
                        "{} fields, expected {} ({})",
                        w.len(),
                        cols.len(),
                        cols.join(" ")
                    ),
                ));
            }
            let pid: i64 = w[id]
                .parse()
                .map_err(|_| l.err("id", format!("malformed id '{}'", w[id])))?;
            let (mut x, mut y) = (num(&l, w[xi], cols[xi])?, num(&l, w[yi], cols[yi])?);
            if scaled {
                (x, y) = (xlo + x * lx + y * xy, ylo + y * ly);
            }
            let image = |k: Option<usize>| -> Result<f64> {
                k.map_or(Ok(0.0), |k| {
                    w[k].parse::<i64>()
                        .map(|n| n as f64)
                        .map_err(|_| l.err(cols[k], format!("malformed image flag '{}'", w[k])))
                })
            };
            let (ix, iy) = (image(ixi)?, image(iyi)?);
            x += ix * lx + iy * xy;
            y += iy * ly;
            let r = match (ri, di) {
                (Some(k), _) => num(&l, w[k], "radius")?,
                (None, Some(k)) => 0.5 * num(&l, w[k], "diameter")?,
                _ => {
                    let tk = ty.expect("checked above");
                    let (rs, rl) = opt.radii.expect("checked above");
                    match w[tk] {
                        "1" => rs,
                        "2" => rl,
                        other => {
                            return Err(l.err(
                                "type",
                                format!("type {other}: with --radii only types 1 (small) and 2 (large) are known"),
                            ));
                        }
                    }
                }
            };
            t.frame.push(snapshot);
            t.particle.push(pid);
            t.x.push(x);
            t.y.push(y);
            t.radius.push(r);
            lines_of_rows.push(l.line);
        }
        snapshot += 1;
    }
    if t.is_empty() {
        return Err(Error::input(&file, "empty dump: no snapshots"));
    }
    // Species: the larger of the two radii is "large".
    let rmax = t.radius.iter().copied().fold(f64::MIN, f64::max);
    let rmin = t.radius.iter().copied().fold(f64::MAX, f64::min);
    let mid = 0.5 * (rmax + rmin);
    species.extend(
        t.radius
            .iter()
            .map(|&r| if rmax > rmin && r > mid { LARGE } else { SMALL }),
    );
    if rmax > rmin {
        t.species = Some(species);
    }
    if let Some(dt) = opt.frame_time {
        t.time = Some(t.frame.iter().map(|&f| f as f64 * dt).collect());
    }
    t.meta = TracksMeta {
        length_unit: opt.unit.clone().unwrap_or_else(|| "lammps".into()),
        time_unit: if opt.frame_time.is_some() {
            "s"
        } else {
            "frame"
        }
        .into(),
        frame_time: opt.frame_time,
        coordinate_frame: "LAMMPS box coordinates".into(),
        boxes,
        summary: serde_json::json!({ "lammps_timesteps": timesteps }),
        warnings: wrapped_warning(&wrapped_dirs),
        ..TracksMeta::default()
    };
    finalize(t, &file, RowLocator::Explicit, Some(&lines_of_rows))
}

/// The warning for a dump read wrapped along the periodic directions `dirs` (empty: none).
fn wrapped_warning(dirs: &std::collections::BTreeSet<&str>) -> Vec<String> {
    if dirs.is_empty() {
        return Vec::new();
    }
    vec![format!(
        "positions are wrapped along {}: the dump has neither image flags (ix iy) nor unwrapped \
         columns (xu yu), so a track jumps by a box length where its grain crosses a periodic \
         boundary and, across the sheared one, lacks the Lees–Edwards image velocity; dump \
         'ix iy' or 'xu yu' to have them unwrapped",
        dirs.iter().copied().collect::<Vec<_>>().join(", ")
    )]
}
