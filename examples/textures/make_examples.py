#!/usr/bin/env python3
"""Generate the example textures colour_chart.png and leaf_rgba.png (CC0).

Run:  /tmp/datavenv/bin/python examples/textures/make_examples.py
(needs numpy and Pillow: /tmp/datavenv/bin/pip install numpy pillow)
Output is deterministic: no randomness, no timestamps in the PNGs.
"""

import os

import numpy as np
from PIL import Image

HERE = os.path.dirname(os.path.abspath(__file__))


def hsv_to_rgb(h, s, v):
    """Vectorised HSV -> RGB, all in [0, 1]."""
    i = np.floor(h * 6.0).astype(int) % 6
    f = h * 6.0 - np.floor(h * 6.0)
    p, q, t = v * (1 - s), v * (1 - s * f), v * (1 - s * (1 - f))
    choices = [(v, t, p), (q, v, p), (p, v, t), (p, q, v), (t, p, v), (v, p, q)]
    return np.stack([np.choose(i, [c[k] for c in choices]) for k in range(3)], axis=-1)


# Bottom half of the chart: 4 rows x 6 flat sRGB patches.
PATCHES = [
    [(255, 0, 0), (0, 255, 0), (0, 0, 255), (0, 255, 255), (255, 0, 255), (255, 255, 0)],
    [(255, 255, 255), (200, 200, 200), (128, 128, 128), (64, 64, 64), (32, 32, 32), (0, 0, 0)],
    # approximate sRGB of ColorChecker patches 1-12 (compare config/spectral/colorchecker_ohta.csv)
    [(115, 82, 68), (194, 150, 130), (98, 122, 157), (87, 108, 67), (133, 128, 177), (103, 189, 170)],
    [(214, 126, 44), (80, 91, 166), (193, 90, 99), (94, 60, 108), (157, 188, 64), (224, 163, 46)],
]


def colour_chart(w=512, h=256):
    img = np.zeros((h, w, 3), dtype=np.uint8)
    half = h // 2
    hue = (np.arange(w) + 0.5) / w
    # Top quarter: white -> fully saturated hue. Second quarter: full hue -> black.
    t = (np.arange(half // 2) + 0.5) / (half // 2)
    H, T = np.meshgrid(hue, t)
    top = hsv_to_rgb(H, T, np.ones_like(T))
    mid = hsv_to_rgb(H, np.ones_like(T), 1.0 - T)
    img[:half] = np.round(np.concatenate([top, mid]) * 255).astype(np.uint8)
    # Bottom half: flat patches.
    xs = np.linspace(0, w, 7).round().astype(int)
    ys = np.linspace(half, h, 5).round().astype(int)
    for r, row in enumerate(PATCHES):
        for c, rgb in enumerate(row):
            img[ys[r]:ys[r + 1], xs[c]:xs[c + 1]] = rgb
    return Image.fromarray(img, "RGB")


def leaf_rgba(n=256):
    # Leaf coordinates: axis runs from stem (t=0) to tip (t=1), tilted 30 degrees.
    yy, xx = np.mgrid[0:n, 0:n] + 0.5
    x, y = (xx - n / 2) / n, (n / 2 - yy) / n
    a = np.radians(30)
    along = x * np.sin(a) + y * np.cos(a)
    across = x * np.cos(a) - y * np.sin(a)
    t = (along + 0.42) / 0.84
    tc = np.clip(t, 0, 1)
    half_width = 0.24 * np.sin(np.pi * tc) ** 0.7 * (1 - 0.35 * tc)
    dist_px = (half_width - np.abs(across)) * n  # > 0 inside the blade
    dist_px = np.where((t >= 0) & (t <= 1), dist_px, -1e9)
    # Stem: thin strip below the blade.
    stem = np.where((t < 0.02) & (t > -0.14), (0.008 - np.abs(across)) * n, -1e9)
    alpha = np.clip(np.maximum(dist_px, stem) / 6.0, 0.0, 1.0)  # 6 px soft edge

    # Colour: green gradient, darker near the edge, lighter veins.
    base = np.array([0.18, 0.45, 0.12]) + np.array([0.10, 0.15, 0.02]) * tc[..., None]
    shade = 0.75 + 0.25 * np.clip(dist_px / 20.0, 0, 1)
    rel = np.abs(across) / np.maximum(half_width, 1e-3)
    mid_vein = np.clip(1 - np.abs(across) * n / 2.0, 0, 1)
    phase = t * 9 - rel * 1.2  # lateral veins slant towards the tip
    lat_vein = np.clip(1 - np.abs(phase - np.round(phase)) * 14, 0, 1) * (rel < 0.9)
    vein = np.maximum(mid_vein, 0.7 * lat_vein)[..., None]
    rgb = base * shade[..., None] * (1 - vein) + np.array([0.62, 0.78, 0.35]) * vein
    rgba = np.concatenate([rgb, alpha[..., None]], axis=-1)
    return Image.fromarray(np.round(np.clip(rgba, 0, 1) * 255).astype(np.uint8), "RGBA")


def main():
    for name, img in [("colour_chart.png", colour_chart()), ("leaf_rgba.png", leaf_rgba())]:
        path = os.path.join(HERE, name)
        img.save(path, optimize=True)
        print(f"wrote {name}: {img.size[0]}x{img.size[1]} {img.mode}, {os.path.getsize(path)} bytes")


if __name__ == "__main__":
    main()
