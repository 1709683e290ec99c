//! Bad input never panics (issue 24): every reader of user files is fed mutations of a
//! valid sample, driven by a fixed-seed RNG, and each case must end in a result or in an
//! error that names the file, within a time bound.
//!
//! One `#[test]` per target. `FUZZ_CASES` (default 5000 per target) and `FUZZ_SEED`
//! (default fixed) choose the corpus; `FUZZ_CASE_MS` the per-case bound (default 2000).
//! `scripts/fuzz.sh CASES SEED…` runs longer campaigns. A failing case is saved under
//! `target/tmp/fuzz-failures/` and named in the failure with its seed and index, so
//! `FUZZ_SEED=S` reproduces it (the corpus of a seed is the same on every machine).

use pillar_pipe::Error;
use pillar_pipe::rng::Rng;
use std::collections::BTreeMap;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

fn env_or<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn cases() -> usize {
    env_or("FUZZ_CASES", 5000)
}

fn seed() -> u64 {
    env_or("FUZZ_SEED", 0x2024_0024)
}

fn workdir(target: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("pp-fuzz-{target}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

// ---------------------------------------------------------------------------------------
// Mutators
// ---------------------------------------------------------------------------------------

/// Values that have broken parsers before: empty, non-finite, huge, text, extreme integers.
const WEIRD: &[&str] = &[
    "",
    "nan",
    "NaN",
    "inf",
    "-inf",
    "1e40",
    "-1e40",
    "1e308",
    "-1e308",
    "1.8e308",
    "1e-320",
    "text",
    "99999999999999999999999",
    "9223372036854775807",
    "-9223372036854775808",
    "-1",
    "-7",
    "0",
    "-0",
    "0.5",
    "3.0",
    "\"",
    "\"1\"",
    " 1 ",
    "0x10",
    "1;2",
    "é",
];

fn pick<'a, T>(rng: &mut Rng, v: &'a [T]) -> &'a T {
    &v[rng.below(v.len())]
}

/// 1 to 4 operations, fewer more likely.
fn n_ops(rng: &mut Rng) -> usize {
    1 + (rng.uniform() * rng.uniform() * 4.0) as usize
}

/// Byte-level: flip, set, insert, delete, duplicate or cut a chunk, truncate.
fn mutate_bytes(rng: &mut Rng, data: &mut Vec<u8>) {
    for _ in 0..n_ops(rng) {
        let n = data.len();
        let at = rng.below(n + 1);
        match rng.below(8) {
            0 if n > 0 => data[at.min(n - 1)] ^= 1 << rng.below(8),
            1 if n > 0 => data[at.min(n - 1)] = rng.next_u64() as u8,
            2 => {
                let b = *pick(rng, b"\0\xff\n\r,\" .-eE019");
                data.insert(at, b)
            }
            3 if n > 0 => {
                let len = 1 + rng.below(16.min(n - at.min(n - 1)));
                let a = at.min(n - 1);
                data.drain(a..(a + len).min(n));
            }
            4 if n > 0 => {
                let a = at.min(n - 1);
                let len = 1 + rng.below(64.min(n - a));
                let chunk = data[a..a + len].to_vec();
                let to = rng.below(n + 1);
                data.splice(to..to, chunk);
            }
            5 => data.truncate(at),
            6 if n >= 8 => {
                // An aligned word set to an interesting value (lengths, counts, floats).
                let a = (at.min(n - 8)) & !7;
                let v: u64 = *pick(
                    rng,
                    &[
                        0,
                        1,
                        7,
                        u64::MAX,
                        u64::MAX / 2,
                        1 << 32,
                        f64::NAN.to_bits(),
                        f64::INFINITY.to_bits(),
                        1e40f64.to_bits(),
                        (-1.0f64).to_bits(),
                        0.0f64.to_bits(),
                        n as u64,
                        n as u64 / 8,
                    ],
                );
                data[a..a + 8].copy_from_slice(&v.to_le_bytes());
            }
            _ if n > 0 => {
                let a = at.min(n - 1);
                data[a] = data[a].wrapping_add(1);
            }
            _ => data.push(b'0'),
        }
    }
}

