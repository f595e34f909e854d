#!/usr/bin/env python3
"""Render cost of the spectex Mitsuba 3 texture against Mitsuba's own RGB `bitmap` texture.

One scene, two textures: a 512x512 orthographic view of a plane textured with a 2048x2048
photograph-like PNG (speed_vs_error.py's `photographic_png`), `llvm_ad_spectral`, `direct`
integrator, a uniform `constant` D65 emitter, 64 spp. The plane's reflectance is either

  - spectex: the PNG baked by `spectex bake` with its defaults, read by python/spectex_mitsuba, or
  - rgb:     Mitsuba's `bitmap` texture of the same PNG (Mitsuba upsamples the RGB itself).

Both scenes are loaded once, rendered once untimed (tracing and compiling the kernel; reported),
then rendered alternately, --runs times each; each render is synchronised (dr.eval + dr.sync_thread)
and timed as wall time. Prints best and median of each and the ratio spectex / rgb of the medians
(and of the bests); exits 1 if the median ratio exceeds --max-ratio (default 2.0: the spectral
texture may cost at most twice the RGB path).

    DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 \\
    build/venv/bin/python tests/bench/mitsuba_speed.py --spectex build/src/spectex

Not a test: not registered with ctest.
"""
import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(ROOT / "python"))  # this tree's plugin before an installed one

import warnings  # noqa: E402

warnings.filterwarnings("ignore")
import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402
import numpy as np  # noqa: E402

from speed_vs_error import photographic_png  # noqa: E402


def scene_dict(texture, res, spp):
    return {
        "type": "scene",
        "integrator": {"type": "direct"},
        "sensor": {
            "type": "orthographic",
            "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 1], target=[0, 0, 0], up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": res, "height": res, "rfilter": {"type": "box"}},
            "sampler": {"type": "independent", "sample_count": spp},
        },
        "light": {"type": "constant", "radiance": {"type": "d65"}},
        # y scaled by -1: Mitsuba's rectangle has v upwards, the image's first row is v = 0
        "plane": {"type": "rectangle", "to_world": mi.ScalarTransform4f().scale([1, -1, 1]),
                  "bsdf": {"type": "diffuse", "reflectance": texture}},
    }


def timed_render(scene, spp, seed):
    t = time.perf_counter()
    img = mi.render(scene, spp=spp, seed=seed)
    dr.eval(img)
    dr.sync_thread()
    return time.perf_counter() - t, img


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--spectex", default=str(ROOT / "build" / "src" / "spectex"), help="the spectex binary")
    ap.add_argument("--size", type=int, default=2048, help="texture size (default 2048)")
    ap.add_argument("--res", type=int, default=512, help="image size (default 512)")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--runs", type=int, default=3, help="timed renders of each scene, alternating (default 3)")
    ap.add_argument("--max-ratio", type=float, default=2.0,
                    help="exit 1 if median(spectex) / median(rgb) exceeds this (default 2.0)")
    ap.add_argument("--variant", default="llvm_ad_spectral")
    ap.add_argument("--keep", help="keep the PNG and EXR in this folder instead of a temporary one")
    a = ap.parse_args()

    mi.set_variant(a.variant)
    import spectex_mitsuba
    spectex_mitsuba.register()
    print(f"spectex_mitsuba from {Path(spectex_mitsuba.__file__).parent}; mitsuba {mi.__version__}, "
          f"drjit {dr.__version__}, {a.variant}, {os.cpu_count()} cores, load {os.getloadavg()[0]:.2f}")

    with tempfile.TemporaryDirectory() as tmp:
        work = Path(a.keep or tmp)
        work.mkdir(parents=True, exist_ok=True)
        png, exr = work / "photo.png", work / "photo.exr"
        if not png.exists():
            photographic_png(png, a.size)
        t = time.perf_counter()
        r = subprocess.run([a.spectex, "bake", str(png), "-o", str(exr), "-q"], capture_output=True, text=True)
        if r.returncode:
            sys.exit(f"spectex bake failed: {r.stderr.strip()}")
        print(f"bake {a.size}x{a.size} (defaults): {time.perf_counter() - t:.2f} s, {exr.stat().st_size / 1e6:.1f} MB")

        scenes = {}
        for name, tex in (("rgb", {"type": "bitmap", "filename": str(png)}),
                          ("spectex", {"type": "spectex", "filename": str(exr)})):
            t = time.perf_counter()
            scenes[name] = mi.load_dict(scene_dict(tex, a.res, a.spp))
            load = time.perf_counter() - t
            first, _ = timed_render(scenes[name], a.spp, 0)
            print(f"{name:8s} load {load:6.2f} s, first render (trace + compile) {first:6.2f} s")

        walls = {"rgb": [], "spectex": []}
        for run in range(a.runs):
            for name in ("rgb", "spectex") if run % 2 == 0 else ("spectex", "rgb"):
                w, _ = timed_render(scenes[name], a.spp, run + 1)
                walls[name].append(w)
                print(f"  run {run + 1} {name:8s} {w:6.3f} s")

    best = {k: min(v) for k, v in walls.items()}
    med = {k: statistics.median(v) for k, v in walls.items()}
    ratio_med, ratio_best = med["spectex"] / med["rgb"], best["spectex"] / best["rgb"]
    print(f"\n{a.res}x{a.res}, {a.spp} spp, texture {a.size}x{a.size}, {a.runs} runs each, wall s:")
    print(f"  rgb bitmap : best {best['rgb']:.3f}, median {med['rgb']:.3f}")
    print(f"  spectex    : best {best['spectex']:.3f}, median {med['spectex']:.3f}")
    print(f"  ratio spectex / rgb: median {ratio_med:.2f}, best {ratio_best:.2f} (limit {a.max_ratio:g})")
    if ratio_med > a.max_ratio:
        print(f"FAIL: the spectex texture costs {ratio_med:.2f}x the RGB path (> {a.max_ratio:g}x)")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
