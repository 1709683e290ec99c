//! The dependency arrows of `docs/architecture.md`, read from the sources: each top-level
//! module's `crate::…` references (test code left out) must point down the layers —
//! geometry → neighbours → kinematics → fit/analysis → report, io and pipeline on top,
//! the simulators (`dem`) knowing nothing of analysis or files — and the module graph
//! must have no cycle. A forbidden arrow fails here with its file and line.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

/// What each module must not reference.
const FORBIDDEN: &[(&str, &[&str])] = &[
    (
        "geom",
        &[
            "neighbors",
            "tracks",
            "kinematics",
            "fit",
            "dem",
            "io",
            "report",
            "stages",
            "pipeline",
        ],
    ),
    (
        "neighbors",
        &[
            "tracks",
            "kinematics",
            "fit",
            "dem",
            "io",
            "report",
            "stages",
            "pipeline",
        ],
    ),
    (
        "kinematics",
        &["fit", "dem", "io", "report", "stages", "pipeline"],
    ),
    (
        "fit",
        &[
            "tracks",
            "kinematics",
            "dem",
            "io",
            "report",
            "stages",
            "pipeline",
        ],
    ),
    (
        "dem",
        &[
            "neighbors",
            "tracks",
            "kinematics",
            "fit",
            "io",
            "report",
            "stages",
            "pipeline",
            "synth",
        ],
    ),
    (
        "tracks",
        &[
            "kinematics",
            "fit",
            "dem",
            "io",
            "report",
            "stages",
            "pipeline",
        ],
    ),
    ("report", &["stages", "pipeline", "dem"]),
    (
        "structure",
        &[
            "tracks",
            "kinematics",
            "fit",
            "dem",
            "io",
            "stages",
            "pipeline",
        ],
    ),
    ("io", &["stages", "pipeline", "report", "dem"]),
    (
        "camera",
        &[
            "neighbors",
            "tracks",
            "kinematics",
            "fit",
            "dem",
            "io",
            "report",
            "stages",
            "pipeline",
            "structure",
        ],
    ),
    ("stages", &["pipeline"]),
];

/// Words that must not appear in a module's non-test code (the simulation kernels
/// compute; stages read and write files).
const FORBIDDEN_WORDS: &[(&str, &[&str])] = &[("dem", &["polars", "std::fs"])];

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The top-level module a source file belongs to (`src/dem/pillar.rs` → `dem`).
fn module_of(src: &Path, file: &Path) -> String {
    let rel = file.strip_prefix(src).unwrap();
    let first = rel
        .components()
        .next()
        .unwrap()
        .as_os_str()
        .to_string_lossy();
    first.trim_end_matches(".rs").to_string()
}

/// The file's lines up to its test module (`#[cfg(test)]`); none for `tests.rs` files.
fn non_test_lines(file: &Path) -> Vec<(usize, String)> {
    if file.file_name().is_some_and(|n| n == "tests.rs") {
        return Vec::new();
    }
    std::fs::read_to_string(file)
        .unwrap()
        .lines()
        .enumerate()
        .take_while(|(_, l)| !l.trim_start().starts_with("#[cfg(test)]"))
        .map(|(i, l)| (i + 1, l.to_string()))
        .collect()
}

/// Every `crate::name` on a line (comments included: a doc link is an arrow too).
fn crate_refs(line: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = line;
    while let Some(i) = rest.find("crate::") {
        let tail = &rest[i + "crate::".len()..];
        let name: String = tail
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect();
        if !name.is_empty() {
            out.push(name);
        }
        rest = tail;
    }
    out
}

/// (module → modules it references, with a place for each).
fn graph() -> BTreeMap<String, BTreeMap<String, String>> {
    let src = Path::new(ROOT).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    files.sort();
    let mut g: BTreeMap<String, BTreeMap<String, String>> = BTreeMap::new();
    for f in &files {
        let m = module_of(&src, f);
        let entry = g.entry(m.clone()).or_default();
        for (n, line) in non_test_lines(f) {
            for r in crate_refs(&line) {
                if r != m {
                    entry
                        .entry(r)
                        .or_insert_with(|| format!("{}:{n}", f.display()));
                }
            }
        }
    }
    g
}

