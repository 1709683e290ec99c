//! The structure analyses of li-granular-pillars Secs. III and V, one command each:
//! g(r), the outline, shear lines, the size scan and the bar pressure.

use anyhow::{Context, Result};
use clap::Args;
use pillar_pipe::pipeline::kinds::bar_pressure::BarPressureParams;
use pillar_pipe::pipeline::kinds::gofr::GofrParams;
use pillar_pipe::pipeline::kinds::outline::OutlineParams;
use pillar_pipe::pipeline::kinds::shear_lines::ShearLinesParams;
use std::path::{Path, PathBuf};

/// Pair distribution g(r) of one frame, around small and around large grains
/// (li-granular-pillars Fig. 2); r in units of the large-grain diameter D.
#[derive(Args)]
pub struct GofrArgs {
    /// Tracks (canonical CSV/Parquet, e.g. from ingest, simulate or pack).
    pub input: PathBuf,
    /// Output table (.parquet or .csv).
    #[arg(short, long)]
    pub output: PathBuf,
    #[command(flatten)]
    pub params: GofrParams,
}

pub fn gofr(args: GofrArgs) -> Result<()> {
    let GofrArgs {
        input,
        output,
        params: p,
    } = args;
    let (g, f, d) = pillar_pipe::stages::gofr::run(&input, &output, p.frame, p.r_max, p.bins)
        .with_context(|| format!("g(r) of {}", input.display()))?;
    let peak = |v: &[f64]| {
        g.r.iter()
            .zip(v)
            .filter(|(_, x)| x.is_finite())
            .max_by(|a, b| a.1.total_cmp(b.1))
            .map(|(r, x)| format!("{:.3} D (g = {x:.2})", r / d))
            .unwrap_or_else(|| "none".into())
    };
    println!(
        "g(r)        frame {f}: {} centres counted ({} small, {} large) of density {:.4} per unit²; first peak around small {}, around large {}",
        g.centres[0],
        g.centres[1],
        g.centres[2],
        g.density,
        peak(&g.g_small),
        peak(&g.g_large)
    );
    println!("wrote       {}", output.display());
    Ok(())
}

/// A pillar's outline at a frame (li-granular-pillars Fig. 9), in units of its
/// initial width W0: outermost grain edges in slabs one D thick. With --against,
/// also how far it is from another pillar's outline rescaled the same way.
#[derive(Args)]
pub struct OutlineArgs {
    /// Tracks of a pillar.
    pub input: PathBuf,
    #[arg(short, long)]
    pub output: PathBuf,
    /// Another pillar's tracks to compare with (e.g. another size).
    #[arg(long)]
    pub against: Option<PathBuf>,
    #[command(flatten)]
    pub params: OutlineParams,
}

pub fn outline(args: OutlineArgs) -> Result<()> {
    let OutlineArgs {
        input,
        output,
        against,
        params: p,
    } = args;
    let other = against.as_deref().map(|a| (a, p.against_frame));
    let (a, distance) = pillar_pipe::stages::outline::run(&input, p.frame, other, &output)
        .with_context(|| format!("outline of {}", input.display()))?;
    let hw = a.outline.half_width();
    let widest = hw.iter().fold(0.0f64, |m, &w| m.max(2.0 * w));
    println!(
        "outline     frame {}: {} slabs, height {:.3} W0, widest {:.3} W0 (W0 = {:.4})",
        a.frame,
        hw.len(),
        a.outline.height() / a.w0,
        widest / a.w0,
        a.w0
    );
    if let Some(d) = distance {
        println!("shape       rms distance of the rescaled half-widths: {d:.4} W0");
    }
    println!("wrote       {}", output.display());
    Ok(())
}

