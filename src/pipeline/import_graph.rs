//! The crate's file-level import graph, for cache keys (`build.rs` includes this file;
//! the library compiles it only for its tests). A file depends on the files its code
//! names: `use` trees, inline paths (`crate::a::f`, `super::x`, `child::y`, or through
//! a name a `use` bound), the files defining the types and traits it implements for
//! (reversed: whoever reaches a type reaches its impls in other files), and the files
//! it `include_str!`s. A `mod x;` declaration is not an edge: a `mod.rs` declares every
//! child, so counting it would make everything reachable. Comments, strings and
//! `#[cfg(test)]` items are skipped; unit tests change no result.
//!
//! Only the standard library may be used here: build scripts cannot see the crate.

use std::collections::{BTreeMap, BTreeSet};

#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Ident(String),
    /// A string literal's text, escapes left as written.
    Str(String),
    PathSep,
    Punct(char),
}

/// Tokens of `src` with comments, lifetimes and char/number literals dropped.
fn tokens(src: &str) -> Vec<Tok> {
    let c: Vec<char> = src.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    let is_id = |ch: char| ch.is_alphanumeric() || ch == '_';
    while i < c.len() {
        let ch = c[i];
        let next = c.get(i + 1).copied();
        if ch.is_whitespace() {
            i += 1;
        } else if ch == '/' && next == Some('/') {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
        } else if ch == '/' && next == Some('*') {
            let mut depth = 0;
            while i < c.len() {
                if c[i] == '/' && c.get(i + 1) == Some(&'*') {
                    depth += 1;
                    i += 2;
                } else if c[i] == '*' && c.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    i += 1;
                }
            }
        } else if ch == '"' {
            let (s, end) = cooked_string(&c, i + 1);
            out.push(Tok::Str(s));
            i = end;
        } else if ch == '\'' {
            i = quote(&c, i);
        } else if ch.is_ascii_digit() {
            while i < c.len() && is_id(c[i]) {
                i += 1;
            }
        } else if is_id(ch) {
            let start = i;
            while i < c.len() && is_id(c[i]) {
                i += 1;
            }
            let word: String = c[start..i].iter().collect();
            let here = c.get(i).copied();
            let raw_prefix = matches!(word.as_str(), "r" | "br" | "cr");
            if raw_prefix && matches!(here, Some('"' | '#')) && raw_string_start(&c, i) {
                let (s, end) = raw_string(&c, i);
                out.push(Tok::Str(s));
                i = end;
            } else if matches!(word.as_str(), "b" | "c") && here == Some('"') {
                let (s, end) = cooked_string(&c, i + 1);
                out.push(Tok::Str(s));
                i = end;
            } else if word == "b" && here == Some('\'') {
                i = quote(&c, i);
            } else if word == "r" && here == Some('#') {
                // A raw identifier, `r#type`.
                let start = i + 1;
                i = start;
                while i < c.len() && is_id(c[i]) {
                    i += 1;
                }
                out.push(Tok::Ident(c[start..i].iter().collect()));
            } else {
                out.push(Tok::Ident(word));
            }
        } else if ch == ':' && next == Some(':') {
            out.push(Tok::PathSep);
            i += 2;
        } else {
            out.push(Tok::Punct(ch));
            i += 1;
        }
    }
    out
}

/// A `"…"` string's text from just after its opening quote; returns it and the index
/// past the closing quote.
fn cooked_string(c: &[char], mut i: usize) -> (String, usize) {
    let start = i;
    while i < c.len() && c[i] != '"' {
        i += if c[i] == '\\' { 2 } else { 1 };
    }
    let end = i.min(c.len());
    (c[start..end].iter().collect(), end + 1)
}

fn raw_string_start(c: &[char], mut i: usize) -> bool {
    while c.get(i) == Some(&'#') {
        i += 1;
    }
    c.get(i) == Some(&'"')
}

