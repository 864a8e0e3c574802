#!/usr/bin/env python3
"""Where a path tracer's variance sits: the light choice at the vertices after the first, or
the rest (the BSDF's directions, Russian roulette, the first vertex's direct light, the pixel
footprint). Renders `wang` and `bayes` with 1 and N next-event samples at the later vertices
(`render --indirect-light-samples N`, which averages N independent light samples there);
the variance over seeds is then A + B/N, so B (the later vertices' light choice) and A
follow from the two, and `wang`'s variance ÷ `bayes`'s A is what `bayes` would reach over
`wang` at equal spp with no light-choice variance left after the first vertex.

  python3 ci/bench_gi_split.py [N] [SPP] [SEEDS] [OUT]     (defaults 8, 64, 4, bench-gi-split)
  python3 ci/bench_gi_split.py 8 64 4                       # docs/results.md, ninth session

Depth 8, 128×96, the committed scenes rooms16, city, hall and the default scene (ONLY=REGEX
keeps the scenes whose name matches); renders already in OUT are reused (delete OUT after a
rebuild); LIGHTLEARN_BIN=path renders with another binary. Needs what ci/bench_flags.py
needs (a release build, Mitsuba 3's Bitmap to read the EXRs).
"""
import os
import re
import sys

import numpy as np

# ci/bench_flags.py renders a scene over seeds and takes the per-pixel variance: the same here.
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bench_flags as bf  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENES = ["rooms16", "city", "hall", "default"]


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 8
    spp = sys.argv[2] if len(sys.argv) > 2 else "64"
    seeds = int(sys.argv[3]) if len(sys.argv) > 3 else 4
    out = sys.argv[4] if len(sys.argv) > 4 else "bench-gi-split"
    if n < 2 or seeds < 2:
        sys.exit("N and SEEDS must be at least 2 (N: the samples to compare with 1; SEEDS: "
                 "the variance is taken across seeds)")
    only = os.environ.get("ONLY")
    os.makedirs(out, exist_ok=True)
    flags = ["--indirect-light-samples", str(n)]
    print(f"depth 8, {spp} spp, {seeds} seeds, 1 and {n} light samples at the later vertices; "
          f"variance = A + B/N\n\n| scene | `wang` 1 → {n} | `bayes` 1 → {n} | B share of 1: "
          f"`wang` / `bayes` | `bayes` over `wang`, equal spp | with no later light-choice "
          f"variance (`wang` ÷ `bayes`'s A) | time ×{n} ÷ ×1, `bayes` |\n"
          f"|---|---|---|---|---|---|---|", flush=True)
    for name in SCENES:
        if only and not re.search(only, name):
            continue
        scene = os.path.join(ROOT, "scenes", name + ".glb")
        v = {}
        for sampler in ["wang", "bayes"]:
            one, t1 = bf.renders(scene, name, [], "8", spp, seeds, out, sampler)
            many, tn = bf.renders(scene, name, flags, "8", spp, seeds, out, sampler)
            v1, vn = float(np.mean(one)), float(np.mean(many))
            b = (v1 - vn) * n / (n - 1)
            v[sampler] = (v1, vn, b, v1 - b, tn / t1)
        (w1, wn, wb, _, _), (b1, bn, bb, ba, bt) = v["wang"], v["bayes"]
        print(f"| {name} | {w1:.3e} → {wn:.3e} | {b1:.3e} → {bn:.3e} | {wb / w1:.0%} / "
              f"{bb / b1:.0%} | {w1 / b1:.2f}× | {w1 / ba:.2f}× | {bt:.2f}× |", flush=True)


if __name__ == "__main__":
    main()
