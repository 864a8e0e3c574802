#!/usr/bin/env python3
"""Equal-spp variance of --light-point area against solid-angle (docs/results.md, "Triangle
lights sampled by solid angle"): for each scene and sampler, two seeds of each, interleaved;
the variance of one render is the mean over pixels of (a - b)^2 / 2 (no reference needed),
the time the mean render seconds of the two JSON reports.

  python3 ci/bench_light_point.py SCENES SAMPLERS DEPTH SPP [WxH]
  python3 ci/bench_light_point.py scenes/rooms16.glb,scenes/hall.glb wang,bayes 1 256

Reads the EXRs with Mitsuba 3's Bitmap (ci/setup.sh installs mitsuba). Writes into a
temporary folder; needs a release build (cargo build --release).
"""
import json
import os
import subprocess
import sys
import tempfile

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
EXE = os.path.join(ROOT, "target", "release", "lightlearn")


def main():
    if len(sys.argv) < 5:
        sys.exit(__doc__)
    scenes, samplers = sys.argv[1].split(","), sys.argv[2].split(",")
    depth, spp = sys.argv[3], sys.argv[4]
    w, h = sys.argv[5].split("x") if len(sys.argv) > 5 else ("128", "96")
    out = tempfile.mkdtemp(prefix="light_point.")

    def render(scene, sampler, lp, seed):
        f = f"{out}/{os.path.basename(scene)}-{sampler}-{lp}-{depth}-{seed}.exr"
        subprocess.run([EXE, "render", scene, "--sampler", sampler, "--light-point", lp,
                        "--seed", str(seed), "--spp", spp, "--width", w, "--height", h,
                        "--max-depth", depth, "-q", "--out", f], check=True)
        img = np.array(mi.Bitmap(f), dtype=np.float64)[:, :, :3]
        return img, json.load(open(f[:-4] + ".json"))["render_seconds"]

    for scene in scenes:
        for sampler in samplers:
            runs = {}
            for seed in (1, 2):
                for lp in ("area", "solid-angle"):
                    runs.setdefault(lp, []).append(render(scene, sampler, lp, seed))
            rows = []
            for lp in ("area", "solid-angle"):
                (a, ta), (b, tb) = runs[lp]
                rows.append((np.mean((a - b) ** 2) / 2, (ta + tb) / 2, np.mean(a + b) / 2))
            (va, ta, ma), (vs, ts, ms) = rows
            print(f"{os.path.basename(scene)} {sampler} depth {depth} {spp} spp: variance area "
                  f"{va:.3e} solid angle {vs:.3e} ({va / vs:.2f}x less); time {ta:.3f} vs "
                  f"{ts:.3f} s ({ts / ta:.2f}x); variance x time {va * ta / (vs * ts):.2f}; "
                  f"means {ma:.5f} {ms:.5f}", flush=True)


if __name__ == "__main__":
    main()
