//! The part of a stage's cache key that stands for the code: a hash of the source files
//! that can change the stage's result, made at build time (`build.rs`), and of
//! `Cargo.lock`. Two builds of the same source agree (a head process and its cluster
//! jobs built separately, a rebuilt binary), and fixing report code keeps hour-long
//! simulations cached.
//!
//! Which files count for a kind is read from the code, not kept by hand: the kind's
//! file (`kinds/<kind>.rs`) and those it reaches in the import graph
//! (`import_graph::kind_files`), so a module a stage starts to use counts as soon as it
//! is named, and code no stage names (the command line, benchmarks, the run
//! bookkeeping, the dispatch, unit tests) counts for none (issue 33).

use super::Kind;
use crate::io::hash::sha256_bytes;

mod generated {
    include!(concat!(env!("OUT_DIR"), "/sources.rs"));
}
pub use generated::{KIND_FILES, SOURCES};

/// The files (sorted) whose contents make up `kind`'s source hash.
pub fn files(kind: Kind) -> &'static [&'static str] {
    KIND_FILES
        .iter()
        .find(|(k, _)| *k == kind.name())
        .map_or(&[], |(_, f)| f)
}

/// SHA-256 over the (path, hash) pairs of `sources` whose path is in `files` (sorted).
pub fn source_hash_for(files: &[&str], sources: &[(&str, &str)]) -> String {
    let mut text = String::new();
    for (path, hash) in sources
        .iter()
        .filter(|(p, _)| files.binary_search(p).is_ok())
    {
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
            .map(|k| source_hash_for(files(*k), SOURCES))
            .collect()
    });
    let i = Kind::ALL.iter().position(|k| *k == kind).unwrap_or(0);
    &all[i]
}

#[cfg(test)]
mod tests {
    use super::super::import_graph;
    use super::*;
    use std::path::Path;

