#!/usr/bin/env python3
"""The default bake against `--method basis` on three kinds of texture, and memory against bins.

    build/venv/bin/python tests/bench/three_textures.py --spectex build/src/spectex [--repeat 3]

A file's size depends on what it holds: natural spectra compress differently from the basis'
three-spectrum mixtures, and by how much depends on the texture. So every size and time claim the
documentation makes is measured here on three kinds of texture, each 8-bit sRGB:

  * photograph-like, 4096² (--photo-size): speed_vs_error.photographic_png (smooth colour fields,
    edged shapes, shading and grain);
  * noise, 2048² (--size): uniform 8-bit noise, every channel of every pixel independent (the worst
    case for any compressor);
  * the bundled examples/textures/colour_chart.png (512×256) as it is;
  * flat colours, 2048×1024: the same chart scaled up 4× with nearest neighbour (large patches of
    one colour each).

For each, the default bake (no options) and `--method basis` (the default before) alternate,
--repeat pairs, the first of each pair swapped every time; reported are the bytes of each and their
ratio, the per-pair time ratio (median over pairs; the machine may be shared, so a ratio of two
bakes run back to back says more than either time), the median times, and each bake's peak RSS
(the largest over repeats), and whether the default is within 0.6× the basis' bytes on each and
0.6× its time on the photograph-like texture (the targets of the default's grid). Then the default
(31 bins, 400:700:10) against `--wavelengths 380:780:5` (81 bins, the default before) on the
photograph-like texture, alternating likewise: peak RSS, bytes and the time ratio.

Wall time and peak RSS are the bake process's own, measured by a minimal spawner (a fresh `python3
-S` that posix_spawns the bake and reads os.wait4's rusage), as default_decision.py does: a child
forked from this process would count the pages it shares with it in its peak RSS. SPECTEX_CACHE_DIR
is a temporary directory; the default's bits ship with spectex, and the 81-bin bits are chosen once
on a 16² texture before any bake is timed (a warm cache, as after a user's first bake). A
benchmark, not a test: nothing is asserted. About 10-15 minutes on 2 cores. --candidate "OPTIONS"
measures a candidate default the same way: OPTIONS are added to every bake of the default, with
the default's deflate level by size unless they name one.
"""
import argparse
import os
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import default_decision as dd  # noqa: E402
import speed_vs_error as sve  # noqa: E402

CHART = HERE.parent.parent / "examples/textures/colour_chart.png"


def log(*a):
    print(*a, file=sys.stderr, flush=True)


def read_png(path):
    import OpenImageIO as oiio

    inp = oiio.ImageInput.open(str(path))
    px = inp.read_image(0, 0, 0, 3, oiio.UINT8)
    inp.close()
    return px


