#!/usr/bin/env bash
# The README's sampler table: `lightlearn compare` on every committed scene, equal time.
# Usage: ci/bench_compare.sh [SECONDS_PER_SAMPLER] [OUT_DIR]   (defaults: 10, bench-out)
# Prints one markdown row per scene and sampler from each report's metrics.json.
set -euo pipefail
cd "$(dirname "$0")/.."
t="${1:-10}"
out="${2:-bench-out}"
cargo build --release --quiet
for s in default cornell rooms rooms16 hall city strings; do
  ./target/release/lightlearn compare "scenes/$s.glb" --samplers uniform,power,lightbvh,wang,donikian,bayes --time "$t" \
    --reference-spp 2048 --width 256 --height 192 --max-depth 1 --out "$out/$s" -q
done
python3 - "$out" <<'PY'
import json, sys, pathlib
print("| scene | sampler | spp in the budget | relMSE | MSE | relMSE, noise out | speed-up vs uniform, noise out |")
print("|---|---|---|---|---|---|---|")
for s in ["default", "cornell", "rooms", "rooms16", "hall", "city", "strings"]:
    m = json.loads(pathlib.Path(sys.argv[1], s, "metrics.json").read_text())
    for r in m["comparisons"][0]["runs"]:
        c, sp = r["corrected"], r["speedup_corrected"]
        print(f"| {s} | {r['sampler']} | {r['spp']} | {r['rel_mse']:.3e} | {r['mse']:.3e} | {c['rel_mse']:.3e} | "
              + (f"{sp:.2f}" if sp else "n/a") + " |")
PY
