//! Output tables of a pillar run, buffered per frame and flushed as numbered part
//! files at each checkpoint, then concatenated into the final tables. A resumed run
//! drops parts newer than its checkpoint, so the final tables equal an uninterrupted
//! run's.

use crate::dem::pillar::PillarSim;
use crate::dem::pillar::stress::{WIDTH_BAND_D, stress_point};
use crate::error::{Error, Result};
use crate::io::table::{read_table, write_table};
use polars::prelude::*;
use std::path::{Path, PathBuf};

/// Output table names, in the order they are written.
pub const TABLES: [&str; 4] = ["tracks", "bar_forces", "stress_strain", "forces"];

const CM: f64 = 100.0;

/// Rows accumulated since the last flush, column by column.
#[derive(Default)]
pub struct Buffers {
    pub tracks: Vec<(&'static str, Col)>,
    pub bar_forces: Vec<(&'static str, Col)>,
    pub stress_strain: Vec<(&'static str, Col)>,
    pub forces: Vec<(&'static str, Col)>,
}

pub enum Col {
    I64(Vec<i64>),
    I32(Vec<i32>),
    F64(Vec<f64>),
    OptF64(Vec<Option<f64>>),
}

impl Col {
    fn column(&self, name: &str) -> Column {
        match self {
            Col::I64(v) => Column::new(name.into(), v),
            Col::I32(v) => Column::new(name.into(), v),
            Col::F64(v) => Column::new(name.into(), v),
            Col::OptF64(v) => Column::new(name.into(), v),
        }
    }
    fn clear(&mut self) {
        match self {
            Col::I64(v) => v.clear(),
            Col::I32(v) => v.clear(),
            Col::F64(v) => v.clear(),
            Col::OptF64(v) => v.clear(),
        }
    }
}

fn f(names: &[&'static str]) -> Vec<(&'static str, Col)> {
    names.iter().map(|&n| (n, Col::F64(Vec::new()))).collect()
}

fn push_f(cols: &mut [(&'static str, Col)], name: &str, v: f64) {
    match cols.iter_mut().find(|(n, _)| *n == name) {
        Some((_, Col::F64(c))) => c.push(v),
        _ => unreachable!("column {name} is f64"),
    }
}

/// Per-frame quantities the stress–strain table needs beyond the simulator's state.
pub struct FrameStats {
    pub frame: i64,
    /// Eq. 21 with Eq. 13's mean velocities over the interval (W).
    pub p_gs: f64,
}

impl Buffers {
    pub fn new() -> Self {
        Buffers {
            tracks: vec![
                ("frame", Col::I64(vec![])),
                ("particle", Col::I64(vec![])),
                ("x", Col::F64(vec![])),
                ("y", Col::F64(vec![])),
                ("radius", Col::F64(vec![])),
                ("time", Col::F64(vec![])),
                ("species", Col::I32(vec![])),
                ("theta", Col::F64(vec![])),
            ],
            bar_forces: f(&["time", "top_force", "bottom_force", "top_y", "bottom_y"]),
            stress_strain: {
                let mut c = vec![("frame", Col::I64(vec![]))];
                c.extend(f(&[
                    "time",
                    "strain",
                    "top_force",
                    "bottom_force",
                    "width",
                    "width_1d",
                    "width_contact",
                    "stress",
                    "stress_reduced",
                    "p_in",
                    "p_gs",
                    "p_gs_exact",
                ]));
                c.push(("kappa", Col::OptF64(vec![])));
                c.push(("kappa_exact", Col::OptF64(vec![])));
                c.push(("z", Col::F64(vec![])));
                c
            },
            forces: {
                let mut c = vec![("frame", Col::I64(vec![])), ("particle", Col::I64(vec![]))];
                c.extend(f(&[
                    "f_n",
                    "f_t",
                    "f_sub",
                    "f_n_reduced",
                    "f_t_reduced",
                    "f_sub_reduced",
                ]));
                c.push(("contacts", Col::I32(vec![])));
                c.extend(f(&["f_bar", "f_bar_reduced"]));
                c
            },
        }
    }

    /// One output frame: the grains, the interval's mean bar forces, stress and power.
    pub fn record(&mut self, s: &PillarSim, st: &FrameStats) {
        let g = &s.grains;
        let t = s.time();
        for (name, col) in self.tracks.iter_mut() {
            match (*name, col) {
                ("frame", Col::I64(c)) => c.extend(std::iter::repeat_n(st.frame, g.len())),
                ("particle", Col::I64(c)) => c.extend_from_slice(&g.id),
                ("x", Col::F64(c)) => c.extend(g.x.iter().map(|v| v * CM)),
                ("y", Col::F64(c)) => c.extend(g.y.iter().map(|v| v * CM)),
                ("radius", Col::F64(c)) => c.extend(g.radius.iter().map(|v| v * CM)),
                ("time", Col::F64(c)) => c.extend(std::iter::repeat_n(t, g.len())),
                ("species", Col::I32(c)) => c.extend_from_slice(&g.species),
                ("theta", Col::F64(c)) => c.extend_from_slice(&g.theta),
                _ => unreachable!(),
            }
        }
        let iv = &s.interval;
        let k = if iv.steps > 0 {
            1.0 / iv.steps as f64
        } else {
            0.0
        };
        let (top, bottom) = (iv.top_force * k, iv.bottom_force * k);
        let b = &mut self.bar_forces;
        push_f(b, "time", t);
        push_f(b, "top_force", top);
        push_f(b, "bottom_force", bottom);
        push_f(b, "top_y", s.top_y() * CM);
        push_f(b, "bottom_y", s.bottom_y * CM);

        let p = &s.params;
        let d = p.d_large;
        let w = s.width_near_top(WIDTH_BAND_D * d);
        // Sec. III's definitions, shared with `ingest-force` (a sensor's bar forces).
        let sp = stress_point(s.bar_state(top), w, p.stress_unit(), p.bar_speed);
        let p_in = sp.p_in;
        let p_exact = iv.substrate_power * k;
        let ss = &mut self.stress_strain;
        if let Some((_, Col::I64(c))) = ss.first_mut() {
            c.push(st.frame);
        }
        for (name, v) in [
            ("time", t),
            ("strain", sp.strain),
            ("top_force", top),
            ("bottom_force", bottom),
            ("width", w * CM),
            ("width_1d", s.width_near_top(d) * CM),
            ("width_contact", s.contact_span_top() * CM),
            ("stress", sp.stress),
            ("stress_reduced", sp.stress_reduced),
            ("p_in", p_in),
            ("p_gs", st.p_gs),
            ("p_gs_exact", p_exact),
            ("z", 2.0 * s.contacts() as f64 / g.len().max(1) as f64),
        ] {
            push_f(ss, name, v);
        }
        for (name, v) in [("kappa", st.p_gs), ("kappa_exact", p_exact)] {
            if let Some((_, Col::OptF64(c))) = ss.iter_mut().find(|(n, _)| *n == name) {
                c.push((p_in > 0.0).then(|| v / p_in));
            }
        }
    }

    /// Per-grain force snapshot (li-granular-pillars Fig. 6) from the last step's record.
    pub fn record_forces(&mut self, s: &PillarSim, frame: i64) {
        let Some(rec) = &s.record else { return };
        let g = &s.grains;
        let p = &s.params;
        let unit = p.force_unit();
        for (name, col) in self.forces.iter_mut() {
            match (*name, col) {
                ("frame", Col::I64(c)) => c.extend(std::iter::repeat_n(frame, g.len())),
                ("particle", Col::I64(c)) => c.extend_from_slice(&g.id),
                ("f_n", Col::F64(c)) => c.extend_from_slice(&rec.f_n),
                ("f_t", Col::F64(c)) => c.extend_from_slice(&rec.f_t),
                ("f_sub", Col::F64(c)) => {
                    c.extend((0..g.len()).map(|i| s.sub_fx[i].hypot(s.sub_fy[i])))
                }
                ("f_n_reduced", Col::F64(c)) => c.extend(rec.f_n.iter().map(|v| v / unit)),
                ("f_t_reduced", Col::F64(c)) => c.extend(rec.f_t.iter().map(|v| v / unit)),
                ("f_sub_reduced", Col::F64(c)) => c.extend(
                    (0..g.len()).map(|i| s.sub_fx[i].hypot(s.sub_fy[i]) / (g.mass[i] * p.g * p.mu)),
                ),
                ("contacts", Col::I32(c)) => c.extend(rec.contacts.iter().map(|&v| v as i32)),
                ("f_bar", Col::F64(c)) => c.extend_from_slice(&rec.f_bar),
                ("f_bar_reduced", Col::F64(c)) => c.extend(rec.f_bar.iter().map(|v| v / unit)),
                _ => unreachable!(),
            }
        }
    }

    fn table(&mut self, name: &str) -> &mut Vec<(&'static str, Col)> {
        match name {
            "tracks" => &mut self.tracks,
            "bar_forces" => &mut self.bar_forces,
            "stress_strain" => &mut self.stress_strain,
            _ => &mut self.forces,
        }
    }

    /// Write every buffered table as part `k` under `dir` and clear the buffers.
    pub fn flush(&mut self, dir: &Path, k: u64) -> Result<()> {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        for name in TABLES {
            let cols = self.table(name);
            let height = match cols.first() {
                Some((_, Col::I64(v))) => v.len(),
                Some((_, Col::F64(v))) => v.len(),
                _ => 0,
            };
            if height == 0 {
                // Nothing since the last flush (forces are snapshotted sparsely).
                continue;
            }
            let mut df = DataFrame::new(height, cols.iter().map(|(n, c)| c.column(n)).collect())
                .map_err(|e| Error::polars(format!("building {name}"), e))?;
            write_table(&mut df, &part_path(dir, name, k))?;
            cols.iter_mut().for_each(|(_, c)| c.clear());
        }
        Ok(())
    }
}

pub fn part_path(dir: &Path, table: &str, k: u64) -> PathBuf {
    dir.join(format!("{table}.{k:05}.parquet"))
}

/// Remove parts numbered `keep` and above (written after the checkpoint resumed from).
pub fn drop_parts_from(dir: &Path, keep: u64) -> Result<()> {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return Ok(());
    };
    for e in rd.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let k = name.split('.').nth(1).and_then(|s| s.parse::<u64>().ok());
        if k.is_some_and(|k| k >= keep) || name.contains(".partial-") {
            std::fs::remove_file(e.path()).map_err(|err| Error::io(e.path(), err))?;
        }
    }
    Ok(())
}

/// Concatenate parts 0..n of `table` into `out` (atomically).
pub fn merge_parts(dir: &Path, table: &str, n: u64, out: &Path) -> Result<usize> {
    let mut all: Option<DataFrame> = None;
    for k in 0..n {
        let part = part_path(dir, table, k);
        if !part.exists() {
            continue; // an interval with no rows for this table
        }
        let t = read_table(&part, &[])?;
        let df = t.df;
        all = Some(match all {
            None => df,
            Some(mut a) => {
                a.vstack_mut(&df)
                    .map_err(|e| Error::polars(format!("joining {table} parts"), e))?;
                a
            }
        });
    }
    let mut df = all.ok_or_else(|| Error::Other(format!("no parts of {table}")))?;
    df.rechunk_mut();
    write_table(&mut df, out)?;
    Ok(df.height())
}
