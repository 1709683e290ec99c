#!/usr/bin/env bash
# Regenerate the golden values of the short pillar and sheared-disk runs
# (tests/data/golden/*.tsv, checked by tests/it/physics.rs golden_runs_reproduce_bit_for_bit).
# Run it only when a change of results is intended, and say in the commit why they changed:
#   scripts/golden.sh && git diff tests/data/golden/
set -euo pipefail
cd "$(dirname "$0")/.."
PP_GOLDEN_WRITE=1 cargo test --release --test it physics::golden_runs_reproduce_bit_for_bit -- --nocapture