/// `r#"…"#` from its first `#` or quote.
fn raw_string(c: &[char], mut i: usize) -> (String, usize) {
    let mut hashes = 0;
    while c[i] == '#' {
        hashes += 1;
        i += 1;
    }
    i += 1;
    let start = i;
    while i < c.len() {
        if c[i] == '"' && (1..=hashes).all(|k| c.get(i + k) == Some(&'#')) {
            return (c[start..i].iter().collect(), i + 1 + hashes);
        }
        i += 1;
    }
    (c[start..].iter().collect(), c.len())
}

/// Past a char literal (`'a'`, `'\n'`, `b'"'`) or a lifetime (`'a`) starting at the
/// quote `c[i]`.
fn quote(c: &[char], i: usize) -> usize {
    if c.get(i + 1) == Some(&'\\') {
        let mut j = i + 3;
        while j < c.len() && c[j] != '\'' {
            j += 1;
        }
        return j + 1;
    }
    if c.get(i + 2) == Some(&'\'') {
        return i + 3;
    }
    // A lifetime or label: its name is read as an identifier next, which is harmless.
    i + 1
}

/// `tokens` without the items under `#[cfg(test)]`.
fn without_tests(t: Vec<Tok>) -> Vec<Tok> {
    let cfg_test = [
        Tok::Punct('#'),
        Tok::Punct('['),
        Tok::Ident("cfg".into()),
        Tok::Punct('('),
        Tok::Ident("test".into()),
        Tok::Punct(')'),
        Tok::Punct(']'),
    ];
    let mut out = Vec::with_capacity(t.len());
    let mut i = 0;
    while i < t.len() {
        if t[i..].starts_with(&cfg_test) {
            i = past_item(&t, i + cfg_test.len());
        } else {
            out.push(t[i].clone());
            i += 1;
        }
    }
    out
}

/// The index past the item starting at `i` (after its attributes): its `;` at depth
/// zero, or the brace closing its first block.
fn past_item(t: &[Tok], mut i: usize) -> usize {
    let mut depth = 0usize;
    while i < t.len() {
        match t[i] {
            Tok::Punct('(' | '[') => depth += 1,
            Tok::Punct(')' | ']') => depth = depth.saturating_sub(1),
            Tok::Punct(';') if depth == 0 => return i + 1,
            Tok::Punct('{') if depth == 0 => return past_block(t, i),
            _ => {}
        }
        i += 1;
    }
    i
}

/// The index past the brace matching the `{` at `i`.
fn past_block(t: &[Tok], mut i: usize) -> usize {
    let mut depth = 0usize;
    while i < t.len() {
        match t[i] {
            Tok::Punct('{') => depth += 1,
            Tok::Punct('}') => {
                depth -= 1;
                if depth == 0 {
                    return i + 1;
                }
            }
            _ => {}
        }
        i += 1;
    }
    i
}

/// What one file names, before resolution. Paths are raw segments as written
/// (`crate`, `super`, `self` included), each with the module it is written in (the
/// file's, or an inline `mod x { … }` inside it).
#[derive(Debug, Default)]
struct Refs {
    /// `use` bindings: the name, the path it stands for, the module it is written in.
    bindings: Vec<(String, Vec<String>, Vec<String>)>,
    /// Modules glob-imported (`use a::*`), with where.
    globs: Vec<(Vec<String>, Vec<String>)>,
    /// Every path named (use trees included), with where.
    paths: Vec<(Vec<String>, Vec<String>)>,
    /// Type and trait paths in `impl` headers, with where.
    impls: Vec<(Vec<String>, Vec<String>)>,
    /// `include_str!`/`include_bytes!`/`include!` arguments.
    includes: Vec<String>,
    /// Macros invoked by bare name (`name!`).
    macro_calls: BTreeSet<String>,
    /// `#[macro_export]` macros defined here (they live at the crate root).
    exported_macros: Vec<String>,
}

fn ident(t: Option<&Tok>) -> Option<&str> {
    match t {
        Some(Tok::Ident(s)) => Some(s),
        _ => None,
    }
}

