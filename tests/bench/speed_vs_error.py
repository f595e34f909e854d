#!/usr/bin/env python3
"""Speed against error of `spectex bake`, one configuration per row, with the floor and peers.

    build/venv/bin/python tests/bench/speed_vs_error.py --spectex build/src/spectex \\
        --floor build/tests/bench/bench_exr_floor --out bench-report/ [--size 1024] [--quick]

Writes OUT/report.md (Markdown tables), OUT/report.csv and OUT/report.svg (MP/s against mean
ΔE00 under illuminant A). See tests/bench/README.md for what each column means.

Configurations vary one axis at a time from the default (380:780:5, half, zip, smooth fitted
basis): grids 380:780:10, 380:780:20, 400:700:10, 380:780:1; float; compressions none, zips,
piz, dwaa; objective norm; the published mallett2019 table (380:780:5 only); the methods
(--method lattice at sizes 5, 9, 17; --method jakob-hanika).

Per scene (also alone with --scenes-only; --no-scenes skips it): for daylight (D65, D50),
tungsten (A) and mixed fluorescent and LED (FL2, FL11, LED-B3) at budgets 0.25, 0.5 and 1.0 ΔE00,
the grid `spectex plan` chooses, its bake time and bytes on the --size² input against the default
380:780:5, and grid_check.py's worst ΔE00 per light on plan's dense sample against a 1 nm float
bake, marked where it differs from plan's figure by more than grid_check.TOLERANCE. Each scene and
budget is also planned with `--nonuniform --grid-file`; when that choice is a non-uniform grid it is
baked (`--wavelengths-file`) and checked the same way, as a second row. Written to OUT/scenes.md,
scenes.csv, scenes.json (and appended to report.md in a full run).

With --precision-rows (also alone with --precision-only) it adds one row per method and precision:
basis, lattice (Jakob-Hanika prior), lattice (LHTSS prior) and jakob-hanika, each at
`--precision full` and at `--precision auto` with the default decision's budget
(PRECISION_BUDGET): bytes and bake time of the --size² input (best of --repeat with the bits in a
fresh cache, and the first bake, which chooses them), D65 on the 256² all-colours subsample
(`spectex verify`), and method_accuracy.py's mean and worst ΔE00 under A, FL2, FL11, D50 and
LED-B3 on the tuning sets pooled and on Ohta's held-out ColorChecker, spectra as stored (half).
Written to OUT/precision.md and precision.json.

With --method-size S (e.g. 4096) it also times a S² bake of --method lattice against --method
basis, alternating, in the same run, with zip and with no compression (the kernel's share).
"""
import argparse
import csv
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
SPECTRAL = ROOT / "config" / "spectral"

# The reference row: the basis fitted smooth (spectex bake's default before the LHTSS lattice with its
# precision budget; method_args names it, so the row's figures keep their meaning).
DEFAULT = dict(grid="380:780:5", type="half", compression="zip", basis="smooth", method="basis")

# The precision rows: every method at full precision and with the default decision's budget.
PRECISION_METHODS = [
    ("basis", ["--method", "basis"]),
    ("lattice (jakob-hanika prior)", ["--method", "lattice"]),
    ("lattice (lhtss prior)", ["--method", "lattice", "--vertex-prior", "lhtss"]),
    ("jakob-hanika", ["--method", "jakob-hanika"]),
]
PRECISION_BUDGET = ["--precision", "auto", "--lights", "D65,A,FL2,FL11,D50,LED-B3", "--max-de", "0.5"]


def configurations():
    rows = [dict(DEFAULT, name="default")]
    for g in ["380:780:10", "380:780:20", "400:700:10", "380:780:1"]:
        rows.append(dict(DEFAULT, grid=g, name=f"grid {g}"))
    rows.append(dict(DEFAULT, type="float", name="float"))
    for c in ["none", "zips", "piz", "dwaa"]:
        rows.append(dict(DEFAULT, compression=c, name=f"{c}"))
    rows.append(dict(DEFAULT, basis="norm", name="objective norm"))
    rows.append(dict(DEFAULT, basis="mallett2019", name="mallett2019"))
    for n in [5, 9, 17]:
        rows.append(dict(DEFAULT, basis="", method=f"lattice:{n}", name=f"lattice n={n}" + (" (its default)" if n == 9 else "")))
    rows.append(dict(DEFAULT, basis="", method="jakob-hanika", name="jakob-hanika"))
    return rows


def log(*a):
    print(*a, file=sys.stderr, flush=True)


# ---------------------------------------------------------------- inputs

def write_png(path, rgb8):
    import OpenImageIO as oiio

    h, w, _ = rgb8.shape
    out = oiio.ImageOutput.create(str(path))
    out.open(str(path), oiio.ImageSpec(w, h, 3, oiio.UINT8))
    out.write_image(np.ascontiguousarray(rgb8))
    out.close()


