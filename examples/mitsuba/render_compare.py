#!/usr/bin/env python3
"""The same textured plane rendered by Mitsuba 3 two ways, under D65 and under illuminant A.

    DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 \\
    build/venv/bin/python examples/mitsuba/render_compare.py --spectex build/src/spectex \\
        -o docs/images/mitsuba_spectex_vs_rgb.png

Run from the repository root (it reads config/spectral/ and examples/textures/). The texture
(default examples/textures/colour_chart.png) is baked by `spectex bake` with its defaults (or the
`--bake-arg` options) into a temporary folder, then a plane carrying it is rendered (llvm_ad_spectral, orthographic camera,
`direct` integrator, a uniform `constant` light with the illuminant's CIE table as an `irregular`
spectrum, XYZ film) with

  - left:  the bake, through the "spectex" texture plugin (python/spectex_mitsuba), and
  - right: the source PNG through Mitsuba's own `bitmap` texture, which upsamples the RGB to a
           spectrum with Mitsuba's own method,

top row under D65, bottom row under A: a 2x2 sheet, one label above each panel (spectex's 5x7
font). Each light's render is white-balanced to D65 (Bradford adaptation of the light's white, as
`spectex render` does) and written as 8-bit sRGB, so a difference between the columns is a
difference between the two spectra given to the same RGB, not the light's colour cast.

It also prints, per light, the colour difference between the two columns over the 24 flat patches
of the chart's bottom half (CIEDE2000 with colour-science if importable, else CIE 1976 ΔE*ab).
"""
import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent.parent
sys.path.insert(0, str(ROOT / "python"))  # this tree's plugin before an installed one

import drjit as dr  # noqa: E402,F401
import mitsuba as mi  # noqa: E402

# spectex's built-in 5x7 font (src/pipeline/bitmap_font.cpp), the glyphs the labels use.
GLYPHS = {
    ' ': ('.....', '.....', '.....', '.....', '.....', '.....', '.....'),
    '5': ('#####', '#....', '####.', '....#', '....#', '#...#', '.###.'),
    '6': ('..##.', '.#...', '#....', '####.', '#...#', '#...#', '.###.'),
    'A': ('.###.', '#...#', '#...#', '#####', '#...#', '#...#', '#...#'),
    'B': ('####.', '#...#', '#...#', '####.', '#...#', '#...#', '####.'),
    'C': ('.###.', '#...#', '#....', '#....', '#....', '#...#', '.###.'),
    'D': ('###..', '#..#.', '#...#', '#...#', '#...#', '#..#.', '###..'),
    'E': ('#####', '#....', '#....', '####.', '#....', '#....', '#####'),
    'G': ('.###.', '#...#', '#....', '#.###', '#...#', '#...#', '.####'),
    'I': ('.###.', '..#..', '..#..', '..#..', '..#..', '..#..', '.###.'),
    'M': ('#...#', '##.##', '#.#.#', '#.#.#', '#...#', '#...#', '#...#'),
    'P': ('####.', '#...#', '#...#', '####.', '#....', '#....', '#....'),
    'R': ('####.', '#...#', '#...#', '####.', '#.#..', '#..#.', '#...#'),
    'S': ('.####', '#....', '#....', '.###.', '....#', '....#', '####.'),
    'T': ('#####', '..#..', '..#..', '..#..', '..#..', '..#..', '..#..'),
    'U': ('#...#', '#...#', '#...#', '#...#', '#...#', '#...#', '.###.'),
    'X': ('#...#', '#...#', '.#.#.', '..#..', '.#.#.', '#...#', '#...#'),
    '-': ('.....', '.....', '.....', '#####', '.....', '.....', '.....'),
    ':': ('.....', '.##..', '.##..', '.....', '.##..', '.##..', '.....'),
}

# The chart's bottom half: 4 rows x 6 flat patches (examples/textures/make_examples.py).
PATCH_X = np.linspace(0, 512, 7).round().astype(int)
PATCH_Y = np.linspace(128, 256, 5).round().astype(int)