#[test]
fn no_module_references_a_layer_above_it() {
    let g = graph();
    assert!(
        g.contains_key("dem") && g.contains_key("fit"),
        "{:?}",
        g.keys()
    );
    let mut bad = Vec::new();
    for (m, forbidden) in FORBIDDEN {
        for (to, at) in g.get(*m).into_iter().flatten() {
            if forbidden.contains(&to.as_str()) {
                bad.push(format!("{m} → {to} at {at}"));
            }
        }
    }
    let src = Path::new(ROOT).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    for (m, words) in FORBIDDEN_WORDS {
        for f in files.iter().filter(|f| module_of(&src, f) == *m) {
            for (n, line) in non_test_lines(f) {
                for w in *words {
                    if line.contains(w) {
                        bad.push(format!("{m} uses {w} at {}:{n}", f.display()));
                    }
                }
            }
        }
    }
    assert!(bad.is_empty(), "forbidden arrows:\n{}", bad.join("\n"));
}

/// A cycle of the graph, as its places (`a → b at file:line`), if there is one:
/// depth-first search; a node met again while on the stack closes a cycle.
fn find_cycle(g: &BTreeMap<String, BTreeMap<String, String>>) -> Option<Vec<String>> {
    fn visit(
        n: &str,
        g: &BTreeMap<String, BTreeMap<String, String>>,
        stack: &mut Vec<String>,
        done: &mut BTreeSet<String>,
    ) -> Option<Vec<String>> {
        if let Some(i) = stack.iter().position(|s| s == n) {
            let mut c = stack[i..].to_vec();
            c.push(n.to_string());
            return Some(c);
        }
        if done.contains(n) {
            return None;
        }
        stack.push(n.to_string());
        for to in g.get(n).into_iter().flat_map(|e| e.keys()) {
            if let Some(c) = visit(to, g, stack, done) {
                return Some(c);
            }
        }
        stack.pop();
        done.insert(n.to_string());
        None
    }
    let mut done = BTreeSet::new();
    g.keys().find_map(|n| {
        visit(n, g, &mut Vec::new(), &mut done).map(|c| {
            c.windows(2)
                .map(|w| format!("{} → {} at {}", w[0], w[1], g[&w[0]][&w[1]]))
                .collect()
        })
    })
}

#[test]
fn the_module_graph_has_no_cycle() {
    if let Some(places) = find_cycle(&graph()) {
        panic!("module cycle:\n{}", places.join("\n"));
    }
}

/// The simulation core's files as modules (`src/dem/pillar/phases.rs` → `dem/pillar/phases`,
/// a `mod.rs` → its folder).
fn dem_modules() -> BTreeMap<String, PathBuf> {
    let src = Path::new(ROOT).join("src");
    let mut files = Vec::new();
    rust_files(&src.join("dem"), &mut files);
    files
        .into_iter()
        .map(|f| {
            let rel = f.strip_prefix(&src).unwrap().with_extension("");
            let mut parts: Vec<String> = rel
                .components()
                .map(|c| c.as_os_str().to_string_lossy().into_owned())
                .collect();
            if parts.last().is_some_and(|p| p == "mod") {
                parts.pop();
            }
            (parts.join("/"), f)
        })
        .collect()
}

/// Every `crate::dem::…` or `super::…` path on a line, as module segments from the crate
/// root (`super` resolved against `me`).
fn dem_paths(me: &[&str], line: &str) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    let ident = |c: char| c.is_ascii_alphanumeric() || c == '_';
    let bytes: Vec<char> = line.chars().collect();
    let mut i = 0;
    while i < bytes.len() {
        let rest: String = bytes[i..].iter().collect();
        let starts = rest.starts_with("crate::dem::") || rest.starts_with("super::");
        let boundary = i == 0 || !ident(bytes[i - 1]);
        if !(starts && boundary) {
            i += 1;
            continue;
        }
        let path: String = rest.chars().take_while(|&c| ident(c) || c == ':').collect();
        let segs: Vec<&str> = path.split("::").filter(|s| !s.is_empty()).collect();
        let mut base: Vec<String> = Vec::new();
        let mut k = 0;
        if segs[0] == "crate" {
            k = 1;
        } else {
            base = me.iter().map(|s| s.to_string()).collect();
            while k < segs.len() && segs[k] == "super" {
                base.pop();
                k += 1;
            }
        }
        base.extend(segs[k..].iter().map(|s| s.to_string()));
        out.push(base);
        i += path.chars().count().max(1);
    }
    out
}

