//! The part of a stage's cache key that stands for the code: a hash of the source files
//! that can change the stage's result, made at build time (`build.rs`), and of
//! `Cargo.lock`. Two builds of the same source agree (a head process and its cluster
//! jobs built separately, a rebuilt binary), and fixing report code keeps hour-long
//! simulations cached.
//!
//! Every file counts for every kind unless listed below as unable to change that kind's
//! result, so a new module is covered until someone says otherwise: the rules only
//! ever leave out code that the kind does not run (the simulators for analysis stages,
//! the report for everything but the report, the fit for the stages before it), and
//! code that changes no stage's numbers (the command line, benchmarks, the run
//! bookkeeping, unit tests).

use super::Kind;
use crate::io::hash::sha256_bytes;

mod generated {
    include!(concat!(env!("OUT_DIR"), "/sources.rs"));
}
pub use generated::SOURCES;

/// Files no stage's result depends on: argument parsing, benchmarks, the run
/// bookkeeping (locks, records, views, executors), unit tests, the quickstart command.
fn never(path: &str) -> bool {
    let pipeline_bookkeeping = path.starts_with("src/pipeline/")
        && !matches!(path, "src/pipeline/exec.rs" | "src/pipeline/params.rs");
    path == "src/main.rs"
        || path.starts_with("src/cli_")
        || path.starts_with("src/bench")
        || path == "src/interrupt.rs"
        || path == "src/stages/quickstart.rs"
        || path.ends_with("/tests.rs")
        || pipeline_bookkeeping
}

/// What both simulators are made of (contact laws, grains, pair lists, the fast
/// paths), and the simulate stage's table plumbing that the sheared disks reuse.
fn simulator_core(p: &str) -> bool {
    (p.starts_with("src/dem/")
        && !p.starts_with("src/dem/pillar/")
        && !p.starts_with("src/dem/shear/"))
        || p.starts_with("src/stages/simulate/")
}

fn pillar_simulator(p: &str) -> bool {
    p.starts_with("src/dem/pillar/") || p == "src/stages/pack.rs"
}

fn shear_simulator(p: &str) -> bool {
    p.starts_with("src/dem/shear/") || p.starts_with("src/stages/shear/")
}

/// A sweep's own code only gathers its points' summaries into a table; the points
/// are `shear` stages, whose keys (in the sweep's) stand for the simulator.
fn sweep(p: &str) -> bool {
    p == "src/stages/sweep.rs"
}

fn report(p: &str) -> bool {
    p.starts_with("src/stages/report/")
}

fn fit(p: &str) -> bool {
    p.starts_with("src/fit/") || p.starts_with("src/stages/fit/")
}

fn kinematics(p: &str) -> bool {
    p.starts_with("src/kinematics/") || p == "src/stages/kinematics.rs"
}

