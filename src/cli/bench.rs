//! CLI wiring for `pillar-pipe bench …`: each hot path against a reference measured in
//! the same run.

use anyhow::Result;
use clap::Subcommand;
use pillar_pipe::kinematics::Convention;
use std::path::PathBuf;

#[derive(Subcommand)]
pub enum BenchCmd {
    /// The figures a user feels, one after another with their defaults: the whole
    /// `kinematics` command against OVITO's whole process (kinematics-whole), the
    /// N = 1000 pillar on one and two threads (dem --k 1), the fit at 4 M samples (fit),
    /// g(r) against freud (gofr). About two minutes.
    User,
    /// One frame pair of the kinematics kernel, 1 and 2 threads.
    Kinematics {
        #[arg(long, value_delimiter = ',', default_value = "64000,1000000")]
        n: Vec<usize>,
        #[arg(long, default_value_t = 3)]
        reps: usize,
        /// Time the first two frames of these tracks instead (e.g. the frames OVITO ran on).
        #[arg(long)]
        input: Option<PathBuf>,
        /// R_c for --input (length unit).
        #[arg(long, default_value_t = 1.25)]
        rc: f64,
        #[arg(long, value_enum, default_value = "paper")]
        convention: Convention,
        #[arg(long)]
        json: bool,
    },
    /// The whole `kinematics` command on one frame pair from a file, against OVITO's Atomic
    /// Strain as a whole Python process on the same frames (alternating runs, medians).
    KinematicsWhole {
        #[arg(long, default_value_t = 1_000_000)]
        n: usize,
        #[arg(long, default_value_t = 5)]
        reps: usize,
        /// Where to put the frames and outputs (default: a fresh temp dir, removed after).
        #[arg(long)]
        dir: Option<PathBuf>,
        /// The Python with OVITO (`pip install ovito`); without it only ours is timed.
        #[arg(long, default_value = "python3")]
        python: String,
        #[arg(long)]
        json: bool,
    },
    /// g(r) by species of N grains (li-granular-pillars Fig. 2) against freud's
    /// density.RDF on the same points (`pip install freud-analysis`), compute only,
    /// alternating rounds, medians.
    Gofr {
        #[arg(long, default_value_t = 64_000)]
        n: usize,
        #[arg(long, default_value_t = 3)]
        reps: usize,
        #[arg(long, default_value_t = 3)]
        rounds: usize,
        /// The Python with freud.
        #[arg(long, default_value = "python3")]
        python: String,
        #[arg(long)]
        json: bool,
    },
    /// Tracking a rendered pillar movie: the whole `pillar-pipe track` process against
    /// trackpy's `batch` + `link` as a whole Python process (`pip install trackpy
    /// pillow`), same settings, as many processes as our threads; alternating rounds,
    /// medians; both scored against the movie's ground truth (lost, spurious, rms error,
    /// identity switches). Default movie: the bundled sample's 1000 grains rendered at
    /// the shared sample's 31.496 px/cm (grains 20 and 15 px across).
    Track {
        /// Tracks to render (any table `ingest` reads, or a pillar run folder).
        #[arg(long)]
        input: Option<PathBuf>,
        /// Pixels per length unit for the rendering.
        #[arg(long, default_value_t = 31.496063)]
        px_per_unit: f64,
        #[arg(long, default_value_t = 3)]
        rounds: usize,
        /// Threads for us, processes for trackpy (default: the machine's cores).
        #[arg(long)]
        processes: Option<usize>,
        #[arg(long, default_value_t = 19)]
        diameter: usize,
        #[arg(long, default_value_t = 1000.0)]
        minmass: f64,
        #[arg(long, default_value_t = 9.0)]
        separation: f64,
        #[arg(long, default_value_t = 2.0)]
        noise_size: f64,
        #[arg(long, default_value_t = 8.0)]
        search_range: f64,
        #[arg(long, default_value_t = 3)]
        memory: usize,
        /// Where to put the movie and outputs (default: a fresh temp dir, removed after).
        #[arg(long)]
        dir: Option<PathBuf>,
        /// The Python with trackpy.
        #[arg(long, default_value = "python3")]
        python: String,
        #[arg(long)]
        json: bool,
    },
    /// Ingest of a generated trackpy CSV vs polars' plain CSV read (time, peak memory).
    Ingest {
        #[arg(long, default_value_t = 10_000_000)]
        rows: usize,
        /// Where to put the generated CSV (default: the system temp dir).
        #[arg(long)]
        dir: Option<PathBuf>,
        /// Keep the generated CSV.
        #[arg(long)]
        keep: bool,
        /// Timed runs of each reader, alternating (this VM's memory and page-cache
        /// timings vary run to run; the best of several is the machine's own speed).
        #[arg(long, default_value_t = 5)]
        reps: usize,
    },
    #[command(hide = true)]
    IngestChild { mode: String, csv: PathBuf },
    /// Sheared disks (φ = 0.82, Q = 1, CDrot) particle-steps per second.
    Shear {
        #[arg(long, value_delimiter = ',', default_value = "1024,65536")]
        n: Vec<usize>,
        #[arg(long, default_value_t = 2000)]
        steps: u64,
        #[arg(long, default_value_t = 1000)]
        warmup: u64,
        #[arg(long)]
        json: bool,
    },
    /// The whole `fit` command as a user runs it (`fit k.parquet --diameter 1
    /// --bootstrap 1000`) on a protocol-shaped synthetic `kinematics` table: wall time
    /// and peak memory of each process, against issue 35's targets.
    Fit {
        /// Rows (an N = 16,000 pillar gives about 4 M: 35 starts × 7 lags).
        #[arg(long, default_value_t = 4_004_000)]
        samples: usize,
        #[arg(long, default_value_t = 35)]
        starts: u32,
        #[arg(long, default_value_t = 1000)]
        bootstrap: usize,
        /// Runs of the command (median wall time, largest peak memory).
        #[arg(long, default_value_t = 2)]
        reps: usize,
        /// Where to put the table and outputs (default: a fresh temp dir, removed after).
        #[arg(long)]
        dir: Option<PathBuf>,
        #[arg(long)]
        json: bool,
    },
    /// Stress–strain of the `fast` preset against the `paper` preset on one packing.
    Presets {
        #[arg(long, default_value_t = 200)]
        n: usize,
        #[arg(long, default_value_t = 0.1)]
        strain: f64,
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Strain bin for the comparison.
        #[arg(long, default_value_t = 0.01)]
        bin: f64,
    },
    /// The whole `pillar-pipe pack` command (Sec. II.A) against the same binary's
    /// `--serial --f-tol 0` (the packer as it was, bit for bit), alternating by seed;
    /// medians of wall and CPU time, mean φ.
    Pack {
        #[arg(long, default_value_t = 4000)]
        n: usize,
        #[arg(long, value_delimiter = ',', default_value = "1,2,3")]
        seeds: Vec<u64>,
        /// Threads of the pack runs (default: RAYON_NUM_THREADS, else every core).
        #[arg(long)]
        threads: Option<usize>,
        /// Where to put the packings (default: a fresh temp dir, removed after).
        #[arg(long)]
        dir: Option<std::path::PathBuf>,
        #[arg(long)]
        json: bool,
    },
    /// Pillar DEM particle-steps per second (N = 1000 k²), loaded to a small strain.
    Dem {
        /// Tiling factors k: N = 1000 k² grains.
        #[arg(long, value_delimiter = ',', default_value = "1,4")]
        k: Vec<usize>,
        #[arg(long, default_value_t = 20_000)]
        steps: u64,
        #[arg(long, default_value = "paper")]
        preset: String,
        /// Strain to load the pillar to before timing.
        #[arg(long, default_value_t = 0.02)]
        preload: f64,
        /// Write the loaded state here (for bench/lammps_pillar.py).
        #[arg(long)]
        export: Option<PathBuf>,
        /// Time a real run's state instead: a `simulate pillar --checkpoint-every`
        /// checkpoint (DIR/checkpoint.bin); --k, --preset and --preload are then unused.
        #[arg(long, conflicts_with = "export")]
        checkpoint: Option<PathBuf>,
        #[arg(long)]
        json: bool,
    },
}

