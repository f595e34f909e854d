#!/usr/bin/env python3
"""MIP levels: filtering linear RGB then expanding, against filtering the spectra.

    build/venv/bin/python tests/bench/mip_filtering.py --spectex build/src/spectex [--json OUT]

Why (issue item "MIP levels and filtering"): `spectex bake --mipmap` makes level L+1 by
box-filtering level L's linear RGB and then expanding it to a spectrum. For --method basis the
expansion is linear, so this equals box-filtering the spectra. The lattice (piecewise-linear
tetrahedral interpolation) and jakob-hanika (sigmoid) are not linear: the two orders give
different spectra. For the exact lattice both have the same colour under D65 (a convex
combination of D65-exact spectra reproduces the averaged RGB), but not under other light. This
script measures that difference, so that the choice (filter RGB) is documented with numbers.

What: two 8-bit sRGB PNGs, --size² (default 256²; the run takes about 10 s on 2 cores) —
  photo    speed_vs_error.photographic_png(seed=7): smooth fields, hard-edged shapes, grain;
  stripes  worst case, a 4×4 grid of 64² blocks (size/4), two blocks per colour pair (red/cyan,
           green/magenta, blue/yellow, red/white, green/white, blue/white, black/white, random):
           "checker" = 1-pixel checkerboard (50/50 mix at level 1; 1-pixel stripes give the same
           2×2 averages), "dots" = one pixel of the first colour per 2×2 (25/75 mix). The
           "random" pair is a uniformly random 8-bit colour per pixel in both blocks.
Each is baked with `--mipmap --type float` (float: half rounding would blur the comparison) per
method. Reference: level 0 as read from the file, box-filtered 2×2 (float64) level by level, so
only the order of filtering and expansion differs. For every texel of levels 1..last: ΔE00
(CIE 1931 2°, 380:780:5, perfect reflector Y = 1, Bradford of the light's white to D65's,
L*a*b* relative to D65's white) under D65, A, FL2, FL11, D50 and LED-B3, and max |Δ spectrum|
(with its wavelength: the largest sit at the grid's ends, where the observer is nearly blind, so
they weigh little in ΔE00). Per colour pair of the worst case: level 1's max ΔE00 off D65. For
context, the memory of the alternative: an N-bin float pyramid instead of the RGBA one.
Statistics pool all texels of levels 1..last (level 1 holds 3/4 of them) and level 1 alone.
Checks (fail loudly): basis < 1e-3 ΔE00 under every light; lattice < 1e-3 ΔE00 under D65.
"""
import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import OpenImageIO as oiio  # noqa: E402

from method_accuracy import GRID, W65, Evaluator  # noqa: E402
from speed_vs_error import photographic_png, write_png  # noqa: E402

LIGHTS = ["D65", "A", "FL2", "FL11", "D50", "LED-B3"]
METHODS = {
    "basis": ["--method", "basis"],
    "lattice-9": ["--method", "lattice"],
    "lattice-5": ["--method", "lattice", "--lattice-size", "5"],
    "lattice-17": ["--method", "lattice", "--lattice-size", "17"],
    "jakob-hanika": ["--method", "jakob-hanika"],
}
PAIRS = [("red/cyan", (255, 0, 0), (0, 255, 255)), ("green/magenta", (0, 255, 0), (255, 0, 255)),
         ("blue/yellow", (0, 0, 255), (255, 255, 0)), ("red/white", (255, 0, 0), (255, 255, 255)),
         ("green/white", (0, 255, 0), (255, 255, 255)), ("blue/white", (0, 0, 255), (255, 255, 255)),
         ("black/white", (0, 0, 0), (255, 255, 255)), ("random", None, None)]


