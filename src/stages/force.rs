//! `ingest-force`: a force sensor's CSV (time or bar displacement, and the force on the
//! top bar) → the `bar_forces` table the simulator writes, and its stress–strain curve
//! computed with the simulator's own definitions (li-granular-pillars Sec. III, Fig. 4a
//! beside Fig. 4b). The format is in `docs/ingest.md` ("Force sensor").

use crate::dem::pillar::params::PillarParams;
use crate::dem::pillar::stress::{BarState, WIDTH_BAND_D, stress_point, width_near_top};
use crate::error::{Error, Result};
use crate::io::table::{Table, write_table};
use crate::stages::ingest::{IngestSettings, read_settings, settings_path};
use polars::prelude::*;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// The tables' length unit (the simulator's: cm).
const CM: f64 = 100.0;

/// Settings a flag, a `# key = value` comment of the file or `ingest.toml` can give.
/// Lengths are in `unit`, `bar_speed` in `unit` per second.
#[derive(Debug, Clone, Default, Serialize)]
pub struct ForceOptions {
    /// Unit of the force columns: N, mN, kN, uN, gf, kgf, lbf, dyn.
    pub force_unit: Option<String>,
    /// Unit of the time column: s, ms, us, min, h.
    pub time_unit: Option<String>,
    /// Length unit of the displacement column, `height`, `width`, `grain_size` and
    /// `bar_speed`: m, cm, mm, um, in.
    pub unit: Option<String>,
    /// Bar speed v_c (`unit` per second): turns time into displacement or back.
    pub bar_speed: Option<f64>,
    /// Initial pillar height H0 (bar separation), `unit`.
    pub height: Option<f64>,
    /// Pillar width W at the top edge, `unit` (σ = F_bar / W).
    pub width: Option<f64>,
    /// Large-grain diameter D, `unit` (default the paper's 0.635 cm).
    pub grain_size: Option<f64>,
    /// Large-grain mass m, kg (default the paper's 0.80 g).
    pub grain_mass: Option<f64>,
    /// Grain–substrate friction μ (default the paper's 0.23).
    pub mu: Option<f64>,
    /// The experiment's tracks (canonical, y = 0 at the bottom bar face, times in s):
    /// W measured per frame as the simulator does (grains within 2 D of the top bar),
    /// instead of the one `width`.
    pub tracks: Option<PathBuf>,
    /// A `width` setting wins over `tracks` (a pipeline's ingest stage offers its tracks;
    /// the CLI's explicit --tracks wins over a width).
    pub width_over_tracks: bool,
}

/// Keys of [`ForceOptions`] as they are spelled in a comment line and `ingest.toml`.
const KEYS: [&str; 9] = [
    "force_unit",
    "time_unit",
    "unit",
    "bar_speed",
    "height",
    "width",
    "grain_size",
    "grain_mass",
    "mu",
];

#[derive(Debug, Clone, Serialize)]
pub struct ForceReport {
    pub input: String,
    pub bar_forces: String,
    pub stress_strain: String,
    pub rows: usize,
    /// The `ingest.toml` beside the input that gave settings, if any.
    pub settings_file: Option<String>,
    /// Every setting in force, and where each came from.
    pub settings: serde_json::Value,
    pub max_strain: f64,
    pub max_stress: f64,
    pub max_stress_reduced: f64,
    pub warnings: Vec<String>,
}

/// Default outputs beside the input: `name.csv` → `name.bar_forces.parquet`,
/// `name.stress_strain.parquet`.
pub fn default_outputs(input: &Path) -> (PathBuf, PathBuf) {
    let stem = input
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "force".into());
    (
        input.with_file_name(format!("{stem}.bar_forces.parquet")),
        input.with_file_name(format!("{stem}.stress_strain.parquet")),
    )
}

/// Where a setting came from, for messages.
#[derive(Debug, Clone)]
enum Origin {
    Flag,
    Comment(usize),
    Toml(PathBuf),
}

#[derive(Debug, Clone)]
struct Setting {
    value: String,
    origin: Origin,
}

