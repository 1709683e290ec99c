#!/usr/bin/env bash
# Longer fuzz campaigns than `cargo test` runs (issue 24): every target of tests/it/fuzz.rs
# with CASES cases per seed, for each SEED given (default: 5 fresh ones from the clock).
#   scripts/fuzz.sh                      # 20,000 cases x 5 seeds per target
#   scripts/fuzz.sh 100000 1 2 3         # 100,000 cases x seeds 1, 2, 3
#   FUZZ_FILTER="trackpy lammps" scripts/fuzz.sh   # some targets (test-name filters)
# A failing case is saved under the target directory's tmp/fuzz-failures/ and printed
# with its seed and index; `FUZZ_SEED=S cargo test --release --test it fuzz::` replays it.
# Needs no pillar-pipe binary: the readers run in-process.
set -u
cd "$(dirname "$0")/.."
cases=${1:-20000}
shift || true
seeds=("$@")
if [ ${#seeds[@]} -eq 0 ]; then
    base=$(date +%s)
    seeds=($base $((base + 1)) $((base + 2)) $((base + 3)) $((base + 4)))
fi
cargo test --release --test it --no-run || exit 2
failed=()
for s in "${seeds[@]}"; do
    echo "== seed $s, $cases cases per target"
    # One process per target: an abort (an allocation failure cannot be unwound) ends
    # only its own target, whose last case is then left in /tmp/pp-fuzz-TARGET-PID/.
    for t in ${FUZZ_FILTER:-trackpy canonical_csv canonical_parquet lammps pipeline compare pillar_checkpoint shear_checkpoint}; do
        log=$(mktemp)
        FUZZ_CASES=$cases FUZZ_SEED=$s cargo test --release --test it "fuzz::$t" \
            -- --nocapture >"$log" 2>&1
        rc=$?
        grep -E '^FUZZ|cases failed|^seed |FUZZ HANG' "$log"
        if [ $rc -ne 0 ]; then
            failed+=("$s/$t")
            echo "   seed $s, $t FAILED (exit $rc; full log: $log)"
        else
            rm -f "$log"
        fi
    done
done
if [ ${#failed[@]} -ne 0 ]; then
    echo "failing seed/target: ${failed[*]}"
    exit 1
fi
echo "all seeds passed"