/// Line- and field-aware mutation of a text table or dump (`sep`: the field separator,
/// `None` for whitespace): delete, duplicate, swap or cut lines, replace a field with a
/// weird value, drop or add a field, rename a header field; sometimes bytes as well.
fn mutate_text(rng: &mut Rng, text: &str, sep: Option<char>) -> Vec<u8> {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    for _ in 0..n_ops(rng) {
        if lines.is_empty() {
            lines.push(pick(rng, WEIRD).to_string());
            continue;
        }
        let n = lines.len();
        let i = rng.below(n);
        match rng.below(12) {
            0 => {
                lines.remove(i);
            }
            1 => {
                let l = lines[i].clone();
                lines.insert(rng.below(n + 1), l);
            }
            2 => {
                let j = rng.below(n);
                lines.swap(i, j);
            }
            3 => {
                let cut = rng.below(lines[i].len() + 1);
                let mut c = cut;
                while !lines[i].is_char_boundary(c) {
                    c -= 1;
                }
                lines[i].truncate(c);
            }
            4 => lines.insert(i, String::new()),
            5 => {
                let keep = rng.below(n) + 1;
                lines.truncate(keep);
            }
            6 if i > 0 || rng.below(4) == 0 => {
                // Drop or add a field.
                let mut f = fields(&lines[i], sep);
                if rng.below(2) == 0 && !f.is_empty() {
                    f.remove(rng.below(f.len()));
                } else {
                    f.insert(rng.below(f.len() + 1), pick(rng, WEIRD).to_string());
                }
                lines[i] = join(&f, sep);
            }
            7 if n > 1 => {
                // A header field renamed, or made a copy of another.
                let mut f = fields(&lines[0], sep);
                if !f.is_empty() {
                    let k = rng.below(f.len());
                    f[k] = if rng.below(2) == 0 {
                        f[rng.below(f.len())].clone()
                    } else {
                        format!("{}_", f[k])
                    };
                    lines[0] = join(&f, sep);
                }
            }
            _ => {
                // Most often: one value replaced.
                let mut f = fields(&lines[i], sep);
                if !f.is_empty() {
                    let k = rng.below(f.len());
                    f[k] = pick(rng, WEIRD).to_string();
                    lines[i] = join(&f, sep);
                }
            }
        }
    }
    let mut out = lines.join("\n").into_bytes();
    if rng.below(4) != 0 {
        out.push(b'\n');
    }
    if rng.below(5) == 0 {
        mutate_bytes(rng, &mut out);
    }
    out
}

fn fields(line: &str, sep: Option<char>) -> Vec<String> {
    match sep {
        Some(c) => line.split(c).map(str::to_string).collect(),
        None => line.split_whitespace().map(str::to_string).collect(),
    }
}

fn join(f: &[String], sep: Option<char>) -> String {
    f.join(&sep.unwrap_or(' ').to_string())
}

/// Values of another TOML type, or out of any sensible domain.
const TOML_VALUES: &[&str] = &[
    "\"text\"",
    "\"\"",
    "1",
    "-1",
    "0",
    "1e40",
    "-1e308",
    "nan",
    "inf",
    "-inf",
    "true",
    "[]",
    "[1, 2]",
    "[\"a\"]",
    "{ a = 1 }",
    "9223372036854775807",
    "\"../../nowhere.csv\"",
    "\"experiment.ingest\"",
    "\"simulation.fit\"",
    "\"compare\"",
    "\"points\"",
    "[-1]",
    "[0, 1e40]",
];

/// TOML-aware: change a value's type or domain, drop or duplicate a key, add an unknown
/// key, rename a key or a table, plus the text and byte mutations.
fn mutate_toml(rng: &mut Rng, text: &str) -> Vec<u8> {
    if rng.below(4) == 0 {
        return mutate_text(rng, text, Some('='));
    }
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let keyed: Vec<usize> = (0..lines.len())
        .filter(|&i| lines[i].contains('=') && !lines[i].trim_start().starts_with('#'))
        .collect();
    let tables: Vec<usize> = (0..lines.len())
        .filter(|&i| lines[i].trim_start().starts_with('['))
        .collect();
    for _ in 0..n_ops(rng) {
        match rng.below(7) {
            0..=2 if !keyed.is_empty() => {
                let i = *pick(rng, &keyed);
                if let Some((k, _)) = lines[i].clone().split_once('=') {
                    lines[i] = format!("{k}= {}", pick(rng, TOML_VALUES));
                }
            }
            3 if !keyed.is_empty() => {
                let i = *pick(rng, &keyed);
                lines[i] = format!("# {}", lines[i]);
            }
            4 if !keyed.is_empty() => {
                let i = *pick(rng, &keyed);
                if let Some((k, v)) = lines[i].clone().split_once('=') {
                    let name = if rng.below(2) == 0 {
                        format!("{}x", k.trim())
                    } else {
                        "bogus".to_string()
                    };
                    lines[i] = format!("{name} ={v}");
                }
            }
            5 if !tables.is_empty() => {
                let i = *pick(rng, &tables);
                let names = [
                    "[x.y.z]",
                    "[pipeline]",
                    "[compare]",
                    "[report]",
                    "[experiment]",
                    "[a.fit]",
                    "[experiment.fit.extra]",
                    "[[experiment.ingest]]",
                    "[experiment.simulate]",
                ];
                lines[i] = pick(rng, &names).to_string();
            }
            _ => {
                let i = rng.below(lines.len().max(1));
                let l = lines.get(i).cloned().unwrap_or_default();
                lines.insert(rng.below(lines.len() + 1), l);
            }
        }
    }
    lines.join("\n").into_bytes()
}

