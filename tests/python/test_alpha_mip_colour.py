"""Associated alpha on every MIP level: T/A holds its colour under D65 as an opaque pixel does.

The colour-aware rounding holds each pixel's colour under D65 to 6.1e-5 of linear RGB or 2^-10 of
the channel's value (the precision budget's coarser grids), whichever is larger. Spectra
premultiplied by alpha are read back divided by it (verify, a renderer, a compositor), so that is
the colour the rounding must hold: held to 6.1e-5 of the premultiplied colour instead, a MIP texel
of filtered alpha 0.01 was 5.3e-3 off its colour once divided.

Here a texture of saturated and dark colours under alphas 1/256..1 is baked with --mipmap twice: the
default (half, precision budget) and the same in float with every bit (no rounding at all; its
alpha in float too). On every level, T/A of the first against T/A of the second, both integrated
under D65 on the file's bins with the config's own observer and light tables (the weights the
rounding uses), in linear sRGB with white at (1, 1, 1).
"""
import os
import subprocess
import sys
import tempfile

import numpy as np
import OpenImageIO as oiio

SPECTEX = os.environ["SPECTEX_BINARY"]
SOURCE = os.environ["SPECTEX_SOURCE_DIR"]
sys.path.insert(0, os.path.join(SOURCE, "tests", "bench"))
import budget_cube as bc  # noqa: E402  (its config/spectral tables and channel names)

SRGB_XY = np.array([[0.64, 0.33], [0.30, 0.60], [0.15, 0.06]])


def rgb_weights(wl):
    """3 x bins: linear sRGB (white (1, 1, 1)) of a spectrum sampled at wl, under D65."""
    owl, cmf = bc.table("observer_cie1931-2.csv")
    lwl, e = bc.table("illuminant_D65.csv")
    W = np.stack([np.interp(wl, owl, cmf[:, i]) for i in range(3)]) * np.interp(wl, lwl, e[:, 0])
    W /= W[1].sum()
    P = np.array([[x / y, 1.0, (1 - x - y) / y] for x, y in SRGB_XY]).T
    M = np.linalg.inv(P * np.linalg.solve(P, W.sum(1)))
    return M @ W


def levels(path):
    """[(wl, T planes h x w x bins, A h x w)] for every MIP level."""
    inp = oiio.ImageInput.open(path)
    out = []
    for mip in range(64):
        if not inp.seek_subimage(0, mip):
            break
        spec = inp.spec()
        px = np.asarray(inp.read_image(0, mip, 0, spec.nchannels, oiio.FLOAT))
        px = px.reshape(spec.height, spec.width, spec.nchannels)
        wl, idx = bc.spectral_channels(spec)
        out.append((wl, px[..., idx].astype(np.float64),
                    px[..., list(spec.channelnames).index("A")].astype(np.float64)))
    inp.close()
    return out


def test_every_mip_level_holds_the_colour_of_t_over_a():
    with tempfile.TemporaryDirectory() as d:
        # Linear colours of 8-bit codes, premultiplied by alphas that half holds exactly (multiples
        # of 1/256), in a half-float OpenEXR (associated, as OpenEXR's convention is): both bakes
        # then store the same alpha (half; float), so every level filters the same colours.
        codes = np.array([0, 1, 4, 60, 200, 254, 255]) / 255.0
        linear = np.where(codes <= 0.04045, codes / 12.92, ((codes + 0.055) / 1.055) ** 2.4)
        colours = np.array([(r, g, b) for r in linear for g in linear for b in linear[[0, 2, 6]]])
        w, h = 256, 256
        rng = np.random.default_rng(7)
        px = np.zeros((h, w, 4), np.float32)
        px[..., 3] = rng.integers(1, 257, (h, w)) / 256.0
        px[..., :3] = colours[rng.integers(0, len(colours), (h, w))] * px[..., 3:4]
        png = os.path.join(d, "alphas.exr")
        o = oiio.ImageOutput.create(png)
        spec = oiio.ImageSpec(w, h, 4, oiio.HALF)
        spec.channelnames = ("R", "G", "B", "A")
        spec.alpha_channel = 3
        o.open(png, spec)
        o.write_image(px)
        o.close()
        half, ref = os.path.join(d, "half.exr"), os.path.join(d, "float.exr")
        for out, extra in ((half, []), (ref, ["--type", "float", "--precision", "full"])):
            r = subprocess.run([SPECTEX, "bake", png, "-o", out, "-q", "--mipmap", *extra],
                               capture_output=True, text=True)
            assert r.returncode == 0, r.stderr
        got, want = levels(half), levels(ref)
        assert len(got) == len(want) == 9
        worst = 0.0
        for lv, ((wl, t, a), (wl_r, t_r, a_r)) in enumerate(zip(got, want)):
            assert np.array_equal(wl, wl_r)
            M = rgb_weights(wl)
            seen = a_r > 0
            c = (t[seen] / a[seen][:, None]) @ M.T
            c_ref = (t_r[seen] / a_r[seen][:, None]) @ M.T
            # Tolerance: the rounding's (6.1e-5 or 2^-10 of the channel, the larger), raised by 2 %
            # for these weights, which sum the same tables in double where the bake sums in float,
            # and by 2e-6 for the float reference's own rounding.
            tol = 1.02 * np.maximum(2.0 ** -14, 2.0 ** -10 * np.abs(c_ref)) + 2e-6
            over = np.abs(c - c_ref) / tol
            worst = max(worst, float(over.max()))
            assert over.max() <= 1.0, (lv, float(np.abs(c - c_ref).max()), float(over.max()))
        print("worst share of the tolerance over every level:", round(worst, 3))
