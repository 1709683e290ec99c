#!/usr/bin/env bash
# The Python package's check (issue 37), run by `cargo test --release` (tests/it/python.rs):
# build the wheel from python/ with maturin, `pip install ./python` into a fresh virtual
# environment, and run python/tests (the CLI comparisons, the error paths, Ctrl-C, ASE,
# and the example notebook executed by nbclient).
#
# The third-party packages (maturin, polars, pandas, pytest, nbclient, ipykernel, ASE)
# come from PyPI once into a dependency venv under ~/.cache/pillar-pipe/python, rebuilt
# when REQUIREMENTS below change; each run's fresh venv sees them through a .pth file, so
# a warm run installs only the wheel. Cargo's target directory is the caller's
# (CARGO_TARGET_DIR), so the library is not compiled again for the wheel.
#
# Exit status: 0 passed; 77 cannot be checked here (no python3 or venv, no package
# index), with the reason on stderr; anything else: failed.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD

REQUIREMENTS="maturin>=1.7,<2 polars>=1.0 numpy pandas pytest nbclient nbformat ipykernel ase"
CACHE="${PILLAR_PIPE_CACHE:-$HOME/.cache/pillar-pipe}/python"
cannot() {
  echo "cannot check the Python package: $*" >&2
  exit 77
}

command -v python3 >/dev/null || cannot "no python3 on PATH"
mkdir -p "$CACHE"
# One check at a time per cache: sessions sharing a machine share ~/.cache, and the
# dependency venv and the check's venv below live there.
exec 9>"$CACHE/lock"
flock 9
key=$(printf '%s %s' "$REQUIREMENTS" "$(python3 -c 'import sys; print(sys.version)')" | sha256sum | cut -c1-16)
DEPS="$CACHE/deps-$key"
if [ ! -f "$DEPS/.complete" ]; then
  rm -rf "$DEPS"
  python3 -m venv "$DEPS" 2>/dev/null || cannot "python3 -m venv failed (Debian: apt-get install python3-venv)"
  # shellcheck disable=SC2086
  "$DEPS/bin/pip" install -q --cache-dir "$CACHE/pip" $REQUIREMENTS \
    || { rm -rf "$DEPS"; cannot "pip could not install $REQUIREMENTS from the package index"; }
  touch "$DEPS/.complete"
fi
SITE=$("$DEPS/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')

WORK=$(mktemp -d "${TMPDIR:-/tmp}/pillar-pipe-python.XXXXXX")
trap 'rm -rf "$WORK"' EXIT
# A fresh environment: the wheel goes in here; the dependencies are the cache's. Made
# anew each run but at one path: maturin hands the interpreter's path to pyo3's build
# script, and a new path each run rebuilt pyo3 and the extension (25 s warm).
VENV="$CACHE/venv-check"
rm -rf "$VENV"
# Without its own pip (ensurepip takes seconds): the cache's pip installs into it.
python3 -m venv --without-pip "$VENV" || cannot "python3 -m venv failed"
FRESH_SITE=$("$VENV/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')
echo "$SITE" >"$FRESH_SITE/pillar-pipe-deps.pth"

# What the README says a user types, without build isolation (maturin is the cache's,
# not downloaded per run) and without the index (every dependency must already be met).
PATH="$DEPS/bin:$PATH" "$DEPS/bin/pip" --python "$VENV/bin/python" install -q \
  --no-build-isolation --no-index ./python

# From outside the source tree, so `import pillar_pipe` is the installed package.
cd "$WORK"
"$VENV/bin/python" -c 'import pillar_pipe; print("pillar_pipe", pillar_pipe.__version__, "from", pillar_pipe.__file__)'
PILLAR_PIPE_ROOT="$ROOT" "$VENV/bin/python" -m pytest -q -p no:cacheprovider --durations=6 "$ROOT/python/tests"
