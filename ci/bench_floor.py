#!/usr/bin/env python3
"""The floor under any light choice, and how far each sampler is from it (issue #17).

A film's variance at equal spp splits by the law of total variance into the camera ray's
(what the pixel's value varies by where its rays land: the footprint) and the light
sample's given the ray. No light choice, however good, takes out the first part:
Var X >= Var E[X | ray] = F. F is measured, not modelled: `wang` with --first-light-samples
N averages N light samples at the first vertex, each from independent numbers, so its
variance is V_N = F + I / N (I: one independent light sample's), and two N give
F = (16 V16 - 4 V4) / 12. V2 checks the 1/N law (measured / predicted, near 1).

Then each sampler at its defaults (one stratified light sample): its variance V, wang's
over it (equal spp), the ceiling V_wang / F (what a perfect light choice would be at equal
spp over wang), and the share of wang's reducible variance V_wang - F that it takes out.
The variance of a render is the mean over pixels of the sample variance across SEEDS
renders of other seeds (no reference needed), as in ci/bench_flags.py, whose renders this
reuses (in OUT: the defaults' renders are shared).

  python3 ci/bench_floor.py [DEPTH] [SPP] [SEEDS] [OUT]
  python3 ci/bench_floor.py 1 256 4 bench-floor        # docs/results.md, twelfth session

SAMPLERS=wang,bayes (default wang,donikian,bayes); FROZEN=N adds `bayes` with statistics
learned over N spp (one render of seed 100, --save-stats) and then frozen (--load-stats,
--update-every 1000000): the model's ceiling as built; FROZEN_FLAGS="..." learns and renders
that column with these flags too (e.g. "--k-max 64 --tau 0.005": the ceiling of finer cuts,
docs/results.md, thirteenth session); ONLY=REGEX keeps the scenes whose name
matches (the committed rooms16, city, hall, strings and the six of ci/bench_outside.py,
generated into OUT). At DEPTH >= 2 F is the floor under the first vertex's light choice
alone (the later vertices': ci/bench_gi_split.py). The N = 16 renders take ~10x a default
render. Reads the EXRs with Mitsuba 3's Bitmap (ci/setup.sh installs mitsuba); needs a
release build (cargo build --release).
"""
import hashlib
import importlib.util
import os
import shlex
import subprocess
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def load(name):
    """A script of ci/ as a module."""
    spec = importlib.util.spec_from_file_location(name, os.path.join(ROOT, "ci", name + ".py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def main():
    flags_mod = load("bench_flags")
    depth, spp, seeds, out = flags_mod.outside().run_args(sys.argv[1:], "bench-floor")
    samplers = os.environ.get("SAMPLERS", "wang,donikian,bayes").split(",")
    only = os.environ.get("ONLY")
    if "wang" not in samplers:
        samplers = ["wang"] + samplers
    frozen = int(os.environ.get("FROZEN", "0"))
    frozen_flags = shlex.split(os.environ.get("FROZEN_FLAGS", ""))
    if frozen_flags and not frozen:
        sys.exit("FROZEN_FLAGS needs FROZEN=N (the spp the frozen statistics learn over)")
    tag = hashlib.sha1(" ".join(frozen_flags).encode()).hexdigest()[:8] if frozen_flags else ""
    label = f"bayes {' '.join(frozen_flags)} frozen after {frozen} spp".replace("  ", " ")
    others = [s for s in samplers if s != "wang"] + ([label] if frozen else [])
    head = " | ".join(f"`{s}` V, wang ÷ it, share taken" for s in others)
    print(f"Direct-light floor F (depth {depth}), {spp} spp, {seeds} seeds, 128×96\n\n"
          f"| scene | `wang` V | F | V2 measured ÷ predicted | ceiling V_wang ÷ F | {head} |\n"
          f"|---|---|---|---|---|{'---|' * len(others)}", flush=True)
    for name, scene in flags_mod.scenes(out, only):

        def variance(sampler, flags=()):
            v, _ = flags_mod.renders(scene, name, list(flags), depth, spp, seeds, out, sampler)
            return float(np.mean(v))

        v = {n: variance("wang", ["--first-light-samples", str(n)]) for n in (2, 4, 16)}
        floor = (16 * v[16] - 4 * v[4]) / 12
        independent = (v[4] - v[16]) / (1 / 4 - 1 / 16)
        check = v[2] / (floor + independent / 2)
        vw = variance("wang")
        cells = []
        for s in others:
            if s == label and frozen:
                stats = os.path.join(out, f"{name}-learned-{frozen}{'-' + tag if tag else ''}.stats")
                if not os.path.exists(stats):
                    subprocess.run([flags_mod.EXE, "render", scene, "--sampler", "bayes", "--seed",
                                    "100", "--spp", str(frozen), "--width", "128", "--height",
                                    "96", "--max-depth", depth, "-q", "--force", "--out",
                                    stats[:-6] + ".exr", "--save-stats", stats, *frozen_flags],
                                   check=True)
                vs = variance("bayes", [*frozen_flags, "--load-stats", stats,
                                        "--update-every", "1000000"])
            else:
                vs = variance(s)
            # Where F is within 5 % of wang's variance there is nothing to take.
            taken = f"{100 * (vw - vs) / (vw - floor):.0f} %" if vw - floor > 0.05 * vw else "–"
            cells.append(f"{vs:.3e}, {vw / vs:.2f}×, {taken}")
        ceiling = f"{vw / floor:.1f}×" if floor > 0 else "∞ (F ≤ 0: more seeds)"
        print(f"| {name} | {vw:.3e} | {floor:.3e} | {check:.2f} | {ceiling} | "
              f"{' | '.join(cells)} |", flush=True)


if __name__ == "__main__":
    main()
