"""pillar_pipe against the CLI on the same input, bit for bit, and its error paths.

Run by scripts/python-check.sh (tests/it/python.rs), which sets PILLAR_PIPE_BIN (the CLI
built by the same `cargo test`) and PILLAR_PIPE_ROOT (the repository).
"""

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pandas as pd
import polars as pl
import pytest

import pillar_pipe as pp

ROOT = Path(os.environ.get("PILLAR_PIPE_ROOT", Path(__file__).resolve().parents[2]))
BIN = os.environ.get("PILLAR_PIPE_BIN", str(ROOT / "target" / "release" / "pillar-pipe"))
SAMPLE = ROOT / "data" / "sample" / "tracks.csv"
SETTINGS = ROOT / "data" / "sample" / "ingest.toml"


def cli(*args):
    r = subprocess.run([BIN, *map(str, args)], capture_output=True, text=True)
    assert r.returncode == 0, f"pillar-pipe {args}: {r.stdout}{r.stderr}"
    return r.stdout


def cli_error(*args):
    r = subprocess.run([BIN, *map(str, args)], capture_output=True, text=True)
    assert r.returncode != 0, f"pillar-pipe {args} should fail"
    return r.stderr


def assert_bitwise(a: pl.DataFrame, b: pl.DataFrame):
    """Same columns, types and every value's bits (NaN payloads included)."""
    assert a.columns == b.columns
    assert a.dtypes == b.dtypes
    assert a.height == b.height
    for c in a.columns:
        x, y = a[c], b[c]
        if x.dtype in (pl.Float64, pl.Float32):
            assert x.to_numpy().tobytes() == y.to_numpy().tobytes(), c
        else:
            assert x.to_list() == y.to_list(), c


@pytest.fixture(scope="module")
def cli_tracks(tmp_path_factory):
    d = tmp_path_factory.mktemp("cli")
    out = d / "tracks.parquet"
    cli("ingest", SAMPLE, "-o", out)  # ingest.toml beside the sample applies
    return out


@pytest.fixture(scope="module")
def py_tracks():
    # trackpy's DataFrame as a notebook holds it: pandas, read with pandas' defaults.
    df = pd.read_csv(SAMPLE)
    return pp.from_trackpy(df, **pp.ingest_settings(SETTINGS))


def test_settings_are_the_ingest_toml():
    s = pp.ingest_settings(SETTINGS)
    assert s == {
        "px_per_unit": 31.496063,
        "unit": "cm",
        "frame_time": 15.0,
        "origin_px": (165.98, 850.0),
        "bar_speed": 0.0084667,
    }


def test_from_trackpy_equals_cli_ingest(cli_tracks, py_tracks):
    assert isinstance(py_tracks, pl.DataFrame)
    assert_bitwise(py_tracks, pl.read_parquet(cli_tracks))
    side = json.loads(Path(str(cli_tracks) + ".meta.json").read_text())
    for k in ("length_unit", "time_unit", "frame_time", "bar_speed", "position_error_ep", "coordinate_frame"):
        assert py_tracks.meta[k] == side[k], k
    assert py_tracks.units["x"] == "cm" and py_tracks.units["time"] == "s"


def test_polars_input_equals_pandas_input(py_tracks):
    t = pp.from_trackpy(pl.read_csv(SAMPLE), **pp.ingest_settings(SETTINGS))
    assert_bitwise(t, py_tracks)


def test_kinematics_equals_cli(cli_tracks, py_tracks, tmp_path):
    out = tmp_path / "k.parquet"
    cli("kinematics", cli_tracks, "--lag", 2, "-o", out)
    k = pp.kinematics(py_tracks, lag=2)
    assert_bitwise(k, pl.read_parquet(out))
    assert k.units["d2min"] == "cm^2" and k.units["j2"] == "1/s"
    # A plain DataFrame (no sidecar) gives the same numbers: the time column carries
    # the frame time.
    k2 = pp.kinematics(pl.DataFrame(py_tracks), lag=2)
    assert_bitwise(k2, k)