    fn root() -> &'static Path {
        Path::new(env!("CARGO_MANIFEST_DIR"))
    }

    fn has(kind: Kind, path: &str) -> bool {
        files(kind).contains(&path)
    }

    fn kind_file(kind: Kind) -> String {
        format!("{}{}.rs", import_graph::KINDS_DIR, kind.name())
    }

    /// The registry and the kinds' files name the same kinds (a file left out of
    /// `registry!` would be keyed but never run), and each key covers its own file.
    #[test]
    fn every_registered_kind_has_its_file_and_files() {
        let mut registered: Vec<&str> = Kind::ALL.iter().map(|k| k.name()).collect();
        registered.sort();
        let embedded: Vec<&str> = KIND_FILES.iter().map(|(k, _)| *k).collect();
        assert_eq!(registered, embedded);
        for &kind in Kind::ALL {
            let f = files(kind);
            assert!(f.windows(2).all(|w| w[0] < w[1]), "{}", kind.name());
            assert!(f.contains(&"Cargo.lock"), "{}", kind.name());
            assert!(f.contains(&kind_file(kind).as_str()), "{}", kind.name());
            println!("{}: {} files", kind.name(), f.len());
        }
    }

    /// The report's size scan calls `stages::sizes::scan` → `stages::shear::block_stats`:
    /// a change in how block errors are computed must change the report's key.
    #[test]
    fn the_report_covers_the_size_scan_and_block_errors() {
        assert!(has(Kind::Report, "src/stages/sizes.rs"));
        assert!(has(Kind::Report, "src/stages/shear/stats.rs"));
        let stats = std::fs::read_to_string(root().join("src/stages/shear/stats.rs")).unwrap();
        assert!(stats.contains("fn block_stats"), "block_stats moved");
    }

    #[test]
    fn kinds_leave_out_what_they_do_not_run() {
        for f in files(Kind::Kinematics) {
            assert!(!f.starts_with("src/dem/"), "kinematics covers {f}");
            assert!(
                !f.starts_with("src/stages/report/"),
                "kinematics covers {f}"
            );
        }
        for f in files(Kind::Simulate) {
            assert!(!f.starts_with("src/stages/report/"), "simulate covers {f}");
        }
        for &kind in Kind::ALL {
            for f in files(kind) {
                let cli = f.starts_with("src/cli/") || f.starts_with("src/bench/");
                let bookkeeping = f.starts_with("src/pipeline/")
                    && (!f.starts_with(import_graph::KINDS_DIR) || f.ends_with("/mod.rs"));
                assert!(
                    *f != "src/main.rs" && !cli && !bookkeeping && !f.ends_with("/tests.rs"),
                    "{} covers {f}",
                    kind.name()
                );
            }
        }
    }

    /// The file a `crate::a::b::c` path names by the longest module prefix, looked up on
    /// disk (independently of the scanner).
    fn module_file(segments: &[&str]) -> Option<String> {
        (1..=segments.len()).rev().find_map(|k| {
            let m = segments[..k].join("/");
            [format!("src/{m}.rs"), format!("src/{m}/mod.rs")]
                .into_iter()
                .find(|f| root().join(f).is_file())
        })
    }

    /// Each kind covers every module its file's `use crate::…` lines name outside the
    /// pipeline's dispatch, and not some module that has nothing to do with it.
    #[test]
    fn entries_imports_counted_and_unrelated_left_out() {
        let unrelated = [
            (Kind::Ingest, "src/stages/report/mod.rs"),
            (Kind::Simulate, "src/dem/shear/mod.rs"),
            (Kind::Kinematics, "src/dem/pillar/mod.rs"),
            (Kind::Fit, "src/dem/shear/mod.rs"),
            (Kind::Compare, "src/stages/simulate/mod.rs"),
            (Kind::Report, "src/io/lammps.rs"),
            (Kind::Shear, "src/stages/report/mod.rs"),
            (Kind::Sweep, "src/stages/report/mod.rs"),
            (Kind::Ramp, "src/fit/mod.rs"),
            (Kind::Render, "src/fit/mod.rs"),
            (Kind::Track, "src/dem/pillar/mod.rs"),
        ];
        for &kind in Kind::ALL {
            let text = std::fs::read_to_string(root().join(kind_file(kind))).unwrap();
            for line in text.lines().map(str::trim) {
                let Some(path) = line.strip_prefix("use crate::") else {
                    continue;
                };
                if path.starts_with("pipeline::") {
                    continue;
                }
                let path = path.split(['{', ';', ' ']).next().unwrap();
                let segments: Vec<&str> = path.split("::").filter(|s| !s.is_empty()).collect();
                let f = module_file(&segments).unwrap_or_else(|| panic!("{line}"));
                assert!(has(kind, &f), "{} leaves out {f} ({line})", kind.name());
            }
        }
        // A ramp runs as a shear stage does: the shear kind's wiring counts for it.
        assert!(has(Kind::Ramp, "src/pipeline/kinds/shear.rs"));
        assert!(!has(Kind::Ramp, "src/pipeline/exec.rs"));
        for (kind, f) in unrelated {
            assert!(root().join(f).is_file(), "{f} moved");
            assert!(!has(kind, f), "{} covers {f}", kind.name());
        }
    }

    /// What the build embedded is what the scanner makes of the tree as it is now.
    #[test]
    fn the_embedded_sets_match_the_tree() {
        fn walk(dir: &Path, out: &mut Vec<(String, String)>) {
            for e in std::fs::read_dir(dir).unwrap().flatten() {
                let p = e.path();
                if p.is_dir() {
                    walk(&p, out);
                } else if p.extension().is_some_and(|x| x == "rs") {
                    let rel = p.strip_prefix(root()).unwrap();
                    let rel: Vec<String> = rel
                        .components()
                        .map(|c| c.as_os_str().to_string_lossy().into_owned())
                        .collect();
                    out.push((rel.join("/"), std::fs::read_to_string(&p).unwrap()));
                }
            }
        }
        let mut code = Vec::new();
        walk(&root().join("src"), &mut code);
        let g = import_graph::graph(&code);
        let names = import_graph::kind_names(code.iter().map(|(f, _)| f.as_str()));
        assert_eq!(names.len(), Kind::ALL.len());
        for kind in names {
            let mut want = import_graph::kind_files(&g, &kind);
            want.insert("Cargo.lock".into());
            let got = files(Kind::from_name(&kind).unwrap());
            assert_eq!(got, want.iter().map(String::as_str).collect::<Vec<_>>());
        }
    }

    #[test]
    fn a_kinds_hash_follows_its_files_only() {
        let sources = |report: &'static str, lock: &'static str| {
            vec![
                ("Cargo.lock", lock),
                ("src/cli_runs.rs", "c"),
                ("src/stages/report/mod.rs", report),
                ("src/stages/sizes.rs", "s"),
            ]
        };
        let report = [
            "Cargo.lock",
            "src/stages/report/mod.rs",
            "src/stages/sizes.rs",
        ];
        let kin = ["Cargo.lock", "src/stages/kinematics.rs"];
        let base = sources("r1", "l1");
        let edited = sources("r2", "l1");
        assert_ne!(
            source_hash_for(&report, &base),
            source_hash_for(&report, &edited)
        );
        assert_eq!(source_hash_for(&kin, &base), source_hash_for(&kin, &edited));
        let relocked = sources("r1", "l2");
        assert_ne!(
            source_hash_for(&kin, &base),
            source_hash_for(&kin, &relocked)
        );
    }

    #[test]
    fn this_build_embeds_its_sources() {
        assert!(SOURCES.iter().any(|(p, _)| *p == "Cargo.lock"));
        assert!(SOURCES.iter().all(|(_, h)| h.len() == 64));
        // Every covered file has a hash.
        for &kind in Kind::ALL {
            for f in files(kind) {
                assert!(SOURCES.iter().any(|(p, _)| p == f), "{f} has no hash");
            }
        }
        assert_ne!(source_hash(Kind::Simulate), source_hash(Kind::Report));
    }
}
