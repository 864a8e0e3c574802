#!/usr/bin/env python3
"""What a switch does to one sampler on ten scenes: the four committed ones with learning to
do (rooms16, city, hall, strings) and the six of ci/bench_outside.py that are not in the
repository. For each scene, SEEDS renders with the defaults and SEEDS with FLAGS; the
variance of a render is the mean over pixels of the sample variance across seeds (no
reference needed; with the renderer's stratified passes this is the real error, which a
render's own `estimated_mse_of_mean` overstates 2-4x), "trimmed" leaves out each side's ten
worst pixels (strings: bulbs next to surfaces put half the variance in ten pixels), and the
time is the mean render seconds of the JSON reports. Ratios are defaults / FLAGS: above 1
the switch helps.

  python3 ci/bench_flags.py "FLAGS" [DEPTH] [SPP] [SEEDS] [OUT]
  python3 ci/bench_flags.py "--grid 16"                 # docs/results.md, seventh session
  python3 ci/bench_flags.py "--k-max 64" 1 256 4 bench-flags

SAMPLER=bayes by default; ONLY=REGEX keeps the scenes whose name matches; renders already in
OUT are reused (delete OUT after a rebuild); LIGHTLEARN_BIN=path renders with another binary
(e.g. a throw-away build; the defaults' renders of the same images can be copied over).
Reads the EXRs with Mitsuba 3's Bitmap (ci/setup.sh installs mitsuba); needs a release build
(cargo build --release).
"""
import hashlib
import importlib.util
import json
import os
import re
import subprocess
import sys

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
EXE = os.environ.get("LIGHTLEARN_BIN", os.path.join(ROOT, "target", "release", "lightlearn"))
COMMITTED = ["rooms16", "city", "hall", "strings"]


def outside():
    """ci/bench_outside.py as a module (its scenes and its argument reader)."""
    spec = importlib.util.spec_from_file_location(
        "bench_outside", os.path.join(ROOT, "ci", "bench_outside.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def scenes(out, only=None):
    """(name, path) of the committed scenes and of ci/bench_outside.py's, those matching the
    regular expression `only`; the outside ones are generated into OUT if missing."""
    listed = [(n, os.path.join(ROOT, "scenes", n + ".glb"), None) for n in COMMITTED]
    listed += [(n, os.path.join(out, n + ".glb"), args) for n, args in outside().SCENES]
    for name, scene, args in listed:
        if only and not re.search(only, name):
            continue
        if args and not os.path.exists(scene):
            subprocess.run([EXE, "scene", *args, "--out", scene], check=True,
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        yield name, scene


def renders(scene, name, flags, depth, spp, seeds, out, sampler):
    """The per-pixel variance over seeds (RGB mean) and the mean render seconds."""
    tag = hashlib.sha1(" ".join(flags).encode()).hexdigest()[:8]
    imgs, secs = [], []
    for seed in range(1, seeds + 1):
        f = os.path.join(out, f"{name}-{sampler}-{tag}-d{depth}-{spp}-{seed}.exr")
        if not (os.path.exists(f) and os.path.exists(f[:-4] + ".json")):
            subprocess.run([EXE, "render", scene, "--sampler", sampler, "--seed", str(seed),
                            "--spp", spp, "--width", "128", "--height", "96",
                            "--max-depth", depth, "-q", "--force", "--out", f, *flags],
                           check=True)
        imgs.append(np.array(mi.Bitmap(f), dtype=np.float64)[:, :, :3])
        secs.append(json.load(open(f[:-4] + ".json"))["render_seconds"])
    per_pixel = np.mean(np.var(np.stack(imgs), axis=0, ddof=1), axis=2)
    return per_pixel, float(np.mean(secs))


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    flags = sys.argv[1].split()
    depth, spp, seeds, out = outside().run_args(sys.argv[2:], "bench-flags")
    sampler = os.environ.get("SAMPLER", "bayes")
    only = os.environ.get("ONLY")
    print(f"`{sampler}` with `{' '.join(flags)}` against the defaults, depth {depth}, {spp} spp, "
          f"{seeds} seeds (defaults / flags)\n\n| scene | variance | ratio | trimmed | time, flags ÷ defaults "
          f"| variance × time |\n|---|---|---|---|---|---|", flush=True)
    for name, scene in scenes(out, only):
        base, tb = renders(scene, name, [], depth, spp, seeds, out, sampler)
        other, to = renders(scene, name, flags, depth, spp, seeds, out, sampler)
        trim = lambda v: float(np.mean(np.sort(v.ravel())[:-10]))
        vb, vo = float(np.mean(base)), float(np.mean(other))
        print(f"| {name} | {vb:.3e} → {vo:.3e} | {vb / vo:.2f}× | {trim(base) / trim(other):.2f}× "
              f"| {to / tb:.2f}× | {vb * tb / (vo * to):.2f}× |", flush=True)


if __name__ == "__main__":
    main()
