#!/usr/bin/env python3
"""Bytes, time and error of `bake --precision auto` against full half (docs/precision.md).

    build/venv/bin/python tests/bench/precision_bytes.py --spectex build/src/spectex \\
        [--size 1024] [--max-de 0.5] [--out DIR]

Bakes one SIZE² photograph-like PNG (speed_vs_error.photographic_png, seed 7) on 380:780:5 (81
bins), zip, with --method basis and --method lattice --vertex-prior lhtss: in float (the
unrounded spectra), in half at full precision, and in half with --precision auto under the lights
below. Prints, per row, the file's bytes, the bake's wall time, and the worst ΔE00 against the
float bake of the same method under D65, A, FL2, FL11, D50 and LED-B3, computed here (numpy on the
bins with the shipped CIE tables; CIEDE2000 from colour-science), not by spectex. A benchmark, not
a test: nothing is asserted.
"""
import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
SPECTRAL = ROOT / "config" / "spectral"
sys.path.insert(0, str(HERE))
from speed_vs_error import photographic_png  # noqa: E402

LIGHTS = ["D65", "A", "FL2", "FL11", "D50", "LED-B3"]


def table(path):
    rows = [l for l in Path(path).read_text().splitlines() if l and not l.startswith("#")]
    data = []
    for l in rows:
        try:
            data.append([float(v) for v in l.split(",")])
        except ValueError:
            continue  # a header line
    return np.array(data)


def weights(lam, light):
    """3 x bins: XYZ of a reflectance on the bins under the light, white Y = 1."""
    obs = table(SPECTRAL / "observer_cie1931-2.csv")
    ill = table(SPECTRAL / f"illuminant_{light}.csv")
    cmf = np.stack([np.interp(lam, obs[:, 0], obs[:, i], left=0, right=0) for i in (1, 2, 3)])
    e = np.interp(lam, ill[:, 0], ill[:, 1], left=0, right=0)
    w = cmf * e
    return w / w[1].sum()


def read_spectra(path):
    import OpenImageIO as oiio
    inp = oiio.ImageInput.open(str(path))
    spec = inp.spec()
    names = list(spec.channelnames)
    px = inp.read_image(0, 0, 0, spec.nchannels, "float")
    inp.close()
    chans = [(float(n[2:-2].replace(",", ".")), i) for i, n in enumerate(names)
             if n.startswith("T.") and n.endswith("nm")]
    chans.sort()
    lam = np.array([c[0] for c in chans])
    s = px.reshape(-1, spec.nchannels)[:, [c[1] for c in chans]]
    return lam, s


def worst_de(ref, cand, lam):
    import colour
    out = {}
    for light in LIGHTS:
        w = weights(lam, light)
        white = w.sum(axis=1)
        xy = colour.XYZ_to_xy(white)
        a = colour.XYZ_to_Lab(ref @ w.T, xy)
        b = colour.XYZ_to_Lab(cand @ w.T, xy)
        out[light] = float(np.max(colour.delta_E(a, b, method="CIE 2000")))
    return out


def bake(spectex, src, out, args):
    t0 = time.perf_counter()
    p = subprocess.run([spectex, "bake", src, "-o", out, "--compression", "zip", *args],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        sys.exit(f"bake failed: {' '.join(args)}\n{p.stderr}")
    return wall, p.stderr


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--spectex", default=str(ROOT / "build" / "src" / "spectex"))
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--max-de", default="0.5")
    ap.add_argument("--out", default="")
    a = ap.parse_args()
    work = Path(a.out) if a.out else Path(tempfile.mkdtemp(prefix="spectex-precision-"))
    work.mkdir(parents=True, exist_ok=True)
    src = work / "photo.png"
    photographic_png(src, a.size)
    methods = {"basis": [], "lattice lhtss": ["--method", "lattice", "--vertex-prior", "lhtss"]}
    auto = ["--precision", "auto", "--lights", ",".join(LIGHTS), "--max-de", a.max_de]
    print(f"{a.size}x{a.size} photograph-like PNG, 380:780:5 (81 bins), zip; worst ΔE00 against "
          f"the method's float bake; --precision auto --max-de {a.max_de} under {','.join(LIGHTS)}")
    print(f"{'method':15} {'precision':9} {'MB':>8} {'s':>6}  " +
          " ".join(f"{l:>7}" for l in LIGHTS))
    for name, margs in methods.items():
        ref_path = work / f"{name.split()[0]}_float.exr"
        bake(a.spectex, src, ref_path, margs + ["--type", "float"])
        lam, ref = read_spectra(ref_path)
        for prec, pargs in [("full", []), ("auto", auto)]:
            out = work / f"{name.split()[0]}_{prec}.exr"
            wall, err = bake(a.spectex, src, out, margs + pargs)
            _, cand = read_spectra(out)
            de = worst_de(ref, cand, lam)
            print(f"{name:15} {prec:9} {out.stat().st_size / 1e6:8.2f} {wall:6.2f}  " +
                  " ".join(f"{de[l]:7.3f}" for l in LIGHTS), flush=True)
            for line in err.splitlines():
                if "--precision auto:" in line:
                    print("    " + line)
    print(f"(files in {work})")


if __name__ == "__main__":
    main()
