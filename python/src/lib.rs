//! `pillar_pipe._native`: the library's stages for the Python package, in-process.
//!
//! One entry point, `call(stage, json)`, runs one stage of the `pillar_pipe` library (the CLI's code, with the
//! CLI's options) on files in a scratch directory the Python side owns, and returns the
//! stage's report as JSON text; the Python side (`pillar_pipe/__init__.py`) turns
//! DataFrames into those files and the outputs back into DataFrames. Going through the
//! stages' own readers and writers is what makes the results equal to the CLI's bit for
//! bit, sidecar metadata (units, frame time, provenance) included.
//!
//! Every stage runs on a worker thread without the GIL, while the calling thread polls
//! Python's signal handling: Ctrl-C raises the library's interrupt flag, the stage stops
//! at its next safe point, and the call raises `KeyboardInterrupt`. A panic in a stage
//! ends the worker thread, not the interpreter: it becomes a `RuntimeError`.

use pillar_pipe::error::Error;
use pyo3::exceptions::{PyKeyboardInterrupt, PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyCFunction, PyDict, PyModule, PyString, PyTuple};
use serde::Deserialize;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::Duration;

/// The library's error as the Python exception a caller expects: bad input or options
/// are `ValueError`, file trouble `OSError`, a stop by Ctrl-C `KeyboardInterrupt`; the
/// message is the one the CLI prints after `error: `.
fn to_py(e: Error) -> PyErr {
    let msg = e.to_string();
    match e {
        Error::Value { .. }
        | Error::MissingColumns { .. }
        | Error::Duplicate { .. }
        | Error::Input { .. }
        | Error::Param { .. } => PyValueError::new_err(msg),
        Error::Io { .. } => PyOSError::new_err(msg),
        Error::Interrupted { .. } => PyKeyboardInterrupt::new_err(msg),
        Error::Polars { .. } | Error::NotImplemented(_) | Error::Other(_) => {
            PyRuntimeError::new_err(msg)
        }
    }
}

/// How often the calling thread looks for Ctrl-C while a stage runs.
const SIGNAL_POLL: Duration = Duration::from_millis(50);

/// Run `work` on a worker thread without the GIL, honouring Ctrl-C, and convert its
/// result to JSON text.
// The stage runs on its own thread (not in `detach` on this one) so that this thread
// can take the GIL back every SIGNAL_POLL to let Python's handler see Ctrl-C.
fn run_stage<T, F>(py: Python<'_>, work: F) -> PyResult<String>
where
    T: serde::Serialize + Send + 'static,
    F: FnOnce() -> pillar_pipe::Result<T> + Send + 'static,
{
    // A flag left by an earlier interrupted call must not stop this one at once.
    pillar_pipe::interrupt::clear();
    let (tx, rx) = mpsc::channel();
    let worker = std::thread::Builder::new()
        .name("pillar_pipe stage".into())
        .spawn(move || {
            // The stage's progress bars write to stderr; a notebook is not a terminal
            // and Python scripts keep their stderr for their own messages.
            pillar_pipe::stages::hide_progress_on_this_thread();
            let r = work();
            let _ = tx.send(());
            r
        })
        .map_err(|e| PyRuntimeError::new_err(format!("cannot start a thread: {e}")))?;
    let mut interrupted: Option<PyErr> = None;
    let mut rx = rx;
    loop {
        // The receiver goes into the GIL-free closure and back (it is Send, not Sync).
        let (done, back) = py.detach(move || (rx.recv_timeout(SIGNAL_POLL), rx));
        rx = back;
        match done {
            Ok(()) | Err(mpsc::RecvTimeoutError::Disconnected) => break,
            Err(mpsc::RecvTimeoutError::Timeout) => {}
        }
        if interrupted.is_none()
            && let Err(e) = py.check_signals()
        {
            // Python's handler saw Ctrl-C (or raised another exception from a signal
            // handler): ask the stage to stop where its state is whole, then wait.
            pillar_pipe::interrupt::request(pillar_pipe::interrupt::SIGINT);
            interrupted = Some(e);
        }
    }
    let joined = py.detach(|| worker.join());
    pillar_pipe::interrupt::clear();
    let result = match joined {
        Ok(r) => r,
        Err(panic) => {
            let what = panic
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "unknown cause".into());
            return Err(PyRuntimeError::new_err(format!(
                "pillar_pipe: internal error (a panic in the library, please report): {what}"
            )));
        }
    };
    match (result, interrupted) {
        // The stage finished before it saw the flag: its result stands, and Python's
        // KeyboardInterrupt is raised as the user asked.
        (Ok(_), Some(e)) => Err(e),
        (Ok(v), None) => Ok(serde_json::to_string(&v).expect("reports serialise")),
        (Err(e), _) => Err(to_py(e)),
    }
}