/// Code that only some kinds run: (is a file in this group, the kinds that run it).
type Group = (fn(&str) -> bool, &'static [Kind]);
const GROUPS: &[Group] = &[
    (simulator_core, &[Kind::Simulate, Kind::Shear, Kind::Ramp]),
    (pillar_simulator, &[Kind::Simulate]),
    (shear_simulator, &[Kind::Shear, Kind::Ramp]),
    (sweep, &[Kind::Sweep]),
    (report, &[Kind::Report]),
    // Eq. 19 and the Sec. IV protocol; compare reads fit types, the report draws the model.
    (fit, &[Kind::Fit, Kind::Compare, Kind::Report]),
    // The kernels; the fit's protocol runs them too.
    (
        kinematics,
        &[Kind::Kinematics, Kind::Fit, Kind::Compare, Kind::Report],
    ),
];

/// Whether the file at `path` can change the result of a stage of `kind`.
pub fn covers(kind: Kind, path: &str) -> bool {
    if never(path) {
        return false;
    }
    GROUPS
        .iter()
        .find(|(is, _)| is(path))
        .is_none_or(|(_, kinds)| kinds.contains(&kind))
}

/// SHA-256 over the (path, hash) pairs of `sources` that `kind` depends on.
pub fn source_hash_for(kind: Kind, sources: &[(&str, &str)]) -> String {
    let mut text = String::new();
    for (path, hash) in sources.iter().filter(|(p, _)| covers(kind, p)) {
        text.push_str(path);
        text.push(' ');
        text.push_str(hash);
        text.push('\n');
    }
    sha256_bytes(text.as_bytes())
}

/// This build's source hash for `kind` (computed once per kind).
pub fn source_hash(kind: Kind) -> &'static str {
    static HASHES: std::sync::OnceLock<Vec<String>> = std::sync::OnceLock::new();
    let all = HASHES.get_or_init(|| {
        Kind::ALL
            .iter()
            .map(|k| source_hash_for(*k, SOURCES))
            .collect()
    });
    let i = Kind::ALL.iter().position(|k| *k == kind).unwrap_or(0);
    &all[i]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A source tree with one file in each part that matters, each at version `v[i]`.
    fn tree(report: &str, dem: &str, fit: &str, cli: &str) -> Vec<(&'static str, String)> {
        vec![
            ("Cargo.lock", "lock".into()),
            ("src/cli_runs.rs", cli.into()),
            ("src/dem/shear/mod.rs", dem.into()),
            ("src/fit/model.rs", fit.into()),
            ("src/io/table.rs", "io".into()),
            ("src/kinematics/mod.rs", "kin".into()),
            ("src/stages/report/render/figures.rs", report.into()),
            ("src/stages/report/fit.rs", report.into()),
            ("src/stages/shear/steady.rs", dem.into()),
            ("src/stages/simulate/setup.rs", dem.into()),
        ]
    }

    /// A tree whose pillar simulator, sheared-disk simulator and sweep table code are
    /// at the given versions.
    fn sim_tree(pillar: &str, shear: &str, sweep: &str) -> Vec<(&'static str, String)> {
        vec![
            ("Cargo.lock", "lock".into()),
            ("src/dem/pillar/kernels.rs", pillar.into()),
            ("src/stages/pack.rs", pillar.into()),
            ("src/dem/shear/pairs.rs", shear.into()),
            ("src/stages/shear/stats.rs", shear.into()),
            ("src/stages/sweep.rs", sweep.into()),
            ("src/dem/law/mod.rs", "law".into()),
        ]
    }

    #[test]
    fn each_simulator_changes_its_own_kind() {
        let base = keys(&sim_tree("p1", "s1", "w1"));
        assert_eq!(
            changed(&base, &keys(&sim_tree("p2", "s1", "w1"))),
            ["simulate"]
        );
        assert_eq!(
            changed(&base, &keys(&sim_tree("p1", "s2", "w1"))),
            ["shear", "ramp"]
        );
        assert_eq!(
            changed(&base, &keys(&sim_tree("p1", "s1", "w2"))),
            ["sweep"]
        );
        let mut t = sim_tree("p1", "s1", "w1");
        t[6].1 = "law2".into();
        assert_eq!(changed(&base, &keys(&t)), ["simulate", "shear", "ramp"]);
    }

    fn keys(t: &[(&'static str, String)]) -> Vec<String> {
        let v: Vec<(&str, &str)> = t.iter().map(|(p, h)| (*p, h.as_str())).collect();
        Kind::ALL.iter().map(|k| source_hash_for(*k, &v)).collect()
    }

    fn changed(a: &[String], b: &[String]) -> Vec<&'static str> {
        Kind::ALL
            .iter()
            .zip(a.iter().zip(b))
            .filter(|(_, (x, y))| x != y)
            .map(|(k, _)| k.name())
            .collect()
    }

    #[test]
    fn report_code_changes_only_the_report() {
        let base = keys(&tree("r1", "d1", "f1", "c1"));
        let edited = keys(&tree("r2", "d1", "f1", "c1"));
        assert_eq!(changed(&base, &edited), ["report"]);
    }

    #[test]
    fn simulator_code_changes_the_simulation() {
        let base = keys(&tree("r1", "d1", "f1", "c1"));
        let edited = keys(&tree("r1", "d2", "f1", "c1"));
        // The analysis stages downstream of a simulation are recomputed through their
        // upstream key (the simulation's), not through their own code; the tree's
        // files are shared code and both simulators' stages.
        assert_eq!(changed(&base, &edited), ["simulate", "shear", "ramp"]);
    }

    #[test]
    fn fit_code_changes_fit_compare_report() {
        let base = keys(&tree("r1", "d1", "f1", "c1"));
        let edited = keys(&tree("r1", "d1", "f2", "c1"));
        assert_eq!(changed(&base, &edited), ["fit", "compare", "report"]);
    }

    #[test]
    fn command_line_and_lock_file() {
        let base = keys(&tree("r1", "d1", "f1", "c1"));
        assert!(changed(&base, &keys(&tree("r1", "d1", "f1", "c2"))).is_empty());
        let mut t = tree("r1", "d1", "f1", "c1");
        t[0].1 = "lock2".into();
        assert_eq!(changed(&base, &keys(&t)).len(), Kind::ALL.len());
    }

    #[test]
    fn a_new_module_counts_for_every_kind() {
        let base = keys(&tree("r1", "d1", "f1", "c1"));
        let mut t = tree("r1", "d1", "f1", "c1");
        t.push(("src/newthing/mod.rs", "n".into()));
        assert_eq!(changed(&base, &keys(&t)).len(), Kind::ALL.len());
    }

    #[test]
    fn this_build_embeds_its_sources() {
        assert!(SOURCES.iter().any(|(p, _)| *p == "src/pipeline/exec.rs"));
        assert!(SOURCES.iter().any(|(p, _)| *p == "Cargo.lock"));
        assert!(SOURCES.iter().all(|(_, h)| h.len() == 64));
        assert_ne!(source_hash(Kind::Simulate), source_hash(Kind::Report));
    }
}
