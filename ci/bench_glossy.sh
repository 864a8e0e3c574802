#!/usr/bin/env bash
# Issue #7's glossy benchmark: full global illumination (--max-depth 8) at equal time on
# rooms16-glossy (rooms16 with rough-metal floors, roughness 0.3): `wang` against `bayes` as the
# paper has it (`--brdf-select off`), against `bayes --brdf-aware --brdf-select off` (the
# observation includes the BRDF towards the light), and against the default `bayes`
# (`--brdf-select on`: cluster weights × the BRDF towards each cluster),
# against one lightbvh path-traced reference with its own noise subtracted.
# Usage: ci/bench_glossy.sh [SECONDS_PER_SAMPLER] [OUT_DIR] [REFERENCE_SPP]
# (defaults: 60, bench-glossy, 8192; the reference is rendered once and cached).
# Prints markdown rows from each report's metrics.json (ci/bench_table.py).
set -euo pipefail
cd "$(dirname "$0")/.."
t="${1:-60}"
out="${2:-bench-glossy}"
ref="${3:-8192}"
cargo build --release --quiet
run() { # name [switches...]
  local name=$1
  shift
  ./target/release/lightlearn compare scenes/rooms16-glossy.glb --samplers wang,bayes --time "$t" \
    --max-depth 8 --reference-spp "$ref" --width 128 --height 96 --out "$out/$name" -q "$@"
}
run bayes-brdf-select-off --brdf-select off
run brdf-aware --brdf-aware --brdf-select off
run brdf-select
python3 ci/bench_table.py "$out" "µs per path"
