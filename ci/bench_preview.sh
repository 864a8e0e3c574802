#!/usr/bin/env bash
# The preview's responsiveness under Xvfb (issue #13): time from launch to the first
# presented image, and the frame time at rest and while moving (W held), read from the
# window title. Usage: ci/bench_preview.sh [SCENE] [WIDTH HEIGHT] [DEPTH]
set -euo pipefail
cd "$(dirname "$0")/.."
scene=${1:-scenes/default.glb}
w=${2:-640}
h=${3:-480}
depth=${4:-1}
export VK_DRIVER_FILES=${VK_DRIVER_FILES:-/usr/share/vulkan/icd.d/lvp_icd.x86_64.json}
cargo build --release --quiet
n=$(for i in $(seq 150 199); do [ -e /tmp/.X$i-lock ] || { echo $i; break; }; done)
Xvfb ":$n" -screen 0 1280x1024x24 -nolisten tcp >/dev/null 2>&1 &
xvfb=$!
trap 'kill $xvfb 2>/dev/null' EXIT
export DISPLAY=":$n"
sleep 1
log=$(mktemp)
target/release/lightlearn preview "$scene" --width "$w" --height "$h" --max-depth "$depth" 2>"$log" &
app=$!
win=""
for _ in $(seq 100); do win=$(xdotool search --name lightlearn 2>/dev/null | head -1 || true); [ -n "$win" ] && break; sleep 0.1; done
sleep 4
echo "at rest:  $(xdotool getwindowname "$win")"
xdotool windowfocus --sync "$win"
xdotool keydown w
for t in 1 2 3; do sleep 1; echo "moving $t s: $(xdotool getwindowname "$win")"; done
xdotool keyup w
sleep 3
echo "at rest again: $(xdotool getwindowname "$win")"
xdotool key Escape
wait $app
grep "first image" "$log"
