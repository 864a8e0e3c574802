#!/usr/bin/env bash
# Regenerates every committed scene. tests/committed_scenes.rs replays each `scene` line below
# and fails if a committed file differs from what the command writes.
set -euo pipefail
cd "$(dirname "$0")"
lightlearn() { cargo run --release --quiet -- "$@"; }

lightlearn scene rooms --lights 240 --seed 1 --out default.glb
lightlearn scene cornell --lights 6 --seed 1 --out cornell.glb
lightlearn scene rooms --lights 100 --seed 1 --out rooms.glb
lightlearn scene rooms --lights 400 --seed 1 --rooms 4x4 --out rooms16.glb
lightlearn scene hall --lights 64 --seed 1 --out hall.glb
lightlearn scene city --lights 2000 --seed 1 --out city.glb
lightlearn scene strings --lights 1000 --seed 1 --resolution 24 --out strings.glb
# Glossy variants (#7): cornell's tall box a white GGX metal, rooms16's floors rough metal.
lightlearn scene cornell --lights 6 --seed 1 --glossy 0.3 --out cornell-glossy.glb
lightlearn scene rooms --lights 400 --seed 1 --rooms 4x4 --glossy 0.3 --out rooms16-glossy.glb
# Animated (#16): a camera walk through 3x2 rooms; cars with spot headlights in a 2x2 city.
lightlearn scene rooms --lights 150 --seed 1 --rooms 3x2 --animate --out rooms-walk.glb
lightlearn scene city --lights 300 --seed 1 --blocks 2 --animate --out city-cars.glb