fn scan(src: &str, module: &[String]) -> Refs {
    let t = without_tests(tokens(src));
    let mut r = Refs::default();
    // The inline modules we are in: (name, brace depth inside it).
    let mut inline: Vec<(String, usize)> = Vec::new();
    let mut depth = 0usize;
    let here = |inline: &[(String, usize)]| -> Vec<String> {
        let mut m = module.to_vec();
        m.extend(inline.iter().map(|(n, _)| n.clone()));
        m
    };
    let mut i = 0;
    while i < t.len() {
        let at_path_start = !matches!(i.checked_sub(1).map(|k| &t[k]), Some(Tok::PathSep));
        match &t[i] {
            Tok::Punct('{') => {
                depth += 1;
                i += 1;
            }
            Tok::Punct('}') => {
                if inline.last().is_some_and(|(_, d)| *d == depth) {
                    inline.pop();
                }
                depth = depth.saturating_sub(1);
                i += 1;
            }
            Tok::Ident(w) if w == "mod" && t.get(i + 2) == Some(&Tok::Punct('{')) => {
                if let Some(name) = ident(t.get(i + 1)) {
                    inline.push((name.to_string(), depth + 1));
                }
                i += 2;
            }
            Tok::Ident(w) if w == "use" => {
                let at = here(&inline);
                let mut j = i + 1;
                use_tree(&t, &mut j, &[], &at, &mut r);
                i = j;
            }
            Tok::Ident(w) if w == "impl" && item_start(&t, i) => {
                let at = here(&inline);
                let mut j = i + 1;
                while j < t.len() && !matches!(t[j], Tok::Punct('{' | ';')) {
                    if ident(t.get(j)).is_some_and(|w| w == "where") {
                        break;
                    }
                    if ident(t.get(j)).is_some()
                        && !matches!(t.get(j.wrapping_sub(1)), Some(Tok::PathSep))
                    {
                        let (p, end) = path_at(&t, j);
                        r.impls.push((p, at.clone()));
                        j = end;
                    } else {
                        j += 1;
                    }
                }
                i += 1;
            }
            Tok::Ident(w) if w == "macro_export" => {
                let mut j = i + 1;
                while j < t.len() && ident(t.get(j)) != Some("macro_rules") {
                    j += 1;
                }
                if let Some(name) = ident(t.get(j + 2)) {
                    r.exported_macros.push(name.to_string());
                }
                i += 1;
            }
            Tok::Ident(w) if at_path_start && t.get(i + 1) == Some(&Tok::Punct('!')) => {
                r.macro_calls.insert(w.clone());
                let args = (t.get(i + 2), t.get(i + 3));
                if matches!(w.as_str(), "include_str" | "include_bytes" | "include")
                    && let (Some(Tok::Punct('(')), Some(Tok::Str(s))) = args
                {
                    r.includes.push(s.clone());
                }
                i += 2;
            }
            // `#[serde(deserialize_with = "json_nonfinite::nan")]` names code.
            Tok::Str(s) if i > 0 && t[i - 1] == Tok::Punct('=') && is_path(s) => {
                let p = s.split("::").map(str::to_string).collect();
                r.paths.push((p, here(&inline)));
                i += 1;
            }
            Tok::Ident(_) if at_path_start && t.get(i + 1) == Some(&Tok::PathSep) => {
                let (p, end) = path_at(&t, i);
                r.paths.push((p, here(&inline)));
                i = end;
            }
            _ => i += 1,
        }
    }
    r
}

/// Whether `impl` at `t[i]` begins an item (not `-> impl Trait`, `x: impl Fn()`).
fn item_start(t: &[Tok], i: usize) -> bool {
    match i.checked_sub(1).map(|k| &t[k]) {
        None => true,
        Some(Tok::Punct(c)) => matches!(c, '}' | ';' | ']' | '{'),
        Some(Tok::Ident(w)) => w == "unsafe",
        _ => false,
    }
}

