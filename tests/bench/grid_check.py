#!/usr/bin/env python3
"""An independent check of `spectex plan`'s grid error, from two baked files.

    build/venv/bin/python tests/bench/grid_check.py --candidate C.exr --reference R.exr \\
        --lights D65,A --reconstruction linear --range 360:830 [--source IN.png] [--json out.json]

C.exr is a bake of a texture on any grid (half or float); R.exr is a bake of the same texture on
the renderer's range at 1 nm in float (`spectex bake IN.png -o R.exr --wavelengths 360:830:1
--type float`). For every pixel this script

1. reads the `T.<λ>nm` channels of both files with OpenImageIO (`,` is the decimal separator;
   OpenEXR sorts channel names, so the bins are sorted by their parsed wavelength), in chunks of
   rows so that memory stays bounded by the chunk, not the image;
2. reconstructs the candidate at every whole nm of --range by the renderer's rule:
   `linear` (interpolation between bin centres), `nearest` (the value of the nearest bin centre,
   a tie goes to the shorter-wavelength bin) or `box` (bins are boxes with edges halfway between
   centres, the outer edges infinite, and each 1 nm sample is the mean of the box function over
   [λ - 0.5, λ + 0.5]); every rule holds the end values beyond the first and last bin;
3. integrates both spectra at 1 nm (each sample weighs 1) under each light with CIE 1931 2°,
   XYZ scaled so that the perfect reflector has Y = 1, with colour-science's own tables
   (`colour.MSDS_CMFS['CIE 1931 2 Degree Standard Observer']`, `colour.SDS_ILLUMINANTS[name]`),
   the light interpolated linearly inside its table and zero outside it;
4. converts both to L*a*b* relative to the light's own white (XYZ of the perfect reflector under
   it) with `colour.XYZ_to_Lab` and takes `colour.delta_E(..., method='CIE 2000')`.

It prints, per light, the worst ΔE00, the exact 99th percentile (`numpy.percentile`, linear
interpolation between order statistics), the mean and the worst pixel (x, y; with --source, its
8-bit code). It shares no code with spectex: nothing here reads src/ or calls the binary.

colour-science 0.4.7 has every light spectex ships (D50, D55, D65, D75, A, FL1-FL12, LED-B1-B5,
LED-BH1, LED-RGB1, LED-V1, LED-V2). Its D50, D55, D65 and D75 tables stop at 780 nm, while the
shipped CSVs extend them to 830 nm by the CIE daylight formula (config/spectral/README.md), so
with the default `--lights-from colour` a D light is dark from 781 nm on here and not in spectex:
this is the one difference of table data between the two (the CMFs and every other table are the
same numbers). `--lights-from csv` takes the shipped CSVs instead, for comparison. A name colour
lacks (or a CSV path) falls back to config/spectral/illuminant_<name>.csv, and the report says so.

As a module (import by path, see tests/python/test_plan_checker.py):

    check(candidate, reference, lights, reconstruction, range_) -> dict       (the CLI's JSON)
    Integrator(lights, range_): .xyz_of_file(path, rule) -> {light: n×3}; .compare(ref, cand)
"""
import argparse
import json
import math
import re
import sys
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
SPECTRAL = ROOT / "config" / "spectral"

# Agreement between this checker and `spectex plan --colours sample` on the same colours (the worst
# ΔE00 under each light), used by tests/python/test_plan_checker.py and speed_vs_error.py's
# per-scene section. Why it is not zero and how it was measured: tests/bench/README.md.
TOLERANCE = 0.002

CHANNEL = re.compile(r"T\.(\d+(?:,\d+)?)nm")
RULES = ("linear", "nearest", "box")
OBSERVER = "CIE 1931 2 Degree Standard Observer"
CHUNK_PIXELS = 1 << 15  # pixels per piece: 32,768 × 471 bins × 8 bytes = 123 MB at most
# Scanlines per compressed chunk of an OpenEXR file, by compression.
LINES_PER_CHUNK = {"none": 1, "rle": 1, "zips": 1, "zip": 16, "pxr24": 16, "piz": 32, "b44": 32, "b44a": 32,
                   "dwaa": 32, "dwab": 256}


def _colour():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        import colour
    return colour


