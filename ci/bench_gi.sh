#!/usr/bin/env bash
# Issue #7's benchmark: full global illumination (--max-depth 8) at equal time, `wang` against
# `bayes`, on rooms16 (the rooms instance of the learning benchmark), city and hall, against a lightbvh path-traced reference with its own
# noise subtracted. Usage: ci/bench_gi.sh [SECONDS_PER_SAMPLER] [OUT_DIR] [REFERENCE_SPP]
# (defaults: 60, bench-gi, 16384; references are rendered once and cached).
# Prints markdown rows from each report's metrics.json.
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
python3 - "$out" <<'PY'
import json, sys, pathlib
root = pathlib.Path(sys.argv[1])
print("| scene | sampler | spp in the budget | µs per path | MSE (noise out) | relMSE (noise out) | MSE(wang)/MSE (raw) | zero light samples |")
print("|---|---|---|---|---|---|---|---|")
for d in sorted(p for p in root.iterdir() if (p / "metrics.json").exists()):
    m = json.loads((d / "metrics.json").read_text())
    px = m["width"] * m["height"]
    for r in m["comparisons"][0]["runs"]:
        c = r["corrected"] or {"mse": float("nan"), "rel_mse": float("nan")}
        us = 1e6 * r["seconds"] / (r["spp"] * px)
        sp = r["speedup_corrected"]
        print(f"| {d.name} | {r['sampler']} | {r['spp']} | {us:.3f} | {c['mse']:.3e} | {c['rel_mse']:.3e} | "
              + (f"{sp:.2f}" if sp else "n/a") + f" ({r['speedup']:.2f}) | {100 * r['zero_sample_fraction']:.1f} % |")
PY