fn is_path(s: &str) -> bool {
    s.contains("::")
        && s.split("::")
            .all(|seg| !seg.is_empty() && seg.chars().all(|c| c.is_alphanumeric() || c == '_'))
}

/// The path `a::b::c` starting at identifier `t[i]`, and the index past it (generic
/// arguments end it: `Vec::<T>::new` is `Vec`).
fn path_at(t: &[Tok], mut i: usize) -> (Vec<String>, usize) {
    let mut p = Vec::new();
    while let Some(w) = ident(t.get(i)) {
        p.push(w.to_string());
        i += 1;
        if t.get(i) == Some(&Tok::PathSep) && ident(t.get(i + 1)).is_some() {
            i += 1;
        } else {
            break;
        }
    }
    (p, i)
}

/// One use tree from `t[*i]` (after `use` or a `{`/`,` inside one), under `prefix`;
/// leaves `*i` past it (at the `;`, `,` or `}` that ends it, or past the `;`).
fn use_tree(t: &[Tok], i: &mut usize, prefix: &[String], at: &[String], r: &mut Refs) {
    let mut path = prefix.to_vec();
    // A leading `::` (an extern crate path) is dropped: nothing in the crate.
    if t.get(*i) == Some(&Tok::PathSep) {
        *i += 1;
    }
    loop {
        match t.get(*i) {
            Some(Tok::Ident(w)) => {
                path.push(w.clone());
                *i += 1;
                if t.get(*i) == Some(&Tok::PathSep) {
                    *i += 1;
                    continue;
                }
                let mut name = w.clone();
                if ident(t.get(*i)) == Some("as") {
                    if let Some(n) = ident(t.get(*i + 1)) {
                        name = n.to_string();
                    }
                    *i += 2;
                }
                if path.last().is_some_and(|l| l == "self") {
                    path.pop();
                    if name == "self" {
                        name = path.last().cloned().unwrap_or_default();
                    }
                }
                r.paths.push((path.clone(), at.to_vec()));
                if name != "_" && !name.is_empty() {
                    r.bindings.push((name, path, at.to_vec()));
                }
                break;
            }
            Some(Tok::Punct('*')) => {
                *i += 1;
                r.paths.push((path.clone(), at.to_vec()));
                r.globs.push((path, at.to_vec()));
                break;
            }
            Some(Tok::Punct('{')) => {
                *i += 1;
                while *i < t.len() && t[*i] != Tok::Punct('}') {
                    use_tree(t, i, &path, at, r);
                    if t.get(*i) == Some(&Tok::Punct(',')) {
                        *i += 1;
                    }
                }
                *i += 1;
                break;
            }
            _ => break,
        }
    }
    if prefix.is_empty() && t.get(*i) == Some(&Tok::Punct(';')) {
        *i += 1;
    }
}

/// The module a file under `src/` defines (`src/a/b.rs` and `src/a/b/mod.rs` are
/// `a::b`, `src/lib.rs` the root), or `None` for files outside the library.
pub fn module_of(path: &str) -> Option<Vec<String>> {
    let rel = path.strip_prefix("src/")?.strip_suffix(".rs")?;
    if rel == "lib" {
        return Some(Vec::new());
    }
    if rel == "main" || rel.starts_with("bin/") {
        return None;
    }
    let mut m: Vec<String> = rel.split('/').map(str::to_string).collect();
    if m.last().is_some_and(|l| l == "mod") {
        m.pop();
    }
    Some(m)
}

/// `a/b/../c` as `a/c`.
fn normalise(path: &str) -> String {
    let mut out: Vec<&str> = Vec::new();
    for part in path.split('/') {
        match part {
            "" | "." => {}
            ".." => {
                out.pop();
            }
            p => out.push(p),
        }
    }
    out.join("/")
}

