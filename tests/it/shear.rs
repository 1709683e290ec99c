//! Sheared disks (vagberg-sheared-disks, issue 7): Lees–Edwards images, conservation,
//! CD's decoupling of rotation, the Z = 2 τ_dur ν_coll consistency check, ⟨θ̇/γ̇⟩ ≈ −1/2,
//! the linear profile, and the CLI's outputs.

use crate::common::tmpdir;
use pillar_pipe::dem::base::grains::{Grains, SMALL};
use pillar_pipe::dem::shear::{Dissipation, ShearParams, ShearSim};
use pillar_pipe::io::table::read_table;
use pillar_pipe::stages::shear::{ShearOptions, run};
use std::process::Command;

fn params(n: usize, phi: f64, model: Dissipation, rate: f64) -> ShearParams {
    ShearParams {
        n,
        phi,
        q: 1.0,
        rate,
        model,
        alpha: 2.0,
        dt: 0.05,
        seed: 3,
    }
}

/// Two disks touching across the top/bottom boundary, or the same pair with j placed
/// at its image (unwrapped: y + L, x + γL, v_x + γ̇L).
fn pair(image: bool, model: Dissipation) -> ShearSim {
    let (l, rate, t) = (10.0, 0.1, 3.7);
    let off = rate * t * l;
    let mut g = Grains::default();
    g.push(0, SMALL, 0.5, 1.0, 2.0, 9.8);
    let (xj, yj, vxj) = if image {
        (8.5 - l + off, 10.3, 0.03 + rate * l)
    } else {
        (8.5, 0.3, 0.03)
    };
    g.push(1, SMALL, 0.5, 1.0, xj, yj);
    g.vx[0] = 0.98;
    g.vy[0] = 0.1;
    g.omega[0] = 0.4;
    g.vx[1] = vxj;
    g.vy[1] = -0.2;
    g.omega[1] = -0.7;
    let mut p = params(2, 0.5, model, rate);
    p.n = 2;
    let mut s = ShearSim::from_grains(p, g, l);
    s.time = t;
    s.gamma = rate * t;
    s.refresh();
    s
}

#[test]
fn a_pair_across_the_lees_edwards_boundary_feels_the_unwrapped_force() {
    for model in [Dissipation::Cd, Dissipation::Cdrot] {
        let (mut a, mut b) = (pair(false, model), pair(true, model));
        let vir = a.virial();
        assert_eq!(vir.contacts, 1, "they touch through the boundary");
        // The virial of the one contact is f_01 ⊗ r_01 (Eqs. 12–13), elastic plus
        // dissipative, and the same in the unwrapped picture.
        let (dx, dy) = a.boundary().delta(a.g.x[0] - a.g.x[1], a.g.y[0] - a.g.y[1]);
        let f_r = [a.fx[0] * dx, a.fx[0] * dy, a.fy[0] * dx, a.fy[0] * dy];
        let vb = b.virial();
        for (k, f_r) in f_r.iter().enumerate() {
            let total = vir.el[k] + vir.dis[k];
            assert!((total - f_r).abs() < 1e-12, "{model:?} component {k}");
            assert!((total - vb.el[k] - vb.dis[k]).abs() < 1e-12);
        }
        assert!(vir.el[0] > 0.0 && vir.dis[0] != 0.0);
        for (u, v) in [(&a.fx, &b.fx), (&a.fy, &b.fy), (&a.tq, &b.tq)] {
            for k in 0..2 {
                assert!((u[k] - v[k]).abs() < 1e-12, "{model:?}: {u:?} vs {v:?}");
            }
        }
        assert!(a.fx[0].abs() > 1e-3 && (a.fx[0] + a.fx[1]).abs() < 1e-15);
    }
}

#[test]
fn momentum_is_conserved_and_cd_rotation_does_not_feed_back() {
    let mut a = ShearSim::new(params(256, 0.82, Dissipation::Cd, 1e-3));
    let mut b = a.clone();
    b.rotate = false;
    let p0 = a.momentum();
    for _ in 0..2000 {
        a.step();
        b.step();
    }
    let p1 = a.momentum();
    assert!(
        (p1.0 - p0.0).abs() < 1e-9 && (p1.1 - p0.1).abs() < 1e-9,
        "{p0:?} → {p1:?}"
    );
    assert_eq!(
        a.g.x, b.g.x,
        "CD: same trajectories with rotation on or off"
    );
    assert_eq!(a.g.vy, b.g.vy);
    assert!(a.g.omega.iter().any(|w| *w != 0.0) && b.g.omega.iter().all(|w| *w == 0.0));
    // CDrot couples them.
    let mut c = ShearSim::new(params(256, 0.82, Dissipation::Cdrot, 1e-3));
    let mut d = c.clone();
    d.rotate = false;
    for _ in 0..500 {
        c.step();
        d.step();
    }
    assert_ne!(c.g.x, d.g.x);
}

#[test]
fn contact_number_matches_two_tau_nu_and_disks_roll_at_minus_half_the_rate() {
    let out = tmpdir("stats");
    let opt = ShearOptions {
        n: 512,
        phi: 0.76,
        rate: 1e-3,
        strain: 2.0,
        quiet: true,
        ..Default::default()
    };
    let rep = run(&out, &opt).unwrap();
    let s = &rep.summary;
    let (z, ztn) = (s["z"].mean, s["two_tau_dur_nu_coll"].mean);
    assert!((ztn / z - 1.0).abs() < 0.05, "Z = {z}, 2 τ ν = {ztn}");
    let spin = s["theta_dot_over_gamma_dot"];
    assert!(
        (spin.mean + 0.5).abs() < 0.05,
        "⟨θ̇/γ̇⟩ = {} ± {}",
        spin.mean,
        spin.err
    );
    // Homogeneous flow: R_v = ⟨δv_x²⟩/⟨v_y²⟩ of order one (Eq. 37).
    let rv = s["r_v"].mean;
    assert!(rv > 0.3 && rv < 3.0, "R_v = {rv}");
    for k in [
        "p", "sigma", "mu", "b_p", "eta_p", "tau_dur", "nu_coll", "r_v",
    ] {
        assert!(s[k].mean > 0.0 && s[k].err >= 0.0, "{k}");
    }
    // The transport coefficients as the paper defines them (Eqs. 19, 20; Fig. 2):
    // B = P/(γ̇ τ_e)², η = P/(γ̇ τ_0) with τ_0 = τ_e/Q (k_d = 1/Q), in units τ_e = m = 1.
    let (rate, q) = (opt.rate, opt.q);
    for (b, eta, of) in [("b_p", "eta_p", "p"), ("b_p_el", "eta_p_el", "p_el")] {
        let pm = s[of].mean;
        let close = |a: f64, want: f64| ((a - want) / want).abs() < 1e-12;
        assert!(
            close(s[b].mean, pm / (rate * rate)),
            "{b} = {} against {of}/γ̇²",
            s[b].mean
        );
        assert!(
            close(s[eta].mean, pm * q / rate),
            "{eta} = {} against {of} Q/γ̇",
            s[eta].mean
        );
    }
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    for k in [
        "z",
        "tau_dur",
        "nu_coll",
        "two_tau_dur_nu_coll",
        "p",
        "sigma",
        "mu",
        "b_p",
        "eta_p",
        "theta_dot_over_gamma_dot",
    ] {
        assert!(
            j[k]["mean"].is_number() && j[k]["err"].is_number(),
            "summary.json {k}"
        );
    }
    assert!(out.join("manifest.json").exists());
}

