#!/usr/bin/env python3
"""Memory, load and render cost of spectex textures in Mitsuba 3 against Mitsuba's own `bitmap`.

One scene: a 512x512 orthographic view of a rectangle textured with a photograph-like PNG
(speed_vs_error.py's `photographic_png`, 2048x2048 by default), `llvm_ad_spectral`, `direct`
integrator, a uniform `constant` D65 emitter, 64 spp. The rectangle's reflectance is one of

  - bitmap:  Mitsuba's `bitmap` texture of the PNG (Mitsuba upsamples the RGB itself),
  - spectra: the PNG baked by `spectex bake` with its defaults, every bin held (mode "spectra"),
  - rgb:     the same file held as RGB and the file's table (mode "rgb", the default for a file
             that records its table),
  - rgb::linear: the same with wavelength_filter "linear" (the value between two bins
             interpolated, where the default reads one of them, picked at random with its weight),
  - rgb:stochastic: the same with filter_type "stochastic" (one of the bilinear 4 texels picked at
             random with its weight: the bilinear filter on average, one texel's cost).

The limits below are checked on rgb, with the default filters (bilinear in uv, stochastic in
wavelength). Beside the times, each mode's noise: a pixel's standard deviation, from the last
two rounds' images (their difference over sqrt(2), RMS over the image), against the bitmap's.

Each mode runs in a process of its own (so that each peak is its own): it loads the scene (timed:
the texture's load is nearly all of it) and renders once (tracing and compiling the kernel;
reported). The process's peak resident memory (VmHWM) covers loading and rendering. The render
times are then taken in one more process holding every mode's scene: --runs rounds, each
rendering every scene once in turn, synchronised and timed as wall time, after an untimed first
round. A mode's render ratio is the median over the rounds of its time over the bitmap's in the
same round: on a shared machine the speed drifts by 15 % and more between processes and
minutes, and a ratio of neighbouring renders cancels most of it. Prints each mode's figures and
the ratios to `bitmap`; exits 1 if the rgb mode misses a limit: peak memory 1.5x, load 3x, render
1.5x the bitmap's (--max-memory, --max-load, --max-render). With --lookups, each mode's
texture is also timed alone, in a process of its own: eval() at the render's lookups, outside any
scene (in the render the BSDF evaluates it twice a sample, and the rest of the kernel is shared).

    DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 \\
    build/venv/bin/python tests/bench/mitsuba_speed.py --spectex build/src/spectex [--size 4096]

Not a test: not registered with ctest.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent

# What every child starts with: the plugin of this tree, the variant, a mode's texture, a scene
# around a texture and a timed render.
PREAMBLE = r"""
import json, sys, time, warnings
warnings.filterwarnings("ignore")
sys.path.insert(0, sys.argv[1])  # this tree's plugin before an installed one
import drjit as dr
import mitsuba as mi
mode, filename, res, spp, runs, variant = sys.argv[2], sys.argv[3], int(sys.argv[4]), int(sys.argv[5]), \
    int(sys.argv[6]), sys.argv[7]
mi.set_variant(variant)
import spectex_mitsuba
spectex_mitsuba.register()
def texture_of(mode, filename):
    if mode == "bitmap":
        return {"type": "bitmap", "filename": filename}
    # "rgb:stochastic": that mode with that filter_type; "rgb::linear": with that wavelength_filter
    mode, _, filt = mode.partition(":")
    filt, _, wfilt = filt.partition(":")
    return {"type": "spectex", "filename": filename, "mode": mode, "filter_type": filt or "bilinear",
            "wavelength_filter": wfilt or "stochastic"}
def make_scene(texture):
    return mi.load_dict({
        "type": "scene",
        "integrator": {"type": "direct"},
        "sensor": {
            "type": "orthographic",
            "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 1], target=[0, 0, 0], up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": res, "height": res, "rfilter": {"type": "box"}},
            "sampler": {"type": "independent", "sample_count": spp},
        },
        "light": {"type": "constant", "radiance": {"type": "d65"}},
        "plane": {"type": "rectangle", "to_world": mi.ScalarTransform4f().scale([1, -1, 1]),
                  "bsdf": {"type": "diffuse", "reflectance": texture}},
    })