/// File → the files it depends on, over `files` (path relative to the crate root,
/// text). Files named `tests.rs`, and files outside the library's module tree, get no
/// node.
pub fn graph(files: &[(String, String)]) -> BTreeMap<String, BTreeSet<String>> {
    let mut modules: BTreeMap<Vec<String>, String> = BTreeMap::new();
    for (path, _) in files {
        if path.ends_with("/tests.rs") {
            continue;
        }
        if let Some(m) = module_of(path) {
            modules.insert(m, path.clone());
        }
    }
    let scanned: BTreeMap<&str, Refs> = files
        .iter()
        .filter_map(|(path, text)| {
            let m = module_of(path)?;
            modules
                .contains_key(&m)
                .then(|| (path.as_str(), scan(text, &m)))
        })
        .collect();
    let mut macros: BTreeMap<&str, &str> = BTreeMap::new();
    for (&path, refs) in &scanned {
        for m in &refs.exported_macros {
            macros.insert(m, path);
        }
    }
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (&path, refs) in &scanned {
        let res = Resolver {
            modules: &modules,
            macros: &macros,
            refs,
        };
        let deps = g.entry(path.to_string()).or_default();
        for m in &refs.macro_calls {
            if let Some(f) = macros.get(m.as_str()) {
                deps.insert(f.to_string());
            }
        }
        for (p, at) in &refs.paths {
            if let Some(f) = res.file(p, at, 0) {
                deps.insert(f);
            }
        }
        let dir = path.rsplit_once('/').map_or("", |(d, _)| d);
        for inc in &refs.includes {
            deps.insert(normalise(&format!("{dir}/{inc}")));
        }
        deps.remove(path);
        let mut reverse = Vec::new();
        for (p, at) in &refs.impls {
            if let Some(f) = res.file(p, at, 0).filter(|f| f != path) {
                reverse.push(f);
            }
        }
        for f in reverse {
            g.entry(f).or_default().insert(path.to_string());
        }
    }
    g
}

struct Resolver<'a> {
    modules: &'a BTreeMap<Vec<String>, String>,
    /// `#[macro_export]` macro → its file (`crate::m!` names the root, not the file).
    macros: &'a BTreeMap<&'a str, &'a str>,
    refs: &'a Refs,
}

impl Resolver<'_> {
    /// The crate-absolute path `p` (written in module `at`) stands for, if it is in the
    /// crate.
    fn absolute(&self, p: &[String], at: &[String], depth: usize) -> Option<Vec<String>> {
        let (first, rest) = p.split_first()?;
        if depth > 8 {
            return None;
        }
        let mut base: Vec<String> = match first.as_str() {
            "crate" => Vec::new(),
            "self" => at.to_vec(),
            "super" => {
                let mut m = at.to_vec();
                m.pop()?;
                let mut rest = rest;
                while rest.first().is_some_and(|s| s == "super") {
                    m.pop()?;
                    rest = &rest[1..];
                }
                m.extend(rest.iter().cloned());
                return Some(m);
            }
            name => {
                let child: Vec<String> = at.iter().cloned().chain([name.to_string()]).collect();
                let bound = self.refs.bindings.iter().find(|(n, _, _)| n == name);
                if let Some((_, target, where_)) = bound {
                    self.absolute(target, where_, depth + 1)?
                } else if self.modules.keys().any(|m| m.starts_with(&child)) {
                    child
                } else {
                    // Through a glob import, a name can be a child module of the
                    // globbed one.
                    self.refs.globs.iter().find_map(|(g, where_)| {
                        let mut m = self.absolute(g, where_, depth + 1)?;
                        m.push(name.to_string());
                        self.modules.keys().any(|k| k.starts_with(&m)).then_some(m)
                    })?
                }
            }
        };
        base.extend(rest.iter().cloned());
        Some(base)
    }

    /// The file defining the longest module prefix of what `p` stands for.
    fn file(&self, p: &[String], at: &[String], depth: usize) -> Option<String> {
        let abs = self.absolute(p, at, depth)?;
        if let [name] = abs.as_slice()
            && let Some(f) = self.macros.get(name.as_str())
        {
            return Some(f.to_string());
        }
        (0..=abs.len())
            .rev()
            .find_map(|k| self.modules.get(&abs[..k]))
            .cloned()
    }
}

