#!/usr/bin/env bash
# Installs the system packages lightlearn needs to build and test: a Vulkan loader, Mesa's
# lavapipe (the CPU Vulkan driver CI renders on), the GLSL compiler, SPIR-V tools and the
# Khronos validation layers (tests fail on any validation error). Idempotent: it installs only
# what is missing, so running it again is cheap.
set -euo pipefail

packages=(
  libvulkan1              # the Vulkan loader (ash loads it at run time)
  mesa-vulkan-drivers     # lavapipe: Vulkan on the CPU, the CI device
  vulkan-validationlayers # VK_LAYER_KHRONOS_validation, on in tests
  glslang-tools           # glslangValidator: GLSL -> SPIR-V in build.rs
  spirv-tools             # spirv-opt strips each render kernel in build.rs; spirv-val / spirv-dis
  vulkan-tools            # vulkaninfo, to see which devices the loader finds
  chromium                # headless browser: tests/report_browser.rs checks the HTML report
  python3-pip             # pip for Mitsuba 3, the independent renderer of tests/mitsuba.rs
  libllvm19               # Mitsuba's llvm_ad_rgb variant in ci/bench_mitsuba.py (LLVM 15 crashes its JIT)
  ffmpeg                  # animate writes DIR/animation.mp4 (tests/animate.rs checks it)
  xvfb                    # a virtual X display: tests/preview.rs opens the real preview window
  xdotool                 # ... and types keys into it
  x11-apps                # ... and captures it (xwd)
  pkg-config
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if ((${#missing[@]})); then
  echo "ci/setup.sh: installing ${missing[*]}"
  if [ "$(id -u)" -ne 0 ]; then
    if command -v sudo >/dev/null 2>&1; then
      SUDO=sudo
    else
      echo "ci/setup.sh: not root and no sudo. Ask an administrator to run:" >&2
      echo "  apt-get install -y ${missing[*]}" >&2
      exit 1
    fi
  else
    SUDO=
  fi
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
else
  echo "ci/setup.sh: system packages present"
fi

if ! command -v cargo >/dev/null 2>&1; then
  echo "ci/setup.sh: cargo not found. Install Rust (https://rustup.rs) and run this again." >&2
  exit 1
fi

# Mitsuba 3 (scalar_rgb) for tests/mitsuba.rs, the cross-check against an independent renderer;
# the test skips itself, saying so, when it is missing. Installed for the first python3 on
# PATH (the one the test runs); Debian's own python refuses plain pip (PEP 668), hence the
# second form.
if python3 -c "import mitsuba, numpy" >/dev/null 2>&1; then
  echo "ci/setup.sh: mitsuba present"
else
  echo "ci/setup.sh: installing mitsuba and numpy (pip)"
  python3 -m pip install --quiet mitsuba numpy 2>/dev/null ||
    python3 -m pip install --quiet --break-system-packages mitsuba numpy ||
    echo "ci/setup.sh: warning: pip install mitsuba failed; tests/mitsuba.rs will be skipped" >&2
fi

# openjd-cli (the Open Job Description reference runtime) for tests/farm.rs: `openjd check`
# and `openjd run` of the job templates `lightlearn farm` writes; skipped, saying so, without.
if python3 -m openjd --version >/dev/null 2>&1; then
  echo "ci/setup.sh: openjd-cli present"
else
  echo "ci/setup.sh: installing openjd-cli (pip)"
  python3 -m pip install --quiet openjd-cli 2>/dev/null ||
    python3 -m pip install --quiet --break-system-packages openjd-cli ||
    echo "ci/setup.sh: warning: pip install openjd-cli failed; tests/farm.rs will be skipped" >&2
fi

# The Khronos glTF validator (npm) for tests/gltf_validator.rs; skipped, with a note, without
# Node.js — that test then says it was skipped.
here="$(cd "$(dirname "$0")" && pwd)"
if command -v npm >/dev/null 2>&1; then
  if [ ! -f "$here/node_modules/gltf-validator/package.json" ]; then
    echo "ci/setup.sh: installing gltf-validator (npm) into ci/node_modules"
    (cd "$here" && npm install --no-audit --no-fund --loglevel=error >/dev/null) ||
      echo "ci/setup.sh: warning: npm install of gltf-validator failed; its test will be skipped" >&2
  fi
else
  echo "ci/setup.sh: note: Node.js/npm not found; the glTF validator test will be skipped" >&2
fi

# Lavapipe is the device CI renders on; say so when it is missing so a failing test is explained.
if ! ls /usr/share/vulkan/icd.d/lvp_icd.*.json >/dev/null 2>&1; then
  echo "ci/setup.sh: warning: lavapipe ICD not found under /usr/share/vulkan/icd.d" >&2
fi