/// Near jamming contacts live long against the window (φ = 0.82: τ_dur ≈ 330 τ_e in a
/// 1500 τ_e window), so the contacts that end inside it are the short ones: their mean
/// alone puts 2 τ_dur ν_coll about 12 % under Z. The censoring-aware τ_dur (contacts
/// begun in the window followed to its end, those still open counted as such) agrees
/// with Z within its error, and says how much of the cohort was censored.
#[test]
fn two_tau_nu_matches_z_near_jamming_despite_long_contacts() {
    let out = tmpdir("censored");
    let opt = ShearOptions {
        n: 512,
        phi: 0.82,
        q: 1.0,
        rate: 1e-3,
        strain: 2.0,
        quiet: true,
        ..Default::default()
    };
    let rep = run(&out, &opt).unwrap();
    let s = &rep.summary;
    let (z, ztn, nu) = (s["z"], s["two_tau_dur_nu_coll"], s["nu_coll"].mean);
    let censored = s["tau_dur_censored_fraction"].mean;
    assert!(censored > 0.05 && censored < 0.6, "censored {censored}");
    let biased = 2.0 * s["tau_dur_ended_only"].mean * nu;
    let sigma = (ztn.err.powi(2) + z.err.powi(2)).sqrt();
    assert!(
        (ztn.mean - z.mean).abs() < 3.0 * sigma,
        "Z = {} ± {}, 2 τ ν = {} ± {}",
        z.mean,
        z.err,
        ztn.mean,
        ztn.err
    );
    assert!(
        (biased - z.mean).abs() > (ztn.mean - z.mean).abs(),
        "the ended-only estimate ({biased}) should be the worse one"
    );
}

#[test]
fn dilute_cd_flow_keeps_the_linear_profile() {
    let rate = 1e-2;
    let mut s = ShearSim::new(params(400, 0.5, Dissipation::Cd, rate));
    for _ in 0..4000 {
        s.step(); // strain 2
    }
    // Least-squares slope of v_x against y in the primary cell.
    let n = s.g.len();
    let (mut sy, mut sv, mut syy, mut syv) = (0.0, 0.0, 0.0, 0.0);
    for i in 0..n {
        let (_, y) = s.wrapped(i);
        let v = s.g.vx[i] - rate * (s.g.y[i] - y); // velocity of the primary-cell image
        sy += y;
        sv += v;
        syy += y * y;
        syv += y * v;
    }
    let nn = n as f64;
    let slope = (nn * syv - sy * sv) / (nn * syy - sy * sy);
    assert!(
        (slope / rate - 1.0).abs() < 0.1,
        "dv_x/dy = {slope}, γ̇ = {rate}"
    );
}

#[test]
fn cli_acceptance_outputs_and_kinematics_on_sheared_tracks() {
    let out = tmpdir("cli");
    let bin = env!("CARGO_BIN_EXE_pillar-pipe");
    let o = Command::new(bin)
        .args([
            "simulate", "shear", "--n", "256", "--phi", "0.82", "--q", "1", "--rate", "1e-3",
            "--model", "cdrot",
        ])
        .args(["--strain", "0.5", "--quiet", "-o", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let series = read_table(&out.join("series.parquet"), &[]).unwrap();
    assert!(series.df.height() > 100);
    assert_eq!(
        series.columns(),
        pillar_pipe::schema::load("shear_series").names(),
        "data_schema/shear_series.schema.json"
    );
    let t = read_table(&out.join("tracks.parquet"), &[]).unwrap();
    assert_eq!(t.df.height() % 256, 0);
    let k = out.join("k.parquet");
    let o = Command::new(bin)
        .args([
            "kinematics",
            out.join("tracks.parquet").to_str().unwrap(),
            "--lag",
            "1",
            "--rc",
            "1.5",
        ])
        .args(["-o", k.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    // The affine part of the sheared neighbourhoods is the imposed shear: mean J12 ≈ γ̇ Δt.
    let kt = read_table(&k, &[]).unwrap();
    let j12 = kt.f64("j12").unwrap();
    let valid = kt.bool("valid").unwrap();
    let m: Vec<f64> = j12
        .iter()
        .zip(&valid)
        .filter(|(_, v)| **v)
        .map(|(j, _)| *j)
        .collect();
    let mean = m.iter().sum::<f64>() / m.len() as f64;
    let frame_strain = 0.05;
    assert!(
        (mean / frame_strain - 1.0).abs() < 0.3,
        "mean J12 {mean} vs γ per frame {frame_strain}"
    );
    let o = Command::new(bin)
        .args([
            "simulate",
            "shear",
            "--n",
            "64",
            "--ramp",
            "up",
            "-o",
            tmpdir("ramp0").to_str().unwrap(),
        ])
        .output()
        .unwrap();
    // A ramp needs its end rate.
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("--rate-end"));
}

#[test]
fn checkpoint_halt_resume_equals_an_uninterrupted_run() {
    let bin = env!("CARGO_BIN_EXE_pillar-pipe");
    let (a, b) = (tmpdir("ra"), tmpdir("rb"));
    let base = [
        "simulate", "shear", "--n", "128", "--phi", "0.8", "--rate", "1e-2", "--strain", "0.6",
        "--quiet",
    ];
    let run_cli = |extra: &[&str]| {
        let o = Command::new(bin).args(base).args(extra).output().unwrap();
        (
            o.status.success(),
            format!(
                "{}{}",
                String::from_utf8_lossy(&o.stdout),
                String::from_utf8_lossy(&o.stderr)
            ),
        )
    };
    let (ok, text) = run_cli(&["-o", a.to_str().unwrap()]);
    assert!(ok, "{text}");
    let (ok, text) = run_cli(&[
        "--checkpoint-every",
        "300",
        "--halt-after",
        "700",
        "-o",
        b.to_str().unwrap(),
    ]);
    assert!(!ok && text.contains("halted"), "{text}");
    assert!(
        b.join("checkpoint.bin").exists()
            && !b.join("tracks.parquet").exists()
            && !b.join("manifest.json").exists()
    );
    let (ok, text) = run_cli(&["--checkpoint-every", "300", "--resume", b.to_str().unwrap()]);
    assert!(ok, "{text}");
    for t in [
        "series.parquet",
        "tracks.parquet",
        "collision_angles.parquet",
        "profile.parquet",
        "contact_velocities.parquet",
        "fields.parquet",
    ] {
        let (x, y) = (
            read_table(&a.join(t), &[]).unwrap(),
            read_table(&b.join(t), &[]).unwrap(),
        );
        assert_eq!(format!("{:?}", x.df), format!("{:?}", y.df), "{t}");
    }
    let sa: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(a.join("summary.json")).unwrap()).unwrap();
    let sb: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(b.join("summary.json")).unwrap()).unwrap();
    assert_eq!(sa["p"], sb["p"]);
    assert_eq!(sa["z"], sb["z"]);
    assert!(!b.join("checkpoint.bin").exists() && !b.join(".parts").exists());
    // The sidecar keeps one Lees–Edwards box per frame across the parts.
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(b.join("tracks.parquet.meta.json")).unwrap())
            .unwrap();
    let frames = read_table(&b.join("tracks.parquet"), &[])
        .unwrap()
        .df
        .height()
        / 128;
    assert_eq!(m["boxes"].as_array().unwrap().len(), frames);
    assert_eq!(m["length_unit"], "d_s");
}