def render(scene, seed):
    t = time.perf_counter()
    img = mi.render(scene, spp=spp, seed=seed)
    dr.eval(img)
    dr.sync_thread()
    return time.perf_counter() - t, img
"""

CHILD = PREAMBLE + r"""
def peak_kib():
    # VmHWM: this process's own high-water mark. ru_maxrss is not: Linux carries it across exec
    # from the parent (the benchmark, which made a 4096^2 texture in NumPy).
    with open("/proc/self/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith("VmHWM:"))
base = peak_kib()
t = time.perf_counter()
scene = make_scene(texture_of(mode, filename))
load = time.perf_counter() - t

first, img = render(scene, 0)
import numpy as np
mean = np.asarray(img).reshape(-1, np.asarray(img).shape[-1]).mean(axis=0).tolist()
print(json.dumps({"load": load, "first": first, "peak_mib": peak_kib() / 1024,
                  "base_mib": base / 1024, "mean": mean}))
"""

# Every mode's scene in one process, rendered in turn: argv[2] is {mode: filename} as JSON.
ROUNDS = PREAMBLE + r"""
import numpy as np
scenes = {m: make_scene(texture_of(m, f)) for m, f in json.loads(mode).items()}
for s in scenes.values():
    render(s, 0)
walls = {m: [] for m in scenes}
last = {m: [] for m in scenes}
for k in range(runs):
    for m, s in scenes.items():
        wall, img = render(s, k + 1)
        walls[m].append(wall)
        last[m] = (last[m] + [np.asarray(img)[..., :3].astype(np.float64)])[-2:]
# A pixel's noise: the RMS over pixels of the difference of the last two rounds' images (other
# seeds) over sqrt(2), as a share of the image's mean.
noise = {m: float(np.sqrt(np.mean((a - b) ** 2) / 2) / np.mean(a)) for m, (a, b) in last.items()}
print(json.dumps({"walls": walls, "noise": noise}))
"""

# The texture alone: eval() at the render's lookups (res^2 * spp positions, pixel by pixel, each
# pixel's spp in a row as the render orders them; 4 wavelengths a lookup, spread over 360-830 nm),
# outside any scene, so that its cost is seen apart from the rest of the render's kernel.
LOOKUPS = PREAMBLE + r"""
texture = mi.load_dict(texture_of(mode, filename))
n = res * res * spp
pixel = dr.arange(mi.UInt32, n) // spp
sampler = mi.load_dict({"type": "independent"})
sampler.seed(1, n)
si = dr.zeros(mi.SurfaceInteraction3f, n)
si.uv = mi.Point2f((mi.Float(pixel % res) + sampler.next_1d()) / res,
                   (mi.Float(pixel // res) + sampler.next_1d()) / res)
u = sampler.next_1d()
si.wavelengths = mi.Spectrum(*[360.0 + 470.0 * ((u + k / 4) - dr.floor(u + k / 4)) for k in range(4)])
dr.eval(si.uv, si.wavelengths)
def once():
    t = time.perf_counter()
    dr.eval(texture.eval(si))
    dr.sync_thread()
    return time.perf_counter() - t
first = once()
print(json.dumps({"first": first, "walls": [once() for _ in range(runs)]}))
"""


def run_mode(mode, filename, a, child=CHILD):
    r = subprocess.run([sys.executable, "-c", child, str(ROOT / "python"), mode, str(filename), str(a.res),
                        str(a.spp), str(a.runs), a.variant], capture_output=True, text=True)
    if r.returncode:
        sys.exit(f"{mode}: failed: {r.stderr.strip()[-2000:]}")
    return json.loads(r.stdout.strip().splitlines()[-1])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--spectex", default=str(ROOT / "build" / "src" / "spectex"), help="the spectex binary")
    ap.add_argument("--size", type=int, default=2048, help="texture size (default 2048)")
    ap.add_argument("--res", type=int, default=512, help="image size (default 512)")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--runs", type=int, default=5, help="timed rounds of renders (default 5)")
    ap.add_argument("--modes", default="bitmap,spectra,rgb,rgb::linear,rgb:stochastic",
                    help="which to run (default bitmap,spectra,rgb,rgb::linear,rgb:stochastic); MODE:FILTER gives "
                         "a spectex mode a filter_type (bilinear otherwise), MODE:FILTER:WFILTER also a "
                         "wavelength_filter (stochastic otherwise)")
    ap.add_argument("--max-memory", type=float, default=1.5)
    ap.add_argument("--max-load", type=float, default=3.0)
    ap.add_argument("--max-render", type=float, default=1.5)
    ap.add_argument("--variant", default="llvm_ad_spectral")
    ap.add_argument("--keep", help="keep the PNG and EXR in this folder instead of a temporary one")
    ap.add_argument("--lookups", action="store_true",
                    help="also time each mode's texture alone: eval() at the render's lookups, outside the scene")
    a = ap.parse_args()
    if a.runs < 2:
        ap.error("--runs must be at least 2: a mode's noise is measured from its last two rounds")
    sys.path.insert(0, str(HERE))
    from speed_vs_error import photographic_png

    print(f"{a.variant}, {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f}; "
          f"{a.res}x{a.res} at {a.spp} spp, texture {a.size}x{a.size}, {a.runs} timed rounds of renders")
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(a.keep or tmp)
        work.mkdir(parents=True, exist_ok=True)
        png, exr = work / f"photo{a.size}.png", work / f"photo{a.size}.exr"
        if not png.exists():
            photographic_png(png, a.size)
        if not exr.exists():
            t = time.perf_counter()
            r = subprocess.run([a.spectex, "bake", str(png), "-o", str(exr), "-q"], capture_output=True, text=True)
            if r.returncode:
                sys.exit(f"spectex bake failed: {r.stderr.strip()}")
            print(f"bake (defaults): {time.perf_counter() - t:.2f} s")
        print(f"PNG {png.stat().st_size / 1e6:.1f} MB, EXR {exr.stat().st_size / 1e6:.1f} MB")
        modes = a.modes.split(",")
        source = {m: png if m == "bitmap" else exr for m in modes}
        for mode in modes:
            results[mode] = res = run_mode(mode, source[mode], a)
            print(f"  {mode:8s} peak {res['peak_mib']:7.0f} MiB (before the scene {res['base_mib']:.0f}), "
                  f"load {res['load']:6.2f} s, first render {res['first']:6.2f} s, "
                  f"image mean {', '.join(f'{x:.4f}' for x in res['mean'][:3])}")
            if a.lookups:
                lk = run_mode(mode, source[mode], a, LOOKUPS)
                res["lookups"] = statistics.median(lk["walls"])
                print(f"  {mode:8s} texture alone: {a.res * a.res * a.spp:,} lookups, median {res['lookups']:.3f} s "
                      f"(runs {', '.join(f'{w:.3f}' for w in lk['walls'])})")
        rounds = run_mode(json.dumps({m: str(source[m]) for m in modes}), "-", a, ROUNDS)
        for mode in modes:
            walls = rounds["walls"][mode]
            results[mode]["walls"] = walls
            results[mode]["median"] = statistics.median(walls)
            results[mode]["noise"] = rounds["noise"][mode]
            print(f"  {mode:8s} render median {results[mode]['median']:.3f} s "
                  f"(rounds {', '.join(f'{w:.3f}' for w in walls)}); a pixel's noise "
                  f"{100 * rounds['noise'][mode]:.2f} % of the mean")
    if "bitmap" not in results:
        return 0
    b = results["bitmap"]
    status = 0
    print("\nratios to bitmap (peak memory, load, render: the median over the rounds; a pixel's noise):")
    for mode in results:
        if mode == "bitmap":
            continue
        m = results[mode]
        per_round = statistics.median(x / y for x, y in zip(m["walls"], b["walls"]))
        ratios = (m["peak_mib"] / b["peak_mib"], m["load"] / b["load"], per_round)
        print(f"  {mode:8s} memory {ratios[0]:.2f}x, load {ratios[1]:.2f}x, render {ratios[2]:.2f}x, "
              f"noise {m['noise'] / b['noise']:.3f}x"
              + (f"; texture alone {m['lookups'] / b['lookups']:.2f}x" if "lookups" in m and "lookups" in b else ""))
        if mode == "rgb":
            for what, r, limit in zip(("memory", "load", "render"), ratios, (a.max_memory, a.max_load, a.max_render)):
                if r > limit:
                    print(f"FAIL: rgb mode {what} {r:.2f}x the bitmap's (limit {limit:g}x)")
                    status = 1
    return status


if __name__ == "__main__":
    sys.exit(main())
