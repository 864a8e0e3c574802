#!/usr/bin/env bash
# Temporal coherence on the committed animated scenes (#16): per-frame variance from two
# seeds (no reference needed) and flicker, for wang, bayes --carry off and bayes --carry on,
# at equal spp. Usage: ci/bench_animation.sh [DEPTH] [SPP] (default 1 = direct light, 64).
set -euo pipefail
cd "$(dirname "$0")/.."
depth=${1:-1}
spp=${2:-64}
export VK_DRIVER_FILES=${VK_DRIVER_FILES:-/usr/share/vulkan/icd.d/lvp_icd.x86_64.json}
cargo build --release --quiet --example temporal
out=${TMPDIR:-/tmp}/bench_animation
rm -rf "$out"
for scene in rooms-walk city-cars; do
  for mode in "wang:--sampler wang" "bayes-off:--sampler bayes --carry off" "bayes-on:--sampler bayes --carry on"; do
    name=${mode%%:*}
    for seed in 1 2; do
      # shellcheck disable=SC2086
      target/release/lightlearn animate "scenes/$scene.glb" --out "$out/$scene-$name-$seed" \
        --fps 2 --spp "$spp" --width 96 --height 72 --max-depth "$depth" --seed "$seed" \
        --no-video -q ${mode#*:}
    done
    secs=$(python3 -c "import json,sys;d=json.load(open('$out/$scene-$name-1/animation.json'));print(round(sum(f['render_seconds'] for f in d['frames']),2))")
    echo "$scene $name (depth $depth, $spp spp, ${secs} s):"
    target/release/examples/temporal "$out/$scene-$name-1" "$out/$scene-$name-2"
  done
done