/// `--resume DIR` alone continues with the run's own options (issue 33, item 4): a run
/// with non-default N, φ, γ̇, strain and seed, halted twice, ends with an uninterrupted
/// run's tables byte for byte; a typed option that differs is refused by name.
#[test]
fn resume_alone_continues_with_the_runs_own_options() {
    let bin = env!("CARGO_BIN_EXE_pillar-pipe");
    let (a, b) = (tmpdir("alone-a"), tmpdir("alone-b"));
    let b_s = b.to_str().unwrap();
    let run_cli = |args: &[&str]| {
        let o = Command::new(bin).args(args).output().unwrap();
        (
            o.status.success(),
            format!(
                "{}{}",
                String::from_utf8_lossy(&o.stdout),
                String::from_utf8_lossy(&o.stderr)
            ),
        )
    };
    let base = [
        "simulate", "shear", "--n", "128", "--phi", "0.8", "--rate", "1e-2", "--strain", "0.6",
        "--seed", "5", "--quiet",
    ];
    let (ok, text) = run_cli(&[&base[..], &["-o", a.to_str().unwrap()]].concat());
    assert!(ok, "{text}");
    let halted = [
        &base[..],
        &[
            "--checkpoint-every",
            "300",
            "--halt-after",
            "500",
            "-o",
            b_s,
        ],
    ]
    .concat();
    let (ok, text) = run_cli(&halted);
    assert!(!ok && text.contains("halted"), "{text}");
    let (ok, text) = run_cli(&["simulate", "shear", "--phi", "0.81", "--resume", b_s]);
    assert!(
        !ok && text.contains("phi: then 0.8, now 0.81") && text.contains("-o NEW_DIR"),
        "{text}"
    );
    // Run-only options may differ.
    let (ok, text) = run_cli(&[
        "simulate",
        "shear",
        "--checkpoint-every",
        "200",
        "--checkpoint-interval",
        "0",
        "--halt-after",
        "800",
        "--resume",
        b_s,
    ]);
    assert!(
        !ok && text.contains("halted") && text.contains("seed = 5"),
        "{text}"
    );
    let (ok, text) = run_cli(&["simulate", "shear", "--resume", b_s]);
    assert!(
        ok && text.contains("phi = 0.8") && text.contains("seed = 5"),
        "{text}"
    );
    for t in [
        "series.parquet",
        "tracks.parquet",
        "collision_angles.parquet",
        "profile.parquet",
        "contact_velocities.parquet",
        "fields.parquet",
    ] {
        assert!(
            std::fs::read(a.join(t)).unwrap() == std::fs::read(b.join(t)).unwrap(),
            "{t} differs byte for byte"
        );
    }
    // The summary also lists the options, whose run-only ones differ here.
    let summary = |d: &std::path::Path| {
        let mut v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(d.join("summary.json")).unwrap())
                .unwrap();
        v.as_object_mut().unwrap().remove("options");
        v
    };
    assert_eq!(summary(&a), summary(&b));
}

