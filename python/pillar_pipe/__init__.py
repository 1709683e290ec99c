"""pillar_pipe: deformation analysis and DEM simulation of 2D granular packings.

The stages of the ``pillar-pipe`` command line (Li et al., *granular pillars*; Vågberg et
al., *sheared disks*), called in this process through the same Rust library — not a
subprocess — so the tables equal the CLI's bit for bit::

    import pillar_pipe as pp
    tracks = pp.from_trackpy(df, px_per_unit=31.496063, unit="cm", frame_time=15.0,
                             origin_px=(165.98, 850.0), bar_speed=0.0084667)
    kin = pp.kinematics(tracks, lag=1)          # J, η, η^s, J2, D²min, v per particle
    fit = pp.fit(tracks)                        # Θ, η_c of Eq. 19 (Sec. IV protocol)
    fit.figure()                                # the D²min–η^s crossover figure (PNG)

Tables come back as polars DataFrames (:class:`Table`, a ``polars.DataFrame`` that also
carries ``meta``, the table's sidecar — length and time units, frame time, provenance —
and ``units``, column → unit); ``to="pandas"`` gives a pandas DataFrame with the same in
``df.attrs``. Units of every column: ``pillar_pipe.schema(name)`` (``data_schema/`` in the
repository). Bad input raises ``ValueError`` with the CLI's message; Ctrl-C stops a long
call at its next safe point and raises ``KeyboardInterrupt``. Calls release the GIL.

Functions take tables as a :class:`Table` (read back from the file the library wrote,
nothing converted), a polars or pandas DataFrame (written to Parquet for the library; a
frame without a sidecar has no length unit or frame time, as with the CLI), or a path.
"""

from __future__ import annotations

import atexit
import itertools
import json
import numbers
import os
import re
import shutil
import tempfile
from pathlib import Path
from typing import Any, Dict, Iterable, Optional, Sequence, Tuple, Union

import polars as pl

from . import _native



def _native_call(stage: str, **args) -> Any:
    """Run `stage` in the library (``_native.call`` takes and gives JSON text)."""
    return json.loads(_native.call(stage, json.dumps(args)))


__version__ = _native_call("version")

__all__ = [
    "Table",
    "Fit",
    "SimRun",
    "from_trackpy",
    "ingest",
    "ingest_settings",
    "kinematics",
    "fit",
    "gofr",
    "simulate_pillar",
    "simulate_shear",
    "run",
    "crossover_figure",
    "schema",
]

# trackpy's columns that `ingest` reads (src/io/csvdiag.rs TRACKPY_COLUMNS).
_TRACKPY_COLUMNS = ("y", "x", "mass", "size", "ecc", "signal", "raw_mass", "ep", "frame", "particle")

_scratch_dir: Optional[Path] = None
_names = itertools.count()


def _scratch(stem: str, suffix: str = "") -> Path:
    """A fresh path in this process's scratch directory (removed at exit)."""
    global _scratch_dir
    if _scratch_dir is None:
        _scratch_dir = Path(tempfile.mkdtemp(prefix="pillar_pipe-"))
        atexit.register(shutil.rmtree, _scratch_dir, True)
    return _scratch_dir / f"{stem}-{next(_names)}{suffix}"


def schema(table: str) -> Dict[str, Any]:
    """The schema of a table (``tracks``, ``kinematics``, ``gofr``, ``bar_forces``, …):
    its columns with type, unit and description, as ``data_schema/<table>.schema.json``."""
    return json.loads(_native.call("schema", json.dumps(table)))


def _units(table: Optional[str], meta: Dict[str, Any]) -> Dict[str, str]:
    """Column → unit from the schema, with the generic 'length' and 'time' replaced by
    the table's own units where its sidecar names them."""
    if table is None:
        return {}
    try:
        cols = schema(table)["columns"]
    except ValueError:
        return {}
    length = meta.get("length_unit")
    time = meta.get("time_unit")
    out = {}
    for c in cols:
        u = c.get("unit") or ""
        if length and length != "unspecified":
            u = re.sub(r"\blength\b", length, u)
        if time and u in ("1/time", "length/time", f"{length}/time"):
            u = u.replace("time", time)
        elif time and u.startswith("time ("):  # "time (s, or frames if …)"
            u = time
        out[c["name"]] = u
    return out


