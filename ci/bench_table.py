#!/usr/bin/env python3
"""Markdown rows of the benchmark scripts (ci/bench_*.sh) from each `compare` report's
metrics.json under OUT_DIR: one row per (run, sampler) of the first comparison.

Usage: python3 ci/bench_table.py OUT_DIR [TIME_UNIT_LABEL]
The MSE ratio is MSE(wang)/MSE with the reference's noise subtracted, the raw ratio in
parentheses; µs is render time per pixel sample (a path, or one light sample with DI)."""
import json
import pathlib
import sys

root = pathlib.Path(sys.argv[1])
unit = sys.argv[2] if len(sys.argv) > 2 else "µs per pixel sample"
print(f"| run | sampler | spp in the budget | {unit} | MSE (noise out) | relMSE (noise out) | MSE(wang)/MSE (raw) | zero light samples |")
print("|---|---|---|---|---|---|---|---|")
for d in sorted(p for p in root.iterdir() if (p / "metrics.json").exists()):
    m = json.loads((d / "metrics.json").read_text())
    px = m["width"] * m["height"]
    for r in m["comparisons"][0]["runs"]:
        c = r["corrected"] or {"mse": float("nan"), "rel_mse": float("nan")}
        us = 1e6 * r["seconds"] / (r["spp"] * px)
        sp = r["speedup_corrected"]
        print(f"| {d.name} | {r['sampler']} | {r['spp']} | {us:.3f} | {c['mse']:.3e} | {c['rel_mse']:.3e} | "
              + (f"{sp:.2f}" if sp else "n/a") + f" ({r['speedup']:.2f}) | {100 * r['zero_sample_fraction']:.1f} % |")