/// File → files of the simulation core it references (a parent's references to its own
/// children are how Rust declares them, not arrows).
fn dem_graph() -> BTreeMap<String, BTreeMap<String, String>> {
    let mods = dem_modules();
    let mut g: BTreeMap<String, BTreeMap<String, String>> = BTreeMap::new();
    for (m, f) in &mods {
        let me: Vec<&str> = m.split('/').collect();
        // `super` in a file module `a/b/c.rs` is `a/b`; in `a/b/mod.rs`, `a`.
        let is_mod = f.file_name().is_some_and(|n| n == "mod.rs");
        let mut scope = me.clone();
        if !is_mod {
            scope.push("self");
        }
        let entry = g.entry(m.clone()).or_default();
        for (n, line) in non_test_lines(f) {
            for p in dem_paths(&scope, &line) {
                let target = (1..=p.len())
                    .rev()
                    .map(|k| p[..k].join("/"))
                    .find(|t| mods.contains_key(t));
                if let Some(t) = target
                    && t != *m
                    && !t.starts_with(&format!("{m}/"))
                {
                    entry
                        .entry(t)
                        .or_insert_with(|| format!("{}:{n}", f.display()));
                }
            }
        }
    }
    g
}

/// Inside the simulation core: the contact laws depend on nothing else of it, the shared
/// base on no scenario, neither scenario on the other; and no two files import each
/// other in a circle. Checked by planting `use crate::dem::pillar::PillarSim;` in
/// `src/dem/law/substrate.rs` (fails the layering) and `use crate::dem::backend::
/// pillar_avx2::PackedGrains;` in `src/dem/pillar/kernels.rs` (fails with the cycle
/// kernels → pillar_avx2 → kernels).
#[test]
fn the_simulation_core_is_layered_and_acyclic() {
    let g = dem_graph();
    assert!(
        g.contains_key("dem/law") && g.contains_key("dem/pillar/phases"),
        "{:?}",
        g.keys()
    );
    let rules: &[(&str, &[&str])] = &[
        (
            "dem/law",
            &["dem/base", "dem/pillar", "dem/shear", "dem/backend"],
        ),
        ("dem/base", &["dem/pillar", "dem/shear"]),
        ("dem/pillar", &["dem/shear"]),
        ("dem/shear", &["dem/pillar"]),
    ];
    let within = |m: &str, folder: &str| m == folder || m.starts_with(&format!("{folder}/"));
    let mut bad = Vec::new();
    for (m, edges) in &g {
        for (from, forbidden) in rules {
            if !within(m, from) {
                continue;
            }
            for (to, at) in edges {
                if forbidden.iter().any(|f| within(to, f)) {
                    bad.push(format!("{m} → {to} at {at}"));
                }
            }
        }
    }
    assert!(bad.is_empty(), "forbidden arrows:\n{}", bad.join("\n"));
    if let Some(places) = find_cycle(&g) {
        panic!(
            "import cycle in the simulation core:\n{}",
            places.join("\n")
        );
    }
}