class Table(pl.DataFrame):
    """A polars DataFrame that pillar_pipe returned, with its metadata.

    Attributes: ``meta`` (dict: the table's ``.meta.json`` sidecar — ``length_unit``,
    ``time_unit``, ``frame_time`` in s, ``bar_speed`` in length unit/s, provenance),
    ``units`` (dict: column → unit), ``table`` (its schema name), ``path`` (the Parquet
    file the library wrote; handing this frame to another pillar_pipe function reads that
    file, sidecar included). polars operations return plain DataFrames, without these.
    """

    meta: Dict[str, Any]
    units: Dict[str, str]
    table: Optional[str]
    path: Optional[Path]

    @classmethod
    def _read(cls, path: Path, table: Optional[str]) -> "Table":
        df = pl.read_parquet(path)
        # The frame's own data, no copy, in this subclass (polars' constructor for it).
        t = cls._from_pydf(df._df)
        side = Path(str(path) + ".meta.json")
        t.meta = json.loads(side.read_text()) if side.exists() else {}
        t.units = _units(table, t.meta)
        t.table = table
        t.path = Path(path)
        t._shape_at_read = (df.height, tuple(df.columns))
        return t

    def _unchanged_file(self) -> Optional[Path]:
        """The file this frame was read from, if it still holds what the frame shows
        (no column added or row dropped in place since)."""
        p = getattr(self, "path", None)
        if p is None or not p.exists():
            return None
        if getattr(self, "_shape_at_read", None) != (self.height, tuple(self.columns)):
            return None
        return p


def _convert(t: Table, to: str):
    if to == "polars":
        return t
    if to == "pandas":
        # Column by column through numpy: polars' own to_pandas needs pyarrow.
        import pandas as pd

        df = pd.DataFrame({c: t[c].to_numpy() for c in t.columns})
        df.attrs["meta"] = t.meta
        df.attrs["units"] = t.units
        return df
    raise ValueError(f"invalid parameter 'to': '{to}'; one of polars, pandas")


def _as_polars(df: Any, what: str) -> pl.DataFrame:
    if isinstance(df, pl.DataFrame):
        return df
    if isinstance(df, pl.LazyFrame):
        return df.collect()
    try:
        import pandas as pd
    except ImportError:  # pragma: no cover - pandas absent
        pd = None
    if pd is not None and isinstance(df, pd.DataFrame):
        # Column by column through numpy: no pyarrow needed, values copied as they are.
        return pl.DataFrame({str(c): df[c].to_numpy() for c in df.columns})
    raise TypeError(f"{what}: expected a polars or pandas DataFrame, a Table or a path, got {type(df).__name__}")


def _input_path(obj: Any, what: str) -> Tuple[Path, Optional[str]]:
    """The file the library reads for `obj`, and the name to put in its messages in
    place of a scratch file's path (None: the path is the user's own)."""
    if isinstance(obj, (str, os.PathLike)):
        return Path(obj), None
    if isinstance(obj, Table):
        p = obj._unchanged_file()
        if p is not None:
            return p, None
    df = _as_polars(obj, what)
    p = _scratch(what, ".parquet")
    df.write_parquet(p)
    return p, "DataFrame"


def _call(stage: str, rename: Dict[str, str] = {}, **kwargs):
    """Run `stage` in the library; a message naming a scratch file names what the user
    gave instead."""
    try:
        return _native_call(stage, **kwargs)
    except (ValueError, OSError, RuntimeError) as e:
        msg = str(e)
        for path, name in rename.items():
            msg = msg.replace(path, name)
        if _scratch_dir is not None:
            # A table this package wrote (a Table handed back in): the user knows it as
            # a DataFrame, not by its scratch file.
            msg = re.sub(re.escape(str(_scratch_dir)) + r"/[^\s:,]+", "DataFrame", msg)
        if msg == str(e):
            raise
        raise type(e)(msg) from None


def ingest_settings(path: Union[str, os.PathLike]) -> Dict[str, Any]:
    """The camera settings of an ``ingest.toml`` (px_per_unit, unit, frame_time in s,
    origin_px in px, bar_speed in length unit/s, radii in length unit), as keyword
    arguments for :func:`from_trackpy`. Errors name the file and line."""
    s = json.loads(_native.call("ingest_settings", json.dumps(str(path))))
    s.pop("format", None)
    out = {k: v for k, v in s.items() if v is not None}
    for k in ("origin_px", "radii"):
        if k in out:
            out[k] = tuple(out[k])
    return out


