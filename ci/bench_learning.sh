#!/usr/bin/env bash
# The README's learning tables (issue #6): `lightlearn compare` at equal time on rooms16, city
# and hall — wang, donikian and bayes against one lightbvh reference per scene, with the
# reference's own noise subtracted — then the bayes ablations on rooms16 and city.
# Usage: ci/bench_learning.sh [SECONDS_PER_SAMPLER] [SECONDS_PER_ABLATION] [OUT_DIR] [REFERENCE_SPP]
#        (defaults: 60, 20, bench-learning, 65536; references are rendered once and cached:
#        about 10 minutes each at 65536 spp on 2 cores)
# ONLY=REGEX runs just the runs whose name matches (e.g. ONLY='^(rooms16|city)(-defaults)?$').
# Prints markdown rows from each report's metrics.json (and learning curves of the main runs).
# DI only (--max-depth 1): this is issue #6's benchmark.
set -euo pipefail
cd "$(dirname "$0")/.."
t="${1:-60}"
ta="${2:-20}"
out="${3:-bench-learning}"
ref="${4:-65536}"
cargo build --release --quiet
run() { # name scene seconds samplers [switches...]
  local name=$1 scene=$2 secs=$3 samplers=$4
  shift 4
  [[ -z "${ONLY:-}" || "$name" =~ $ONLY ]] || return 0
  ./target/release/lightlearn compare "scenes/$scene.glb" --samplers "$samplers" --time "$secs" \
    --reference-spp "$ref" --width 128 --height 96 --max-depth 1 --out "$out/$name" -q "$@"
}
for s in rooms16 city hall; do
  run "$s" "$s" "$t" wang,donikian,bayes
  run "$s-power" "$s" "$t" wang,bayes --in-cluster power
done
for s in rooms16 city; do
  run "$s-defaults" "$s" "$ta" wang,bayes
  run "$s-regression-off" "$s" "$ta" wang,bayes --regression off
  run "$s-target-mean" "$s" "$ta" wang,bayes --target mean
  run "$s-priors-off" "$s" "$ta" wang,bayes --priors off
  run "$s-brdf-aware" "$s" "$ta" wang,bayes --brdf-aware
  run "$s-control-variates" "$s" "$ta" wang,bayes --control-variates
  run "$s-k-max-64" "$s" "$ta" wang,bayes --k-max 64
  run "$s-tau-0.005" "$s" "$ta" wang,bayes --tau 0.005
  run "$s-normal-bins-off" "$s" "$ta" wang,bayes --normal-bins off
  for g in 16 64 128; do
    run "$s-grid-$g" "$s" "$ta" wang,bayes --grid "$g"
  done
done
python3 ci/bench_table.py "$out" "µs per sample·pixel"
python3 - "$out" <<'PY'
import json, sys, pathlib
root = pathlib.Path(sys.argv[1])
# Learning curves of the main runs: MSE × seconds at each checkpoint (constant for a sampler
# that does not learn; falling while bayes learns), with the reference's noise taken out.
print()
print("| run | sampler | MSE × s (noise out) at 1/64, 1/16, 1/4, 1 of the budget |")
print("|---|---|---|")
for d in sorted(p for p in root.iterdir() if (p / "metrics.json").exists() and "-" not in p.name):
    m = json.loads((d / "metrics.json").read_text())
    for r in m["comparisons"][0]["runs"]:
        noise = r["mse"] - r["corrected"]["mse"] if r["corrected"] else 0.0
        pts = [p for p in r["convergence"] if p["seconds"] > 0]
        T = pts[-1]["seconds"]
        row = []
        for f in (1 / 64, 1 / 16, 1 / 4, 1):
            p = min(pts, key=lambda p: abs(p["seconds"] - f * T))
            row.append(f"{(p['mse'] - noise) * p['seconds']:.2e} ({p['seconds']:.1f} s)")
        print(f"| {d.name} | {r['sampler']} | " + " · ".join(row) + " |")
PY