def test_fit_equals_cli(cli_tracks, py_tracks, tmp_path):
    out = tmp_path / "fit.json"
    cli("fit", cli_tracks, "-o", out, "--bootstrap", 200)
    f = pp.fit(py_tracks, bootstrap=200)
    ref = json.loads(out.read_text())
    for k in ("theta", "eta_c", "theta_interval", "eta_c_interval", "n_points", "protocol", "range", "noise"):
        assert f[k] == ref[k], k
    assert_bitwise(f.scatter, pl.read_parquet(ref["scatter"]))
    # and from kinematics, as `fit KINEMATICS`
    kout = tmp_path / "k.parquet"
    cli("kinematics", cli_tracks, "--lag", 1, "-o", kout)
    cli("fit", kout, "-o", tmp_path / "fk.json", "--bootstrap", 100)
    fk = pp.fit(pp.kinematics(py_tracks, lag=1), bootstrap=100)
    ref = json.loads((tmp_path / "fk.json").read_text())
    assert (fk["theta"], fk["eta_c"]) == (ref["theta"], ref["eta_c"])
    # Every fit option, by the command's names: the same struct serves both.
    cli("fit", kout, "-o", tmp_path / "fm.json", "--bootstrap", 50, "--method", "points",
        "--eta-range", "all", "--bins-per-decade", 4, "--min-bin-count", 5, "--seed", 3)
    fm = pp.fit(pp.kinematics(py_tracks, lag=1), bootstrap=50, method="points",
                eta_range="all", bins_per_decade=4, min_bin_count=5, seed=3)
    ref = json.loads((tmp_path / "fm.json").read_text())
    assert (fm["theta"], fm["eta_c"], fm["method"]) == (ref["theta"], ref["eta_c"], ref["method"])
    with pytest.raises(ValueError, match="fit.eta_range"):
        pp.fit(py_tracks, eta_range="nonsense")


def test_gofr_equals_cli(cli_tracks, py_tracks, tmp_path):
    out = tmp_path / "g.parquet"
    cli("gofr", cli_tracks, "-o", out)
    assert_bitwise(pp.gofr(py_tracks), pl.read_parquet(out))


def test_pandas_on_request(py_tracks):
    k = pp.kinematics(py_tracks, lag=1, to="pandas")
    assert isinstance(k, pd.DataFrame)
    assert k.attrs["units"]["eta_s"] == "1" and k.attrs["units"]["d2min"] == "cm^2"
    assert k.attrs["units"]["dt"] == "s"
    assert k.attrs["meta"]["lags"] == [1]
    ref = pp.kinematics(py_tracks, lag=1)
    assert list(k.columns) == ref.columns
    assert k["d2min"].to_numpy().tobytes() == ref["d2min"].to_numpy().tobytes()


def test_missing_x_is_a_value_error_naming_it():
    df = pd.read_csv(SAMPLE).drop(columns=["x"])
    with pytest.raises(ValueError) as e:
        pp.from_trackpy(df, **pp.ingest_settings(SETTINGS))
    msg = str(e.value)
    assert 'missing required column(s) ["x"]' in msg and msg.startswith("DataFrame:"), msg


def test_lag_beyond_the_movie_is_a_value_error_naming_it(py_tracks, cli_tracks):
    with pytest.raises(ValueError) as e:
        pp.kinematics(py_tracks, lag=1000)
    msg = str(e.value)
    assert "lags [1000]" in msg and "frames 0..39" in msg, msg
    # the CLI's message, but for the file's name
    err = cli_error("kinematics", cli_tracks, "--lag", 1000, "-o", cli_tracks.with_name("x.parquet"))
    assert msg.replace("DataFrame", str(cli_tracks)) in err, (msg, err)


def test_bad_options_are_value_errors():
    with pytest.raises(ValueError, match="px-per-unit"):
        pp.from_trackpy(pd.read_csv(SAMPLE), px_per_unit=-1.0, unit="cm")
    with pytest.raises(ValueError, match="no_such_option"):
        pp.simulate_pillar(no_such_option=1)
    with pytest.raises(ValueError, match="convention"):
        pp.kinematics(pp.from_trackpy(pd.read_csv(SAMPLE), **pp.ingest_settings(SETTINGS)), convention="x")


def test_a_panic_is_a_runtime_error_not_a_crash():
    from pillar_pipe import _native

    with pytest.raises(RuntimeError, match="deliberate test panic"):
        _native.call("panic_for_test", "null")
    assert pp.schema("tracks")["table"] == "tracks"  # still alive


def test_simulate_pillar_equals_cli(tmp_path):
    opts = dict(n=60, strain=0.02, seed=3)
    cli("simulate", "pillar", "--n", 60, "--strain", 0.02, "--seed", 3, "--quiet", "-o", tmp_path / "cli")
    r = pp.simulate_pillar(out=tmp_path / "py", **opts)
    for table in ("tracks", "stress_strain", "bar_forces"):
        assert_bitwise(r[table], pl.read_parquet(tmp_path / "cli" / f"{table}.parquet"))
    assert r["tracks"].meta["provenance"]["source_format"] == "simulation"


@pytest.fixture(scope="module")
def sheared_xyz(tmp_path_factory):
    """A Lees–Edwards run exported with its kinematics by `pillar-pipe export`."""
    d = tmp_path_factory.mktemp("shear")
    run = d / "shear"
    r = pp.simulate_shear(out=run, n=64, strain=0.2, rate=1e-3, seed=2)
    tracks = r["tracks"]
    k = pp.kinematics(tracks, lag=1)
    kin_path = d / "k.parquet"
    k.write_parquet(kin_path)
    xyz = d / "shear.xyz"
    cli("export", run / "tracks.parquet", "--kinematics", kin_path, "-o", xyz)
    return xyz, tracks, k


