//! `report`: experiment and simulation side by side — the D²min–η^s crossover with both
//! fits (Fig. 8), per-particle maps of speed, J2 and D²min at matching strains (Fig. 5),
//! the simulation's force maps (Fig. 6), stress–strain and κ when the simulator's table
//! exists (Figs. 4 and 10d), the fit table and provenance — as `report.html` (figures
//! inlined) plus every figure as PNG and SVG under `figures/`.

mod data;
mod fit;
mod grid;
pub use fit::crossover_figure;
pub mod frames;
pub mod render;
mod sections;
pub mod shear;
mod sizes;
mod transient;

use crate::error::{Error, Result};
use crate::io::atomic_write_str;
use crate::stages::report::data::{Loaded, Panel};
use crate::stages::report::frames::{nearest_frames, pick_frames, strain_range, strain_targets};
use crate::stages::report::render::SavedFigure;
use crate::stages::report::render::html::{Block, Report, Section, render};
use crate::stages::report::sections::{map_blocks, strain_blocks};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

pub use crate::stages::datasets::DatasetInputs;

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ReportOptions {
    pub title: String,
    pub datasets: Vec<DatasetInputs>,
    /// How many strain stages (start frames) the maps show per data set.
    pub map_stages: usize,
    /// Anything to print under "Provenance" (run id, parameters, hashes, version).
    pub provenance: serde_json::Value,
    /// The size scan of the data sets' pillar runs (a `sizes` stage's
    /// `size_analysis.msgpack`, its tables beside it), drawn as the "Size scan" section.
    #[serde(default)]
    pub sizes: Option<PathBuf>,
}

#[derive(Debug, Clone, Serialize)]
pub struct ReportOutput {
    pub html: PathBuf,
    pub figures: Vec<SavedFigure>,
    pub sections: Vec<String>,
}

/// Map and force frames per data set: nearest to strains shared by all data sets
/// where the strain is known, evenly spread otherwise; force frames nearest to the
/// map frames.
fn stages(loaded: &[Loaded], stages: usize) -> Vec<(Vec<i64>, Vec<i64>)> {
    let candidates = |l: &Loaded| {
        if l.kin_frames.is_empty() {
            l.force_frames.clone()
        } else {
            l.kin_frames.clone()
        }
    };
    let ranges: Vec<_> = loaded
        .iter()
        .map(|l| strain_range(l.strain.as_ref(), &candidates(l)))
        .collect();
    let targets = strain_targets(&ranges, stages);
    loaded
        .iter()
        .zip(&targets)
        .map(|(l, t)| {
            let pick =
                |frames: &[i64]| pick_frames(frames, l.strain.as_ref(), t.as_deref(), stages);
            let maps = pick(&l.kin_frames);
            let forces = if maps.is_empty() {
                pick(&l.force_frames)
            } else {
                nearest_frames(&l.force_frames, &maps)
            };
            (maps, forces)
        })
        .collect()
}

