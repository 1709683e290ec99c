//! Stage kinds, one file each (`kinds/<name>.rs`): its parameters' type, the checks at
//! load the schema cannot express, the stage function it runs and the outputs it names.
//! The pipeline's files ask the registry (`Kind::def`) instead of matching on the kind.
//!
//! A kind's cache key covers its own file and what that file reaches in the import
//! graph outside `src/pipeline/` (`build.rs`): the wiring of parameters to options
//! changes results, the dispatch around it does not.
//!
//! A new kind: its file here, its `pub mod` and one line in `registry!` below, and its
//! entry in `data_schema/pipeline.schema.json` (the schema test names what is missing;
//! the source-key test a file left out of the registry).

use super::exec::{Ctx, Produced};
use crate::error::{Error, Result};
use serde::{Deserialize, Serialize, de::DeserializeOwned};
use serde_json::Value as Json;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Where a key sits in the pipeline file, for errors that name file, line and key
/// (`parse::Source` is one).
pub trait Locate {
    /// An error about the key at dotted `path`.
    fn locate(&self, path: &str, msg: String) -> Error;
}

impl dyn Locate + '_ {
    pub fn err(&self, path: &str, msg: impl std::fmt::Display) -> Error {
        self.locate(path, msg.to_string())
    }
}

/// One side of a report: the stages of a branch by role.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Dataset {
    pub label: String,
    pub tracks: Option<String>,
    pub kinematics: Option<String>,
    pub fit: Option<String>,
    /// The simulate stage whose stress-strain and forces tables to plot.
    pub stress: Option<String>,
    /// The ingest stage whose force sensor's stress-strain to plot (when it has one).
    #[serde(default)]
    pub force: Option<String>,
    /// A sheared-disk run (`shear` stage) of the branch.
    #[serde(default)]
    pub shear: Option<String>,
    /// A sheared-disk grid (`sweep` stage) of the branch.
    #[serde(default)]
    pub sweep: Option<String>,
    /// The branch's strain-rate ramps (`ramp` stages), in file order: a ramp up and a
    /// ramp down draw one hysteresis loop (Fig. 31).
    #[serde(default)]
    pub ramps: Vec<String>,
    /// A parameter study of the branch (a stage with `vary`).
    #[serde(default)]
    pub grid: Option<String>,
}

/// A validated stage, ready to run.
#[derive(Debug, Clone)]
pub struct Stage {
    pub name: String,
    pub kind: Kind,
    pub branch: Option<String>,
    pub line: usize,
    /// Every key with its value (defaults filled, references as full stage names).
    pub params: Json,
    /// Upstream stages by key (`input`, `a`, `datasets.experiment.fit`, ...).
    pub upstream: BTreeMap<String, String>,
    pub datasets: Vec<Dataset>,
    /// Input files by key, absolute.
    pub files: BTreeMap<String, PathBuf>,
}

/// Typed parameters back from resolved JSON (always succeeds for resolved values).
pub fn typed<T: DeserializeOwned>(stage: &str, params: &Json) -> Result<T> {
    let mut p = params.clone();
    if let Some(o) = p.as_object_mut() {
        o.remove("kind");
    }
    serde_json::from_value(p).map_err(|e| Error::param(stage, e.to_string()))
}

/// `A,B` as two numbers (`--origin-px 165.98,850`, `--strain 0.1,0.2`).
pub fn parse_pair(s: &str) -> std::result::Result<(f64, f64), String> {
    let v: Vec<&str> = s.split(',').collect();
    if v.len() != 2 {
        return Err(format!("expected two numbers A,B, got '{s}'"));
    }
    let a = v[0]
        .trim()
        .parse::<f64>()
        .map_err(|e| format!("'{}': {e}", v[0]))?;
    let b = v[1]
        .trim()
        .parse::<f64>()
        .map_err(|e| format!("'{}': {e}", v[1]))?;
    Ok((a, b))
}

/// What a stage kind does, beyond the keys the schema file describes.
pub trait StageKind: Sync {
    /// Every key with its value, defaults filled (what the manifest records and the key
    /// hashes), from the validated stage table; or what is wrong.
    fn resolve(&self, given: Json) -> std::result::Result<Json, String>;

    /// Checks at load beyond the schema's, reported at the stage or its key; returns the
    /// stages this one expands into (a sweep's grid points), which run before it.
    fn check(&self, _src: &dyn Locate, _st: &mut Stage) -> Result<Vec<Stage>> {
        Ok(Vec::new())
    }

    /// Checks against the stages it refers to, once every stage is built.
    fn check_references(&self, _src: &dyn Locate, _st: &Stage, _all: &[Stage]) -> Result<()> {
        Ok(())
    }

    /// A file read beside the input file `path` (ingest's settings): hashed into the
    /// key under `<key>.settings`.
    fn beside(&self, _path: &Path) -> Option<PathBuf> {
        None
    }

    /// Fill keys whose default comes from the pipeline's header (a report's title).
    fn complete(&self, _params: &mut Json, _title: &str) {}

