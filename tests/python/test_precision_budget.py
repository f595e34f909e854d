"""The precision budget's recorded worst, checked by code that shares nothing with the chooser.

A bake with --precision auto records, per light, the worst ΔE00 over every 8-bit sRGB code between
its stored spectra, as a renderer sees them, and the same method's own spectrum at 1 nm
(spectex:precisionWorstDe): the grid's error and the rounding together. Here 65,536 random 8-bit
codes are baked twice (the budgeted half file, and --type float on 360:830:1, the method at 1 nm),
read back with OpenImageIO's Python bindings, seen as a renderer sees them (the bins linear at 1 nm
over 360-830 nm, ends held; the observer and the light at 1 nm from config/spectral/, NumPy's
interpolation) and compared with colour-science's CIEDE2000. No colour may exceed the recorded
figure, and the figure must be within the budget. (65,536 colours, not a million: the 1 nm float
file holds 471 bins a colour.) A chooser that checked only its 35,937-colour sample recorded
figures 1.4-1.9x below what random colours reach.
"""
import os
import re
import subprocess
import sys
import tempfile
import warnings

import numpy as np
import pytest

warnings.filterwarnings("ignore")
import colour  # noqa: E402
import OpenImageIO as oiio  # noqa: E402

SPECTEX = os.environ["SPECTEX_BINARY"]
SOURCE = os.environ["SPECTEX_SOURCE_DIR"]
sys.path.insert(0, os.path.join(SOURCE, "tests", "bench"))
import budget_cube as bc  # noqa: E402

SIZE = 256  # 65,536 random codes


@pytest.fixture(scope="module")
def codes_png():
    with tempfile.TemporaryDirectory() as d:
        rng = np.random.default_rng(20261206)
        px = rng.integers(0, 256, size=(SIZE, SIZE, 3), dtype=np.uint8)
        path = os.path.join(d, "codes.png")
        out = oiio.ImageOutput.create(path)
        out.open(path, oiio.ImageSpec(SIZE, SIZE, 3, oiio.UINT8))
        out.write_image(px)
        out.close()
        yield d, path


def spectra(exr):
    """(wavelengths, pixels × bins as float64) of a spectral EXR, and its header."""
    inp = oiio.ImageInput.open(exr)
    spec = inp.spec()
    chans = sorted((float(m.group(1).replace(",", ".")), i) for i, n in enumerate(spec.channelnames)
                   if (m := re.fullmatch(r"T\.(\d+(?:[.,]\d+)?)nm", n)))
    px = inp.read_image(0, 0, 0, spec.nchannels, oiio.FLOAT).reshape(-1, spec.nchannels)
    attrs = {a: spec.get_string_attribute(a) for a in
             ("spectex:precisionWorstDe", "spectex:precisionWorstCode", "spectex:precisionSample",
              "spectex:precisionLights", "spectex:precisionMaxDe")}
    inp.close()
    return np.array([w for w, _ in chans]), px[:, [i for _, i in chans]].astype(np.float64), attrs


