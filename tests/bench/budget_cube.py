#!/usr/bin/env python3
"""The precision budget over every 8-bit colour: the worst ΔE00 between a bake's stored spectra and
the same method's spectra in float, under each light, on all 16,777,216 colours of the cube.

    build/venv/bin/python tests/bench/budget_cube.py --spectex build/src/spectex [--options "..."]

The chooser of --precision auto searches on a sample and then checks its answer on every 8-bit
colour in its own C++ code (src/spectral/precision.cpp); default_decision.py checks 274,625 colours;
this checks them all, as a renderer sees them: the file's bins reconstructed linearly at 1 nm over
360-830 nm (end values held), integrated with the CIE 1931 2° observer under each light at 1 nm
(the tables of config/spectral/, linear between their rows, zero outside them), L*a*b* relative to
each light's own white (both spectra under the same light: no adaptation). --options are the
candidate's bake options (default: none, spectex bake's default, whose budget is 0.5 under D65, A,
FL2, FL11, D50, LED-B3); the reference is the same options with --type float. This is the
independent check of the chooser: NumPy, OpenImageIO's Python reader and colour-science's ΔE00. With --alpha every
colour is baked under an alpha of 1..254 (associated: T/A of the bake against T/A of the float
twin), which the recorded figure (opaque) does not cover.
The files are read 256 rows at a time, so memory stays near 1 GB. Beside each light's true worst
it prints the header's spectex:precisionWorstDe and their ratio. The chooser now records the file
against the method's own spectrum at 1 nm (the grid's error and the rounding together), a wider
comparison than this one (the rounding alone, against the same grid in float): the ratio is then a
share, not a proof of the bound. A float bake of the cube at 1 nm would be 31 GB, so the whole-cube
check of the wider figure is the chooser's own (precision.cpp), tested against double-precision
figures on a sample (tests/unit/precision_test.cpp). Exits 1 when a colour's rounding alone is over
the budget. Any grid (the file's own bins). About 2.5 minutes for the default (31 bins) on 2 cores,
longer with more bins. A benchmark, not a test.
"""
import argparse
import re
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import speed_vs_error as sve  # noqa: E402

LIGHTS = ["D65", "A", "FL2", "FL11", "D50", "LED-B3"]


def spectral_channels(spec):
    chans = sorted((float(m.group(1).replace(",", ".")), i) for i, n in enumerate(spec.channelnames)
                   if (m := re.fullmatch(r"T\.(\d+(?:,\d+)?)nm", n)))
    return np.array([w for w, _ in chans]), [i for _, i in chans]


def grid(exr):
    """The wavelengths of a spectral EXR's bins, ascending."""
    import OpenImageIO as oiio

    inp = oiio.ImageInput.open(str(exr))
    wl, _ = spectral_channels(inp.spec())
    inp.close()
    return wl


def rows(exr, step=256):
    """(y0, pixels × bins, in ascending wavelength) of a spectral EXR, `step` rows at a time; with an
    A channel, the bins divided by it (the straight spectrum of an associated file)."""
    import OpenImageIO as oiio

    inp = oiio.ImageInput.open(str(exr))
    spec = inp.spec()
    wl, idx = spectral_channels(spec)
    names = list(spec.channelnames)
    for y0 in range(0, spec.height, step):
        y1 = min(spec.height, y0 + step)
        px = inp.read_scanlines(0, 0, y0, y1, 0, 0, spec.nchannels, oiio.FLOAT).reshape(-1, spec.nchannels)
        s = px[:, idx].astype(np.float64)
        if "A" in names:
            s /= px[:, names.index("A")].astype(np.float64)[:, None]
        yield y0, s
    inp.close()


def cube_alpha_png(path):
    """All 16,777,216 8-bit sRGB colours, 4096×4096, each under an alpha of 1..254 (every value
    alike often, neighbouring codes under different ones), straight (PNG)."""
    import OpenImageIO as oiio

    c = np.arange(1 << 24, dtype=np.uint64)
    px = np.stack([(c >> 16) & 255, (c >> 8) & 255, c & 255, 1 + (c * 7919) % 254], -1).astype(np.uint8)
    out = oiio.ImageOutput.create(str(path))
    out.open(str(path), oiio.ImageSpec(4096, 4096, 4, oiio.UINT8))
    out.write_image(px.reshape(4096, 4096, 4))
    out.close()


DATA = HERE.parent.parent / "config" / "spectral"
FINE = np.arange(360.0, 830.0 + 1e-9, 1.0)


def table(name):
    """(wavelengths, values...) of a CSV of config/spectral/ (comment lines start with #)."""
    rows = [r for r in (DATA / name).read_text().splitlines() if r and not r.startswith("#")]
    data = np.array([[float(v) for v in r.split(",")] for r in rows if r[0].isdigit()])
    return data[:, 0], data[:, 1:]


