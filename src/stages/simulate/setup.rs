//! The initial pillar of a run: a generated packing (Sec. II.A protocol) or a given one
//! (an experiment's first frame, overlaps relaxed), placed between the bars.

use crate::dem::base::grains::{LARGE, SMALL};
use crate::dem::pillar::PillarSim;
use crate::dem::pillar::pack::{PackOptions, pack, relax};
use crate::dem::pillar::params::PillarParams;
use crate::error::{Error, Result};
use crate::io::csvdiag::Expect;
use crate::io::table::read_table;
use crate::stages::simulate::SimulateOptions;
use std::path::Path;

/// Choices the paper leaves open, recorded in every manifest.
pub const DECISIONS: &[&str] = &[
    "no normal damping unless damping_n is set (the undamped pillar is stable: substrate and grain friction dissipate)",
    "grain-bar friction mu_bar = mu_g unless set",
    "bars start touching the lowest and highest grains: initial bar force zero, H0 = initial bar separation",
    "g = 9.81 m/s^2",
    "W = lateral extent, radii included, of grains with centres within 2 D of the top bar (width_1d: 1 D band; width_contact: span of grains touching the bar)",
    "sigma = bar force averaged over each output interval / W at the frame",
    "the substrate's static test uses grain-grain and grain-bar forces only",
    "torque lever arm 1/2 |r_ij| for both grains (Eq. 8), also in the contact-point slip velocity, so the tangential spring does no spurious work",
    "velocity Verlet for positions with substrate friction from the mid-step velocity; explicit Euler for spins; xi rule (Eq. 11) after the update",
    "grains from a given packing take the preset's radius and mass of their species; overlaps are relaxed with the Eq. 1 potential before the run",
    "a generated packing's CG minimisations stop on the paper's energy rule (1e-12) or once the forces balance (rms residual <= f_tol = 1e-3 of the mean virial per grain; setup.protocol)",
    "p_gs (Eq. 21) uses the mean velocity over the output interval (Eq. 13); p_gs_exact is the interval mean of sum |f_i . v_i|",
];

/// Build the pillar, centred at x = 0 with the bottom bar face at y = 0.
pub fn initial_pillar(
    opt: &SimulateOptions,
    params: PillarParams,
) -> Result<(PillarSim, serde_json::Value)> {
    let d = params.d_large;
    let (mut x, mut y, species, ids, mut setup) = match &opt.packing {
        None => {
            if opt.n < 2 {
                return Err(Error::param(
                    "n",
                    format!("a pillar needs at least 2 grains, got {}", opt.n),
                ));
            }
            let protocol = PackOptions {
                n: opt.n,
                seed: opt.seed,
                ..Default::default()
            };
            let pk = pack(&protocol, |_, _| {}).map_err(crate::stages::pack::stopped)?;
            let setup = serde_json::json!({"packing": "generated (Sec. II.A)", "seed": opt.seed, "protocol": protocol, "pack": pk});
            let x: Vec<f64> = pk.x.iter().map(|v| v * d).collect();
            let y: Vec<f64> = pk.y.iter().map(|v| v * d).collect();
            (
                x,
                y,
                pk.species,
                (0..opt.n as i64).collect::<Vec<_>>(),
                setup,
            )
        }
        Some(path) => read_packing(path)?,
    };
    // Relax overlaps with the preset radii (measurement error in experiments).
    let r: Vec<f64> = species
        .iter()
        .map(|&s| {
            if s == LARGE {
                0.5 * d
            } else {
                0.5 * params.d_small
            }
        })
        .collect();
    let worst = max_overlap(&x, &y, &r) / d;
    if worst > 1e-9 {
        let it = relax(&mut x, &mut y, &r, 1e-12);
        setup["relaxed"] = serde_json::json!({"max_overlap_before_over_d": worst, "cg_iterations": it,
            "max_overlap_after_over_d": max_overlap(&x, &y, &r) / d});
    }
    let x_mid = {
        let lo = (0..x.len())
            .map(|i| x[i] - r[i])
            .fold(f64::INFINITY, f64::min);
        let hi = (0..x.len())
            .map(|i| x[i] + r[i])
            .fold(f64::NEG_INFINITY, f64::max);
        0.5 * (lo + hi)
    };
    let y_lo = (0..y.len())
        .map(|i| y[i] - r[i])
        .fold(f64::INFINITY, f64::min);
    x.iter_mut().for_each(|v| *v -= x_mid);
    y.iter_mut().for_each(|v| *v -= y_lo);
    let sim = PillarSim::new(params, &x, &y, &species, &ids);
    setup["n"] = serde_json::json!(x.len());
    setup["n_large"] = serde_json::json!(species.iter().filter(|&&s| s == LARGE).count());
    setup["h0_over_d"] = serde_json::json!((sim.top_y0 - sim.bottom_y) / d);
    setup["w0_over_d"] = serde_json::json!(sim.width_near_top(f64::INFINITY) / d);
    Ok((sim, setup))
}