def test_extxyz_opens_in_ase_as_written(sheared_xyz):
    # Regression: export wrote `species:I:1`, which ASE reads as element symbols and
    # fails on (ase/io/extxyz.py: s.capitalize()); it writes `type` (OVITO's Particle
    # Type too) with 1 small, 2 large.
    ase_io = pytest.importorskip("ase.io")
    frames = ase_io.read(sheared_xyz[0], index=":")
    assert set(np.unique(frames[-1].arrays["type"])) == {1, 2}


def test_extxyz_positions_d2min_and_tilted_cell_in_ase(sheared_xyz, tmp_path):
    ase_io = pytest.importorskip("ase.io")
    xyz, tracks, k = sheared_xyz
    frames = ase_io.read(xyz, index=":")
    boxes = {b["frame"]: b for b in tracks.meta["boxes"]}
    all_frames = sorted(tracks["frame"].unique().to_list())
    assert len(frames) == len(all_frames)
    last = int(k["frame"].max())
    atoms = frames[all_frames.index(last)]
    rows = tracks.filter(pl.col("frame") == last)
    order = np.argsort(atoms.arrays["id"])
    rows = rows.sort("particle")
    assert np.array_equal(atoms.arrays["id"][order], rows["particle"].to_numpy())
    assert np.array_equal(atoms.positions[order, 0], rows["x"].to_numpy())
    assert np.array_equal(atoms.positions[order, 1], rows["y"].to_numpy())
    kr = k.filter(pl.col("frame") == last).sort("particle")
    want = dict(zip(kr["particle"].to_list(), kr["d2min"].to_list()))
    got = {int(i): v for i, v in zip(atoms.arrays["id"], atoms.arrays["d2min"]) if int(i) in want}
    assert len(got) == len(want) > 0
    assert all((np.isnan(v) and np.isnan(want[i])) or v == want[i] for i, v in got.items())
    b = boxes[last]
    assert b["xy"] != 0.0, "a sheared frame has a tilt"
    # The export reduces the offset to |xy| <= L/2 (the same lattice).
    xy = b["xy"] - round(b["xy"] / b["lx"]) * b["lx"]
    # float precision: ASE's Cell keeps the lattice it parsed up to round-off
    tol = 1e-13 * b["lx"]
    assert np.allclose(atoms.cell[0], [b["lx"], 0.0, 0.0], rtol=0, atol=tol), atoms.cell
    assert np.allclose(atoms.cell[1], [xy, b["ly"], 0.0], rtol=0, atol=tol), atoms.cell
    assert list(atoms.pbc[:2]) == [True, True]


def test_ctrl_c_stops_a_long_simulation(tmp_path):
    script = textwrap.dedent(
        f"""
        import sys, time, pillar_pipe as pp
        print("started", flush=True)
        t0 = time.time()
        try:
            pp.simulate_pillar(out={str(tmp_path / "long")!r}, n=300, strain=0.3, preset="paper")
            print("finished", flush=True)
        except KeyboardInterrupt as e:
            print(f"interrupted after {{time.time() - t0:.1f}} s: {{e}}", flush=True)
            # the library's flag is cleared: the next call runs
            print("schema", pp.schema("tracks")["table"], flush=True)
            print(pp.gofr(pp.simulate_pillar(n=40, strain=0.005)["tracks"]).height, flush=True)
        """
    )
    p = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "started"
    # Into the run: its packing (Sec. II.A) does not poll the interrupt flag, so a
    # signal during it takes effect at the first step (as with the CLI).
    time.sleep(3.0)
    p.send_signal(signal.SIGINT)
    try:
        out, err = p.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        p.kill()
        raise AssertionError("Ctrl-C did not stop simulate_pillar within 120 s")
    assert p.returncode == 0, err
    print(out)
    assert "interrupted after" in out and "stopped by SIGINT" in out, out + err
    assert "finished" not in out
    assert "schema tracks" in out and out.strip().splitlines()[-1] == "80", out + err


def test_run_pipeline(tmp_path):
    (tmp_path / "p.toml").write_text(
        textwrap.dedent(
            f"""
            [pipeline]
            name = "py"
            root = {str(ROOT)!r}
            [exp.ingest]
            input = "data/sample/tracks.csv"
            [exp.kinematics]
            input = "exp.ingest"
            lags = [1]
            """
        )
    )
    m = pp.run(tmp_path / "p.toml", runs_dir=tmp_path / "runs")
    assert {s["name"] for s in m["stages"]} >= {"exp.ingest", "exp.kinematics"}
