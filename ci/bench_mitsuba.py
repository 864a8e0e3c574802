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

Usage: python3 ci/bench_mitsuba.py [SCENE.glb ...] [--width 96 --height 72 --spp 256] [--rays]
       (LIGHTLEARN_BIN=path: another lightlearn binary, e.g. an older build, to compare)

--rays also splits both into their rays: Mitsuba's llvm variant traces with Embree 3 (the
wheel ships libembree3.so), timed on the same camera rays (`ray_intersect_preliminary`) and
shadow rays to uniformly chosen emitters (`ray_test`) as its render traces; ours from
`lightlearn profile --sampler uniform --max-depth 1` (camera rays: the pass with everything
after them left out; shadow rays: what leaving them out saves, counted per light sample,
although a sample that faces away from its light traces none, so ours reads high where many
do).

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

# Embree's rays alone, the fastest of --repeats after a first (compiling) run each.
MITSUBA_RAYS = r"""
import sys, time, json
import mitsuba as mi
mi.set_variant("llvm_ad_rgb")
import drjit as dr
scene = mi.load_file(sys.argv[1])
spp, repeats = int(sys.argv[2]), int(sys.argv[3])
sensor = scene.sensors()[0]
W, H = sensor.film().size()
N = int(W * H * spp)
rng = mi.PCG32(size=N)
def best(f):
    ts = []
    for k in range(repeats + 1):
        t0 = time.perf_counter(); r = f(); dr.eval(r); dr.sync_thread(); ts.append(time.perf_counter() - t0)
    return min(ts[1:])
idx = dr.arange(mi.UInt32, N)
pos = (mi.Vector2f(mi.Float(idx % W), mi.Float((idx // W) % H))
       + mi.Vector2f(rng.next_float32(), rng.next_float32())) / mi.Vector2f(W, H)
ray, _ = sensor.sample_ray(0.0, 0.5, pos, mi.Point2f(0.5))
dr.eval(ray)
camera = best(lambda: scene.ray_intersect_preliminary(ray).t)
si = scene.ray_intersect(ray)
ds, _ = scene.sample_emitter_direction(si, mi.Point2f(rng.next_float32(), rng.next_float32()), False)
shadow_rays = si.spawn_ray_to(ds.p)
dr.eval(shadow_rays)
shadow = best(lambda: scene.ray_test(shadow_rays))
print(json.dumps({"rays": N, "camera": camera, "shadow": shadow}))
"""


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scenes", nargs="*", default=["scenes/rooms.glb", "scenes/city.glb"])
    ap.add_argument("--width", type=int, default=96)
    ap.add_argument("--height", type=int, default=72)
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--rays", action="store_true",
                    help="also time each one's camera and shadow rays alone (Mitsuba's: Embree 3)")
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
    rays = []
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
            if a.rays:
                rays.append((pathlib.Path(scene).stem, ray_rates(scene, xml, a, env)))
    if a.rays:
        print()
        print("M rays/s (ours on lavapipe: `profile --sampler uniform`; Mitsuba's: Embree 3)")
        print()
        print("| scene | camera rays, ours / Embree | ratio | shadow rays (ours: a light sample's), ours / Embree | ratio |")
        print("|---|---|---|---|---|")
        for name, (oc, osh, mc, msh) in rays:
            print(f"| {name} | {oc:.1f} / {mc:.1f} | {oc / mc:.2f} | {osh:.1f} / {msh:.1f} | {osh / msh:.2f} |")


def ray_rates(scene, xml, a, env):
    """Camera and shadow rays per second (millions): ours from the stage profile, Mitsuba's
    (Embree 3) on the same numbers of rays."""
    rays = a.width * a.height * a.spp
    m = subprocess.run([sys.executable, "-c", MITSUBA_RAYS, str(xml), str(a.spp), str(a.repeats)],
                       check=True, capture_output=True, text=True, env=env)
    mr = json.loads(m.stdout.strip().splitlines()[-1])
    p = subprocess.run([str(LIGHTLEARN), "profile", scene, "--sampler", "uniform", "--max-depth", "1",
                        "--width", str(a.width), "--height", str(a.height), "--spp", str(a.spp),
                        "--repeats", str(a.repeats)], check=True, capture_output=True, text=True)
    rows = {}
    for line in p.stdout.splitlines():
        cells = [c.strip() for c in line.split("|")]
        if len(cells) > 3 and cells[2].replace(".", "", 1).isdigit():
            rows[cells[1]] = (float(cells[2]), float(cells[3]))
    camera = rows["everything but the camera rays"][0]
    shadow = rows["shadow rays (all visible)"][1]
    return (rays / camera / 1e6, rays / shadow / 1e6, mr["rays"] / mr["camera"] / 1e6,
            mr["rays"] / mr["shadow"] / 1e6)


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