/// The files reachable from `entries` in `g`, the entries included.
pub fn reachable(g: &BTreeMap<String, BTreeSet<String>>, entries: &[&str]) -> BTreeSet<String> {
    let mut seen: BTreeSet<String> = BTreeSet::new();
    let mut todo: Vec<String> = entries.iter().map(|e| e.to_string()).collect();
    while let Some(f) = todo.pop() {
        if !seen.insert(f.clone()) {
            continue;
        }
        if let Some(deps) = g.get(&f) {
            todo.extend(deps.iter().filter(|d| !seen.contains(*d)).cloned());
        }
    }
    seen
}

/// Where the stage kinds live, one file each (`<dir><name>.rs`; `mod.rs` is the registry).
pub const KINDS_DIR: &str = "src/pipeline/kinds/";

/// The stage kinds' names, from the files under `KINDS_DIR` among `files`, sorted.
pub fn kind_names<'a>(files: impl IntoIterator<Item = &'a str>) -> Vec<String> {
    let mut names: Vec<String> = files
        .into_iter()
        .filter_map(|f| f.strip_prefix(KINDS_DIR)?.strip_suffix(".rs"))
        .filter(|n| *n != "mod" && !n.contains('/'))
        .map(str::to_string)
        .collect();
    names.sort();
    names
}

/// The files a kind's cache key covers: its file and what that reaches, without going
/// through the pipeline's other files (the registry, the dispatch, the run bookkeeping
/// change no result) except other kinds' files (a ramp runs as a shear stage does).
pub fn kind_files(g: &BTreeMap<String, BTreeSet<String>>, kind: &str) -> BTreeSet<String> {
    let counts = |f: &str| {
        !f.starts_with("src/pipeline/") || (f.starts_with(KINDS_DIR) && !f.ends_with("/mod.rs"))
    };
    let entry = format!("{KINDS_DIR}{kind}.rs");
    let mut seen: BTreeSet<String> = BTreeSet::new();
    let mut todo = vec![entry];
    while let Some(f) = todo.pop() {
        if !seen.insert(f.clone()) {
            continue;
        }
        if let Some(deps) = g.get(&f) {
            todo.extend(
                deps.iter()
                    .filter(|d| counts(d) && !seen.contains(*d))
                    .cloned(),
            );
        }
    }
    seen
}

/// The part of `Cargo.lock` that `root`'s build uses: its `[[package]]` entries in the
/// dependency closure of `root`, in the file's order. A stage's key covers this rather
/// than the whole lock, so a dependency of another workspace member (the Python
/// package's pyo3) does not recompute every cached stage. Entries are matched by name,
/// or by name and version where the lock lists several versions (`"syn 1.0.109"`).
pub fn lock_closure(lock: &str, root: &str) -> String {
    let blocks: Vec<&str> = lock.split("[[package]]").skip(1).collect();
    let field = |b: &str, key: &str| -> Option<String> {
        b.lines()
            .find_map(|l| l.strip_prefix(key)?.trim().strip_prefix('='))
            .map(|v| v.trim().trim_matches('"').to_string())
    };
    let deps = |b: &str| -> Vec<(String, Option<String>)> {
        let Some(start) = b.find("dependencies = [") else {
            return Vec::new();
        };
        let list = &b[start + "dependencies = [".len()..];
        let list = &list[..list.find(']').unwrap_or(list.len())];
        list.split(',')
            .map(|d| d.trim().trim_matches('"'))
            .filter(|d| !d.is_empty())
            .map(|d| {
                let mut t = d.split_whitespace();
                let name = t.next().unwrap_or_default().to_string();
                (name, t.next().map(str::to_string))
            })
            .collect()
    };
    let keyed: Vec<(String, String)> = blocks
        .iter()
        .map(|b| {
            (
                field(b, "name ").unwrap_or_default(),
                field(b, "version ").unwrap_or_default(),
            )
        })
        .collect();
    let find = |name: &str, version: Option<&str>| {
        keyed
            .iter()
            .position(|(n, v)| n == name && version.is_none_or(|want| want == v))
    };
    let mut keep = vec![false; blocks.len()];
    let mut todo: Vec<usize> = find(root, None).into_iter().collect();
    while let Some(i) = todo.pop() {
        if std::mem::replace(&mut keep[i], true) {
            continue;
        }
        for (name, version) in deps(blocks[i]) {
            if let Some(j) = find(&name, version.as_deref()) {
                todo.push(j);
            }
        }
    }
    blocks
        .iter()
        .zip(&keep)
        .filter(|(_, k)| **k)
        .map(|(b, _)| format!("[[package]]{b}"))
        .collect()
}