/// The force, time and length factors: value in the unit × factor = N, s, m.
fn unit_factor(kind: &str, u: &str) -> Option<f64> {
    let u = u.trim();
    let f = match kind {
        "force" => match u {
            "N" | "n" => 1.0,
            "mN" => 1e-3,
            "kN" => 1e3,
            "uN" | "µN" | "μN" => 1e-6,
            "gf" => 9.80665e-3,
            "kgf" => 9.80665,
            "lbf" => 4.448_221_615_260_5,
            "dyn" => 1e-5,
            _ => return None,
        },
        "time" => match u {
            "s" | "sec" => 1.0,
            "ms" => 1e-3,
            "us" | "µs" | "μs" => 1e-6,
            "min" => 60.0,
            "h" => 3600.0,
            _ => return None,
        },
        _ => match u {
            "m" => 1.0,
            "cm" => 1e-2,
            "mm" => 1e-3,
            "um" | "µm" | "μm" => 1e-6,
            "in" => 2.54e-2,
            _ => return None,
        },
    };
    Some(f)
}

fn known_units(kind: &str) -> &'static str {
    match kind {
        "force" => "N, mN, kN, uN, gf, kgf, lbf, dyn",
        "time" => "s, ms, us, min, h",
        _ => "m, cm, mm, um, in",
    }
}

/// A column of the header: its role, its name as written, a unit in brackets.
#[derive(Debug, Clone)]
struct Col {
    index: usize,
    raw: String,
    unit: Option<String>,
}

/// `force [mN]` or `force (mN)` → ("force", Some("mN")); names are case-insensitive.
fn split_unit(raw: &str) -> (String, Option<String>) {
    let t = raw.trim().trim_matches('"').trim();
    for (open, close) in [('[', ']'), ('(', ')')] {
        if t.ends_with(close)
            && let Some(i) = t.rfind(open)
        {
            let name = t[..i].trim().to_lowercase().replace(' ', "_");
            let unit = t[i + 1..t.len() - 1].trim().to_string();
            return (name, Some(unit));
        }
    }
    (t.to_lowercase().replace(' ', "_"), None)
}

/// The roles a header column can take, with the names that give each.
const ROLES: [(&str, &[&str]); 4] = [
    ("time", &["time", "t"]),
    ("displacement", &["displacement", "disp", "travel"]),
    ("force", &["force", "top_force", "load"]),
    ("bottom_force", &["bottom_force"]),
];

