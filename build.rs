//! Build-time hashes of the source, for cache keys that survive a rebuild. Embeds
//! `SOURCES`, the SHA-256 of every file under `src/` and `data_schema/`, of
//! `Cargo.lock` (the exact versions of this crate's dependencies, not another workspace
//! member's) and of every file the code
//! `include_bytes!`s, and `KIND_FILES`, for each stage kind the files its key covers:
//! the kind's file (`src/pipeline/kinds/<kind>.rs`) and those it reaches in the import
//! graph (`src/pipeline/import_graph.rs::kind_files`), and `Cargo.lock`. A stage's
//! key then changes when the code it runs changes, not when any byte of the
//! executable does (a typo fixed in the report code, another linker).

use sha2::{Digest, Sha256};
use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

#[path = "src/pipeline/import_graph.rs"]
#[allow(dead_code)]
mod import_graph;

fn walk(root: &Path, dir: &Path, out: &mut Vec<String>) {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return;
    };
    for e in rd.flatten() {
        let p = e.path();
        if p.is_dir() {
            walk(root, &p, out);
        } else if p.is_file() {
            let rel: Vec<String> = p
                .strip_prefix(root)
                .unwrap_or(&p)
                .components()
                .map(|c| c.as_os_str().to_string_lossy().into_owned())
                .collect();
            out.push(rel.join("/"));
        }
    }
}

fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .fold(String::new(), |mut s, b| {
            let _ = write!(s, "{b:02x}");
            s
        })
}

fn main() {
    let root = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets it"));
    let mut files = Vec::new();
    for d in ["src", "data_schema"] {
        walk(&root, &root.join(d), &mut files);
        println!("cargo:rerun-if-changed={d}");
    }
    println!("cargo:rerun-if-changed=Cargo.lock");
    println!("cargo:rerun-if-changed=build.rs");
    let code: Vec<(String, String)> = files
        .iter()
        .filter(|f| f.ends_with(".rs"))
        .map(|f| {
            let text = std::fs::read_to_string(root.join(f)).unwrap_or_default();
            (f.clone(), text)
        })
        .collect();
    let graph = import_graph::graph(&code);
    let mut hashed: BTreeSet<String> = files.into_iter().collect();
    hashed.insert("Cargo.lock".into());
    // What the code includes from elsewhere (a font): hashed, and watched.
    for deps in graph.values() {
        for d in deps.iter().filter(|d| !hashed.contains(*d)) {
            println!("cargo:rerun-if-changed={d}");
        }
        hashed.extend(deps.iter().cloned());
    }

    let mut text = String::from("/// (path, SHA-256) of every source file, sorted by path.\n");
    text.push_str("pub const SOURCES: &[(&str, &str)] = &[\n");
    for rel in &hashed {
        let mut bytes = std::fs::read(root.join(rel)).unwrap_or_default();
        if rel == "Cargo.lock" {
            // Only what this crate's build uses (not the Python package's pyo3).
            let lock = String::from_utf8_lossy(&bytes).into_owned();
            let name = std::env::var("CARGO_PKG_NAME").expect("cargo sets it");
            bytes = import_graph::lock_closure(&lock, &name).into_bytes();
        }
        let _ = writeln!(text, "    ({rel:?}, {:?}),", sha256_hex(&bytes));
    }
    text.push_str("];\n\n");
    text.push_str("/// Each stage kind and the files its key covers, sorted.\n");
    text.push_str("pub const KIND_FILES: &[(&str, &[&str])] = &[\n");
    for kind in import_graph::kind_names(code.iter().map(|(f, _)| f.as_str())) {
        let mut reach = import_graph::kind_files(&graph, &kind);
        reach.insert("Cargo.lock".into());
        let _ = writeln!(text, "    ({kind:?}, &[");
        for f in &reach {
            let _ = writeln!(text, "        {f:?},");
        }
        text.push_str("    ]),\n");
    }
    text.push_str("];\n");
    let out = PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets it")).join("sources.rs");
    // Rewritten only when it changes, so an unchanged source does not rebuild the crate.
    if std::fs::read_to_string(&out).ok().as_deref() != Some(text.as_str()) {
        std::fs::write(&out, text).expect("OUT_DIR is writable");
    }
}
