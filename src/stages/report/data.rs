//! The report's inputs read into plain data: per-particle map panels (Li et al. Fig. 5),
//! simulation force panels (Fig. 6) and curves against strain (Figs. 4 and 10d).

use crate::error::Result;
use crate::io::csvdiag::Expect;
use crate::io::read_tracks;
use crate::io::table::{Table, read_table};
use crate::stages::report::DatasetInputs;
use crate::stages::report::frames::StrainIndex;
use crate::tracks::Tracks;
use std::collections::{BTreeMap, HashMap};
use std::path::Path;

/// One grain of a panel: x, y, radius (length unit) and three values.
pub type Grain = (f64, f64, f64, [f64; 3]);

/// One panel: its title and grains, for the three quantities of a map section.
#[derive(Debug, Clone)]
pub struct Panel {
    pub title: String,
    pub grains: Vec<Grain>,
}

/// Per-grain rows of a kinematics or forces table with the three values to map.
struct PerGrain {
    frame: Vec<i64>,
    particle: Vec<i64>,
    /// Centres when the table has them (kinematics); forces take the tracks'.
    xy: Option<(Vec<f64>, Vec<f64>)>,
    valid: Option<Vec<bool>>,
    values: [Vec<f64>; 3],
}

impl PerGrain {
    fn read(p: &Path, xy: bool, cols: [&str; 3]) -> Result<PerGrain> {
        let mut expect = vec![("frame", Expect::Int), ("particle", Expect::Int)];
        expect.extend(cols.iter().map(|c| (*c, Expect::Float)));
        if xy {
            expect.extend([("x", Expect::Float), ("y", Expect::Float)]);
        }
        let t: Table = read_table(p, &expect)?;
        t.require(&expect.iter().map(|e| e.0).collect::<Vec<_>>())?;
        Ok(PerGrain {
            frame: t.i64("frame")?,
            particle: t.i64("particle")?,
            xy: if xy {
                Some((t.f64("x")?, t.f64("y")?))
            } else {
                None
            },
            valid: if t.has("valid") {
                Some(t.bool("valid")?)
            } else {
                None
            },
            values: [t.f64(cols[0])?, t.f64(cols[1])?, t.f64(cols[2])?],
        })
    }
    fn frames(&self) -> Vec<i64> {
        let mut f = self.frame.clone();
        f.sort_unstable();
        f.dedup();
        f
    }
}

/// One data set's inputs, read once.
pub struct Loaded {
    pub label: String,
    pub tracks: Option<Tracks>,
    /// Tracks rows by frame.
    rows: BTreeMap<i64, Vec<usize>>,
    pub strain: Option<StrainIndex>,
    kin: Option<PerGrain>,
    pub kin_frames: Vec<i64>,
    forces: Option<PerGrain>,
    pub force_frames: Vec<i64>,
}

impl Loaded {
    pub fn read(d: &DatasetInputs) -> Result<Loaded> {
        let tracks = match &d.tracks {
            Some(p) => Some(read_tracks(p)?.0),
            None => None,
        };
        let mut rows: BTreeMap<i64, Vec<usize>> = BTreeMap::new();
        if let Some(t) = &tracks {
            for (i, &f) in t.frame.iter().enumerate() {
                rows.entry(f).or_default().push(i);
            }
        }
        // The simulator's measured strain first; an estimate from the bar speed else.
        let strain = match &d.stress {
            Some(p) => Some(StrainIndex::from_table(p)?),
            None => tracks
                .as_ref()
                .and_then(|t| StrainIndex::from_tracks(t, &rows)),
        };
        let kin = match &d.kinematics {
            Some(p) => Some(PerGrain::read(p, true, ["speed", "j2", "d2min"])?),
            None => None,
        };
        // Forces are only drawn where the tracks give the grains' positions.
        let forces = match (&d.forces, &tracks) {
            (Some(p), Some(_)) => Some(PerGrain::read(
                p,
                false,
                ["f_n_reduced", "f_t_reduced", "f_sub_reduced"],
            )?),
            _ => None,
        };
        Ok(Loaded {
            label: d.label.clone(),
            kin_frames: kin.as_ref().map(PerGrain::frames).unwrap_or_default(),
            force_frames: forces.as_ref().map(PerGrain::frames).unwrap_or_default(),
            tracks,
            rows,
            strain,
            kin,
            forces,
        })
    }