# ---------------------------------------------------------------- the renderer's reconstruction

def reconstruction_matrix(bins, fine, rule):
    """len(fine) × len(bins): the candidate at fine[f] is Σ_k R[f, k]·s_k under `rule`."""
    bins = np.asarray(bins, float)
    fine = np.asarray(fine, float)
    n = len(bins)
    if n == 0:
        raise ValueError("no bins")
    if np.any(np.diff(bins) <= 0):
        raise ValueError("bins are not strictly increasing")
    if rule == "linear":
        # np.interp interpolates between the centres and holds the end values beyond them.
        return np.stack([np.interp(fine, bins, np.eye(n)[k]) for k in range(n)], axis=1)
    if rule == "nearest":
        # argmin keeps the first of equal distances: the shorter-wavelength bin.
        k = np.argmin(np.abs(fine[:, None] - bins[None, :]), axis=1)
        return np.eye(n)[k]
    if rule == "box":
        mid = 0.5 * (bins[1:] + bins[:-1])
        lo_edge = np.concatenate([[-np.inf], mid])
        hi_edge = np.concatenate([mid, [np.inf]])
        lo, hi = fine[:, None] - 0.5, fine[:, None] + 0.5
        # Length of [λ-0.5, λ+0.5] ∩ [edge_k, edge_k+1): the box function's mean over the nanometre.
        return np.clip(np.minimum(hi, hi_edge[None, :]) - np.maximum(lo, lo_edge[None, :]), 0.0, None)
    raise ValueError(f"reconstruction '{rule}' is not one of {', '.join(RULES)}")


def reconstruct(bins, spectra, fine, rule):
    """The spectra (… × bins) reconstructed at the wavelengths `fine` (… × len(fine))."""
    return np.asarray(spectra, float) @ reconstruction_matrix(bins, fine, rule).T


# ---------------------------------------------------------------- lights

def _read_csv_light(path):
    rows = [l.split(",") for l in Path(path).read_text().splitlines()
            if l.strip() and not l.startswith("#") and not l.startswith("wavelength")]
    a = np.array([[float(v) for v in r[:2]] for r in rows])
    return a[:, 0], a[:, 1]


def light_table(name, source="colour"):
    """(wavelengths, values, where-from) of a light: colour-science's table by name, else (or with
    source='csv') the shipped CSV config/spectral/illuminant_<name>.csv, else a CSV path."""
    colour = _colour()
    if source == "colour" and name in colour.SDS_ILLUMINANTS:
        sd = colour.SDS_ILLUMINANTS[name]
        return np.asarray(sd.wavelengths, float), np.asarray(sd.values, float), f"colour.SDS_ILLUMINANTS['{name}']"
    csv = SPECTRAL / f"illuminant_{name}.csv"
    if csv.exists():
        why = "" if source == "csv" else f" (colour-science {colour.__version__} has no '{name}')"
        wl, v = _read_csv_light(csv)
        return wl, v, f"{csv.relative_to(ROOT)}{why}"
    if Path(name).exists():
        wl, v = _read_csv_light(name)
        return wl, v, f"{name} (a CSV file)"
    raise ValueError(f"no light '{name}' in colour-science or config/spectral")


