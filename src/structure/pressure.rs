//! Contact pressure along the bar (li-granular-pillars Fig. 10c): the local force per
//! length p(x) that the compressing bar exerts on the pillar, against the position x
//! along the contact interface scaled by the interface's width W.
//!
//! The interface is the span, radii included, of the grains the bar touches (a grain
//! touches when its bar force is positive), so x/W runs from 0 to 1 across it; the
//! profile puts each grain's force in the bin of its centre and divides by the bin's
//! length, so Σ p Δx = Σ f exactly (the bar force). Bins are a few grains wide at any
//! size: the paper's "near zero at the edge, saturated around the centre" is a shape on
//! the scale of W, and a bin narrower than a grain would only show the grains.

/// One snapshot's (or an average's) pressure profile on `bins` equal bins of x/W.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PressureProfile {
    /// Bin centres in x/W, 0 and 1 being the interface's ends.
    pub x_over_w: Vec<f64>,
    /// Force per length in each bin (the force unit over the length unit of the input).
    pub p: Vec<f64>,
    /// The interface's width W (length unit) and the total force on it (force unit).
    pub width: f64,
    pub force: f64,
    /// Grains touching the bar.
    pub contacts: usize,
}

/// The profile of grains at `x` with radii `radius` and bar forces `f` (0 where a grain
/// does not touch the bar) on `bins` bins; None when no grain touches or `bins` is 0.
pub fn bar_pressure(x: &[f64], radius: &[f64], f: &[f64], bins: usize) -> Option<PressureProfile> {
    let touching: Vec<usize> = (0..x.len())
        .filter(|&i| f[i] > 0.0 && f[i].is_finite() && x[i].is_finite())
        .collect();
    if touching.is_empty() || bins == 0 {
        return None;
    }
    let lo = touching
        .iter()
        .map(|&i| x[i] - radius[i])
        .fold(f64::INFINITY, f64::min);
    let hi = touching
        .iter()
        .map(|&i| x[i] + radius[i])
        .fold(f64::NEG_INFINITY, f64::max);
    let width = hi - lo;
    let dx = width / bins as f64;
    let mut p = vec![0.0; bins];
    let mut force = 0.0;
    for &i in &touching {
        let k = (((x[i] - lo) / dx) as usize).min(bins - 1);
        p[k] += f[i] / dx;
        force += f[i];
    }
    Some(PressureProfile {
        x_over_w: (0..bins).map(|k| (k as f64 + 0.5) / bins as f64).collect(),
        p,
        width,
        force,
        contacts: touching.len(),
    })
}

/// The mean of profiles on the same bins (snapshots of one run over a strain window).
pub fn mean_profile(profiles: &[PressureProfile]) -> Option<PressureProfile> {
    let first = profiles.first()?;
    let n = profiles.len() as f64;
    let bins = first.p.len();
    let mut p = vec![0.0; bins];
    for q in profiles {
        for (a, b) in p.iter_mut().zip(&q.p) {
            *a += b / n;
        }
    }
    Some(PressureProfile {
        x_over_w: first.x_over_w.clone(),
        p,
        width: profiles.iter().map(|q| q.width).sum::<f64>() / n,
        force: profiles.iter().map(|q| q.force).sum::<f64>() / n,
        contacts: (profiles.iter().map(|q| q.contacts).sum::<usize>() as f64 / n).round() as usize,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A row of equal grains, touching, each pressed with force f: p = f/D in every
    /// bin that holds whole grains, W the row's length, Σ p Δx the total force.
    #[test]
    fn a_uniformly_loaded_row_has_uniform_pressure() {
        let n = 40;
        let x: Vec<f64> = (0..n).map(|i| 0.5 + i as f64).collect();
        let r = vec![0.5; n];
        let f = vec![2.0; n];
        let p = bar_pressure(&x, &r, &f, 8).unwrap();
        assert_eq!(p.width, 40.0);
        assert_eq!(p.contacts, n);
        for v in &p.p {
            assert!((v - 2.0).abs() < 1e-12, "{v}");
        }
        let dx = p.width / 8.0;
        assert!((p.p.iter().sum::<f64>() * dx - 80.0).abs() < 1e-9);
    }

    /// Forces rising linearly from the edges to the centre (a tent) give a tent that
    /// peaks in the middle bins at the loaded value; grains off the bar do not count.
    #[test]
    fn a_tent_of_forces_is_a_tent_of_pressure_and_idle_grains_are_ignored() {
        let n = 100;
        let mut x: Vec<f64> = (0..n).map(|i| 0.5 + i as f64).collect();
        let mut f: Vec<f64> = (0..n)
            .map(|i| 1.0 - ((i as f64 + 0.5) / n as f64 - 0.5).abs() * 2.0)
            .collect();
        let mut r = vec![0.5; n];
        // Grains in the pillar's bulk, far out in x, with no bar force.
        x.extend([-50.0, 300.0]);
        f.extend([0.0, 0.0]);
        r.extend([0.5, 0.5]);
        let p = bar_pressure(&x, &r, &f, 10).unwrap();
        assert_eq!(p.width, 100.0);
        for (k, v) in p.p.iter().enumerate() {
            let want = 1.0 - (p.x_over_w[k] - 0.5).abs() * 2.0;
            assert!((v - want).abs() < 1e-9, "bin {k}: {v} vs {want}");
        }
        assert!(bar_pressure(&x, &r, &vec![0.0; x.len()], 10).is_none());
        let m = mean_profile(&[p.clone(), p.clone()]).unwrap();
        assert_eq!(m.p, p.p);
    }
}