/// The options of a call, or a ValueError naming the bad one (unknown keys are refused
/// by name: every argument type denies unknown fields).
fn args<T: serde::de::DeserializeOwned>(stage: &str, json: &str) -> PyResult<T> {
    serde_json::from_str(json)
        .map_err(|e| PyValueError::new_err(format!("{stage}: invalid option: {e}")))
}

/// `pillar-pipe ingest INPUT -o OUTPUT` with its flags.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct IngestArgs {
    input: PathBuf,
    output: PathBuf,
    format: Option<String>,
    px_per_unit: Option<f64>,
    unit: Option<String>,
    frame_time: Option<f64>,
    radii: Option<(f64, f64)>,
    origin_px: Option<(f64, f64)>,
    bar_speed: Option<f64>,
    #[serde(default)]
    keep_detached: bool,
}

fn ingest(py: Python<'_>, a: IngestArgs) -> PyResult<String> {
    use pillar_pipe::stages::ingest::{Format, IngestOptions, run};
    let format = match a.format.as_deref() {
        None | Some("auto") => None,
        Some("trackpy") => Some(Format::Trackpy),
        Some("lammps") => Some(Format::Lammps),
        Some("canonical") => Some(Format::Canonical),
        Some(other) => {
            return Err(PyValueError::new_err(format!(
                "invalid parameter 'format': '{other}'; one of auto, trackpy, lammps, canonical"
            )));
        }
    };
    let opt = IngestOptions {
        format,
        px_per_unit: a.px_per_unit,
        unit: a.unit,
        frame_time: a.frame_time,
        radii: a.radii,
        origin_px: a.origin_px,
        bar_speed: a.bar_speed,
        keep_detached: a.keep_detached,
    };
    run_stage(py, move || run(&a.input, &a.output, &opt))
}

/// The settings of an `ingest.toml` (the CLI's reader, its errors naming the line), with
/// the keyword names of `from_trackpy`.
fn ingest_settings(path: &Path) -> PyResult<String> {
    let s = pillar_pipe::stages::ingest::read_settings(path).map_err(to_py)?;
    let v = serde_json::json!({
        "format": s.format, "px_per_unit": s.px_per_unit, "unit": s.unit,
        "frame_time": s.frame_time, "radii": s.radii, "origin_px": s.origin_px,
        "bar_speed": s.bar_speed,
    });
    Ok(v.to_string())
}

/// `pillar-pipe kinematics INPUT --lags … -o OUTPUT`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct KinematicsArgs {
    input: PathBuf,
    output: PathBuf,
    lags: Vec<i64>,
    rc: Option<f64>,
    start: Option<i64>,
    every: Option<i64>,
    convention: Option<String>,
    columns: Option<Vec<String>>,
}

fn kinematics(py: Python<'_>, a: KinematicsArgs) -> PyResult<String> {
    use pillar_pipe::io::kinematics_io::Selection;
    use pillar_pipe::kinematics::Convention;
    use pillar_pipe::stages::kinematics::{KinematicsOptions, LagSpec, run};
    let convention = match a.convention.as_deref() {
        None | Some("paper") => Convention::Paper,
        Some("ovito") => Convention::Ovito,
        Some(other) => {
            return Err(PyValueError::new_err(format!(
                "invalid parameter 'convention': '{other}'; one of paper, ovito"
            )));
        }
    };
    let columns = match &a.columns {
        None => Selection::all(),
        Some(c) => Selection::of(c).map_err(to_py)?,
    };
    let opt = KinematicsOptions {
        lag: LagSpec::Frames(a.lags),
        rc: a.rc,
        start: a.start,
        every: a.every,
        convention,
        columns,
        quiet: true,
    };
    run_stage(py, move || run(&a.input, &a.output, &opt))
}