    /// Why `key` is unknown here, when it belongs to another kind.
    fn unknown_key_hint(&self, _key: &str) -> Option<&'static str> {
        None
    }

    /// Keys that change how a run behaves, not what it computes (how often it
    /// checkpoints): left out of the cache key.
    fn run_only(&self) -> &'static [&'static str] {
        &[]
    }

    /// The stage spreads over every core on threads of its own (which wait for each
    /// other at spinning barriers a second stage would stall): it runs alone.
    fn exclusive(&self) -> bool {
        false
    }

    /// The stage's outputs are a report the run directory shows (`report.html`).
    fn is_report(&self) -> bool {
        false
    }

    /// Run the stage into `out`: its parameters become the stage function's options,
    /// its references the upstream stages' output files.
    fn execute(&self, s: &Stage, ctx: &Ctx, out: &Path) -> Result<Produced>;
}

/// Defaults filled by a round trip through the kind's parameter type.
pub(crate) fn round_trip<T: Serialize + DeserializeOwned>(
    given: Json,
) -> std::result::Result<Json, String> {
    let t: T = serde_json::from_value(given).map_err(|e| e.to_string())?;
    Ok(serde_json::to_value(t).expect("json"))
}

/// For kinds that read a pillar run's folder (its force snapshots): `input` must name a
/// simulate stage; `what` says what is read, for the error at `STAGE.input`.
pub(crate) fn input_is_simulate(
    src: &dyn Locate,
    st: &Stage,
    all: &[Stage],
    what: &str,
) -> Result<()> {
    let Some(up) = st.upstream.get("input") else {
        return Ok(());
    };
    match all.iter().find(|s| &s.name == up) {
        Some(u) if u.kind != Kind::Simulate => Err(src.err(
            &format!("{}.input", st.name),
            format!(
                "'{up}' is a {} stage; {what} are a simulate stage's",
                u.kind.name()
            ),
        )),
        _ => Ok(()),
    }
}

/// The stage's parameters as the kind's typed struct, or the schema error at its line.
pub(crate) fn typed_at<T: DeserializeOwned>(src: &dyn Locate, st: &Stage) -> Result<T> {
    serde_json::from_value(st.params.clone()).map_err(|e| src.err(&st.name, e.to_string()))
}

// The kinds' modules are declared here, not by `registry!`, so rustfmt sees them.
pub mod bar_pressure;
pub mod compare;
pub mod edge_stress;
pub mod fit;
pub mod gofr;
pub mod grid;
pub mod ingest;
pub mod kinematics;
pub mod outline;
pub mod pack;
pub mod ramp;
pub mod render;
pub mod report;
pub mod shear;
pub mod shear_line_tracks;
pub mod shear_lines;
pub mod simulate;
pub mod sizes;
pub mod sweep;
pub mod track;

macro_rules! registry {
    ($($(#[$doc:meta])* $variant:ident => $module:ident;)*) => {

        /// The kinds of stage a pipeline can hold; the name is the file's.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub enum Kind {
            $($(#[$doc])* $variant,)*
        }

        impl Kind {
            pub const ALL: &[Kind] = &[$(Kind::$variant,)*];

            pub fn name(self) -> &'static str {
                match self {
                    $(Kind::$variant => stringify!($module),)*
                }
            }

            /// What the kind does.
            pub fn def(self) -> &'static dyn StageKind {
                match self {
                    $(Kind::$variant => &$module::$variant,)*
                }
            }
        }
    };
}

registry! {
    /// Tracks from a file (trackpy, LAMMPS, canonical), with an optional force sensor.
    Ingest => ingest;
    /// The pillar DEM (li-granular-pillars Sec. II).
    Simulate => simulate;
    Kinematics => kinematics;
    Fit => fit;
    Compare => compare;
    Report => report;
    /// One sheared-disk run (vagberg-sheared-disks).
    Shear => shear;
    /// A grid of sheared-disk runs, each grid point a `Shear` stage of its own.
    Sweep => sweep;
    /// One sheared-disk strain-rate ramp (vagberg-sheared-disks Eqs. 38–41, Fig. 31).
    Ramp => ramp;
    /// The camera emulator: tracks → frames (`pillar-pipe render`).
    Render => render;
    /// Frames → linked features → canonical tracks (`pillar-pipe track`, then `ingest`).
    Track => track;
    /// The size scan of pillar runs (li-granular-pillars Sec. V) a report draws.
    Sizes => sizes;
    /// g(r) of one frame by species (li-granular-pillars Fig. 2).
    Gofr => gofr;
    /// A pillar's outline over W0 (li-granular-pillars Fig. 9).
    Outline => outline;
    /// Transient shear lines of one frame pair (li-granular-pillars Fig. 11).
    ShearLines => shear_lines;
    /// Shear lines linked across frame pairs (li-granular-pillars Sec. V).
    ShearLineTracks => shear_line_tracks;
    /// Contact pressure along the bar (li-granular-pillars Fig. 10c).
    BarPressure => bar_pressure;
    /// Local stress against distance from the lateral edges (li-granular-pillars Sec. V).
    EdgeStress => edge_stress;
    /// A jammed packing (li-granular-pillars Sec. II.A) simulate stages share.
    Pack => pack;
    /// A parameter study's points gathered (made by `vary` on a stage).
    Grid => grid;
}

impl Kind {
    pub fn from_name(s: &str) -> Option<Kind> {
        Kind::ALL.iter().copied().find(|k| k.name() == s)
    }

    pub fn names() -> String {
        Kind::ALL
            .iter()
            .map(|k| k.name())
            .collect::<Vec<_>>()
            .join(", ")
    }
}