def photographic_png(path, size, seed=7):
    """A deterministic photograph-like image: smooth multi-scale colour fields, hard-edged shapes,
    soft shading and sensor-like grain, 8-bit sRGB."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:size, 0:size].astype(np.float32) / size
    img = np.zeros((size, size, 3), np.float32)
    for scale, amp in [(4, 0.35), (16, 0.15), (64, 0.06)]:
        coarse = rng.random((scale + 1, scale + 1, 3)).astype(np.float32)
        # bilinear upsampling of a coarse random field
        gx, gy = x * scale, y * scale
        ix, iy = np.minimum(gx.astype(int), scale - 1), np.minimum(gy.astype(int), scale - 1)
        fx, fy = (gx - ix)[..., None], (gy - iy)[..., None]
        c = (coarse[iy, ix] * (1 - fx) * (1 - fy) + coarse[iy, ix + 1] * fx * (1 - fy)
             + coarse[iy + 1, ix] * (1 - fx) * fy + coarse[iy + 1, ix + 1] * fx * fy)
        img += amp * (c - 0.5)
    img += 0.45
    for _ in range(12):  # objects with edges
        cx, cy, r = rng.random(), rng.random(), 0.05 + 0.15 * rng.random()
        col = rng.random(3).astype(np.float32)
        mask = ((x - cx) ** 2 + (y - cy) ** 2) < r * r
        shade = (1.0 - 0.6 * np.clip(((x - cx) + (y - cy)) / r, -1, 1))[..., None] * 0.5 + 0.5
        img = np.where(mask[..., None], col * shade, img)
    img *= (0.6 + 0.4 * (1 - y))[..., None]  # vignette-like light falloff
    img += rng.normal(0, 0.012, img.shape).astype(np.float32)  # grain
    write_png(path, (np.clip(img, 0, 1) * 255 + 0.5).astype(np.uint8))


def cube_subsample_png(path):
    """65536 distinct colours of the 8-bit sRGB cube, spread by a multiplicative hash: colour
    i·K mod 2^24 (K odd, so distinct), 256×256."""
    k = 0x9E3779B1 & 0xFFFFFF | 1
    c = (np.arange(65536, dtype=np.uint64) * k) & 0xFFFFFF
    rgb = np.stack([(c >> 16) & 255, (c >> 8) & 255, c & 255], -1).astype(np.uint8)
    rgb[-1] = 255  # include white (black is colour 0)
    write_png(path, rgb.reshape(256, 256, 3))


def cube_full_png(path):
    """All 16,777,216 8-bit sRGB colours, 4096×4096."""
    c = np.arange(1 << 24, dtype=np.uint32)
    rgb = np.stack([(c >> 16) & 255, (c >> 8) & 255, c & 255], -1).astype(np.uint8)
    write_png(path, rgb.reshape(4096, 4096, 3))


# ---------------------------------------------------------------- running things

def timed(cmd, **kw):
    """Runs cmd under /usr/bin/time: (wall s, peak RSS MB, stdout)."""
    with tempfile.NamedTemporaryFile("r", suffix=".time") as tf:
        p = subprocess.run(["/usr/bin/time", "-f", "%e %M", "-o", tf.name, *map(str, cmd)],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kw)
        if p.returncode != 0:
            raise RuntimeError(f"{' '.join(map(str, cmd))} failed ({p.returncode}):\n{p.stderr[-2000:]}")
        wall, kb = tf.read().split()[-2:]
    return float(wall), float(kb) / 1024.0, p.stdout


def method_args(cfg):
    m, _, n = cfg["method"].partition(":")
    if m != "basis":
        return ["--method", m] + (["--lattice-size", n] if n else [])
    if cfg["basis"] == "mallett2019":
        return ["--basis", "mallett2019"]
    return ["--objective", cfg["basis"]]


def bake(a, cfg, src, out, jsonl):
    """cfg["grid"] is START:END:STEP, unless cfg["wavelengths_file"] names a file of wavelengths
    (`--wavelengths-file`, e.g. a non-uniform grid written by `plan --grid-file`)."""
    grid = (["--wavelengths-file", cfg["wavelengths_file"]] if cfg.get("wavelengths_file")
            else ["--wavelengths", cfg["grid"]])
    cmd = [a.spectex, "bake", src, "-o", out, *grid, "--type", cfg["type"],
           "--compression", cfg["compression"], *method_args(cfg), "--threads", a.threads, "-q",
           "--json", jsonl]
    wall, mb, _ = timed(cmd)
    rec = json.loads(Path(jsonl).read_text().strip().splitlines()[-1])
    return wall, mb, rec


def floor(a, cfg, size, out, source):
    cmd = [a.floor, "--source", source, "--whole", "--width", size, "--height", size, "--wavelengths", cfg["grid"], "--type", cfg["type"],
           "--compression", cfg["compression"], "--threads", a.threads, "--out", out]
    wall, mb, stdout = timed(cmd)
    return json.loads(stdout.strip().splitlines()[-1])


def verify(a, exr, src):
    p = subprocess.run([str(x) for x in [a.spectex, "verify", exr, "--source", src, "--json", "-", "--threads", a.threads]],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if p.returncode not in (0, 1):
        raise RuntimeError(f"verify failed: {p.stderr}")
    return json.loads(p.stdout)


# ---------------------------------------------------------------- ColorChecker under other light

CC_LIGHTS = ["A", "FL2", "FL11", "D50", "LED-B3"]


def read_spectra(exr):
    """(wavelengths, pixels × bins) of a spectral EXR's T.<λ>nm channels, as float."""
    import re

    import OpenImageIO as oiio

    inp = oiio.ImageInput.open(str(exr))
    spec = inp.spec()
    px = inp.read_image(oiio.FLOAT).reshape(-1, spec.nchannels)
    inp.close()
    chans = sorted((float(m.group(1).replace(",", ".")), i) for i, n in enumerate(spec.channelnames)
                   if (m := re.fullmatch(r"T\.(\d+(?:,\d+)?)nm", n)))
    return np.array([w for w, _ in chans]), px[:, [i for _, i in chans]].astype(float)


def colorchecker_errors(a, cfg, work):
    """ΔE00 of the row's spectra for the 24 ColorChecker patches against their measured spectra.

    The input is what a texture holds: each patch's 8-bit sRGB code (measured spectrum under D65,
    white-consistent matrix, clipped, encoded), baked by spectex with the row's settings and read
    back from the file. Both spectra are compared on 380:780:5 (the file's spectra interpolated
    linearly and held beyond its ends, as a renderer does) under each light with CIE 1931 2°, after
    a Bradford transform of the light's white to D65's (method_accuracy.Evaluator, the issue's
    measure). The chart is held out: nothing was tuned on it."""
    import OpenImageIO as oiio

    sys.path.insert(0, str(HERE))
    import method_accuracy as ma

    _, measured = ma.read_colorchecker_csv()
    codes, _, _ = ma.to_codes(measured)
    png, exr = work / "cc.png", work / "cc.exr"
    out = oiio.ImageOutput.create(str(png))
    out.open(str(png), oiio.ImageSpec(len(codes), 1, 3, oiio.UINT8))
    out.write_image(np.ascontiguousarray(codes.reshape(1, -1, 3)))
    out.close()
    bake(a, cfg, png, exr, work / "cc.jsonl")
    wl, S = read_spectra(exr)
    exr.unlink(missing_ok=True)
    if len(wl) != ma.N or np.abs(wl - ma.GRID).max() > 1e-6:
        S = np.stack([np.interp(ma.GRID, wl, r) for r in S])
    ev = ma.Evaluator()
    res = {}
    for light in CC_LIGHTS:
        de = ev.delta_e(light, measured, S)
        res[f"cc_{light}_mean"], res[f"cc_{light}_max"] = float(de.mean()), float(de.max())
    res["cc_avg_mean"] = float(np.mean([res[f"cc_{l}_mean"] for l in CC_LIGHTS]))
    return res


# ---------------------------------------------------------------- report

COLUMNS = [
    ("name", "configuration"), ("grid", "grid"), ("bins", "bins"), ("type", "type"),
    ("compression", "compression"), ("method", "method"), ("basis", "basis"),
    ("mp_s", "MP/s"), ("wall_s", "bake s"), ("bytes", "output bytes"), ("peak_mb", "peak MB"),
    ("floor_s", "floor s"), ("ratio_floor", "× floor"),
    ("d65_max", "ΔE00 D65 max"), ("d65_mean", "ΔE00 D65 mean"), ("code_match", "codes kept %"),
] + [(f"cc_{l}_{s}", f"CC {l} {s}") for l in CC_LIGHTS for s in ("mean", "max")] + [("cc_avg_mean", "CC avg mean")]


def fmt(key, v):
    if v is None or v == "":
        return "–"
    if isinstance(v, str):
        return v
    if key in ("bytes", "bins"):
        return f"{int(v):,}"
    if key in ("d65_max", "d65_mean"):
        return f"{v:.2g}" if v < 0.01 else f"{v:.3f}"
    if key == "code_match":
        return f"{v:.4f}" if v < 100 else "100"
    return f"{v:.2f}"