/// `pillar-pipe fit INPUT -o OUTPUT` (fit.json, the scatter table beside it): `input`
/// and `output`, and every other key is one of `FitParams`' — the struct the command
/// line flattens and a pipeline's fit stage reads, so names and defaults are theirs.
fn fit(py: Python<'_>, json: &str) -> PyResult<String> {
    use pillar_pipe::stages::fit::params::FitParams;
    let bad = |e: String| PyValueError::new_err(format!("fit: invalid option: {e}"));
    let mut v: serde_json::Value = serde_json::from_str(json).map_err(|e| bad(e.to_string()))?;
    let obj = v
        .as_object_mut()
        .ok_or_else(|| bad("expected keyword arguments".into()))?;
    let mut path = |key: &str| -> PyResult<PathBuf> {
        match obj.remove(key) {
            Some(serde_json::Value::String(s)) => Ok(PathBuf::from(s)),
            _ => Err(bad(format!("missing {key}"))),
        }
    };
    let (input, output) = (path("input")?, path("output")?);
    let params: FitParams = serde_json::from_value(v).map_err(|e| bad(e.to_string()))?;
    let opt = params.options("fit", true).map_err(to_py)?;
    run_stage(py, move || {
        pillar_pipe::stages::fit::run(&input, &output, &opt)
    })
}

/// `pillar-pipe gofr INPUT -o OUTPUT` (the CLI's defaults: r_max 4 D, 80 bins).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct GofrArgs {
    input: PathBuf,
    output: PathBuf,
    frame: Option<i64>,
    r_max: Option<f64>,
    bins: Option<usize>,
}

fn gofr(py: Python<'_>, a: GofrArgs) -> PyResult<String> {
    let (r_max, bins) = (a.r_max.unwrap_or(4.0), a.bins.unwrap_or(80));
    run_stage(py, move || {
        pillar_pipe::stages::gofr::run(&a.input, &a.output, a.frame, r_max, bins)
            .map(|(_, f, d)| serde_json::json!({"frame": f, "d_large": d}))
    })
}

/// A simulation's output directory and its options (the stage's own option type, as a
/// pipeline file gives them).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SimArgs<O> {
    out: PathBuf,
    options: O,
}

/// `pillar-pipe run PIPELINE --runs-dir RUNS_DIR` on the local executor.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RunArgs {
    pipeline: PathBuf,
    runs_dir: PathBuf,
    #[serde(default)]
    sets: Vec<String>,
    #[serde(default)]
    force: Vec<String>,
}

fn run_pipeline(py: Python<'_>, a: RunArgs) -> PyResult<String> {
    use pillar_pipe::pipeline::options::RunOptions;
    let opt = RunOptions {
        pipeline: a.pipeline,
        sets: a.sets,
        force: a.force,
        quiet: true,
        runs_dir: a.runs_dir,
        dry_run: false,
        verify: false,
        executor: Some("local".into()),
        slurm: Default::default(),
        jobs: None,
    };
    run_stage(py, move || {
        pillar_pipe::pipeline::runner::run(&opt, &mut |_| {})
    })
}

/// The report's crossover figure of labelled fits (fit.json paths) as `stem.png` and
/// `stem.svg`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FigureArgs {
    fits: Vec<(String, PathBuf)>,
    stem: PathBuf,
}

fn crossover_figure(py: Python<'_>, a: FigureArgs) -> PyResult<String> {
    run_stage(py, move || {
        let fits = a
            .fits
            .iter()
            .map(|(label, p)| Ok((label.clone(), pillar_pipe::stages::fit::read_fit(p)?)))
            .collect::<pillar_pipe::Result<Vec<_>>>()?;
        let fig = pillar_pipe::stages::report::crossover_figure(&fits, &a.stem)?;
        Ok(serde_json::json!({"png": fig.png, "svg": fig.svg}))
    })
}

/// The embedded schema (`data_schema/<table>.schema.json`) of a table.
fn schema(table: &str) -> PyResult<String> {
    let files = pillar_pipe::schema::SCHEMA_FILES;
    files
        .iter()
        .find(|(t, _)| *t == table)
        .map(|(_, s)| s.to_string())
        .ok_or_else(|| {
            let known: Vec<&str> = files.iter().map(|(t, _)| *t).collect();
            PyValueError::new_err(format!("no schema for table '{table}'; known: {known:?}"))
        })
}