/// A parsed sensor file: settings from its comments, its columns by role, the rows.
struct Sensor {
    comments: Vec<(String, Setting)>,
    header_line: usize,
    cols: Vec<(&'static str, Col)>,
    /// Values of the role columns, row by row, with each row's line number.
    rows: Vec<(usize, Vec<f64>)>,
}

fn value_err(file: &str, line: usize, column: &str, msg: impl Into<String>) -> Error {
    Error::Value {
        file: file.into(),
        loc: format!("line {line}"),
        column: column.into(),
        msg: msg.into(),
    }
}

/// The header's line, its columns by role, the delimiter and the number of fields.
type Header = (usize, Vec<(&'static str, Col)>, char, usize);

fn parse_sensor(path: &Path) -> Result<Sensor> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    // A spreadsheet's byte-order mark is not part of the first name.
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    let mut comments = Vec::new();
    let mut header: Option<Header> = None;
    let mut rows = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let n = i + 1;
        let t = line.trim();
        if t.is_empty() {
            continue;
        }
        if let Some(c) = t.strip_prefix('#') {
            // `# key = value` (or `key: value`) for a known key; anything else is a note.
            if let Some((k, v)) = c.split_once('=').or_else(|| c.split_once(':')) {
                let k = k.trim().to_lowercase();
                if KEYS.contains(&k.as_str()) {
                    let v = v.split('#').next().unwrap_or("").trim().trim_matches('"');
                    comments.push((
                        k,
                        Setting {
                            value: v.to_string(),
                            origin: Origin::Comment(n),
                        },
                    ));
                }
            }
            continue;
        }
        match &header {
            None => {
                let delim = [',', '\t', ';']
                    .into_iter()
                    .find(|d| t.contains(*d))
                    .unwrap_or(',');
                let fields: Vec<&str> = t.split(delim).collect();
                let mut cols: Vec<(&'static str, Col)> = Vec::new();
                for (index, raw) in fields.iter().enumerate() {
                    let (name, unit) = split_unit(raw);
                    let Some((role, _)) = ROLES.iter().find(|(_, names)| names.contains(&&*name))
                    else {
                        continue; // a column the format does not use (an index, a channel)
                    };
                    if let Some((_, other)) = cols.iter().find(|(r, _)| r == role) {
                        return Err(value_err(
                            &file,
                            n,
                            raw.trim(),
                            format!("a second {role} column (the first is '{}')", other.raw),
                        ));
                    }
                    cols.push((
                        role,
                        Col {
                            index,
                            raw: raw.trim().to_string(),
                            unit,
                        },
                    ));
                }
                let has = |r: &str| cols.iter().any(|(c, _)| *c == r);
                let found = fields
                    .iter()
                    .map(|f| f.trim())
                    .collect::<Vec<_>>()
                    .join(",");
                if !has("force") {
                    return Err(value_err(
                        &file,
                        n,
                        "force",
                        format!(
                            "no force column in the header '{found}': expected 'force' (or 'top_force', 'load'), with its unit as 'force [N]' or a force_unit setting"
                        ),
                    ));
                }
                if !has("time") && !has("displacement") {
                    return Err(value_err(
                        &file,
                        n,
                        "time",
                        format!(
                            "no time or displacement column in the header '{found}': expected 'time' and/or 'displacement' (bar travel)"
                        ),
                    ));
                }
                header = Some((n, cols, delim, fields.len()));
            }
            Some((_, cols, delim, width)) => {
                let fields: Vec<&str> = t.split(*delim).collect();
                if fields.len() != *width {
                    return Err(value_err(
                        &file,
                        n,
                        "(row)",
                        format!(
                            "malformed row: {} fields, expected {width} as in the header",
                            fields.len()
                        ),
                    ));
                }
                let mut vals = Vec::with_capacity(cols.len());
                for (_, c) in cols {
                    let s = fields[c.index].trim().trim_matches('"');
                    let v: f64 = s.parse().map_err(|_| {
                        value_err(&file, n, &c.raw, format!("'{s}' is not a number"))
                    })?;
                    if !v.is_finite() {
                        return Err(value_err(&file, n, &c.raw, format!("{s} is not finite")));
                    }
                    vals.push(v);
                }
                rows.push((n, vals));
            }
        }
    }
    let Some((header_line, cols, _, _)) = header else {
        return Err(Error::input(&file, "empty file: no header line"));
    };
    if rows.is_empty() {
        return Err(Error::input(
            &file,
            format!("no data rows after the header (line {header_line})"),
        ));
    }
    Ok(Sensor {
        comments,
        header_line,
        cols,
        rows,
    })
}

/// Every setting: flags first, then the file's comments, then `ingest.toml`.
fn gather(
    opt: &ForceOptions,
    comments: &[(String, Setting)],
    toml: Option<(&Path, &IngestSettings)>,
) -> Vec<(String, Setting)> {
    let flags: [(&str, Option<String>); 9] = [
        ("force_unit", opt.force_unit.clone()),
        ("time_unit", opt.time_unit.clone()),
        ("unit", opt.unit.clone()),
        ("bar_speed", opt.bar_speed.map(|v| v.to_string())),
        ("height", opt.height.map(|v| v.to_string())),
        ("width", opt.width.map(|v| v.to_string())),
        ("grain_size", opt.grain_size.map(|v| v.to_string())),
        ("grain_mass", opt.grain_mass.map(|v| v.to_string())),
        ("mu", opt.mu.map(|v| v.to_string())),
    ];
    let mut out = Vec::new();
    for (k, flag) in flags {
        let from_toml = toml.and_then(|(p, s)| {
            let v = match k {
                "force_unit" => s.force_unit.clone(),
                "time_unit" => s.time_unit.clone(),
                "unit" => s.unit.clone(),
                "bar_speed" => s.bar_speed.map(|v| v.to_string()),
                "height" => s.height.map(|v| v.to_string()),
                "width" => s.width.map(|v| v.to_string()),
                "grain_size" => s.grain_size.map(|v| v.to_string()),
                "grain_mass" => s.grain_mass.map(|v| v.to_string()),
                _ => s.mu.map(|v| v.to_string()),
            };
            v.map(|value| Setting {
                value,
                origin: Origin::Toml(p.to_path_buf()),
            })
        });
        let s = flag
            .map(|value| Setting {
                value,
                origin: Origin::Flag,
            })
            .or_else(|| {
                comments
                    .iter()
                    .rev()
                    .find(|(c, _)| c == k)
                    .map(|(_, s)| s.clone())
            })
            .or(from_toml);
        if let Some(s) = s {
            out.push((k.to_string(), s));
        }
    }
    out
}

/// An error about setting `key`, placed where it was given.
fn setting_err(file: &str, key: &str, s: &Setting, msg: String) -> Error {
    match &s.origin {
        Origin::Flag => Error::param(format!("--{}", key.replace('_', "-")), msg),
        Origin::Comment(line) => value_err(file, *line, key, msg),
        Origin::Toml(p) => {
            // The key's line in the settings file, where it can be found.
            let line = std::fs::read_to_string(p).ok().and_then(|t| {
                t.lines().position(|l| {
                    l.trim_start()
                        .strip_prefix(key)
                        .is_some_and(|r| r.trim_start().starts_with('='))
                })
            });
            match line {
                Some(i) => value_err(&p.display().to_string(), i + 1, key, msg),
                None => Error::input(p.display(), format!("{key}: {msg}")),
            }
        }
    }
}

fn describe(s: &Setting) -> String {
    match &s.origin {
        Origin::Flag => "flag".into(),
        Origin::Comment(line) => format!("line {line}"),
        Origin::Toml(p) => p.display().to_string(),
    }
}

/// Read `input`, write `bar_forces` and `stress_strain` (Parquet or CSV by extension).
pub fn run(input: &Path, bar_out: &Path, ss_out: &Path, opt: &ForceOptions) -> Result<ForceReport> {
    if !input.exists() {
        return Err(Error::io(
            input,
            std::io::Error::new(std::io::ErrorKind::NotFound, "input file not found"),
        ));
    }
    if input == bar_out || input == ss_out || bar_out == ss_out {
        return Err(Error::param(
            "output",
            "the outputs must differ from each other and from the input",
        ));
    }
    let (bar, ss, report) = read(input, opt)?;
    let (mut bar, mut ss) = (bar, ss);
    write_table(&mut bar, bar_out)?;
    write_table(&mut ss, ss_out)?;
    Ok(ForceReport {
        bar_forces: bar_out.display().to_string(),
        stress_strain: ss_out.display().to_string(),
        ..report
    })
}

/// Everything [`run`] does short of writing: the two tables and the report.
pub fn read(input: &Path, opt: &ForceOptions) -> Result<(DataFrame, DataFrame, ForceReport)> {
    let file = input.display().to_string();
    let sensor = parse_sensor(input)?;
    let toml_path = settings_path(input);
    let toml = match &toml_path {
        Some(p) => Some(read_settings(p)?),
        None => None,
    };
    let settings = gather(
        opt,
        &sensor.comments,
        toml_path.as_deref().zip(toml.as_ref()),
    );
    let get = |k: &str| settings.iter().find(|(n, _)| n == k).map(|(_, s)| s);
    let num = |k: &str| -> Result<Option<f64>> {
        let Some(s) = get(k) else { return Ok(None) };
        let v: f64 = s
            .value
            .parse()
            .map_err(|_| setting_err(&file, k, s, format!("'{}' is not a number", s.value)))?;
        if !(v.is_finite() && v > 0.0) {
            return Err(setting_err(&file, k, s, format!("{v} must be > 0")));
        }
        Ok(Some(v))
    };
    let unit_of = |kind: &str, key: &str| -> Result<Option<f64>> {
        let Some(s) = get(key) else { return Ok(None) };
        unit_factor(kind, &s.value).map(Some).ok_or_else(|| {
            setting_err(
                &file,
                key,
                s,
                format!(
                    "{kind} unit '{}' not understood; known: {}",
                    s.value,
                    known_units(kind)
                ),
            )
        })
    };
    let length = unit_of("length", "unit")?;
    let force_key = unit_of("force", "force_unit")?;
    let time_key = unit_of("time", "time_unit")?;
    // A column's factor: its bracketed unit, else the key's; they must agree.
    let hl = sensor.header_line;
    let col_factor = |c: &Col, kind: &str, key: &str, keyed: Option<f64>| -> Result<f64> {
        match (&c.unit, keyed) {
            (Some(u), k) => {
                let f = unit_factor(kind, u).ok_or_else(|| {
                    value_err(
                        &file,
                        hl,
                        &c.raw,
                        format!(
                            "{kind} unit '{u}' not understood; known: {}",
                            known_units(kind)
                        ),
                    )
                })?;
                if let Some(k) = k
                    && (k - f).abs() > 1e-12 * f
                {
                    let s = get(key).expect("a keyed factor has its setting");
                    return Err(value_err(
                        &file,
                        hl,
                        &c.raw,
                        format!(
                            "unit '{u}' disagrees with {key} = '{}' ({})",
                            s.value,
                            describe(s)
                        ),
                    ));
                }
                Ok(f)
            }
            (None, Some(k)) => Ok(k),
            (None, None) => Err(value_err(
                &file,
                hl,
                &c.raw,
                format!(
                    "no {kind} unit: write it in the header ('{} [{}]'), as a '# {key} = ...' comment, in ingest.toml or as --{}",
                    c.raw,
                    known_units(kind).split(',').next().unwrap_or(""),
                    key.replace('_', "-")
                ),
            )),
        }
    };
    let col = |role: &str| {
        sensor
            .cols
            .iter()
            .position(|(r, _)| *r == role)
            .map(|i| (i, &sensor.cols[i].1))
    };
    let values = |i: usize| -> Vec<f64> { sensor.rows.iter().map(|(_, v)| v[i]).collect() };
    let need_len = |k: &str| -> Result<f64> {
        length.ok_or_else(|| {
            let s = get(k).expect("asked only for a given setting");
            setting_err(
                &file,
                k,
                s,
                "a length needs a length unit: unit = m, cm, mm, um or in".into(),
            )
        })
    };
    // SI from here on: N, s, m, m/s.
    let (fi, fc) = col("force").expect("the parser requires a force column");
    let ff = col_factor(fc, "force", "force_unit", force_key)?;
    let top_force: Vec<f64> = values(fi).iter().map(|v| v * ff).collect();
    let bottom_force: Vec<f64> = match col("bottom_force") {
        Some((i, c)) => {
            let f = col_factor(c, "force", "force_unit", force_key)?;
            values(i).iter().map(|v| v * f).collect()
        }
        None => vec![f64::NAN; top_force.len()],
    };
    let bar_speed = match num("bar_speed")? {
        Some(v) => Some(v * need_len("bar_speed")?),
        None => None,
    };
    let missing = |k: &str, why: &str| {
        Error::param(
            k,
            format!(
                "{file}: {why}; give it as a '# {k} = ...' comment in the file, in ingest.toml beside it, or as --{}",
                k.replace('_', "-")
            ),
        )
    };
    let height = match num("height")? {
        Some(v) => v * need_len("height")?,
        None => {
            return Err(missing(
                "height",
                "the initial pillar height H0 is needed for ε = ΔH/H0",
            ));
        }
    };
    let width = match num("width")? {
        Some(v) => Some(v * need_len("width")?),
        None if opt.tracks.is_some() => None,
        None => {
            return Err(missing(
                "width",
                "the pillar width W at the top edge is needed for σ = F_bar / W (or tracks to measure it per frame)",
            ));
        }
    };
    // Strictly increasing: a column's value on each row against the previous row's.
    let increasing = |i: usize, c: &Col, what: &str| -> Result<()> {
        for w in sensor.rows.windows(2) {
            let ((_, a), (n, b)) = (&w[0], &w[1]);
            if b[i] <= a[i] {
                return Err(value_err(
                    &file,
                    *n,
                    &c.raw,
                    format!(
                        "{what} {} does not increase (previous row: {}): the {what} must increase row by row",
                        b[i], a[i]
                    ),
                ));
            }
        }
        Ok(())
    };
    let time_col = col("time");
    let disp_col = col("displacement");
    let mut warnings = Vec::new();
    let (time, disp): (Vec<f64>, Vec<f64>) = match (time_col, disp_col) {
        (Some((ti, tc)), d) => {
            increasing(ti, tc, "time")?;
            let tf = col_factor(tc, "time", "time_unit", time_key)?;
            let t: Vec<f64> = values(ti).iter().map(|v| v * tf).collect();
            let dsp = match d {
                Some((di, dc)) => {
                    let lf = col_factor(dc, "length", "unit", length)?;
                    values(di).iter().map(|v| v * lf).collect()
                }
                None => {
                    let v = bar_speed.ok_or_else(|| {
                        missing(
                            "bar_speed",
                            "with a time column and no displacement column, the bar speed v_c turns time into bar travel",
                        )
                    })?;
                    t.iter().map(|t| v * t).collect()
                }
            };
            (t, dsp)
        }
        (None, Some((di, dc))) => {
            increasing(di, dc, "displacement")?;
            let lf = col_factor(dc, "length", "unit", length)?;
            let dsp: Vec<f64> = values(di).iter().map(|v| v * lf).collect();
            let v = bar_speed.ok_or_else(|| {
                missing(
                    "bar_speed",
                    "with a displacement column and no time column, the bar speed v_c gives the time",
                )
            })?;
            (dsp.iter().map(|d| d / v).collect(), dsp)
        }
        (None, None) => unreachable!("the parser requires time or displacement"),
    };
    if let Some((k, (n, d))) = disp
        .iter()
        .zip(&sensor.rows)
        .map(|(d, (n, _))| (n, d))
        .enumerate()
        .find(|(_, (_, d))| **d >= height)
    {
        let c = disp_col
            .or(time_col)
            .map(|(_, c)| c.raw.as_str())
            .unwrap_or("");
        return Err(value_err(
            &file,
            *n,
            c,
            format!(
                "bar travel {:.6} m at row {} reaches the pillar height H0 = {height:.6} m",
                d,
                k + 1
            ),
        ));
    }
    if bar_speed.is_none() {
        warnings.push("no bar_speed: P_in = F_bar v_c is NaN".into());
    }
    if col("bottom_force").is_none() {
        warnings.push("no bottom_force column: bottom_force is NaN".into());
    }
    let mut p = PillarParams::paper();
    if let Some(d) = num("grain_size")? {
        p.d_large = d * need_len("grain_size")?;
    }
    if let Some(m) = num("grain_mass")? {
        p.m_large = m;
    }
    if let Some(m) = num("mu")? {
        p.mu = m;
    }
    // The bar_forces table, in the simulator's units (s, N, cm): the bottom bar face is
    // y = 0 (the tracks' origin in docs/ingest.md), the top bar's is H0 − travel.
    let top_y: Vec<f64> = disp.iter().map(|d| (height - d) * CM).collect();
    let n = time.len();
    let bar = DataFrame::new(
        n,
        vec![
            Column::new("time".into(), &time),
            Column::new("top_force".into(), &top_force),
            Column::new("bottom_force".into(), &bottom_force),
            Column::new("top_y".into(), &top_y),
            Column::new("bottom_y".into(), vec![0.0; n]),
        ],
    )
    .map_err(|e| Error::polars("building bar_forces", e))?;
    let tracks = opt
        .tracks
        .as_ref()
        .filter(|_| !(opt.width_over_tracks && width.is_some()));
    let (widths, width_from) = match tracks {
        Some(tp) => {
            if width.is_some() {
                warnings.push(format!(
                    "width given and tracks too: W is measured per frame from {}",
                    tp.display()
                ));
            }
            let top: Vec<f64> = disp.iter().map(|d| height - d).collect();
            let w = widths_from_tracks(tp, &time, &top, WIDTH_BAND_D * p.d_large)?;
            let (t0, t1) = (w[0].0, w[w.len() - 1].0);
            if time[0] < t0 - 1e-9 || time[n - 1] > t1 + 1e-9 {
                warnings.push(format!(
                    "the sensor's times {}–{} s reach beyond the tracked frames' {t0}–{t1} s: W held at the nearest frame's there",
                    time[0],
                    time[n - 1]
                ));
            }
            let (wt, wv): (Vec<f64>, Vec<f64>) = w.iter().copied().unzip();
            let per_row = time.iter().map(|t| interp(&wt, &wv, *t) * CM).collect();
            (
                per_row,
                serde_json::json!({"tracks": tp.display().to_string(), "frames": w.len(), "band_m": WIDTH_BAND_D * p.d_large}),
            )
        }
        None => {
            let w = width.expect("required without tracks");
            (vec![w * CM; n], serde_json::json!({"constant_m": w}))
        }
    };
    let ss = stress_strain(
        &bar,
        height * CM,
        &widths,
        p.stress_unit(),
        bar_speed.unwrap_or(f64::NAN),
    )?;
    let max = |c: &str| -> f64 {
        ss.column(c)
            .ok()
            .and_then(|c| c.f64().ok().and_then(|v| v.max()))
            .unwrap_or(f64::NAN)
    };
    let mut resolved = serde_json::Map::new();
    for (k, s) in &settings {
        resolved.insert(
            k.clone(),
            serde_json::json!({"value": s.value, "from": describe(s)}),
        );
    }
    resolved.insert("width_from".into(), width_from);
    resolved.insert(
        "stress_unit_n_per_m".into(),
        serde_json::json!(p.stress_unit()),
    );
    resolved.insert(
        "grains".into(),
        serde_json::json!({"d_large_m": p.d_large, "m_large_kg": p.m_large, "mu": p.mu, "g": p.g}),
    );
    let report = ForceReport {
        input: file,
        bar_forces: String::new(),
        stress_strain: String::new(),
        rows: n,
        settings_file: toml_path.map(|p| p.display().to_string()),
        settings: serde_json::Value::Object(resolved),
        max_strain: max("strain"),
        max_stress: max("stress"),
        max_stress_reduced: max("stress_reduced"),
        warnings,
    };
    Ok((bar, ss, report))
}

/// Linear interpolation of y(x) at `at`, x increasing, held at the ends.
fn interp(x: &[f64], y: &[f64], at: f64) -> f64 {
    let k = x.partition_point(|v| *v < at);
    if k == 0 {
        return y[0];
    }
    if k >= x.len() {
        return y[x.len() - 1];
    }
    let (x0, x1) = (x[k - 1], x[k]);
    let f = if x1 > x0 { (at - x0) / (x1 - x0) } else { 1.0 };
    y[k - 1] + f * (y[k] - y[k - 1])
}

/// W per tracked frame, (time s, W m), from the experiment's tracks with the simulator's
/// rule ([`width_near_top`]: grains within `band` m of the top bar), the top bar's face at
/// each frame's time interpolated from the sensor's (`time` s, `top` m). Frames with no
/// grain in the band are skipped; none at all is an error.
pub fn widths_from_tracks(
    path: &Path,
    time: &[f64],
    top: &[f64],
    band: f64,
) -> Result<Vec<(f64, f64)>> {
    let file = path.display().to_string();
    let (t, _) = crate::io::read_tracks(path)?;
    let lf = unit_factor("length", &t.meta.length_unit).ok_or_else(|| {
        Error::input(
            &file,
            format!(
                "length unit '{}' is not one of {}: W needs the tracks in real units",
                t.meta.length_unit,
                known_units("length")
            ),
        )
    })?;
    let tf = unit_factor("time", &t.meta.time_unit);
    let scale = |v: &[f64]| v.iter().map(|v| v * lf).collect::<Vec<_>>();
    let mut out = Vec::new();
    for (frame, r) in t.frame_ranges() {
        let ft = match (&t.time, t.meta.frame_time, tf) {
            (Some(tt), _, Some(tf)) => tt[r.start] * tf,
            (None, Some(dt), Some(tf)) => frame as f64 * dt * tf,
            _ => {
                return Err(Error::input(
                    &file,
                    format!(
                        "no frame times in seconds (time unit '{}', frame time {:?}): give ingest a frame time",
                        t.meta.time_unit, t.meta.frame_time
                    ),
                ));
            }
        };
        let w = width_near_top(
            &scale(&t.x[r.clone()]),
            &scale(&t.y[r.clone()]),
            &scale(&t.radius[r.clone()]),
            interp(time, top, ft),
            band,
        );
        if w > 0.0 {
            out.push((ft, w));
        }
    }
    if out.is_empty() {
        let ymax = t.y.iter().fold(f64::NEG_INFINITY, |a, b| a.max(*b)) * lf;
        return Err(Error::input(
            &file,
            format!(
                "no grain within {band} m of the top bar in any frame (the top bar at {} m at the sensor's first row, the highest grain centre at {ymax} m): the tracks' y = 0 must be the bottom bar face and `height` the initial bar separation",
                top[0]
            ),
        ));
    }
    Ok(out)
}

/// A `bar_forces` table (s, N, cm; data_schema/bar_forces.schema.json) → the
/// stress–strain columns the simulator writes from the same quantities (frame, time,
/// strain, top_force, bottom_force, width, stress, stress_reduced, p_in), with
/// [`stress_point`]'s definitions: ε = (top_y0 − top_y)/(top_y0 − bottom_y) and
/// σ = F_bar / W. `top_y0` is the top bar's initial face (cm), `width` W per row (cm),
/// `stress_unit` m g μ / D (N/m), `bar_speed` v_c (m/s).
pub fn stress_strain(
    bar: &DataFrame,
    top_y0: f64,
    width: &[f64],
    stress_unit: f64,
    bar_speed: f64,
) -> Result<DataFrame> {
    let t = Table {
        df: bar.clone(),
        file: "bar_forces".into(),
        format: crate::io::table::TableFormat::Parquet,
    };
    let time = t.f64("time")?;
    let top = t.f64("top_force")?;
    let bottom = t.f64("bottom_force")?;
    let top_y = t.f64("top_y")?;
    let bottom_y = t.f64("bottom_y")?;
    if width.len() != time.len() {
        return Err(Error::Other(format!(
            "{} widths for {} bar_forces rows",
            width.len(),
            time.len()
        )));
    }
    let n = time.len();
    let (mut strain, mut stress, mut reduced, mut p_in) = (
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
    );
    for i in 0..n {
        let sp = stress_point(
            BarState {
                top_y0: top_y0 / CM,
                bottom_y: bottom_y[i] / CM,
                top_y: top_y[i] / CM,
                top_force: top[i],
            },
            width[i] / CM,
            stress_unit,
            bar_speed,
        );
        strain.push(sp.strain);
        stress.push(sp.stress);
        reduced.push(sp.stress_reduced);
        p_in.push(sp.p_in);
    }
    DataFrame::new(
        n,
        vec![
            Column::new("frame".into(), (0..n as i64).collect::<Vec<_>>()),
            Column::new("time".into(), &time),
            Column::new("strain".into(), &strain),
            Column::new("top_force".into(), &top),
            Column::new("bottom_force".into(), &bottom),
            Column::new("width".into(), width),
            Column::new("stress".into(), &stress),
            Column::new("stress_reduced".into(), &reduced),
            Column::new("p_in".into(), &p_in),
        ],
    )
    .map_err(|e| Error::polars("building stress_strain", e))
}
