//! Build-time hashes of the source, for cache keys that survive a rebuild: every file
//! under `src/` and `data_schema/`, and `Cargo.lock` (the dependencies' exact
//! versions), each with its SHA-256, embedded as `SOURCES` (see
//! `src/pipeline/source_key.rs`, which decides which of them each stage kind's key
//! covers). A stage's key then changes when the code it runs changes, not when any
//! byte of the executable does (a typo fixed in the report code, another linker).

use sha2::{Digest, Sha256};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

fn walk(root: &Path, dir: &Path, out: &mut Vec<(String, PathBuf)>) {
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
            out.push((rel.join("/"), p));
        }
    }
}

fn main() {
    let root = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets it"));
    let mut files = Vec::new();
    for d in ["src", "data_schema"] {
        walk(&root, &root.join(d), &mut files);
        println!("cargo:rerun-if-changed={d}");
    }
    if root.join("Cargo.lock").is_file() {
        files.push(("Cargo.lock".into(), root.join("Cargo.lock")));
    }
    println!("cargo:rerun-if-changed=Cargo.lock");
    println!("cargo:rerun-if-changed=build.rs");
    files.sort();
    let mut text = String::from("/// (path, SHA-256) of every source file, sorted by path.\n");
    text.push_str("pub const SOURCES: &[(&str, &str)] = &[\n");
    for (rel, p) in &files {
        let bytes = std::fs::read(p).unwrap_or_default();
        let h = Sha256::digest(&bytes);
        let hex = h.iter().fold(String::new(), |mut s, b| {
            let _ = write!(s, "{b:02x}");
            s
        });
        let _ = writeln!(text, "    ({rel:?}, {hex:?}),");
    }
    text.push_str("];\n");
    let out = PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets it")).join("sources.rs");
    // Rewritten only when it changes, so an unchanged source does not rebuild the crate.
    if std::fs::read_to_string(&out).ok().as_deref() != Some(text.as_str()) {
        std::fs::write(&out, text).expect("OUT_DIR is writable");
    }
}