def stripes_png(path, size=256, seed=3):
    """The worst case described in the module docstring: a 4×4 grid of (size/4)² blocks; block
    k = 4·row + col holds pair k // 2, pattern k % 2 (0 checker, 1 dots)."""
    rng = np.random.default_rng(seed)
    side = size // 4
    y, x = np.mgrid[0:side, 0:side]
    first = [(x + y) % 2 == 0, (x % 2 == 0) & (y % 2 == 0)]
    img = np.zeros((size, size, 3), np.uint8)
    for k in range(16):
        _, a, b = PAIRS[k // 2]
        r, c = divmod(k, 4)
        if a is None:
            block = rng.integers(0, 256, (side, side, 3), dtype=np.uint8)
        else:
            block = np.where(first[k % 2][..., None], np.array(a, np.uint8), np.array(b, np.uint8))
        img[r * side:(r + 1) * side, c * side:(c + 1) * side] = block
    write_png(path, img)


def read_levels(path):
    """Every MIP level of a spectral EXR as float64 (h, w, bins), bins sorted by wavelength."""
    inp = oiio.ImageInput.open(str(path))
    assert inp, oiio.geterror()
    names = inp.spec().channelnames
    spectral = [i for i, n in enumerate(names) if n.startswith("T.") and n.endswith("nm")]
    wl = np.array([float(names[i][2:-2].replace(",", ".")) for i in spectral])
    order = [spectral[i] for i in np.argsort(wl)]
    levels, m = [], 0
    while inp.seek_subimage(0, m):
        levels.append(inp.read_image(format="float")[..., order].astype(np.float64))
        m += 1
    inp.close()
    return np.sort(wl), levels


def box2(a):
    h, w, n = a.shape
    return a.reshape(h // 2, 2, w // 2, 2, n).mean(axis=(1, 3))


def stats(d):
    return {"mean": float(d.mean()), "p99": float(np.percentile(d, 99)), "max": float(d.max())}


def compare(ev, levels):
    """ΔE00 per light and spectral |Δ| of the file's levels 1.. against filtered level-0 spectra.
    Returns the stats and, per light, the level-1 ΔE00 image (for the per-block breakdown)."""
    ref, de, de1, ds = levels[0], {k: [] for k in LIGHTS}, {}, []
    for L in range(1, len(levels)):
        ref = box2(ref)
        got = levels[L]
        assert got.shape == ref.shape, (L, got.shape, ref.shape)
        a, b = ref.reshape(-1, ref.shape[-1]), got.reshape(-1, got.shape[-1])
        d = np.abs(a - b)
        ds.append((float(d.max()), float(GRID[np.unravel_index(d.argmax(), d.shape)[1]])))
        for k in LIGHTS:
            de[k].append(ev.delta_e(k, a, b))
            if L == 1:
                de1[k] = de[k][0].reshape(got.shape[:2])
    out = {k: {"all": stats(np.concatenate(de[k])), "level1": stats(de[k][0])} for k in LIGHTS}
    top = max(ds)
    out["spectral_max_abs"] = {"all": top[0], "all_at_nm": top[1], "level1": ds[0][0]}
    return out, de1


def memory_cost(bins, side=4096):
    pyramid = 4 / 3
    rgba, spec = 4 * 4 * pyramid, bins * 4 * pyramid
    return {"bins": bins, "rgba_bytes_per_texel": rgba, "spectral_bytes_per_texel": spec,
            "side": side, "rgba_bytes": rgba * side * side, "spectral_bytes": spec * side * side}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--spectex", default=str(HERE.parent.parent / "build" / "src" / "spectex"))
    ap.add_argument("--size", type=int, default=256, help="side of both inputs (power of two, <= 512)")
    ap.add_argument("--json", help="write the results here")
    args = ap.parse_args()
    assert args.size >= 8 and args.size & (args.size - 1) == 0, "--size: a power of two >= 8"
    t0 = time.monotonic()

    ev = Evaluator()
    ev.W["D65"], ev.cat["D65"] = W65, np.eye(3)
    rows, pair_rows = [], {}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        inputs = {"photo": tmp / "photo.png", "stripes": tmp / "stripes.png"}
        photographic_png(inputs["photo"], args.size, seed=7)
        stripes_png(inputs["stripes"], args.size)
        for method, flags in METHODS.items():
            for name, png in inputs.items():
                exr = tmp / f"{name}-{method}.exr"
                subprocess.run([args.spectex, "bake", str(png), "-o", str(exr), "--mipmap",
                                "--type", "float", "-q", *flags], check=True)
                wl, levels = read_levels(exr)
                assert np.allclose(wl, GRID), "the bake's grid is not 380:780:5"
                res, de1 = compare(ev, levels)
                rows.append({"method": method, "input": name, **res})
                if name == "stripes":  # level-1 max ΔE00 per pair over the off-D65 lights
                    off = np.max([de1[k] for k in LIGHTS[1:]], axis=0)
                    b = args.size // 8  # a block's side at level 1
                    blocks = off.reshape(4, b, 4, b).max(axis=(1, 3)).reshape(16)
                    pair_rows[method] = [float(blocks[2 * p:2 * p + 2].max()) for p in range(len(PAIRS))]
                print(f"{method:13s} {name:8s} levels={len(levels)} "
                      f"A max={res['A']['all']['max']:.3f}", file=sys.stderr, flush=True)
        bins = levels[0].shape[-1]

    print("## ΔE00, file's level (RGB filtered, then expanded) vs level 0's spectra box-filtered\n")
    print(f"{args.size}² inputs; 'all' = every texel of levels 1..last; 'L1' = level 1 only.\n")
    print("| method | input | light | mean | p99 | max | L1 mean | L1 p99 | L1 max |")
    print("|---|---|---|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        for k in LIGHTS:
            a, l1 = r[k]["all"], r[k]["level1"]
            print(f"| {r['method']} | {r['input']} | {k} | {a['mean']:.4f} | {a['p99']:.4f} | "
                  f"{a['max']:.4f} | {l1['mean']:.4f} | {l1['p99']:.4f} | {l1['max']:.4f} |")
    print("\n## Spectral max |Δ| (reflectance) and the D65 control (max ΔE00)\n")
    print("| method | input | max abs Δ, all | at λ (nm) | max abs Δ, L1 | D65 max ΔE00 |")
    print("|---|---|---:|---:|---:|---:|")
    for r in rows:
        s = r["spectral_max_abs"]
        print(f"| {r['method']} | {r['input']} | {s['all']:.2e} | {s['all_at_nm']:.0f} | "
              f"{s['level1']:.2e} | {r['D65']['all']['max']:.1e} |")
    print("\n## Stripes, level 1: max ΔE00 over A, FL2, FL11, D50, LED-B3, per colour pair\n")
    print("| pair | " + " | ".join(METHODS) + " |")
    print("|---|" + "---:|" * len(METHODS))
    for p, (pair, _, _) in enumerate(PAIRS):
        print(f"| {pair} | " + " | ".join(f"{pair_rows[m][p]:.3f}" for m in METHODS) + " |")
    mem = memory_cost(bins)
    print(f"\n## Memory of the pyramid being filtered ({bins} bins, float, × 4/3 for the levels)\n")
    print(f"RGBA: {mem['rgba_bytes_per_texel']:.1f} B/texel, {mem['rgba_bytes'] / 2**20:.0f} MiB at "
          f"{mem['side']}²; spectra: {mem['spectral_bytes_per_texel']:.1f} B/texel, "
          f"{mem['spectral_bytes'] / 2**30:.2f} GiB at {mem['side']}² "
          f"({mem['spectral_bytes'] / mem['rgba_bytes']:.1f}×).")
    seconds = time.monotonic() - t0
    print(f"\nRuntime {seconds:.1f} s.")

    for r in rows:  # the comparison is set up right only if these hold
        lights = LIGHTS if r["method"] == "basis" else ["D65"] if r["method"].startswith("lattice") else []
        for k in lights:
            assert r[k]["all"]["max"] < 1e-3, f"{r['method']} {r['input']} {k}: {r[k]['all']['max']}"
    if args.json:
        Path(args.json).write_text(json.dumps({
            "size": args.size, "lights": LIGHTS, "methods": METHODS, "results": rows,
            "stripes_level1_max_off_d65_per_pair": {"pairs": [p[0] for p in PAIRS], **pair_rows},
            "memory": mem, "seconds": seconds}, indent=1))


if __name__ == "__main__":
    main()