def from_trackpy(
    df: Any,
    px_per_unit: Optional[float] = None,
    unit: Optional[str] = None,
    frame_time: Optional[float] = None,
    origin_px: Optional[Tuple[float, float]] = None,
    bar_speed: Optional[float] = None,
    radii: Optional[Tuple[float, float]] = None,
    keep_detached: bool = False,
    to: str = "polars",
):
    """trackpy's linked DataFrame (pandas or polars; columns ``x, y, frame, particle,
    size``, and ``ep`` if present, in pixels) → the canonical ``tracks`` table, as
    ``pillar-pipe ingest`` with the same-named flags.

    - ``px_per_unit``: pixels per length unit; ``unit``: the length unit's name (``"cm"``;
      ``unit="px"`` alone keeps pixels);
    - ``frame_time``: seconds per frame (without it, times are in frames);
    - ``origin_px``: (x0, y0) in pixels, the canonical origin: x = (x_px − x0)/s,
      y = (y0 − y_px)/s, y up (default x0 = 0, y0 = the largest y_px);
    - ``bar_speed``: v_c in length unit per second (the fit's time scale R/v_c);
    - ``radii``: (small, large) in the length unit (default estimated from the packing);
    - ``keep_detached``: keep trajectories detached from the packing.

    Returns a :class:`Table` (``frame``, ``particle``, ``x``, ``y``, ``radius`` in the
    length unit, ``time`` in s, ``species`` 0 small / 1 large). Raises ``ValueError`` for
    a missing column or bad value, with the CLI's message (the file named "DataFrame").
    """
    pdf = _as_polars(df, "from_trackpy")
    pdf = pdf.select([c for c in pdf.columns if c in _TRACKPY_COLUMNS])
    src = _scratch("trackpy", ".parquet")
    pdf.write_parquet(src)
    out = _scratch("tracks", ".parquet")
    _call(
        "ingest",
        input=str(src),
        output=str(out),
        format="trackpy",
        px_per_unit=px_per_unit,
        unit=unit,
        frame_time=frame_time,
        radii=radii,
        origin_px=origin_px,
        bar_speed=bar_speed,
        keep_detached=keep_detached,
        rename={str(src): "DataFrame"},
    )
    src.unlink()
    return _convert(Table._read(out, "tracks"), to)


def ingest(path: Union[str, os.PathLike], to: str = "polars", **flags):
    """``pillar-pipe ingest PATH`` (trackpy CSV, LAMMPS dump, canonical CSV/Parquet; an
    ``ingest.toml`` beside it applies as with the CLI) → the ``tracks`` :class:`Table`.
    Keywords as :func:`from_trackpy` plus ``format``."""
    out = _scratch("tracks", ".parquet")
    _call("ingest", input=str(path), output=str(out), **flags)
    return _convert(Table._read(out, "tracks"), to)


def kinematics(
    tracks: Any,
    lag: Union[int, Sequence[int]] = 1,
    r_c: Optional[float] = None,
    start: Optional[int] = None,
    every: Optional[int] = None,
    convention: str = "paper",
    columns: Optional[Sequence[str]] = None,
    to: str = "polars",
):
    """Per-particle kinematics (Li et al. Eqs. 13–18), as ``pillar-pipe kinematics``:
    for each frame pair ``lag`` frames apart (an int or several), neighbours strictly
    within ``r_c`` (length unit; default 1.25 D, D the large-grain diameter), the best
    affine J (Eq. 14), η (Eq. 15), η^m (Eq. 16), η^s (Eq. 17, dimensionless), J2 = η^s/Δt
    (Eq. 18, 1/s), D²min/N_i (length unit²), v (length unit/s). Rows with fewer than 2
    or collinear neighbours have ``valid`` false and NaN. ``convention="ovito"`` uses
    OVITO's definitions. Returns the ``kinematics`` :class:`Table`; a lag beyond the movie
    raises ``ValueError``."""
    src, name = _input_path(tracks, "tracks")
    lags = [int(lag)] if isinstance(lag, numbers.Integral) else [int(x) for x in lag]
    out = _scratch("kinematics", ".parquet")
    _call(
        "kinematics",
        input=str(src),
        output=str(out),
        lags=lags,
        rc=r_c,
        start=start,
        every=every,
        convention=convention,
        columns=list(columns) if columns is not None else None,
        rename={str(src): name} if name else {},
    )
    return _convert(Table._read(out, "kinematics"), to)