/// One call from Python: `stage` names what to run, `json` carries its arguments.
fn dispatch(py: Python<'_>, stage: &str, json: &str) -> PyResult<String> {
    match stage {
        "ingest" => ingest(py, args(stage, json)?),
        "ingest_settings" => ingest_settings(&args::<PathBuf>(stage, json)?),
        "kinematics" => kinematics(py, args(stage, json)?),
        "fit" => fit(py, json),
        "gofr" => gofr(py, args(stage, json)?),
        "simulate_pillar" => {
            let a: SimArgs<pillar_pipe::stages::simulate::SimulateOptions> = args(stage, json)?;
            let mut opt = a.options;
            opt.quiet = true;
            run_stage(py, move || pillar_pipe::stages::simulate::run(&a.out, &opt))
        }
        "simulate_shear" => {
            let a: SimArgs<pillar_pipe::stages::shear::ShearOptions> = args(stage, json)?;
            let mut opt = a.options;
            opt.quiet = true;
            run_stage(py, move || pillar_pipe::stages::shear::run(&a.out, &opt))
        }
        "run" => run_pipeline(py, args(stage, json)?),
        "crossover_figure" => crossover_figure(py, args(stage, json)?),
        "schema" => schema(&args::<String>(stage, json)?),
        "version" => Ok(serde_json::to_string(pillar_pipe::stages::VERSION).expect("json")),
        // Testing aid: a panic inside a stage must come back as a RuntimeError and leave
        // the interpreter running.
        "panic_for_test" => run_stage::<(), _>(py, || panic!("deliberate test panic")),
        other => Err(PyValueError::new_err(format!("no stage '{other}'"))),
    }
}

/// `call(stage: str, json: str) -> str`: the module's one function.
fn call(a: &Bound<'_, PyTuple>, kw: Option<&Bound<'_, PyDict>>) -> PyResult<Py<PyAny>> {
    let py = a.py();
    if kw.is_some_and(|k| !k.is_empty()) || a.len() != 2 {
        return Err(PyValueError::new_err(
            "call(stage, json): two positional strings",
        ));
    }
    let stage: String = a.get_item(0)?.extract()?;
    let json: String = a.get_item(1)?.extract()?;
    let out = dispatch(py, &stage, &json)?;
    Ok(PyString::new(py, &out).into_any().unbind())
}

/// The module's definition: Python requires one behind a single-phase initialiser's
/// module ("initialization of _native did not return an extension module" otherwise).
static mut MODULE_DEF: pyo3::ffi::PyModuleDef = pyo3::ffi::PyModuleDef {
    m_base: pyo3::ffi::PyModuleDef_HEAD_INIT,
    m_name: c"pillar_pipe._native".as_ptr(),
    m_doc: c"pillar_pipe's Rust library; see pillar_pipe/__init__.py".as_ptr(),
    m_size: -1,
    m_methods: std::ptr::null_mut(),
    m_slots: std::ptr::null_mut(),
    m_traverse: None,
    m_clear: None,
    m_free: None,
};

fn module(py: Python<'_>) -> PyResult<Bound<'_, PyModule>> {
    // SAFETY: the interpreter imports an extension module once per process, with the
    // GIL held, so nothing else touches MODULE_DEF; it lives for the whole process, as
    // PyModule_Create requires.
    let m = unsafe {
        Bound::from_owned_ptr_or_err(
            py,
            pyo3::ffi::PyModule_Create(std::ptr::addr_of_mut!(MODULE_DEF)),
        )?
    };
    let m = m.cast_into::<PyModule>()?;
    let f = PyCFunction::new_closure(
        py,
        Some(c"call"),
        Some(c"call(stage, json) -> json: run one pillar_pipe stage (see pillar_pipe/__init__.py)"),
        call,
    )?;
    m.add("call", f)?;
    Ok(m)
}

/// The module's initialiser, written out because pyo3's `#[pymodule]` macro is not used
/// (see Cargo.toml).
///
/// # Safety
/// Called by the Python interpreter, with the GIL held, when `pillar_pipe._native` is
/// imported; it returns a new reference or NULL with an exception set.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn PyInit__native() -> *mut pyo3::ffi::PyObject {
    Python::attach(|py| match module(py) {
        Ok(m) => m.into_ptr(),
        Err(e) => {
            e.restore(py);
            std::ptr::null_mut()
        }
    })
}