#[cfg(test)]
mod tests {

    #[test]
    fn the_lock_closure_keeps_the_roots_dependencies_only() {
        let lock = r#"version = 4

[[package]]
name = "a"
version = "1.0.0"
dependencies = [
 "b 2.0.0",
]

[[package]]
name = "b"
version = "1.0.0"

[[package]]
name = "b"
version = "2.0.0"

[[package]]
name = "py"
version = "0.1.0"
dependencies = [
 "a",
 "pyo3",
]

[[package]]
name = "pyo3"
version = "0.27.0"

[[package]]
name = "root"
version = "0.1.0"
dependencies = [
 "a",
]
"#;
        let c = lock_closure(lock, "root");
        let names: Vec<&str> = c
            .lines()
            .filter_map(|l| l.strip_prefix("name = "))
            .collect();
        assert_eq!(names, ["\"a\"", "\"b\"", "\"root\""]);
        assert!(
            c.contains("version = \"2.0.0\"")
                && !c.contains("version = \"1.0.0\"\n\n[[package]]\nname = \"b\"")
        );
        assert!(!c.contains("pyo3"));
        // A new version of another member's dependency leaves it as it was.
        assert_eq!(lock_closure(&lock.replace("0.27.0", "0.28.0"), "root"), c);
    }

    use super::*;

    fn deps(files: &[(&str, &str)], of: &str) -> Vec<String> {
        let owned: Vec<(String, String)> = files
            .iter()
            .map(|(p, t)| (p.to_string(), t.to_string()))
            .collect();
        graph(&owned)
            .remove(of)
            .unwrap_or_default()
            .into_iter()
            .collect()
    }

    /// A small crate: `a/{mod,b,c/mod,c/d}.rs`, `e.rs`, `f.rs`, `g.rs`, with `src/x.rs`
    /// (the file under test) written by each test.
    fn tree(x: &'static str) -> Vec<(&'static str, &'static str)> {
        vec![
            (
                "src/lib.rs",
                "pub mod a; pub mod e; pub mod f; pub mod g; pub mod x;",
            ),
            ("src/a/mod.rs", "pub mod b; pub mod c;"),
            ("src/a/b.rs", "pub fn f() {}"),
            ("src/a/c/mod.rs", "pub mod d; pub struct S;"),
            ("src/a/c/d.rs", "pub fn g() {}"),
            ("src/e.rs", "pub const E: u8 = 1;"),
            ("src/f.rs", "pub fn f() {}"),
            ("src/g.rs", "pub fn g() {}"),
            ("src/x.rs", x),
        ]
    }

    #[test]
    fn nested_use_trees_self_globs_and_renames() {
        let x = "use crate::a::{b::{self as bee}, c::{d::g as gee, S}};\nuse crate::e::*;";
        assert_eq!(
            deps(&tree(x), "src/x.rs"),
            ["src/a/b.rs", "src/a/c/d.rs", "src/a/c/mod.rs", "src/e.rs"]
        );
    }