class Integrator:
    """XYZ weights at every whole nm of range_ for each light: W (fine × 3) with Σ W[:, Y] = 1
    (the perfect reflector has Y = 1), white = W summed over the wavelengths."""

    def __init__(self, lights, range_=(360, 830), light_source="colour"):
        colour = _colour()
        lo, hi = range_
        if lo != int(lo) or hi != int(hi) or not hi > lo:
            raise ValueError(f"range {lo}:{hi} is not two whole nm, START < END")
        self.range = (int(lo), int(hi))
        self.fine = np.arange(self.range[0], self.range[1] + 1, dtype=float)
        cmfs = colour.MSDS_CMFS[OBSERVER]
        cw = np.asarray(cmfs.wavelengths, float)
        if self.fine[0] < cw[0] or self.fine[-1] > cw[-1]:
            raise ValueError(f"{OBSERVER} covers {cw[0]:g} to {cw[-1]:g} nm, not {lo}:{hi}")
        # The CMFs are tabulated at 1 nm: pick the rows (no interpolation).
        idx = np.searchsorted(cw, self.fine)
        if not np.allclose(cw[idx], self.fine):
            raise ValueError("the observer is not tabulated at every whole nm")
        cmf = np.asarray(cmfs.values, float)[idx]
        self.lights, self.W, self.white, self.white_xy, self.sources, self.dark_nm = [], {}, {}, {}, {}, {}
        for name in lights:
            wl, v, where = light_table(name, light_source)
            inside = (self.fine >= wl[0]) & (self.fine <= wl[-1])
            e = np.where(inside, np.interp(self.fine, wl, v), 0.0)
            w = e[:, None] * cmf
            w /= w[:, 1].sum()
            self.lights.append(name)
            self.W[name] = w
            self.white[name] = w.sum(axis=0)
            self.white_xy[name] = colour.XYZ_to_xy(self.white[name])
            self.sources[name] = where
            self.dark_nm[name] = int((~inside).sum())

    def weights_for(self, bins, rule):
        """bins × 3L: XYZ of every light at once = spectra @ this (the reconstruction at every whole
        nm of the range, then each light's W; columns 3j..3j+2 are light j's X, Y, Z)."""
        R = reconstruction_matrix(bins, self.fine, rule)
        return R.T @ np.hstack([self.W[n] for n in self.lights])

    def split(self, xyz_all):
        """{light: n×3} from n×3L."""
        return {n: xyz_all[:, 3 * j:3 * j + 3] for j, n in enumerate(self.lights)}

    def xyz_of_file(self, path, rule="linear", chunk_pixels=CHUNK_PIXELS):
        """({light: n×3 XYZ}, SpectralFile) of every pixel of a spectral EXR (row-major),
        reconstructed by `rule`; the spectra are read in chunks of rows. For a reference (a bin at
        every whole nm of the range) every rule picks those bins' values unchanged."""
        f = SpectralFile(path)
        M = self.weights_for(f.wavelengths, rule)
        out = np.empty((f.pixels, M.shape[1]))
        for p0, S in f.chunks(chunk_pixels):
            out[p0:p0 + len(S)] = S @ M
        return self.split(out), f

    def delta_e(self, light, ref_xyz, cand_xyz):
        colour = _colour()
        xy = self.white_xy[light]
        return np.asarray(colour.delta_E(colour.XYZ_to_Lab(ref_xyz, xy), colour.XYZ_to_Lab(cand_xyz, xy),
                                         method="CIE 2000"), float)


# ---------------------------------------------------------------- files

