#!/usr/bin/env python3
"""Samplers on scenes that are not in the repository: other light counts, layouts and seeds of
the five scene families, generated into OUT by `lightlearn scene`. For each scene and sampler,
SEEDS renders of other seeds; the variance of one render is the mean over pixels of the
sample variance across seeds (no reference needed), its time the mean render seconds of the
JSON reports. Variance x time is proportional to the MSE at equal time (unbiased samplers), so
the table gives each sampler's equal-time and equal-spp ratio against wang and donikian. A
few pixels can hold most of a scene's variance (strings5k: one to ten pixels, 77-95 %, whose
values jump 10-100x between seeds), so the median over pixels of the per-pixel variance (over
the pixels that vary: not the sky) is given too, as wang's divided by the sampler's.

  python3 ci/bench_outside.py [DEPTH] [SPP] [SEEDS] [OUT]
  python3 ci/bench_outside.py 1 256 4 bench-outside     # direct light (docs/results.md)
  python3 ci/bench_outside.py 8 64 4 bench-outside      # path traced

ONLY=REGEX keeps the scenes whose name matches; SAMPLERS=wang,donikian,bayes by default;
REUSE=1 reads renders already in OUT instead of rendering them again; WIDTH and HEIGHT set
the film (128×96 by default: a larger film gives each region more observations a pass, and
the learned samplers gain more in the same passes, docs/results.md, eleventh session);
COMMITTED=1 adds the committed scenes with learning to do (rooms16, city, hall, strings).
Heavy-tailed scenes (strings: tiny bulbs next to surfaces) need more seeds for a stable
variance. Reads the EXRs with Mitsuba 3's Bitmap (ci/setup.sh installs mitsuba); needs a
release build (cargo build --release).
"""
import json
import os
import re
import subprocess
import sys

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
EXE = os.path.join(ROOT, "target", "release", "lightlearn")

# (name, `lightlearn scene` arguments): none of these is a committed scene (scenes/make.sh).
SCENES = [
    ("rooms36", ["rooms", "--lights", "2000", "--seed", "7", "--rooms", "6x6"]),
    ("rooms4", ["rooms", "--lights", "60", "--seed", "3", "--rooms", "2x2"]),
    ("hall256", ["hall", "--lights", "256", "--seed", "5"]),
    ("city10k", ["city", "--lights", "10000", "--seed", "3"]),
    ("strings5k", ["strings", "--lights", "5000", "--seed", "2"]),
    ("cornell40", ["cornell", "--lights", "40", "--seed", "2"]),
]
# The committed scenes with learning to do (COMMITTED=1), rendered from scenes/.
COMMITTED = ["rooms16", "city", "hall", "strings"]


def run_args(argv, default_out):
    """[DEPTH] [SPP] [SEEDS] [OUT] from argv (defaults 1, 256, 4, default_out), as the bench
    scripts that take variances across seeds read them (also ci/bench_flags.py and
    ci/bench_floor.py); SEEDS below 2 is refused, OUT is made."""
    depth = argv[0] if len(argv) > 0 else "1"
    spp = argv[1] if len(argv) > 1 else "256"
    seeds = int(argv[2]) if len(argv) > 2 else 4
    out = argv[3] if len(argv) > 3 else default_out
    if seeds < 2:
        sys.exit("SEEDS must be at least 2 (the variance is taken across seeds)")
    os.makedirs(out, exist_ok=True)
    return depth, spp, seeds, out


def main():
    depth, spp, seeds, out = run_args(sys.argv[1:], "bench-outside")
    samplers = os.environ.get("SAMPLERS", "wang,donikian,bayes").split(",")
    only = os.environ.get("ONLY")
    reuse = os.environ.get("REUSE") == "1"
    width, height = os.environ.get("WIDTH", "128"), os.environ.get("HEIGHT", "96")
    size = "" if (width, height) == ("128", "96") else f"-{width}x{height}"
    scenes = [(n, None) for n in COMMITTED] if os.environ.get("COMMITTED") == "1" else []
    print(f"| scene | sampler | variance | seconds | equal spp / wang | equal time / wang "
          f"| equal time / donikian | median pixel / wang |\n|---|---|---|---|---|---|---|---|",
          flush=True)
    for name, args in scenes + SCENES:
        if only and not re.search(only, name):
            continue
        scene = os.path.join(ROOT, "scenes", name + ".glb") if args is None else os.path.join(out, name + ".glb")
        if args is not None and not os.path.exists(scene):
            subprocess.run([EXE, "scene", *args, "--out", scene], check=True,
                           stdout=subprocess.DEVNULL)
        rows = {}
        for sampler in samplers:
            imgs, secs = [], []
            for seed in range(1, seeds + 1):
                f = os.path.join(out, f"{name}-{sampler}-d{depth}-{spp}{size}-{seed}.exr")
                if not (reuse and os.path.exists(f) and os.path.exists(f[:-4] + ".json")):
                    subprocess.run([EXE, "render", scene, "--sampler", sampler, "--seed",
                                    str(seed), "--spp", spp, "--width", width, "--height", height,
                                    "--max-depth", depth, "-q", "--force", "--out", f],
                                   check=True)
                imgs.append(np.array(mi.Bitmap(f), dtype=np.float64)[:, :, :3])
                secs.append(json.load(open(f[:-4] + ".json"))["render_seconds"])
            per_pixel = np.mean(np.var(np.stack(imgs), axis=0, ddof=1), axis=2)
            rows[sampler] = (float(np.mean(per_pixel)), float(np.mean(secs)), per_pixel)
        # The median over the pixels that vary under some sampler (not the sky).
        varies = np.any(np.stack([r[2] for r in rows.values()]) > 0, axis=0)
        for sampler, (v, t, per_pixel) in rows.items():
            med = float(np.median(per_pixel[varies]))
            def ratio(base, time):
                if base not in rows:
                    return "–"
                bv, bt, _ = rows[base]
                return f"{bv * (bt if time else 1) / (v * (t if time else 1)):.2f}×"
            print(f"| {name} | {sampler} | {v:.3e} | {t:.2f} | {ratio('wang', False)} "
                  f"| {ratio('wang', True)} | {ratio('donikian', True)} "
                  f"| {np.median(rows['wang'][2][varies]) / med if 'wang' in rows else float('nan'):.2f}× |",
                  flush=True)


if __name__ == "__main__":
    main()