class Fit(dict):
    """A fit's ``fit.json`` as a dict (``theta``, ``eta_c`` of Eq. 19 — Θ and η_c are
    dimensionless —, their 95 % intervals, whether each is constrained, the protocol,
    the noise floor, warnings), with ``scatter`` (the D²min/R²–η^s samples, a
    :class:`Table`), ``path`` (the fit.json written) and :meth:`figure`."""

    path: Path
    scatter: Table

    @property
    def theta(self) -> float:
        """Θ of Eq. 19 (NaN when undetermined; see ``theta_constrained``)."""
        v = self["theta"]
        return float("nan") if v is None else v

    @property
    def eta_c(self) -> float:
        """η_c of Eq. 19, dimensionless (NaN when undetermined)."""
        v = self["eta_c"]
        return float("nan") if v is None else v

    def figure(self, label: str = "data", path: Optional[Union[str, os.PathLike]] = None):
        """The D²min/R²–η^s crossover figure of this fit (the report's Fig. 8), drawn by
        the library: see :func:`crossover_figure`."""
        return crossover_figure({label: self}, path=path)


def fit(
    tracks_or_kinematics: Any,
    diameter: Optional[float] = None,
    bar_speed: Optional[float] = None,
    starts: Optional[Sequence[float]] = None,
    lags: Optional[Sequence[float]] = None,
    rc_over_d: Optional[float] = None,
    method: Optional[str] = None,
    bins_per_decade: Optional[float] = None,
    min_bin_count: Optional[int] = None,
    bootstrap: Optional[int] = None,
    seed: Optional[int] = None,
    eta_range: Optional[str] = None,
    position_noise: Optional[float] = None,
    to: str = "polars",
) -> Fit:
    """The D²min–η^s crossover fit (Li et al. Eq. 19), as ``pillar-pipe fit``: from
    ``tracks`` it runs the Sec. IV protocol (start times ``starts`` and lags ``lags`` in
    units of R/v_c; ``bar_speed`` v_c in length unit/s), from a ``kinematics`` table it
    fits the rows as given. ``diameter`` D in the length unit (default from the data);
    ``rc_over_d`` R_c/D (1.25); ``method`` ``binned-median`` (default), ``binned-mean``,
    ``points`` or ``weighted-mean``; ``bins_per_decade`` (5) and ``min_bin_count`` (10)
    of the η^s bins; ``bootstrap`` replicates (1000) with ``seed`` (1) for the 95 %
    intervals; ``eta_range`` ``coverage`` (default), ``all`` or ``"LO,HI"``;
    ``position_noise`` σ per coordinate (length unit) sets the tracking-noise floor.
    An option left at None takes the library's default, the command's and a pipeline's
    (one definition: ``FitParams``). Returns a :class:`Fit`; ``to`` applies to its
    scatter table."""
    src, name = _input_path(tracks_or_kinematics, "input")
    out = _scratch("fit", ".json")
    given = dict(
        diameter=diameter,
        bar_speed=bar_speed,
        starts=list(starts) if starts is not None else None,
        lags=list(lags) if lags is not None else None,
        rc_over_d=rc_over_d,
        method=method,
        bins_per_decade=bins_per_decade,
        min_bin_count=min_bin_count,
        bootstrap=bootstrap,
        seed=seed,
        eta_range=eta_range,
        position_noise=position_noise,
    )
    rep = _call(
        "fit",
        input=str(src),
        output=str(out),
        rename={str(src): name} if name else {},
        **{k: v for k, v in given.items() if v is not None},
    )
    f = Fit(rep)
    f.path = out
    f.scatter = _convert(Table._read(Path(rep["scatter"]), None), to)
    return f


def crossover_figure(
    fits: Union[Fit, Dict[str, Fit]],
    path: Optional[Union[str, os.PathLike]] = None,
):
    """The D²min/R² against η^s figure (log–log; every sample, the binned curve, Eq. 19
    with the fitted Θ, η_c over the fitted range), rendered by the same code as the
    report, for one fit or several (``{"label": fit}``). Saved as ``path`` (.png, with an
    .svg beside it; default a scratch file). Returns an ``IPython.display.Image`` when
    IPython is present (a notebook shows it), else the PNG's path."""
    if isinstance(fits, Fit):
        fits = {"data": fits}
    stem = Path(path).with_suffix("") if path is not None else _scratch("crossover")
    saved = _call("crossover_figure", fits=[(k, str(f.path)) for k, f in fits.items()], stem=str(stem))
    png = Path(saved["png"])
    try:
        from IPython.display import Image
    except ImportError:
        return png
    return Image(filename=str(png))