/// JSON-aware: a value replaced by one of another type or an absurd number, a key
/// dropped or added; sometimes the text mutated byte by byte.
fn mutate_json(rng: &mut Rng, text: &str) -> Vec<u8> {
    if rng.below(4) == 0 {
        let mut b = text.as_bytes().to_vec();
        mutate_bytes(rng, &mut b);
        return b;
    }
    let mut v: serde_json::Value = serde_json::from_str(text).unwrap();
    for _ in 0..n_ops(rng) {
        let mut paths = Vec::new();
        collect_json_paths(&v, &mut Vec::new(), &mut paths);
        let path = pick(rng, &paths).clone();
        let Some(node) = json_at(&mut v, &path) else {
            continue;
        };
        use serde_json::json;
        let replacement = [
            json!(null),
            json!("text"),
            json!(-1),
            json!(0),
            json!(1e300),
            json!(-1e300),
            json!(u64::MAX),
            json!(i64::MIN),
            json!([]),
            json!([1e300, -1e300]),
            json!({}),
            json!(true),
            json!("points"),
            json!("binned-mean"),
        ];
        match rng.below(5) {
            0 => {
                if let serde_json::Value::Object(m) = node {
                    if let Some(k) = m.keys().nth(rng.below(m.len().max(1))).cloned() {
                        m.remove(&k);
                    }
                } else if let serde_json::Value::Array(a) = node
                    && !a.is_empty()
                {
                    a.remove(rng.below(a.len()));
                }
            }
            1 => {
                if let serde_json::Value::Object(m) = node {
                    m.insert("bogus".into(), json!(1));
                } else if let serde_json::Value::Array(a) = node {
                    a.push(json!(1e300));
                }
            }
            _ => *node = pick(rng, &replacement).clone(),
        }
    }
    serde_json::to_vec_pretty(&v).unwrap()
}

fn collect_json_paths(v: &serde_json::Value, at: &mut Vec<String>, out: &mut Vec<Vec<String>>) {
    out.push(at.clone());
    match v {
        serde_json::Value::Object(m) => {
            for (k, c) in m {
                at.push(k.clone());
                collect_json_paths(c, at, out);
                at.pop();
            }
        }
        serde_json::Value::Array(a) => {
            for (i, c) in a.iter().enumerate() {
                at.push(i.to_string());
                collect_json_paths(c, at, out);
                at.pop();
            }
        }
        _ => {}
    }
}

fn json_at<'a>(v: &'a mut serde_json::Value, path: &[String]) -> Option<&'a mut serde_json::Value> {
    let mut v = v;
    for k in path {
        v = match v {
            serde_json::Value::Object(m) => m.get_mut(k)?,
            serde_json::Value::Array(a) => a.get_mut(k.parse::<usize>().ok()?)?,
            _ => return None,
        };
    }
    Some(v)
}

// ---------------------------------------------------------------------------------------
// The campaign
// ---------------------------------------------------------------------------------------

/// Writes a case's files from the RNG.
type Make<'a> = Box<dyn Fn(&mut Rng, &Path) + 'a>;
/// Reads a case in-process.
type Run<'a> = Box<dyn Fn(&Path) -> pillar_pipe::Result<()> + 'a>;
/// Why an error's message does not locate its problem, if it does not.
type Place<'a> = Box<dyn Fn(&str) -> Option<String> + 'a>;

/// One target: how a case's files are made and how the reader is called.
struct Target<'a> {
    name: &'a str,
    /// The case's main file (its extension chooses the format).
    file: PathBuf,
    /// Writes the mutated case (the main file, and sidecars if any).
    make: Make<'a>,
    /// Reads it in-process.
    run: Run<'a>,
    /// Whether an error's message locates the problem well enough; `None` when fine.
    place: Place<'a>,
}

#[derive(Default)]
struct Tally {
    ok: usize,
    errors: BTreeMap<String, usize>,
    slowest: (Duration, usize),
    failures: Vec<String>,
}

fn save_failure(target: &str, seed: u64, case: usize, file: &Path) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("fuzz-failures");
    let _ = std::fs::create_dir_all(&dir);
    let name = file.file_name().unwrap().to_string_lossy();
    let to = dir.join(format!("{target}-seed{seed}-case{case}-{name}"));
    let _ = std::fs::copy(file, &to);
    to
}

