#!/usr/bin/env bash
# The README's variance attribution (issue #17): `lightlearn variance` on rooms16, city, hall
# and strings at 128×96, 256 spp, direct light — wang, donikian and bayes from scratch, and
# bayes with statistics learned over CONVERGE spp and then frozen — each split into the
# cluster choice, the light in the cluster, the point on the light and the pixel footprint.
# Usage: ci/bench_variance.sh [OUT_DIR] [CONVERGE] (defaults: bench-variance, 2048)
# ONLY=REGEX runs just the scenes whose name matches. EXTRA="..." adds switches to every run.
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-bench-variance}"
converge="${2:-2048}"
cargo build --release --quiet
mkdir -p "$out"
for s in rooms16 city hall strings; do
  [[ -z "${ONLY:-}" || "$s" =~ $ONLY ]] || continue
  echo "## $s"
  # shellcheck disable=SC2086
  /usr/bin/time -f "($s: %e s)" ./target/release/lightlearn variance "scenes/$s.glb" \
    --samplers wang,donikian,bayes --converge "$converge" --width 128 --height 96 --spp 256 \
    --out "$out/$s" ${EXTRA:-} 2>&1 | grep -v '^$' | grep -v 'decomposing' | grep -v ' % after '
  echo
done