#[test]
fn sweep_runs_the_grid_once_and_tabulates_it() {
    let bin = env!("CARGO_BIN_EXE_pillar-pipe");
    let out = tmpdir("sweep");
    let args = [
        "sweep",
        "--phi",
        "0.76,0.8",
        "--q",
        "1",
        "--rate",
        "1e-2,2e-2",
        "--n",
        "64",
        "--strain",
        "0.5",
        "--jobs",
        "2",
    ];
    let o = Command::new(bin)
        .args(args)
        .args(["-o", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let t = read_table(&out.join("sweep.parquet"), &[]).unwrap();
    assert_eq!(t.df.height(), 4);
    let cols = t.columns();
    for c in [
        "phi", "q", "rate", "p", "p_err", "sigma", "mu", "z", "tau_dur", "nu_coll",
    ] {
        assert!(cols.iter().any(|x| x == c), "{c} in {cols:?}");
    }
    let (phi, rate) = (t.f64("phi").unwrap(), t.f64("rate").unwrap());
    assert_eq!(phi, vec![0.76, 0.76, 0.8, 0.8]);
    assert_eq!(rate, vec![1e-2, 2e-2, 1e-2, 2e-2]);
    // Denser is stiffer: more pressure at the same rate.
    let p = t.f64("p").unwrap();
    assert!(p[2] > p[0] && p[3] > p[1], "{p:?}");
    let before = std::fs::read(out.join("sweep.parquet")).unwrap();
    let o = Command::new(bin)
        .args(args)
        .args(["-o", out.to_str().unwrap()])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success() && text.contains("4 already finished"),
        "{text}"
    );
    assert_eq!(
        std::fs::read(out.join("sweep.parquet")).unwrap(),
        before,
        "same table when read back"
    );
}

#[test]
fn a_ramp_changes_the_rate_every_tau_e_and_rescales_velocities() {
    let out = tmpdir("ramp");
    let opt = ShearOptions {
        n: 256,
        phi: 0.8,
        rate: 1e-2,
        ramp: Some("up".into()),
        kappa: 0.05,
        rate_end: Some(1e-1),
        window: 5.0,
        sample_every: 5,
        quiet: true,
        ..Default::default()
    };
    run(&out, &opt).unwrap();
    let s = read_table(&out.join("series.parquet"), &[]).unwrap();
    let (rate, time) = (s.f64("rate").unwrap(), s.f64("time").unwrap());
    // γ̇(t) = γ̇0 10^{κ̃ floor(t/τ_e)} (Eqs. 38–39), ending at the requested rate.
    for (r, t) in rate.iter().zip(&time) {
        let want = 1e-2 * 10f64.powf(0.05 * t.floor());
        assert!((r / want - 1.0).abs() < 1e-9, "t = {t}: {r} vs {want}");
    }
    assert!((rate.last().unwrap() / 1e-1 - 1.0).abs() < 1e-9);
    let w = read_table(&out.join("ramp.parquet"), &[]).unwrap();
    assert_eq!(w.columns(), pillar_pipe::schema::load("shear_ramp").names());
    assert_eq!(w.df.height(), 4, "20 τ_e in windows of 5 τ_e");
    let (wr, ws) = (w.f64("rate").unwrap(), w.f64("sigma").unwrap());
    assert!(wr.windows(2).all(|p| p[1] > p[0]));
    assert!(
        ws.windows(2).all(|p| p[1] > p[0]),
        "faster shear, more stress: {ws:?}"
    );
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(j["rate_changes"], 20);
    // Eq. 40: rescaling keeps the profile at the new rate.
    let mut sim = ShearSim::new(params(256, 0.8, Dissipation::Cdrot, 1e-3));
    let vx0 = sim.g.vx.clone();
    sim.set_rate(2e-3);
    for (a, b) in sim.g.vx.iter().zip(&vx0) {
        assert!((a - 2.0 * b).abs() <= 1e-15 * b.abs().max(1e-300));
    }
}

#[test]
fn collision_angles_and_profile_in_steady_shear() {
    let out = tmpdir("angles");
    let opt = ShearOptions {
        n: 512,
        phi: 0.8,
        rate: 1e-2,
        strain: 3.0,
        quiet: true,
        ..Default::default()
    };
    run(&out, &opt).unwrap();
    let a = read_table(&out.join("collision_angles.parquet"), &[]).unwrap();
    assert_eq!(a.df.height(), 100, "3.6° bins over (−180°, 180°]");
    assert_eq!(
        a.columns(),
        pillar_pipe::schema::load("collision_angles").names()
    );
    let pr = read_table(&out.join("profile.parquet"), &[]).unwrap();
    assert_eq!(
        pr.columns(),
        pillar_pipe::schema::load("shear_profile").names()
    );
    let (lo, hi) = (
        a.f64("theta_lo_deg").unwrap(),
        a.f64("theta_hi_deg").unwrap(),
    );
    assert_eq!((lo[0], hi[99]), (-180.0, 180.0));
    let (mk, br, both) = (
        a.f64("making").unwrap(),
        a.f64("breaking").unwrap(),
        a.f64("pdf").unwrap(),
    );
    let norm: f64 = both.iter().sum::<f64>() * 3.6;
    assert!((norm - 1.0).abs() < 1e-9);
    // Eq. 27: a contact that begins has the grains driven into each other (|ϑ| > 90°),
    // one that breaks has them driven apart (|ϑ| < 90°) — the 99 % check.
    let share = |h: &[f64], inside: bool| -> f64 {
        let sel: f64 = lo
            .iter()
            .zip(hi.iter().zip(h))
            .filter(|(l, (u, _))| (**l >= -90.0 && **u <= 90.0) == inside)
            .map(|(_, (_, c))| *c)
            .sum();
        sel / h.iter().sum::<f64>()
    };
    assert!(mk.iter().sum::<f64>() > 1000.0, "enough contacts to judge");
    let (approach, separate) = (share(&mk, false), share(&br, true));
    assert!(approach >= 0.99, "making with |ϑ| > 90°: {approach}");
    assert!(separate >= 0.99, "breaking with |ϑ| < 90°: {separate}");
    // The summary carries the same counts and fractions, and P(±90°).
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let counts = |k: &str| -> Vec<f64> {
        s[k].as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect()
    };
    assert_eq!(counts("collision_angle_making"), mk);
    assert_eq!(counts("collision_angle_breaking"), br);
    let q = |k: &str| s[k]["mean"].as_f64().unwrap();
    assert!((q("making_approaching_fraction") - approach).abs() < 1e-12);
    assert!((q("breaking_separating_fraction") - separate).abs() < 1e-12);
    let p90 = (both[74] + both[75]) / 2.0;
    assert!((q("p_theta_90") - p90).abs() <= 1e-12 * p90.max(1e-300));
    // The steady profile is the imposed one.
    let p = read_table(&out.join("profile.parquet"), &[]).unwrap();
    let (y, vx, aff) = (
        p.f64("y").unwrap(),
        p.f64("vx").unwrap(),
        p.f64("vx_affine").unwrap(),
    );
    let n = y.len() as f64;
    let (my, mv) = (y.iter().sum::<f64>() / n, vx.iter().sum::<f64>() / n);
    let slope = y
        .iter()
        .zip(&vx)
        .map(|(a, b)| (a - my) * (b - mv))
        .sum::<f64>()
        / y.iter().map(|a| (a - my).powi(2)).sum::<f64>();
    assert!((slope / 1e-2 - 1.0).abs() < 0.2, "dv_x/dy = {slope}");
    assert!((aff[0] - 1e-2 * y[0]).abs() < 1e-15);
    // φ(y) and the local fields average back to the global φ; the local rate to γ̇.
    let phi_y = p.f64("phi").unwrap();
    let mean_phi = phi_y.iter().sum::<f64>() / phi_y.len() as f64;
    assert!((mean_phi / 0.8 - 1.0).abs() < 0.02, "φ(y) mean {mean_phi}");
    let f = read_table(&out.join("fields.parquet"), &[]).unwrap();
    assert_eq!(
        f.columns(),
        pillar_pipe::schema::load("shear_fields").names()
    );
    let (fphi, fg) = (f.f64("phi").unwrap(), f.f64("gamma_dot_over_rate").unwrap());
    let m = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    assert!(
        (m(&fphi) / 0.8 - 1.0).abs() < 0.1,
        "local φ mean {}",
        m(&fphi)
    );
    assert!((m(&fg) - 1.0).abs() < 0.3, "local γ̇/γ̇ mean {}", m(&fg));
    // Contact velocities (Fig. 21): the sample, V^C_T = V_T + V^R, and in CDrot the
    // rotation cancels much of the tangential slip: var V^C_T < var V_T.
    let cv = read_table(&out.join("contact_velocities.parquet"), &[]).unwrap();
    assert_eq!(
        cv.columns(),
        pillar_pipe::schema::load("contact_velocities").names()
    );
    assert!(cv.df.height() >= 4000, "{}", cv.df.height());
    let (vt, vr, vct) = (
        cv.f64("v_t").unwrap(),
        cv.f64("v_r").unwrap(),
        cv.f64("v_c_t").unwrap(),
    );
    for k in 0..vt.len() {
        assert!((vct[k] - vt[k] - vr[k]).abs() <= 1e-9 * (1.0 + vct[k].abs()));
    }
    let var = |v: &[f64]| {
        let m = v.iter().sum::<f64>() / v.len() as f64;
        v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64
    };
    assert!(
        var(&vct) < var(&vt),
        "var V^C_T {} vs var V_T {}",
        var(&vct),
        var(&vt)
    );
}

#[test]
fn re_sorting_into_cell_order_keeps_the_physics_and_every_contact() {
    // Sheared a while, so storage order and space have drifted apart.
    let mut a = ShearSim::new(params(512, 0.82, Dissipation::Cdrot, 1e-3));
    a.resort_every = 0;
    for _ in 0..400 {
        a.step();
    }
    let mut b = a.clone();
    // Its list built on two threads (the steps' team): the same list.
    b.threads = 2;
    assert!(
        b.resort(),
        "400 steps of shear should have scrambled the order"
    );
    // Same grains, same forces on each (by id), same contacts with the same history.
    let by_id = |s: &ShearSim, v: &[f64]| {
        let mut p: Vec<(i64, f64)> = s.g.id.iter().cloned().zip(v.iter().cloned()).collect();
        p.sort_by_key(|e| e.0);
        p.into_iter().map(|e| e.1).collect::<Vec<_>>()
    };
    assert_eq!(by_id(&a, &a.g.x), by_id(&b, &b.g.x));
    assert_eq!(by_id(&a, &a.fx), by_id(&b, &b.fx));
    let history = |s: &ShearSim| {
        let mut h: Vec<(i64, i64, u64)> = Vec::new();
        for i in 0..s.g.len() {
            for k in s.list.start[i] as usize..s.list.start[i + 1] as usize {
                if s.list.shear[k] != 0.0 {
                    let (p, q) = (s.g.id[i], s.g.id[s.list.j[k] as usize]);
                    h.push((p.min(q), p.max(q), s.list.shear[k].to_bits()));
                }
            }
        }
        h.sort();
        h
    };
    assert!(!history(&a).is_empty());
    assert_eq!(history(&a), history(&b));
    // Then both run on: contacts begun/ended agree exactly over a short stretch (no
    // contact is counted as new because its indices changed), the state to round-off.
    let (b0, e0) = (b.coll.begun, b.coll.ended);
    for _ in 0..50 {
        a.step();
        b.step();
    }
    assert_eq!(a.coll.begun - b0, b.coll.begun - b0);
    assert_eq!(a.coll.ended - e0, b.coll.ended - e0);
    let (xa, xb) = (by_id(&a, &a.g.x), by_id(&b, &b.g.x));
    let worst = xa
        .iter()
        .zip(&xb)
        .map(|(p, q)| (p - q).abs())
        .fold(0.0, f64::max);
    assert!(worst < 1e-9, "positions drift apart by {worst}");
}

/// The virial a sample reads, computed in ranges of grains (on the steps' threads)
/// and summed in order, against the straight loop's one pass: the same sums and
/// contact count bit for bit, for any split and thread count.
#[test]
fn the_virial_in_ranges_gives_the_straight_loops_sums_bit_for_bit() {
    use pillar_pipe::dem::shear::pairs::{PairParams, add_virial, for_each_virial_term, pair_loop};
    use pillar_pipe::dem::shear::params::{Collisions, Virial};
    let mut s = ShearSim::new(params(700, 0.84, Dissipation::Cdrot, 1e-2));
    for _ in 0..300 {
        s.step();
    }
    let got = s.virial();
    let b = s.boundary();
    let pp = PairParams::new(&s.p, s.l, b.offset(), s.time);
    let st = s.state_slices();
    // The Verlet list (the near list's pairs and more, in the same order: the same
    // contacts in the same order as the near list `virial` reads).
    let (start, js) = (&s.list.start[..], &s.list.j[..]);
    let n = s.g.len();
    let (mut fx, mut fy, mut tq) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let (mut coll, mut want) = (Collisions::default(), Virial::default());
    pair_loop::<false, true>(
        st,
        start,
        js,
        &mut [],
        &pp,
        &mut fx,
        &mut fy,
        &mut tq,
        &mut coll,
        &mut want,
    );
    assert!(
        want.contacts > n,
        "a dense packing: {} contacts",
        want.contacts
    );
    let bits = |v: &Virial| {
        let t: Vec<u64> = v.el.iter().chain(&v.dis).map(|x| x.to_bits()).collect();
        (t, v.contacts)
    };
    assert_eq!(bits(&got), bits(&want));
    for cuts in [
        vec![0, n],
        vec![0, 1, n],
        vec![0, 350, 351, n],
        vec![0, 100, 400, 650, n],
    ] {
        // Each range's terms apart (as threads make them), then added in order.
        let terms: Vec<Vec<[f64; 8]>> = cuts
            .windows(2)
            .map(|w| {
                let mut out = Vec::new();
                for_each_virial_term(st, (start, js), &pp, w[0]..w[1], |t| out.push(t));
                out
            })
            .collect();
        let mut sum = Virial::default();
        terms
            .iter()
            .flatten()
            .for_each(|&t| add_virial(&mut sum, t));
        assert_eq!(bits(&sum), bits(&want), "{cuts:?}");
    }
    for threads in [2, 3] {
        let mut t = s.clone();
        t.threads = threads;
        assert_eq!(bits(&t.virial()), bits(&want), "{threads} threads");
    }
}

/// The vectorised two-pass kernel (`shear_slots`, each instruction-set version) against
/// the straight loop (`shear_pairs::pair_loop`): every model and exponent, a dense and a
/// dilute packing, long enough for contacts to make and break and the list to be
/// rebuilt. Same numbers bit for bit: positions, velocities, spins, forces, collision
/// statistics, contact history and virial.
#[test]
fn slot_kernel_gives_the_straight_loops_run_bit_for_bit() {
    use pillar_pipe::dem::backend::simd::{Level, detected, level, use_at_most};
    use pillar_pipe::dem::shear::ShearKernel;
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    for (model, alpha, phi) in [
        (Dissipation::Cdrot, 2.0, 0.84),
        (Dissipation::Cd, 2.0, 0.82),
        (Dissipation::Cdrot, 2.5, 0.80),
        (Dissipation::Cd, 2.5, 0.50),
    ] {
        let mut p = params(300, phi, model, 1e-2);
        p.alpha = alpha;
        let start = ShearSim::new(p);
        let mut straight = start.clone();
        straight.kernel = ShearKernel::Straight;
        for _ in 0..600 {
            straight.step();
        }
        assert!(
            straight.coll.begun > 50 && straight.coll.ended > 50,
            "{model:?}"
        );
        assert!(
            straight.list.builds > 2,
            "{model:?}: the list was never rebuilt"
        );
        for max in [Level::Baseline, Level::Avx2, Level::Avx512] {
            if detected() < max {
                // Missing hardware is a skip, said so, not a pass.
                eprintln!("SKIP: this CPU has no {max:?}: that kernel is not compared");
                continue;
            }
            use_at_most(max);
            assert_eq!(level(), max);
            let mut fast = start.clone();
            for _ in 0..600 {
                fast.step();
            }
            let what = format!("{model:?} α = {alpha} {max:?}");
            // The near list was re-selected often, not only with the Verlet list.
            let builds = fast.list.builds;
            assert!(
                fast.slots.selections > 2 * builds,
                "{what}: {builds} builds"
            );
            let (f, s) = (&fast.g, &straight.g);
            for (a, b) in [
                (&f.x, &s.x),
                (&f.y, &s.y),
                (&f.vx, &s.vx),
                (&f.vy, &s.vy),
                (&f.theta, &s.theta),
                (&f.omega, &s.omega),
                (&fast.fx, &straight.fx),
                (&fast.fy, &straight.fy),
                (&fast.tq, &straight.tq),
            ] {
                assert_eq!(bits(a), bits(b), "{what}");
            }
            // The Verlet lists are rebuilt at different steps (the slot kernel checks
            // its list only when it re-selects the near list): compare the history of
            // every pair that has some.
            let held = |s: &ShearSim| {
                let l = &s.list;
                let mut h = Vec::new();
                for i in 0..s.g.len() {
                    for k in l.start[i] as usize..l.start[i + 1] as usize {
                        if l.shear[k] != 0.0 {
                            h.push((i, l.j[k], l.shear[k].to_bits()));
                        }
                    }
                }
                h
            };
            assert_eq!(held(&fast), held(&straight), "{what}");
            assert_eq!(fast.virial(), straight.virial(), "{what}");
            assert_eq!(fast.coll, straight.coll, "{what}");
        }
        use_at_most(Level::Avx512);
    }
}

/// The lists are rebuilt only when grains stray from the affine flow (not when the flow
/// itself carries them, however fast at large L), and the near list the force kernels
/// read holds every touching pair at every evaluated state: checked by brute force over
/// all pairs, at a rate fast enough for the box to shear by a disk diameter between
/// Verlet-list builds.
#[test]
fn sheared_pair_lists_never_miss_a_contact() {
    let mut s = ShearSim::new(params(400, 0.80, Dissipation::Cdrot, 0.01));
    // Past the start, where the random packing's overlaps fly apart.
    for _ in 0..3000 {
        s.step();
    }
    let n = s.g.len();
    let (b0, s0) = (s.list.builds, s.slots.selections);
    for step in 0..1500 {
        s.step();
        let b = s.boundary();
        let near: std::collections::HashSet<(u32, u32)> = s.slots.pairs().collect();
        for i in 0..n {
            for j in i + 1..n {
                let (dx, dy) = b.delta(s.g.x[i] - s.g.x[j], s.g.y[i] - s.g.y[j]);
                let dij = s.g.radius[i] + s.g.radius[j];
                if dx * dx + dy * dy < dij * dij {
                    let pair = (i as u32, j as u32);
                    assert!(near.contains(&pair), "step {step}: pair {i}–{j} missing");
                }
            }
        }
    }
    // The offset moves γ̇ L dt ≈ 0.01 d_s a step: a rule that spent the skin (0.3 d_s)
    // on it would rebuild at least every 30 steps, 50 times in 1500 steps.
    let builds = s.list.builds - b0;
    assert!(builds < 35, "{builds} rebuilds");
    assert!(
        s.slots.selections - s0 > builds,
        "the near list is re-selected in between"
    );
}

/// A box too small for the lists' minimum images is refused with the reason.
#[test]
fn a_box_smaller_than_twice_the_list_reach_is_refused() {
    let small = params(4, 0.82, Dissipation::Cd, 1e-3);
    let e = small.validate().unwrap_err();
    assert!(e.contains("box of side") && e.contains("more disks"), "{e}");
    assert!(params(64, 0.82, Dissipation::Cd, 1e-3).validate().is_ok());
}

/// The near list's skin thins where selections are rare (slow shear) and thickens where
/// the flow forces them within a few steps (fast shear), and changes no number: runs
/// started at the thinnest and the thickest skin stay bit-identical.
#[test]
fn the_near_list_skin_adapts_and_changes_no_number() {
    use pillar_pipe::dem::shear::near::{NEAR_SKIN_MAX, NEAR_SKIN_MIN};
    let bits = |s: &ShearSim| {
        let g = &s.g;
        [&g.x, &g.y, &g.vx, &g.vy, &g.omega, &s.fx, &s.tq]
            .iter()
            .flat_map(|v| v.iter().map(|x| x.to_bits()))
            .collect::<Vec<_>>()
    };
    for (rate, steps) in [(1e-4, 3000), (3e-2, 600)] {
        let start = ShearSim::new(params(300, 0.82, Dissipation::Cdrot, rate));
        let (mut thin, mut thick) = (start.clone(), start);
        thin.slots.set_skin(NEAR_SKIN_MIN);
        thick.slots.set_skin(NEAR_SKIN_MAX);
        for _ in 0..steps {
            thin.step();
            thick.step();
        }
        assert_eq!(bits(&thin), bits(&thick), "γ̇ = {rate}");
        assert_eq!(thin.coll, thick.coll, "γ̇ = {rate}");
        let (a, b) = (thin.slots.skin(), thick.slots.skin());
        if rate < 1e-3 {
            assert!(
                b < 0.5 * NEAR_SKIN_MAX,
                "slow shear kept a thick skin: {a} {b}"
            );
        } else {
            assert!(
                a > 2.0 * NEAR_SKIN_MIN,
                "fast shear kept the thinnest skin: {a} {b}"
            );
        }
    }
}

/// Eq. 27 on hand-made pairs: ϑ rotates v_ij onto r_ij (counter-clockwise positive),
/// −180° < ϑ ≤ 180°, and the bins are (−180° + 3.6° k, −180° + 3.6° (k + 1)].
#[test]
fn collision_angle_is_eq_27() {
    use pillar_pipe::dem::shear::{angle_bin, collision_angle};
    let th = |r: (f64, f64), v: (f64, f64)| collision_angle(r, v).unwrap();
    // i to the right of j, moving left at it: head-on approach (the −0 cross product
    // atan2 would call −180° is +180°).
    assert_eq!(th((1.0, 0.0), (-1.0, 0.0)), 180.0);
    assert_eq!(th((1.0, 0.0), (-1.0, -0.0)), 180.0);
    assert_eq!(angle_bin(180.0), 99);
    // Separating along r_ij.
    assert_eq!(th((0.3, -0.4), (0.6, -0.8)), 0.0);
    assert_eq!(angle_bin(0.0), 49);
    // Grazing: v_ij along +x, r_ij along +y is a quarter turn counter-clockwise (+90°);
    // r_ij along −y, clockwise (−90°). The sign is the sense of rotation.
    assert!((th((0.0, 1.0), (1.0, 0.0)) - 90.0).abs() < 1e-12);
    assert!((th((0.0, -1.0), (1.0, 0.0)) + 90.0).abs() < 1e-12);
    // Just past grazing, either way: approach has |ϑ| > 90°, separation |ϑ| < 90°.
    let eps = 1e-3;
    let a = th((0.0, 1.0), (1.0, eps)); // v has a component along +r: separating
    let b = th((0.0, 1.0), (1.0, -eps)); // against r: approaching
    assert!(a < 90.0 && b > 90.0, "{a} {b}");
    assert_eq!((angle_bin(a), angle_bin(b)), (74, 75));
    assert_eq!((angle_bin(-a), angle_bin(-b)), (25, 24));
    // Exact edges belong to the bin below; the open end −180° never occurs.
    assert_eq!((angle_bin(90.0), angle_bin(-90.0)), (74, 24));
    assert_eq!(angle_bin(-180.0 + 1e-9), 0);
    // Rotating the whole picture leaves ϑ alone.
    let (c, s) = (0.3f64.cos(), 0.3f64.sin());
    let rot = |(x, y): (f64, f64)| (c * x - s * y, s * x + c * y);
    let (r, v) = ((0.2, 0.9), (-0.7, 0.1));
    assert!((th(rot(r), rot(v)) - th(r, v)).abs() < 1e-9);
    // No relative velocity, no angle.
    assert_eq!(collision_angle((1.0, 0.0), (0.0, 0.0)), None);
    assert_eq!(collision_angle((f64::NAN, 0.0), (1.0, 0.0)), None);
}

/// A pair that meets through the Lees–Edwards boundary: the image of j moves γ̇L faster
/// along x, so the relative velocity is v_ij = (0, 1) and the contact forms at
/// r_ij ≈ (0.2, −0.95), ϑ ≈ −168° (bin 3). Forgetting the image's velocity would give
/// v_ij = (1, 1) and ϑ ≈ −123° (bin 15). The same pair placed at its image agrees, on
/// every kernel.
#[test]
fn a_contact_made_across_the_seam_has_the_image_velocity_in_its_angle() {
    use pillar_pipe::dem::shear::{ShearKernel, angle_bin, collision_angle};
    let expected = angle_bin(collision_angle((0.2, -0.95), (0.0, 1.0)).unwrap());
    assert_eq!(expected, 3);
    let forgot = angle_bin(collision_angle((0.2, -0.95), (1.0, 1.0)).unwrap());
    assert_eq!(forgot, 15);
    for kernel in [ShearKernel::Straight, ShearKernel::default()] {
        for image in [false, true] {
            let (l, rate, t) = (10.0, 0.1, 3.7);
            let off = rate * t * l;
            let mut g = Grains::default();
            g.push(0, SMALL, 0.5, 1.0, 2.2, 9.4);
            // j's image sits 1.1 d_s above i and 0.2 d_s to its left, moving down at it.
            let (xj, yj, vxj) = if image {
                (2.0, 10.5, -1.0 + rate * l)
            } else {
                (2.0 - off + l, 0.5, -1.0)
            };
            g.push(1, SMALL, 0.5, 1.0, xj, yj);
            g.vy[0] = 0.5;
            g.vx[1] = vxj;
            g.vy[1] = -0.5;
            let mut p = params(2, 0.5, Dissipation::Cd, rate);
            p.n = 2;
            let mut s = ShearSim::from_grains(p, g, l);
            s.kernel = kernel;
            s.time = t;
            s.gamma = rate * t;
            s.refresh();
            for _ in 0..20 {
                s.step();
                if s.coll.begun > 0 {
                    break;
                }
            }
            let what = format!("{kernel:?}, image {image}");
            assert_eq!(s.coll.begun, 1, "{what}");
            let bins: Vec<usize> = (0..100).filter(|&k| s.coll.angle_making[k] > 0).collect();
            assert_eq!(bins, [expected], "{what}");
        }
    }
}

/// The collision angle's two limits: in a dilute elastic gas (φ = 0.6, Q = 20) impact
/// parameters are spread evenly, so P(ϑ) vanishes at grazing (±90°) and its mass lies
/// at head-on angles; in dense, strongly damped flow (φ = 0.76, Q = 0.1) contacts form
/// and break glancing, peaked at ±90° (vagberg-sheared-disks Figs. 8–9). The issue's
/// check at φ = 0.82 in CD: near zero well above Q_c (Q = 300), a clear peak below it
/// (Q = 3).
#[test]
fn p_theta_90_is_small_in_a_dilute_gas_and_peaks_in_dense_damped_flow() {
    let uniform = 1.0 / 360.0;
    let mut p90 = Vec::new();
    let cases = [
        (0.6, 20.0, 1e-3),
        (0.76, 0.1, 1e-4),
        (0.82, 300.0, 1e-3),
        (0.82, 3.0, 1e-3),
    ];
    for (phi, q, rate) in cases {
        let out = tmpdir("p90");
        let opt = ShearOptions {
            n: 256,
            phi,
            q,
            rate,
            model: Dissipation::Cd,
            strain: 2.0,
            quiet: true,
            ..Default::default()
        };
        let s = run(&out, &opt).unwrap().summary;
        p90.push(s["p_theta_90"].mean);
    }
    assert!(p90[0] < 0.3 * uniform, "dilute gas: P(90°) = {}", p90[0]);
    assert!(p90[1] > 3.0 * uniform, "dense, damped: P(90°) = {}", p90[1]);
    assert!(
        p90[2] < 0.3 * uniform,
        "φ = 0.82, Q = 300: P(90°) = {}",
        p90[2]
    );
    assert!(
        p90[3] > 3.0 * uniform,
        "φ = 0.82, Q = 3: P(90°) = {}",
        p90[3]
    );
}

/// CDn (normal dissipation only) is Bagnoldian, p ∝ γ̇², where CD at the same φ and Q
/// is not (vagberg-sheared-disks Sec. II, citing the CDn papers), and at a Q ten times
/// larger too ("for all values of φ and Q"); it runs the reference loop, which the
/// manifest says.
#[test]
fn cdn_is_bagnoldian_where_cd_is_not() {
    let slope = |model: Dissipation, phi: f64, q: f64| {
        let p: Vec<f64> = [1e-3, 1e-4]
            .iter()
            .map(|&rate| {
                let out = tmpdir("cdn");
                let opt = ShearOptions {
                    n: 256,
                    phi,
                    q,
                    rate,
                    model,
                    strain: 1.0,
                    quiet: true,
                    ..Default::default()
                };
                let rep = run(&out, &opt).unwrap();
                if model == Dissipation::Cdn {
                    let m = std::fs::read_to_string(out.join("manifest.json")).unwrap();
                    assert!(m.contains("\"force_kernel\": \"reference\""), "{m}");
                }
                rep.summary["p"].mean
            })
            .collect();
        (p[0] / p[1]).log10()
    };
    let (cdn, cd) = (
        slope(Dissipation::Cdn, 0.82, 1.0),
        slope(Dissipation::Cd, 0.82, 1.0),
    );
    assert!((cdn - 2.0).abs() < 0.2, "CDn: d ln p / d ln γ̇ = {cdn}");
    assert!(cd < 1.5, "CD: d ln p / d ln γ̇ = {cd}");
    let high_q = slope(Dissipation::Cdn, 0.80, 10.0);
    assert!((high_q - 2.0).abs() < 0.25, "CDn at Q = 10: {high_q}");
}

/// A checkpoint from before the collision angle of Eq. 27 (50 bins of r_ij's direction)
/// is refused with the reason, never continued with the old counts under the new name.
#[test]
fn a_checkpoint_with_the_old_direction_histograms_is_refused_with_the_reason() {
    let mut s = ShearSim::new(params(64, 0.5, Dissipation::Cd, 1e-3));
    let good = s.save(&[]);
    assert!(ShearSim::load(&good).is_ok());
    s.coll.angle_making = vec![0; 50];
    s.coll.angle_breaking = vec![0; 50];
    let err = ShearSim::load(&s.save(&[])).expect_err("refused");
    assert!(
        err.contains("50 bins") && err.contains("Eq. 27") && err.contains("without --resume"),
        "{err}"
    );
}

/// Any thread count gives the same run bit for bit: positions, velocities, spins,
/// forces, contact histories and collision counts after a few hundred steps fast
/// enough to re-select the near list, rebuild the Verlet list and re-sort on the way,
/// at every vector level that runs threads; a run that changes its thread count
/// half-way too; and `simulate shear`'s output tables, byte for byte.
#[test]
fn any_thread_count_gives_the_same_run_bit_for_bit() {
    use pillar_pipe::dem::backend::simd::{Level, detected, use_at_most};
    let bits = |s: &ShearSim| {
        let g = &s.g;
        let arrays = [
            &g.x, &g.y, &g.vx, &g.vy, &g.theta, &g.omega, &s.fx, &s.fy, &s.tq,
        ];
        arrays
            .iter()
            .map(|v| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>())
            .collect::<Vec<_>>()
    };
    for model in [Dissipation::Cdrot, Dissipation::Cd] {
        let mut start = ShearSim::new(params(700, 0.84, model, 1e-2));
        start.resort_every = 100;
        let run = |threads: &[usize]| {
            let mut s = start.clone();
            for &t in threads {
                s.threads = t;
                for _ in 0..100 {
                    s.step();
                }
            }
            s
        };
        for max in [Level::Avx2, Level::Avx512] {
            if detected() < max {
                // Missing hardware is a skip, said so, not a pass.
                eprintln!("SKIP: this CPU has no {max:?}: its threads are not compared");
                continue;
            }
            use_at_most(max);
            let one = run(&[1, 1, 1, 1]);
            assert!(one.coll.begun > 50 && one.coll.ended > 50);
            assert!(
                one.list.builds > start.list.builds + 3,
                "rebuilt on the way"
            );
            assert!(
                one.slots.selections > one.list.builds,
                "re-selected on the way"
            );
            for threads in [vec![2; 4], vec![3; 4], vec![2, 1, 3, 2]] {
                let other = run(&threads);
                let what = format!("{model:?} {max:?} threads {threads:?}");
                assert_eq!(
                    other.step_threads_used(),
                    *threads.last().unwrap(),
                    "{what}"
                );
                assert!(bits(&one) == bits(&other), "{what}");
                assert_eq!(one.list.shear, other.list.shear, "{what}");
                assert_eq!(one.coll, other.coll, "{what}");
                assert_eq!(one.slots.selections, other.slots.selections, "{what}");
            }
        }
        use_at_most(Level::Avx512);
    }
    // The CLI's tables: the same bytes on one thread and on three.
    let mut tables = Vec::new();
    for threads in [1, 3] {
        let out = tmpdir(&format!("threads-{threads}"));
        let opt = ShearOptions {
            n: 400,
            phi: 0.84,
            rate: 1e-2,
            strain: 1.0,
            quiet: true,
            threads,
            ..Default::default()
        };
        run(&out, &opt).unwrap();
        let mut files: Vec<_> = std::fs::read_dir(&out)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "parquet"))
            .collect();
        files.sort();
        assert!(files.len() >= 4, "{files:?}");
        let bytes: Vec<_> = files
            .iter()
            .map(|p| (p.file_name().unwrap().to_owned(), std::fs::read(p).unwrap()))
            .collect();
        tables.push(bytes);
    }
    assert!(
        tables[0] == tables[1],
        "output tables differ between 1 and 3 threads"
    );
}

/// `--output-every 0` writes the first and the last frame only (a regression: the
/// loop that steps up to the next frame once divided by it and panicked), and the
/// series is sampled as with any interval.
#[test]
fn output_every_zero_writes_the_first_and_last_frames() {
    let out = tmpdir("every0");
    let opt = ShearOptions {
        n: 64,
        phi: 0.8,
        rate: 1e-2,
        strain: 0.1,
        output_every: Some(0),
        blocks: 2,
        quiet: true,
        ..Default::default()
    };
    run(&out, &opt).unwrap();
    let frames = read_table(&out.join("tracks.parquet"), &[])
        .unwrap()
        .df
        .height()
        / 64;
    assert_eq!(frames, 2);
    // 0.1 / (1e-2 · 0.05) = 200 steps, a sample every 10 from step 0 to 200.
    let series = read_table(&out.join("series.parquet"), &[]).unwrap();
    assert_eq!(series.df.height(), 21);
}
