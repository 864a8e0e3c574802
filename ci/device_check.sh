#!/usr/bin/env bash
# The check a session with a real GPU lent (the `device` tool) runs as is, and that runs here on
# lavapipe too: the test suite on that device, bench-rays, the README's default render, what
# bayes spends between its passes (profile --timeline) and a short wang/bayes compare, with a
# summary in $OUT/summary.md.
#
#   ci/device_check.sh prepare   here, before the device call: builds the release binary and
#                                the test binaries (stripped, xz-packed) into .device/, and
#                                downloads the Vulkan loader and validation-layer .debs into
#                                .device/debs (the device machine starts bare and offline, and
#                                has no Rust toolchain). Prints the `run` call to make.
#   ci/device_check.sh [run]     anywhere: uses .device/ when it is there, else builds with
#                                cargo; runs the checks. Results go to $OUT (the device tool's
#                                folder) or, without it, to ./device-check-out.
#
# Env: DEVICE_CHECK_SKIP_TESTS=1 skips the suite (a quick re-run of the timings);
#      DEVICE_CHECK_STEP_LIMIT=S caps each step at S seconds (default 300: lavapipe needs ~210 s for the default render).
set -uo pipefail
cd "$(dirname "$0")/.."
root="$PWD"
pack="$root/.device"
mode="${1:-run}"

# Builds the test executables and lists them as "KIND-NAME<TAB>PATH", one per test target
# (lib-lightlearn, bin-lightlearn, test-cli, ...: the library's and the binary's unit tests
# share the crate's name).
list_tests() {
  cargo test --release --no-run --message-format=json |
    python3 -c '
import json, sys
for line in sys.stdin:
    m = json.loads(line)
    if m.get("reason") == "compiler-artifact" and m.get("executable") and m["profile"]["test"]:
        print(m["target"]["kind"][0] + "-" + m["target"]["name"] + "\t" + m["executable"])'
}