/// What `bench user` runs, in order.
const USER_BENCHES: [&[&str]; 4] = [
    &["kinematics-whole"],
    &["dem", "--k", "1"],
    &["fit"],
    &["gofr"],
];

/// A sub-benchmark with its command-line defaults.
fn with_defaults(args: &[&str]) -> BenchCmd {
    #[derive(clap::Parser)]
    struct One {
        #[command(subcommand)]
        cmd: BenchCmd,
    }
    let argv = std::iter::once("bench").chain(args.iter().copied());
    <One as clap::Parser>::try_parse_from(argv)
        .expect("the bench's own arguments parse")
        .cmd
}

pub fn bench(what: BenchCmd) -> Result<()> {
    use pillar_pipe::bench;
    match what {
        BenchCmd::User => {
            for args in USER_BENCHES {
                println!("== pillar-pipe bench {}", args.join(" "));
                self::bench(with_defaults(args))?;
            }
        }
        BenchCmd::Fit {
            samples,
            starts,
            bootstrap,
            reps,
            dir,
            json,
        } => {
            let (work, temp) = match dir {
                Some(d) => (d, false),
                None => (
                    std::env::temp_dir().join(format!("pillar-pipe-fit-{}", std::process::id())),
                    true,
                ),
            };
            let exe = std::env::current_exe()?;
            let b =
                pillar_pipe::bench::fit::bench_fit(&exe, &work, samples, starts, bootstrap, reps);
            if temp {
                let _ = std::fs::remove_dir_all(&work);
            }
            let b = b?;
            if json {
                println!("{}", serde_json::to_string(&b)?);
            } else {
                let mb = |b: u64| b as f64 / 1e6;
                let met = |ok: bool| if ok { "met" } else { "NOT met" };
                println!(
                    "fit   `pillar-pipe fit` on a {} row kinematics table ({:.0} MB, {} starts × 7 lags), --bootstrap {}: median {:.2} s, peak {:.0} MB over {} runs (issue 35 targets: {:.0} s {}, {:.0} MB {}); Θ = {:.4}, η_c = {:.4} (true 0.3, 0.05)",
                    b.rows,
                    mb(b.table_bytes),
                    b.starts,
                    b.bootstrap,
                    b.median_s,
                    mb(b.peak_rss_bytes),
                    b.runs.len(),
                    b.target_s,
                    met(b.median_s < b.target_s),
                    mb(b.target_peak_bytes),
                    met(b.peak_rss_bytes < b.target_peak_bytes),
                    b.theta,
                    b.eta_c
                );
                for r in &b.runs {
                    println!(
                        "      {:.2} s wall, {:.2} s CPU, peak {:.0} MB",
                        r.seconds,
                        r.cpu_seconds,
                        mb(r.peak_rss_bytes)
                    );
                }
            }
        }
        BenchCmd::Shear {
            n,
            steps,
            warmup,
            json,
        } => {
            for n in n {
                let b = pillar_pipe::bench::dem::bench_shear(n, steps, warmup);
                if json {
                    println!("{}", serde_json::to_string(&b)?);
                } else {
                    println!(
                        "shear n={:>6} Z={:.2} {} steps {:.2} s  {:.1} ns/particle-step (Eqs. 21–24: two force evaluations per step; {} list builds, {} near-list selections); without re-sorting {:.1}",
                        b.n,
                        b.z,
                        b.steps,
                        b.seconds,
                        b.ns_per_particle_step,
                        b.list_builds,
                        b.near_selections,
                        b.ns_per_particle_step_unsorted
                    );
                }
            }
        }
        BenchCmd::Presets {
            n,
            strain,
            seed,
            bin,
        } => {
            let c = pillar_pipe::bench::dem::compare_presets(n, strain, seed, bin)?;
            println!("strain   sigma_fast  sigma_paper   (m g mu / D, binned means)");
            for (e, f, p) in &c.bins {
                println!("{e:6.3}   {f:9.3}   {p:9.3}");
            }
            println!(
                "mean sigma: fast {:.3}, paper {:.3}; mean |difference| {:.1}% of paper's mean; run time fast {:.1} s, paper {:.1} s",
                c.mean_stress_fast,
                c.mean_stress_paper,
                100.0 * c.mean_abs_difference_rel,
                c.seconds_fast,
                c.seconds_paper
            );
        }
        BenchCmd::Dem {
            k,
            steps,
            preset,
            preload,
            export,
            checkpoint,
            json,
        } => {
            let results: Vec<pillar_pipe::bench::dem::PillarBench> = match &checkpoint {
                Some(path) => vec![pillar_pipe::bench::dem::bench_checkpoint(path, steps)?],
                None => k
                    .iter()
                    .map(|&k| {
                        let dir = export
                            .as_ref()
                            .map(|d| d.join(format!("n{}", 1000 * k * k)));
                        pillar_pipe::bench::dem::bench_pillar(
                            k,
                            steps,
                            &preset,
                            preload,
                            dir.as_deref(),
                        )
                    })
                    .collect::<Result<_, _>>()?,
            };
            for b in results {
                if json {
                    println!("{}", serde_json::to_string(&b)?);
                } else {
                    println!(
                        "pillar n={:>6} Z={:.2} {:>6} steps {:>7.2} s  {:>6.1} ns/particle-step on {} thread(s); one thread {:.1} (both medians of {} alternating rounds); one thread without the frozen-grain skip {:.1} ({:.0}% of grain-steps frozen); pair-list distance pass {:.1} ns/particle; {} list builds",
                        b.n,
                        b.z,
                        b.steps,
                        b.seconds,
                        b.ns_per_particle_step,
                        b.threads,
                        b.ns_per_particle_step_one_thread,
                        b.rounds,
                        b.ns_per_particle_step_no_skip,
                        100.0 * b.reused_fraction,
                        b.floor_ns_per_particle,
                        b.list_builds
                    );
                    if b.fell_back {
                        println!(
                            "  a timed run on threads finished on one thread (its waits kept being long: a busy machine); the threads' figure is partly a one-thread one"
                        );
                    }
                    if b.threads > 1 {
                        let c = &b.cross_lines;
                        println!(
                            "  {} threads: {} cache lines cross cores a step (partners' state {}, terms {}, rest flags {}, chunk sums {}); moving that many there and back takes {:.2} µs here (same run; the partners' state alone {:.2} µs), of an overhead of {:.2} µs a step over the one-thread step / {}",
                            b.threads,
                            c.total(),
                            c.partner_state,
                            c.terms,
                            c.marking,
                            c.chunk_sums,
                            b.line_exchange_ns / 1e3,
                            b.state_exchange_ns / 1e3,
                            b.overhead_ns_per_step / 1e3,
                            b.threads
                        );
                    }
                }
            }
        }
        BenchCmd::Track {
            input,
            px_per_unit,
            rounds,
            processes,
            diameter,
            minmass,
            separation,
            noise_size,
            search_range,
            memory,
            dir,
            python,
            json,
        } => {
            let processes = processes
                .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
            let settings = pillar_pipe::bench::track::TrackSettings {
                px_per_unit,
                locate: pillar_pipe::camera::LocateParams {
                    diameter,
                    minmass,
                    separation: Some(separation),
                    noise_size,
                    ..Default::default()
                },
                link: pillar_pipe::camera::LinkOptions {
                    memory,
                    ..pillar_pipe::camera::LinkOptions::new(search_range)
                },
                match_tolerance_px: 7.5,
                processes,
            };
            let input = input.unwrap_or_else(pillar_pipe::bench::track::default_input);
            let (work, temp) = match dir {
                Some(d) => (d, false),
                None => (
                    std::env::temp_dir().join(format!("pillar-pipe-track-{}", std::process::id())),
                    true,
                ),
            };
            let exe = std::env::current_exe()?;
            let b = pillar_pipe::bench::track::bench_track(
                &exe, &input, &settings, rounds, &work, &python,
            );
            if temp {
                let _ = std::fs::remove_dir_all(&work);
            }
            let b = b?;
            if json {
                println!("{}", serde_json::to_string_pretty(&b)?);
                return Ok(());
            }
            println!(
                "track  {} frames of {}x{} px rendered from {}; {} rounds alternating, whole processes, {} threads/processes, medians",
                b.frames, b.width, b.height, b.input, rounds, processes
            );
            let line = |name: &str, t: f64, s: &pillar_pipe::camera::score::TrackingScore| {
                println!(
                    "       {name:<28} {t:>7.2} s   found {:>6}  lost {:>5}  spurious {:>4}  rms {:.3} px  id switches {}  breaks {}",
                    s.detections,
                    s.lost,
                    s.spurious,
                    s.rms_error_px,
                    s.id_switches.unwrap_or(0),
                    s.trajectory_breaks.unwrap_or(0)
                )
            };
            line("pillar-pipe track", b.ours_median(), &b.ours_score);
            match (&b.trackpy, b.trackpy_median(), &b.trackpy_score) {
                (Ok(v), Some(t), Some(s)) => {
                    line(v, t, s);
                    println!(
                        "       ratio (trackpy / ours)       {:>7.1}x",
                        t / b.ours_median()
                    );
                }
                (e, _, _) => println!(
                    "       trackpy: not timed ({})",
                    e.clone().err().unwrap_or_default()
                ),
            }
            return Ok(());
        }
        BenchCmd::Gofr {
            n,
            reps,
            rounds,
            python,
            json,
        } => {
            let tmp = std::env::temp_dir().join(format!("pillar-pipe-gofr-{}", std::process::id()));
            let b = pillar_pipe::bench::gofr::bench_gofr(n, reps, rounds, &tmp, &python);
            let _ = std::fs::remove_dir_all(&tmp);
            let b = b?;
            if json {
                println!("{}", serde_json::to_string_pretty(&b)?);
                return Ok(());
            }
            println!(
                "gofr  n = {}, periodic box, r_max = {} D, {} bins; {} rounds x {} computes each, alternating, medians",
                b.n, b.r_max_over_d, b.bins, rounds, reps
            );
            println!(
                "      pillar-pipe g(r) (all, small, large)  {:>8.4} s   peak g = {:.2}",
                b.ours_median(),
                b.g_peak_ours
            );
            match (&b.freud, b.freud_median()) {
                (Ok(v), Some(f)) => {
                    println!(
                        "      freud {v} density.RDF            {f:>8.4} s   peak g = {:.2}",
                        b.g_peak_freud
                    );
                    println!(
                        "      freud / pillar-pipe: {:.1}x (issue 20 target: 10x)",
                        f / b.ours_median()
                    );
                }
                (Err(e), _) => println!("      no same-run reference: {e}"),
                (Ok(_), None) => println!("      no same-run reference: freud gave no timings"),
            }
        }
        BenchCmd::Pack {
            n,
            seeds,
            threads,
            dir,
            json,
        } => {
            let tmp = std::env::temp_dir().join(format!("pillar-pipe-pack-{}", std::process::id()));
            let at = dir.clone().unwrap_or_else(|| tmp.clone());
            let exe = std::env::current_exe()?;
            let b = pillar_pipe::bench::pack::bench_pack(&exe, n, &seeds, threads, &at);
            if dir.is_none() {
                let _ = std::fs::remove_dir_all(&tmp);
            }
            let b = b?;
            if json {
                println!("{}", serde_json::to_string_pretty(&b)?);
                return Ok(());
            }
            println!(
                "pack  n = {}, seeds {:?}, {} threads, whole `pillar-pipe pack` processes, alternating",
                b.n, seeds, b.threads
            );
            for r in &b.runs {
                println!(
                    "  seed {:>3} {:8} {:>8.2} s wall {:>8.2} s CPU  φ = {:.5}  {:>3} growths {:>8} CG iterations",
                    r.seed,
                    r.variant,
                    r.run.seconds,
                    r.run.cpu_seconds,
                    r.phi,
                    r.growth_steps,
                    r.cg_iterations
                );
            }
            let (w, c, phi) = b.summary("default");
            let (wr, cr, phir) = b.summary("reference");
            println!(
                "  medians: default {w:.2} s wall, {c:.2} s CPU; reference (--serial --f-tol 0) {wr:.2} s wall, {cr:.2} s CPU: {:.2}x wall, {:.2}x CPU",
                wr / w,
                cr / c
            );
            println!("  mean φ: default {phi:.5}, reference {phir:.5} (issue 35: within 1e-3)");
        }
        BenchCmd::KinematicsWhole {
            n,
            reps,
            dir,
            python,
            json,
        } => {
            let tmp =
                std::env::temp_dir().join(format!("pillar-pipe-whole-{}", std::process::id()));
            let at = dir.clone().unwrap_or_else(|| tmp.clone());
            let exe = std::env::current_exe()?;
            let b = pillar_pipe::bench::whole::bench_kinematics_whole(&exe, n, reps, &at, &python);
            if dir.is_none() {
                let _ = std::fs::remove_dir_all(&tmp);
            }
            let b = b?;
            if json {
                println!("{}", serde_json::to_string_pretty(&b)?);
                return Ok(());
            }
            let mb = |x: u64| x as f64 / 1e6;
            let ours = b.ours_median();
            println!(
                "kinematics-whole n = {}, one frame pair from a file, {} alternating runs each, medians",
                b.n, b.reps
            );
            println!(
                "  pillar-pipe kinematics (whole process)   {:>7.3} s   peak {:>5.0} MB = {:.2}x the output table ({:.0} MB in memory, {:.0} MB file)",
                ours,
                mb(b.ours_peak()),
                b.ours_peak() as f64 / b.output_table_bytes.max(1) as f64,
                mb(b.output_table_bytes),
                mb(b.output_bytes)
            );
            let d2 = b.ours_d2min_median();
            let d2_peak = b
                .ours_d2min
                .iter()
                .map(|r| r.peak_rss_bytes)
                .max()
                .unwrap_or(0);
            println!(
                "  ... --columns d2min (what OVITO saves)  {d2:>7.3} s   peak {:>5.0} MB ({:.0} MB file)",
                mb(d2_peak),
                mb(b.d2min_output_bytes)
            );
            match b.ovito_median() {
                Some(ov) => {
                    let peak = b.ovito.iter().map(|r| r.peak_rss_bytes).max().unwrap_or(0);
                    println!(
                        "  OVITO Atomic Strain (whole process)      {ov:>7.3} s   peak {:>5.0} MB",
                        mb(peak)
                    );
                    println!(
                        "  OVITO / pillar-pipe, whole process: {:.2}x writing every column, {:.2}x writing D²min only as OVITO does",
                        ov / ours,
                        ov / d2
                    );
                }
                None => println!(
                    "  no same-run reference: {}",
                    b.ovito_missing.as_deref().unwrap_or("OVITO unavailable")
                ),
            }
            let phases: Vec<String> = b
                .phases
                .iter()
                .map(|p| format!("{} {:.3} s", p.name, p.seconds))
                .collect();
            println!("  our phases (one more run): {}", phases.join(", "));
        }
        BenchCmd::Kinematics {
            n,
            reps,
            input,
            rc,
            convention,
            json,
        } => {
            let mut all = Vec::new();
            let given = match &input {
                Some(p) => Some(pillar_pipe::io::read_tracks(p)?.0),
                None => None,
            };
            // Synthetic pairs in lattice order, then relabelled into no spatial order
            // (a shuffled dump; this tool's pillar tracks), which the kernel fits in
            // the cell list's order.
            let cases: Vec<(usize, bool)> = if given.is_some() {
                vec![(0, false)]
            } else {
                n.iter().flat_map(|&n| [(n, false), (n, true)]).collect()
            };
            for &(n, shuffled) in &cases {
                for threads in [1, 2] {
                    let b = match &given {
                        Some(t) => {
                            bench::bench_kinematics_tracks(t, rc, convention, threads, reps)?
                        }
                        None => bench::bench_kinematics(n, threads, reps, shuffled)?,
                    };
                    if !json {
                        println!(
                            "kinematics n={:>8} {} threads={} {:>8.4} s/pair {:>12.0} particles/s   (same-run reference: cell list + neighbour count {:.4} s, ratio {:.2})",
                            b.n,
                            match (&given, shuffled) {
                                (Some(_), _) => "(given)   ",
                                (None, false) => "(lattice) ",
                                (None, true) => "(shuffled)",
                            },
                            b.threads,
                            b.seconds,
                            b.particles_per_s,
                            b.neighbour_pass_seconds,
                            b.seconds / b.neighbour_pass_seconds
                        );
                    }
                    all.push(b);
                }
                let (t1, t2) = (all[all.len() - 2].seconds, all[all.len() - 1].seconds);
                if !json {
                    println!("  speed-up 2 threads / 1 thread: {:.2}x", t1 / t2);
                }
            }
            if json {
                println!("{}", serde_json::to_string_pretty(&all)?);
            }
        }
        BenchCmd::Ingest {
            rows,
            dir,
            keep,
            reps,
        } => {
            let dir = dir.unwrap_or_else(std::env::temp_dir);
            std::fs::create_dir_all(&dir)?;
            let csv = dir.join(format!("pillar-pipe-bench-{rows}.csv"));
            eprintln!(
                "generating {} rows of trackpy CSV at {} ...",
                rows,
                csv.display()
            );
            bench::write_trackpy_csv(&csv, rows, 1)?;
            let size = std::fs::metadata(&csv)?.len();
            let exe = std::env::current_exe()?;
            // Both readers see the file in the page cache: read it once untimed.
            std::io::copy(&mut std::fs::File::open(&csv)?, &mut std::io::sink())?;
            let modes = ["polars", "ingest"];
            let mut res: Vec<Vec<bench::IngestChild>> = vec![Vec::new(), Vec::new()];
            for _ in 0..reps.max(1) {
                for (k, mode) in modes.iter().enumerate() {
                    let out = std::process::Command::new(&exe)
                        .args([
                            "bench",
                            "ingest-child",
                            mode,
                            csv.to_str().unwrap_or_default(),
                        ])
                        .output()?;
                    if !out.status.success() {
                        anyhow::bail!(
                            "{mode} child failed: {}",
                            String::from_utf8_lossy(&out.stderr)
                        );
                    }
                    res[k].push(serde_json::from_slice(&out.stdout)?);
                }
            }
            if !keep {
                let _ = std::fs::remove_file(&csv);
            }
            let table = rows as f64 * 52.0;
            println!(
                "ingest bench: {rows} rows, CSV {:.0} MB, canonical table {:.0} MB in memory, {} alternating runs each",
                size as f64 / 1e6,
                table / 1e6,
                reps.max(1)
            );
            let stat = |v: &[bench::IngestChild]| {
                let mut t: Vec<f64> = v.iter().map(|c| c.seconds).collect();
                t.sort_by(f64::total_cmp);
                let peak = v.iter().map(|c| c.peak_rss_bytes).max().unwrap_or(0);
                (t[0], t[t.len() / 2], peak)
            };
            let (pb, pm, _) = stat(&res[0]);
            let (ib, im, _) = stat(&res[1]);
            for (k, mode) in modes.iter().enumerate() {
                let (best, median, peak) = stat(&res[k]);
                println!(
                    "  {mode:7} best {best:5.2} s  median {median:5.2} s  {:>10.0} rows/s  peak RSS {:6.0} MB ({:.2}x the table)",
                    rows as f64 / best,
                    peak as f64 / 1e6,
                    peak as f64 / table
                );
            }
            println!(
                "  ingest / polars read time: {:.2}x (best), {:.2}x (median)",
                ib / pb,
                im / pm
            );
        }
        BenchCmd::IngestChild { mode, csv } => {
            let c = bench::ingest_child(&mode, &csv)?;
            println!("{}", serde_json::to_string(&c)?);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `bench user`'s list parses into the benches it names, with their defaults.
    #[test]
    fn user_benches_parse_with_their_defaults() {
        let cmds: Vec<BenchCmd> = USER_BENCHES.iter().map(|a| with_defaults(a)).collect();
        assert!(matches!(
            cmds[0],
            BenchCmd::KinematicsWhole { n: 1_000_000, .. }
        ));
        assert!(matches!(&cmds[1], BenchCmd::Dem { k, .. } if k == &vec![1]));
        assert!(matches!(cmds[2], BenchCmd::Fit { .. }));
        assert!(matches!(cmds[3], BenchCmd::Gofr { n: 64_000, .. }));
    }
}
