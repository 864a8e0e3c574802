#!/usr/bin/env bash
# Issue #7's benchmark: full global illumination (--max-depth 8) at equal time, `wang` against
# `bayes`, on rooms16 (the rooms instance of the learning benchmark), city and hall, against a lightbvh path-traced reference with its own
# noise subtracted. Usage: ci/bench_gi.sh [SECONDS_PER_SAMPLER] [OUT_DIR] [REFERENCE_SPP]
# (defaults: 60, bench-gi, 16384; references are rendered once and cached).
# Prints markdown rows from each report's metrics.json (ci/bench_table.py).
set -euo pipefail
cd "$(dirname "$0")/.."
t="${1:-60}"
out="${2:-bench-gi}"
ref="${3:-16384}"
cargo build --release --quiet
for s in rooms16 city hall; do
  ./target/release/lightlearn compare "scenes/$s.glb" --samplers wang,bayes --time "$t" --max-depth 8 \
    --reference-spp "$ref" --width 128 --height 96 --out "$out/$s" -q
done
python3 ci/bench_table.py "$out" "µs per path"