pub fn run(out_dir: &Path, opt: &ReportOptions) -> Result<ReportOutput> {
    if opt.datasets.is_empty() {
        return Err(Error::param(
            "datasets",
            "a report needs at least one data set",
        ));
    }
    let figdir = out_dir.join("figures");
    std::fs::create_dir_all(&figdir).map_err(|e| Error::io(&figdir, e))?;
    let mut figures = Vec::new();
    let mut sections = Vec::new();
    if let Some(s) =
        crate::stages::report::fit::crossover_section(&opt.datasets, &figdir, &mut figures)?
    {
        sections.push(s);
    }

    let loaded = opt
        .datasets
        .iter()
        .map(Loaded::read)
        .collect::<Result<Vec<_>>>()?;
    let picked = stages(&loaded, opt.map_stages);
    let columns = opt.map_stages.max(1);

    // Maps: one figure per quantity, every data set's stages side by side on one scale.
    let panels: Vec<Panel> = loaded
        .iter()
        .zip(&picked)
        .flat_map(|(l, (f, _))| l.map_panels(f))
        .collect();
    if !panels.is_empty() {
        let reduced = loaded
            .iter()
            .filter(|l| !l.kin_frames.is_empty())
            .all(Loaded::has_bar_speed);
        let q = if reduced {
            [
                ("speed |v| / v_c (Eq. 13)", "map_speed", false),
                ("J2 = η^s/Δt in v_c/R (Eq. 18)", "map_j2", true),
                ("D²min / R² (Eq. 14)", "map_d2min", true),
            ]
        } else {
            [
                ("speed |v| (Eq. 13)", "map_speed", false),
                ("J2 = η^s/Δt (Eq. 18)", "map_j2", true),
                ("D²min (Eq. 14)", "map_d2min", true),
            ]
        };
        let caption = "on one colour scale for all panels, at matching strains where known; grains at rest (grey) are left off log scales (Li et al. Fig. 5).";
        sections.push(Section {
            id: "maps".into(),
            title: "Per-particle maps".into(),
            blocks: map_blocks(&panels, q, columns, caption, &figdir, &mut figures)?,
        });
    }

    // Forces (simulations only): same stages as the maps.
    let panels: Vec<Panel> = loaded
        .iter()
        .zip(&picked)
        .flat_map(|(l, (_, f))| l.force_panels(f))
        .collect();
    if !panels.is_empty() {
        let q = [
            (
                "grain–grain normal force F_n in m g μ (Eq. 4)",
                "forces_fn",
                false,
            ),
            (
                "grain–grain tangential force F_t in m g μ (Eq. 7)",
                "forces_ft",
                false,
            ),
            (
                "substrate friction |f| in m_i g μ (Sec. II.B.3)",
                "forces_sub",
                false,
            ),
        ];
        let caption = "summed over its contacts for F_n and F_t, on one colour scale for all panels, at the snapshots nearest to the maps' stages (Li et al. Fig. 6).";
        sections.push(Section {
            id: "forces".into(),
            title: "Forces (simulation)".into(),
            blocks: map_blocks(&panels, q, columns, caption, &figdir, &mut figures)?,
        });
    }

    // Stress–strain and κ, where a data set has pillar data at all.
    if opt.datasets.iter().any(|d| {
        d.tracks.is_some() || d.stress.is_some() || d.measured_stress.is_some() || d.fit.is_some()
    }) {
        sections.push(Section {
            id: "stress".into(),
            title: "Stress–strain".into(),
            blocks: strain_blocks(&opt.datasets, &figdir, &mut figures)?,
        });
    }

    // Two or more pillar runs: the size scan (li-granular-pillars Sec. V).
    if let Some(s) = sizes::size_section(opt, out_dir, &figdir, &mut figures)? {
        sections.push(s);
    }

    // Parameter studies (a stage with `vary`), each against its key.
    // A study of sheared-disk runs over φ, Q or γ̇ is drawn as a sweep, below.
    let sweep_of = |d: &DatasetInputs| {
        d.sweep.clone().or_else(|| {
            d.grid
                .clone()
                .filter(|g| g.join(crate::stages::sweep::TABLE).is_file())
        })
    };
    for d in &opt.datasets {
        if let Some(dir) = d
            .grid
            .as_ref()
            .filter(|g| !g.join(crate::stages::sweep::TABLE).is_file())
        {
            sections.push(grid::grid_section(&d.label, dir, &figdir, &mut figures)?);
        }
    }

    // Sheared disks: one run, and a sweep; sweeps of one model at several sizes side by
    // side after them (Fig. 36).
    let mut sweeps = Vec::new();
    for d in &opt.datasets {
        if let Some(dir) = &d.shear {
            sections.push(shear::shear_section(&d.label, dir, &figdir, &mut figures)?);
        }
        if let Some(dir) = &sweep_of(d) {
            let data = shear::read_sweep(dir)?;
            sections.push(shear::sweep_section(
                &d.label,
                &data,
                out_dir,
                &figdir,
                &mut figures,
            )?);
            sweeps.push((d.label.clone(), data));
        }
        if !d.ramps.is_empty() {
            let data = d
                .ramps
                .iter()
                .map(|r| shear::ramp::read_ramp(r))
                .collect::<Result<Vec<_>>>()?;
            sections.push(shear::ramp::ramp_section(
                &d.label,
                &data,
                &figdir,
                &mut figures,
            )?);
        }
    }

    let by_label: Vec<(String, &shear::SweepData)> =
        sweeps.iter().map(|(l, d)| (l.clone(), d)).collect();
    if let Some(s) = shear::coexistence::size_section(&by_label, &figdir, &mut figures)? {
        sections.push(s);
    }

    // Provenance.
    let mut rows = Vec::new();
    for d in &opt.datasets {
        for (what, p) in [
            ("tracks", &d.tracks),
            ("kinematics", &d.kinematics),
            ("fit", &d.fit),
            ("stress", &d.stress),
            ("measured stress", &d.measured_stress),
            ("forces", &d.forces),
            ("shear run", &d.shear),
            ("sweep", &d.sweep),
        ] {
            if p.as_ref().is_some_and(|p| p.is_dir()) {
                let p = p.as_ref().expect("checked");
                rows.push(vec![
                    d.label.clone(),
                    what.into(),
                    p.display().to_string(),
                    "(directory)".into(),
                ]);
                continue;
            }
            if let Some(p) = p {
                rows.push(vec![
                    d.label.clone(),
                    what.into(),
                    p.display().to_string(),
                    crate::io::sha256_file(p)?,
                ]);
            }
        }
        for r in &d.ramps {
            rows.push(vec![
                d.label.clone(),
                "ramp".into(),
                r.display().to_string(),
                "(directory)".into(),
            ]);
        }
    }
    sections.push(Section {
        id: "provenance".into(),
        title: "Provenance".into(),
        blocks: vec![
            Block::Table {
                header: ["data", "input", "file", "sha256"]
                    .map(String::from)
                    .to_vec(),
                rows,
            },
            Block::Pre(serde_json::to_string_pretty(&opt.provenance).expect("json")),
        ],
    });
    let report = Report {
        title: opt.title.clone(),
        subtitle: format!(
            "{} {} — {}",
            crate::stages::TOOL,
            crate::stages::VERSION,
            opt.datasets
                .iter()
                .map(|d| d.label.as_str())
                .collect::<Vec<_>>()
                .join(" vs ")
        ),
        sections,
    };
    let html = out_dir.join("report.html");
    atomic_write_str(&html, &render(&report))?;
    let names: BTreeMap<usize, String> = report
        .sections
        .iter()
        .enumerate()
        .map(|(k, s)| (k, s.id.clone()))
        .collect();
    Ok(ReportOutput {
        html,
        figures,
        sections: names.into_values().collect(),
    })
}