/// Transient shear lines (li-granular-pillars Fig. 11) in one frame pair of a
/// `kinematics` table: grains with J2 above THRESHOLD x the mean J2, linked at
/// 1.25 D, measured by the principal axes of their centres. Writes one row per line:
/// angle to the compression axis y in degrees (0-90), width and length in units of
/// the large-grain diameter D, centre in the table's length unit, mean J2 in
/// 1/time. Method: docs/shear-lines.md.
#[derive(Args)]
pub struct ShearLinesArgs {
    /// A `kinematics` table (from `pillar-pipe kinematics`: frame, frame_end, x, y, j2).
    pub kinematics: PathBuf,
    /// Output table (.csv or .parquet); default <stem>.shear_lines.csv beside the input.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    #[command(flatten)]
    pub params: ShearLinesParams,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

pub fn shear_lines(args: ShearLinesArgs) -> Result<()> {
    let ShearLinesArgs {
        kinematics,
        output,
        params,
        json,
    } = args;
    use pillar_pipe::stages::shear_lines as sl;
    let output = output.unwrap_or_else(|| sl::default_output(&kinematics));
    let opt = params.options();
    let rep = sl::run(&kinematics, &output, &opt)
        .with_context(|| format!("shear lines of {}", kinematics.display()))?;
    show(&rep, json, &output)
}

/// A line analysis's report: as JSON, or as text with the table it wrote.
fn show<T: serde::Serialize + std::fmt::Display>(rep: &T, json: bool, output: &Path) -> Result<()> {
    if json {
        println!("{}", serde_json::to_string_pretty(rep)?);
    } else {
        println!("{rep}");
        println!("wrote       {}", output.display());
    }
    Ok(())
}

/// A pillar size scan's flow stress (li-granular-pillars Fig. 10a, b): per
/// `simulate pillar` run ⟨σ⟩ over 0.05 ≤ ε ≤ 0.2 (m g μ/D) and κ, against W0; the
/// fit ⟨σ⟩ = c W0/D through the origin with its 95 % interval; the yield point ε_y,
/// σ_y of each σ(ε) (Sec. III; docs/size-scan.md), "not reached" for a curve still
/// rising at ε = 0.2.
#[derive(Args)]
pub struct SizesArgs {
    /// `simulate pillar` output directories (run each to ε ≥ 0.2).
    #[arg(required = true)]
    pub runs: Vec<PathBuf>,
    /// One row per run: N, W0/D, ⟨σ⟩ and its error (m g μ/D), ⟨κ⟩, χ = W/W0 at
    /// ε = 0.1 and 0.2, the bar pressure at the interface's centre (m g μ/D), ε_y and
    /// σ_y (m g μ/D) with their 95 % intervals (NaN where not reached).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Also every run's frames: ε, σ (m g μ/D), κ, χ (Figs. 10a, 10d, shape scaling).
    #[arg(long)]
    pub curves: Option<PathBuf>,
    /// Also every run's bar pressure profile p (m g μ/D) against x/W (Fig. 10c).
    #[arg(long)]
    pub pressure: Option<PathBuf>,
}

pub fn sizes(args: SizesArgs) -> Result<()> {
    let SizesArgs {
        runs,
        output,
        curves,
        pressure,
    } = args;
    let out = pillar_pipe::stages::sizes::SizeOutputs {
        table: output.clone(),
        curves,
        pressure,
    };
    let scan = pillar_pipe::stages::sizes::run(&runs, &out).context("size scan")?;
    let (rows, fit) = (&scan.rows, &scan.fit);
    for r in rows {
        println!(
            "size        N = {:6}  W0 = {:6.2} D  <sigma> = {:.3} ± {:.3} m g mu/D  kappa = {:.3}  ({})",
            r.n,
            r.w0_over_d,
            r.sigma,
            r.sigma_err,
            r.kappa,
            r.run.display()
        );
    }
    match fit {
        Some(f) => println!(
            "fit         <sigma> = c W0/D, c = {:.4} [{:.4}, {:.4}] (95 %) m g mu/D per D",
            f.c, f.c_interval[0], f.c_interval[1]
        ),
        None => println!("fit         needs two runs or more"),
    }
    for r in rows {
        match &r.yielding {
            pillar_pipe::structure::yielding::Yield::Reached(p) => println!(
                "yield       N = {:6}  eps_y = {:.4} [{:.4}, {:.4}]  sigma_y = {:.3} [{:.3}, {:.3}] m g mu/D  sigma_y/W0 = {:.4}",
                r.n,
                p.eps_y,
                p.eps_interval[0],
                p.eps_interval[1],
                p.sigma_y,
                p.sigma_interval[0],
                p.sigma_interval[1],
                p.sigma_y / r.w0_over_d
            ),
            pillar_pipe::structure::yielding::Yield::NotReached(why) => {
                println!("yield       N = {:6}  not reached: {why}", r.n)
            }
        }
    }
    for r in rows {
        println!(
            "shape       N = {:6}  chi = W/W0: {:.3} at eps = 0.1, {:.3} at 0.2",
            r.n, r.chi[0], r.chi[1]
        );
        match &r.pressure {
            Ok((_, snaps)) => println!(
                "pressure    N = {:6}  p at the centre = {:.3} m g mu/D ({snaps} snapshots, 0.1 <= eps <= 0.2), p/W0 = {:.4}",
                r.n,
                r.p_centre(),
                r.p_centre() / r.w0_over_d
            ),
            Err(e) => println!("warning     N = {}: no bar pressure: {e}", r.n),
        }
    }
    if let Some(c) = &scan.checks {
        let tol = &pillar_pipe::stages::sizes::TOLERANCES;
        let verdict = |ok: bool| if ok { "holds" } else { "does NOT hold" };
        println!(
            "check       <sigma>/W0 equal across sizes within {:.0} %: spread {:.1} % ({})",
            100.0 * tol.sigma_over_w0,
            100.0 * c.sigma_over_w0_spread,
            verdict(c.sigma_holds())
        );
        match (c.sigma_y_over_w0_spread, c.sigma_y_holds()) {
            (Some(s), Some(ok)) => println!(
                "check       sigma_y/W0 equal across sizes within {:.0} %: spread {:.1} % ({})",
                100.0 * tol.sigma_y_over_w0,
                100.0 * s,
                verdict(ok)
            ),
            _ => println!(
                "check       sigma_y/W0 equal across sizes within {:.0} %: not made (a run does not yield)",
                100.0 * tol.sigma_y_over_w0
            ),
        }
        println!(
            "check       kappa equal across sizes within {}: spread {:.3} ({})",
            tol.kappa,
            c.kappa_spread,
            verdict(c.kappa_holds())
        );
        for (what, law, want, holds) in [
            ("P_in vs W0", c.p_in_exponent, 2.0, c.p_in_holds()),
            ("P_g-s vs N", c.p_gs_exponent, 1.0, c.p_gs_holds()),
        ] {
            match (law, holds) {
                (Some(p), Some(ok)) => println!(
                    "check       exponent of {what} = {want} within {}: {:.3} {} ({})",
                    tol.exponent,
                    p.exponent,
                    if p.interval[0].is_finite() {
                        format!("[{:.3}, {:.3}] (95 %)", p.interval[0], p.interval[1])
                    } else {
                        "(two runs: no interval)".into()
                    },
                    verdict(ok)
                ),
                _ => println!("check       exponent of {what}: not measurable"),
            }
        }
        match (c.edge_rate_spread, c.edge_rate_holds()) {
            (Some(s), Some(ok)) => println!(
                "check       edge stress rate equal across sizes within {:.0} %: spread {:.1} % ({})",
                100.0 * tol.edge_rate,
                100.0 * s,
                verdict(ok)
            ),
            _ => println!(
                "check       edge stress rate: not measurable (a run has no force snapshot at 0.1 <= eps <= 0.2)"
            ),
        }
        for (k, at) in pillar_pipe::stages::sizes::CHI_AT.iter().enumerate() {
            println!(
                "check       W/W0 at eps = {at} equal across sizes within {:.0} %: spread {:.1} % ({})",
                100.0 * tol.chi,
                100.0 * c.chi_spread[k],
                verdict(c.chi_holds(k))
            );
        }
    }
    println!("wrote       {}", output.display());
    for p in [&out.curves, &out.pressure].into_iter().flatten() {
        println!("wrote       {}", p.display());
    }
    Ok(())
}

/// Contact pressure along the compressing bar of a `simulate pillar` run
/// (li-granular-pillars Fig. 10c): p in m g μ/D against x/W (W the span of the
/// grains touching the bar), averaged over the force snapshots in a strain window.
#[derive(Args)]
pub struct BarPressureArgs {
    /// A `simulate pillar` output directory.
    pub run: PathBuf,
    #[command(flatten)]
    pub params: BarPressureParams,
    /// x_over_w, p table (CSV or Parquet by extension).
    #[arg(short, long)]
    pub output: PathBuf,
}

pub fn bar_pressure(args: BarPressureArgs) -> Result<()> {
    let BarPressureArgs {
        run,
        params: BarPressureParams { strain, bins, .. },
        output,
    } = args;
    let (p, snaps) = pillar_pipe::stages::bar_pressure::run(&run, strain, bins, &output)
        .context("bar pressure")?;
    println!(
        "pressure    {snaps} snapshots at {} <= eps <= {}: W = {:.2} D, bar force {:.3} m g mu, {} grains touching",
        strain.0, strain.1, p.width, p.force, p.contacts
    );
    for (x, v) in p.x_over_w.iter().zip(&p.p) {
        println!("  x/W = {x:.2}   p = {v:.3} m g mu/D");
    }
    println!("wrote       {}", output.display());
    Ok(())
}

/// The front between moving and resting grains (li-granular-pillars Fig. 5a: sharp,
/// at about 45°) in every frame pair of a `kinematics` table. A grain moves when its
/// speed is at least MOVING times the pair's 95th-percentile speed (the grains the bar
/// drives). Per slab one D wide the boundary best separating moving from resting
/// grains; per half of the pillar a straight line through those boundaries. Writes one
/// row per pair and side: the angle to the bar (x axis) in degrees (0-90), slope,
/// intercept (length unit), the boundaries' rms about the line in D, and the fraction
/// of grains on the wrong side.
#[derive(Args)]
pub struct FrontArgs {
    /// A `kinematics` table (from `pillar-pipe kinematics`: frame, frame_end, x, y, speed).
    pub kinematics: PathBuf,
    /// Output table (.csv or .parquet).
    #[arg(short, long)]
    pub output: PathBuf,
    /// A grain moves when |v| >= MOVING x the pair's 95th-percentile speed (a fraction).
    #[arg(long, default_value_t = pillar_pipe::stages::front::FrontOptions::default().moving)]
    pub moving: f64,
    /// Only the pair starting at this frame (default: every pair).
    #[arg(long)]
    pub frame: Option<i64>,
    /// Large-grain diameter D in the table's length unit (default: the table's sidecar).
    #[arg(long)]
    pub diameter: Option<f64>,
}

pub fn front(args: FrontArgs) -> Result<()> {
    let opt = pillar_pipe::stages::front::FrontOptions {
        moving: args.moving,
        frame: args.frame,
        diameter: args.diameter,
    };
    let rep = pillar_pipe::stages::front::run(&args.kinematics, &args.output, &opt)
        .with_context(|| format!("front of {}", args.kinematics.display()))?;
    println!("{rep}");
    println!("wrote       {}", args.output.display());
    Ok(())
}

/// Transient shear lines (li-granular-pillars Sec. V): the lines of every frame pair of
/// a `kinematics` table (its smallest lag, pairs end to end), linked across consecutive
/// pairs when they share at least MIN_OVERLAP of the smaller line's grains. Prints the
/// lifetime distribution (in frame pairs and in the table's time unit), lines and births
/// per pair, and how many line grains are in a line again in the next pair against
/// chance; writes one row per line with its `track` and the track's lifetime
/// `track_pairs` (widths and lengths in D). Method: docs/shear-lines.md.
#[derive(Args)]
pub struct ShearLineTracksArgs {
    /// A `kinematics` table (frame, frame_end, particle, x, y, j2).
    pub kinematics: PathBuf,
    /// Output table (.csv or .parquet); default <stem>.shear_line_tracks.csv beside it.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    #[command(flatten)]
    pub params: pillar_pipe::pipeline::kinds::shear_line_tracks::ShearLineTracksParams,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

pub fn shear_line_tracks(args: ShearLineTracksArgs) -> Result<()> {
    use pillar_pipe::stages::line_tracks as lt;
    let output = args
        .output
        .unwrap_or_else(|| lt::default_output(&args.kinematics));
    let rep = lt::run(&args.kinematics, &output, &args.params.options())
        .with_context(|| format!("shear-line tracks of {}", args.kinematics.display()))?;
    show(&rep, args.json, &output)
}

/// Local stress against distance from the lateral edges of a `simulate pillar` run
/// (li-granular-pillars Sec. V): each grain's p = sum of its normal contact forces /
/// (2 pi R), in m g mu/D, binned by its distance d (in D, 1 D bins) to the nearer edge of
/// the pillar at its height, grains within 2 D of the bars left out, pooled over the
/// force snapshots in the strain window; and the rate dp/dd over d <= 6 D (m g mu/D per
/// D). Method: docs/size-scan.md.
#[derive(Args)]
pub struct EdgeStressArgs {
    /// A `simulate pillar` output directory (stress_strain, forces, tracks).
    pub run: PathBuf,
    #[command(flatten)]
    pub params: pillar_pipe::pipeline::kinds::edge_stress::EdgeStressParams,
    /// d_over_d, p, grains table (CSV or Parquet by extension).
    #[arg(short, long)]
    pub output: PathBuf,
}

pub fn edge_stress(args: EdgeStressArgs) -> Result<()> {
    let strain = args.params.strain;
    let p = pillar_pipe::stages::edge_stress::run(&args.run, strain, &args.output)
        .with_context(|| format!("edge stress of {}", args.run.display()))?;
    println!(
        "edge stress {} snapshots at {} <= eps <= {}: rate dp/dd = {:.3} m g mu/D per D over d <= {} D",
        p.snapshots,
        strain.0,
        strain.1,
        p.rate,
        pillar_pipe::structure::edge_stress::FIT_D
    );
    for ((d, v), g) in p.d_over_d.iter().zip(&p.p).zip(&p.grains) {
        println!("  d = {d:5.1} D   p = {v:.3} m g mu/D   ({g} grains)");
    }
    println!("wrote       {}", args.output.display());
    Ok(())
}