if [ "$mode" = prepare ]; then
  set -e
  grep -qx '/.device/' .git/info/exclude 2>/dev/null || echo '/.device/' >>.git/info/exclude
  rm -rf "$pack" && mkdir -p "$pack/bin" "$pack/debs"
  cargo build --release --quiet
  # The test executables cargo would run, one per test target (cargo prints them as JSON).
  list_tests 2>/dev/null >"$pack/tests.tsv"
  cp target/release/lightlearn "$pack/bin/lightlearn"
  while IFS=$'\t' read -r name exe; do cp "$exe" "$pack/bin/test-$name"; done <"$pack/tests.tsv"
  [ "$(cut -f1 "$pack/tests.tsv" | sort | uniq -d)" = "" ] || { echo "device_check: two test targets share a name" >&2; exit 1; }
  strip "$pack"/bin/*
  # tests/layout.rs compiles two kernels again for naga; the device machine has no
  # glslangValidator (it needs only libstdc++), so it travels too.
  mkdir -p "$pack/tools" && cp "$(command -v glslangValidator)" "$pack/tools/"
  # The binaries have this folder compiled in (CARGO_MANIFEST_DIR, CARGO_BIN_EXE_lightlearn).
  echo "$root" >"$pack/manifest_dir"
  # The commit the binaries were built from (the device's copy of .git can be older).
  commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
  [ -n "$(git status --porcelain --untracked-files=no 2>/dev/null)" ] && commit="$commit (with uncommitted changes)"
  echo "$commit" >"$pack/commit"
  (cd "$pack" && tar -cJf bin.tar.xz bin && rm -rf bin)
  # Debian 12's loader and validation layers (tests run with validation on). The device
  # tool's README gives the amd64 apt options; packages the image already has are skipped
  # there at unpack time.
  o=(-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/amd64-lists)
  mkdir -p /tmp/amd64-lists/partial
  if apt-get "${o[@]}" update -qq >/dev/null 2>&1; then
    (cd "$pack/debs" && apt-get "${o[@]}" download libvulkan1 vulkan-validationlayers libglvnd0 libegl1 libgl1 libglx0 libopengl0 libgles2 >/dev/null 2>&1) ||
      echo "device_check: warning: could not download the Vulkan .debs; the device needs its own loader" >&2
  else
    echo "device_check: warning: apt-get update failed; no .debs packed" >&2
  fi
  du -sh "$pack"
  echo "device_check: packed. Make the device call with carry [\".device\"] and the command:"
  echo "  bash ci/device_check.sh run"
  exit 0
fi

out="${OUT:-$root/device-check-out}"
mkdir -p "$out"
log="$out/log.txt"
: >"$log"
summary="$out/summary.md"
limit="${DEVICE_CHECK_STEP_LIMIT:-300}"
say() { echo "$*" | tee -a "$log"; }
t_start=$(date +%s)

# --- The Vulkan loader and driver -------------------------------------------------------
# Each packed .deb the machine does not have installed is unpacked into / (the device tool's
# README way): the loader, the validation layers and libglvnd. On an H200 (2026-12-04) with
# the loader and layers alone, NVIDIA's ICD (libGLX_nvidia.so.0) loaded but handed the loader
# no vkCreateInstance ("Found no drivers!"); with libglvnd and the EGL vendor file below
# (both added at once, so which one it needed is not known) it gave the device.
unpacked=0
for f in "$pack"/debs/*.deb; do
  [ -f "$f" ] || continue
  pkg=$(dpkg-deb -f "$f" Package 2>/dev/null)
  if [ "$(dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null)" != "install ok installed" ]; then
    dpkg -x "$f" / && say "unpacked $(basename "$f")" && unpacked=1
  fi
done
[ $unpacked = 1 ] && ldconfig
nvidia_icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
if [ -z "${VK_DRIVER_FILES:-}" ]; then
  if [ -f "$nvidia_icd" ]; then
    export VK_DRIVER_FILES="$nvidia_icd"
  elif [ -f /etc/vulkan/icd.d/nvidia_icd.json ]; then
    export VK_DRIVER_FILES=/etc/vulkan/icd.d/nvidia_icd.json
  elif [ -f /usr/share/vulkan/icd.d/nvidia_icd.json ]; then
    export VK_DRIVER_FILES=/usr/share/vulkan/icd.d/nvidia_icd.json
  else
    export VK_DRIVER_FILES=/usr/share/vulkan/icd.d/lvp_icd.x86_64.json
  fi
fi
say "VK_DRIVER_FILES=$VK_DRIVER_FILES"
# NVIDIA's EGL vendor file, which the device tool's README sets beside the ICD.
nvidia_egl=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
[ -f "$nvidia_egl" ] && [ -z "${__EGL_VENDOR_LIBRARY_FILENAMES:-}" ] && export __EGL_VENDOR_LIBRARY_FILENAMES="$nvidia_egl"
command -v nvidia-smi >/dev/null && nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader >>"$log" 2>&1

# --- The binaries -------------------------------------------------------------------------
if [ -f "$pack/bin.tar.xz" ]; then
  tmp=$(mktemp -d)
  tar -xJf "$pack/bin.tar.xz" -C "$tmp"
  bin="$tmp/bin"
  built_in=$(cat "$pack/manifest_dir")
  if [ "$built_in" != "$root" ]; then
    # The test binaries look for scenes/, shaders/ and the lightlearn binary under the folder
    # they were built in: make that folder this checkout, with the binary where cargo put it.
    if [ -e "$built_in" ] && [ ! -L "$built_in" ]; then
      say "device_check: $built_in exists and is not this checkout; tests that read files will fail"
    else
      mkdir -p "$(dirname "$built_in")" && ln -sfn "$root" "$built_in"
    fi
  fi
  mkdir -p "$root/target/release" && cp "$bin/lightlearn" "$root/target/release/lightlearn"
  tests=$(cut -f1 "$pack/tests.tsv")
  test_exe() { echo "$bin/test-$1"; }
else
  command -v cargo >/dev/null || {
    say "device_check: no .device/ pack and no cargo: run 'ci/device_check.sh prepare' here first"
    exit 2
  }
  say "building with cargo"
  cargo build --release --quiet 2>>"$log" || { say "build failed"; exit 1; }
  list_tests 2>>"$log" >"$out/tests.tsv"
  tests=$(cut -f1 "$out/tests.tsv")
  test_exe() { awk -F'\t' -v n="$1" '$1 == n { print $2 }' "$out/tests.tsv"; }
fi
ll="$root/target/release/lightlearn"
[ -d "$pack/tools" ] && export PATH="$pack/tools:$PATH"

rows=()
row() { rows+=("| $1 | $2 | $3 | $4 |"); }
step() { # name, then the command; its output goes to the log; returns its status
  local name="$1"; shift
  local t0=$(date +%s.%N)
  echo "=== $name: $*" >>"$log"
  timeout "$limit" "$@" >>"$log.step" 2>&1
  local rc=$?
  cat "$log.step" >>"$log"
  step_seconds=$(python3 -c "import time; print(f'{time.time() - $t0:.1f}')")
  return $rc
}

# --- The device the renderer picks ----------------------------------------------------------
probe() { # a 16x16 render whose report names the device (env: what to run it with)
  env "$@" "$ll" render scenes/cornell.glb --width 16 --height 16 --spp 1 --max-depth 1 \
    --out "$out/probe/p.exr" --mkdir -q >>"$log" 2>&1
  python3 -c "import json; print(json.load(open('$out/probe/p.json'))['device'])" 2>/dev/null || echo "none found"
  rm -rf "$out/probe"
}
device=$(probe)
say "device: $device"
# A discrete GPU gets bigger workloads below (lavapipe would take minutes to hours on them).
case "$device" in *llvmpipe* | "none found") on_gpu=0 ;; *) on_gpu=1 ;; esac
if [ "$device" = "none found" ]; then
  # Why the loader found no driver: the ICD file and the loader's own account of it.
  cat "$VK_DRIVER_FILES" >>"$log" 2>&1
  lib=$(ldconfig -p | awk '/libGLX_nvidia.so.0/ { print $NF; exit }')
  [ -n "$lib" ] && ldd "$lib" >>"$log" 2>&1
  probe VK_LOADER_DEBUG=error,warn,driver >/dev/null
fi

# --- The test suite on that device ------------------------------------------------------------
passed=0 failed=0 failed_names=()
if [ "${DEVICE_CHECK_SKIP_TESTS:-0}" != 1 ]; then
  t_tests=$(date +%s)
  for t in $tests; do
    : >"$log.step"
    if step "test $t" "$(test_exe "$t")"; then
      passed=$((passed + 1))
    else
      failed=$((failed + 1)) && failed_names+=("$t")
    fi
    counts=$(grep -E '^test result' "$log.step" | tail -1)
    say "test $t: ${counts:-no result line} (${step_seconds} s)"
  done
  detail="${#failed_names[@]} failing: ${failed_names[*]:-none}"
  row "test suite ($((passed + failed)) binaries)" "$([ $failed = 0 ] && echo pass || echo FAIL)" "$(($(date +%s) - t_tests))" "$detail"
fi

# --- bench-rays -----------------------------------------------------------------------------
: >"$log.step"
# bench-rays times each dispatch from submit to fence (tens of microseconds of overhead): on
# lavapipe 512x512 rays take ~0.1 s a dispatch, on a discrete GPU well under a millisecond,
# so there it traces 2048x2048 rays a dispatch to keep the overhead small.
rays_args=(--repeats 5)
[ "$on_gpu" = 1 ] && rays_args=(--width 2048 --height 2048 --repeats 10)
if step bench-rays "$ll" bench-rays "${rays_args[@]}"; then
  rays=$(python3 -c '
import re, sys
for l in open(sys.argv[1]):
    m = re.match(r"(\w+).*GPU\s+([\d.]+) Mrays/s.*CPU \((\d+) threads\)\s+([\d.]+) Mrays/s\s+GPU/CPU ([\d.]+)", l)
    if m:
        print(f"{m[1]}: GPU {m[2]} Mrays/s, CPU ({m[3]} threads) {m[4]}, ratio {m[5]}", end="; ")
' "$log.step")
  row bench-rays pass "$step_seconds" "$rays"
else
  row bench-rays FAIL "$step_seconds" "see log.txt"
fi
cp "$log.step" "$out/bench-rays.txt"

# --- The README's default render --------------------------------------------------------------
: >"$log.step"
if step "default render" "$ll" render --out "$out/render.exr" -q; then
  secs=$(python3 -c "import json; j = json.load(open('$out/render.json')); print(f\"{j['render_seconds']:.2f} s render, {j['total_seconds']:.2f} s total, {j['width']}x{j['height']} {j['spp']} spp\")")
  row "default render (lightlearn render)" pass "$step_seconds" "$secs"
else
  row "default render (lightlearn render)" FAIL "$step_seconds" "see log.txt"
fi
rm -f "$out/render.exr"

# --- Samples per second at a size that fills a GPU ------------------------------------------
# (the Mitsuba comparison of issue #18 is 96x72 on 2 CPU cores; a GPU needs far more pixels a
# pass to be busy: 1024x768 on rooms16, direct light per sampler and path traced with bayes).
# On the H200 64 spp took 0.02-0.07 s, too short to leave per-render costs out (2026-12-04),
# so a discrete GPU takes 1024 spp; lavapipe 64 (16-30 s each here).
tp_spp=64
[ "$on_gpu" = 1 ] && tp_spp=1024
for run in "uniform 1" "wang 1" "bayes 1" "bayes 8"; do
  set -- $run
  s=$1 depth=$2 spp=$tp_spp
  [ "$depth" = 8 ] && spp=$((tp_spp / 4))
  name="rooms16 1024x768 $spp spp, $s, depth $depth"
  : >"$log.step"
  if step "throughput $name" "$ll" render scenes/rooms16.glb --sampler "$s" --max-depth "$depth" \
    --width 1024 --height 768 --spp "$spp" --out "$out/tp/$s-$depth.exr" --mkdir -q; then
    tp=$(python3 -c "import json; j = json.load(open('$out/tp/$s-$depth.json')); print(f\"{j['render_seconds']:.2f} s render: {j['width'] * j['height'] * j['spp'] / j['render_seconds'] / 1e6:.1f} M samples/s\")")
    row "$name" pass "$step_seconds" "$tp"
  else
    row "$name" FAIL "$step_seconds" "see log.txt"
  fi
done
rm -rf "$out/tp"

# --- What bayes spends between its passes (profile --timeline) ---------------------------------
# Each dispatch, learning window's fold and growth point timed alone: on a discrete GPU a
# submission's wait (~0.55 ms on the H200) is where the learned sampler's extra time went
# (2026-12-04), on lavapipe the folds and growth points (docs/results.md, seventeenth session).
tl_args=(--width 128 --height 96 --spp 64)
[ "$on_gpu" = 1 ] && tl_args=(--width 512 --height 384 --spp 256)
: >"$log.step"
if step timeline "$ll" profile scenes/city.glb --sampler bayes --max-depth 1 "${tl_args[@]}" \
  --repeats 1 --timeline; then
  tl=$(python3 -c '
import sys
rows = [l.split("|") for l in open(sys.argv[1]) if l.startswith("| ")]
ms = lambda key: sum(float(r[4]) for r in rows if len(r) > 5 and r[1].strip().startswith(key))
parts = [("passes", "passes in"), ("folds", "folds after"), ("growth points", "growth points"), ("in all", "the steps together")]
print(", ".join("%s %.1f ms" % (name, ms(key)) for name, key in parts))
' "$log.step" 2>>"$log")
  row "timeline city ${tl_args[*]}, bayes, direct" pass "$step_seconds" "$tl"
else
  row "timeline city ${tl_args[*]}, bayes, direct" FAIL "$step_seconds" "see log.txt"
fi
cp "$log.step" "$out/timeline.txt"

# --- A short compare of wang and bayes -----------------------------------------------------------
: >"$log.step"
if step compare "$ll" compare scenes/rooms16.glb --samplers wang,bayes --spp 64 --reference-spp 1024 \
  --width 128 --height 96 --max-depth 1 --out "$out/compare" -q; then
  ratio=$(python3 -c "
import json
m = json.load(open('$out/compare/metrics.json'))
for c in m['comparisons']:
    print(c.get('budget', ''), '; '.join(f\"{r['sampler']} relMSE {r['rel_mse']:.3e} in {r.get('seconds', 0):.2f} s\" for r in c['runs']))
" 2>>"$log" | paste -sd ' ' -)
  row "compare rooms16 wang,bayes 64 spp, direct" pass "$step_seconds" "$ratio"
else
  row "compare rooms16 wang,bayes 64 spp, direct" FAIL "$step_seconds" "see log.txt"
fi
cp "$out/compare/metrics.json" "$out/compare-metrics.json" 2>/dev/null
rm -rf "$out/compare"

# --- The samplers at equal time on a discrete GPU ----------------------------------------------
# 512x384 against lightbvh references (reference noise subtracted); ~45 s on the H200
# (2026-12-04). Skipped on lavapipe, where the references alone would take hours.
if [ "$on_gpu" = 1 ]; then
  for run in "rooms16 1" "city 1" "hall 1" "strings 1" "rooms16 8" "hall 8"; do
    set -- $run
    sc=$1 depth=$2
    if [ "$depth" = 1 ]; then
      args=(--samplers wang,donikian,bayes --time 0.25 --spp 256 --reference-spp 32768)
    else
      args=(--samplers wang,bayes --time 0.5 --spp 64 --reference-spp 8192)
    fi
    name="compare $sc 512x384 depth $depth ${args[*]:0:6}"
    : >"$log.step"
    if step "$name" "$ll" compare "scenes/$sc.glb" "${args[@]}" --width 512 --height 384 \
      --max-depth "$depth" --out "$out/cmp" -q; then
      # MSE(wang) / MSE per sampler, the reference's noise subtracted ("raw" where the
      # corrected MSE fell below that noise).
      ratios=$(python3 -c "
import json
m = json.load(open('$out/cmp/metrics.json'))
for c in m['comparisons']:
    parts = []
    for r in c['runs'][1:]:
        v = r['speedup_corrected']
        parts.append(f\"{r['sampler']} {v:.2f}x\" if v is not None else f\"{r['sampler']} raw {r['speedup']:.2f}x\")
    print(c['kind'] + ' over wang: ' + ', '.join(parts), end='; ')
" 2>>"$log")
      row "$name" pass "$step_seconds" "$ratios"
    else
      row "$name" FAIL "$step_seconds" "see log.txt"
    fi
    rm -rf "$out/cmp"
  done
fi
rm -f "$log.step"

{
  echo "# lightlearn device check"
  echo
  echo "- device: $device"
  echo "- VK_DRIVER_FILES: $VK_DRIVER_FILES"
  echo "- commit: $(cat "$pack/commit" 2>/dev/null || git rev-parse --short HEAD 2>/dev/null || echo unknown)"
  echo "- total: $(($(date +%s) - t_start)) s"
  echo
  echo "| step | result | seconds | numbers |"
  echo "|---|---|---|---|"
  printf '%s\n' "${rows[@]}"
} >"$summary"
cat "$summary"
grep -q FAIL "$summary" && exit 1
exit 0