def renderer_weights(light, bins):
    """(3 × bins XYZ weights, white XYZ) of a file's bins as a renderer sees them under `light`: the
    bins reconstructed linearly at 1 nm over 360-830 nm (ends held), the observer and the light at
    1 nm (the light zero outside its table), the perfect reflector at Y = 1."""
    wl, cmf = table("observer_cie1931-2.csv")
    cmf = np.stack([np.interp(FINE, wl, cmf[:, i]) for i in range(3)], 1)
    lw, e = table(f"illuminant_{light}.csv")
    e = np.where((FINE >= lw[0]) & (FINE <= lw[-1]), np.interp(FINE, lw, e[:, 0]), 0.0)
    Wf = (cmf * e[:, None]).T  # 3 × fine
    R = np.stack([np.interp(FINE, bins, np.eye(len(bins))[k]) for k in range(len(bins))], 1)
    norm = Wf[1].sum()
    return (Wf @ R) / norm, Wf.sum(1) / norm


def recorded_worst(exr):
    """{light: figure} of the header's spectex:precisionWorstDe ("D65 0.0908, A 0.148, ..."), {} without."""
    import OpenImageIO as oiio

    inp = oiio.ImageInput.open(str(exr))
    text = inp.spec().get_string_attribute("spectex:precisionWorstDe")
    inp.close()
    out = {}
    for item in filter(None, (t.strip() for t in text.split(","))):
        name, _, value = item.rpartition(" ")
        out[name] = float(value)
    return out


def main():
    import colour

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--spectex", default=str(HERE.parent.parent / "build/src/spectex"))
    ap.add_argument("--options", default="", help="the candidate's bake options (default: none)")
    ap.add_argument("--budget", type=float, default=0.5, help="the ΔE00 the bake should hold (default 0.5)")
    ap.add_argument("--alpha", action="store_true",
                    help="every colour under an alpha of 1..254, the files associated: T/A against T/A")
    a = ap.parse_args()
    opts = shlex.split(a.options)
    t0 = time.time()
    with tempfile.TemporaryDirectory(prefix="spectex-budget-") as d:
        d = Path(d)
        cube, stored, ref = d / "cube.png", d / "stored.exr", d / "float.exr"
        if a.alpha:
            cube_alpha_png(cube)
        else:
            sve.cube_full_png(cube)
        subprocess.run([a.spectex, "bake", cube, "-o", stored, "-q", *opts], check=True)
        subprocess.run([a.spectex, "bake", cube, "-o", ref, "-q", *opts, "--type", "float"], check=True)
        recorded = recorded_worst(stored)
        bins = grid(stored)  # any grid: the default's 400:700:10, or what --options give
        if len(bins) != len(grid(ref)) or np.abs(bins - grid(ref)).max() > 1e-6:
            raise SystemExit(f"{stored} and {ref}: the float twin has other bins")
        W, whites = {}, {}
        for L in LIGHTS:
            W[L], white = renderer_weights(L, bins)
            whites[L] = colour.XYZ_to_xy(white)
        worst = {L: 0.0 for L in LIGHTS}
        over = {L: 0 for L in LIGHTS}
        for (y, s), (_, f) in zip(rows(stored), rows(ref)):
            for L in LIGHTS:
                de = colour.delta_E(colour.XYZ_to_Lab(s @ W[L].T, whites[L]),
                                    colour.XYZ_to_Lab(f @ W[L].T, whites[L]), method="CIE 2000")
                worst[L] = max(worst[L], float(de.max()))
                over[L] += int((de > a.budget).sum())
            if y % 1024 == 0:
                print(f"  rows {y}..: " + ", ".join(f"{L} {worst[L]:.3f}" for L in LIGHTS), file=sys.stderr, flush=True)
    under = ", each under an alpha of 1..254 (T/A)" if a.alpha else ""
    print(f"# The budget over all 16,777,216 colours{under}: spectex bake {a.options or '(the default)'}\n")
    print("| light | worst ΔE00 | colours over " + f"{a.budget:g} | recorded spectex:precisionWorstDe | true / recorded |")
    print("|---|---|---|---|---|")
    for L in LIGHTS:
        rec = recorded.get(L)
        ratio = f"{worst[L] / rec:.3f}" if rec else "-"
        print(f"| {L} | {worst[L]:.4f} | {over[L]:,} | {rec if rec is not None else '-'} | {ratio} |")
    print(f"\n{time.time() - t0:.0f} s.")
    # Exit 1 when a colour's rounding alone is over the budget.
    return 0 if max(worst.values()) <= a.budget else 1


if __name__ == "__main__":
    sys.exit(main())