def gofr(tracks: Any, frame: Optional[int] = None, r_max: float = 4.0, bins: int = 80, to: str = "polars"):
    """g(r) of one frame (default the first) around all, small and large grains (Li et
    al. Fig. 2), as ``pillar-pipe gofr``: ``r_over_d`` (r in units of the large diameter D,
    up to ``r_max``, ``bins`` bins), ``g_all``, ``g_small``, ``g_large`` (dimensionless).
    Open edges: only centres r_max inside the hull count."""
    src, name = _input_path(tracks, "tracks")
    out = _scratch("gofr", ".parquet")
    _call("gofr", input=str(src), output=str(out), frame=frame, r_max=r_max, bins=bins,
          rename={str(src): name} if name else {})
    return _convert(Table._read(out, "gofr"), to)


class SimRun(dict):
    """A simulation's report (its ``manifest.json``) as a dict, with ``dir`` (the output
    directory) and its tables by name: ``run["tracks"]`` is a :class:`Table`."""

    dir: Path
    _to: str

    def table(self, name: str, to: Optional[str] = None):
        """The run's table ``name`` (``tracks``, ``bar_forces``, ``stress_strain``,
        ``series``, …; the ``.parquet`` files of ``dir``)."""
        tables = self.get("tables") or {}
        p = Path(tables[name]) if name in tables else self.dir / f"{name}.parquet"
        if not p.is_absolute() and not p.exists():
            p = self.dir / p
        if not p.exists():
            have = sorted(x.stem for x in self.dir.glob("*.parquet"))
            raise KeyError(f"no table '{name}' in {self.dir}; tables: {have}")
        return _convert(Table._read(p, name), to or self._to)

    def __missing__(self, key: str):
        return self.table(key)


def _sim_options(options: Dict[str, Any]) -> Dict[str, Any]:
    o = {}
    for k, v in options.items():
        if isinstance(v, Table):
            v = v._unchanged_file() or _input_path(v, k)[0]
        if isinstance(v, os.PathLike):
            v = str(v)
        if isinstance(v, tuple):
            v = list(v)
        o[k] = v
    return o


def simulate_pillar(out: Optional[Union[str, os.PathLike]] = None, to: str = "polars", **options) -> SimRun:
    """The granular-pillar DEM (Li et al. Sec. II), as ``pillar-pipe simulate pillar``:
    keywords as the pipeline's ``simulate`` keys — ``n`` grains, ``seed``, ``preset``
    (``"fast"`` or ``"paper"``), ``strain`` ε = ΔH/H0, ``packing`` (a tracks Table or
    path), ``set`` ({name: value} overrides, SI units), ``output_every``, ``forces_every``,
    ``normal_law``, … Unknown keywords raise ``ValueError``. Writes into ``out`` (default
    a scratch directory); Ctrl-C stops at the next step and saves a checkpoint there."""
    d = Path(out) if out is not None else _scratch("pillar")
    rep = _call("simulate_pillar", out=str(d), options=_sim_options(options))
    r = SimRun(rep)
    r.dir, r._to = d, to
    return r


def simulate_shear(out: Optional[Union[str, os.PathLike]] = None, to: str = "polars", **options) -> SimRun:
    """Frictionless disks under Lees–Edwards shear (Vågberg et al.), as ``pillar-pipe
    simulate shear``: keywords ``n``, ``phi`` (packing fraction), ``q`` (Q), ``rate``
    (γ̇ τ_e), ``model`` (``"cd"`` or ``"cdrot"``), ``strain`` (γ), ``dt`` (Δt/τ_e),
    ``seed``, ``output_every``, ``sample_every``, ``ramp``, … Tables: ``series``, ``tracks``
    (Lees–Edwards boxes in its sidecar), … Ctrl-C stops at the next step."""
    d = Path(out) if out is not None else _scratch("shear")
    rep = _call("simulate_shear", out=str(d), options=_sim_options(options))
    r = SimRun(rep)
    r.dir, r._to = d, to
    return r


def run(
    pipeline_path: Union[str, os.PathLike],
    runs_dir: Union[str, os.PathLike] = "runs",
    sets: Iterable[str] = (),
    force: Iterable[str] = (),
) -> Dict[str, Any]:
    """``pillar-pipe run PIPELINE --runs-dir RUNS_DIR`` (local executor): stages cached
    in ``RUNS_DIR/cache``, the run's report and figures in ``RUNS_DIR/<id>/``. ``sets``:
    ``STAGE.KEY=VALUE`` overrides; ``force``: stages to recompute. Returns the manifest."""
    return _call("run", pipeline=str(pipeline_path), runs_dir=str(runs_dir), sets=list(sets), force=list(force))