def svg_plot(rows, path):
    W, H, L, R, T, Bm = 760, 480, 70, 200, 30, 55
    pts = [(r["cc_avg_mean"], r["mp_s"], r["name"]) for r in rows if r.get("mp_s") and r.get("cc_avg_mean") is not None]
    xs, ys = [p[0] for p in pts], [p[1] for p in pts]
    x0, x1 = min(xs) * 0.95, max(xs) * 1.05
    y0, y1 = 0, max(ys) * 1.1
    if x1 - x0 < 1e-9:
        x1 = x0 + 1

    def px(x):
        return L + (x - x0) / (x1 - x0) * (W - L - R)

    def py(y):
        return H - Bm - (y - y0) / (y1 - y0) * (H - T - Bm)

    o = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" font-family="sans-serif" font-size="11">',
         f'<rect width="{W}" height="{H}" fill="white"/>',
         f'<text x="{W / 2 - 100}" y="18" font-size="13">spectex bake: speed against error</text>']
    for i in range(6):
        xv = x0 + (x1 - x0) * i / 5
        yv = y0 + (y1 - y0) * i / 5
        o.append(f'<line x1="{px(xv):.1f}" y1="{T}" x2="{px(xv):.1f}" y2="{H - Bm}" stroke="#eee"/>')
        o.append(f'<line x1="{L}" y1="{py(yv):.1f}" x2="{W - R}" y2="{py(yv):.1f}" stroke="#eee"/>')
        o.append(f'<text x="{px(xv):.1f}" y="{H - Bm + 15}" text-anchor="middle">{xv:.2f}</text>')
        o.append(f'<text x="{L - 6}" y="{py(yv) + 4:.1f}" text-anchor="end">{yv:.2f}</text>')
    o.append(f'<rect x="{L}" y="{T}" width="{W - L - R}" height="{H - T - Bm}" fill="none" stroke="black"/>')
    o.append(f'<text x="{(L + W - R) / 2}" y="{H - 15}" text-anchor="middle">mean ΔE00 over A, FL2, FL11, D50, LED-B3, '
             f'24 ColorChecker patches (lower is better)</text>')
    o.append(f'<text transform="translate(18,{(T + H - Bm) / 2}) rotate(-90)" text-anchor="middle">'
             f'megapixels per second (higher is better)</text>')
    for k, (x, y, name) in enumerate(pts):
        o.append(f'<circle cx="{px(x):.1f}" cy="{py(y):.1f}" r="4" fill="#1f77b4"/>')
        o.append(f'<text x="{px(x) + 6:.1f}" y="{py(y) - 4 + (k % 3) * 4:.1f}" font-size="10">{name}</text>')
    o.append("</svg>")
    Path(path).write_text("\n".join(o) + "\n")


# ---------------------------------------------------------------- per scene

SCENES = [("daylight", ["D65", "D50"]), ("tungsten", ["A"]), ("mixed fluorescent and LED", ["FL2", "FL11", "LED-B3"])]
BUDGETS = [0.25, 0.5, 1.0]
DEFAULT_GRID = DEFAULT["grid"]
REFERENCE_GRID = "360:830:1"  # plan's default --range at 1 nm