def bake_twice(d, png, name, options, method):
    """The budgeted bake and the same method at 1 nm in float: (wl, spectra, header) of the first,
    (wl, spectra) of the second."""
    stored, ref = os.path.join(d, name + ".exr"), os.path.join(d, name + "-1nm.exr")
    fine = ["--type", "float", "--wavelengths", "360:830:1"]
    for out, args in ((stored, [*method, *options]), (ref, [*method, *fine])):
        r = subprocess.run([SPECTEX, "bake", png, "-o", out, "-q", *args],
                           capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
    wl, s, attrs = spectra(stored)
    wl_f, f, _ = spectra(ref)
    assert np.array_equal(wl_f, np.arange(360.0, 831.0))
    return wl, s, attrs, wl_f, f


def de_under(light, wl, s, wl_f, f):
    """ΔE00 per pixel under `light` between the stored spectra as a renderer sees them and the
    method at 1 nm."""
    W, white = bc.renderer_weights(light, wl)
    Wf, _ = bc.renderer_weights(light, wl_f)
    white_xy = colour.XYZ_to_xy(white)
    return colour.delta_E(colour.XYZ_to_Lab(s @ W.T, white_xy), colour.XYZ_to_Lab(f @ Wf.T, white_xy),
                          method="CIE 2000")


def by_light(text, value):
    """'D65 0.233, A 0.298' -> {'D65': value('0.233'), ...}"""
    out = {}
    for item in text.split(","):
        light, _, v = item.strip().rpartition(" ")
        out[light] = value(v)
    return out


def check(d, png, name, options, method=()):
    """options: the budgeted bake's; method: what makes the same method at 1 nm in float (--type
    float takes no budget)."""
    wl, s, attrs, wl_f, f = bake_twice(d, png, name, options, method)
    assert "16777216" in attrs["spectex:precisionSample"], attrs
    recorded = by_light(attrs["spectex:precisionWorstDe"], float)
    budget = float(attrs["spectex:precisionMaxDe"])
    assert list(recorded) == attrs["spectex:precisionLights"].split(","), attrs
    found = {}
    for light, rec in recorded.items():
        found[light] = float(de_under(light, wl, s, wl_f, f).max())
        # Tolerance: none. The recorded figure is rounded up from the chooser's; the two
        # colorimetries differ in summation order and in the 1 nm spectra's float32 storage (a
        # relative 1e-7, against the figure's margin of 1e-4 of itself).
        assert found[light] <= rec, (name, light, found[light], rec)
        assert rec <= budget, (name, light, rec, budget)
    print(name, {k: (round(v, 4), recorded[k]) for k, v in found.items()})

    # The code recorded with each light's figure has that figure: those colours baked alone, the
    # same two ways, measured here. Tolerance: the figure is the chooser's raised by 1e-4 of itself
    # and rounded up to 3 decimals, so it lies at most 1e-4 x itself + 0.001 above the colour's.
    codes = by_light(attrs["spectex:precisionWorstCode"], lambda v: int(v.lstrip("#"), 16))
    assert list(codes) == list(recorded), attrs
    px = np.array([[[(c >> 16) & 255, (c >> 8) & 255, c & 255] for c in codes.values()]], dtype=np.uint8)
    worst_png = os.path.join(d, name + "-worst.png")
    out = oiio.ImageOutput.create(worst_png)
    out.open(worst_png, oiio.ImageSpec(px.shape[1], 1, 3, oiio.UINT8))
    out.write_image(px)
    out.close()
    wl, s, _, wl_f, f = bake_twice(d, worst_png, name + "-worst", options, method)
    at_code = {}
    for j, (light, rec) in enumerate(recorded.items()):
        at_code[light] = de = float(de_under(light, wl, s, wl_f, f)[j])
        assert rec - 1e-4 * rec - 0.001 - 1e-6 <= de <= rec, (name, light, hex(codes[light]), de, rec)
    print(name, "at the recorded codes", {k: (f"#{codes[k]:06x}", round(v, 5)) for k, v in at_code.items()})
    return found, recorded


def test_the_default_bakes_recorded_worst_bounds_every_colour(codes_png):
    d, png = codes_png
    found, recorded = check(d, png, "default", [])
    assert set(recorded) == {"D65", "A", "FL2", "FL11", "D50", "LED-B3"}
    # The figure is the cube's worst, not a loose bound: random colours come close to it under
    # the light where it is largest.
    worst = max(recorded, key=recorded.get)
    assert found[worst] >= 0.7 * recorded[worst], (found, recorded)


def test_a_chosen_budget_bounds_every_colour_too(codes_png):
    # A question with no shipped answer: the chooser runs (three whole-cube passes at most here).
    d, png = codes_png
    check(d, png, "basis", ["--wavelengths", "400:700:5", "--precision", "auto", "--lights",
                            "D65,A,FL11", "--max-de", "0.3"], method=["--method", "basis"])


def test_codes_whose_decoding_differs_from_the_formula_are_bounded_too():
    # The bake decodes an 8-bit code through the config (OpenColorIO's sRGB curve, continuous at its
    # knee: 2.5e-4 of the value below IEC 61966-2-1's for codes 1-10, a last float bit elsewhere);
    # the rounding is not smooth, so a chooser that measured the formula's colours recorded FL2 0.394
    # where #ff0406 bakes at 0.3953. Every code with at least two channels in the curve's linear
    # part (0-10), any third channel: 92,416 colours.
    low = np.arange(11)
    codes = {(a, b, c) for a in low for b in low for c in range(256)}
    codes = sorted(codes | {(b, c, a) for a, b, c in codes} | {(c, a, b) for a, b, c in codes})
    px = np.array(codes, dtype=np.uint8)
    side = int(np.ceil(np.sqrt(len(px))))
    px = np.concatenate([px, np.repeat(px[:1], side * side - len(px), 0)]).reshape(side, side, 3)
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "low.png")
        out = oiio.ImageOutput.create(path)
        out.open(path, oiio.ImageSpec(side, side, 3, oiio.UINT8))
        out.write_image(px)
        out.close()
        check(d, path, "low", [])