# XYZ -> linear sRGB (IEC 61966-2-1) and Bradford's cone matrix.
XYZ_TO_SRGB = np.array([[3.2404542, -1.5371385, -0.4985314],
                        [-0.9692660, 1.8760108, 0.0415560],
                        [0.0556434, -0.2040259, 1.0572252]])
BRADFORD = np.array([[0.8951, 0.2664, -0.1614], [-0.7502, 1.7135, 0.0367], [0.0389, -0.0685, 1.0296]])


def read_csv(path):
    rows = [line.strip() for line in open(path) if line.strip() and not line.startswith("#")]
    names = rows[0].split(",")
    data = np.array([[float(v) for v in r.split(",")] for r in rows[1:]])
    return {n: data[:, k] for k, n in enumerate(names)}


def light_white_xyz(wl, val):
    """XYZ of a perfect white under the light as Mitsuba's XYZ film estimates it: 360-830 nm, the
    light linear between its samples and 0 outside ('irregular'), divided by the integral of ybar."""
    obs = read_csv(ROOT / "config" / "spectral" / "observer_cie1931-2.csv")
    fine = np.arange(360.0, 831.0)
    cmf = np.stack([np.interp(fine, obs["wavelength"], obs[c]) for c in "xyz"], axis=1)
    e = np.interp(fine, wl, val, left=0.0, right=0.0)
    return e @ cmf / cmf[:, 1].sum()


def render(texture, light, width, height, spp):
    wl, val = light
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "direct"},
        "sensor": {
            "type": "orthographic",
            "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 1], target=[0, 0, 0], up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": width, "height": height, "pixel_format": "xyz",
                     "component_format": "float32", "rfilter": {"type": "box"}},
            "sampler": {"type": "independent", "sample_count": spp},
        },
        "light": {"type": "constant", "radiance": {"type": "irregular",
                                                   "wavelengths": ",".join(f"{w:g}" for w in wl),
                                                   "values": ",".join(f"{v:.9g}" for v in val)}},
        # y scaled by -1: Mitsuba's rectangle has v upwards, the image's first row is v = 0
        "plane": {"type": "rectangle", "to_world": mi.ScalarTransform4f().scale([1, -height / width, 1]),
                  "bsdf": {"type": "diffuse", "reflectance": texture}},
    })
    return np.array(mi.render(scene, seed=1), dtype=np.float64)


def to_display(xyz, white):
    """XYZ (white's Y = 1 after scaling) -> Bradford-adapted to D65 -> 8-bit sRGB."""
    d65 = np.array([0.95047, 1.0, 1.08883])
    xyz = xyz / white[1]
    w = white / white[1]
    cone_src, cone_dst = BRADFORD @ w, BRADFORD @ d65
    adapt = np.linalg.inv(BRADFORD) @ np.diag(cone_dst / cone_src) @ BRADFORD
    adapted = xyz @ adapt.T
    lin = np.clip(adapted @ XYZ_TO_SRGB.T, 0.0, 1.0)
    enc = np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * np.power(lin, 1 / 2.4) - 0.055)
    return (enc * 255 + 0.5).astype(np.uint8), adapted


def draw_label(img, x, y, text, scale=2):
    for k, ch in enumerate(text.upper()):
        rows = GLYPHS.get(ch, GLYPHS[' '])
        for r, row in enumerate(rows):
            for c, bit in enumerate(row):
                if bit == "#":
                    x0, y0 = x + (k * 6 + c) * scale, y + r * scale
                    img[y0:y0 + scale, x0:x0 + scale] = 255


def lab(xyz):
    d65 = np.array([0.95047, 1.0, 1.08883])
    t = xyz / d65
    f = np.where(t > (6 / 29) ** 3, np.cbrt(t), t / (3 * (6 / 29) ** 2) + 4 / 29)
    return np.stack([116 * f[..., 1] - 16, 500 * (f[..., 0] - f[..., 1]), 200 * (f[..., 1] - f[..., 2])], -1)


