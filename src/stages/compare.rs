//! `compare`: two fits (say experiment and simulation) side by side, refused when they
//! were made differently (estimator, R_c, lags, η^s range rule), since Θ and η_c then differ for
//! reasons that have nothing to do with the physics.

use crate::error::{Error, Result};
use crate::stages::fit::{FitReport, read_fit};
use serde::Serialize;
use std::path::Path;

#[derive(Debug, Clone, Serialize)]
pub struct ParamComparison {
    pub name: String,
    pub a: f64,
    pub a_interval: [f64; 2],
    pub b: f64,
    pub b_interval: [f64; 2],
    /// The 95 % intervals overlap.
    pub agree: bool,
    pub both_constrained: bool,
}

#[derive(Debug, Clone, Serialize)]
pub struct Comparison {
    pub a: String,
    pub b: String,
    pub method: String,
    pub params: Vec<ParamComparison>,
}

/// Why two fits cannot be compared, or `None` when they can.
pub fn incompatibility(a: &FitReport, b: &FitReport) -> Option<String> {
    if a.method != b.method {
        return Some(format!(
            "different estimators: {} vs {} (refit one with --method {})",
            a.method.name(),
            b.method.name(),
            a.method.name()
        ));
    }
    let (pa, pb) = (&a.protocol, &b.protocol);
    if (pa.rc_over_d / pb.rc_over_d - 1.0).abs() > 1e-6 {
        return Some(format!(
            "different R_c: {} D vs {} D",
            pa.rc_over_d, pb.rc_over_d
        ));
    }
    if pa.binning != pb.binning {
        return Some(format!(
            "different binning: {:?} vs {:?}",
            pa.binning, pb.binning
        ));
    }
    // The same rule may give each data set its own bounds (that is its point); a rule
    // that differs, or bounds given by hand that differ, make the fits incomparable.
    let rule = |f: &FitReport| f.range.as_ref().map(|r| r.rule);
    if rule(a) != rule(b) {
        let name = |f: &FitReport| {
            rule(f).map_or("all (made before range rules)".to_string(), |r| r.name())
        };
        return Some(format!(
            "different η^s range rules: {} vs {} (refit one with --eta-range {})",
            name(a),
            name(b),
            name(a)
        ));
    }
    // Lags compare in R/v_c when both have a time scale, else in frames.
    let same_lags = if !pa.lags_used.is_empty() && !pb.lags_used.is_empty() {
        pa.lags_requested == pb.lags_requested
    } else {
        pa.lags_frames == pb.lags_frames
    };
    if !same_lags {
        return Some(format!(
            "different lags: {:?} vs {:?} (R/v_c requested) / {:?} vs {:?} (frames)",
            pa.lags_requested, pb.lags_requested, pa.lags_frames, pb.lags_frames
        ));
    }
    None
}

pub fn run(a_path: &Path, b_path: &Path) -> Result<Comparison> {
    let (a, b) = (read_fit(a_path)?, read_fit(b_path)?);
    if let Some(why) = incompatibility(&a, &b) {
        return Err(Error::Other(format!(
            "{} and {} were fitted differently, so their Θ and η_c are not comparable: {why}",
            a_path.display(),
            b_path.display()
        )));
    }
    let overlap = |x: [f64; 2], y: [f64; 2]| x[0] <= y[1] && y[0] <= x[1];
    let params = vec![
        ParamComparison {
            name: "theta".into(),
            a: a.theta,
            a_interval: a.theta_interval,
            b: b.theta,
            b_interval: b.theta_interval,
            agree: overlap(a.theta_interval, b.theta_interval),
            both_constrained: a.theta_constrained && b.theta_constrained,
        },
        ParamComparison {
            name: "eta_c".into(),
            a: a.eta_c,
            a_interval: a.eta_c_interval,
            b: b.eta_c,
            b_interval: b.eta_c_interval,
            agree: overlap(a.eta_c_interval, b.eta_c_interval),
            both_constrained: a.eta_c_constrained && b.eta_c_constrained,
        },
    ];
    Ok(Comparison {
        a: a_path.display().to_string(),
        b: b_path.display().to_string(),
        method: a.method.name().into(),
        params,
    })
}

impl std::fmt::Display for Comparison {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "estimator {}", self.method)?;
        writeln!(f, "{:8} {:>28} {:>28}  agree", "", self.a, self.b)?;
        for p in &self.params {
            writeln!(
                f,
                "{:8} {:>8.4} [{:.4}, {:.4}] {:>8.4} [{:.4}, {:.4}]  {}{}",
                p.name,
                p.a,
                p.a_interval[0],
                p.a_interval[1],
                p.b,
                p.b_interval[0],
                p.b_interval[1],
                if p.agree { "yes" } else { "no" },
                if p.both_constrained {
                    ""
                } else {
                    " (a parameter is not constrained)"
                }
            )?;
        }
        Ok(())
    }
}

/// Write a comparison as `compare.json` (what the `compare` stage and command keep).
pub fn write(c: &Comparison, path: &Path) -> Result<()> {
    crate::io::atomic_write_str(path, &serde_json::to_string_pretty(c).expect("json"))
}
