#!/usr/bin/env python3
"""Peers of `spectex bake`, written the way a user would: the same job in Python.

    peers_numpy_oiio.py numpy  IN.png BASIS.csv OUT.exr [--compression zip]
    peers_numpy_oiio.py colour IN.png BASIS.csv OUT.exr

`numpy`: read the PNG with OpenImageIO (PyPI wheel), decode sRGB with the IEC 61966-2-1 formula,
expand every pixel with numpy.einsum against the basis CSV (wavelength,r,g,b), write an N-channel
half EXR (channels T.<λ>nm, spectralLayoutVersion = 1.0) with OpenImageIO, ZIP compressed.

`colour`: the same read, decode and expansion, then colour-science's own writer for the layout,
colour.io.write_spectral_image_Fichet2021(components, path, "float16") (it also adds an sRGB
preview, as it always does).

Whole image in memory, one process: what a script does. Timed from outside (speed_vs_error.py runs
it under /usr/bin/time, interpreter start-up and imports included) and from inside: the last line
printed is a JSON object with the in-process stage times.
"""
import argparse
import json
import sys
import time

import numpy as np


def read_basis(path):
    rows = [l for l in open(path) if l.strip() and not l.startswith("#")]
    if not rows[0][0].isdigit():
        rows = rows[1:]  # header wavelength,r,g,b
    data = np.array([[float(v) for v in l.split(",")] for l in rows])
    return data[:, 0], data[:, 1:4]


def channel_name(wl):
    s = f"{wl:.6f}".rstrip("0").rstrip(".")
    return "T." + s.replace(".", ",") + "nm"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("peer", choices=["numpy", "colour"])
    ap.add_argument("input")
    ap.add_argument("basis")
    ap.add_argument("output")
    ap.add_argument("--compression", default="zip")
    a = ap.parse_args()

    t0 = time.perf_counter()
    import OpenImageIO as oiio

    stages = {}
    t = time.perf_counter()
    inp = oiio.ImageInput.open(a.input)
    if inp is None:
        sys.exit(f"cannot open {a.input}: {oiio.geterror()}")
    img = inp.read_image(oiio.FLOAT)[..., :3]  # 8-bit codes / 255
    inp.close()
    stages["read_s"] = time.perf_counter() - t

    t = time.perf_counter()
    lin = np.where(img <= 0.04045, img / 12.92, ((img + 0.055) / 1.055) ** 2.4).astype(np.float32)
    stages["decode_s"] = time.perf_counter() - t

    wl, B = read_basis(a.basis)
    t = time.perf_counter()
    spec = np.einsum("hwc,kc->hwk", lin, B.astype(np.float32))
    stages["expand_s"] = time.perf_counter() - t

    t = time.perf_counter()
    if a.peer == "numpy":
        h, w, n = spec.shape
        spec16 = spec.astype(np.float16)
        spect = oiio.ImageSpec(w, h, n, oiio.HALF)
        spect.channelnames = tuple(channel_name(x) for x in wl)
        spect.attribute("compression", a.compression)
        spect.attribute("spectralLayoutVersion", "1.0")
        out = oiio.ImageOutput.create(a.output)
        if out is None or not out.open(a.output, spect):
            sys.exit(f"cannot write {a.output}: {oiio.geterror()}")
        ok = out.write_image(spec16)
        out.close()
        if not ok:
            sys.exit(f"write failed: {oiio.geterror()}")
    else:
        import colour
        from colour.io import Image_Specification_Attribute, Specification_Fichet2021

        spec_f = Specification_Fichet2021(
            is_emissive=False,
            attributes=[
                Image_Specification_Attribute("spectralLayoutVersion", "1.0"),
                Image_Specification_Attribute("compression", a.compression),
            ],
        )
        ok = colour.io.write_spectral_image_Fichet2021({"T": (wl, spec)}, a.output, "float16", spec_f)
        if not ok:
            sys.exit("colour.io.write_spectral_image_Fichet2021 failed")
    stages["write_s"] = time.perf_counter() - t
    stages["total_s"] = time.perf_counter() - t0
    stages["peer"] = a.peer
    print(json.dumps(stages))


if __name__ == "__main__":
    main()