    /// Whether the maps can be drawn in the paper's units (v_c and R known).
    pub fn has_bar_speed(&self) -> bool {
        self.tracks
            .as_ref()
            .is_some_and(|t| t.meta.bar_speed.is_some())
    }

    /// "label: ε = 0.05 (frame 12)", or the frame and time when the strain is unknown.
    fn title(&self, f: i64) -> String {
        if let Some(e) = self.strain.as_ref().and_then(|s| s.label(f)) {
            return format!("{}: {e} (frame {f})", self.label);
        }
        let time = self
            .tracks
            .as_ref()
            .and_then(|t| {
                t.meta
                    .frame_time
                    .map(|ft| format!(", t = {:.0} {}", f as f64 * ft, t.meta.time_unit))
            })
            .unwrap_or_default();
        format!("{}: frame {f}{time}", self.label)
    }

    /// Panels of `table` at `frames`: grains at their true radii from the tracks (the
    /// large radius where a grain is missing), values multiplied by `scale`.
    fn panels(&self, table: &PerGrain, frames: &[i64], scale: [f64; 3]) -> Vec<Panel> {
        let default_r = self
            .tracks
            .as_ref()
            .and_then(|t| t.large_diameter())
            .map_or(0.5, |dd| 0.5 * dd);
        frames
            .iter()
            .map(|&f| {
                let at: HashMap<i64, usize> = match (&self.tracks, self.rows.get(&f)) {
                    (Some(t), Some(r)) => r.iter().map(|&i| (t.particle[i], i)).collect(),
                    _ => HashMap::new(),
                };
                let grains = (0..table.frame.len())
                    .filter(|&r| table.frame[r] == f)
                    .filter(|&r| table.valid.as_ref().is_none_or(|v| v[r]))
                    .filter_map(|r| {
                        let row = at.get(&table.particle[r]).copied();
                        let t = self.tracks.as_ref();
                        let (x, y) = match &table.xy {
                            Some((x, y)) => (x[r], y[r]),
                            None => {
                                let (t, i) = (t?, row?);
                                (t.x[i], t.y[i])
                            }
                        };
                        let radius = t.zip(row).map_or(default_r, |(t, i)| t.radius[i]);
                        let v = [0, 1, 2].map(|k| table.values[k][r] * scale[k]);
                        Some((x, y, radius, v))
                    })
                    .collect();
                Panel {
                    title: self.title(f),
                    grains,
                }
            })
            .collect()
    }

    /// Speed, J2 and D²min panels at `frames`, in the paper's units (Fig. 5: v in v_c,
    /// J2 in v_c/R, D²min in R²) when v_c is known, so that an experiment and a faster
    /// simulation share one colour scale.
    pub fn map_panels(&self, frames: &[i64]) -> Vec<Panel> {
        let Some(kin) = &self.kin else {
            return Vec::new();
        };
        let scale = match self
            .tracks
            .as_ref()
            .and_then(|t| t.meta.bar_speed.zip(t.large_diameter()))
        {
            Some((vc, dd)) if vc > 0.0 => [1.0 / vc, 0.5 * dd / vc, 4.0 / (dd * dd)],
            _ => [1.0; 3],
        };
        self.panels(kin, frames, scale)
    }

    /// F_n, F_t (m g μ) and substrate friction |f| (m_i g μ) panels at `frames` (Fig. 6).
    pub fn force_panels(&self, frames: &[i64]) -> Vec<Panel> {
        match &self.forces {
            Some(f) => self.panels(f, frames, [1.0; 3]),
            None => Vec::new(),
        }
    }
}

/// (ε, column) from a stress–strain table, None when the column is absent; nulls (κ
/// where P_in = 0) read as NaN and are left out when drawn.
pub fn strain_curve(p: &Path, column: &str) -> Result<Option<Vec<(f64, f64)>>> {
    let t = read_table(p, &[("strain", Expect::Float), (column, Expect::Float)])?;
    t.require(&["strain"])?;
    if !t.has(column) {
        return Ok(None);
    }
    Ok(Some(
        t.f64("strain")?
            .into_iter()
            .zip(t.f64_or_nan(column)?)
            .collect(),
    ))
}