type Packed = (Vec<f64>, Vec<f64>, Vec<i32>, Vec<i64>, serde_json::Value);

/// First frame of a tracks table, in metres.
fn read_packing(path: &Path) -> Result<Packed> {
    let (t, _) = crate::io::read_tracks(path)?;
    let to_m = match t.meta.length_unit.as_str() {
        "m" => 1.0,
        "cm" => 1e-2,
        "mm" => 1e-3,
        u => {
            return Err(Error::input(
                path.display(),
                format!(
                    "packing length unit '{u}' is not cm, mm or m; ingest it with --px-per-unit/--unit first"
                ),
            ));
        }
    };
    let Some((frame, range)) = t.frame_ranges().into_iter().next() else {
        return Err(Error::input(
            path.display(),
            "the packing table has no rows",
        ));
    };
    let rr = &t.radius[range.clone()];
    let species: Vec<i32> = match &t.species {
        Some(s) => s[range.clone()].to_vec(),
        None => {
            let (lo, hi) = rr
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                    (a.min(v), b.max(v))
                });
            rr.iter()
                .map(|&v| if v > 0.5 * (lo + hi) { LARGE } else { SMALL })
                .collect()
        }
    };
    let x = t.x[range.clone()].iter().map(|v| v * to_m).collect();
    let y = t.y[range.clone()].iter().map(|v| v * to_m).collect();
    let setup = serde_json::json!({"packing": path.display().to_string(), "packing_frame": frame,
        "packing_sha256": crate::io::sha256_file(path)?});
    Ok((x, y, species, t.particle[range].to_vec(), setup))
}

fn max_overlap(x: &[f64], y: &[f64], r: &[f64]) -> f64 {
    let mut list = crate::dem::base::verlet::PairList::new(0.0);
    list.build(x, y, r, crate::dem::base::verlet::Boundary::Open);
    let mut worst: f64 = 0.0;
    for i in 0..x.len() {
        for k in list.start[i] as usize..list.start[i + 1] as usize {
            let j = list.j[k] as usize;
            worst = worst.max(r[i] + r[j] - (x[i] - x[j]).hypot(y[i] - y[j]));
        }
    }
    worst
}

/// ⟨σ⟩ over 0.05 ≤ ε ≤ 0.2 (Sec. V), when the run reached ε = 0.2.
pub fn mean_flow_stress(stress_strain: &Path) -> Result<Option<f64>> {
    let t = read_table(
        stress_strain,
        &[("strain", Expect::Float), ("stress", Expect::Float)],
    )?;
    let (e, s) = (t.f64("strain")?, t.f64("stress")?);
    if e.last().is_none_or(|&v| v < 0.2 - 1e-9) {
        return Ok(None);
    }
    let v: Vec<f64> = e
        .iter()
        .zip(&s)
        .filter(|(e, _)| (0.05..=0.2).contains(*e))
        .map(|(_, s)| *s)
        .collect();
    Ok((!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64))
}