/// Every `unsafe fn` says what its caller must guarantee (a `# Safety` section in its
/// doc comment) and every `unsafe impl` why it holds (a `SAFETY` comment above it).
/// Checked by deleting one `# Safety` line in `src/dem/backend/pillar_threads/arrays.rs`.
#[test]
fn every_unsafe_fn_and_impl_states_its_contract() {
    let src = Path::new(ROOT).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut bad = Vec::new();
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        for (i, l) in lines.iter().enumerate() {
            let code = l.trim_start();
            if code.starts_with("//") || code.contains('$') {
                continue; // comments, and the macros that generate kernels
            }
            let above = || {
                lines[..i]
                    .iter()
                    .rev()
                    .take_while(|p| {
                        let p = p.trim_start();
                        p.starts_with("//") || p.starts_with("#[")
                    })
                    .map(|p| p.to_string())
                    .collect::<Vec<String>>()
            };
            if code.contains("unsafe fn ") && !above().iter().any(|p| p.contains("# Safety")) {
                bad.push(format!(
                    "{}:{}: unsafe fn without # Safety",
                    f.display(),
                    i + 1
                ));
            }
            if code.starts_with("unsafe impl") {
                // A group of impls shares the comment above the first.
                let mut k = i;
                while k > 0 && lines[k - 1].trim_start().starts_with("unsafe impl") {
                    k -= 1;
                }
                let has = lines[..k]
                    .iter()
                    .rev()
                    .take_while(|p| p.trim_start().starts_with("//"))
                    .any(|p| p.contains("SAFETY"));
                if !has {
                    bad.push(format!(
                        "{}:{}: unsafe impl without SAFETY",
                        f.display(),
                        i + 1
                    ));
                }
            }
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// The report draws what other stages computed: from `src/stages/report/` it names the
/// pipeline never, and other stages and the simulators only by their constants (file
/// names, bins), types and readers (`read_…`); a call into another stage's computation
/// (as the size scan once was) fails here with its file and line. Exceptions are
/// listed with why.
#[test]
fn the_report_renders_and_never_computes_another_stage() {
    const EXCEPTIONS: &[(&str, &str)] = &[
        (
            "fit::num",
            "formats a fit's number as the fit's own report does",
        ),
        ("fit::with_interval", "formats a value with its interval"),
        (
            "compare::incompatibility",
            "why two fits cannot be compared, from their recorded settings",
        ),
    ];
    let dir = Path::new(ROOT).join("src/stages/report");
    let mut files = Vec::new();
    rust_files(&dir, &mut files);
    files.sort();
    let mut problems = Vec::new();
    let mut seen = 0;
    for f in &files {
        for (n, line) in non_test_lines(f) {
            for prefix in ["crate::pipeline", "crate::stages::", "crate::dem::"] {
                let mut rest = line.as_str();
                while let Some(i) = rest.find(prefix) {
                    rest = &rest[i + prefix.len()..];
                    if prefix == "crate::pipeline" {
                        problems.push(format!("{}:{n}: names the pipeline", f.display()));
                        continue;
                    }
                    let module: String = rest
                        .chars()
                        .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                        .collect();
                    if prefix == "crate::stages::" && (module == "report" || module == "datasets") {
                        continue;
                    }
                    // Past `module::`: nested modules, then one item or a `{…}` list.
                    let mut tail = &rest[module.len()..];
                    let mut path = vec![module.clone()];
                    while let Some(t) = tail.strip_prefix("::") {
                        let seg: String = t
                            .chars()
                            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                            .collect();
                        if seg.is_empty() {
                            tail = t;
                            break;
                        }
                        path.push(seg.clone());
                        tail = &t[seg.len()..];
                        if seg.starts_with(|c: char| c.is_ascii_lowercase())
                            && !tail.starts_with("::")
                        {
                            break;
                        }
                    }
                    let items: Vec<String> = if let Some(list) = tail.strip_prefix('{') {
                        list.split('}')
                            .next()
                            .unwrap_or("")
                            .split(',')
                            .map(|s| s.trim().to_string())
                            .filter(|s| !s.is_empty())
                            .collect()
                    } else {
                        path.pop().into_iter().collect()
                    };
                    for item in items {
                        seen += 1;
                        let constant = item
                            .chars()
                            .all(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || c == '_');
                        let ty = item.starts_with(|c: char| c.is_ascii_uppercase());
                        let reader = item.starts_with("read");
                        let key = format!("{module}::{item}");
                        if !(constant || ty || reader || EXCEPTIONS.iter().any(|(k, _)| *k == key))
                        {
                            problems.push(format!(
                                "{}:{n}: {prefix}{key} is another stage's computation",
                                f.display()
                            ));
                        }
                    }
                }
            }
        }
    }
    assert!(
        seen > 10,
        "the scan found only {seen} references: is it reading the report?"
    );
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// No file imports one that imports it back, inside any folder of `src/` that wires or
/// computes (issue 33), as `../shared/tools/import_cycles.py` reads them. A cycle the
/// registry's kinds once made (each kind naming `graph::Stage` and `parse::Source`,
/// which reach the kinds again) fails here.
#[test]
fn no_import_cycle_inside_the_wiring_or_the_core() {
    let tool = Path::new(ROOT).join("../shared/tools/import_cycles.py");
    if !tool.is_file() {
        crate::common::cannot_check("../shared/tools/import_cycles.py is not here");
        return;
    }
    for folder in [
        "pipeline",
        "io",
        "stages",
        "dem",
        "cli",
        "camera",
        "fit",
        "structure",
    ] {
        let o = std::process::Command::new("python3")
            .arg(&tool)
            .arg("src")
            .arg(folder)
            .current_dir(ROOT)
            .output()
            .expect("python3 runs");
        let text =
            String::from_utf8_lossy(&o.stdout).into_owned() + &String::from_utf8_lossy(&o.stderr);
        assert!(
            o.status.success() && text.contains("ok: 0 import cycles"),
            "src/{folder}:\n{text}"
        );
    }
}