def delta_e(xyz_a, xyz_b):
    try:
        import colour
        return colour.delta_E(lab(xyz_a), lab(xyz_b), method="CIE 2000"), "CIEDE2000"
    except ImportError:
        return np.linalg.norm(lab(xyz_a) - lab(xyz_b), axis=-1), "CIE 1976 dE*ab"


def patch_means(img, tex_w, tex_h, margin=3):
    h, w = img.shape[:2]
    out = []
    for r in range(4):
        for c in range(6):
            y0 = int(np.ceil(PATCH_Y[r] * h / tex_h)) + margin
            y1 = int(PATCH_Y[r + 1] * h / tex_h) - margin
            x0 = int(np.ceil(PATCH_X[c] * w / tex_w)) + margin
            x1 = int(PATCH_X[c + 1] * w / tex_w) - margin
            out.append(img[y0:y1, x0:x1].reshape(-1, 3).mean(axis=0))
    return np.array(out)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--spectex", default="spectex", help="the spectex binary (default: spectex on PATH)")
    ap.add_argument("--texture", default=str(ROOT / "examples" / "textures" / "colour_chart.png"))
    ap.add_argument("-o", "--output", default="mitsuba_spectex_vs_rgb.png")
    ap.add_argument("--width", type=int, default=320, help="width of one panel in pixels (default 320)")
    ap.add_argument("--spp", type=int, default=512, help="samples per pixel (default 512)")
    ap.add_argument("--bake-arg", action="append", default=[],
                    help="an option for spectex bake, repeatable (e.g. --bake-arg=--method --bake-arg=lattice)")
    a = ap.parse_args()

    mi.set_variant("llvm_ad_spectral")
    import spectex_mitsuba
    spectex_mitsuba.register()

    src = mi.Bitmap(a.texture)
    tex_w, tex_h = src.width(), src.height()
    width, height = a.width, round(a.width * tex_h / tex_w)
    chart = Path(a.texture).name == "colour_chart.png"

    with tempfile.TemporaryDirectory() as tmp:
        exr = os.path.join(tmp, "texture.exr")
        subprocess.run([a.spectex, "bake", a.texture, "-o", exr, "-q", *a.bake_arg], check=True)
        columns = [("spectex", {"type": "spectex", "filename": exr}),
                   ("Mitsuba RGB bitmap", {"type": "bitmap", "filename": a.texture})]
        label_h, gap = 22, 4
        sheet = np.full((2 * (label_h + height) + gap, 2 * width + gap, 3), 24, np.uint8)
        for row, name in enumerate(("D65", "A")):
            csv = read_csv(ROOT / "config" / "spectral" / f"illuminant_{name}.csv")
            light = (csv["wavelength"], csv["value"])
            white = light_white_xyz(*light)
            adapted = []
            for col, (label, texture) in enumerate(columns):
                xyz = render(texture, light, width, height, a.spp)
                rgb8, ad = to_display(xyz, white)
                adapted.append(ad)
                y0, x0 = row * (label_h + height + gap), col * (width + gap)
                draw_label(sheet, x0 + 4, y0 + 4, f"{label} - {name}")
                sheet[y0 + label_h:y0 + label_h + height, x0:x0 + width] = rgb8
            if chart:
                de, metric = delta_e(patch_means(adapted[0], tex_w, tex_h), patch_means(adapted[1], tex_w, tex_h))
                print(f"{name}: spectex vs Mitsuba RGB bitmap over the 24 patches, {metric}: "
                      f"mean {de.mean():.2f}, max {de.max():.2f} (patch {int(de.argmax()) + 1} of 24, row-major)")
    mi.Bitmap(sheet, mi.Bitmap.PixelFormat.RGB).write(a.output)
    print(f"wrote {a.output} ({os.path.getsize(a.output) / 1e3:.0f} kB): rows D65, A; columns spectex, "
          "Mitsuba RGB bitmap")


if __name__ == "__main__":
    main()