    #[test]
    fn inline_paths_super_and_bound_names() {
        // `a` is bound by the use, so `a::c::d::g` is the crate's; `e` through `super`.
        let x = "use crate::a;\nfn h() { a::c::d::g(); super::e::E; crate::f::f(); Vec::<u8>::new(); std::mem::drop(1); }";
        assert_eq!(
            deps(&tree(x), "src/x.rs"),
            ["src/a/c/d.rs", "src/a/mod.rs", "src/e.rs", "src/f.rs"]
        );
        // A child module named by a bare path, and `super::` from below.
        let files = tree("");
        let mut files: Vec<_> = files
            .into_iter()
            .map(|(p, t)| match p {
                "src/a/mod.rs" => (p, "pub mod b; pub mod c; fn k() { c::d::g() }"),
                "src/a/b.rs" => (p, "fn k() { super::c::S; }"),
                _ => (p, t),
            })
            .collect();
        files.push(("src/a/c/tests.rs", "use crate::g::g;"));
        assert_eq!(deps(&files, "src/a/mod.rs"), ["src/a/c/d.rs"]);
        assert_eq!(deps(&files, "src/a/b.rs"), ["src/a/c/mod.rs"]);
    }

    #[test]
    fn comments_strings_and_tests_are_not_code() {
        let x = r####"
            // crate::a::b::f()
            /* crate::e::E /* nested */ crate::f::f() */
            /// `crate::g::g` in a doc comment
            fn h() -> &'static str { let _c = '"'; let _q = b'\''; "crate::a::b::f()" }
            const R: &str = r#"crate::e::E "still a string" "#;
            #[cfg(test)]
            mod tests { use crate::f::f; #[test] fn t() { crate::g::g() } }
            #[cfg(test)]
            fn helper() { crate::e::E; }
            fn kept<'a>(s: &'a str) -> &'a str { crate::a::c::d::g(); s }
        "####;
        assert_eq!(deps(&tree(x), "src/x.rs"), ["src/a/c/d.rs"]);
    }

    #[test]
    fn includes_macros_and_impls() {
        let files = vec![
            ("src/lib.rs", "pub mod m; pub mod t; pub mod u; pub mod x;"),
            (
                "src/m.rs",
                "#[macro_export]\nmacro_rules! fast { () => { crate::t::T } }",
            ),
            ("src/t.rs", "pub struct T;"),
            (
                "src/u.rs",
                "use crate::t::T;\nimpl T { pub fn go(&self) {} }",
            ),
            (
                "src/x.rs",
                "const S: &str = include_str!(\"../data_schema/s.json\");\ncrate::fast! {}\nfn f() -> impl Iterator<Item = u8> { crate::t::T.go(); [].into_iter() }",
            ),
        ];
        assert_eq!(
            deps(&files, "src/x.rs"),
            ["data_schema/s.json", "src/m.rs", "src/t.rs"]
        );
        // The impl in u.rs is reached through the type it implements.
        assert_eq!(deps(&files, "src/t.rs"), ["src/u.rs"]);
        let g = graph(
            &files
                .iter()
                .map(|(p, t)| (p.to_string(), t.to_string()))
                .collect::<Vec<_>>(),
        );
        assert!(reachable(&g, &["src/x.rs"]).contains("src/u.rs"));
        assert!(!reachable(&g, &["src/t.rs"]).contains("src/x.rs"));
    }

    #[test]
    fn modules_of_files() {
        assert_eq!(module_of("src/lib.rs"), Some(vec![]));
        assert_eq!(module_of("src/a/mod.rs"), Some(vec!["a".to_string()]));
        assert_eq!(
            module_of("src/a/b.rs"),
            Some(vec!["a".to_string(), "b".to_string()])
        );
        assert_eq!(module_of("src/main.rs"), None);
        assert_eq!(module_of("data_schema/x.json"), None);
    }
}