class SpectralFile:
    def __init__(self, path):
        import OpenImageIO as oiio

        self.path = str(path)
        inp = oiio.ImageInput.open(self.path)
        if inp is None:
            raise OSError(f"cannot open {path}: {oiio.geterror()}")
        spec = inp.spec()
        inp.close()
        found = []
        for i, name in enumerate(spec.channelnames):
            m = CHANNEL.fullmatch(name)
            if m:
                found.append((float(m.group(1).replace(",", ".")), i))
        if not found:
            raise ValueError(f"{path}: no T.<λ>nm channels")
        found.sort()
        self.wavelengths = np.array([w for w, _ in found])
        self.channels = np.array([i for _, i in found])
        self.ch0, self.ch1 = int(self.channels.min()), int(self.channels.max()) + 1
        self.width, self.height, self.x0, self.y0 = spec.width, spec.height, spec.x, spec.y
        self.tile_h = spec.tile_height
        self.pixels = spec.width * spec.height
        self.format = str(spec.format)
        comp = spec.get_string_attribute("compression").split(":")[0].lower()
        self.lines_per_chunk = LINES_PER_CHUNK.get(comp, 16)

    @property
    def block(self):
        """Rows of one compressed chunk (or tile row) of the file."""
        return self.tile_h or self.lines_per_chunk

    def chunks(self, chunk_pixels=CHUNK_PIXELS, block=None):
        """(first pixel index, pixels × bins float64 sorted by wavelength) for pieces of at most
        chunk_pixels pixels. The file is read a few rows at a time, whole compressed chunks of the
        file at once (16 lines for zip: reading fewer decompresses each chunk again and again)."""
        import OpenImageIO as oiio

        block = block or self.block
        rows = max(1, chunk_pixels // self.width)
        rows = max(block, (rows + block - 1) // block * block)
        inp = oiio.ImageInput.open(self.path)
        try:
            sel = self.channels - self.ch0
            for y in range(0, self.height, rows):
                yend = min(self.height, y + rows)
                if self.tile_h:
                    a = inp.read_tiles(0, 0, self.x0, self.x0 + self.width, self.y0 + y, self.y0 + yend, 0, 1,
                                       self.ch0, self.ch1, oiio.FLOAT)
                else:
                    a = inp.read_scanlines(0, 0, self.y0 + y, self.y0 + yend, 0, self.ch0, self.ch1, oiio.FLOAT)
                if a is None:
                    raise OSError(f"{self.path}: cannot read rows {y}-{yend}: {inp.geterror()}")
                a = np.asarray(a).reshape(-1, self.ch1 - self.ch0)
                for i in range(0, len(a), chunk_pixels):
                    yield y * self.width + i, a[i:i + chunk_pixels][:, sel].astype(np.float64)
                del a
        finally:
            inp.close()


def read_codes(source):
    """8-bit codes (n × 3) of a source image, row-major."""
    import OpenImageIO as oiio

    buf = oiio.ImageBuf(str(source))
    px = buf.get_pixels(oiio.UINT8)
    return np.asarray(px)[..., :3].reshape(-1, 3)


# ---------------------------------------------------------------- the check

def stats(de, width, codes=None):
    i = int(np.argmax(de))
    s = dict(worst=float(de[i]), p99=float(np.percentile(de, 99)), mean=float(de.mean()),
             worst_pixel=[i % width, i // width])
    if codes is not None:
        s["worst_code"] = [int(c) for c in codes[i]]
    return s


def compare(integ, ref_xyz, cand_xyz, width, codes=None):
    """Per light: worst, p99, mean, worst pixel of ΔE00 between two {light: n×3} XYZ lists."""
    out = []
    for n in integ.lights:
        de = integ.delta_e(n, ref_xyz[n], cand_xyz[n])
        out.append(dict(light=n, source=integ.sources[n], dark_nm=integ.dark_nm[n], **stats(de, width, codes)))
    return out


def check(candidate, reference, lights, reconstruction="linear", range_=(360, 830), source=None,
          light_source="colour", chunk_pixels=CHUNK_PIXELS, integ=None, reference_xyz=None):
    """The checker's result (the CLI's JSON) for a candidate against a 1 nm reference; both files
    are read chunk by chunk in lock-step (memory: one chunk of each plus n floats per light).
    `integ` and `reference_xyz` (from Integrator.xyz_of_file on the reference) let callers that
    check many candidates read the reference once."""
    integ = integ or Integrator(lights, range_, light_source)
    cand = SpectralFile(candidate)
    ref = SpectralFile(reference) if reference_xyz is None else None
    if ref is not None:
        if (ref.width, ref.height) != (cand.width, cand.height):
            raise ValueError(f"{reference} is {ref.width}×{ref.height}, {candidate} {cand.width}×{cand.height}")
        pos = np.searchsorted(ref.wavelengths, integ.fine)
        pos = np.minimum(pos, len(ref.wavelengths) - 1)
        if not np.all(np.abs(ref.wavelengths[pos] - integ.fine) < 1e-6):
            missing = integ.fine[np.abs(ref.wavelengths[pos] - integ.fine) >= 1e-6]
            raise ValueError(f"{reference} has no bin at {missing[0]:g} nm: the reference must hold every whole nm "
                             f"of {integ.range[0]}:{integ.range[1]} (bake it with --wavelengths "
                             f"{integ.range[0]}:{integ.range[1]}:1 --type float)")
    Mc = integ.weights_for(cand.wavelengths, reconstruction)
    if ref is not None:
        Mr = np.zeros((len(ref.wavelengths), Mc.shape[1]))
        Mr[pos] = np.hstack([integ.W[n] for n in integ.lights])  # the reference's 1 nm samples, as they are
    de = {n: np.empty(cand.pixels) for n in integ.lights}
    block = math.lcm(cand.block, ref.block) if ref is not None else cand.block
    ref_chunks = ref.chunks(chunk_pixels, block) if ref is not None else None
    for p0, S in cand.chunks(chunk_pixels, block):
        if ref_chunks is not None:
            q0, Sr = next(ref_chunks)
            assert q0 == p0 and len(Sr) == len(S), "the two files are read in the same pieces"
            rx = integ.split(Sr @ Mr)
        else:
            rx = {n: reference_xyz[n][p0:p0 + len(S)] for n in integ.lights}
        cx = integ.split(S @ Mc)
        for n in integ.lights:
            de[n][p0:p0 + len(S)] = integ.delta_e(n, rx[n], cx[n])
    codes = read_codes(source) if source else None
    if codes is not None and len(codes) != cand.pixels:
        raise ValueError(f"{source} has {len(codes)} pixels, {candidate} {cand.pixels}")
    grid = cand.wavelengths
    steps = np.diff(grid)
    return dict(
        candidate=str(candidate), reference=str(reference), reconstruction=reconstruction,
        range=list(integ.range), pixels=cand.pixels, width=cand.width, height=cand.height,
        candidate_grid=dict(start=float(grid[0]), end=float(grid[-1]),
                            step=float(steps[0]) if len(steps) and np.allclose(steps, steps[0]) else None,
                            bins=int(len(grid)), type=cand.format),
        observer=f"colour.MSDS_CMFS['{OBSERVER}']",
        lights=[dict(light=n, source=integ.sources[n], dark_nm=integ.dark_nm[n],
                     **stats(de[n], cand.width, codes)) for n in integ.lights])


def table(res):
    g = res["candidate_grid"]
    step = f"{g['step']:g}" if g["step"] else "non-uniform"
    L = [f"candidate {res['candidate']}: {g['bins']} bins {g['start']:g}:{g['end']:g}:{step} ({g['type']}), "
         f"{res['reconstruction']} reconstruction at 1 nm over {res['range'][0]}:{res['range'][1]}, "
         f"{res['pixels']:,} pixels, against {res['reference']}",
         f"{'light':<9} {'worst':>9} {'p99':>9} {'mean':>9}  worst pixel (x, y){'  code' if 'worst_code' in res['lights'][0] else ''}"]
    for l in res["lights"]:
        code = f"  {tuple(l['worst_code'])}" if "worst_code" in l else ""
        L.append(f"{l['light']:<9} {l['worst']:>9.4g} {l['p99']:>9.4g} {l['mean']:>9.4g}  "
                 f"({l['worst_pixel'][0]}, {l['worst_pixel'][1]}){code}")
    L.append("lights: " + "; ".join(f"{l['light']} from {l['source']}"
                                    + (f", dark on {l['dark_nm']} nm of the range" if l["dark_nm"] else "")
                                    for l in res["lights"]))
    return "\n".join(L)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--candidate", required=True, help="EXR baked on the grid to check (half or float)")
    ap.add_argument("--reference", required=True, help="EXR of the same texture baked on the range at 1 nm, float")
    ap.add_argument("--lights", default="D65", help="comma-separated light names (default D65)")
    ap.add_argument("--reconstruction", default="linear", choices=RULES)
    ap.add_argument("--range", default="360:830", help="whole nm START:END the renderer samples (default 360:830)")
    ap.add_argument("--source", help="the baked texture (8-bit): report the worst pixel's code")
    ap.add_argument("--lights-from", default="colour", choices=("colour", "csv"),
                    help="colour-science's tables (default) or the shipped config/spectral CSVs")
    ap.add_argument("--chunk-pixels", type=int, default=CHUNK_PIXELS, help="pixels read per chunk")
    ap.add_argument("--json", help="write the result as JSON ('-' = stdout, instead of the table)")
    a = ap.parse_args(argv)
    lo, _, hi = a.range.partition(":")
    res = check(a.candidate, a.reference, [l for l in a.lights.split(",") if l], a.reconstruction,
                (float(lo), float(hi)), a.source, a.lights_from, a.chunk_pixels)
    if a.json != "-":
        print(table(res))
    if a.json:
        text = json.dumps(res, indent=1) + "\n"
        if a.json == "-":
            sys.stdout.write(text)
        else:
            Path(a.json).write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