def grid_check_module():
    import importlib.util

    spec = importlib.util.spec_from_file_location("grid_check", HERE / "grid_check.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def dense_sample_png(path, stride=4):
    """plan's dense sample, one colour per pixel in plan's order: codes 0, stride, … and 255 per
    axis (65³ = 274,625 colours at stride 4), 65²×65."""
    axis = np.array(list(range(0, 255, stride)) + [255], np.uint8)
    r, g, b = np.meshgrid(axis, axis, axis, indexing="ij")
    write_png(path, np.stack([r, g, b], -1).reshape(len(axis), len(axis) ** 2, 3))


def plan_json(a, *args):
    """`spectex plan ... --json -` (exit 1, no grid within the budget, still prints the JSON)."""
    t0 = time.time()
    p = subprocess.run([str(x) for x in [a.spectex, "plan", *args, "--json", "-", "--threads", a.threads]],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if p.returncode not in (0, 1) or not p.stdout.strip():
        raise RuntimeError(f"plan {' '.join(map(str, args))} failed ({p.returncode}): {p.stderr[-2000:]}")
    return json.loads(p.stdout), time.time() - t0


def nonuniform_key(wavelengths):
    """The key of a non-uniform grid in res["grids"]: its wavelengths (two scenes may choose
    different grids with the same label, "non-uniform N")."""
    return "non-uniform:" + ",".join(f"{w:g}" for w in wavelengths)


def read_grid_file(path):
    """Wavelengths of a `plan --grid-file` (a `# ` comment line, then one per line)."""
    return [float(l) for l in Path(path).read_text().splitlines() if l.strip() and not l.startswith("#")]


def span(wavelengths):
    return f"{wavelengths[0]:g}–{wavelengths[-1]:g}"


def scenes(a, work, photo=None):
    """The per-scene section: plan's choice for each scene and budget (uniform candidates, and with
    --nonuniform), its bake time and bytes on the photograph-like input against the default grid,
    and the checker's figures."""
    gc = grid_check_module()
    lights_all = list(dict.fromkeys(["D65"] + [l for _, ls in SCENES for l in ls]))
    res = dict(size=a.size, repeat=a.repeat, threads=a.threads, tolerance=gc.TOLERANCE, budgets=BUDGETS,
               scenes=[dict(name=n, lights=ls) for n, ls in SCENES], plans=[], grids={})
    grid_files = {}  # non-uniform key -> the --grid-file plan wrote
    # 1. plan's choice per scene and budget (default --colours auto, linear, 360:830), then the same
    #    with --nonuniform.
    for name, lights in SCENES:
        for budget in BUDGETS:
            log(f"plan: {name} ({','.join(lights)}), --max-de {budget}")
            p, secs = plan_json(a, "--lights", ",".join(lights), "--max-de", budget)
            row = next((g for g in p["grids"] if g["chosen"]), None)
            res["plans"].append(dict(
                scene=name, lights=lights, budget=budget, seconds=secs, chosen=p["chosen"],
                best=p["best"], colours=row["colours"] if row else None, worst=row["worst"] if row else None,
                plan_lights={l["light"]: l["worst"] for l in row["lights"]} if row else {},
                half_shift={l["light"]: l["half_shift"] for l in row["lights"]} if row else {}))
            log(f"  {p['chosen']} ({secs:.0f} s)")
            gfile = work / f"grid_{len(res['plans'])}.txt"
            p, secs = plan_json(a, "--lights", ",".join(lights), "--max-de", budget, "--nonuniform", "--grid-file", gfile)
            row = next((g for g in p["grids"] if g["chosen"]), None)
            nu = dict(seconds=secs, chosen=p["chosen"], best=p["best"], search=p.get("search"),
                      uniform=row["uniform"] if row else None)
            res["plans"][-1]["nonuniform"] = nu
            log(f"  --nonuniform: {p['chosen']} ({secs:.0f} s; {p.get('search')})")
            if not row or row["uniform"]:
                continue
            wl = row["wavelengths"]
            if read_grid_file(gfile) != wl:
                raise RuntimeError(f"plan --grid-file {gfile} does not hold the chosen row's wavelengths {wl}")
            key = nonuniform_key(wl)
            grid_files[key] = gfile
            nu.update(grid=key, label=row["grid"], wavelengths=wl, colours=row["colours"], worst=row["worst"],
                      plan_lights={l["light"]: l["worst"] for l in row["lights"]},
                      half_shift={l["light"]: l["half_shift"] for l in row["lights"]})
            gr = res["grids"].setdefault(key, dict(grid=key, label=row["grid"], wavelengths=wl, uniform=False,
                                                   walls=[], plan_sample={}))
            # plan's figure for this grid on the sample (the checker's colours): `plan --grids` takes
            # only uniform grids, so the same search with --colours sample, which evaluates every grid
            # of its trails on the sample. The trails do not depend on the uniform candidates (these
            # only drop trail grids with as many bins as the cheapest passing one): one candidate,
            # the default grid, keeps every trail grid and skips evaluating the other uniform ones.
            ps, ssecs = plan_json(a, "--lights", ",".join(lights), "--max-de", budget, "--nonuniform",
                                  "--colours", "sample", "--grids", DEFAULT_GRID)
            nu["sample_seconds"] = ssecs
            srow = next((g for g in ps["grids"] if not g["uniform"] and g["wavelengths"] == wl), None)
            if srow is None:
                log(f"  ! the --colours sample run has no row with the chosen wavelengths ({ssecs:.0f} s)")
            else:
                gr["plan_sample"].update({l["light"]: dict(worst=l["worst"], p99=l["p99"], worst_code=l["worst_code"])
                                          for l in srow["lights"]})
                log(f"  its sample figures: " + ", ".join(f"{l['light']} {l['worst']:.4g}" for l in srow["lights"])
                    + f" ({ssecs:.0f} s)")
    uniform = list(dict.fromkeys([r["chosen"] for r in res["plans"] if r["chosen"]] + [DEFAULT_GRID]))
    for g in uniform:
        res["grids"].setdefault(g, dict(grid=g, label=g, wavelengths=None, uniform=True, walls=[]))
    grids = uniform + list(grid_files)

    def cfg_of(key):
        return dict(DEFAULT, grid=res["grids"][key]["label"], wavelengths_file=grid_files.get(key))

    # 2. Bake time and bytes on the photograph-like input: every grid and the default, alternating.
    if photo is None:
        photo = work / "scene_photo.png"
        photographic_png(photo, a.size)
    exr = work / "scene.exr"
    for rep in range(a.repeat):
        for g in grids:
            jsonl = work / "scene.jsonl"
            jsonl.unlink(missing_ok=True)
            wall, mb, rec = bake(a, cfg_of(g), photo, exr, jsonl)
            exr.unlink(missing_ok=True)
            gr = res["grids"][g]
            gr["walls"].append(wall)
            if wall == min(gr["walls"]):
                gr.update(wall_s=wall, peak_mb=mb, bytes=rec["bytes"], bins=rec["bins"])
            log(f"  bake {gr['label']}{'' if gr['uniform'] else ' (' + span(gr['wavelengths']) + ')'}: {wall:.2f} s")
    d = res["grids"][DEFAULT_GRID]
    for gr in res["grids"].values():
        gr["ratio_default"] = gr["wall_s"] / d["wall_s"]
        gr["bytes_ratio_default"] = gr["bytes"] / d["bytes"]
        gr["bytes_per_pixel"] = gr["bins"] * 2
    # 3. The checker: plan's dense sample baked in half on each grid, against its 1 nm float bake.
    sample, ref = work / "scene_sample.png", work / "scene_ref.exr"
    dense_sample_png(sample)
    log(f"checker: reference bake of the dense sample on {REFERENCE_GRID}, float")
    bake(a, dict(DEFAULT, grid=REFERENCE_GRID, type="float"), sample, ref, work / "scene_ref.jsonl")
    integ = gc.Integrator(lights_all, (360, 830))
    ref_xyz, rf = integ.xyz_of_file(ref)
    ref.unlink(missing_ok=True)
    codes = gc.read_codes(sample)
    res["light_sources"] = dict(integ.sources)
    for g in grids:
        gr = res["grids"][g]
        cand = work / "scene_sample.exr"
        bake(a, cfg_of(g), sample, cand, work / "scene_sample.jsonl")
        cx, f = integ.xyz_of_file(cand, "linear")
        cand.unlink(missing_ok=True)
        if not gr["uniform"] and f.wavelengths.tolist() != gr["wavelengths"]:
            raise RuntimeError(f"the sample baked on {g} has the channels {f.wavelengths.tolist()}")
        chk = {l["light"]: l for l in gc.compare(integ, ref_xyz, cx, f.width, codes)}
        gr["checker"] = {l: dict(worst=chk[l]["worst"], p99=chk[l]["p99"], mean=chk[l]["mean"],
                                 worst_code=chk[l]["worst_code"]) for l in lights_all}
        if gr["uniform"]:
            p, _ = plan_json(a, "--colours", "sample", "--grids", g, "--lights", ",".join(lights_all), "--max-de", 100)
            gr["plan_sample"] = {l["light"]: dict(worst=l["worst"], p99=l["p99"], worst_code=l["worst_code"])
                                 for l in p["grids"][0]["lights"]}
        ps = gr["plan_sample"]
        log(f"  {gr['label']}: " + ", ".join(
            f"{l} {chk[l]['worst']:.4g}" + (f" (plan {ps[l]['worst']:.4g})" if l in ps else "") for l in lights_all))
    # 4. Rows.
    tol = gc.TOLERANCE
    rows = []

    def verdict(g, lights, cube=None):
        gr = res["grids"][g]
        bad, diffs = [], []
        for l in lights:
            if l not in gr["plan_sample"]:
                bad.append(f"{l}: no plan figure on the sample")
                continue
            d = gr["checker"][l]["worst"] - gr["plan_sample"][l]["worst"]
            diffs.append(abs(d))
            if abs(d) > tol:
                bad.append(f"{l} {d:+.3g} vs plan's sample")
            if cube and gr["checker"][l]["worst"] > cube[l] + tol:
                bad.append(f"{l} above plan's cube figure by {gr['checker'][l]['worst'] - cube[l]:.3g}")
        return (not bad), bad, (max(diffs) if diffs else None)

    def grid_fields(g, lights, plan_lights):
        gr = res["grids"][g]
        ok, bad, dmax = verdict(g, lights, plan_lights)
        return dict(bins=gr["bins"], bytes_per_pixel=gr["bytes_per_pixel"], bytes=gr["bytes"], wall_s=gr["wall_s"],
                    ratio_default=gr["ratio_default"], bytes_ratio_default=gr["bytes_ratio_default"],
                    agree=ok, disagreements="; ".join(bad), max_abs_diff=dmax,
                    **{f"plan_{l}": plan_lights[l] for l in lights},
                    **{f"plan_sample_{l}": gr["plan_sample"].get(l, {}).get("worst") for l in lights},
                    **{f"checker_{l}": gr["checker"][l]["worst"] for l in lights})

    for name, lights in SCENES:
        for r in [r for r in res["plans"] if r["scene"] == name]:
            row = dict(scene=name, lights=",".join(lights), budget=r["budget"], grid=r["chosen"], uniform=True,
                       plan_seconds=r["seconds"])
            if r["chosen"]:
                row.update(plan_worst=r["worst"], plan_colours=r["colours"],
                           **grid_fields(r["chosen"], lights, r["plan_lights"]))
            else:
                row.update(plan_worst=r["best"]["worst"] if r["best"] else None, plan_colours="none within budget")
            rows.append(row)
            nu = r["nonuniform"]
            row = dict(scene=name, lights=",".join(lights), budget=r["budget"], uniform=False,
                       plan_seconds=nu["seconds"], plan_search=nu["search"])
            if nu.get("grid"):
                row.update(grid=nu["label"], wavelengths=nu["wavelengths"], plan_sample_seconds=nu.get("sample_seconds"),
                           plan_worst=nu["worst"], plan_colours=nu["colours"],
                           **grid_fields(nu["grid"], lights, nu["plan_lights"]))
            else:
                row.update(grid=None, nonuniform_kept=nu["chosen"])
            rows.append(row)
        dl = list(dict.fromkeys(["D65"] + lights))
        gr = res["grids"][DEFAULT_GRID]
        rows.append(dict(scene=name, lights=",".join(lights), budget=None, grid=DEFAULT_GRID + " (default)", uniform=True,
                         plan_worst=max(gr["plan_sample"][l]["worst"] for l in dl), plan_colours="sample",
                         **grid_fields(DEFAULT_GRID, dl, {l: gr["plan_sample"][l]["worst"] for l in dl})))
    res["rows"] = rows
    return res


def scenes_markdown(res):
    def g3(v):
        return "–" if v is None else f"{v:.3g}"

    L = ["## Per scene\n",
         f"Which grid `spectex plan --lights L --max-de B` chooses for three scenes (default `--colours auto`: every "
         "candidate on plan's 274,625-colour sample, the chosen one on all 16,777,216 8-bit codes plus half "
         "rounding's largest shift; linear reconstruction over 360:830 at 1 nm), and what it costs: the "
         f"{res['size']}×{res['size']} photograph-like PNG baked on that grid and on the default {DEFAULT_GRID} "
         f"(half, zip, {res['threads']} threads), runs alternating over all the grids, best of {res['repeat']}; "
         "`× 81 bins` is the bake's wall time over the default bake's, `× 81 bytes` its file's size over the "
         "default file's; bytes/px counts the spectral channels. "
         "The second row of each budget is `plan --nonuniform` (the same, also searching non-uniform grids, "
         "offered when one needs fewer bins than every uniform candidate): its non-uniform choice, written by "
         "`--grid-file` and baked with `--wavelengths-file` (wavelengths under the table), or *uniform kept* "
         "when it offers none. "
         "**plan** is the worst ΔE00 per light: the chosen row's on the cube (what plan decides on) / "
         "plan's figure on the sample (the checker's colours: `plan --colours sample --grids G`; for a non-uniform "
         f"grid, its row in `plan --nonuniform --colours sample --grids {DEFAULT_GRID}`, the same search). "
         "**checker** is `grid_check.py`: "
         f"plan's dense sample baked in half on the grid, against the same texture baked on {REFERENCE_GRID} in "
         "float, linear reconstruction at 1 nm, colour-science's tables; worst ΔE00 per light over the sample. "
         f"**agree**: the checker within {res['tolerance']} of plan's sample figure on the same grid (same "
         "colours) under every light, and not above plan's cube figure by more than that; a row that does not "
         "is marked **no**. The default row gives the default grid's error under D65 and the scene's lights "
         "with the renderer's continuous integration (plan's figure there is the sample's).\n",
         "| scene (`--lights`) | budget | grid | bins | bytes/px | file bytes | × 81 bytes | bake s | × 81 bins | "
         "plan worst (cube / sample) | checker worst | agree (max \\|Δ\\|) |",
         "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    nonuniform = []
    for r in res["rows"]:
        lights = [k[len("checker_"):] for k in r if k.startswith("checker_")]
        budget = "–" if r["budget"] is None else f"{r['budget']:g}"
        if r.get("grid") is None:
            what = (f"*uniform kept* (`--nonuniform`: {r.get('nonuniform_kept') or 'none'})" if not r.get("uniform", True)
                    else f"none (best {g3(r['plan_worst'])})")
            L.append(f"| {r['scene']} ({r['lights']}) | {budget} | {what} | | | | | | | | | |")
            continue
        if r["budget"] is None:
            plan = ", ".join(f"{l} – / {g3(r['plan_sample_' + l])}" for l in lights)
        else:
            plan = ", ".join(f"{l} {g3(r['plan_' + l])} / {g3(r['plan_sample_' + l])}" for l in lights)
        chk = ", ".join(f"{l} {g3(r['checker_' + l])}" for l in lights)
        agree = (f"yes ({r['max_abs_diff']:.1g})" if r["agree"] else f"**no**: {r['disagreements']}")
        if r["budget"] is None:
            grid = r["grid"]
        elif r.get("uniform", True):
            grid = f"**{r['grid']}**"
        else:
            grid = f"**{r['grid']}** ({span(r['wavelengths'])})"
            nonuniform.append(r)
        L.append(f"| {r['scene']} ({r['lights']}) | {budget} | {grid} | {r['bins']} | {r['bytes_per_pixel']} | "
                 f"{r['bytes']:,} | {r['bytes_ratio_default']:.2f} | {r['wall_s']:.2f} | {r['ratio_default']:.2f} | "
                 f"{plan} | {chk} | {agree} |")
    if nonuniform:
        L.append("\nNon-uniform grids (nm):\n")
        for r in nonuniform:
            L.append(f"- {r['scene'].split()[0]} {r['budget']:g}, {r['grid']}: "
                     + ", ".join(f"{w:g}" for w in r["wavelengths"]))
    srcs = "; ".join(f"{l}: {s}" for l, s in res.get("light_sources", {}).items())
    L.append(f"\nPlan's own run time per scene and budget (uniform candidates; with `--nonuniform`; its "
             "`--colours sample` run for the non-uniform grid's sample figures): "
             + ", ".join(f"{p['scene'].split()[0]} {p['budget']:g}: {p['seconds']:.0f} s; "
                         f"{p['nonuniform']['seconds']:.0f} s"
                         + (f"; {p['nonuniform']['sample_seconds']:.0f} s" if "sample_seconds" in p["nonuniform"] else "")
                         for p in res["plans"])
             + f". Checker's lights: {srcs}.")
    L.append("\n`--nonuniform`'s search, as plan reports it: "
             + "; ".join(f"{p['scene'].split()[0]} {p['budget']:g}: {p['nonuniform']['search']}" for p in res["plans"])
             + ".")
    return "\n".join(L) + "\n"


def write_scenes(out, res, report=None):
    text = scenes_markdown(res)
    (out / "scenes.json").write_text(json.dumps(res, indent=1))
    (out / "scenes.md").write_text(text)
    keys = list(dict.fromkeys(k for r in res["rows"] for k in r))
    with open(out / "scenes.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        for r in res["rows"]:
            w.writerow({k: " ".join(f"{x:g}" for x in v) if isinstance(v, list) else v for k, v in r.items()})
    if report is not None and report.exists():
        with open(report, "a") as f:
            f.write("\n" + text)
    print(text)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--spectex", default=str(ROOT / "build/src/spectex"))
    ap.add_argument("--floor", default=str(ROOT / "build/tests/bench/bench_exr_floor"))
    ap.add_argument("--out", default="bench-report")
    ap.add_argument("--size", type=int, default=1024, help="side of the speed input PNG (default 1024)")
    ap.add_argument("--peer-size", type=int, default=None,
                    help="side of the peers' input (default 1024; with --quick, --size)")
    ap.add_argument("--threads", type=int, default=os.cpu_count(), help="threads for spectex and the floor")
    ap.add_argument("--repeat", type=int, default=None, help="timed runs per row, best kept (default 3; --quick 1)")
    ap.add_argument("--quick", action="store_true",
                    help="one timed run per row, no 4096² all-colours cube, peers at --size")
    ap.add_argument("--no-peers", action="store_true")
    ap.add_argument("--python", default=sys.executable, help="interpreter for the peers")
    ap.add_argument("--method-size", type=int, default=0,
                    help="also time a SIZE² bake of --method lattice against --method basis (e.g. 4096)")
    ap.add_argument("--only-methods", action="store_true",
                    help="only the --method-size comparison (no rows, no peers)")
    ap.add_argument("--no-scenes", action="store_true", help="skip the per-scene section")
    ap.add_argument("--precision-rows", action="store_true",
                    help="also the method × precision rows (precision.md, precision.json)")
    ap.add_argument("--precision-only", action="store_true", help="only the method × precision rows")
    ap.add_argument("--scenes-only", action="store_true",
                    help="only the per-scene section (scenes.md, scenes.csv, scenes.json)")
    a = ap.parse_args()
    a.repeat = a.repeat or (1 if a.quick else 3)
    a.peer_size = a.peer_size or (a.size if a.quick else 1024)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix="spectex-bench-"))
    t_start = time.time()
    try:
        if a.only_methods:
            if not a.method_size:
                ap.error("--only-methods needs --method-size")
            write_method_speed(out, method_speed(a, work))
        elif a.scenes_only:
            write_scenes(out, scenes(a, work))
        elif a.precision_only:
            write_precision_rows(out, precision_rows(a, work))
        else:
            run(a, out, work)
            if a.precision_rows:
                write_precision_rows(out, precision_rows(a, work))
    finally:
        shutil.rmtree(work, ignore_errors=True)
    done = ("methods.md, methods.json" if a.only_methods else "precision.md, precision.json" if a.precision_only else "scenes.md, scenes.csv, scenes.json" if a.scenes_only
            else "report.md, report.csv, report.svg" + ("" if a.no_scenes else ", scenes.md, scenes.csv, scenes.json"))
    log(f"done in {time.time() - t_start:.0f} s: {out}/ {done}")


def run(a, out, work):
    speed_png, cube_png = work / "photo.png", work / "cube.png"
    log(f"inputs: {a.size}² photograph-like PNG, 256² all-colours subsample")
    photographic_png(speed_png, a.size)
    cube_subsample_png(cube_png)
    full_cube = None
    if not a.quick:
        full_cube = work / "cube4096.png"
        log("input: 4096² all-colours PNG (default row)")
        cube_full_png(full_cube)

    rows = []
    for cfg in configurations():
        log(f"- {cfg['name']}")
        r = dict(cfg)
        exr, jsonl = work / "speed.exr", work / "bake.jsonl"
        best = None
        for _ in range(a.repeat):
            jsonl.unlink(missing_ok=True)
            wall, mb, rec = bake(a, cfg, speed_png, exr, jsonl)
            if best is None or wall < best[0]:
                best = (wall, mb, rec)
        wall, mb, rec = best
        r.update(wall_s=wall, peak_mb=mb, bytes=rec["bytes"], bins=rec["bins"], bake_internal_s=rec["seconds"],
                 mp_s=a.size * a.size / 1e6 / wall)
        for k, v in rec.get("stages", {}).items():
            r["stage_" + k] = v
        exr.unlink(missing_ok=True)
        fl = min((floor(a, cfg, a.size, work / "floor.exr", speed_png) for _ in range(a.repeat)), key=lambda f: f["wall_s"])
        r.update(floor_s=fl["wall_s"], floor_cpu_s=fl["cpu_s"], floor_bytes=fl["bytes"],
                 ratio_floor=wall / fl["wall_s"], ratio_floor_internal=rec["seconds"] / fl["wall_s"])
        # Round trip on the all-colours subsample.
        cexr = work / "cube.exr"
        bake(a, cfg, cube_png, cexr, work / "cube.jsonl")
        v = verify(a, cexr, cube_png)["source"]
        r.update(d65_max=v["ciede2000"]["max"], d65_mean=v["ciede2000"]["mean"],
                 code_match=100.0 * v["code_match"]["share"], cube="256² hashed subsample (65,536 colours)")
        cexr.unlink(missing_ok=True)
        if full_cube is not None and cfg["name"] == "default":
            fexr = work / "cube4096.exr"
            bake(a, cfg, full_cube, fexr, work / "cube4096.jsonl")
            v = verify(a, fexr, full_cube)["source"]
            r.update(full_d65_max=v["ciede2000"]["max"], full_d65_mean=v["ciede2000"]["mean"],
                     full_code_match=100.0 * v["code_match"]["share"],
                     full_code_matched=v["code_match"]["matched"])
            fexr.unlink(missing_ok=True)
        r.update(colorchecker_errors(a, cfg, work))
        rows.append(r)
        log(f"  {r['mp_s']:.2f} MP/s, {r['ratio_floor']:.2f}× floor, ΔE D65 max {r['d65_max']:.3g}, "
            f"CC A mean {r['cc_A_mean']:.2f}")

    kernel = expand_kernel(a)
    peers = [] if a.no_peers else run_peers(a, work)
    write_report(a, out, rows, peers, kernel)
    if not a.no_scenes:
        write_scenes(out, scenes(a, work, speed_png), out / "report.md")
    if a.method_size:
        write_method_speed(out, method_speed(a, work))


def precision_rows(a, work):
    """Each method at --precision full and auto (PRECISION_BUDGET): cost, D65, other light."""
    import shlex

    import default_decision as dd  # its timed bake and method_accuracy.py driver

    # A cache of this run's own: the first bake of each budgeted row chooses the bits, the rest
    # take them from there (as every bake after the first does on a user's machine).
    os.environ["SPECTEX_CACHE_DIR"] = str(work / "cache")
    photo, cube = work / "precision.png", work / "cube.png"
    photographic_png(photo, a.size)
    cube_subsample_png(cube)
    configs = {}
    for name, m in PRECISION_METHODS:
        configs[f"{name}|full"] = m + ["--precision", "full"]
        configs[f"{name}|auto"] = m + PRECISION_BUDGET
    rows = {}
    for key, o in configs.items():
        exr = work / "precision.exr"
        cold, _ = dd.timed_bake(a.spectex, photo, exr, o)
        walls = [dd.timed_bake(a.spectex, photo, exr, o)[0] for _ in range(a.repeat)]
        name, _, prec = key.partition("|")
        r = dict(method=name, precision=prec, options=shlex.join(o), first_s=cold, wall_s=min(walls),
                 walls=walls, bytes=exr.stat().st_size)
        exr.unlink(missing_ok=True)
        cexr = work / "precision-cube.exr"
        dd.run([a.spectex, "bake", cube, "-o", cexr, "-q", *o])
        v = verify(a, cexr, cube)["source"]
        r.update(d65_max=v["ciede2000"]["max"], d65_mean=v["ciede2000"]["mean"],
                 code_match=100.0 * v["code_match"]["share"])
        cexr.unlink(missing_ok=True)
        rows[key] = r
        log(f"  {name} {prec}: {r['wall_s']:.2f} s (first {cold:.2f} s), {r['bytes'] / 1e6:.2f} MB, "
            f"D65 max {r['d65_max']:.3g}")
    log("accuracy under other light (method_accuracy.py)")
    acc = dd.accuracy(a, configs, work)
    for key in configs:
        rows[key]["tuning"] = acc[key]["tuning"]
        rows[key]["ohta"] = acc[key]["ohta"]
    return dict(size=a.size, repeat=a.repeat, budget=shlex.join(PRECISION_BUDGET), rows=list(rows.values()))


def write_precision_rows(out, res):
    L = [f"## Methods × precision at {res['size']}²\n",
         f"`spectex bake` of one {res['size']}² photograph-like PNG, 81 bins (380:780:5), half, zip; "
         f"`auto` is `{res['budget']}`. Time: best of {res['repeat']} with the bits in the cache "
         "(first: the first bake, which chooses them). D65: ΔE00 max of the 256² all-colours subsample "
         "(`spectex verify`) and the share of codes that re-encode. Other light: method_accuracy.py, "
         "mean / worst ΔE00, TUNING sets pooled and Ohta's held-out ColorChecker, spectra as stored.\n",
         "| method | precision | MB | bake s | first s | D65 max | codes | "
         + " | ".join(f"{l} TUNING" for l in CC_LIGHTS) + " | " + " | ".join(f"{l} Ohta" for l in CC_LIGHTS) + " |",
         "|---|---|---|---|---|---|---|" + "---|" * (2 * len(CC_LIGHTS))]
    for r in res["rows"]:
        L.append(f"| {r['method']} | {r['precision']} | {r['bytes'] / 1e6:.2f} | {r['wall_s']:.2f} | "
                 f"{r['first_s']:.2f} | {r['d65_max']:.3g} | {r['code_match']:.2f} % | "
                 + " | ".join(f"{r['tuning'][l]['mean']:.2f} / {r['tuning'][l]['max']:.2f}" for l in CC_LIGHTS) + " | "
                 + " | ".join(f"{r['ohta'][l]['mean']:.2f} / {r['ohta'][l]['max']:.2f}" for l in CC_LIGHTS) + " |")
    text = "\n".join(L) + "\n"
    (out / "precision.json").write_text(json.dumps(res, indent=1))
    (out / "precision.md").write_text(text)
    print(text)


def method_speed(a, work):
    """--method lattice against --method basis on one SIZE² photograph-like PNG, 81 bins, half,
    alternating runs (so that load on the machine falls on both), best of --repeat each; with zip
    (the issue's target: lattice within 1.10× basis) and with no compression (the kernel's share)."""
    src = work / "method.png"
    log(f"method speed: {a.method_size}² photograph-like PNG")
    photographic_png(src, a.method_size)
    exr = work / "method.exr"
    res = dict(size=a.method_size, repeat=a.repeat, runs={})
    for comp in ["zip", "none"]:
        for _ in range(a.repeat):
            for m in ["basis", "lattice:9", "jakob-hanika"]:
                jsonl = work / "method.jsonl"
                jsonl.unlink(missing_ok=True)
                wall, mb, rec = bake(a, dict(DEFAULT, method=m, compression=comp), src, exr, jsonl)
                exr.unlink(missing_ok=True)
                log(f"  {m} {comp}: {wall:.2f} s, {rec['bytes']:,} bytes")
                r = res["runs"].setdefault(f"{m} {comp}", dict(method=m, compression=comp, walls=[]))
                r["walls"].append(wall)
                if wall == min(r["walls"]):
                    stages = rec.get("stages", {})
                    r.update(wall_s=wall, peak_mb=mb, bytes=rec["bytes"], expand_s=stages.get("expand_s"),
                             compress_cpu_s=stages.get("compress_cpu_s"))
    for key, r in res["runs"].items():
        base = res["runs"][f"basis {r['compression']}"]
        r["ratio_vs_basis"] = r["wall_s"] / base["wall_s"]
        r["bytes_vs_basis"] = r["bytes"] / base["bytes"]
    return res


def write_method_speed(out, res):
    L = [f"## Methods at {res['size']}²\n",
         f"`spectex bake` of one {res['size']}×{res['size']} photograph-like PNG, 81 bins (380:780:5), half, "
         f"each method's default settings, runs alternating between the methods, best of {res['repeat']} "
         "(every run listed). The issue's target: `--method lattice` with zip within 1.10× `--method basis`. "
         "`none` writes the same samples uncompressed: the difference there is the kernel's.\n",
         "| method | compression | wall s (best) | every run | × basis | output bytes | × basis bytes | peak MB | "
         "expand s | compress CPU s |",
         "|---|---|---|---|---|---|---|---|---|---|"]
    for r in res["runs"].values():
        L.append(f"| {r['method']} | {r['compression']} | {r['wall_s']:.2f} | "
                 f"{', '.join(f'{w:.2f}' for w in r['walls'])} | {r['ratio_vs_basis']:.2f} | {r['bytes']:,} | "
                 f"{r['bytes_vs_basis']:.2f} | {r['peak_mb']:.0f} | "
                 f"{(r['expand_s'] or float('nan')):.2f} | {(r['compress_cpu_s'] or float('nan')):.2f} |")
    text = "\n".join(L) + "\n"
    (out / "methods.json").write_text(json.dumps(res, indent=1))
    (out / "methods.md").write_text(text)
    print(text)


def expand_kernel(a):
    """Per-core rate of the expansion kernel (bench_expand next to the floor), if built."""
    exe = Path(a.floor).with_name("bench_expand")
    if not exe.exists():
        return None
    p = subprocess.run([str(exe), "--benchmark_filter=/81/", "--benchmark_min_time=0.2", "--benchmark_format=json"],
                       stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        return {b["label"]: b for b in json.loads(p.stdout)["benchmarks"]}
    except (ValueError, KeyError):
        return None


def run_peers(a, work):
    log(f"peers at {a.peer_size}²")
    src = work / "peer.png"
    photographic_png(src, a.peer_size, seed=11)
    mp = a.peer_size ** 2 / 1e6
    basis = SPECTRAL / "basis_fit_smooth_380-780-5.csv"  # the default basis, as a file
    res = []
    exr = work / "peer.exr"
    best = min((bake(a, dict(DEFAULT), src, exr, work / f"peer{i}.jsonl") for i in range(a.repeat)),
               key=lambda t: t[0])
    spx = dict(peer="spectex bake (default settings)", wall_s=best[0], peak_mb=best[1], bytes=best[2]["bytes"])
    exr.unlink(missing_ok=True)
    fl = floor(a, dict(DEFAULT), a.peer_size, work / "floor.exr", src)
    res.append(dict(peer="OpenEXR floor (bench_exr_floor)", wall_s=fl["wall_s"], peak_mb=fl["peak_rss_mb"],
                    bytes=fl["bytes"]))
    for kind, label in [("numpy", "NumPy + OpenImageIO script"),
                        ("colour", "colour-science write_spectral_image_Fichet2021")]:
        try:
            wall, mb, stdout = timed([a.python, HERE / "peers_numpy_oiio.py", kind, src, basis, exr])
            stages = json.loads(stdout.strip().splitlines()[-1])
            v = verify(a, exr, src)
            res.append(dict(peer=label, wall_s=wall, peak_mb=mb, bytes=exr.stat().st_size, stages=stages,
                            d65_max=v["source"]["ciede2000"]["max"]))
        except Exception as e:  # a peer failing is reported, not fatal
            res.append(dict(peer=label, error=str(e)[-300:]))
        exr.unlink(missing_ok=True)
    for p in [spx] + res:
        if "wall_s" in p:
            p["mp_s"] = mp / p["wall_s"]
            p["spectex_ratio"] = spx["wall_s"] / p["wall_s"]
    return [spx] + res


def write_report(a, out, rows, peers, kernel):
    with open(out / "report.csv", "w", newline="") as f:
        keys = [k for k, _ in COLUMNS] + ["bake_internal_s", "floor_cpu_s", "floor_bytes", "ratio_floor_internal",
                                          "cube", "full_d65_max", "full_d65_mean", "full_code_match",
                                          "full_code_matched", "size", "threads", "stage_writer", "stage_read_s",
                                          "stage_colour_s", "stage_expand_s", "stage_pack_s", "stage_encoder_wait_s",
                                          "stage_producer_wait_s", "stage_compress_cpu_s"]
        w = csv.DictWriter(f, fieldnames=keys, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow(dict(r, size=a.size, threads=a.threads))
    svg_plot(rows, out / "report.svg")

    L = [f"# spectex: speed against error\n",
         f"Machine: {os.cpu_count()} cores, `--threads {a.threads}` for spectex and the floor; speed input "
         f"{a.size}×{a.size} 8-bit photograph-like PNG (generated); {'one timed run' if a.repeat == 1 else f'best of {a.repeat} runs'} "
         f"per row{' (--quick)' if a.quick else ''}. Generated by `tests/bench/speed_vs_error.py` on "
         f"{time.strftime('%Y-%m-%d %H:%M')}.\n",
         "One axis varies per row from the default (380:780:5, half, zip, smooth fitted basis). "
         "Round-trip ΔE00 under D65 is on a 256×256 subsample of the 8-bit sRGB cube (65,536 distinct colours "
         "spread by a multiplicative hash, black and white included)"
         + (", and for the default row also on all 16,777,216 colours (below)." if not a.quick else
            "; the full 4096×4096 cube is skipped with --quick.") + "\n",
         "ColorChecker columns (CC, mean and max ΔE00 over the 24 patches): the measured spectra of "
         "`config/spectral/colorchecker_ohta.csv` (Ohta; held out: nothing is tuned on it) give each patch's 8-bit "
         "sRGB code under D65 (white-consistent matrix, clipped); spectex bakes those codes with the row's settings; "
         "the file's spectra, read back (interpolated to 380:780:5 and held beyond its ends for other grids), are "
         "compared with the measured ones under A, FL2, FL11, D50 and LED-B3, CIE 1931 2°, after a Bradford "
         "transform of the light's white to D65's (`method_accuracy.Evaluator`). `CC avg mean` averages the five "
         "means. D65 and codes-kept columns: `spectex verify --source` on the all-colours subsample.\n",
         "| " + " | ".join(h for _, h in COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    for r in rows:
        L.append("| " + " | ".join(fmt(k, r.get(k)) for k, _ in COLUMNS) + " |")
    d = next(r for r in rows if r["name"] == "default")
    if "full_d65_max" in d:
        L.append(f"\nDefault row on all 16,777,216 sRGB colours (4096² PNG): ΔE00 max {d['full_d65_max']:.3g}, "
                 f"mean {d['full_d65_mean']:.3g}, {d['full_code_matched']:,} colours re-encode to their codes "
                 f"({d['full_code_match']:.5f} %).")
    L.append("\n## Stages\n")
    L.append("The floor (`bench_exr_floor --whole`: spectex's own writer, same compression, ZIP level, strip size "
             "and threads, fed the same input expanded before the clock starts) is the write stage alone; "
             "`floor share` = floor / bake (internal time, without process start-up). The other columns are the "
             "bake's own stages (`--json`): read, colour and expand run on the producer thread while the encoder "
             "runs; `wait enc` is the writer thread waiting for a free chunk (the encoder is the bottleneck), "
             "`wait prod` waiting for the producer (it is); `compress` is CPU seconds over the workers.\n")
    L.append("| configuration | writer | bake s (internal) | floor s | floor share | read | colour | expand | pack | "
             "wait enc | wait prod | compress CPU s |")
    L.append("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        st = lambda k: f"{r.get('stage_' + k, float('nan')):.2f}"
        L.append(f"| {r['name']} | {r.get('stage_writer', '?')} | {r['bake_internal_s']:.3f} | {r['floor_s']:.3f} | "
                 f"{100 * r['floor_s'] / max(r['bake_internal_s'], 1e-9):.0f} % | {st('read_s')} | {st('colour_s')} | "
                 f"{st('expand_s')} | {st('pack_s')} | {st('encoder_wait_s')} | {st('producer_wait_s')} | "
                 f"{st('compress_cpu_s')} |")
    if kernel:
        L.append("")
        for lab, b in kernel.items():
            rate = b.get("items_per_second", 0)
            vs = (f"{b['speedup_vs_naive']:.1f}× a naive scalar loop" if "speedup_vs_naive" in b else
                  f"{b['colour_cost_vs_plain']:.2f}× the time of plain rounding" if "colour_cost_vs_plain" in b else "")
            L.append(f"Expansion kernel alone (bench_expand, 81 bins, {lab}, one core): {rate / 1e6:.1f} Mpixel/s "
                     f"({vs}), i.e. {a.size ** 2 / max(rate, 1):.3f} s of one core for the {a.size}² input.")
    if peers:
        L.append(f"\n## Peers\n")
        L.append(f"Same run, same {a.peer_size}×{a.peer_size} input (another generated photograph-like PNG), 81 bins "
                 "380:780:5, half, ZIP, the default smooth basis. Python peers are timed as whole processes "
                 "(interpreter start-up and imports included, as a user runs them) with `/usr/bin/time`; "
                 "`spectex ÷ peer` is spectex's wall time over the peer's (below 1: spectex is faster).\n")
        L.append("| peer | wall s | MP/s | peak MB | output bytes | spectex ÷ peer | in-process stages |")
        L.append("|---|---|---|---|---|---|---|")
        for p in peers:
            if "error" in p:
                L.append(f"| {p['peer']} | failed: {p['error'].splitlines()[-1] if p['error'] else ''} | | | | | |")
                continue
            st = p.get("stages")
            sts = ", ".join(f"{k[:-2]} {v:.2f}" for k, v in st.items() if k.endswith("_s")) if st else ""
            L.append(f"| {p['peer']} | {p['wall_s']:.2f} | {p['mp_s']:.2f} | {p['peak_mb']:.0f} | {p['bytes']:,} | "
                     f"{p['spectex_ratio']:.2f} | {sts} |")
    L.append("\n![speed against error](report.svg)\n")
    (out / "report.md").write_text("\n".join(L) + "\n")
    print("\n".join(L))


if __name__ == "__main__":
    main()
