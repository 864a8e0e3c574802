#!/usr/bin/env python3
"""Samples per second, lightlearn against Mitsuba 3 on the same CPU, side by side.

Direct light by light sampling alone, uniform light selection, one shadow ray per sample:
lightlearn `render --sampler uniform --max-depth 1` (on lavapipe or whatever Vulkan device
it picks) against Mitsuba 3's `direct` integrator with emitter_samples 1 and bsdf_samples 0
(its emitter sampling is uniform), variant llvm_ad_rgb, on the scene that
scripts/mitsuba_scene.py exports (the same geometry, camera, lights and Lambertian
materials). Render time only, the fastest of --repeats runs each; Mitsuba's first run
(its JIT compile) is not counted. Both images' means are printed as a check that the two
rendered the same thing.

Usage: python3 ci/bench_mitsuba.py [SCENE.glb ...] [--width 96 --height 72 --spp 256]
       (LIGHTLEARN_BIN=path: another lightlearn binary, e.g. an older build, to compare)

Needs: a release build (cargo build --release), `pip install mitsuba numpy`, and for
llvm_ad_rgb Debian's libllvm19 (`apt-get install libllvm19`; LLVM 15 crashes Dr.Jit's JIT),
found through DRJIT_LIBLLVM_PATH (default /usr/lib/x86_64-linux-gnu/libLLVM-19.so).
"""
import argparse
import json
import os
import pathlib
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parent.parent
LIGHTLEARN = pathlib.Path(os.environ.get("LIGHTLEARN_BIN", ROOT / "target" / "release" / "lightlearn"))

MITSUBA = r"""
import sys, time, json
import mitsuba as mi
mi.set_variant("llvm_ad_rgb")
import drjit as dr
xml, spp, repeats = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
scene = mi.load_file(xml)
times = []
img = None
for k in range(repeats + 1):
    t0 = time.perf_counter()
    img = mi.render(scene, spp=spp, seed=k)
    dr.eval(img)
    dr.sync_thread()
    times.append(time.perf_counter() - t0)
import numpy as np
a = np.array(img)
print(json.dumps({"seconds": min(times[1:]), "first": times[0], "mean": float(a[..., :3].mean())}))
"""


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scenes", nargs="*", default=["scenes/rooms.glb", "scenes/city.glb"])
    ap.add_argument("--width", type=int, default=96)
    ap.add_argument("--height", type=int, default=72)
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--repeats", type=int, default=3)
    a = ap.parse_args()
    if not LIGHTLEARN.exists():
        sys.exit(f"bench_mitsuba.py: {LIGHTLEARN} is missing: run `cargo build --release` first")
    env = dict(os.environ)
    env.setdefault("DRJIT_LIBLLVM_PATH", "/usr/lib/x86_64-linux-gnu/libLLVM-19.so")
    if not pathlib.Path(env["DRJIT_LIBLLVM_PATH"]).exists():
        sys.exit(f"bench_mitsuba.py: {env['DRJIT_LIBLLVM_PATH']} is missing: "
                 "`apt-get install libllvm19` (or set DRJIT_LIBLLVM_PATH)")
    for scene in a.scenes:
        if not pathlib.Path(scene).is_file():
            sys.exit(f"bench_mitsuba.py: error: {scene}: no such scene file")
    if min(a.width, a.height, a.spp, a.repeats) < 1:
        sys.exit("bench_mitsuba.py: error: --width, --height, --spp and --repeats must be at least 1")
    samples = a.width * a.height * a.spp
    print(f"{a.width}x{a.height}, {a.spp} spp, direct light, uniform light selection; "
          f"render seconds, fastest of {a.repeats}")
    print("| scene | lightlearn M samples/s | Mitsuba 3 llvm M samples/s | ratio | image means (ours / Mitsuba) |")
    print("|---|---|---|---|---|")
    for scene in a.scenes:
        with tempfile.TemporaryDirectory(prefix="bench_mitsuba_") as tmp:
            subprocess.run([sys.executable, str(ROOT / "scripts" / "mitsuba_scene.py"), scene,
                            "--width", str(a.width), "--height", str(a.height),
                            "--spp", str(a.spp), "--export-xml", tmp], check=True,
                           stdout=subprocess.DEVNULL)
            xml = pathlib.Path(tmp, "scene.xml")
            text = xml.read_text()
            direct = '<integrator type="direct"/>'
            assert direct in text, "mitsuba_scene.py wrote another integrator"
            xml.write_text(text.replace(direct, '<integrator type="direct">'
                                        '<integer name="emitter_samples" value="1"/>'
                                        '<integer name="bsdf_samples" value="0"/></integrator>'))
            m = subprocess.run([sys.executable, "-c", MITSUBA, str(xml), str(a.spp), str(a.repeats)],
                               check=True, capture_output=True, text=True, env=env)
            mi = json.loads(m.stdout.strip().splitlines()[-1])
            ours = []
            for k in range(a.repeats):
                out = pathlib.Path(tmp, f"ours{k}.exr")
                subprocess.run([str(LIGHTLEARN), "render", scene, "--sampler", "uniform",
                                "--max-depth", "1", "--width", str(a.width), "--height",
                                str(a.height), "--spp", str(a.spp), "--seed", str(k),
                                "--out", str(out), "-q"], check=True)
                ours.append(json.loads(out.with_suffix(".json").read_text()))
            best = min(r["render_seconds"] for r in ours)
            mean = mean_of_exr(pathlib.Path(tmp, "ours0.exr"))
            ll, ms = samples / best / 1e6, samples / mi["seconds"] / 1e6
            print(f"| {pathlib.Path(scene).stem} | {ll:.2f} | {ms:.2f} | {ll / ms:.2f} | "
                  f"{mean:.4g} / {mi['mean']:.4g} |")


def mean_of_exr(path):
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    import numpy as np
    return float(np.array(mi.Bitmap(str(path)))[..., :3].mean())


if __name__ == "__main__":
    try:
        main()
    except subprocess.CalledProcessError as e:
        # The failing tool has printed its own one-line error above.
        sys.exit(f"bench_mitsuba.py: error: {e.cmd[0]} {e.cmd[1] if len(e.cmd) > 1 else ''} failed (exit {e.returncode})")