/// Kind of an error for the tally: its variant and the start of its message.
fn error_kind(e: &Error, file: &str) -> String {
    let variant = format!("{e:?}");
    let variant = variant
        .split([' ', '(', '{'])
        .next()
        .unwrap_or("")
        .to_string();
    let msg = e.to_string().replace(file, "FILE");
    let short: String = msg
        .split(|c: char| c.is_ascii_digit() || c == '\'')
        .next()
        .unwrap_or("")
        .chars()
        .take(60)
        .collect();
    format!("{variant}: {short}")
}

/// A watchdog for cases that never return: after `hang` with no progress it names the
/// case and its saved input, and ends the process (a hung case cannot be unwound).
fn watchdog(target: String, seed: u64, file: PathBuf, hang: Duration) -> Arc<AtomicU64> {
    let progress = Arc::new(AtomicU64::new(0));
    let p = Arc::clone(&progress);
    std::thread::spawn(move || {
        let mut last = (u64::MAX, Instant::now());
        loop {
            std::thread::sleep(Duration::from_millis(200));
            let now = p.load(Ordering::Relaxed);
            if now == u64::MAX {
                return;
            }
            if now != last.0 {
                last = (now, Instant::now());
            } else if last.1.elapsed() > hang {
                let saved = save_failure(&target, seed, now as usize, &file);
                eprintln!(
                    "FUZZ HANG {target}: seed {seed} case {now} ran over {hang:?}; input saved at {}",
                    saved.display()
                );
                std::process::exit(101);
            }
        }
    });
    progress
}