def make_textures(work, size, photo_size=None):
    tex = {}
    photo_size = photo_size or size
    p = work / "photograph-like.png"
    sve.photographic_png(p, photo_size)
    tex[f"photograph-like, {photo_size}²"] = p
    p = work / "noise.png"
    sve.write_png(p, np.random.default_rng(11).integers(0, 256, (size, size, 3), dtype=np.uint8))
    tex[f"noise (uniform 8-bit), {size}²"] = p
    tex["the bundled chart, 512×256"] = CHART
    chart = read_png(CHART)
    k = max(1, size // chart.shape[1])
    p = work / "flat.png"
    flat = np.repeat(np.repeat(chart, k, axis=0), k, axis=1)
    sve.write_png(p, flat)
    tex[f"flat colours (colour chart ×{k}, nearest), {flat.shape[1]}×{flat.shape[0]}"] = p
    return tex


def candidate_opts(candidate, src):
    """The candidate's options for this texture: a bake with any method option is not the default
    bake and deflates at level 4, so unless it names a level it gets the default's by size (1, or
    6 for at most 512 x 512 pixels: DefaultBake in src/pipeline/bake_request.h)."""
    opts = candidate.split()
    if opts and "--zip-level" not in opts:
        import OpenImageIO as oiio

        inp = oiio.ImageInput.open(str(src))
        spec = inp.spec()
        inp.close()
        opts += ["--zip-level", "6" if spec.width * spec.height <= 512 * 512 else "1"]
    return opts


def pairs(spectex, src, work, a_opts, b_opts, repeat):
    """Alternating bakes of a and b; per-bake (wall, rss) lists and the bytes of each."""
    res = {"a": [], "b": []}
    size = {}
    for r in range(repeat):
        order = [("a", a_opts), ("b", b_opts)]
        if r % 2:
            order.reverse()
        for key, opts in order:
            out = work / f"{key}.exr"
            wall, rss = dd.timed_bake(spectex, src, out, opts)
            res[key].append((wall, rss))
            size[key] = out.stat().st_size
            out.unlink()
            log(f"    {key} {' '.join(opts) or '(default)'}: {wall:.2f} s, {size[key] / 1e6:.2f} MB, {rss:.0f} MiB")
    ratio = statistics.median(a[0] / b[0] for a, b in zip(res["a"], res["b"]))
    return dict(
        bytes_a=size["a"], bytes_b=size["b"], bytes_ratio=size["a"] / size["b"],
        time_a=statistics.median(w for w, _ in res["a"]), time_b=statistics.median(w for w, _ in res["b"]),
        time_ratio=ratio, time_ratios=[a[0] / b[0] for a, b in zip(res["a"], res["b"])],
        rss_a=max(m for _, m in res["a"]), rss_b=max(m for _, m in res["b"]))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--spectex", default=str(HERE.parent.parent / "build/src/spectex"))
    ap.add_argument("--size", type=int, default=2048, help="side of the noise PNG (default 2048)")
    ap.add_argument("--photo-size", type=int, default=4096, help="side of the photograph-like PNG (default 4096)")
    ap.add_argument("--repeat", type=int, default=3, help="alternating pairs per texture (default 3)")
    ap.add_argument("--bins-repeat", type=int, default=2, help="alternating pairs of 31 and 81 bins (default 2)")
    ap.add_argument("--candidate", default="",
                    help="options added to the default's bakes: a candidate default measured the same way "
                         "(e.g. '--vertex-prior measured --precision auto --wavelengths 400:700:10')")
    a = ap.parse_args()
    t0 = time.time()
    work = Path(tempfile.mkdtemp(prefix="spectex-three-"))
    os.environ["SPECTEX_CACHE_DIR"] = str(work / "cache")
    try:
        log("making the textures")
        tex = make_textures(work, a.size, a.photo_size)
        tiny = work / "tiny.png"
        sve.photographic_png(tiny, 16)
        if a.candidate:  # its bits chosen once before any bake is timed, as the default's ship
            log(f"  warming the cache: the candidate's bits ({a.candidate})")
            dd.run([a.spectex, "bake", tiny, "-o", work / "tiny.exr", "-q", *a.candidate.split()])
        rows = {}
        for name, src in tex.items():
            log(f"  {name}: default against --method basis")
            rows[name] = pairs(a.spectex, src, work, candidate_opts(a.candidate, src), ["--method", "basis"],
                               a.repeat)

        photo = next(iter(tex.values()))
        fine = ["--wavelengths", "380:780:5"]
        log("  warming the cache: the default's bits at 81 bins")
        dd.run([a.spectex, "bake", tiny, "-o", work / "tiny.exr", "-q", *fine])
        log("  photograph-like: the default (31 bins) against 81 bins")
        bins = pairs(a.spectex, photo, work, candidate_opts(a.candidate, photo), fine, a.bins_repeat)
    finally:
        shutil.rmtree(work, ignore_errors=True)

    out = [f"`{a.spectex}`; nproc {os.cpu_count()} (os.sched_getaffinity: {len(os.sched_getaffinity(0))}); "
           f"load average at the end {os.getloadavg()[0]:.2f}. The machine was shared with other builds and "
           f"tests while this ran: read the ratios (each the median of {a.repeat} alternating pairs), not the "
           f"seconds." + (f" The default's bakes with `{a.candidate}`." if a.candidate else "") + "\n",
           "| texture | bytes: default / basis (×) | time: default / basis (× per-pair median) | "
           "peak RSS: default / basis | within 0.6× |",
           "|---|---|---|---|---|"]
    for name, r in rows.items():
        out.append(f"| {name} | {r['bytes_a'] / 1e6:.2f} MB / {r['bytes_b'] / 1e6:.2f} MB "
                   f"(**{r['bytes_ratio']:.2f}×**) | {r['time_a']:.2f} s / {r['time_b']:.2f} s "
                   f"(**{r['time_ratio']:.2f}×**; pairs {', '.join(f'{x:.2f}' for x in r['time_ratios'])}) | "
                   f"{r['rss_a']:.0f} MiB / {r['rss_b']:.0f} MiB | bytes "
                   f"{'yes' if r['bytes_ratio'] <= 0.6 else 'no'}"
                   + (f", time {'yes' if r['time_ratio'] <= 0.6 else 'no'}" if name.startswith("photograph") else "")
                   + " |")
    b = bins
    out += ["", f"The default on the photograph-like texture, 31 bins (400:700:10) against 81 bins (380:780:5, "
                f"the default before), {a.bins_repeat} alternating pairs:\n",
            "| bins | bytes | time (median) | peak RSS |", "|---|---|---|---|",
            f"| 31 | {b['bytes_a'] / 1e6:.2f} MB | {b['time_a']:.2f} s | {b['rss_a']:.0f} MiB |",
            f"| 81 | {b['bytes_b'] / 1e6:.2f} MB | {b['time_b']:.2f} s | {b['rss_b']:.0f} MiB |",
            f"\n81 / 31 bins: bytes {b['bytes_b'] / b['bytes_a']:.2f}×, time {statistics.median(1 / x for x in b['time_ratios']):.2f}× "
            f"(per-pair median), peak RSS {b['rss_b'] / b['rss_a']:.2f}×.",
            f"\nRuntime {time.time() - t0:.0f} s."]
    print("\n".join(out))


if __name__ == "__main__":
    main()