fn campaign(t: Target) {
    let (n, seed) = (cases(), seed());
    let limit = Duration::from_millis(env_or("FUZZ_CASE_MS", 2000));
    let file_str = t.file.display().to_string();
    let progress = watchdog(t.name.into(), seed, t.file.clone(), limit * 15);
    let tally = Mutex::new(Tally::default());
    let t0 = Instant::now();
    for case in 0..n {
        progress.store(case as u64, Ordering::Relaxed);
        // Each case has its own stream, so a case is reproducible alone.
        let mut rng = Rng::new(seed ^ (case as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
        (t.make)(&mut rng, &t.file);
        let start = Instant::now();
        let out = catch_unwind(AssertUnwindSafe(|| (t.run)(&t.file)));
        let took = start.elapsed();
        let mut tl = tally.lock().unwrap();
        if took > tl.slowest.0 {
            tl.slowest = (took, case);
        }
        let fail = match out {
            Err(p) => {
                let msg = p
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default();
                Some(format!("panicked: {msg}"))
            }
            Ok(Ok(())) => {
                tl.ok += 1;
                None
            }
            Ok(Err(e)) => {
                *tl.errors.entry(error_kind(&e, &file_str)).or_default() += 1;
                let msg = e.to_string();
                if !msg.contains(&file_str) {
                    Some(format!("error does not name the file: {msg}"))
                } else {
                    (t.place)(&msg).map(|why| format!("{why}: {msg}"))
                }
            }
        };
        let fail = fail
            .or_else(|| (took > limit).then(|| format!("took {took:?}, over the {limit:?} bound")));
        if let Some(why) = fail {
            let saved = save_failure(t.name, seed, case, &t.file);
            tl.failures.push(format!(
                "seed {seed} case {case} ({}): {why}",
                saved.display()
            ));
        }
    }
    progress.store(u64::MAX, Ordering::Relaxed);
    let tl = tally.into_inner().unwrap();
    let errs: usize = tl.errors.values().sum();
    eprintln!(
        "FUZZ {}: {n} cases (seed {seed}) in {:.1} s: {} results, {errs} errors, {} failures; slowest case {} in {:.1} ms",
        t.name,
        t0.elapsed().as_secs_f64(),
        tl.ok,
        tl.failures.len(),
        tl.slowest.1,
        tl.slowest.0.as_secs_f64() * 1e3
    );
    for (k, c) in &tl.errors {
        eprintln!("  {c:6}  {k}");
    }
    assert!(
        tl.failures.is_empty(),
        "{}: {} of {n} cases failed:\n{}",
        t.name,
        tl.failures.len(),
        tl.failures
            .iter()
            .take(20)
            .cloned()
            .collect::<Vec<_>>()
            .join("\n")
    );
    if let Some(dir) = t.file.parent() {
        let _ = std::fs::remove_dir_all(dir);
    }
    // A corpus whose every case fails the same way exercises nothing past that check.
    if n >= 1000 {
        assert!(tl.ok > 0, "{}: no case gave a result", t.name);
    }
}

/// Errors that locate their problem: a line, row, byte, key or column, or a whole-file
/// condition that has no place. Returns why not, otherwise `None`.
fn located(msg: &str, whole_file: &[&str]) -> Option<String> {
    let places = [
        "line ",
        "row ",
        "byte ",
        "index ",
        "grain ",
        "column",
        "--set",
        "duplicate",
        "key",
        "field",
    ];
    if places.iter().any(|p| msg.contains(p)) || whole_file.iter().any(|w| msg.contains(w)) {
        None
    } else {
        Some("error names no place".into())
    }
}

// ---------------------------------------------------------------------------------------
// Seeds
// ---------------------------------------------------------------------------------------

/// A few frames of a few dozen neighbouring grains from the bundled trackpy sample.
fn trackpy_seed() -> String {
    let text = std::fs::read_to_string(Path::new(ROOT).join("data/sample/tracks.csv")).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let cols: Vec<&str> = header.split(',').collect();
    let at = |n: &str| cols.iter().position(|c| *c == n).unwrap();
    let (ix, iy, ifr, ip) = (at("x"), at("y"), at("frame"), at("particle"));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    // The grains of frame 0 in a patch near the bottom of the pillar.
    let chosen: std::collections::BTreeSet<&str> = rows
        .iter()
        .filter(|r| r[ifr] == "0")
        .filter(|r| {
            let (x, y): (f64, f64) = (r[ix].parse().unwrap(), r[iy].parse().unwrap());
            (200.0..300.0).contains(&x) && (100.0..200.0).contains(&y)
        })
        .map(|r| r[ip])
        .collect();
    assert!(chosen.len() >= 20, "{}", chosen.len());
    let mut out = format!("{header}\n");
    for r in &rows {
        if r[ifr].parse::<i64>().unwrap() < 4 && chosen.contains(r[ip]) {
            out += &r.join(",");
            out.push('\n');
        }
    }
    out
}

fn trackpy_options() -> pillar_pipe::stages::ingest::IngestOptions {
    pillar_pipe::stages::ingest::IngestOptions {
        px_per_unit: Some(31.496063),
        unit: Some("cm".into()),
        frame_time: Some(15.0),
        ..Default::default()
    }
}

/// The seed slice ingested into canonical tracks at `out` (CSV or Parquet by extension).
fn canonical_seed(dir: &Path, out: &Path) {
    let src = dir.join("seed-trackpy.csv");
    std::fs::write(&src, trackpy_seed()).unwrap();
    pillar_pipe::stages::ingest::run(&src, out, &trackpy_options()).unwrap();
}

/// Ingest the case as the CLI does (format detected unless given), short of hashing
/// the input and writing the validated table, which no input byte can reach.
fn ingest(
    input: &Path,
    opt: &pillar_pipe::stages::ingest::IngestOptions,
) -> pillar_pipe::Result<()> {
    use pillar_pipe::stages::ingest::{Format, detect, read_input};
    let format = match opt.format.unwrap_or(Format::Auto) {
        Format::Auto => detect(input)?,
        f => f,
    };
    read_input(input, format, opt).map(|_| ())
}

// ---------------------------------------------------------------------------------------
// Targets
// ---------------------------------------------------------------------------------------

#[test]
fn fuzz_trackpy_csv() {
    let dir = workdir("trackpy");
    let seed = trackpy_seed();
    // The seed itself reads.
    let file = dir.join("case.csv");
    std::fs::write(&file, &seed).unwrap();
    ingest(&file, &trackpy_options()).unwrap();
    campaign(Target {
        name: "trackpy",
        file,
        make: Box::new(|rng, f| std::fs::write(f, mutate_text(rng, &seed, Some(','))).unwrap()),
        run: Box::new(|f| ingest(f, &trackpy_options())),
        place: Box::new(|m| {
            located(
                m,
                &[
                    "empty file",
                    "no data rows",
                    "unknown format",
                    "missing required column",
                    "cannot estimate the radius",
                    "not a text file",
                ],
            )
        }),
    });
}

#[test]
fn fuzz_canonical_csv() {
    let dir = workdir("canonical-csv");
    let file = dir.join("case.csv");
    canonical_seed(&dir, &dir.join("seed.csv"));
    let seed = std::fs::read_to_string(dir.join("seed.csv")).unwrap();
    let meta = std::fs::read_to_string(dir.join("seed.csv.meta.json")).unwrap();
    campaign(Target {
        name: "canonical-csv",
        file,
        make: Box::new(|rng, f| {
            let side = pillar_pipe::io::sidecar_path(f);
            // Mostly the table; sometimes the sidecar, or no sidecar at all.
            match rng.below(8) {
                0 => {
                    std::fs::write(f, &seed).unwrap();
                    std::fs::write(&side, mutate_json(rng, &meta)).unwrap();
                }
                1 => {
                    std::fs::write(f, mutate_text(rng, &seed, Some(','))).unwrap();
                    let _ = std::fs::remove_file(&side);
                }
                _ => {
                    std::fs::write(f, mutate_text(rng, &seed, Some(','))).unwrap();
                    std::fs::write(&side, &meta).unwrap();
                }
            }
        }),
        run: Box::new(|f| ingest(f, &Default::default())),
        place: Box::new(|m| {
            located(
                m,
                &[
                    "empty file",
                    "no data rows",
                    "unknown format",
                    "missing required column",
                    "malformed sidecar",
                    "trackpy positions are in pixels",
                ],
            )
        }),
    });
}

/// Parquet: half the cases are byte mutations of the file, half tables that polars
/// writes correctly but that hold bad values, types or columns.
#[test]
fn fuzz_canonical_parquet() {
    use polars::prelude::*;
    let dir = workdir("canonical-parquet");
    let file = dir.join("case.parquet");
    let seed_file = dir.join("seed.parquet");
    canonical_seed(&dir, &seed_file);
    let bytes = std::fs::read(&seed_file).unwrap();
    let meta = std::fs::read_to_string(pillar_pipe::io::sidecar_path(&seed_file)).unwrap();
    let df = ParquetReader::new(std::fs::File::open(&seed_file).unwrap())
        .finish()
        .unwrap();
    campaign(Target {
        name: "canonical-parquet",
        file,
        make: Box::new(|rng, f| {
            std::fs::write(pillar_pipe::io::sidecar_path(f), &meta).unwrap();
            if rng.below(2) == 0 {
                let mut b = bytes.clone();
                mutate_bytes(rng, &mut b);
                std::fs::write(f, b).unwrap();
                return;
            }
            let mut d = df.clone();
            for _ in 0..n_ops(rng) {
                d = mutate_frame(rng, d);
            }
            let mut w = std::fs::File::create(f).unwrap();
            ParquetWriter::new(&mut w).finish(&mut d).unwrap();
        }),
        run: Box::new(|f| ingest(f, &Default::default())),
        place: Box::new(|m| {
            located(
                m,
                &[
                    "reading Parquet",
                    "empty file",
                    "no data rows",
                    "missing required column",
                    "whole column",
                    "expected numbers",
                ],
            )
        }),
    });
}

/// One structural change to a table: a value made null, NaN, huge or negative, a column
/// dropped, duplicated under another name, or cast to another type, rows duplicated or cut.
fn mutate_frame(rng: &mut Rng, df: polars::prelude::DataFrame) -> polars::prelude::DataFrame {
    use polars::prelude::*;
    let names: Vec<String> = df
        .get_column_names()
        .iter()
        .map(|s| s.to_string())
        .collect();
    if names.is_empty() || df.height() == 0 {
        return df;
    }
    let name = pick(rng, &names).clone();
    let col = df.column(&name).unwrap().clone();
    let row = rng.below(df.height());
    let with = |df: &DataFrame, c: Column| {
        let mut d = df.clone();
        d.with_column(c).unwrap();
        d
    };
    match rng.below(8) {
        0 => df.drop(&name).unwrap(),
        1 => {
            let to = pick(
                rng,
                &[
                    DataType::String,
                    DataType::Int32,
                    DataType::Float32,
                    DataType::Boolean,
                    DataType::UInt64,
                ],
            )
            .clone();
            match col.cast(&to) {
                Ok(c) => with(&df, c),
                Err(_) => df,
            }
        }
        2 => df.slice(0, row),
        3 => {
            let mut d = df.clone();
            d.vstack_mut(&df.slice(row as i64, 1 + rng.below(3)))
                .unwrap();
            d
        }
        4 => {
            let other = pick(
                rng,
                &["frame", "particle", "x", "radius", "species", "extra"],
            );
            let mut d = df.clone();
            let _ = d.with_column(col.clone().with_name((*other).into()));
            d
        }
        _ => {
            // One value replaced, in the column's own type where it has one.
            let f = col.cast(&DataType::Float64).unwrap();
            let mut v: Vec<Option<f64>> = f.f64().unwrap().iter().collect();
            v[row] = *pick(
                rng,
                &[
                    None,
                    Some(f64::NAN),
                    Some(f64::INFINITY),
                    Some(1e40),
                    Some(-1e308),
                    Some(-1.0),
                    Some(0.0),
                    Some(1e19),
                    Some(0.5),
                ],
            );
            let c = Column::new(name.as_str().into(), v);
            let c = if col.dtype().is_float() {
                c
            } else {
                match c.cast(col.dtype()) {
                    Ok(c) => c,
                    Err(_) => return df,
                }
            };
            with(&df, c)
        }
    }
}

/// Small LAMMPS dumps: orthogonal `x y radius`, triclinic `xs ys diameter`, and `type`
/// with radii given.
fn lammps_seeds() -> Vec<(String, Option<(f64, f64)>)> {
    let mut rng = Rng::new(11);
    let mut dump = |tri: bool, cols: &str, snaps: usize| {
        let mut s = String::new();
        for t in 0..snaps {
            s += &format!("ITEM: TIMESTEP\n{}\nITEM: NUMBER OF ATOMS\n12\n", t * 100);
            if tri {
                s += "ITEM: BOX BOUNDS xy xz yz pp pp pp\n-0.5 10.5 0.5\n0 10 0\n-0.5 0.5 0\n";
            } else {
                s += "ITEM: BOX BOUNDS pp pp pp\n0 10\n0 10\n-0.5 0.5\n";
            }
            s += &format!("ITEM: ATOMS {cols}\n");
            for i in 0..12 {
                let (x, y) = (
                    (i % 4) as f64 * 2.5 + 0.1 * rng.uniform(),
                    (i / 4) as f64 * 3.0 + 0.2,
                );
                let ty = 1 + i % 2;
                let r = if ty == 1 { 0.5 } else { 0.7 };
                let row: Vec<String> = cols
                    .split_whitespace()
                    .map(|c| match c {
                        "id" => (i + 1).to_string(),
                        "type" => ty.to_string(),
                        "x" => format!("{x:.4}"),
                        "y" => format!("{y:.4}"),
                        "xs" => format!("{:.5}", x / 10.0),
                        "ys" => format!("{:.5}", y / 10.0),
                        "radius" => r.to_string(),
                        "diameter" => (2.0 * r).to_string(),
                        _ => "0".into(),
                    })
                    .collect();
                s += &row.join(" ");
                s.push('\n');
            }
        }
        s
    };
    vec![
        (dump(false, "id type x y z radius", 3), None),
        (dump(true, "id type xs ys zs diameter", 3), None),
        (dump(false, "id type x y", 2), Some((0.5, 0.7))),
    ]
}

#[test]
fn fuzz_lammps_dump() {
    let dir = workdir("lammps");
    let seeds = lammps_seeds();
    let file = dir.join("case.dump");
    for (s, radii) in &seeds {
        std::fs::write(&file, s).unwrap();
        let opt = pillar_pipe::stages::ingest::IngestOptions {
            radii: *radii,
            ..Default::default()
        };
        ingest(&file, &opt).unwrap();
    }
    let which = std::cell::Cell::new(0usize);
    campaign(Target {
        name: "lammps",
        file,
        make: Box::new(|rng, f| {
            which.set(rng.below(seeds.len()));
            std::fs::write(f, mutate_text(rng, &seeds[which.get()].0, None)).unwrap();
        }),
        run: Box::new(|f| {
            let opt = pillar_pipe::stages::ingest::IngestOptions {
                radii: seeds[which.get()].1,
                ..Default::default()
            };
            ingest(f, &opt)
        }),
        place: Box::new(|m| {
            located(
                m,
                &[
                    "empty file",
                    "empty dump",
                    "unknown format",
                    "not a text file",
                ],
            )
        }),
    });
}

#[test]
fn fuzz_pipeline_file() {
    let dir = workdir("pipeline");
    // The bundled pipelines name `data/sample/tracks.csv` relative to `root = ".."`.
    std::fs::create_dir_all(dir.join("data/sample")).unwrap();
    std::fs::create_dir_all(dir.join("pipelines")).unwrap();
    std::fs::write(dir.join("data/sample/tracks.csv"), trackpy_seed()).unwrap();
    let seeds: Vec<String> = [
        "quickstart",
        "experiment-only",
        "paper-n1000",
        "shear-ramps",
    ]
    .iter()
    .map(|n| std::fs::read_to_string(Path::new(ROOT).join(format!("pipelines/{n}.toml"))).unwrap())
    .collect();
    let file = dir.join("pipelines/case.toml");
    for s in &seeds {
        std::fs::write(&file, s).unwrap();
        pillar_pipe::pipeline::load(&file, &[]).unwrap();
    }
    campaign(Target {
        name: "pipeline",
        file,
        make: Box::new(|rng, f| {
            let s = pick(rng, &seeds);
            std::fs::write(f, mutate_toml(rng, s)).unwrap()
        }),
        run: Box::new(|f| pillar_pipe::pipeline::load(f, &[]).map(|_| ())),
        place: Box::new(|m| {
            located(
                m,
                &["no stages", "stream did not contain valid UTF-8", "cycle"],
            )
        }),
    });
    let _ = std::fs::remove_dir_all(&dir);
}

/// A fit of the bundled sample with few bootstrap draws: fast, and a real fit.json.
fn fit_seed(dir: &Path) -> PathBuf {
    let src = Path::new(ROOT).join("data/sample/tracks.csv");
    let tracks = dir.join("sample.tracks.parquet");
    let mut opt = trackpy_options();
    opt.origin_px = Some((165.98, 850.0));
    opt.bar_speed = Some(0.0084667);
    pillar_pipe::stages::ingest::run(&src, &tracks, &opt).unwrap();
    let fit = dir.join("seed.fit.json");
    let fo = pillar_pipe::stages::fit::FitOptions {
        bootstrap: 20,
        quiet: true,
        ..Default::default()
    };
    pillar_pipe::stages::fit::run(&tracks, &fit, &fo).unwrap();
    fit
}

#[test]
fn fuzz_compare_fit_json() {
    let dir = workdir("compare");
    let seed_file = fit_seed(&dir);
    let seed = std::fs::read_to_string(&seed_file).unwrap();
    let file = dir.join("case.fit.json");
    std::fs::write(&file, &seed).unwrap();
    pillar_pipe::stages::compare::run(&file, &seed_file).unwrap();
    let flip = std::cell::Cell::new(false);
    campaign(Target {
        name: "compare",
        file,
        make: Box::new(|rng, f| {
            flip.set(rng.below(2) == 0);
            std::fs::write(f, mutate_json(rng, &seed)).unwrap()
        }),
        run: Box::new(|f| {
            // The mutated fit on either side.
            let r = if flip.get() {
                pillar_pipe::stages::compare::run(&seed_file, f)
            } else {
                pillar_pipe::stages::compare::run(f, &seed_file)
            };
            r.map(|c| {
                // The table prints whatever the numbers are.
                let _ = c.to_string();
            })
        }),
        place: Box::new(|m| located(m, &["fitted differently", "not a pillar-pipe fit.json"])),
    });
}

/// A checkpoint error names a byte or grain, or the section it found inconsistent.
const CHECKPOINT_SECTIONS: &[&str] = &[
    "bad magic",
    "pair list",
    "parameters",
    "box side",
    "inconsistent array lengths",
    "output bookkeeping",
];

#[test]
fn fuzz_pillar_checkpoint() {
    use pillar_pipe::stages::simulate::{SimulateOptions, read_checkpoint, run};
    let dir = workdir("pillar-ckpt");
    let out = dir.join("run");
    let opt = SimulateOptions {
        n: 24,
        strain: 0.02,
        checkpoint_every: 200,
        halt_after: Some(1),
        quiet: true,
        threads: 1,
        ..Default::default()
    };
    let halted = run(&out, &opt);
    assert!(
        halted
            .as_ref()
            .is_err_and(|e| e.to_string().contains("halted")),
        "{:?}",
        halted.map(|_| ())
    );
    let seed = std::fs::read(out.join("checkpoint.bin")).unwrap();
    read_checkpoint(&out.join("checkpoint.bin")).unwrap();
    let file = dir.join("checkpoint.bin");
    campaign(Target {
        name: "pillar-checkpoint",
        file,
        make: Box::new(|rng, f| {
            let mut b = seed.clone();
            mutate_bytes(rng, &mut b);
            std::fs::write(f, b).unwrap()
        }),
        run: Box::new(|f| {
            // A checkpoint that loads must also run: a few steps from its state.
            let (mut sim, _) = read_checkpoint(f)?;
            sim.scratch.threads = 1;
            for _ in 0..3 {
                sim.step();
            }
            Ok(())
        }),
        place: Box::new(|m| located(m, CHECKPOINT_SECTIONS)),
    });
}

#[test]
fn fuzz_shear_checkpoint() {
    use pillar_pipe::stages::shear::{ShearOptions, read_checkpoint, run};
    let dir = workdir("shear-ckpt");
    let out = dir.join("run");
    let opt = ShearOptions {
        n: 32,
        phi: 0.8,
        rate: 1e-2,
        strain: 0.5,
        checkpoint_every: 20,
        halt_after: Some(1),
        quiet: true,
        ..Default::default()
    };
    let halted = run(&out, &opt);
    assert!(
        halted
            .as_ref()
            .is_err_and(|e| e.to_string().contains("halted")),
        "{:?}",
        halted.map(|_| ())
    );
    let seed = std::fs::read(out.join("checkpoint.bin")).unwrap();
    read_checkpoint(&out.join("checkpoint.bin")).unwrap();
    let file = dir.join("checkpoint.bin");
    campaign(Target {
        name: "shear-checkpoint",
        file,
        make: Box::new(|rng, f| {
            let mut b = seed.clone();
            mutate_bytes(rng, &mut b);
            std::fs::write(f, b).unwrap()
        }),
        run: Box::new(|f| {
            // A checkpoint that loads must also run: a few steps from its state.
            let mut sim = read_checkpoint(f)?.sim;
            for _ in 0..3 {
                sim.step();
            }
            Ok(())
        }),
        place: Box::new(|m| located(m, CHECKPOINT_SECTIONS)),
    });
}
